//! Bias and equivalence checks whose negative controls can fail.
//!
//! A check bounds a measured per-channel relative deviation `d` (a method's image mean over a
//! reference's, minus 1). Its control is a second, independent measurement: the same estimator
//! run on other seeds with a known defect planted on the GPU (`Renderer::plant_scale`, which
//! scales the frames as they are accumulated), or a biased mode. The same check must flag it.
//! Scaling the already measured number instead proves nothing: if |d| < b, then
//! |(1 + d)(1 - k) - 1| >= b for every k >= 2b, always.

/// Mean of an image per channel.
pub fn channel_means(img: &[[f32; 3]]) -> [f64; 3] {
    let n = img.len() as f64;
    [0, 1, 2].map(|c| img.iter().map(|p| f64::from(p[c])).sum::<f64>() / n)
}

/// Per channel `got / want - 1`.
pub fn relative(got: [f64; 3], want: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| got[c] / want[c] - 1.0)
}

/// The check: every channel of `d` within `bound`.
pub fn within(d: [f64; 3], bound: f64) -> bool {
    d.iter().all(|x| x.abs() < bound)
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
