//! Screen-space ReSTIR GI (`restir-gi` and its compositions): layouts, no reuse equal to
//! `ris`'s indirect image, bias of the unbiased default against a converged reference on the
//! built-in scenes with a static and an orbiting camera (a planted wrong Jacobian and the
//! paper's biased mode caught by the same check) and of `restir-gi+world-restir`, no NaN/Inf
//! under 500 frames of motion, no history across a camera cut, determinism.

use restir_world::methods::{self, Composed, FrameMethod};
use restir_world::plant::Planted;
use restir_world::render::{RenderOptions, Renderer};
use restir_world::restir_gi::{self, GiReservoir, RestirGiConfig};
use restir_world::sampling::Estimator;
use restir_world::scene::{Camera, CameraPath, Scene};
use tests::bias::{channel_means, mean_over_seeds, relative, within};
use tests::gpu;
use tests::scenes::{MANY_LIGHTS, test_scene as scene};

/// `spec` at the default paths, seeded.
fn build(spec: &str, s: &Scene, cam: &Camera, seed: u32) -> Composed {
    gpu::build(spec, s, cam, gpu::planted(seed, Planted::None))
}

#[test]
fn layouts_match_wgsl() {
    let src = &restir_gi::kernels()[1].source;
    tests::assert_wgsl_layout!(
        GiReservoir,
        src,
        "GiReservoir",
        [position, ucw, radiance, normal_m]
    );
    tests::wgsl::assert_screen_params_layout(src, RestirGiConfig::GPU_WORDS);
    tests::assert_knobs_layout!(RestirGiConfig, src, "ScreenKnobs");
}

/// With reuse off, each pixel's reservoir holds its own path with W = 1 / its cosine pdf, and
/// shading it gives back the pixel's albedo x the radiance leaving x2: `ris`'s indirect
/// estimate, drawn from the same random streams. So at the same seed `restir-gi:no-reuse`'s
/// accumulated indirect image equals `ris`'s pixel by pixel (cornell and many-lights, 32x32,
/// 16 frames; tolerance 1e-4 relative + 1e-6 absolute per channel: float rounding of pi / cos
/// x cos / pi), which is more than equality in expectation. Control: the same run with its
/// light samples' pdf overstated by 10% (planted on the GPU; with reuse off nothing is merged
/// or shifted) must fail the same check.
#[test]
fn no_reuse_equals_ris_pixel_by_pixel() {
    const FRAMES: u32 = 16;
    let ctx = gpu::context();
    let close = |a: &[[f32; 3]], b: &[[f32; 3]]| {
        a.iter().zip(b).all(|(p, q)| {
            (0..3).all(|c| (p[c] - q[c]).abs() <= 1e-4 * q[c].abs().max(p[c].abs()) + 1e-6)
        })
    };
    for name in ["cornell", "many-lights"] {
        let (s, cam) = scene(name, 32);
        let mut ris = Renderer::with_options(
            ctx,
            &s,
            &cam,
            Estimator::Ris { candidates: 16 },
            &RenderOptions::seeded(5),
        )
        .expect("ris");
        gpu::render(&mut ris, FRAMES);
        let want = gpu::images(&ris).indirect;
        let run = |planted: Planted| {
            let mut m = gpu::build("restir-gi:no-reuse", &s, &cam, gpu::planted(5, planted));
            gpu::render(&mut m, FRAMES);
            gpu::images(&m).indirect
        };
        let got = run(Planted::None);
        let lit = want.iter().filter(|p| p[0] + p[1] + p[2] > 0.0).count();
        assert!(
            lit > want.len() / 2,
            "{name}: too little indirect light to compare"
        );
        assert!(
            close(&got, &want),
            "{name}: restir-gi:no-reuse differs from ris"
        );
        assert!(
            !close(&run(Planted::LightPdfOverstated), &want),
            "{name}: the control (light pdf overstated) passed"
        );
    }
}

/// Side and frames of the bias runs.
const BIAS_SIDE: u32 = 48;
const BIAS_FRAMES: u32 = 128;
/// Frames of the converged reference (`ris`, the same paths and camera path, seed 1000).
const REFERENCE_FRAMES: u32 = 512;
/// The check's bound, per channel.
const BOUND: f64 = 0.02;

/// The orbit of the moving-camera runs: 20 degrees over 16 frames, then back to the start.
const ORBIT: CameraPath = CameraPath::Orbit {
    frames: 16,
    degrees: 20.0,
};

/// The seeds of a scene's bias runs, sized to its noise. One run's 128-frame mean scatters
/// with a standard deviation near 2% on cornell and 2.7% on colonnade (seeds 1-9: a bright
/// path keeps being reused for many frames and spreads over the 48x48 image), under 1% on
/// many-lights and 0.4% on furnace; 9 seeds leave about 0.7% and 0.9%.
fn seeds(name: &str) -> std::ops::Range<u32> {
    match name {
        "cornell" | "colonnade" => 1..10,
        _ => 1..4,
    }
}

/// The indirect channel means of the converged reference, rendered once per key and kept on
/// disk (`tests::reference`). Its own standard error (512 frames of `ris`) is about a third of
/// a 9-seed mean's on cornell and colonnade and is part of the bounds' calibration below.
fn reference(name: &str, path: CameraPath) -> [f64; 3] {
    let key = format!(
        "restir_gi reference: ris seed 1000, {name} ({MANY_LIGHTS} lights) \
         {BIAS_SIDE}x{BIAS_SIDE}, {REFERENCE_FRAMES} frames of {path:?}, default paths"
    );
    tests::reference::cached_means(&key, || {
        let (s, cam) = scene(name, BIAS_SIDE);
        let mut r = build("ris", &s, &cam, 1000);
        gpu::render_path(&mut r, REFERENCE_FRAMES, path);
        channel_means(&gpu::images(&r).indirect)
    })
}

/// The relative bias of `spec`'s accumulated indirect mean (`BIAS_FRAMES` frames of `path`),
/// averaged over `seeds`, against the reference, with `planted` compiled into the method.
fn bias(
    spec: &str,
    name: &str,
    path: CameraPath,
    seeds: std::ops::Range<u32>,
    planted: Planted,
) -> [f64; 3] {
    let (s, cam) = scene(name, BIAS_SIDE);
    let got = mean_over_seeds(seeds, |seed| {
        let mut m = gpu::build(spec, &s, &cam, gpu::planted(seed, planted));
        gpu::render_path(&mut m, BIAS_FRAMES, path);
        channel_means(&gpu::images(&m).indirect)
    });
    relative(got, reference(name, path))
}

/// The unbiased default (pairwise MIS, a visibility ray per reconnection, temporal + spatial
/// reuse, 3 bounces) converges to the reference: the accumulated indirect mean of 128 frames at
/// 48x48, averaged over the scene's seeds, is within 2% of `ris`'s (512 frames, the same camera
/// path) in every channel on cornell, many-lights, furnace and colonnade, with a static camera
/// and orbiting. Measured on lavapipe (static / orbiting): cornell -0.93/-0.59/+0.79%,
/// -1.06/+0.61/+0.36%; many-lights +0.09/+0.04/-1.21%, -0.72/-0.25/-1.00%; furnace -0.08%,
/// -0.08%; colonnade -0.37/-0.22/-0.42%, -0.68/-0.72/-0.63%.
/// Controls, measured by the same check: on every scene (static, seed 20), the reuse passes
/// merging neighbours without their M, planted on the GPU; on cornell, where their defects show
/// most, the shift's Jacobian without its distance ratio, planted on the GPU (seeds 10-18,
/// measured -3.86/-2.30/-2.76%; on many-lights it measured -1.3/-1.1/-2.2% and on furnace
/// -1.0%, 4 seeds: the neighbours' distances to x2 differ little within 8 pixels), and the
/// paper's biased mode (1/M where pairwise MIS is the default, no visibility rays; seeds 10-12,
/// measured -10.8/-14.5/-14.4%). Each must leave the bound. One test per scene (they run in
/// parallel); the cornell-only controls are `wrong_jacobian_and_one_over_m_are_caught_on_cornell`.
fn assert_unbiased_on(name: &str) {
    let mut failed = Vec::new();
    for path in [CameraPath::Static, ORBIT] {
        let d = bias("restir-gi", name, path, seeds(name), Planted::None);
        eprintln!("restir-gi {name} {path:?}: bias {d:+.4?} (bound {BOUND})");
        if !within(d, BOUND) {
            failed.push(format!("{name} {path:?}: {d:+.4?}"));
        }
    }
    let merge = Planted::MergeWithoutM;
    let control = bias("restir-gi", name, CameraPath::Static, 20..21, merge);
    eprintln!("control, {name}, merged without M: {control:+.4?}");
    assert!(failed.is_empty(), "{failed:?} (bound {BOUND})");
    assert!(!within(control, BOUND), "the merge without M passed");
}

#[test]
fn unbiased_default_on_cornell() {
    assert_unbiased_on("cornell");
}

#[test]
fn unbiased_default_on_many_lights() {
    assert_unbiased_on("many-lights");
}

#[test]
fn unbiased_default_on_furnace() {
    assert_unbiased_on("furnace");
}

#[test]
fn unbiased_default_on_colonnade() {
    assert_unbiased_on("colonnade");
}

/// The controls of [`assert_unbiased_on`] that show where their defects show most, on cornell
/// (static), by the same check: the shift's Jacobian without its distance ratio, planted on the
/// GPU, and the paper's biased mode (1/M where pairwise MIS is the default).
#[test]
fn wrong_jacobian_and_one_over_m_are_caught_on_cornell() {
    let jacobian = Planted::JacobianWithoutDistance;
    let wrong_jacobian = bias("restir-gi", "cornell", CameraPath::Static, 10..19, jacobian);
    eprintln!("control, Jacobian without the distance ratio: {wrong_jacobian:+.4?}");
    let biased = bias(
        "restir-gi:biased",
        "cornell",
        CameraPath::Static,
        10..13,
        Planted::None,
    );
    eprintln!("control, the biased mode: {biased:+.4?}");
    assert!(!within(wrong_jacobian, BOUND), "the wrong Jacobian passed");
    assert!(!within(biased, BOUND), "the biased mode passed");
}

/// `restir-gi+world-restir` (world-restir's reservoirs light x2) at its defaults keeps the
/// indirect mean within the same 2% of the reference on many-lights (static), where
/// world-restir's light selection has the most to do; 9 seeds: seeds 1-3 alone measured
/// +1.90/+1.03/-0.27% and seeds 4-9 +0.04/+0.12/-0.42% (restir-gi alone on seeds 4-9:
/// -0.27/+0.09/-0.85%), so three seeds leave too little margin; seeds 1-9: +0.66/+0.43/-0.37%. (The full stack's indirect
/// image is this one's, bit for bit: `deterministic_and_the_direct_image_is_intact`.)
/// Control: its biased mode (1/M, no visibility rays, seed 10; measured -6.0/-6.4/-5.8%) must
/// leave the bound.
#[test]
fn restir_gi_over_world_restir_is_unbiased() {
    let (spec, name) = ("restir-gi+world-restir", "many-lights");
    let d = bias(spec, name, CameraPath::Static, 1..10, Planted::None);
    eprintln!("{spec} {name}: bias {d:+.4?} (bound {BOUND})");
    let biased = format!("{spec}:biased");
    let control = bias(&biased, name, CameraPath::Static, 10..11, Planted::None);
    eprintln!("control, {biased}: {control:+.4?}");
    assert!(within(d, BOUND), "{spec}: {d:+.4?} beyond {BOUND}");
    assert!(!within(control, BOUND), "the biased composition passed");
}

/// 500 frames at 32x32 on many-lights: orbiting (a full turn every 100 frames, frames 0-239),
/// still for 10 frames, then cut at frame 250 (turned round on the spot to look away from all
/// it saw) and still again. Every checked frame and the accumulated images are finite. After the
/// cut the reprojection finds nothing, so no pixel merges history: every final reservoir's M is
/// at most 1 + spatial-k, while the frame before the cut had reused history (M above that).
#[test]
fn camera_motion_and_a_cut_stay_finite_and_drop_history() {
    let ctx = gpu::context();
    let (s, cam) = scene("many-lights", 32);
    let k = RestirGiConfig::default().spatial_k;
    let mut m = build("restir-gi", &s, &cam, 7);
    let max_m = |m: &Composed| {
        let r = m.gi().unwrap().reservoirs(ctx).expect("reservoirs");
        r.iter().map(GiReservoir::m).max().unwrap_or(0)
    };
    gpu::check_cut_drops_history(&mut m, &cam, k, max_m);
}

/// Same seed, bit-identical images (restir-gi and the full stack, 8 frames of cornell at
/// 32x32); another seed differs. The direct image is left alone: restir-gi's is `ris`'s, bit
/// for bit, at the same seed; and ReSTIR DI leaves the paths alone: the full stack's indirect
/// image is restir-gi+world-restir's.
#[test]
fn deterministic_and_the_direct_image_is_intact() {
    let (s, cam) = scene("cornell", 32);
    let run = |spec: &str, seed: u32| {
        let mut m = build(spec, &s, &cam, seed);
        gpu::render(&mut m, 8);
        gpu::images(&m)
    };
    for spec in ["restir-gi", "restir-di+restir-gi+world-restir"] {
        gpu::check_seeded(run, spec, 3, |i| &i.indirect);
    }
    assert_eq!(run("restir-gi", 3).direct, run("ris", 3).direct);
    // ReSTIR DI leaves the paths alone: the full stack's indirect image is
    // restir-gi+world-restir's.
    assert_eq!(
        run("restir-di+restir-gi+world-restir", 3).indirect,
        run("restir-gi+world-restir", 3).indirect
    );
}

/// The knobs' errors name the knob; the debug views exist (M, rejected reconnections) and only
/// those.
#[test]
fn knob_errors_and_debug_views() {
    for (spec, knob) in [
        ("restir-gi:max-jacobian=0.5", "max-jacobian"),
        ("restir-gi:spatial-k=17", "spatial-k"),
        ("restir-gi:temporal-m-cap=0", "temporal-m-cap"),
        ("restir-gi:visibility=maybe", "visibility"),
    ] {
        let e = methods::check_spec(spec).unwrap_err().to_string();
        assert!(e.contains(knob), "{spec}: {e}");
    }
    let ctx = gpu::context();
    let (s, cam) = scene("cornell", 16);
    let mut m = build("restir-gi", &s, &cam, 1);
    gpu::render(&mut m, 4);
    use restir_world::render::DebugView;
    for view in [DebugView::M, DebugView::Rejected] {
        let img = m.debug_image(ctx, view).expect("debug").expect("a view");
        assert_eq!(img.len(), 256);
        assert!(
            img.iter().any(|p| p.iter().any(|&v| v > 0.0)),
            "{view:?} is black"
        );
    }
    assert!(m.debug_image(ctx, DebugView::Cells).unwrap().is_none());
}
