//! World-space ReSTIR GI's bias at its shipped defaults on the scenes of issue 15: `colonnade`
//! (1064 small lamps) and Sponza under a constant sky (environment samples reused, shading
//! normals). The accumulated indirect mean of world-restir against
//! the converged `ris` reference (16 candidates, 512 frames), each with a negative control (a
//! planted darkening that must fail the same bound). Sponza is skipped with a printed reason
//! when the public scenes are absent.

use restir_world::render::Renderer;
use restir_world::sampling::Estimator;
use restir_world::scene::{self, BuiltinOptions, Camera, Environment, Scene};
use restir_world::world_restir::WorldRestirConfig;
use tests::bias::{channel_means, mean_over_seeds, relative, world_restir_indirect_means};
use tests::gpu;
use tests::scenes::builtin_square;

const SIDE: u32 = 64;

/// Per channel: (mean over `seeds` of world-restir's accumulated indirect mean over `frames`)
/// / (the mean of `reference_runs` ris references of 512 frames) - 1.
fn relative_bias(
    s: &Scene,
    cam: &Camera,
    reference_runs: u32,
    seeds: std::ops::Range<u32>,
    frames: u32,
) -> [f64; 3] {
    let ctx = gpu::context();
    let want = mean_over_seeds(1000..1000 + reference_runs, |seed| {
        let mut r = Renderer::new(ctx, s, cam, Estimator::Ris { candidates: 16 }, seed).unwrap();
        gpu::render(&mut r, 512);
        channel_means(&gpu::images(&r).indirect)
    });
    let config = WorldRestirConfig::default();
    relative(
        world_restir_indirect_means(s, cam, config, seeds, frames),
        want,
    )
}

fn check(name: &str, bias: [f64; 3], bound: f64) {
    eprintln!(
        "bias {name} {SIDE}x{SIDE}: {:+.4} {:+.4} {:+.4} (bound {bound})",
        bias[0], bias[1], bias[2]
    );
    for (c, b) in bias.iter().enumerate() {
        assert!(
            b.abs() < bound,
            "{name} channel {c}: bias {b:+.4} beyond {bound}"
        );
        let planted = (1.0 + b) * (1.0 - 2.0 * bound) - 1.0;
        assert!(
            planted.abs() >= bound,
            "{name} channel {c}: a planted {}% darkening went unnoticed",
            200.0 * bound
        );
    }
}

/// colonnade at 64x64, 4 seeds x 256 frames against 4 ris references of 512 frames: bound 3%
/// (the built-in scenes' test bounds 2% with 5 seeds at 96x96). The small lamps near the
/// surfaces make every estimator heavy-tailed here: one 512-frame ris reference sat 3.4% above
/// the mean of three 256-frame ris runs (the same estimator), which is why the reference is
/// four. Measured: +0.07/+0.45/+0.24%.
#[test]
fn colonnade_bias_at_the_defaults() {
    let (s, cam) = builtin_square("colonnade", SIDE, BuiltinOptions::default());
    check("colonnade", relative_bias(&s, &cam, 4, 100..104, 256), 0.03);
}

use tests::scenes_dir;

/// Sponza (no emitters of its own, shading normals) under a constant sky of radiance
/// (2, 2.2, 2.5) only, 64x64, 3 seeds x 256 frames against one ris reference of 512 frames:
/// bound 3%. With 200 added lamps (`--add-lights 200`) the references themselves scatter: one
/// 512-frame ris reference sat 7% above the mean of three 256-frame ris runs, and ris against a
/// 512-frame nee reference was -8% with lamps only and -0.65% with the sky only; so the lamps
/// are left out of this bound. Measured: -1.00% in every channel (grey sky, grey walls).
#[test]
fn sponza_under_a_sky_bias_at_the_defaults() {
    let Some(dir) = scenes_dir() else { return };
    let mut s = scene::load(&dir.join("sponza-capsaicin/Sponza.gltf"))
        .unwrap()
        .scene;
    s.sanitize("sponza").unwrap();
    s.environment = Some(Environment::constant([2.0, 2.2, 2.5]).unwrap());
    let cam = s.camera_or_default(SIDE, SIDE);
    check(
        "sponza under a sky",
        relative_bias(&s, &cam, 1, 100..103, 256),
        0.03,
    );
}
