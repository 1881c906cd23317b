//! # reservoir
//!
//! Weighted reservoir sampling and resampled importance sampling (RIS) helpers in WGSL,
//! with a Rust twin of identical arithmetic and a documented numerical contract.

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    Vec::new()
}
