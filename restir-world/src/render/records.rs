//! The Rust twins of the render library's WGSL structs, and the tables the renderer uploads.

use crate::sampling::{CameraGpu, Estimator};
use crate::scene::{Camera, MaterialModel, Scene, tangents};

use super::RenderOptions;
use super::library::{METHOD_NEE, METHOD_RIS};

/// WGSL `StoredReservoir` (16 bytes): a reservoir as world-restir and restir-di store it, its
/// light sample as the light and the packed coordinates on it, and reservoir's packed (W, M).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct StoredReservoir {
    /// The sample's `lights::KIND_*` in the low 2 bits, its light table index above.
    pub light_kind: u32,
    /// Barycentrics of a triangle point (two unorm16), or an environment direction's
    /// octahedral coordinates (two snorm16); 0 for punctual lights.
    pub coords: u32,
    pub ucw: f32,
    pub m: u32,
}

/// WGSL `PackedVertex`: a `GVertex` as the G-buffer and the histories store it, 64 bytes without
/// padding (a 1920x1080 frame's vertices fit one 128 MiB storage binding).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GVertex {
    pub position: [f32; 3],
    pub prim: u32,
    pub normal: [f32; 3],
    pub albedo: [f32; 3],
    pub emission: [f32; 3],
    /// The unit shading normal (interpolated vertex normals, on the side of `normal`) as its
    /// octahedral coordinates, or `[SHADING_FLAT, 0]` where it is `normal` (a triangle
    /// without vertex normals).
    pub shading: [f32; 2],
    /// The rest of the surface's BRDF: [`pack_material`]'s word (0: diffuse).
    pub material: u32,
}

const _: () = assert!(size_of::<GVertex>() == 64);

impl GVertex {
    /// The unit shading normal (twin of WGSL `render_unpack_vertex`'s).
    pub fn shading_normal(&self) -> glam::Vec3 {
        if self.shading[0] == SHADING_FLAT {
            return glam::Vec3::from(self.normal);
        }
        oct_decode(glam::Vec2::from(self.shading))
    }

    /// The vertex's BRDF (twin of WGSL `render_vertex_brdf`): its base colour and material
    /// word unpacked.
    pub fn brdf(&self) -> crate::brdf::BrdfSurface {
        let m = self.material;
        crate::brdf::BrdfSurface {
            base: glam::Vec3::from(self.albedo).as_dvec3(),
            metallic: f64::from(((m >> 16) & 255) as f32 / 255.0),
            roughness: f64::from((m & 65535) as f32 / 65535.0),
            diffuse: (m >> 24) == 0,
        }
    }
}

/// [`GVertex::shading`]'s first coordinate where the shading normal is the geometric normal
/// (WGSL `RENDER_SHADING_FLAT`).
pub const SHADING_FLAT: f32 = 2.0;

/// A vertex's material word (twin of WGSL `render_pack_material`): perceptual roughness as
/// unorm16 (bits 0-15), metallic as unorm8 (16-23), the [`MaterialModel`] above; 0 for a
/// diffuse surface.
pub fn pack_material(model: MaterialModel, metallic: f32, roughness: f32) -> u32 {
    if model == MaterialModel::Diffuse {
        return 0;
    }
    let r = (roughness.clamp(0.0, 1.0) * 65535.0).round() as u32;
    let m = (metallic.clamp(0.0, 1.0) * 255.0).round() as u32;
    r | (m << 16) | ((model as u32) << 24)
}

/// [`TriangleAttributes::flags`]: the vertex normals are set.
pub const ATTR_NORMALS: u32 = 1;
/// [`TriangleAttributes::flags`]: the texture coordinates are set.
pub const ATTR_UV: u32 = 2;
/// [`TriangleAttributes::flags`]: the tangents are set (the triangle's material has a normal
/// map, and its tangents are usable: `scene::tangents::usable`).
pub const ATTR_TANGENTS: u32 = 4;
/// [`TriangleAttributes::flags`]: corner c's tangent has handedness -1 where bit
/// `ATTR_TANGENT_FLIP << c` is set.
pub const ATTR_TANGENT_FLIP: u32 = 8;

/// WGSL `TriangleAttributes`: per scene triangle (indexed by `Scene::triangles` order), its
/// vertex normals, texture coordinates and (normal-mapped triangles) tangents, each present
/// when its flag is set. The tangents take the words that were padding, so that a scene
/// without normal maps uploads the same bytes as before them: each corner's unit tangent as
/// its octahedral coordinates in two snorm16 ([`pack_tangent`]), its handedness in `flags`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TriangleAttributes {
    pub n0: [f32; 3],
    pub flags: u32,
    pub n1: [f32; 3],
    /// The triangle's material's emissive texture (1 + texture ref, 0: none), for light
    /// samples, which know their triangle but not its material.
    pub emissive_texture: u32,
    pub n2: [f32; 3],
    /// Corner 0's tangent ([`pack_tangent`]).
    pub tangent0: u32,
    pub uv0: [f32; 2],
    pub uv1: [f32; 2],
    pub uv2: [f32; 2],
    /// Corners 1 and 2's tangents.
    pub tangent12: [u32; 2],
}

const _: () = assert!(size_of::<TriangleAttributes>() == 80);

/// Octahedral coordinates in [-1, 1]^2 of the unit vector d (twin of WGSL
/// `sampling_oct_encode`).
pub fn oct_encode(d: glam::Vec3) -> glam::Vec2 {
    let p = glam::Vec2::new(d.x, d.y) / (d.x.abs() + d.y.abs() + d.z.abs());
    if d.z >= 0.0 {
        return p;
    }
    let s = glam::Vec2::new(
        if p.x >= 0.0 { 1.0 } else { -1.0 },
        if p.y >= 0.0 { 1.0 } else { -1.0 },
    );
    (glam::Vec2::ONE - glam::Vec2::new(p.y.abs(), p.x.abs())) * s
}

/// The unit direction of octahedral coordinates `e` (twin of WGSL `sampling_oct_decode`).
pub fn oct_decode(e: glam::Vec2) -> glam::Vec3 {
    let mut d = glam::Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    if d.z < 0.0 {
        let s = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
        let (x, y) = (d.x, d.y);
        d.x = (1.0 - y.abs()) * s(x);
        d.y = (1.0 - x.abs()) * s(y);
    }
    d.normalize()
}

/// A unit tangent as the GPU keeps it: its octahedral coordinates ([`oct_encode`]) as two
/// snorm16 (WGSL `pack2x16snorm`'s layout, read by `unpack2x16snorm`): directions to about
/// 5e-5 radians.
pub fn pack_tangent(t: glam::Vec3) -> u32 {
    let e = oct_encode(t.normalize());
    let q = |x: f32| u32::from((x.clamp(-1.0, 1.0) * 32767.0).round() as i16 as u16);
    q(e.x) | (q(e.y) << 16)
}

/// The per-triangle attributes of `scene`, or `None` when no triangle has vertex normals or
/// texture coordinates (the renderer then binds one dummy entry and shades flat). A triangle
/// gets its tangents where its material has a normal texture and they are usable; one without
/// vertex normals then gets its geometric normal at each corner (the normal its tangents were
/// made for).
pub fn triangle_attributes(scene: &Scene) -> Option<Vec<TriangleAttributes>> {
    if scene
        .triangles
        .iter()
        .all(|t| t.n.is_none() && t.uv.is_none())
    {
        return None;
    }
    Some(
        scene
            .triangles
            .iter()
            .map(|t| {
                let mut a: TriangleAttributes = bytemuck::Zeroable::zeroed();
                let material = scene.materials.get(t.material as usize);
                let tangents = match (t.t, material) {
                    (Some(tan), Some(m)) if m.normal_texture != 0 && tangents::usable(t) => {
                        Some(tan)
                    }
                    _ => None,
                };
                let normals = match (t.n, tangents) {
                    (Some(n), _) => Some(n),
                    (None, Some(_)) => Some([t.cross().normalize(); 3]),
                    (None, None) => None,
                };
                if let Some(n) = normals {
                    a.flags |= ATTR_NORMALS;
                    (a.n0, a.n1, a.n2) = (n[0].to_array(), n[1].to_array(), n[2].to_array());
                }
                if let Some(tan) = tangents {
                    a.flags |= ATTR_TANGENTS;
                    for (c, t) in tan.iter().enumerate() {
                        if t.w < 0.0 {
                            a.flags |= ATTR_TANGENT_FLIP << c;
                        }
                    }
                    let packed = tan.map(|t| pack_tangent(t.truncate()));
                    (a.tangent0, a.tangent12) = (packed[0], [packed[1], packed[2]]);
                }
                a.emissive_texture = material.map_or(0, |m| m.emissive_texture);
                if let Some(uv) = t.uv {
                    a.flags |= ATTR_UV;
                    (a.uv0, a.uv1, a.uv2) = (uv[0].to_array(), uv[1].to_array(), uv[2].to_array());
                }
                a
            })
            .collect(),
    )
}

/// WGSL `TextureGpu`: one texture ref (a material's use of a texture): its affine map of the
/// texture coordinates, its texels' offset in `render_texels`, size, wrap modes and encoding
/// (s | t << 8, [`crate::scene::Wrap`] values, | [`TEXTURE_LINEAR`] for linear data).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TextureGpu {
    pub row0: [f32; 4],
    pub row1: [f32; 4],
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub wrap: u32,
}

/// `TextureGpu::wrap`'s flag of a texture ref whose texels are linear data (value / 255), not
/// sRGB-encoded colour ([`crate::scene::TextureRef::linear`]).
pub const TEXTURE_LINEAR: u32 = 1 << 16;

/// The scene's texture refs and all texels (RGBA8, one u32 each, textures one after the
/// other); one dummy each when the scene has none.
pub fn texture_tables(scene: &Scene) -> (Vec<TextureGpu>, Vec<u32>) {
    let mut texels = Vec::new();
    let mut offsets = Vec::new();
    for t in &scene.textures {
        offsets.push(texels.len() as u32);
        texels.extend(t.texels.iter().map(|p| u32::from_le_bytes(*p)));
    }
    let refs: Vec<TextureGpu> = scene
        .texture_refs
        .iter()
        .map(|r| {
            let t = &scene.textures[r.texture as usize];
            TextureGpu {
                row0: [r.row0[0], r.row0[1], r.row0[2], 0.0],
                row1: [r.row1[0], r.row1[1], r.row1[2], 0.0],
                offset: offsets[r.texture as usize],
                width: t.width,
                height: t.height,
                wrap: r.wrap[0] as u32
                    | (r.wrap[1] as u32) << 8
                    | if r.linear { TEXTURE_LINEAR } else { 0 },
            }
        })
        .collect();
    match (refs.is_empty(), texels.is_empty()) {
        (false, false) => (refs, texels),
        _ => (vec![bytemuck::Zeroable::zeroed()], vec![0]),
    }
}

/// WGSL `RenderParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RenderParams {
    pub camera: CameraGpu,
    pub pixel_count: u32,
    pub seed: u32,
    pub method: u32,
    pub candidates: u32,
    /// Smallest scale ray offsets are relative to: [`ray_offset_floor`] of the scene.
    pub ray_offset_floor: f32,
    /// 1 when `render_attributes` holds the scene's [`TriangleAttributes`], 0 when it is a
    /// dummy (flat shading, no texture coordinates).
    pub attributes: u32,
    /// [`crate::sampling::Paths::bounces`] and [`crate::sampling::Paths::roulette_from`].
    pub bounces: u32,
    pub roulette_from: u32,
    /// [`crate::sampling::Paths::mis`] as 0 or 1.
    pub mis: u32,
    /// [`Planted::id`](crate::plant::Planted::id) of the build's defect (0 but in tests' negative controls).
    pub planted: u32,
    /// [`Planted::scales`](crate::plant::Planted::scales) of the build: the scales of the accumulated direct and indirect
    /// frames (1 but in tests' power checks).
    pub planted_direct_scale: f32,
    pub planted_indirect_scale: f32,
    /// 1: the path pass records the path split (`render_path_split`, [`RenderOptions::path_split`]).
    pub path_split: u32,
    /// [`Planted::amount`](crate::plant::Planted::amount): a tunable defect's size (1 but in
    /// tests' negative controls).
    pub planted_amount: f32,
    /// The smallest packed roughness (unorm16, as [`pack_material`] packs it) of a glossy
    /// secondary vertex whose record the passes keep ([`RenderOptions::glossy_x2`]); `u32::MAX`:
    /// none.
    pub glossy_x2: u32,
    pub _pad2: u32,
}

impl RenderParams {
    /// The parameters of a render of `camera` with `estimator` and `options`, for a scene
    /// without triangle attributes and with the default ray-offset floor.
    pub(super) fn new(camera: &Camera, estimator: Estimator, options: &RenderOptions) -> Self {
        let (method, candidates) = match estimator {
            Estimator::Nee => (METHOD_NEE, 1),
            Estimator::Ris { candidates } => (METHOD_RIS, candidates),
        };
        Self {
            camera: CameraGpu::new(camera),
            pixel_count: camera.width * camera.height,
            seed: options.seed,
            method,
            candidates,
            ray_offset_floor: 1.0,
            attributes: 0,
            bounces: options.paths.bounces,
            roulette_from: options.paths.roulette_from,
            mis: u32::from(options.paths.mis),
            planted: options.planted().id(),
            planted_direct_scale: options.planted().scales().0,
            planted_indirect_scale: options.planted().scales().1,
            path_split: u32::from(options.path_split),
            planted_amount: options.planted().amount(),
            glossy_x2: match options.glossy_x2 {
                Some(r) if options.path_split => u32::from(r),
                _ => u32::MAX,
            },
            _pad2: 0,
        }
    }
}

/// The floor of the ray-offset scale for `scene`: its extent (largest side of its bounding
/// box), capped at 1. Offsets are `RAY_EPS` times the larger of this and the point's largest
/// coordinate, so scenes of extent 1 and more keep absolute 1e-4 offsets near the origin while a
/// scene in small units (a box of 1e-5) keeps the same relative ones instead of offsetting rays
/// past its walls.
pub fn ray_offset_floor(scene: &Scene) -> f32 {
    let extent = scene
        .bounds()
        .map_or(1.0, |(lo, hi)| (hi - lo).max_element());
    if extent.is_finite() && extent > 0.0 {
        extent.min(1.0)
    } else {
        1.0
    }
}

/// WGSL `RenderState`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RenderState {
    pub frame: u32,
    pub _pad: [u32; 3],
}
