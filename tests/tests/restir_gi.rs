//! ReSTIR GI, screen space (`restir-gi` and its compositions) and world space
//! (`world-restir-gi`, its neighbours from a grid of the primary vertices): layouts, no reuse
//! equal to `ris`'s indirect image, bias of the unbiased defaults against a converged reference
//! on the built-in scenes with a static, an orbiting and (world space) a dollying camera (a
//! planted wrong Jacobian, a merge without M and the biased mode caught by the same check) and
//! of `restir-gi+world-restir`, no NaN/Inf under 500 frames of motion, no history across a
//! camera cut, determinism.

use restir_world::methods::{self, Composed, FrameMethod};
use restir_world::metrics::rel_mse;
use restir_world::plant::Planted;
use restir_world::render::{RenderOptions, Renderer};
use restir_world::restir_gi::{
    self, GiReservoir, HistoryOrigin, RestirGiConfig, WorldRestirGiConfig,
};
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
        [
            position, ucw, radiance, normal_m, material, base, shading, light
        ]
    );
    tests::wgsl::assert_screen_params_layout(src, RestirGiConfig::GPU_WORDS);
    tests::assert_knobs_layout!(RestirGiConfig, src, "ScreenKnobs");
    let src = &restir_gi::world::kernels()[1].source;
    tests::wgsl::assert_screen_params_layout(src, WorldRestirGiConfig::GPU_WORDS);
    tests::assert_knobs_layout!(WorldRestirGiConfig, src, "ScreenKnobs");
}

/// With reuse off, each pixel's reservoir holds its own path with W = 1 / its cosine pdf, and
/// shading it gives back the pixel's albedo x the radiance leaving x2: `ris`'s indirect
/// estimate, drawn from the same random streams. So at the same seed `restir-gi:no-reuse`'s
/// and `world-restir-gi:no-reuse`'s (whose grid is built and unused) accumulated indirect
/// images equal `ris`'s pixel by pixel (cornell and many-lights, 32x32,
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
        let lit = want.iter().filter(|p| p[0] + p[1] + p[2] > 0.0).count();
        assert!(
            lit > want.len() / 2,
            "{name}: too little indirect light to compare"
        );
        for spec in ["restir-gi:no-reuse", "world-restir-gi:no-reuse"] {
            let run = |planted: Planted| {
                let mut m = gpu::build(spec, &s, &cam, gpu::planted(5, planted));
                gpu::render(&mut m, FRAMES);
                gpu::images(&m).indirect
            };
            assert!(
                close(&run(Planted::None), &want),
                "{name}: {spec} differs from ris"
            );
            assert!(
                !close(&run(Planted::LightPdfOverstated), &want),
                "{name}: {spec}'s control (light pdf overstated) passed"
            );
        }
    }
}

/// Side and frames of the bias runs.
const BIAS_SIDE: u32 = 48;
const BIAS_FRAMES: u32 = 128;
/// Frames of the controls that merge without M: once the reservoirs hold history (a few
/// frames) that defect darkens the image by 39-98% here, far past the bound, so it is caught
/// in a quarter of the check's frames.
const CONTROL_FRAMES: u32 = 32;
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
/// many-lights and 0.4% on furnace; 9 seeds leave about 0.7% and 0.9%. Cornell runs 18: with
/// `visibility=selected` restir-gi's orbiting seeds 1-9 measured -2.2/+1.6/+1.0% and seeds
/// 10-18 +1.1/+0.1/+0.4% (a 9-seed mean scatters by 1.1-1.7% per channel there).
fn seeds(name: &str) -> std::ops::Range<u32> {
    match name {
        "cornell" => 1..19,
        "colonnade" => 1..10,
        _ => 1..4,
    }
}

/// The indirect channel means of the converged reference, rendered once per key and kept on
/// disk (`tests::reference`). Its own standard error (512 frames of `ris`) is about a third of
/// a 9-seed mean's on cornell and colonnade and is part of the bounds' calibration below. The
/// closed furnace needs no render: every pixel's indirect light is Le (rho^2 + ... +
/// rho^(bounces + 1)) wherever the camera is.
fn reference(name: &str, path: CameraPath) -> [f64; 3] {
    if name == "furnace" {
        let o = restir_world::scene::BuiltinOptions::default();
        let bounces = restir_world::sampling::Paths::default().bounces;
        let v = f64::from(o.le) * tests::scenes::furnace_indirect(f64::from(o.rho), bounces);
        return [v; 3];
    }
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
/// averaged over `seeds`, against the reference, with `planted` in the method.
fn bias(
    spec: &str,
    name: &str,
    path: CameraPath,
    seeds: std::ops::Range<u32>,
    planted: Planted,
) -> [f64; 3] {
    bias_over(spec, name, path, seeds, planted, BIAS_FRAMES)
}

/// [`bias`] over `frames` frames of `path` (the same camera path and reference).
fn bias_over(
    spec: &str,
    name: &str,
    path: CameraPath,
    seeds: std::ops::Range<u32>,
    planted: Planted,
    frames: u32,
) -> [f64; 3] {
    let (s, cam) = scene(name, BIAS_SIDE);
    let got = mean_over_seeds(seeds, |seed| {
        let mut m = gpu::build(spec, &s, &cam, gpu::planted(seed, planted));
        gpu::render_path(&mut m, frames, path);
        channel_means(&gpu::images(&m).indirect)
    });
    relative(got, reference(name, path))
}

/// The control of a check of `spec` on `name` along `path`: seed 20 merging without M,
/// [`CONTROL_FRAMES`] frames.
fn merged_without_m(spec: &str, name: &str, path: CameraPath) -> [f64; 3] {
    let merge = Planted::MergeWithoutM;
    bias_over(spec, name, path, 20..21, merge, CONTROL_FRAMES)
}

/// The unbiased default (pairwise MIS, the back ray per neighbour and the forward ray for the
/// selected sample, temporal + spatial reuse, 3 bounces) converges to the reference: the
/// accumulated indirect mean of 128 frames at 48x48, averaged over the scene's seeds, is within
/// 2% of `ris`'s (512 frames, the same camera path) in every channel on cornell, many-lights,
/// furnace and colonnade, with a static camera and orbiting. Measured on lavapipe at
/// `visibility=selected` (2026-12-05; static / orbiting): cornell -0.2/+0.2/-0.2%,
/// -0.5/+0.9/+0.7% (18 seeds); many-lights -0.2/+0.1/-0.9%, -0.7/-0.1/-1.0%; furnace -0.0%,
/// -0.0% (against its analytic value); colonnade -0.4/-0.2/-0.4%, -0.7/-0.7/-0.6%. At `on`
/// (the default before): cornell -0.9/-0.6/+0.8%, -1.1/+0.6/+0.4% (9 seeds); many-lights
/// +0.1/+0.0/-1.2%, -0.7/-0.3/-1.0%; colonnade -0.4/-0.2/-0.4%, -0.7/-0.7/-0.6%.
/// Controls, measured by the same check: on every scene (static, seed 20, 32 frames: -69% on
/// many-lights to -95% on the furnace), the reuse passes merging neighbours without their M,
/// planted on the GPU; on cornell, where their defects show
/// most, the shift's Jacobian without its distance ratio, planted on the GPU (seeds 10-18,
/// measured -3.1/-2.4/-1.8%, at `on` -3.9/-2.3/-2.8%; on many-lights it measured
/// -1.3/-1.1/-2.2% and on furnace -1.0%, 4 seeds: the neighbours' distances to x2 differ
/// little within 8 pixels), and the paper's biased mode (1/M where pairwise MIS is the
/// default, no visibility rays; seeds 10-12, measured -10.8/-14.5/-14.4%). Each must leave the
/// bound. One test per scene (they run in parallel); the cornell-only controls are
/// `wrong_jacobian_and_one_over_m_are_caught_on_cornell`.
fn assert_unbiased_on(name: &str) {
    assert_spec_unbiased_on("restir-gi", name, &[CameraPath::Static, ORBIT], seeds(name));
}

/// `spec`'s check on scene `name` along each of `paths`, with the merge without M (static,
/// seed 20, [`CONTROL_FRAMES`] frames) as the control that must leave the bound.
fn assert_spec_unbiased_on(
    spec: &str,
    name: &str,
    paths: &[CameraPath],
    seeds: std::ops::Range<u32>,
) {
    let mut failed = Vec::new();
    for &path in paths {
        let d = bias(spec, name, path, seeds.clone(), Planted::None);
        eprintln!("{spec} {name} {path:?}: bias {d:+.4?} (bound {BOUND})");
        if !within(d, BOUND) {
            failed.push(format!("{name} {path:?}: {d:+.4?}"));
        }
    }
    let control = merged_without_m(spec, name, CameraPath::Static);
    eprintln!("control, {spec} {name}, merged without M: {control:+.4?}");
    assert!(failed.is_empty(), "{spec}: {failed:?} (bound {BOUND})");
    assert!(
        !within(control, BOUND),
        "{spec}: the merge without M passed"
    );
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

/// The dolly of world-restir-gi's moving-camera runs: a third of the way towards the target
/// over 16 frames, then back to the start.
const DOLLY: CameraPath = CameraPath::Dolly {
    frames: 16,
    fraction: 0.3,
};

/// World-space ReSTIR GI's unbiased default (pairwise MIS, the back ray per neighbour and the
/// forward ray for the selected sample, temporal reuse from last frame's reprojected pixel or,
/// where it has none, last frame's cell and the pool, spatial reuse from this frame's cell, 3
/// bounces) converges to the reference by [`assert_unbiased_on`]'s check (128 frames at 48x48, 2%
/// per channel, the scene's seeds; on cornell seeds 1-18, on many-lights 1-9) on `paths`. Measured
/// on lavapipe at `visibility=selected` (2026-12-05): cornell static +1.4/-0.4/-0.4%; colonnade
/// static -1.0/-1.1/-1.3%; many-lights static, orbiting, dollying -0.7/-0.5/-1.2%, -0.5/-0.1/-0.3%,
/// -1.8/-0.8/-1.9%; furnace +0.2%, +0.2%, -0.7%. At `on` (the default before; 2026-12-05, with the
/// reprojection): cornell static +0.8/-0.2/-0.2% (seeds 1-18; each seed's mean scatters by 2.5%
/// there and by 3.4% on an NVIDIA H200); colonnade static -0.8/-0.9/-1.2%; many-lights static,
/// orbiting, dollying +0.3/+0.3/-1.1%, -0.4/-0.0/-0.3%, -1.6/-1.1/-1.7% over seeds 1-9, where seeds
/// 1-3 alone measured +1.6/+1.6/-2.0% and -2.6/-0.7/-2.7% still and dollying (seeds 4-9
/// -0.4/-0.4/-0.7%, -1.1/-1.2/-1.2%): with the receiver's own pixel merged every frame a pixel's
/// chain is longer and a 3-seed mean scatters past the bound; furnace +0.2%, +0.2%, -0.7%. Before
/// the reprojection (2026-12-04, the cell's items only): cornell -0.3/-0.0/+0.1%, colonnade
/// +1.7/+1.4/+1.3%, many-lights (seeds 1-3) -0.2/+0.7/+0.3%, +0.8/+0.8/+1.4%, -1.7/-0.8/-1.6%;
/// dollying, seeds 1-9 measured -1.3/-1.2/-1.4% then and restir-gi -0.5/-0.1/-1.3%. The motion runs
/// are on the scenes whose seeds scatter least (many-lights, furnace); cornell and colonnade (the
/// slowest) are static only: cornell's noise and the suite's time are the limits. Measured and
/// not checked, at `selected` (2026-12-05): cornell orbiting and dollying +0.5/+0.6/+1.1% and
/// +1.0/-0.4/-0.7% (seeds 1-18); colonnade orbiting -1.0/-1.1/-1.0% (seeds 1-9), dollying
/// -1.6/-1.8/-1.8% over seeds 1-45, whose 9-seed means scatter from -3.6/-3.8/-4.0% (seeds
/// 1-9; at `on` -3.5/-3.7/-3.9%) to -0.3/-0.5/-0.7% (restir-gi dollying, seeds 1-27,
/// -0.9/-1.0/-1.1%): checking it would take about 45 seeds. Most of that is this file's
/// reference, not the method (2026-12-07, seeds 1-64 or 1-256, green channel, mean +- standard
/// error against the reference): `ris` itself reads -0.67 +- 0.13% on colonnade dollying (the
/// one-seed 512-frame reference reads high by that), restir-gi -1.08 +- 0.31%, world-restir-gi
/// -1.26 +- 0.24% (256 seeds): -0.4 +- 0.3% and -0.6 +- 0.3% against `ris`, no bias resolved
/// at 0.5%; many-lights dollying, against `ris` (64 seeds): world-restir-gi
/// -0.0/+0.1/-0.4 +- 0.3%, restir-gi -0.2/-0.2/-0.6 +- 0.2%. Control on every
/// scene: merging without M (static, seed 20, 32 frames: -85% to -95%) must leave the bound. The
/// Jacobian that loses its distance ratio is restir-gi's shift, the same code, caught by
/// `wrong_jacobian_and_one_over_m_are_caught_on_cornell` (with world-space neighbours, whose
/// distances to x2 differ little, it measured only -0.8/-1.6/-2.8% over 9 seeds on cornell).
fn assert_world_unbiased_on(name: &str, paths: &[CameraPath]) {
    let seeds = match name {
        "many-lights" => 1..10,
        _ => seeds(name),
    };
    assert_spec_unbiased_on("world-restir-gi", name, paths, seeds);
}

/// [`assert_world_unbiased_on`] cornell, static; controls by the same check: its biased mode
/// (1/M weights, no visibility rays; seed 10, measured -13/-18/-17%) and the selected sample
/// left untested (`Planted::ForwardUntested`, seed 20, 32 frames: an occluded neighbour's
/// sample lights the receiver and is reused again; measured +170,195/+170,150/+181,956%, the
/// mean 1,700 times the reference).
/// Orbiting, a 9-seed mean scatters by 1.1-1.7% per channel here (seeds 1-9 measured
/// +0.6/+1.6/+2.7%, seeds 10-18 +1.7/+0.7/+0.4%: +1.2/+1.2/+1.5% over the 18), too much for a 2%
/// bound to decide; the motion runs are many-lights' and the furnace's.
#[test]
fn world_restir_gi_unbiased_on_cornell() {
    assert_world_unbiased_on("cornell", &[CameraPath::Static]);
    let biased = "world-restir-gi:biased";
    let control = bias(biased, "cornell", CameraPath::Static, 10..11, Planted::None);
    eprintln!("control, {biased}: {control:+.4?}");
    let untested = Planted::ForwardUntested;
    let still = CameraPath::Static;
    let forward = bias_over(
        "world-restir-gi",
        "cornell",
        still,
        20..21,
        untested,
        CONTROL_FRAMES,
    );
    eprintln!("control, world-restir-gi, {untested:?}: {forward:+.4?}");
    assert!(!within(control, BOUND), "the biased mode passed");
    assert!(
        !within(forward, BOUND),
        "the selected sample left untested passed"
    );
}

#[test]
fn world_restir_gi_unbiased_on_many_lights() {
    assert_world_unbiased_on("many-lights", &[CameraPath::Static, ORBIT, DOLLY]);
}

/// world-restir (light reuse, whose temporal pass looks last frame's vertices up in last
/// frame's grid, built from last frame's eye) with an orbiting camera, by the same check
/// against the same reference as restir-gi's, on many-lights (where it pays), over 9 seeds:
/// its 3-seed means scatter by about 1.3% per channel (seeds 1-3 +1.6/+0.9/+1.6%, 4-6
/// -0.2/+0.6/+1.1%, 7-9 -0.0/-1.0/-1.6%, 10-12 +0.0/+0.8/+0.7%), too much for the bound at 3;
/// seeds 1-9 measured +0.5/+0.2/+0.4%, the control -39% in every channel. Its static bias is
/// world_restir_quality.rs's. Control: its reuse merging without M (seed 20, orbiting, 32
/// frames).
#[test]
fn world_restir_unbiased_on_many_lights_orbiting() {
    let d = bias("world-restir", "many-lights", ORBIT, 1..10, Planted::None);
    eprintln!("world-restir many-lights orbiting: bias {d:+.4?} (bound {BOUND})");
    let control = merged_without_m("world-restir", "many-lights", ORBIT);
    eprintln!("control, world-restir merged without M: {control:+.4?}");
    assert!(within(d, BOUND), "world-restir orbiting: {d:+.4?}");
    assert!(!within(control, BOUND), "the merge without M passed");
}

/// [`world_restir_unbiased_on_many_lights_orbiting`] on cornell and colonnade, whose 3-seed
/// means scatter little with world-restir (cornell seeds 1-3, 4-6, 7-9: +0.3/+0.3/+0.8%,
/// +0.4/+0.5/+0.9%, +0.5/+0.5/+1.0%; colonnade +0.2/+0.2/+0.3%, -0.7/-0.6/-0.6%,
/// -0.7/-0.8/-0.8%): seeds 1-3, the controls merging without M (seed 20, static, 32 frames:
/// cornell -55/-57/-62%, colonnade -26/-26/-28%).
#[test]
fn world_restir_unbiased_on_cornell_and_colonnade_orbiting() {
    for name in ["cornell", "colonnade"] {
        let d = bias("world-restir", name, ORBIT, 1..4, Planted::None);
        eprintln!("world-restir {name} orbiting: bias {d:+.4?} (bound {BOUND})");
        assert!(within(d, BOUND), "world-restir {name} orbiting: {d:+.4?}");
        let control = merged_without_m("world-restir", name, CameraPath::Static);
        eprintln!("control, world-restir {name} merged without M: {control:+.4?}");
        assert!(
            !within(control, BOUND),
            "{name}: the merge without M passed"
        );
    }
}

/// world-restir-gi's sub-path reuse (`world-restir-gi:subpath`, subpath-k=1: each pixel's
/// secondary vertex x2 resamples a path sample this frame's pixels left in its cell, its
/// radiance one vertex short, before the initial pass) converges to the reference by
/// [`assert_unbiased_on`]'s check (128 frames at 48x48, 2% per channel) on cornell, static,
/// seeds 1-9 (measured at the default `visibility=selected` -1.0/+0.1/+0.6%; at `on`
/// -1.1/-0.4/-1.0%, seeds 1-18 -0.1/-0.5/-0.8%: 9 keep the suite's time, a 9-seed mean
/// scattering by about 0.8% here). Control by the same check: the candidates whose GI ray
/// escaped left out of the sub-path pass's MIS (planted on the GPU, seeds 20-25, measured
/// +3.5/+4.3/+3.1%, at `on` +5.5/+4.1/+3.5%), the defect this check caught while the pass was
/// written. Measured beside
/// it and not checked (the suite's time): many-lights static and orbiting (seeds 1-9)
/// -0.3/-0.6/-2.4% and -0.4/-0.2/-0.3%, colonnade static -0.7/-0.7/-0.9%; there the planted
/// defects show less (the escaped candidates +1.6/+1.7/+2.3% on colonnade and none on the closed
/// many-lights hall; samples one bounce too deep, `Planted::SubpathFullDepth`, +2.6/+2.4/+2.3% on
/// colonnade, +1.0/+1.1/+1.6% on many-lights, -0.2/-0.2/-0.8% on cornell, seeds 20-22), and the
/// furnace's camera sees one wall, which no secondary vertex lies on. What it guards that no
/// other test does: the path split and the sub-path pass's MIS.
#[test]
fn world_restir_gi_subpath_unbiased_on_cornell() {
    let escaped = Planted::SubpathSkipsEscaped;
    assert_variant_unbiased_on_cornell("world-restir-gi:subpath", (escaped, 20..26, BIAS_FRAMES));
}

/// A variant's check on still cornell, seeds 1-9, with its control (a defect planted over
/// seeds `control.1`, `control.2` frames each) by the same check, which must leave the bound.
fn assert_variant_unbiased_on_cornell(spec: &str, control: (Planted, std::ops::Range<u32>, u32)) {
    let (planted, control_seeds, control_frames) = control;
    let still = CameraPath::Static;
    let d = bias(spec, "cornell", still, 1..10, Planted::None);
    eprintln!("{spec} cornell: bias {d:+.4?} (bound {BOUND})");
    let c = bias_over(
        spec,
        "cornell",
        still,
        control_seeds,
        planted,
        control_frames,
    );
    eprintln!("control, {spec} cornell, {planted:?}: {c:+.4?}");
    assert!(within(d, BOUND), "{spec} cornell: {d:+.4?} (bound {BOUND})");
    assert!(!within(c, BOUND), "{spec}: the control {planted:?} passed");
}

/// `visibility=on` (the variant `all-visibility`, the default until 2026-12-05): both rays for
/// every neighbour, the forward ray (the receiver's x1 to a neighbour's x2) inside the targets,
/// where the default traces it only for the sample a merge selects. world-restir-gi with it
/// converges to the reference by [`assert_unbiased_on`]'s check (128 frames at 48x48, 2% per
/// channel) on cornell, static, seeds 1-9 (measured +0.8/+0.1/+0.2%). Control by the same check:
/// the forward ray never traced (`Planted::ForwardUntested`, seed 20, 32 frames), where an occluded
/// neighbour's sample lights the receiver (measured +170,195/+170,150/+181,956%: without its
/// forward ray `on` is the default without the test after the merge, the same images). What it
/// guards that no other test does: the targets with visibility (`gi_pair`'s forward ray).
#[test]
fn world_restir_gi_all_visibility_unbiased_on_cornell() {
    let untested = Planted::ForwardUntested;
    let spec = "world-restir-gi:all-visibility";
    assert_variant_unbiased_on_cornell(spec, (untested, 20..21, CONTROL_FRAMES));
}

#[test]
fn world_restir_gi_unbiased_on_furnace() {
    assert_world_unbiased_on("furnace", &[CameraPath::Static, ORBIT, DOLLY]);
}

#[test]
fn world_restir_gi_unbiased_on_colonnade() {
    assert_world_unbiased_on("colonnade", &[CameraPath::Static]);
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
    let max_m = |m: &Composed| {
        let r = m.gi().unwrap().reservoirs(ctx).expect("reservoirs");
        r.iter().map(GiReservoir::m).max().unwrap_or(0)
    };
    let k = RestirGiConfig::default().spatial_k;
    let mut m = build("restir-gi", &s, &cam, 7);
    gpu::check_cut_drops_history(&mut m, &cam, k, max_m);
}

/// World-restir-gi under [`camera_motion_and_a_cut_stay_finite_and_drop_history`]'s 500
/// frames (orbit, hold, cut, hold; many-lights at 32x32): every checked frame and the
/// accumulated images are finite; no final reservoir's M is past what one frame can merge
/// (its own 1, then temporal-k and spatial-k neighbours of at most temporal-m-cap each); and
/// 249 frames after the cut the pool holds no record older than history-frames, at most one
/// per pixel (those of the cells out of view were evicted).
#[test]
fn world_restir_gi_motion_and_a_cut_stay_finite_bounded_and_evicted() {
    use tests::scenes::{cut_checkpoints, orbit_then_cut};
    let ctx = gpu::context();
    let (s, cam) = scene("many-lights", 32);
    let c = WorldRestirGiConfig::default();
    let most_m = 1 + (c.temporal_k + c.spatial_k) * c.temporal_m_cap;
    let mut m = build("world-restir-gi", &s, &cam, 7);
    let finite = |img: &[[f32; 3]]| img.iter().flatten().all(|v| v.is_finite());
    let mut next = 0;
    for frame in cut_checkpoints() {
        gpu::render_cameras(&mut m, next..frame + 1, |k| Some(orbit_then_cut(&cam, k)));
        next = frame + 1;
        let last = gpu::last_frame(&m);
        assert!(finite(&last.indirect), "frame {frame}: indirect not finite");
        let r = m.gi().unwrap().reservoirs(ctx).expect("reservoirs");
        let max_m = r.iter().map(GiReservoir::m).max().unwrap_or(0);
        assert!(max_m <= most_m, "frame {frame}: M {max_m} past {most_m}");
    }
    let (ages, wanted) = m.gi().unwrap().pool(ctx).expect("pool").expect("a pool");
    let oldest = ages.iter().copied().max().unwrap_or(0);
    assert!(oldest <= c.history_frames, "a record of age {oldest} kept");
    assert!(
        !ages.is_empty() && ages.len() <= 32 * 32,
        "{} records",
        ages.len()
    );
    assert!(wanted as usize >= ages.len());
    let acc = gpu::images(&m);
    assert!(finite(&acc.direct) && finite(&acc.indirect));
}

/// A camera cut away and back: 16 frames of cornell's view (48x48), 4 frames turned round on
/// the spot (another wall), then the first view again. World-restir-gi's pool keeps its cells'
/// path samples while they are out of view, so on the frame back its temporal pass merges them
/// (final M past 1 + spatial-k somewhere), where restir-gi, whose history is last frame's
/// screen, starts again (M at most 1 + spatial-k); and the indirect error of the two frames
/// after the cut back (frame relMSE against a converged `ris` reference of the view, summed
/// over the two, median over seeds 1-6) is lower than restir-gi's. Control of the history
/// check: world-restir-gi with `history-frames=0` (its pool keeps last frame's cells only) has
/// none on the frame back (seed 1). Where the temporal neighbours came from (the debug view
/// History): on frame 15, still, the reprojected pixel for more than 3/4 of the pixels; on the
/// frame back none, and some pooled records, the youngest 5 frames old (HistoryAge; the oldest
/// measured 6-9 over seeds 1-6). Measured with the reprojection (2026-12-05,
/// seeds 1-6): 0.112 against restir-gi's 0.203 (`history-frames=0`, seed 1: 0.119). Before it,
/// over seeds 1-27 (median error): lavapipe 0.118
/// (restir-gi 0.186, `history-frames=0` 0.128; with the pooled records merged at their full M,
/// `pool-m-cap=20`, 0.227, which this test's former 3-seed sums hid); an NVIDIA H200 with
/// `pool-m-cap=20` 0.169 (restir-gi 0.191, `history-frames=0` 0.128). The error comparison has
/// no control that fails it: over seeds 1-6 `pool-m-cap=20` measured 0.147 (two of its seeds
/// at 0.35 and 0.37, the median below restir-gi's 0.203), and the merge without M and a
/// missing bounce measured below it too (0.130, 0.093).
#[test]
fn world_restir_gi_keeps_history_across_a_cut_and_back() {
    const SIDE: u32 = 48;
    let ctx = gpu::context();
    let (s, cam) = scene("cornell", SIDE);
    let away = Camera {
        target: cam.eye + (cam.eye - cam.target),
        ..cam
    };
    let camera = |k: u32| Some(if (16..20).contains(&k) { away } else { cam });
    let key = format!(
        "restir_gi cut-and-back reference: ris seed 1000, cornell {SIDE}x{SIDE}, 512 frames, default paths"
    );
    let pixels = (SIDE * SIDE) as usize;
    let reference = tests::reference::cached_image(&key, pixels, || {
        let mut r = build("ris", &s, &cam, 1000);
        gpu::render(&mut r, 512);
        gpu::images(&r).indirect
    });
    let k = WorldRestirGiConfig::default().spatial_k;
    // Pixels whose temporal neighbour came from each origin (world-restir-gi's; none for
    // restir-gi), and the least and most age of the pooled ones' samples.
    let origins = |m: &Composed| {
        let gi = m.gi().unwrap();
        let o = gi
            .history_origins(ctx)
            .expect("origins")
            .unwrap_or_default();
        let ages = gi.history_ages(ctx).expect("ages").unwrap_or_default();
        let count = |k| o.iter().filter(|&&x| x == k).count();
        let pooled = o
            .iter()
            .zip(&ages)
            .filter(|(o, _)| **o == HistoryOrigin::Pool);
        let ages = pooled.map(|(_, &a)| a);
        (
            count(HistoryOrigin::Reprojected),
            count(HistoryOrigin::Pool),
            (ages.clone().min(), ages.max()),
        )
    };
    // (max M on the frame back, median over `seeds` of the two frames' summed relMSE).
    let run = |spec: &str, seeds: std::ops::Range<u32>| {
        let (mut max_m, mut errs) = (0, Vec::new());
        for seed in seeds {
            let mut m = build(spec, &s, &cam, seed);
            gpu::render_cameras(&mut m, 0..16, camera);
            let still = origins(&m);
            gpu::render_cameras(&mut m, 16..21, camera);
            let back = origins(&m);
            if spec == "world-restir-gi" {
                eprintln!("seed {seed}: (reprojected, pooled) still {still:?}, back {back:?}");
                // Still, the temporal neighbour is the reprojected pixel nearly everywhere; on
                // the frame back the last camera looked away, so none is, and the pool serves.
                assert!(
                    still.0 > pixels * 3 / 4,
                    "seed {seed}: reprojected {still:?} of {pixels}"
                );
                assert!(
                    back.0 == 0 && back.1 > 0,
                    "seed {seed}: on the frame back {back:?}"
                );
                // The pooled samples' ages (the debug view HistoryAge): none resampled while
                // the camera looked away, so at least 5 frames old (frame 15, the last still
                // one; cells its pixels missed at the view's edge, older), at most the pool's
                // history-frames + 2.
                let most = WorldRestirGiConfig::default().history_frames + 2;
                let (young, old) = back.2;
                assert!(
                    young == Some(5) && old.is_some_and(|a| a <= most),
                    "seed {seed}: pooled samples' ages {:?}",
                    back.2
                );
            }
            let r = m.gi().unwrap().reservoirs(ctx).expect("reservoirs");
            max_m = max_m.max(r.iter().map(GiReservoir::m).max().unwrap_or(0));
            let mut err = rel_mse(&gpu::last_frame(&m).indirect, &reference).expect("relMSE");
            gpu::render_cameras(&mut m, 21..22, camera);
            err += rel_mse(&gpu::last_frame(&m).indirect, &reference).expect("relMSE");
            errs.push(err);
        }
        errs.sort_by(f64::total_cmp);
        let median = (errs[(errs.len() - 1) / 2] + errs[errs.len() / 2]) / 2.0;
        eprintln!(
            "{spec}: M on the frame back up to {max_m}, median relMSE of the two frames after {median:.4} ({errs:.4?})"
        );
        (max_m, median)
    };
    let (world_m, world_err) = run("world-restir-gi", 1..7);
    let (screen_m, screen_err) = run("restir-gi", 1..7);
    let (control_m, _) = run("world-restir-gi:history-frames=0", 1..2);
    assert!(
        world_m > 1 + k,
        "world-restir-gi merged no history after the cut back"
    );
    assert!(
        screen_m <= 1 + k,
        "restir-gi kept history across the cut: M {screen_m}"
    );
    assert!(
        control_m <= 1 + k,
        "the control (history-frames=0) kept history: M {control_m}"
    );
    assert!(
        world_err < screen_err,
        "world-restir-gi's error after the cut back {world_err} is not below restir-gi's \
         {screen_err}"
    );
}

/// Same seed, bit-identical images (restir-gi, the full stack and world-restir-gi, whose cells
/// list their pixels in order, 8 frames of cornell at 32x32); another seed differs. The direct
/// image is left alone: restir-gi's and world-restir-gi's are `ris`'s, bit
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
    for spec in [
        "restir-gi",
        "restir-di+restir-gi+world-restir",
        "world-restir-gi",
    ] {
        gpu::check_seeded(run, spec, 3, |i| &i.indirect);
    }
    let ris = run("ris", 3).direct;
    assert_eq!(run("restir-gi", 3).direct, ris);
    assert_eq!(run("world-restir-gi", 3).direct, ris);
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
        ("world-restir-gi:temporal-k=0", "temporal-k"),
        ("world-restir-gi:projected-size=0", "projected-size"),
        ("world-restir-gi:spatial-radius=4", "spatial-radius"),
        ("world-restir-gi:history-frames=1001", "history-frames"),
    ] {
        let e = methods::check_spec(spec).unwrap_err().to_string();
        assert!(e.contains(knob), "{spec}: {e}");
    }
    let ctx = gpu::context();
    let (s, cam) = scene("cornell", 16);
    use restir_world::render::DebugView;
    for spec in ["restir-gi", "world-restir-gi"] {
        let mut m = build(spec, &s, &cam, 1);
        gpu::render(&mut m, 4);
        let views: &[DebugView] = match spec {
            "world-restir-gi" => &[
                DebugView::M,
                DebugView::Rejected,
                DebugView::History,
                DebugView::HistoryAge,
            ],
            _ => &[DebugView::M, DebugView::Rejected],
        };
        for &view in views {
            let img = m.debug_image(ctx, view).expect("debug").expect("a view");
            assert_eq!(img.len(), 256);
            assert!(
                img.iter().any(|p| p.iter().any(|&v| v > 0.0)),
                "{spec}: {view:?} is black"
            );
        }
    }
    // The settings say which views a method draws (the viewer offers those and refuses
    // others): each of them drawn, no other.
    for spec in [
        "nee",
        "restir-gi",
        "world-restir-gi",
        "restir-gi+world-restir",
    ] {
        let mut m = build(spec, &s, &cam, 1);
        gpu::render(&mut m, 1);
        let views = methods::parse_spec(spec).unwrap().debug_views();
        for view in DebugView::ALL {
            let drawn = m.debug_image(ctx, view).unwrap().is_some();
            assert_eq!(drawn, views.contains(&view), "{spec}: {view:?}");
        }
    }
}

/// Guards the refusal view (`DebugView::Refused`: why path reuse refused a pixel's
/// reconnections), which no other check reads: on cornell-glossy (32x32, 4 frames, seed 1) at
/// the defaults, restir-gi and world-restir-gi mark exactly the pixels whose primary vertex is
/// glossy as too smooth to take part (`min-roughness` 1: grey), and some diffuse pixels as
/// seeing a secondary vertex too smooth to reconnect to (`x2-min-roughness` 0.5: the metal
/// blocks and the polished floor; blue); with both knobs at 0 neither reason shows. The
/// shift's and the visibility's refusals (red, green) show on some pixel either way.
#[test]
fn refusal_view_names_the_reason() {
    use restir_world::render::DebugView;
    let ctx = gpu::context();
    let (s, cam) = tests::scenes::builtin_square("cornell-glossy", 32, Default::default());
    for method in ["restir-gi", "world-restir-gi"] {
        for knobs in ["", ":min-roughness=0+x2-min-roughness=0"] {
            let spec = format!("{method}{knobs}");
            let mut m = gpu::build(&spec, &s, &cam, gpu::planted(1, Planted::None));
            gpu::render(&mut m, 4);
            let gbuffer = m.renderer().read_gbuffer(ctx).expect("G-buffer");
            let img = m
                .debug_image(ctx, DebugView::Refused)
                .unwrap()
                .expect("view");
            let x1: Vec<bool> = img.iter().map(|p| *p == [0.5; 3]).collect();
            let count = |c: usize| img.iter().filter(|p| p[c] == 1.0).count();
            let glossy = gbuffer
                .iter()
                .map(|v| v.prim != restir_world::trace::NO_HIT && v.material != 0)
                .collect::<Vec<_>>();
            let (x2, shift, occluded) = (count(2), count(0), count(1));
            eprintln!(
                "{spec}: x1 too smooth {}, x2 too smooth {x2}, shift {shift}, occluded {occluded} \
                 of {} pixels ({} glossy)",
                x1.iter().filter(|&&b| b).count(),
                img.len(),
                glossy.iter().filter(|&&b| b).count()
            );
            match knobs {
                "" => {
                    assert_eq!(x1, glossy, "{spec}: x1 refusals are not the glossy pixels");
                    assert!(x2 > 0, "{spec}: no x2 refused");
                }
                _ => assert!(
                    x1.iter().all(|&b| !b) && x2 == 0,
                    "{spec}: a roughness refusal at roughness 0"
                ),
            }
            assert!(
                shift + occluded > 0,
                "{spec}: no shift or visibility refusal"
            );
        }
    }
}
