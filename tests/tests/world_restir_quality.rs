//! World-space ReSTIR GI against a converged reference: bias of the mean after N static frames
//! (measured and bounded, with a planted-bias control) and single-frame noise (relMSE) against
//! the `ris` and `nee` baselines at the same sample count. Images are 32x32 (bias) and 64x64
//! (noise) to keep the file near a minute on lavapipe.

use restir_world::render::{Method, Renderer};
use restir_world::scene::{BuiltinOptions, Camera, Scene, builtin};
use restir_world::world_restir::{self, WorldRestir, WorldRestirConfig};
use std::sync::Mutex;

use tests::gpu;

/// Side of the bias test's images.
const SIDE: u32 = 32;
/// Side of the noise test's images (at 32x32 cells hold too few vertices for reuse to pay).
const NOISE_SIDE: u32 = 64;
/// Frames of the converged reference (`ris`, 16 candidates).
const REFERENCE_FRAMES: u32 = 512;

fn scene(name: &str, side: u32) -> (Scene, Camera) {
    let opts = BuiltinOptions {
        width: side,
        height: side,
        lights: 2000,
        ..Default::default()
    };
    let s = builtin(name, &opts).expect("scene");
    let cam = s.camera_or_default(side, side);
    (s, cam)
}

/// The default knobs except a smaller table and a projected cell size scaled to the tiny
/// image: the paper's 16 px target is for 960x540 GI (1/34 of the height); at 32x32 that would
/// make a cell a quarter of the image, so the tests use 1/16 of the height (override with the
/// env var WR_PROJECTED, in pixels, to explore).
fn config(side: u32) -> WorldRestirConfig {
    WorldRestirConfig {
        buckets: Some(4096),
        projected_size: projected_size(side),
        ..Default::default()
    }
}

/// PROJECTED_FRACTION of the image height, or the env var WR_PROJECTED (pixels).
fn projected_size(side: u32) -> f32 {
    std::env::var("WR_PROJECTED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(side as f32 * PROJECTED_FRACTION)
}

/// 2 px at 32x32, 4 px at 64x64.
const PROJECTED_FRACTION: f32 = 1.0 / 16.0;

fn luminance(c: &[f32; 3]) -> f64 {
    0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2])
}

fn mean_lum(img: &[[f32; 3]]) -> f64 {
    img.iter().map(luminance).sum::<f64>() / img.len() as f64
}

/// relMSE = mean over pixels and channels of (I - R)^2 / (R^2 + 0.01) (DESIGN.md section 4).
fn rel_mse(img: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    let mut s = 0.0;
    for (a, r) in img.iter().zip(reference) {
        for c in 0..3 {
            let (a, r) = (f64::from(a[c]), f64::from(r[c]));
            s += (a - r).powi(2) / (r * r + 0.01);
        }
    }
    s / (3 * img.len()) as f64
}

/// (scene name, side, reference image).
type Cached = (String, u32, Vec<[f32; 3]>);

/// The converged reference of a scene at side x side, computed once per test binary.
fn reference(name: &str, side: u32) -> Vec<[f32; 3]> {
    static CACHE: Mutex<Vec<Cached>> = Mutex::new(Vec::new());
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, _, r)) = cache.iter().find(|(n, s, _)| n == name && *s == side) {
        return r.clone();
    }
    let ctx = gpu::context();
    let (s, cam) = scene(name, side);
    let mut r = Renderer::new(ctx, &s, &cam, Method::Ris { candidates: 16 }, 1000).expect("ris");
    r.render(ctx, REFERENCE_FRAMES, |_| {}).expect("render");
    let img = world_restir::read_accumulated(ctx, &r)
        .expect("images")
        .indirect;
    cache.push((name.to_owned(), side, img.clone()));
    img
}

/// Mean and standard error of batch means (frames of one run are correlated through the
/// temporal history; batches of 16 frames are treated as independent).
fn batch_mean_se(x: &[f64], batch: usize) -> (f64, f64) {
    let means: Vec<f64> = x
        .chunks(batch)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect();
    let n = means.len() as f64;
    let m = means.iter().sum::<f64>() / n;
    let var = means.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Bias after N static frames: world-restir (default config: 1 temporal + 4 spatial passes,
/// 4096 x 32 table) warms up for 8 frames, then the indirect image's mean luminance of each of
/// the next 128 frames is compared with the converged reference (`ris`, 512 frames); standard
/// error from 8 batch means of 16 frames.
///
/// Measured on lavapipe at 32x32 with 2 px projected cells: cornell -1.1% +- 0.9%, many-lights
/// +2.0% +- 2.0% (relative bias of the image mean +- one standard error). Earlier measurements
/// on cornell: -0.4% +- 0.8% with 4 px cells, -10.5% +- 2% with the paper's 16 px (a quarter
/// of this tiny image per cell): the technique is biased by design (normal test, no visibility
/// in the reuse target) and the bias grows with the cell size. Bound: |relative bias| < 5%.
/// Negative control: the same frames against the reference scaled by 0.85 must exceed it.
#[test]
fn bias_after_static_frames_is_bounded() {
    const WARMUP: u32 = 8;
    const FRAMES: usize = 128;
    const BOUND: f64 = 0.05;
    let ctx = gpu::context();
    for name in ["cornell", "many-lights"] {
        let (s, cam) = scene(name, SIDE);
        let reference = reference(name, SIDE);
        let ref_mean = mean_lum(&reference);
        let mut wr = WorldRestir::new(ctx, &s, &cam, config(SIDE), 100).expect("wr");
        wr.render(ctx, WARMUP, None, |_| {}).expect("warmup");
        let mut means = Vec::new();
        let mut mean_img = vec![[0.0f32; 3]; reference.len()];
        for _ in 0..FRAMES {
            wr.render(ctx, 1, None, |_| {}).expect("render");
            let img = wr.last_frame(ctx).expect("frame").indirect;
            means.push(mean_lum(&img));
            for (acc, p) in mean_img.iter_mut().zip(&img) {
                for c in 0..3 {
                    acc[c] += p[c] / FRAMES as f32;
                }
            }
        }
        let (mean, se) = batch_mean_se(&means, 16);
        let bias = (mean - ref_mean) / ref_mean;
        eprintln!(
            "bias {name} {SIDE}x{SIDE}: world-restir mean {mean:.5} (se {se:.5}) reference \
             {ref_mean:.5}: relative bias {bias:+.4} +- {:.4}; relMSE of the {FRAMES}-frame \
             mean image {:.5}",
            se / ref_mean,
            rel_mse(&mean_img, &reference)
        );
        assert!(bias.abs() < BOUND, "{name}: bias {bias:+.4} beyond {BOUND}");
        let planted = (mean - 0.85 * ref_mean) / (0.85 * ref_mean);
        assert!(
            planted.abs() >= BOUND,
            "{name}: a 15% planted reference error went unnoticed ({planted:+.4})"
        );
    }
}

/// Noise: relMSE of single frames' indirect images against the converged reference, for
/// world-restir (3 independent runs, frames 9..=24 of a static camera: temporal history built)
/// and for 16 frames each of `ris` (16 candidates) and `nee`, all at one GI path per pixel, on
/// many-lights at 64x64 (4 px projected cells).
///
/// Measured on lavapipe: ris/world-restir 2.12x, 1.39x, 1.24x (mean 1.50x) and nee/world-restir
/// 13.3x, 8.8x, 7.8x (mean 9.45x) in the three runs. At 32x32 (2 px cells) the `ris` factor swung between 0.46x
/// and 1.28x from run to run: with few vertices per cell, reused samples whose target is much
/// larger at the receiver than where they were generated (1/d^2 next to the small lights) make
/// persistent fireflies that dominate relMSE.
#[test]
fn single_frame_noise_lower_than_ris_and_nee_on_many_lights() {
    const FRAMES: u32 = 16;
    let ctx = gpu::context();
    let (s, cam) = scene("many-lights", NOISE_SIDE);
    let reference = reference("many-lights", NOISE_SIDE);
    let n = f64::from(FRAMES);
    let mut base = [0.0; 2];
    for (k, method) in [Method::Ris { candidates: 16 }, Method::Nee]
        .into_iter()
        .enumerate()
    {
        let mut r = Renderer::new(ctx, &s, &cam, method, 300).expect("baseline");
        for _ in 0..FRAMES {
            r.render(ctx, 1, |_| {}).expect("render");
            base[k] += rel_mse(
                &world_restir::read_last_frame(ctx, &r)
                    .expect("frame")
                    .indirect,
                &reference,
            ) / n;
        }
    }
    let [ris_err, nee_err] = base;
    let mut total = 0.0;
    for seed in 200..203 {
        let mut wr = WorldRestir::new(ctx, &s, &cam, config(NOISE_SIDE), seed).expect("wr");
        wr.render(ctx, 8, None, |_| {}).expect("warmup");
        let mut wr_err = 0.0;
        for _ in 0..FRAMES {
            wr.render(ctx, 1, None, |_| {}).expect("render");
            wr_err += rel_mse(&wr.last_frame(ctx).expect("frame").indirect, &reference) / n;
        }
        total += wr_err / 3.0;
        eprintln!(
            "noise many-lights {NOISE_SIDE}x{NOISE_SIDE} seed {seed}: relMSE world-restir \
             {wr_err:.4}, ris {ris_err:.4}, nee {nee_err:.4}: ris/world-restir {:.2}x, \
             nee/world-restir {:.2}x",
            ris_err / wr_err,
            nee_err / wr_err
        );
        assert!(
            wr_err < ris_err,
            "seed {seed}: world-restir not less noisy than ris"
        );
        assert!(
            wr_err < nee_err,
            "seed {seed}: world-restir not less noisy than nee"
        );
    }
    eprintln!(
        "noise many-lights {NOISE_SIDE}x{NOISE_SIDE} mean of 3 runs: world-restir {total:.4}: \
         ris/world-restir {:.2}x, nee/world-restir {:.2}x",
        ris_err / total,
        nee_err / total
    );
}
