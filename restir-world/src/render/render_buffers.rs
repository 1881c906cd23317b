//! The renderer's buffers: per-pixel images and vertices, the scene's materials, triangle
//! attributes and textures.

use crate::gpu::{Resource, buffers};
use crate::scene::Material;

use super::records::{GVertex, RenderParams, RenderState, TextureGpu, TriangleAttributes};

/// Bytes of one pixel's path split (WGSL `RenderPathSplit`, four vec4).
pub(crate) const PATH_SPLIT_BYTES: u64 = 64;

/// The render buffers (per pixel unless noted).
#[derive(Debug)]
pub(crate) struct RenderBuffers {
    pub params: wgpu::Buffer,
    pub state: wgpu::Buffer,
    pub gbuffer: wgpu::Buffer,
    pub secondary: wgpu::Buffer,
    pub direct_frame: wgpu::Buffer,
    pub indirect_frame: wgpu::Buffer,
    /// The radiance leaving each pixel's secondary vertex towards its primary along the
    /// pixel's path (with `secondary`, the pixel's path sample: WGSL `PathLight`).
    pub path_radiance: wgpu::Buffer,
    /// Four vec4 per pixel when `RenderParams::path_split` is 1 (WGSL `RenderPathSplit`), one
    /// dummy record when it is 0.
    pub path_split: wgpu::Buffer,
    pub accum_direct: wgpu::Buffer,
    pub accum_indirect: wgpu::Buffer,
    /// Per material.
    pub materials: wgpu::Buffer,
    /// Per scene triangle (one dummy entry when `RenderParams::attributes` is 0).
    pub attributes: wgpu::Buffer,
    /// Per texture ref, and all texels.
    pub textures: wgpu::Buffer,
    pub texels: wgpu::Buffer,
    /// The BRDF's energy-compensation tables ([`crate::brdf::BrdfTables`]) for a scene with
    /// glossy materials; one dummy value for a diffuse scene, whose kernels never read them.
    pub brdf_tables: wgpu::Buffer,
}

impl RenderBuffers {
    pub(super) fn new(
        device: &wgpu::Device,
        params: &RenderParams,
        materials: &[Material],
        attributes: &[TriangleAttributes],
        textures: &(Vec<TextureGpu>, Vec<u32>),
        brdf_tables: &[f32],
    ) -> Self {
        let px = u64::from(params.pixel_count);
        let vertices = px * size_of::<GVertex>() as u64;
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(device, label, size);
        Self {
            params: buffers::with_usage(
                device,
                "render_params",
                std::slice::from_ref(params),
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            state: zeroed("render_state", size_of::<RenderState>() as u64),
            gbuffer: zeroed("render_gbuffer", vertices),
            secondary: zeroed("render_secondary", vertices),
            direct_frame: zeroed("render_direct_frame", px * 16),
            indirect_frame: zeroed("render_indirect_frame", px * 16),
            path_radiance: zeroed("render_path_radiance", px * 16),
            path_split: zeroed(
                "render_path_split",
                PATH_SPLIT_BYTES * if params.path_split != 0 { px } else { 1 },
            ),
            accum_direct: zeroed("render_accum_direct", px * 16),
            accum_indirect: zeroed("render_accum_indirect", px * 16),
            materials: buffers::storage_from(device, "render_materials", materials),
            attributes: buffers::storage_from(device, "render_attributes", attributes),
            textures: buffers::storage_from(device, "render_textures", &textures.0),
            texels: buffers::storage_from(device, "render_texels", &textures.1),
            brdf_tables: buffers::storage_from(device, "render_brdf_tables", brdf_tables),
        }
    }

    /// Bytes of the per-pixel buffers (vertices, this frame's light, the accumulation).
    pub(super) fn pixel_bytes(&self) -> u64 {
        [
            &self.gbuffer,
            &self.secondary,
            &self.direct_frame,
            &self.indirect_frame,
            &self.path_radiance,
            &self.path_split,
            &self.accum_direct,
            &self.accum_indirect,
        ]
        .map(wgpu::Buffer::size)
        .iter()
        .sum()
    }

    /// The buffers of [`bindings`], by name.
    pub(super) fn resources(&self) -> [(&'static str, Resource<'_>); 15] {
        [
            ("render_params", (&self.params).into()),
            ("render_state", (&self.state).into()),
            ("render_gbuffer", (&self.gbuffer).into()),
            ("render_secondary", (&self.secondary).into()),
            ("render_direct_frame", (&self.direct_frame).into()),
            ("render_indirect_frame", (&self.indirect_frame).into()),
            ("render_path_radiance", (&self.path_radiance).into()),
            ("render_path_split", (&self.path_split).into()),
            ("render_accum_direct", (&self.accum_direct).into()),
            ("render_accum_indirect", (&self.accum_indirect).into()),
            ("render_materials", (&self.materials).into()),
            ("render_attributes", (&self.attributes).into()),
            ("render_textures", (&self.textures).into()),
            ("render_texels", (&self.texels).into()),
            ("render_brdf_tables", (&self.brdf_tables).into()),
        ]
    }
}
