//! # gpu-scan
//!
//! Single-pass prefix sums of `u32` on the GPU: chained scan with decoupled look-back
//! (Merrill & Garland 2016) made portable by a bounded spin and a fallback (Smith, Levien &
//! Owens, "Decoupled Fallback", SPAA 2025). Encodes into the caller's command encoder over
//! caller-owned buffers.

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    Vec::new()
}
