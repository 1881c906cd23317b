//! # restir-world
//!
//! World-space spatiotemporal reservoir reuse for ray-traced global illumination
//! (Boissé 2021), composed from the `gpu-scan`, `gpu-hash` and `reservoir` primitives on a
//! software-BVH ray tracer.
//!
//! Layers, each using only those below it (a test parses the `crate::` paths and fails on a
//! cycle):
//!
//! - [`gpu`]: device acquisition, timestamp spans, upload/readback, and the vocabulary every
//!   pass is written in (`BindingSet`, `WgslModule`, `Kernel`, `Pass`, `FrameEncoder`);
//!   [`image_io`] and [`knobs`](mod@knobs) (a method's settings declared once).
//! - [`scene`], then [`sampling`], [`brdf`] (glTF's metallic-roughness BRDF: WGSL and its f64
//!   twin), [`trace`] (the BVH tracer), [`framing`] (a default camera),
//!   [`lights`] (light sampling); [`reference`](mod@reference) (the CPU reference renderer),
//!   [`images`] (the one image set) and [`metrics`].
//! - [`render`]: the renderer's shared passes and the `nee`/`ris` baselines.
//! - [`reuse`] (the one merge loop every reuse calls, its target, shift and neighbours as the
//!   including kernel's hooks), [`light_tiles`], [`screen_reuse`] (screen-space reuse written
//!   once: parameters,
//!   reservoir buffers, neighbours, the pass chain, camera history) and [`grid`] (the
//!   world-space grid a stage gathers its items in), then the stages that replace the renderer's shading: [`world_restir`] (light at
//!   the secondary vertex), [`restir_gi`] (the paths, resampled between pixels) and
//!   [`restir_di`] (direct), independent of each other; [`cache`] (the radiance cache the
//!   paths end in); [`denoise`] (SVGF after any method).
//! - [`methods`]: the registry, which composes the stages into methods, the one frame loop
//!   (`run_frames`) and readback; [`gpu_reference`]: converged GPU references.

pub mod brdf;
pub mod cache;
pub mod denoise;
pub mod framing;
pub mod gpu;
pub mod gpu_reference;
pub mod grid;
pub mod image_io;
pub mod images;
pub mod knobs;
pub mod light_tiles;
pub mod lights;
pub mod methods;
pub mod metrics;
pub mod plant;
pub mod reference;
pub mod render;
pub mod restir_di;
pub mod restir_gi;
pub mod reuse;
pub mod sampling;
pub mod scene;
pub mod screen_reuse;
pub mod trace;
pub mod world_restir;

#[cfg(test)]
mod layering;

pub use gpu::{GpuContext, GpuError, GpuTimer};

/// Every compute kernel the renderer and its stages create, composed as used, with the binding
/// sets of its pipeline layout.
pub fn kernels() -> Vec<render::ComposedKernel> {
    let mut k = render::kernels();
    k.extend(light_tiles::kernels());
    k.extend(world_restir::kernels());
    k.extend(restir_di::kernels());
    k.extend(restir_gi::kernels());
    k.extend(restir_gi::world::kernels());
    k.extend(cache::kernels());
    k.extend(denoise::kernels());
    k
}

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    let lights = gpu::compose(&lights::modules(0)).expect("the lights' modules compose");
    let mut modules = vec![
        ("restir-world/sampling".into(), sampling::WGSL.into()),
        ("restir-world/brdf".into(), brdf::wgsl_with_table_buffer()),
        ("restir-world/lights".into(), lights),
    ];
    modules.extend(trace::wgsl_modules());
    modules.extend(kernels().into_iter().map(|k| (k.name, k.source)));
    modules
}
