//! # restir-world
//!
//! World-space spatiotemporal reservoir reuse for ray-traced global illumination
//! (Boissé 2021), composed from the `gpu-scan`, `gpu-hash` and `reservoir` primitives on a
//! software-BVH ray tracer.
//!
//! Layers, each using only those below it:
//!
//! - [`gpu`]: device acquisition, timestamp spans, upload/readback, and the vocabulary every
//!   pass is written in (`BindingSet`, `WgslModule`, `Kernel`, `Pass`, `FrameEncoder`).
//! - [`scene`], [`trace`], [`lights`], [`sampling`]: the scene, the BVH tracer, light sampling.
//! - [`render`]: the renderer's shared passes and the `nee`/`ris` baselines;
//!   [`world_restir`] (indirect) and [`restir_di`] (direct) build on it.
//! - [`methods`]: the registry of methods, the one frame loop (`run_frames`) and readback.
//! - [`reference`](mod@reference) (CPU) and [`gpu_reference`]: converged references; [`metrics`].

pub mod gpu;
pub mod gpu_reference;
pub mod image_io;
pub mod lights;
pub mod methods;
pub mod metrics;
pub mod reference;
pub mod render;
pub mod restir_di;
pub mod sampling;
pub mod scene;
pub mod trace;
pub mod world_restir;

pub use gpu::{GpuContext, GpuError, GpuTimer};

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    let lights = gpu::compose(&lights::modules(0)).expect("the lights' modules compose");
    let mut modules = vec![
        ("restir-world/sampling".into(), sampling::WGSL.into()),
        ("restir-world/lights".into(), lights),
    ];
    modules.extend(trace::wgsl_modules());
    modules.extend(render::wgsl_modules());
    modules.extend(world_restir::wgsl_modules());
    modules.extend(restir_di::wgsl_modules());
    modules
}
