//! # restir-world
//!
//! World-space spatiotemporal reservoir reuse for ray-traced global illumination
//! (Boissé 2021), composed from the `gpu-scan`, `gpu-hash` and `reservoir` primitives on a
//! software-BVH ray tracer.
//!
//! This crate also holds the GPU plumbing shared by the demo, the tests and the benchmarks:
//! [`gpu::GpuContext`] (adapter + device acquisition that honours `WGPU_BACKEND` and
//! `WGPU_ADAPTER_NAME`), [`gpu::GpuTimer`] (named timestamp spans) and the buffer
//! upload/readback helpers in [`gpu::buffers`].

pub mod gpu;
pub mod image_io;
pub mod lights;
pub mod reference;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod trace;
pub mod world_restir;

pub use gpu::{GpuContext, GpuError, GpuTimer};

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    let mut modules = vec![
        ("restir-world/sampling".into(), sampling::WGSL.into()),
        ("restir-world/lights".into(), lights::composed_wgsl(0, 0)),
    ];
    modules.extend(trace::wgsl_modules());
    modules.extend(render::wgsl_modules());
    modules.extend(world_restir::wgsl_modules());
    modules
}
