//! # reservoir
//!
//! Weighted reservoir sampling and resampled importance sampling (RIS) helpers in WGSL,
//! with a Rust twin of identical arithmetic and a documented numerical contract.
//!
//! [`rng`] holds the random-number generator the ReSTIR passes share (WGSL + Rust twin).

pub mod rng;

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    vec![("reservoir/rng".into(), rng::WGSL.into())]
}
