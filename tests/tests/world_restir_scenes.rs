//! World-space ReSTIR GI's bias at its shipped defaults on the scenes of issue 15: `colonnade`
//! (1064 small lamps) and Sponza under a constant sky (environment samples reused, shading
//! normals). The accumulated indirect mean of world-restir against
//! the converged `ris` reference (16 candidates, 512 frames, rendered once per key and kept on
//! disk), at the default path depth, each with a negative control (world-restir on another seed
//! with its reuse passes merging neighbours without their M, planted on the GPU, which must
//! fail the same bound). Sponza is skipped with a printed reason when the public scenes are
//! absent.

use restir_world::plant::Planted;
use restir_world::render::Renderer;
use restir_world::sampling::Estimator;
use restir_world::scene::{self, BuiltinOptions, Camera, Environment, Scene};
use restir_world::world_restir::WorldRestirConfig;
use std::ops::Range;
use tests::bias::{
    assert_checked, channel_means, mean_over_seeds, relative, world_restir_indirect_means,
    world_restir_planted_means,
};
use tests::gpu;
use tests::scenes::builtin_square;

const SIDE: u32 = 64;

/// The converged reference's indirect channel means of scene `name`: the mean of `runs` ris
/// references of 512 frames, each rendered once per key and kept on disk.
fn reference(name: &str, s: &Scene, cam: &Camera, runs: u32) -> [f64; 3] {
    mean_over_seeds(1000..1000 + runs, |seed| {
        let key = format!(
            "world_restir_scenes reference: ris seed {seed}, {name} {SIDE}x{SIDE}, 512 frames, \
             default paths"
        );
        tests::reference::cached_means(&key, || {
            let ctx = gpu::context();
            let ris = Estimator::Ris { candidates: 16 };
            let mut r = Renderer::new(ctx, s, cam, ris, seed).unwrap();
            gpu::render(&mut r, 512);
            channel_means(&gpu::images(&r).indirect)
        })
    })
}

/// world-restir's indirect mean over `seeds` x 256 frames against the reference of
/// `reference_runs` runs, within `bound` per channel; the control (seed 200, the reuse passes
/// merging neighbours without their M, planted on the GPU, `control_frames` frames) must fail
/// the same check.
fn check(
    name: &str,
    (s, cam): (&Scene, &Camera),
    reference_runs: u32,
    seeds: Range<u32>,
    bound: f64,
    control_frames: u32,
) {
    const FRAMES: u32 = 256;
    let want = reference(name, s, cam, reference_runs);
    let config = WorldRestirConfig::default();
    let got = world_restir_indirect_means(s, cam, config, seeds, FRAMES);
    let merge = Planted::MergeWithoutM;
    let control = world_restir_planted_means(s, cam, config, 200..201, control_frames, merge);
    assert_checked(
        &format!("bias {name} {SIDE}x{SIDE}"),
        relative(got, want),
        bound,
        relative(control, want),
        "merged without M, seed 200",
    );
}

/// colonnade at 64x64, 4 seeds x 256 frames against 4 ris references of 512 frames: bound 3%
/// (the built-in scenes' test bounds 2% with 5 seeds at 96x96). The small lamps near the
/// surfaces make every estimator heavy-tailed here: one 512-frame ris reference sat 3.4% above
/// the mean of three 256-frame ris runs (the same estimator), which is why the reference is
/// four. Measured at one bounce: +0.07/+0.45/+0.24%; at the default paths +0.51/+0.57/+0.52%.
/// The control runs 64 frames: its defect darkened 256 frames by 24-26% and 64 frames by
/// 28-30%, far past the bound, once the reservoirs held history.
#[test]
fn colonnade_bias_at_the_defaults() {
    let (s, cam) = builtin_square("colonnade", SIDE, BuiltinOptions::default());
    check("colonnade", (&s, &cam), 4, 100..104, 0.03, 64);
}

use tests::scenes_dir;

/// Sponza (no emitters of its own, shading normals) under a constant sky of radiance
/// (2, 2.2, 2.5) only, 64x64, 3 seeds x 256 frames against one ris reference of 512 frames:
/// bound 3%. With 200 added lamps (`--add-lights 200`) the references themselves scatter: one
/// 512-frame ris reference sat 7% above the mean of three 256-frame ris runs, and ris against a
/// 512-frame nee reference was -8% with lamps only and -0.65% with the sky only; so the lamps
/// are left out of this bound. Measured at one bounce: -1.00% in every channel (grey sky, grey
/// walls). The control runs the check's 256 frames: its defect darkens Sponza by only about 5%.
#[test]
fn sponza_under_a_sky_bias_at_the_defaults() {
    let Some(dir) = scenes_dir() else { return };
    // Its materials matte (`--materials diffuse`): world-restir does not model glossy ones yet.
    let mut s = scene::load(&dir.join("sponza-capsaicin/Sponza.gltf"))
        .unwrap()
        .scene
        .with_diffuse_materials();
    s.sanitize("sponza").unwrap();
    s.environment = Some(Environment::constant([2.0, 2.2, 2.5]).unwrap());
    let cam = s.camera_or_default(SIDE, SIDE);
    check("sponza under a sky", (&s, &cam), 1, 100..103, 0.03, 256);
}
