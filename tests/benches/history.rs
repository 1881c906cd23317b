//! What a moving camera costs screen-space ReSTIR GI, and so what any history could give back:
//! on `compare`'s camera paths (18 frames; orbit 1 degree a frame, dolly 1% of the distance a
//! frame), `restir-gi` and `world-restir-gi` rendered with the same seed, and on the last frame
//! the pixels whose reprojection fails ("lost": world-restir-gi's debug view History shows them
//! as not `Reprojected`; restir-gi merges no history there, world-restir-gi last frame's cell or
//! the pool). Each method's frame relMSE (indirect, against `ris` over [`REFERENCE_FRAMES`]
//! frames at the last camera, seed 1000) is split over the lost pixels and the rest.
//!
//! The peer is restir-gi itself: were its lost pixels' error 0 (the best history any method
//! could find there), its relMSE would fall by their share, so `history_bound` = 1 / (1 -
//! share) bounds what history alone can gain over restir-gi at equal time. `wgi_lost_vs_rgi` and
//! `wgi_kept_vs_rgi` are world-restir-gi's error per pixel over restir-gi's in each set. One
//! `RESULT history` line per scene, camera and seed; many-lights has 10,000 lights, as compare's.
//!
//! Size: `HISTORY_BENCH_SIZE` (default 128; compare's equal-time runs are 256). Seeds:
//! `HISTORY_BENCH_SEEDS` (default 3, seeds 1..=N).

use restir_world::methods::Composed;
use restir_world::metrics::rel_mse_map;
use restir_world::plant::Planted;
use restir_world::restir_gi::HistoryOrigin;
use restir_world::scene::{Camera, CameraPath, Scene};
use tests::{bench, gpu};

/// Frames of a run: compare's equal-time runs.
const FRAMES: u32 = 18;
/// Frames of `ris` in the reference.
const REFERENCE_FRAMES: u32 = 128;

fn main() {
    let ctx = gpu::context();
    let side = bench::side_from_env("HISTORY_BENCH_SIZE");
    let seeds: u32 = std::env::var("HISTORY_BENCH_SEEDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let orbit = CameraPath::Orbit {
        frames: FRAMES,
        degrees: FRAMES as f32,
    };
    let dolly = CameraPath::Dolly {
        frames: FRAMES,
        fraction: 0.01 * FRAMES as f32,
    };
    let still = CameraPath::Static;
    // Colonnade's orbit leaves its lit hall (compare refuses it: the reference is black).
    let runs = [
        (
            "cornell",
            [
                Some(("static", still)),
                Some(("orbit", orbit)),
                Some(("dolly", dolly)),
            ],
        ),
        (
            "colonnade",
            [Some(("static", still)), None, Some(("dolly", dolly))],
        ),
        (
            "many-lights",
            [
                Some(("static", still)),
                Some(("orbit", orbit)),
                Some(("dolly", dolly)),
            ],
        ),
    ];
    let run = |spec: &str, scene: &Scene, cam: &Camera, path: CameraPath, seed: u32| {
        let mut m = gpu::build(spec, scene, cam, gpu::planted(seed, Planted::None));
        gpu::render_path(&mut m, FRAMES, path);
        m
    };
    for (name, paths) in runs {
        for (camera, path) in paths.into_iter().flatten() {
            let (scene, cam) = bench::builtin_square(name, side);
            let last = path.camera(&cam, FRAMES - 1);
            let mut r = gpu::build("ris", &scene, &last, gpu::planted(1000, Planted::None));
            gpu::render(&mut r, REFERENCE_FRAMES);
            let reference = gpu::images(&r).indirect;
            for seed in 1..=seeds {
                let g = run("restir-gi", &scene, &cam, path, seed);
                let w = run("world-restir-gi", &scene, &cam, path, seed);
                let origins = w.gi().expect("gi").history_origins(ctx).expect("origins");
                let origins = origins.expect("world-restir-gi's origins");
                let error = |m: &Composed| {
                    rel_mse_map(&gpu::last_frame(m).indirect, &reference).expect("relMSE")
                };
                let (eg, ew) = (error(&g), error(&w));
                // Lost: lit (the reference is not black there) and not reprojected.
                let lit: Vec<bool> = reference
                    .iter()
                    .map(|p| p.iter().sum::<f32>() > 0.0)
                    .collect();
                let lost: Vec<bool> = origins
                    .iter()
                    .zip(&lit)
                    .map(|(o, &l)| l && *o != HistoryOrigin::Reprojected)
                    .collect();
                let sum = |e: &[f64], want: bool| -> f64 {
                    e.iter()
                        .zip(&lost)
                        .filter(|(_, l)| **l == want)
                        .map(|(v, _)| v)
                        .sum()
                };
                let n = lost.len() as f64;
                let n_lit = lit.iter().filter(|&&l| l).count() as f64;
                let n_lost = lost.iter().filter(|&&l| l).count() as f64;
                let (g_lost, g_kept) = (sum(&eg, true), sum(&eg, false));
                let (w_lost, w_kept) = (sum(&ew, true), sum(&ew, false));
                let share = g_lost / (g_lost + g_kept);
                let f = |x: f64| format!("{x:.4}");
                bench::print_result(
                    ctx,
                    "history",
                    &[
                        ("scene", name.into()),
                        ("camera", camera.into()),
                        ("seed", seed.to_string()),
                        ("size", format!("{side}x{side}")),
                        ("frames", FRAMES.to_string()),
                        ("lost_share_of_lit", f(n_lost / n_lit)),
                        ("rgi_rel_mse", f((g_lost + g_kept) / n)),
                        ("rgi_error_share_lost", f(share)),
                        ("history_bound", f(1.0 / (1.0 - share))),
                        ("wgi_rel_mse", f((w_lost + w_kept) / n)),
                        ("wgi_lost_vs_rgi", f(w_lost / g_lost)),
                        ("wgi_kept_vs_rgi", f(w_kept / g_kept)),
                    ],
                );
            }
        }
    }
}
