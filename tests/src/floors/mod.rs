//! Floor kernels measured in the same run as a benchmark: what any kernel moving the same bytes
//! must pay on this device. Benchmarks print their speed as a ratio to these.

mod copy;
mod random_access;
mod rts;

pub use copy::CopyKernel;
pub use random_access::{RandomAccess, RandomAccessKernel};
pub use rts::ReduceThenScan;

/// WGSL modules of the floor kernels, for the naga checks.
pub fn wgsl_modules() -> Vec<(String, String)> {
    vec![
        ("floors/copy".into(), copy::SOURCE.into()),
        ("floors/rts".into(), rts::composed()),
        ("floors/random_access".into(), random_access::SOURCE.into()),
    ]
}

pub use restir_world::gpu::dispatch_2d;
