//! The GPU renderer: the `nee` and `ris` baselines as small compute passes, progressively
//! accumulated, and the shared passes world-space ReSTIR builds on.
//!
//! Per frame (one sample per pixel), each step a [`Pass`] in its own timestamp span:
//!
//! 1. `primary`: camera rays with a uniform sub-pixel jitter (box filter) -> G-buffer
//!    (`render_gbuffer`, one [`GVertex`] per pixel).
//! 2. `gi`: one cosine-weighted ray from each primary hit -> secondary vertex
//!    (`render_secondary`).
//! 3. *(ReSTIR passes: read the G-buffer and secondary vertices, write `render_indirect_frame`
//!    instead of step 5.)*
//! 4. `shade_direct`: emission seen at the primary + NEE there -> `render_direct_frame`
//!    (`restir_di::RestirDi` writes it instead in the `restir-di` methods).
//! 5. `shade_indirect`: primary albedo x NEE at the secondary vertex -> `render_indirect_frame`.
//!    `path` (with [`Paths::bounces`] > 1): the path goes on from the secondary vertex
//!    by cosine sampling, with NEE at every vertex, Russian roulette from
//!    [`Paths::roulette_from`]; it adds bounces 2.. to `render_indirect_frame`, after
//!    whichever pass wrote bounce 1 (world-restir's shade included).
//! 6. `accumulate`: running sums of both frames; advances the GPU frame counter that seeds
//!    every pass.
//!
//! NEE is one light sample (power-proportional alias table over emissive triangles, the
//! environment and punctual lights: see [`crate::lights`]) with one shadow ray (to the light
//! point, or to infinity for the environment and directional lights); [`Estimator::Ris`] draws
//! K candidates, resamples one by RIS (target: luminance of the unshadowed contribution) and
//! traces one shadow ray. Outputs: `direct` = emission seen (the environment where a camera ray
//! escapes) + reflected direct light, `indirect` = indirect light of bounces 1..N ([`Paths`]; a GI ray that
//! escapes adds nothing: the environment it sees is direct light at the primary vertex,
//! estimated by NEE there), linear HDR. Emitters are two-sided. Shading uses the interpolated
//! vertex normals where a triangle has them ([`TriangleAttributes`], `GVertex::shading`): the
//! BRDF's cosine and the GI ray's cosine distribution; the geometric normal keeps the ray
//! offsets and the sidedness of lights (a light behind the geometric surface contributes
//! nothing; a GI direction below it ends the path). Scenes without vertex normals (the
//! built-in ones) take the flat path unchanged.
//!
//! A later pass composes [`library`] + its own kernel module and binds [`SharedGroups`]
//! (render buffers at group 0, the tracer's at 1, lights at 2) before its own groups. Rays are
//! traced by the context's [`Tracer`]: the software CWBVH or the adapter's ray queries, behind
//! the same WGSL functions.

use crate::gpu::{
    Access, BindGroupLayout, BindingSet, FrameEncoder, GpuContext, GpuError, Kernel, KernelCache,
    Pass, Resource, Tracer, WgslModule, buffers, compose, workgroup_size_wgsl,
};
pub use crate::images::{FrameImages, Readback};
use crate::lights::{self, GpuLights, Lights};
pub use crate::plant::Planted;
use crate::sampling::{CameraGpu, Estimator};
use crate::scene::{Camera, LUMINANCE, Material, Scene};
use crate::trace::{self, Bvh};

/// The renderer's library (structs + functions).
pub const WGSL: &str = include_str!("render.wgsl");
/// The pass kernels.
pub const PASSES_WGSL: &str = include_str!("passes.wgsl");
/// The indirect path beyond the secondary vertex (`render_path_pixel`), shared with the
/// radiance cache's path pass; needs a module named [`PATH_CACHE`].
pub const PATH_WGSL: &str = include_str!("path.wgsl");
/// The name of the module that defines `path_cache_radiance` for [`PATH_WGSL`].
pub const PATH_CACHE: &str = "path-cache";

/// Default RIS candidate count (the paper's 16).
pub const DEFAULT_CANDIDATES: u32 = 16;

/// Most RIS candidates a method accepts: GPU drivers cap shader loop iterations (llvmpipe at
/// 65,535), so more would silently give the image of this many.
pub const MAX_CANDIDATES: u32 = crate::sampling::MAX_LOOP_ITERATIONS;

/// Checks a RIS candidate count: 1 ..= [`MAX_CANDIDATES`].
pub fn check_candidates(candidates: u32) -> Result<(), String> {
    if (1..=MAX_CANDIDATES).contains(&candidates) {
        Ok(())
    } else {
        Err(format!(
            "candidates {candidates} must be in 1..={MAX_CANDIDATES} (GPU drivers cap shader \
             loop iterations)"
        ))
    }
}
pub use crate::sampling::{
    DEFAULT_BOUNCES, DEFAULT_MIS, DEFAULT_ROULETTE_FROM, MAX_BOUNCES, Paths,
};

/// How a render runs, whatever the method: the seed of its random streams, the depth of its
/// indirect paths, and (tests' negative controls only) a defect compiled into its kernels.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderOptions {
    pub seed: u32,
    pub paths: Paths,
    /// [`Planted::None`] but in tests' negative controls (see [`crate::plant`]).
    pub planted: Planted,
}

impl RenderOptions {
    /// `seed` and the default paths.
    pub fn seeded(seed: u32) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }
}

/// Relative ray-origin offset off surfaces (times max(1, |coordinate|)).
pub const RAY_EPS: f32 = 1e-4;
/// tmax of unbounded rays.
pub const T_MAX: f32 = 1e30;

/// The random streams of the passes, allocated in this one place: each id is mixed into the
/// seed of every invocation of the pass that draws from it (WGSL `render_rng`), so passes draw
/// independent numbers. The WGSL constants `STREAM_*` are generated from [`Stream::ALL`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum Stream {
    /// Camera-ray jitter.
    Primary = 0,
    /// GI-ray directions.
    Gi = 1,
    /// NEE at the primary vertex.
    Direct = 2,
    /// NEE at the secondary vertex.
    Indirect = 3,
    WrGenerate = 4,
    WrBuild = 5,
    WrTemporal = 6,
    WrSpatial = 7,
    /// Filling the light tiles.
    LightTiles = 8,
    /// A pixel block's pick of a light tile.
    LightTilePick = 9,
    DiInitial = 10,
    DiTemporal = 11,
    DiSpatial = 12,
    /// The path beyond the secondary vertex (salted by the bounce).
    Path = 13,
    GiTemporal = 14,
    GiSpatial = 15,
}

impl Stream {
    /// Every stream with the suffix of its WGSL constant.
    pub const ALL: [(Stream, &'static str); 16] = [
        (Stream::Primary, "PRIMARY"),
        (Stream::Gi, "GI"),
        (Stream::Direct, "DIRECT"),
        (Stream::Indirect, "INDIRECT"),
        (Stream::WrGenerate, "WR_GENERATE"),
        (Stream::WrBuild, "WR_BUILD"),
        (Stream::WrTemporal, "WR_TEMPORAL"),
        (Stream::WrSpatial, "WR_SPATIAL"),
        (Stream::LightTiles, "LIGHT_TILES"),
        (Stream::LightTilePick, "LIGHT_TILE_PICK"),
        (Stream::DiInitial, "DI_INITIAL"),
        (Stream::DiTemporal, "DI_TEMPORAL"),
        (Stream::DiSpatial, "DI_SPATIAL"),
        (Stream::Path, "PATH"),
        (Stream::GiTemporal, "GI_TEMPORAL"),
        (Stream::GiSpatial, "GI_SPATIAL"),
    ];
}

/// Stream ids per seed: the seed of a render is `seed * STREAM_COUNT + stream`, so changing it
/// changes every image.
pub const STREAM_COUNT: u32 = 16;

const METHOD_NEE: u32 = 0;
const METHOD_RIS: u32 = 1;

/// [`Estimator::Ris`] with the default candidate count.
pub fn ris() -> Estimator {
    Estimator::Ris {
        candidates: DEFAULT_CANDIDATES,
    }
}

/// Errors of the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Trace(#[from] trace::TraceError),
    #[error(transparent)]
    Lights(#[from] lights::LightsError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad render setting: {0}")]
    Settings(String),
}

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

/// WGSL `GVertex`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GVertex {
    pub position: [f32; 3],
    pub prim: u32,
    pub normal: [f32; 3],
    pub _pad0: u32,
    pub albedo: [f32; 3],
    pub _pad1: u32,
    pub emission: [f32; 3],
    pub _pad2: u32,
    /// Unit shading normal (interpolated vertex normals, on the side of `normal`; equal to
    /// `normal` for a triangle without them).
    pub shading: [f32; 3],
    pub _pad3: u32,
}

/// [`TriangleAttributes::flags`]: the vertex normals are set.
pub const ATTR_NORMALS: u32 = 1;
/// [`TriangleAttributes::flags`]: the texture coordinates are set.
pub const ATTR_UV: u32 = 2;

/// WGSL `TriangleAttributes`: per scene triangle (indexed by `Scene::triangles` order), its
/// vertex normals and texture coordinates, each present when its flag is set.
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
    pub _pad1: u32,
    pub uv0: [f32; 2],
    pub uv1: [f32; 2],
    pub uv2: [f32; 2],
    pub _pad2: [u32; 2],
}

/// The per-triangle attributes of `scene`, or `None` when no triangle has vertex normals or
/// texture coordinates (the renderer then binds one dummy entry and shades flat).
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
                if let Some(n) = t.n {
                    a.flags |= ATTR_NORMALS;
                    (a.n0, a.n1, a.n2) = (n[0].to_array(), n[1].to_array(), n[2].to_array());
                }
                a.emissive_texture = scene
                    .materials
                    .get(t.material as usize)
                    .map_or(0, |m| m.emissive_texture);
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
/// texture coordinates, its texels' offset in `render_texels`, size, and wrap modes
/// (s | t << 8, [`crate::scene::Wrap`] values).
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

/// The scene's texture refs and all texels (RGBA8 sRGB, one u32 each, textures one after the
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
                wrap: r.wrap[0] as u32 | (r.wrap[1] as u32) << 8,
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
    /// [`Paths::bounces`] and [`Paths::roulette_from`].
    pub bounces: u32,
    pub roulette_from: u32,
    /// [`Paths::mis`] as 0 or 1.
    pub mis: u32,
    /// 1 when the indirect passes write the radiance leaving the secondary vertex towards the
    /// primary (ReSTIR GI's sample, [`Renderer::set_secondary_radiance`]), 0 when they write
    /// the primary's reflected light (that radiance times the primary's albedo).
    pub secondary_radiance: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

impl RenderParams {
    /// The parameters of a render of `camera` with `estimator` and `options`, for a scene
    /// without triangle attributes and with the default ray-offset floor.
    fn new(camera: &Camera, estimator: Estimator, options: &RenderOptions) -> Self {
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
            secondary_radiance: 0,
            _pad0: 0,
            _pad1: 0,
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

/// Constants header of the render WGSL, with the defect `planted` ([`Planted::wgsl`]).
pub fn constants_wgsl(planted: Planted) -> String {
    let mut s = format!(
        "const RENDER_METHOD_NEE: u32 = {METHOD_NEE}u;\nconst RENDER_METHOD_RIS: u32 = {METHOD_RIS}u;\n\
         const STREAM_COUNT: u32 = {STREAM_COUNT}u;\nconst RENDER_RAY_EPS: f32 = {RAY_EPS:e};\n\
         const RENDER_T_MAX: f32 = {T_MAX:e};\nconst RENDER_NO_PIXEL: u32 = 0xffffffffu;\n\
         const RENDER_LUMINANCE: vec3<f32> = vec3<f32>({:?}, {:?}, {:?});\n{}",
        LUMINANCE[0],
        LUMINANCE[1],
        LUMINANCE[2],
        Stream::ALL
            .iter()
            .map(|(s, name)| format!("const STREAM_{name}: u32 = {}u;\n", *s as u32))
            .collect::<String>()
    );
    s += &planted.wgsl();
    s
}

/// The render buffers' bindings (group 0 of every pixel pass).
pub fn bindings() -> BindingSet {
    let rw = Access::ReadWrite;
    let image = "array<vec4<f32>>";
    BindingSet::new("render buffers")
        .buffer("render_params", "RenderParams", Access::Uniform)
        .buffer("render_state", "RenderState", rw)
        .buffer("render_gbuffer", "array<GVertex>", rw)
        .buffer("render_secondary", "array<GVertex>", rw)
        .buffer("render_direct_frame", image, rw)
        .buffer("render_indirect_frame", image, rw)
        .buffer("render_accum_direct", image, rw)
        .buffer("render_accum_indirect", image, rw)
        .buffer("render_materials", "array<Material>", Access::Read)
        .buffer(
            "render_attributes",
            "array<TriangleAttributes>",
            Access::Read,
        )
        .buffer("render_textures", "array<TextureGpu>", Access::Read)
        .buffer("render_texels", "array<u32>", Access::Read)
}

/// The bind groups every pixel pass binds first: render buffers, the tracer's, lights.
pub fn shared_bindings(tracer: Tracer) -> [BindingSet; 3] {
    [bindings(), trace::bindings(tracer), lights::bindings()]
}

/// The WGSL every pixel pass composes its kernel with: constants, the shared bindings
/// (groups 0..3) and the libraries (rng, reservoir, sampling, lights, `tracer`'s trace, render,
/// `WORKGROUP_SIZE` and `item_index`).
pub fn library(tracer: Tracer) -> Vec<WgslModule> {
    planted_library(tracer, Planted::None)
}

/// [`library`] with the defect `planted` compiled in (tests' negative controls).
pub fn planted_library(tracer: Tracer, planted: Planted) -> Vec<WgslModule> {
    let mut m = trace::modules(1, tracer);
    m.extend(lights::modules(2));
    m.extend([
        WgslModule::new("reservoir", &["rng"], reservoir::wgsl()),
        WgslModule::new("workgroup", &[], workgroup_size_wgsl()),
        WgslModule::new("render-constants", &[], constants_wgsl(planted)),
        WgslModule::new("render-bindings", &[], bindings().wgsl(0)),
        WgslModule::new(
            "render",
            &[
                "render-constants",
                "render-bindings",
                "trace",
                "lights",
                "reservoir",
            ],
            WGSL,
        ),
    ]);
    m
}

/// [`library`] + `modules`, which need what they name of the library and of each other.
pub fn compose_with_library(tracer: Tracer, modules: Vec<WgslModule>) -> String {
    compose_planted(tracer, Planted::None, modules)
}

/// [`compose_with_library`] with the defect `planted` compiled in.
pub fn compose_planted(tracer: Tracer, planted: Planted, modules: Vec<WgslModule>) -> String {
    let mut m = planted_library(tracer, planted);
    m.extend(modules);
    compose(&m).expect("the render library composes")
}

fn passes_module() -> WgslModule {
    WgslModule::new("render-passes", &["render-path", "workgroup"], PASSES_WGSL)
}

/// The path module ([`PATH_WGSL`]) and, when no cache provides [`PATH_CACHE`], a
/// `path_cache_radiance` that never ends a path.
pub fn path_modules(with_cache: bool) -> Vec<WgslModule> {
    let mut m = vec![WgslModule::new(
        "render-path",
        &["render", PATH_CACHE],
        PATH_WGSL,
    )];
    if !with_cache {
        m.push(WgslModule::new(
            PATH_CACHE,
            &["render"],
            "// No radiance cache: every path goes on to its full depth.\n\
             fn path_cache_radiance(w: GVertex, bounce: u32, footprint: f32) -> vec4<f32> {\n    \
             return vec4<f32>(0.0);\n}\n",
        ));
    }
    m
}

/// The composed pass module on `tracer`.
pub fn passes_source(tracer: Tracer) -> String {
    let mut m = vec![passes_module()];
    m.extend(path_modules(false));
    compose_with_library(tracer, m)
}

/// A composed kernel module with the binding sets of its groups (0, 1, ... in order): what its
/// pipeline layout is made of. The workspace's tests check each against the bindings naga finds
/// in the source.
#[derive(Debug, Clone)]
pub struct ComposedKernel {
    pub name: String,
    pub source: String,
    pub groups: Vec<BindingSet>,
}

impl ComposedKernel {
    /// A kernel of a stage: the shared groups on the software tracer, then `own` at group 3.
    pub fn stage(name: String, source: String, own: BindingSet) -> Self {
        let mut groups: Vec<BindingSet> = shared_bindings(Tracer::Bvh).into();
        groups.push(own);
        Self {
            name,
            source,
            groups,
        }
    }
}

/// The renderer's pass kernels on both tracers.
pub fn kernels() -> Vec<ComposedKernel> {
    [Tracer::Bvh, Tracer::RayQuery]
        .map(|t| ComposedKernel {
            name: format!("restir-world/render/{}", t.name()),
            source: passes_source(t),
            groups: shared_bindings(t).into(),
        })
        .into()
}

/// The render buffers (per pixel unless noted).
#[derive(Debug)]
pub(crate) struct RenderBuffers {
    pub params: wgpu::Buffer,
    pub state: wgpu::Buffer,
    pub gbuffer: wgpu::Buffer,
    pub secondary: wgpu::Buffer,
    pub direct_frame: wgpu::Buffer,
    pub indirect_frame: wgpu::Buffer,
    pub accum_direct: wgpu::Buffer,
    pub accum_indirect: wgpu::Buffer,
    /// Per material.
    pub materials: wgpu::Buffer,
    /// Per scene triangle (one dummy entry when `RenderParams::attributes` is 0).
    pub attributes: wgpu::Buffer,
    /// Per texture ref, and all texels.
    pub textures: wgpu::Buffer,
    pub texels: wgpu::Buffer,
}

impl RenderBuffers {
    fn new(
        device: &wgpu::Device,
        params: &RenderParams,
        materials: &[Material],
        attributes: &[TriangleAttributes],
        textures: &(Vec<TextureGpu>, Vec<u32>),
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
            accum_direct: zeroed("render_accum_direct", px * 16),
            accum_indirect: zeroed("render_accum_indirect", px * 16),
            materials: buffers::storage_from(device, "render_materials", materials),
            attributes: buffers::storage_from(device, "render_attributes", attributes),
            textures: buffers::storage_from(device, "render_textures", &textures.0),
            texels: buffers::storage_from(device, "render_texels", &textures.1),
        }
    }

    /// The buffers of [`bindings`], by name.
    fn resources(&self) -> [(&'static str, Resource<'_>); 12] {
        [
            ("render_params", (&self.params).into()),
            ("render_state", (&self.state).into()),
            ("render_gbuffer", (&self.gbuffer).into()),
            ("render_secondary", (&self.secondary).into()),
            ("render_direct_frame", (&self.direct_frame).into()),
            ("render_indirect_frame", (&self.indirect_frame).into()),
            ("render_accum_direct", (&self.accum_direct).into()),
            ("render_accum_indirect", (&self.accum_indirect).into()),
            ("render_materials", (&self.materials).into()),
            ("render_attributes", (&self.attributes).into()),
            ("render_textures", (&self.textures).into()),
            ("render_texels", (&self.texels).into()),
        ]
    }
}

/// The shared bind groups (render buffers, tracer, lights) with their layouts, the tracer
/// and the frame's pixel count: what a pixel pass is made from.
#[derive(Debug, Clone)]
pub struct SharedGroups {
    pub layouts: [BindGroupLayout; 3],
    pub groups: [wgpu::BindGroup; 3],
    pub tracer: Tracer,
    pub pixels: u32,
    /// The defect compiled into every kernel of this build ([`RenderOptions::planted`]).
    pub planted: Planted,
    /// Where its kernels come from: the context's, so that a build again reuses them.
    pub kernels: KernelCache,
}

impl SharedGroups {
    /// A kernel over the shared layouts (+ `own`, bound at group 3) composed from the
    /// [`library`] and `modules`.
    pub fn kernel(
        &self,
        device: &wgpu::Device,
        label: &str,
        modules: Vec<WgslModule>,
        own: Option<&BindGroupLayout>,
        entry_points: &[&str],
    ) -> Kernel {
        let mut layouts: Vec<&BindGroupLayout> = self.layouts.iter().collect();
        layouts.extend(own);
        let source = compose_planted(self.tracer, self.planted, modules);
        let size = crate::gpu::WORKGROUP_SIZE;
        self.kernels
            .kernel(device, label, &source, &layouts, entry_points, size)
    }

    /// A kernel with its own group-3 bindings `own`, after checking that the stage's storage
    /// buffers (shared + own) fit the device: the kernel and `own`'s layout.
    pub fn own_kernel(
        &self,
        ctx: &GpuContext,
        label: &str,
        own: &BindingSet,
        modules: Vec<WgslModule>,
        entry_points: &[&str],
    ) -> Result<(Kernel, BindGroupLayout), GpuError> {
        let sets = shared_bindings(self.tracer);
        ctx.check_storage_buffers(label, &[&sets[0], &sets[1], &sets[2], own])?;
        let layout = own.layout(&ctx.device);
        let kernel = self.kernel(&ctx.device, label, modules, Some(&layout), entry_points);
        Ok((kernel, layout))
    }

    /// A pass of `entry` of `kernel` over `items` invocations (`None`: every pixel), its own
    /// group 3 bound to `resources` by name.
    pub fn bound_pass(
        &self,
        device: &wgpu::Device,
        (kernel, layout): &OwnKernel,
        entry: &str,
        resources: Vec<(&str, Resource)>,
        items: Option<u32>,
    ) -> Result<Pass, GpuError> {
        let group = layout.bind(device, resources)?;
        let items = items.unwrap_or(self.pixels);
        Ok(self.pass_over(device, kernel, entry, Some(&group), items))
    }

    /// A pass of `entry` over every pixel with the shared groups (+ `own` at group 3).
    pub fn pass(
        &self,
        device: &wgpu::Device,
        kernel: &Kernel,
        entry: &str,
        own: Option<&wgpu::BindGroup>,
    ) -> Pass {
        self.pass_over(device, kernel, entry, own, self.pixels)
    }

    /// A pass of `entry` over `items` invocations with the shared groups (+ `own`).
    pub fn pass_over(
        &self,
        device: &wgpu::Device,
        kernel: &Kernel,
        entry: &str,
        own: Option<&wgpu::BindGroup>,
        items: u32,
    ) -> Pass {
        let mut groups: Vec<&wgpu::BindGroup> = self.groups.iter().collect();
        groups.extend(own);
        kernel.pass(device, entry, &groups, items)
    }
}

/// The group a stage's kernels bind their own buffers at (0..3 are the renderer's: see
/// [`SharedGroups`]).
pub const STAGE_GROUP: u32 = 3;

/// A buffer a kernel binds: name, WGSL type, access.
pub type Buffer = (&'static str, &'static str, Access);

/// One kernel module of a stage above the renderer: its WGSL file, entry points and own
/// group-3 buffers, in runs (e.g. the stage's parameters, then [`REUSE_IO`], then its own).
/// Each stage composes it after the render library with its own library modules
/// ([`SharedGroups::own_kernel`]).
#[derive(Debug)]
pub struct KernelDef {
    pub name: &'static str,
    pub entries: &'static [&'static str],
    pub source: &'static str,
    pub own: &'static [&'static [Buffer]],
}

impl KernelDef {
    pub const fn new(
        name: &'static str,
        entries: &'static [&'static str],
        source: &'static str,
        own: &'static [&'static [Buffer]],
    ) -> Self {
        Self {
            name,
            entries,
            source,
            own,
        }
    }

    /// Its group-3 buffers, in binding order.
    pub fn buffers(&self) -> impl Iterator<Item = &Buffer> {
        self.own.iter().flat_map(|run| run.iter())
    }

    /// Its group-3 bindings.
    pub fn bindings(&self) -> BindingSet {
        let buffers: Vec<Buffer> = self.buffers().copied().collect();
        BindingSet::of_buffers(self.name, &buffers)
    }

    /// Whether it binds buffer `name`.
    pub fn binds(&self, name: &str) -> bool {
        self.buffers().any(|(n, _, _)| *n == name)
    }
}

/// The stored reservoirs of the reuse methods, as their kernels bind them.
pub const RESERVOIRS: &str = "array<StoredReservoir>";

/// What every reuse pass binds after its stage's parameters: the pass's own uniform
/// ([`ReusePass`]), the source reservoirs it merges, the receivers' own reservoirs, and where it
/// writes.
pub const REUSE_IO: &[Buffer] = &[
    ("reuse_pass", "ReusePass", Access::Read),
    ("reuse_src", RESERVOIRS, Access::Read),
    ("reuse_self", RESERVOIRS, Access::Read),
    ("reuse_out", RESERVOIRS, Access::ReadWrite),
];

/// WGSL `ReusePass`: per reuse pass, whether it reads last frame's reservoirs (`temporal` = 1)
/// and its index among the stage's passes (mixed into its random stream).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReusePass {
    pub temporal: u32,
    pub pass_index: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

impl ReusePass {
    /// The uniform of a reuse pass (a storage buffer, read-only).
    pub fn buffer(device: &wgpu::Device, temporal: bool, pass_index: u32) -> wgpu::Buffer {
        let u = Self {
            temporal: u32::from(temporal),
            pass_index,
            ..Default::default()
        };
        buffers::with_usage(device, "reuse pass", &[u], wgpu::BufferUsages::STORAGE)
    }
}

/// A created kernel with the layout of its own group-3 buffers.
pub type OwnKernel = (Kernel, BindGroupLayout);

/// Debug views of a stage's last frame (each stage draws those it has).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DebugView {
    /// A colour per grid slot (cell) of each vertex; black: not in the grid.
    Cells = 0,
    /// Heat map of log2(M) of the final reservoir (blue M = 1 .. red M >= 2^16).
    M = 1,
    /// Red where the vertex found its bucket full and kept its own reservoir.
    Overflow = 2,
    /// The share of a pixel's reconnections rejected (restir-gi: Jacobian out of range, x2
    /// facing away, or occluded): green none .. red all; black: no neighbour merged.
    Rejected = 3,
    /// The radiance cache's cell at each primary vertex: its radiance (demodulated,
    /// x / (1 + x)); black: no cell with samples.
    CacheRadiance = 4,
    /// The cell's frames since its last sample (heat map up to `evict-after`).
    CacheAge = 5,
    /// The cell's sample count (heat map of log2 up to `history`).
    CacheSamples = 6,
}

impl DebugView {
    /// Whether the radiance cache draws this view.
    pub fn is_cache_view(self) -> bool {
        matches!(
            self,
            Self::CacheRadiance | Self::CacheAge | Self::CacheSamples
        )
    }
}

/// The debug views' heat map of t in [0, 1]: blue .. cyan .. yellow .. red (the twin of
/// WGSL `render_heat`).
pub fn heat(t: f32) -> [f32; 3] {
    let x = t.clamp(0.0, 1.0);
    [3.0, 2.0, 1.0].map(|c| (1.5 - (4.0 * x - c).abs()).clamp(0.0, 1.0))
}

/// Reads the first `pixels` entries of a per-pixel `vec4` buffer back as RGB scaled by
/// `scale`.
pub fn read_rgb(
    ctx: &GpuContext,
    image: &wgpu::Buffer,
    pixels: u32,
    scale: f32,
) -> Result<Vec<[f32; 3]>, GpuError> {
    let v: Vec<[f32; 4]> = buffers::read(ctx, image)?;
    let rgb = |p: &[f32; 4]| [p[0] * scale, p[1] * scale, p[2] * scale];
    Ok(v.iter().take(pixels as usize).map(rgb).collect())
}

/// The renderer's passes.
#[derive(Debug)]
struct Passes {
    primary: Pass,
    gi: Pass,
    shade_direct: Pass,
    shade_indirect: Pass,
    path: Pass,
    accumulate: Pass,
}

impl Passes {
    fn new(device: &wgpu::Device, shared: &SharedGroups) -> Self {
        let entries = [
            "render_primary",
            "render_gi",
            "render_shade_direct",
            "render_shade_indirect",
            "render_path",
            "render_accumulate",
        ];
        let mut modules = vec![passes_module()];
        modules.extend(path_modules(false));
        let kernel = shared.kernel(device, "render passes", modules, None, &entries);
        let pass = |entry| shared.pass(device, &kernel, entry, None);
        Self {
            primary: pass(entries[0]),
            gi: pass(entries[1]),
            shade_direct: pass(entries[2]),
            shade_indirect: pass(entries[3]),
            path: pass(entries[4]),
            accumulate: pass(entries[5]),
        }
    }
}

/// The GPU renderer of one scene and camera.
#[derive(Debug)]
pub struct Renderer {
    camera: Camera,
    /// Set by [`Renderer::set_camera`]: uploaded at the start of the next frame.
    camera_changed: bool,
    estimator: Estimator,
    options: RenderOptions,
    pub(crate) buffers: RenderBuffers,
    pub(crate) shared: SharedGroups,
    passes: Passes,
    /// Frames recorded since creation.
    frames: u32,
    /// Frames in the accumulation buffers (since the last restart).
    accumulated: u32,
}

impl Renderer {
    /// Builds the BVH and the light table, uploads them, and creates the passes. The scene
    /// should be sanitized ([`Scene::sanitize`]); `camera` gives the image size.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        estimator: Estimator,
        seed: u32,
    ) -> Result<Self, RenderError> {
        Self::with_options(ctx, scene, camera, estimator, &RenderOptions::seeded(seed))
    }

    /// [`Renderer::new`] with every option.
    pub fn with_options(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        estimator: Estimator,
        options: &RenderOptions,
    ) -> Result<Self, RenderError> {
        let candidates = match estimator {
            Estimator::Nee => 1,
            Estimator::Ris { candidates } => candidates,
        };
        check_candidates(candidates).map_err(RenderError::Settings)?;
        options
            .paths
            .check(candidates)
            .map_err(RenderError::Settings)?;
        let sets = shared_bindings(ctx.tracer);
        ctx.check_storage_buffers("render", &sets.each_ref())?;
        camera
            .validate()
            .map_err(|e| RenderError::Settings(e.to_string()))?;
        let pixels = camera
            .width
            .checked_mul(camera.height)
            .ok_or_else(|| RenderError::Settings("image too large".into()))?;
        let vertex_bytes = u64::from(pixels) * size_of::<GVertex>() as u64;
        ctx.check_binding_size("the G-buffer", vertex_bytes)?;
        let gpu_bvh = Bvh::build(scene)?.upload(ctx)?;
        let gpu_lights = GpuLights::new(&ctx.device, &Lights::build(scene))?;
        let attributes = triangle_attributes(scene);
        if let Some(a) = &attributes {
            let bytes = (a.len() * size_of::<TriangleAttributes>()) as u64;
            ctx.check_binding_size("the triangle attributes", bytes)?;
        }
        let textures = texture_tables(scene);
        let texel_bytes = (textures.1.len() * 4) as u64;
        ctx.check_binding_size("the scene's textures (resize them)", texel_bytes)?;
        let mut params = RenderParams::new(camera, estimator, options);
        params.ray_offset_floor = ray_offset_floor(scene);
        params.attributes = u32::from(attributes.is_some());
        let no_material = [Material::new([0.0; 3], [0.0; 3])];
        let materials = match scene.materials.is_empty() {
            true => &no_material[..],
            false => &scene.materials,
        };
        let dummy = [bytemuck::Zeroable::zeroed()];
        let attributes = attributes.as_deref().unwrap_or(&dummy);
        let buffers = RenderBuffers::new(&ctx.device, &params, materials, attributes, &textures);
        let layouts = sets.map(|s| s.layout(&ctx.device));
        let groups = [
            layouts[0].bind(&ctx.device, buffers.resources())?,
            layouts[1].bind(&ctx.device, gpu_bvh.resources())?,
            layouts[2].bind(&ctx.device, gpu_lights.resources())?,
        ];
        let shared = SharedGroups {
            layouts,
            groups,
            tracer: ctx.tracer,
            pixels,
            planted: options.planted,
            kernels: ctx.kernels.clone(),
        };
        let passes = Passes::new(&ctx.device, &shared);
        Ok(Self {
            camera: *camera,
            camera_changed: false,
            estimator,
            options: *options,
            buffers,
            shared,
            passes,
            frames: 0,
            accumulated: 0,
        })
    }

    /// The camera of the next frame.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The light estimator at both vertices.
    pub fn estimator(&self) -> Estimator {
        self.estimator
    }

    /// Moves the camera from the next recorded frame on (same image size; the accumulation is
    /// not reset). Used by camera animations.
    pub fn set_camera(&mut self, camera: &Camera) -> Result<(), RenderError> {
        camera
            .validate()
            .map_err(|e| RenderError::Settings(e.to_string()))?;
        if (camera.width, camera.height) != (self.camera.width, self.camera.height) {
            return Err(RenderError::Settings(
                "set_camera cannot change the image size".into(),
            ));
        }
        self.camera = *camera;
        self.camera_changed = true;
        Ok(())
    }

    /// Pixels per frame.
    pub fn pixels(&self) -> u32 {
        self.shared.pixels
    }

    /// Frames recorded since creation.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Frames in the accumulation (since creation or the last restart).
    pub fn accumulated(&self) -> u32 {
        self.accumulated
    }

    /// Steps 1-2: the frame's camera, primary rays -> G-buffer, GI rays -> secondary vertices.
    pub fn encode_primary_and_gi(&mut self, f: &mut FrameEncoder) {
        if std::mem::take(&mut self.camera_changed) {
            // The camera is the first field of RenderParams.
            f.upload(&self.buffers.params, 0, &CameraGpu::new(&self.camera));
        }
        f.span("primary", |f| f.dispatch(&self.passes.primary));
        f.span("gi", |f| f.dispatch(&self.passes.gi));
    }

    /// Step 4: direct light at the primary vertex -> `render_direct_frame`.
    pub fn encode_shade_direct(&self, f: &mut FrameEncoder) {
        f.span("shade_direct", |f| f.dispatch(&self.passes.shade_direct));
    }

    /// Step 5: primary albedo x NEE at the secondary vertex -> `render_indirect_frame`.
    pub fn encode_shade_indirect(&self, f: &mut FrameEncoder) {
        f.span("shade_indirect", |f| {
            f.dispatch(&self.passes.shade_indirect)
        });
    }

    /// Step 5b: bounces 2..=bounces of the path beyond the secondary vertex, added to
    /// `render_indirect_frame` (nothing with one bounce and no MIS).
    pub fn encode_path(&self, f: &mut FrameEncoder) {
        if self.options.paths.bounces > 1 || self.options.paths.mis {
            f.span("path", |f| f.dispatch(&self.passes.path));
        }
    }

    /// How the renderer runs (seed, bounces).
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// Step 6: adds the frame to the running sums and advances the frame counter.
    pub fn encode_accumulate(&mut self, f: &mut FrameEncoder) {
        f.span("accumulate", |f| f.dispatch(&self.passes.accumulate));
        self.frames += 1;
        self.accumulated += 1;
    }

    /// One whole baseline frame (steps 1-6).
    pub fn encode_frame(&mut self, f: &mut FrameEncoder) {
        self.encode_primary_and_gi(f);
        self.encode_shade_direct(f);
        self.encode_shade_indirect(f);
        self.encode_path(f);
        self.encode_accumulate(f);
    }

    /// Whether the indirect passes (`shade_indirect`, `path`, world-restir's shade) write the
    /// radiance leaving the secondary vertex towards the primary instead of the primary's
    /// reflected light: set by a stage that resamples that radiance (ReSTIR GI) and writes the
    /// indirect image itself.
    pub fn set_secondary_radiance(&self, ctx: &GpuContext, on: bool) {
        let offset = std::mem::offset_of!(RenderParams, secondary_radiance) as u64;
        let word = [u32::from(on)];
        ctx.queue
            .write_buffer(&self.buffers.params, offset, bytemuck::cast_slice(&word));
    }

    /// The last frame's primary vertices (G-buffer), per pixel.
    pub fn read_gbuffer(&self, ctx: &GpuContext) -> Result<Vec<GVertex>, GpuError> {
        let mut v: Vec<GVertex> = buffers::read(ctx, &self.buffers.gbuffer)?;
        v.truncate(self.pixels() as usize);
        Ok(v)
    }

    /// Clears the running sums (the frame counter, which seeds the passes, runs on).
    pub fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        f.raw().clear_buffer(&self.buffers.accum_direct, 0, None);
        f.raw().clear_buffer(&self.buffers.accum_indirect, 0, None);
        self.accumulated = 0;
    }

    /// Reads the images back: the mean of the frames accumulated since creation or the last
    /// restart, or the last frame alone.
    pub fn read(&self, ctx: &GpuContext, which: Readback) -> Result<FrameImages, GpuError> {
        let b = &self.buffers;
        let (sums, frames, scale) = match which {
            Readback::Accumulated => {
                let n = self.accumulated;
                let scale = if n == 0 { 0.0 } else { 1.0 / n as f32 };
                ([&b.accum_direct, &b.accum_indirect], n, scale)
            }
            Readback::LastFrame => ([&b.direct_frame, &b.indirect_frame], 1, 1.0),
        };
        Ok(FrameImages {
            width: self.camera.width,
            height: self.camera.height,
            frames,
            direct: read_rgb(ctx, sums[0], self.pixels(), scale)?,
            indirect: read_rgb(ctx, sums[1], self.pixels(), scale)?,
        })
    }
}
