//! Image error metrics against a reference: MSE and relMSE on linear HDR (per channel), and
//! FLIP on tone-mapped images (feature `flip`, through the `nv-flip` crate: NVIDIA's
//! reference implementation, not a port of ours).
//!
//! - `MSE = mean over pixels and channels of (I - R)^2`
//! - `relMSE = mean over pixels and channels of (I - R)^2 / (R^2 + eps)`, eps = [`REL_MSE_EPS`]
//!
//! Sums run in f64. A non-finite pixel in the test image makes the result non-finite (we do not
//! hide NaNs a renderer produced).

/// The eps of relMSE (per channel, linear HDR).
pub const REL_MSE_EPS: f64 = 0.01;

/// What can go wrong computing a metric.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MetricsError {
    #[error("images differ in size: {a} pixels against {b}")]
    SizeMismatch { a: usize, b: usize },
    #[error("image of {width}x{height} needs {} pixels, has {len}", *width as u64 * *height as u64)]
    BadDimensions { width: u32, height: u32, len: usize },
    #[error("empty image")]
    Empty,
}

fn check(a: &[[f32; 3]], b: &[[f32; 3]]) -> Result<(), MetricsError> {
    if a.len() != b.len() {
        return Err(MetricsError::SizeMismatch {
            a: a.len(),
            b: b.len(),
        });
    }
    if a.is_empty() {
        return Err(MetricsError::Empty);
    }
    Ok(())
}

/// Mean squared error per channel.
pub fn mse(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<f64, MetricsError> {
    check(image, reference)?;
    let mut s = 0.0f64;
    for (p, r) in image.iter().zip(reference) {
        for c in 0..3 {
            let d = f64::from(p[c]) - f64::from(r[c]);
            s += d * d;
        }
    }
    Ok(s / (3 * image.len()) as f64)
}

/// Per-pixel relative squared error, averaged over the three channels.
pub fn rel_mse_map(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<Vec<f64>, MetricsError> {
    check(image, reference)?;
    Ok(image
        .iter()
        .zip(reference)
        .map(|(p, r)| {
            (0..3)
                .map(|c| {
                    let (i, r) = (f64::from(p[c]), f64::from(r[c]));
                    (i - r) * (i - r) / (r * r + REL_MSE_EPS)
                })
                .sum::<f64>()
                / 3.0
        })
        .collect())
}

/// Relative mean squared error, per channel, eps [`REL_MSE_EPS`].
pub fn rel_mse(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<f64, MetricsError> {
    let m = rel_mse_map(image, reference)?;
    Ok(m.iter().sum::<f64>() / m.len() as f64)
}

/// The fraction of pixels with the largest errors that [`rel_mse_trimmed`] leaves out.
pub const TRIM_FRACTION: f64 = 0.001;

/// relMSE without the `fraction` of pixels with the largest per-pixel error (at least one
/// pixel is kept): robust to a handful of fireflies, which dominate the plain mean of
/// heavy-tailed estimators (many small lights: 1/d^2 next to a light).
pub fn rel_mse_trimmed(
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    fraction: f64,
) -> Result<f64, MetricsError> {
    let mut m = rel_mse_map(image, reference)?;
    let drop = ((m.len() as f64 * fraction.clamp(0.0, 1.0)).floor() as usize).min(m.len() - 1);
    let keep = m.len() - drop;
    if drop > 0 {
        // NaN sorts last (total order): a NaN pixel is trimmed first, like any outlier.
        m.select_nth_unstable_by(keep - 1, f64::total_cmp);
    }
    Ok(m[..keep].iter().sum::<f64>() / keep as f64)
}

/// MSE, relMSE and trimmed relMSE of one image.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Errors {
    pub mse: f64,
    pub rel_mse: f64,
    /// [`rel_mse_trimmed`] with [`TRIM_FRACTION`].
    pub rel_mse_trimmed: f64,
}

/// All linear-HDR errors at once.
pub fn errors(image: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<Errors, MetricsError> {
    Ok(Errors {
        mse: mse(image, reference)?,
        rel_mse: rel_mse(image, reference)?,
        rel_mse_trimmed: rel_mse_trimmed(image, reference, TRIM_FRACTION)?,
    })
}

/// An estimate of the relMSE of the average of two independent, equally sampled renders `a`
/// and `b` (each unbiased): `E[(a - b)^2] = 2 Var(half)` and `Var((a + b)/2) = Var(half)/2`,
/// so relMSE(avg) ~ mean((a - b)^2 / (avg^2 + eps)) / 4.
pub fn rel_mse_of_average(a: &[[f32; 3]], b: &[[f32; 3]]) -> Result<f64, MetricsError> {
    check(a, b)?;
    let mut s = 0.0f64;
    for (p, q) in a.iter().zip(b) {
        for c in 0..3 {
            let (x, y) = (f64::from(p[c]), f64::from(q[c]));
            let avg = 0.5 * (x + y);
            s += (x - y) * (x - y) / (avg * avg + REL_MSE_EPS);
        }
    }
    Ok(s / (3 * a.len()) as f64 / 4.0)
}

/// A tone-mapping exposure for `reference`: the one that maps its 99th-percentile luminance
/// to 1 (at least a tiny positive value; 1 for a black image).
pub fn auto_exposure(reference: &[[f32; 3]]) -> f32 {
    let mut l: Vec<f32> = reference
        .iter()
        .map(|p| crate::scene::luminance(*p))
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if l.is_empty() {
        return 1.0;
    }
    let k = ((l.len() - 1) as f64 * 0.99) as usize;
    let (_, v, _) = l.select_nth_unstable_by(k, f32::total_cmp);
    if *v > 0.0 { 1.0 / *v } else { 1.0 }
}

/// FLIP (LDR) between `image` and `reference`, both tone-mapped with
/// [`crate::image_io::tone_map`] at `exposure`: the mean of the FLIP error map and the map
/// itself (one value in [0, 1] per pixel). Uses 67 pixels per degree (FLIP's default viewing
/// condition).
#[cfg(feature = "flip")]
pub fn flip(
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    width: u32,
    height: u32,
    exposure: f32,
) -> Result<(f64, Vec<f32>), MetricsError> {
    check(image, reference)?;
    if image.len() as u64 != u64::from(width) * u64::from(height) {
        return Err(MetricsError::BadDimensions {
            width,
            height,
            len: image.len(),
        });
    }
    let ldr = |img: &[[f32; 3]]| -> Vec<u8> {
        img.iter()
            .flat_map(|&p| crate::image_io::tone_map(p, exposure))
            .collect()
    };
    let (t, r) = (ldr(image), ldr(reference));
    let test = nv_flip::FlipImageRgb8::with_data(width, height, &t);
    let refi = nv_flip::FlipImageRgb8::with_data(width, height, &r);
    let map = nv_flip::flip(refi, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let pool = nv_flip::FlipPool::from_image(&map);
    Ok((f64::from(pool.mean()), map.to_vec()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_values() {
        // Two pixels. Differences: (1, 0, 0) and (0, 0.5, 0) -> squares 1, 0, 0, 0, 0.25, 0.
        let img = [[2.0, 1.0, 0.0], [0.0, 1.0, 3.0]];
        let r = [[1.0, 1.0, 0.0], [0.0, 0.5, 3.0]];
        let m = mse(&img, &r).unwrap();
        assert!((m - 1.25 / 6.0).abs() < 1e-12, "{m}");
        // relMSE: 1/(1 + 0.01) + 0.25/(0.25 + 0.01), over 6 channel values.
        let want = (1.0 / 1.01 + 0.25 / 0.26) / 6.0;
        let got = rel_mse(&img, &r).unwrap();
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        let map = rel_mse_map(&img, &r).unwrap();
        assert!((map[0] - 1.0 / 1.01 / 3.0).abs() < 1e-12);
        assert!((map[1] - 0.25 / 0.26 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn eps_dominates_on_black_reference() {
        // Reference 0, image 0.1 everywhere: relMSE = 0.01 / 0.01 = 1; MSE = 0.01.
        let img = [[0.1f32; 3]; 4];
        let r = [[0.0f32; 3]; 4];
        assert!((rel_mse(&img, &r).unwrap() - 1.0).abs() < 1e-6);
        assert!((mse(&img, &r).unwrap() - 0.01).abs() < 1e-8);
    }

    #[test]
    fn self_error_is_zero_and_bias_is_seen() {
        let r: Vec<[f32; 3]> = (0..64)
            .map(|i| [i as f32 * 0.1, 1.0, (i % 7) as f32])
            .collect();
        assert_eq!(mse(&r, &r).unwrap(), 0.0);
        assert_eq!(rel_mse(&r, &r).unwrap(), 0.0);
        let biased: Vec<[f32; 3]> = r.iter().map(|p| p.map(|v| v * 1.1)).collect();
        assert!(rel_mse(&biased, &r).unwrap() > 1e-3);
    }

    #[test]
    fn size_mismatch_and_empty_are_errors() {
        assert_eq!(
            mse(&[[0.0; 3]], &[]),
            Err(MetricsError::SizeMismatch { a: 1, b: 0 })
        );
        assert_eq!(rel_mse(&[], &[]), Err(MetricsError::Empty));
    }

    #[test]
    fn nan_is_not_hidden() {
        let img = [[f32::NAN, 0.0, 0.0]];
        assert!(!rel_mse(&img, &[[0.0; 3]]).unwrap().is_finite());
    }

    #[test]
    fn trimmed_drops_the_largest_pixels() {
        // 1000 pixels: 999 with per-pixel relMSE 1 (0.1 against 0), one firefly of 1e6.
        let r = vec![[0.0f32; 3]; 1000];
        let mut img = vec![[0.1f32; 3]; 1000];
        img[17] = [100.0; 3];
        let plain = rel_mse(&img, &r).unwrap();
        assert!(plain > 900.0, "{plain}");
        let t = rel_mse_trimmed(&img, &r, 0.001).unwrap();
        assert!((t - 1.0).abs() < 1e-6, "{t}");
        // Nothing to drop below one pixel's worth; at least one pixel always stays.
        assert_eq!(rel_mse_trimmed(&img, &r, 0.0).unwrap(), plain);
        assert!(rel_mse_trimmed(&img[..1], &r[..1], 1.0).unwrap() > 0.0);
    }

    #[test]
    fn average_estimate_matches_hand_value() {
        // a = 1, b = 3 in one channel (others equal 1): avg 2, (a-b)^2 = 4, 4 / (4 + 0.01) / 3 / 4.
        let a = [[1.0, 1.0, 1.0]];
        let b = [[3.0, 1.0, 1.0]];
        let want = 4.0 / 4.01 / 3.0 / 4.0;
        assert!((rel_mse_of_average(&a, &b).unwrap() - want).abs() < 1e-12);
    }

    #[test]
    fn exposure_maps_high_percentile_to_one() {
        let img: Vec<[f32; 3]> = (1..=100).map(|i| [i as f32; 3]).collect();
        let e = auto_exposure(&img);
        assert!((e - 1.0 / 99.0).abs() < 1e-6, "{e}");
        assert_eq!(auto_exposure(&[[0.0; 3]; 3]), 1.0);
    }

    #[cfg(feature = "flip")]
    #[test]
    fn flip_is_zero_on_equal_and_positive_on_different() {
        let r: Vec<[f32; 3]> = (0..32 * 32)
            .map(|i| [((i % 32) as f32) / 32.0, 0.5, ((i / 32) as f32) / 32.0])
            .collect();
        let (same, map) = flip(&r, &r, 32, 32, 1.0).unwrap();
        assert_eq!(same, 0.0);
        assert_eq!(map.len(), 32 * 32);
        let noisy: Vec<[f32; 3]> = r
            .iter()
            .enumerate()
            .map(|(i, p)| if i % 3 == 0 { [1.0, 1.0, 1.0] } else { *p })
            .collect();
        let (diff, _) = flip(&noisy, &r, 32, 32, 1.0).unwrap();
        assert!(diff > 0.05, "{diff}");
        assert!(flip(&r, &r, 31, 32, 1.0).is_err());
    }
}
