//! # tests
//!
//! The shared test harness of the workspace, plus (under `tests/` and `benches/`) every GPU
//! test, the cross-crate integration tests and the per-primitive microbenchmarks.
//!
//! - [`wgsl`]: naga parsing/validation of every WGSL module and Rust/WGSL layout checks
//!   (no adapter needed).
//! - [`gpu`]: the one shared [`GpuContext`] for a test binary; tests fail loudly when there is no
//!   adapter and skip, with a printed reason, only for missing optional features.
//! - [`floors`]: same-harness floor kernels (vec4 copy) that benchmarks compare against.
//! - [`bench`](mod@bench): GPU-timestamp timing for criterion's `iter_custom` and the `RESULT` line.
//!
//! Buffer upload and readback live in [`restir_world::gpu::buffers`] (re-exported as
//! [`buffers`]).

pub mod bench;
pub mod floors;
pub mod gpu;
pub mod wgsl;

pub use restir_world::GpuContext;
pub use restir_world::gpu::buffers;
