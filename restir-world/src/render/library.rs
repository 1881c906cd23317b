//! The render library's WGSL: its constants, the shared bindings (groups 0..3), the modules
//! every pixel pass composes its kernel with, and the renderer's own pass kernels.

use crate::gpu::{Access, BindingSet, Tracer, WgslModule, compose, workgroup_size_wgsl};
use crate::lights;
use crate::plant::Planted;
use crate::scene::LUMINANCE;
use crate::trace;

use super::records::{ATTR_TANGENT_FLIP, ATTR_TANGENTS, SHADING_FLAT, TEXTURE_LINEAR};
use super::streams::{STREAM_COUNT, Stream, sub_streams_wgsl};
use super::{RAY_EPS, T_MAX};

/// The renderer's library (structs + functions).
pub const WGSL: &str = include_str!("render.wgsl");
/// The BRDF ([`crate::brdf::WGSL`]) with its `brdf_table` hook over `render_brdf_tables`.
const BRDF_WGSL: &str = concat!(
    "fn brdf_table(index: u32) -> f32 {\n    return render_brdf_tables[index];\n}\n",
    include_str!("../brdf/brdf.wgsl")
);
/// The pass kernels.
pub const PASSES_WGSL: &str = include_str!("passes.wgsl");
/// The indirect path beyond the secondary vertex (`render_path_pixel`), shared with the
/// radiance cache's path pass; needs a module named [`PATH_CACHE`].
pub const PATH_WGSL: &str = include_str!("path.wgsl");
/// The name of the module that defines `path_cache_radiance` for [`PATH_WGSL`].
pub const PATH_CACHE: &str = "path-cache";
/// The name of the module that defines `path_light_estimate` and `path_light_nee` for
/// [`PATH_WGSL`].
pub const PATH_LIGHT: &str = "path-light";

pub(super) const METHOD_NEE: u32 = 0;
pub(super) const METHOD_RIS: u32 = 1;

/// Constants header of the render WGSL, with the planted defects' ids ([`Planted::wgsl`]) and
/// the overrides `RENDER_GLOSSY` (false unless a scene's glossy materials specialize the
/// kernels: [`super::SharedGroups::glossy`]), `RENDER_NORMAL_MAPS` (false unless a triangle
/// has a normal map: [`super::SharedGroups::normal_maps`]) and `RENDER_PLANTED` (false unless a
/// test's negative control plants a defect: [`super::SharedGroups::planted`]).
pub fn constants_wgsl() -> String {
    let mut s = format!(
        "const RENDER_METHOD_NEE: u32 = {METHOD_NEE}u;\nconst RENDER_METHOD_RIS: u32 = {METHOD_RIS}u;\n\
         const STREAM_COUNT: u32 = {STREAM_COUNT}u;\nconst RENDER_RAY_EPS: f32 = {RAY_EPS:e};\n\
         const RENDER_T_MAX: f32 = {T_MAX:e};\nconst RENDER_NO_PIXEL: u32 = 0xffffffffu;\n\
         const RENDER_LUMINANCE: vec3<f32> = vec3<f32>({:?}, {:?}, {:?});\n\
         const RENDER_TEXTURE_LINEAR: u32 = {TEXTURE_LINEAR}u;\n\
         const RENDER_SHADING_FLAT: f32 = {SHADING_FLAT:?};\n\
         const RENDER_ATTR_TANGENTS: u32 = {ATTR_TANGENTS}u;\n\
         const RENDER_ATTR_TANGENT_FLIP: u32 = {ATTR_TANGENT_FLIP}u;\n\
         override RENDER_GLOSSY: bool = false;\noverride RENDER_NORMAL_MAPS: bool = false;\n\
         override RENDER_PLANTED: bool = false;\n{}",
        LUMINANCE[0],
        LUMINANCE[1],
        LUMINANCE[2],
        Stream::ALL
            .iter()
            .map(|(s, name)| format!("const STREAM_{name}: u32 = {}u;\n", *s as u32))
            .collect::<String>()
    );
    s += &sub_streams_wgsl();
    s += &Planted::wgsl();
    s
}

/// The render buffers' bindings (group 0 of every pixel pass).
pub fn bindings() -> BindingSet {
    let rw = Access::ReadWrite;
    let image = "array<vec4<f32>>";
    BindingSet::new("render buffers")
        .buffer("render_params", "RenderParams", Access::Uniform)
        .buffer("render_state", "RenderState", rw)
        .buffer("render_gbuffer", "array<PackedVertex>", rw)
        .buffer("render_secondary", "array<PackedVertex>", rw)
        .buffer("render_direct_frame", image, rw)
        .buffer("render_indirect_frame", image, rw)
        .buffer("render_path_radiance", image, rw)
        .buffer("render_path_split", image, rw)
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
        .buffer("render_brdf_tables", "array<f32>", Access::Read)
}

/// The bind groups every pixel pass binds first: render buffers, the tracer's, lights.
pub fn shared_bindings(tracer: Tracer) -> [BindingSet; 3] {
    [bindings(), trace::bindings(tracer), lights::bindings()]
}

/// The WGSL every pixel pass composes its kernel with: constants, the shared bindings
/// (groups 0..3) and the libraries (rng, reservoir, sampling, lights, `tracer`'s trace, render,
/// `WORKGROUP_SIZE` and `item_index`).
pub fn library(tracer: Tracer) -> Vec<WgslModule> {
    let mut m = trace::modules(1, tracer);
    m.extend(lights::modules(2));
    m.extend([
        WgslModule::new("reservoir", &["rng"], reservoir::wgsl()),
        WgslModule::new("workgroup", &[], workgroup_size_wgsl()),
        WgslModule::new("render-constants", &[], constants_wgsl()),
        WgslModule::new("render-bindings", &[], bindings().wgsl(0)),
        WgslModule::new("brdf-constants", &[], crate::brdf::constants_wgsl()),
        WgslModule::new(
            "brdf",
            &["sampling", "brdf-constants", "render-bindings"],
            BRDF_WGSL,
        ),
        WgslModule::new(
            "render",
            &[
                "render-constants",
                "render-bindings",
                "trace",
                "lights",
                "reservoir",
                "brdf",
            ],
            WGSL,
        ),
    ]);
    m
}

/// [`library`] + `modules`, which need what they name of the library and of each other.
pub fn compose_with_library(tracer: Tracer, modules: Vec<WgslModule>) -> String {
    let mut m = library(tracer);
    m.extend(modules);
    compose(&m).expect("the render library composes")
}

pub(super) fn passes_module() -> WgslModule {
    WgslModule::new("render-passes", &["render-path", "workgroup"], PASSES_WGSL)
}

/// The path module ([`PATH_WGSL`]); when no cache provides [`PATH_CACHE`], a
/// `path_cache_radiance` that never ends a path; when no stage provides [`PATH_LIGHT`]
/// (`with_light`), a `path_light_estimate` of 0 (MIS with the light table's density) and a
/// `path_light_nee` that is the renderer's light sample.
pub fn path_modules(with_cache: bool, with_light: bool) -> Vec<WgslModule> {
    let mut m = vec![WgslModule::new(
        "render-path",
        &["render", PATH_CACHE, PATH_LIGHT],
        PATH_WGSL,
    )];
    if !with_light {
        m.push(WgslModule::new(
            PATH_LIGHT,
            &["render"],
            "// No estimates: the path's MIS weighs with the light table's density.\n\
             fn path_light_estimate(i: u32, w: GVertex, bounce: u32) -> f32 {\n    \
             return 0.0;\n}\n\
             // The renderer's light sample at every vertex.\n\
             fn path_light_nee(i: u32, w: GVertex, bounce: u32, e: f32, \
             rng: ptr<function, u32>) -> vec3<f32> {\n    \
             return render_nee_at(w, rng, e);\n}\n",
        ));
    }
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
    m.extend(path_modules(false, false));
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
