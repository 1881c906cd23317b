//! Bias and equivalence checks whose negative controls can fail.
//!
//! A check bounds a measured per-channel relative deviation `d` (a method's image mean over a
//! reference's, minus 1). Its control is a second, independent measurement: the same estimator
//! run on other seeds with a defect planted in it on the GPU ([`restir_world::plant`]: a wrong
//! Jacobian, a merge without M, roulette without its division, ...), or a biased mode. The same
//! check must flag it. A planted [`Planted::Scale`] of the finished frames is only a power
//! check (the bound can see a shift of that size) and is named so; scaling the already
//! measured number proves nothing: if |d| < b, then |(1 + d)(1 - k) - 1| >= b for every
//! k >= 2b, always.

use restir_world::methods::{self, Composed, MethodSettings};
use restir_world::plant::Planted;
use restir_world::render::RenderOptions;
use restir_world::scene::{Camera, Scene};
use restir_world::world_restir::WorldRestirConfig;

use crate::gpu;

/// Per channel: the mean over `seeds` of world-restir's (with `config`) accumulated indirect
/// image mean after `frames` static frames of `s` seen from `cam`.
pub fn world_restir_indirect_means(
    s: &Scene,
    cam: &Camera,
    config: WorldRestirConfig,
    seeds: std::ops::Range<u32>,
    frames: u32,
) -> [f64; 3] {
    world_restir_planted_means(s, cam, config, seeds, frames, Planted::None)
}

/// [`world_restir_indirect_means`] with `planted` in the method (a negative
/// control's defect, or a power check's scale).
pub fn world_restir_planted_means(
    s: &Scene,
    cam: &Camera,
    config: WorldRestirConfig,
    seeds: std::ops::Range<u32>,
    frames: u32,
    planted: Planted,
) -> [f64; 3] {
    let settings = MethodSettings {
        world: Some(config),
        ..methods::parse_spec("world-restir").expect("spec")
    };
    mean_over_seeds(seeds, |seed| {
        let options = RenderOptions {
            seed,
            planted,
            ..Default::default()
        };
        let mut wr = Composed::with_options(gpu::context(), s, cam, &settings, &options)
            .expect("world-restir");
        gpu::render(&mut wr, frames);
        channel_means(&gpu::images(&wr).indirect)
    })
}

/// Mean of an image per channel.
pub fn channel_means(img: &[[f32; 3]]) -> [f64; 3] {
    let n = img.len() as f64;
    [0, 1, 2].map(|c| img.iter().map(|p| f64::from(p[c])).sum::<f64>() / n)
}

/// Per channel `got / want - 1`.
pub fn relative(got: [f64; 3], want: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| got[c] / want[c] - 1.0)
}

/// The mean over `seeds` of a per-channel measurement of each seed.
pub fn mean_over_seeds(
    seeds: impl IntoIterator<Item = u32>,
    mut measure: impl FnMut(u32) -> [f64; 3],
) -> [f64; 3] {
    let (mut sum, mut n) = ([0.0; 3], 0);
    for seed in seeds {
        let m = measure(seed);
        (0..3).for_each(|c| sum[c] += m[c]);
        n += 1;
    }
    sum.map(|s| s / f64::from(n.max(1)))
}

/// The check: every channel of `d` within `bound`.
pub fn within(d: [f64; 3], bound: f64) -> bool {
    d.iter().all(|x| x.abs() < bound)
}

/// Asserts that the measurement `d` passes the check; prints it.
pub fn assert_within(what: &str, d: [f64; 3], bound: f64) {
    eprintln!("{what}: {d:+.4?} (bound {bound})");
    assert!(within(d, bound), "{what}: {d:+.4?} beyond {bound}");
}

/// Asserts that the measurement `d` passes the check and the control `control` (the planted
/// defect `planted`, measured independently) fails it; prints both.
pub fn assert_checked(what: &str, d: [f64; 3], bound: f64, control: [f64; 3], planted: &str) {
    eprintln!("{what}: {d:+.4?} (bound {bound}); control ({planted}): {control:+.4?}");
    assert!(within(d, bound), "{what}: {d:+.4?} beyond {bound}");
    assert!(
        !within(control, bound),
        "{what}: the control ({planted}) passed the check: {control:+.4?}"
    );
}
