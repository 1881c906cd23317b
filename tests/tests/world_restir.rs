//! World-space ReSTIR GI: layouts, grid build by readback, reuse-off equivalence with the `ris`
//! baseline (with a planted-bias control), determinism, and no NaN/Inf over many frames.

use reservoir::reuse::Combination;
use restir_world::methods::{self, Composed, FrameMethod, MethodSettings};
use restir_world::plant::Planted;
use restir_world::render::{DebugView, Renderer};
use restir_world::sampling::Estimator;
use restir_world::scene::{Camera, CameraPath, Scene};
use restir_world::world_restir::{self, WorldRestirConfig, WrParams};
use tests::gpu;
use tests::scenes::test_scene as scene;

/// A table of 4 buckets of 2 slots: it overflows on every built-in scene.
fn tiny_table() -> WorldRestirConfig {
    WorldRestirConfig {
        buckets: Some(4),
        slots: 2,
        ..Default::default()
    }
}

/// A cut from `cam`: a step forward, turned round to look away from everything it saw.
fn cut_from(cam: &Camera) -> Camera {
    Camera {
        eye: cam.target + (cam.target - cam.eye) * 0.3,
        target: cam.target + (cam.target - cam.eye),
        ..*cam
    }
}

/// cornell at `side` x `side` with world-restir at its defaults.
fn cornell_world_restir(side: u32, seed: u32) -> (Scene, Camera, Composed) {
    let (s, cam) = scene("cornell", side);
    let wr = Composed::world_restir(gpu::context(), &s, &cam, small(), seed).expect("world-restir");
    (s, cam, wr)
}

/// The shipped defaults (the table is sized to the frame).
fn small() -> WorldRestirConfig {
    WorldRestirConfig::default()
}

/// Vertices the last frame's hash grid left out.
fn overflows_of(wr: &Composed) -> u32 {
    wr.grid_overflows(gpu::context())
        .expect("stats")
        .expect("world-restir has a grid")
}

fn luminance(c: &[f32; 3]) -> f64 {
    0.2126 * f64::from(c[0]) + 0.7152 * f64::from(c[1]) + 0.0722 * f64::from(c[2])
}

fn mean_lum(img: &[[f32; 3]]) -> f64 {
    img.iter().map(luminance).sum::<f64>() / img.len() as f64
}

#[test]
fn layouts_match_wgsl() {
    let src = &world_restir::kernels()[0].source;
    tests::assert_wgsl_layout!(
        WrParams,
        src,
        "WrParams",
        [knobs, debug_view, items, tiles, tile_size]
    );
    tests::assert_knobs_layout!(WorldRestirConfig, src, "WrKnobs");
    // The grid's parameters, as its lookup composes them into the reuse pass.
    let reuse = world_restir::kernels()
        .into_iter()
        .find(|k| k.name.ends_with("/reuse"))
        .expect("the reuse kernel");
    tests::assert_wgsl_layout!(
        restir_world::grid::GridParams,
        &reuse.source,
        "GridParams",
        [items, jitter, fold_normal, _pad]
    );
}

/// The shared world-space grid's keys against its CPU twin (`grid::cell_of`): without jitter,
/// every inserted vertex's slot lies in the twin's bucket of its position (and normal, with
/// `fold-normal`) and holds the twin's checksum, with the normal's axis folded in and without.
/// Folding must split cells (more cells than without), and the unfolded twin must miss some
/// folded keys: a grid that ignored `fold_normal` fails.
#[test]
fn grid_cells_are_the_twins_keys_with_and_without_the_normal_folded() {
    let ctx = gpu::context();
    let (s, cam) = scene("cornell", 40);
    let mut cells = Vec::new();
    for fold in [false, true] {
        let config = WorldRestirConfig {
            jitter: false,
            fold_normal: fold,
            ..small()
        };
        let mut wr = Composed::world_restir(ctx, &s, &cam, config, 3).expect("world-restir");
        gpu::render(&mut wr, 1);
        let w = wr.world().unwrap();
        let g = w.grid(ctx).expect("grid");
        let params = w.world_grid().params().with_eye(cam.eye).expect("params");
        let spb = params.slots_per_bucket;
        let secondary = wr.renderer().read_secondary(ctx).expect("secondary");
        let mut unfolded_misses = 0;
        let mut inserted = 0;
        for (i, v) in secondary.iter().enumerate() {
            let [slot, _] = g.vertex_slot[i];
            if slot >= gpu_hash::HASH_FIRST_SENTINEL {
                continue;
            }
            inserted += 1;
            let (p, n) = (v.position.into(), v.normal.into());
            let twin = restir_world::grid::cell_of(&params, p, n, fold).expect("a cell");
            assert_eq!(slot / spb, twin.bucket, "fold {fold}: vertex {i}'s bucket");
            assert_eq!(
                g.checksums[slot as usize], twin.checksum,
                "fold {fold}: vertex {i}"
            );
            let plain = restir_world::grid::cell_of(&params, p, n, false).expect("a cell");
            unfolded_misses += usize::from(plain.checksum != twin.checksum);
        }
        assert!(inserted > 1000, "fold {fold}: only {inserted} vertices");
        assert_eq!(
            unfolded_misses > 0,
            fold,
            "fold {fold}: {unfolded_misses} keys differ"
        );
        cells.push(g.counters.iter().filter(|&&c| c > 0).count());
    }
    assert!(
        cells[1] > cells[0],
        "folding the normal split no cell: {cells:?}"
    );
}

/// Algorithm 2 by readback: every vertex with a GI hit is in exactly one slot's compact storage,
/// at offsets[slot] + index, the offsets are the exclusive scan of the counts, and nothing else
/// is stored. Also after a second frame (the other table of the pair).
#[test]
fn grid_build_stores_every_vertex_once() {
    let ctx = gpu::context();
    let (_, _, mut wr) = cornell_world_restir(40, 3);
    for frame in 0..2 {
        gpu::render(&mut wr, 1);
        let g = wr.world().unwrap().grid(ctx).expect("grid");
        let stats = wr.world().unwrap().grid_stats(ctx).expect("stats");
        assert_eq!(stats.overflows, 0);
        // Exclusive scan of the counters.
        let mut acc = 0u32;
        for (c, o) in g.counters.iter().zip(&g.offsets) {
            assert_eq!(*o, acc);
            acc += c;
        }
        let inserted: Vec<usize> = (0..g.vertex_slot.len())
            .filter(|&i| g.vertex_slot[i][0] < gpu_hash::HASH_FIRST_SENTINEL)
            .collect();
        assert!(
            inserted.len() > 1000,
            "frame {frame}: only {} vertices",
            inserted.len()
        );
        assert_eq!(acc as usize, inserted.len(), "counts != inserted vertices");
        let mut seen = vec![0u32; g.vertex_slot.len()];
        for &i in &inserted {
            let [slot, idx] = g.vertex_slot[i];
            assert!(idx < g.counters[slot as usize]);
            let start = g.offsets[slot as usize] as usize;
            let range = &g.cells[start..start + g.counters[slot as usize] as usize];
            assert_eq!(range.iter().filter(|&&v| v as usize == i).count(), 1);
            // Cells are sorted by vertex index (sort_cells).
            assert!(range.windows(2).all(|w| w[0] < w[1]));
        }
        for &v in &g.cells[..acc as usize] {
            seen[v as usize] += 1;
        }
        for (i, &n) in seen.iter().enumerate() {
            let expect = u32::from(g.vertex_slot[i][0] < gpu_hash::HASH_FIRST_SENTINEL);
            assert_eq!(n, expect, "vertex {i} stored {n} times");
        }
    }
}

/// Per-frame mean luminance of the indirect image over `frames` frames.
fn frame_means(m: &mut dyn FrameMethod, frames: u32) -> Vec<f64> {
    (0..frames)
        .map(|_| {
            gpu::render(m, 1);
            mean_lum(&gpu::last_frame(m).indirect)
        })
        .collect()
}

fn mean_se(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// TOST-style equivalence of two sets of independent per-frame image means: the difference
/// must be within `margin` (relative) and the two one-sided tests at ~3 sigma must pass, i.e.
/// |diff| + 3 se < margin * mean.
const MARGIN: f64 = 0.04;

fn equivalent(a: &[f64], b: &[f64], margin: f64) -> (bool, f64, f64) {
    let (ma, sa) = mean_se(a);
    let (mb, sb) = mean_se(b);
    let diff = ma - mb;
    let se = (sa * sa + sb * sb).sqrt();
    ((diff.abs() + 3.0 * se) < margin * mb, diff / mb, se / mb)
}

/// With temporal and spatial reuse off, world-space ReSTIR is the `ris` estimator (RIS over 16
/// candidates + one shadow ray at the secondary vertex): the mean indirect luminance over 96
/// independent frames of each (48x48) must agree within a 4% equivalence margin (3 sigma TOST;
/// the relative standard error of the difference is about 0.7% here). Negative control:
/// world-restir with its light samples' pdf overstated by 10% (planted on the GPU; with reuse
/// off nothing is merged), on another seed, must fail the same test.
#[test]
fn reuse_off_equals_ris_in_expectation() {
    let ctx = gpu::context();
    let side = 48;
    for name in ["cornell", "many-lights"] {
        let (s, cam) = scene(name, side);
        let config = WorldRestirConfig {
            buckets: Some(4096),
            ..WorldRestirConfig::no_reuse()
        };
        let settings = MethodSettings {
            world: Some(config),
            ..methods::parse_spec("world-restir").expect("spec")
        };
        let build = |seed, planted| {
            let options = gpu::planted(seed, planted);
            Composed::with_options(ctx, &s, &cam, &settings, &options).expect("wr")
        };
        let mut wr = build(11, Planted::None);
        let ris = Estimator::Ris { candidates: 16 };
        let mut ris = Renderer::new(ctx, &s, &cam, ris, 12).expect("ris");
        let frames = 96;
        let a = frame_means(&mut wr, frames);
        let b = frame_means(&mut ris, frames);
        let (ok, rel, se) = equivalent(&a, &b, MARGIN);
        eprintln!("{name}: reuse off vs ris: rel diff {rel:+.4}, rel se {se:.4}");
        assert!(
            ok,
            "{name}: reuse-off world-restir differs from ris: {rel:+.4} (se {se:.4})"
        );
        let mut planted = build(13, Planted::LightPdfOverstated);
        let p = frame_means(&mut planted, frames);
        let (bad, rel_p, _) = equivalent(&p, &b, MARGIN);
        eprintln!("{name}: control (light pdf overstated by 10%, seed 13): rel diff {rel_p:+.4}");
        assert!(
            !bad,
            "{name}: the overstated light pdf went unnoticed ({rel_p:+.4})"
        );
    }
}

/// Same seed, same adapter -> identical images (cells are sorted, so the atomics' order does
/// not matter); another seed -> another image.
#[test]
fn same_seed_same_images() {
    let ctx = gpu::context();
    let (s, cam) = scene("cornell", 32);
    let run = |seed| {
        let mut wr = Composed::world_restir(ctx, &s, &cam, small(), seed).expect("world-restir");
        gpu::render(&mut wr, 3);
        gpu::images(&wr)
    };
    let a = run(5);
    let b = run(5);
    let c = run(6);
    assert_eq!(a, b, "same seed, different images");
    assert_ne!(a.indirect, c.indirect, "seed has no effect");
}

fn assert_finite(what: &str, img: &[[f32; 3]]) {
    let bad = img.iter().flatten().filter(|v| !v.is_finite()).count();
    assert_eq!(bad, 0, "{what}: {bad} non-finite values");
}

/// No NaN/Inf in any frame on every built-in scene with reuse on, with a tiny table that
/// overflows (the overflowing vertices keep their own reservoirs; counted), and with temporal
/// reuse across a camera cut, checking every frame (60 per run; the 500-frame runs are below).
#[test]
fn no_nan_over_many_frames_overflow_and_camera_cut() {
    let ctx = gpu::context();
    let side = 24;
    let frames = 60;
    for name in diffuse_builtins() {
        let (s, cam) = scene(name, side);
        for (label, config) in [("default", small()), ("tiny table", tiny_table())] {
            let mut wr = Composed::world_restir(ctx, &s, &cam, config, 1).expect("world-restir");
            let cut = cut_from(&cam);
            let mut overflows = 0u32;
            for f in 0..frames {
                if f == frames / 2 {
                    wr.set_camera(&cut).expect("cut");
                }
                gpu::render(&mut wr, 1);
                let img = gpu::last_frame(&wr);
                assert_finite(&format!("{name} {label} frame {f}"), &img.indirect);
                assert_finite(&format!("{name} {label} frame {f}"), &img.direct);
                overflows = overflows.max(overflows_of(&wr));
            }
            eprintln!("{name} {label}: most overflows in a frame {overflows}");
            if label == "tiny table" {
                assert!(overflows > 0, "{name}: tiny table did not overflow");
            }
            let res = wr.world().unwrap().reservoirs(ctx).expect("reservoirs");
            assert!(res.iter().all(|r| r.ucw.is_finite()));
        }
    }
}

/// Camera animation (orbit) with temporal reuse, and the three debug views, stay finite.
#[test]
fn orbit_and_debug_views() {
    let ctx = gpu::context();
    let (s, cam, mut wr) = cornell_world_restir(32, 2);
    let path = CameraPath::Orbit {
        frames: 8,
        degrees: 20.0,
    };
    gpu::render_path(&mut wr, 8, path);
    assert_finite("orbit", &gpu::images(&wr).indirect);
    let cells = wr
        .world()
        .unwrap()
        .debug_image(ctx, DebugView::Cells)
        .expect("cells");
    let distinct: std::collections::HashSet<[u32; 3]> =
        cells.iter().map(|c| c.map(f32::to_bits)).collect();
    assert!(
        distinct.len() > 4,
        "cell view shows {} colours",
        distinct.len()
    );
    let m = wr
        .world()
        .unwrap()
        .debug_image(ctx, DebugView::M)
        .expect("m");
    assert!(m.iter().any(|c| c.iter().any(|&v| v > 0.0)));
    // The overflow view is red exactly at the vertices the grid left out: none with the
    // defaults, as many as the table's statistics count with a table too small for the frame.
    let red = |wr: &Composed| {
        let o = wr
            .world()
            .unwrap()
            .debug_image(ctx, DebugView::Overflow)
            .expect("overflow");
        o.iter().filter(|c| *c == &[1.0, 0.0, 0.0]).count() as u32
    };
    assert_eq!(red(&wr), 0, "no overflow expected with the defaults");
    let mut wr = Composed::world_restir(ctx, &s, &cam, tiny_table(), 2).expect("world-restir");
    gpu::render(&mut wr, 2);
    let overflows = overflows_of(&wr);
    assert!(overflows > 0, "the tiny table did not overflow");
    assert_eq!(
        red(&wr),
        overflows,
        "overflow view against the grid's count"
    );
}

/// The other knobs produce finite, non-black indirect images: half-resolution GI (gi_stride 2),
/// the paper's biased 1/M weights, no jitter, no adaptive cell size (2 cm cells), unsorted
/// cells, a single spatial pass without temporal reuse.
#[test]
fn other_knobs_render_finite_non_black() {
    let ctx = gpu::context();
    let (s, cam) = scene("cornell", 32);
    let configs = [
        WorldRestirConfig {
            gi_stride: 2,
            ..small()
        },
        WorldRestirConfig {
            combine: Combination::OneOverM,
            ..small()
        },
        WorldRestirConfig {
            jitter: false,
            adaptive_cell_size: false,
            min_cell_size: 0.02,
            sort_cells: false,
            ..small()
        },
        WorldRestirConfig {
            temporal: false,
            spatial_passes: 1,
            ..small()
        },
    ];
    for config in configs {
        let mut wr = Composed::world_restir(ctx, &s, &cam, config, 4).expect("world-restir");
        gpu::render(&mut wr, 4);
        let img = gpu::images(&wr);
        assert_finite("knobs", &img.indirect);
        assert!(mean_lum(&img.indirect) > 0.0, "{config:?}: black indirect");
    }
}

/// 500 frames on every built-in scene at 16x16 with a table that overflows (8 slots, 2 px
/// cells), temporal
/// reuse, an orbit and a camera cut at frame 250: no NaN/Inf in any frame (a single NaN or Inf
/// in any frame would stay in the accumulated sums, which are checked at the end).
#[test]
fn five_hundred_frames_every_scene_overflowing_with_cut() {
    let ctx = gpu::context();
    let side = 16;
    for name in diffuse_builtins() {
        let (s, cam) = scene(name, side);
        let tiny = WorldRestirConfig {
            projected_size: 2.0,
            ..tiny_table()
        };
        let mut wr = Composed::world_restir(ctx, &s, &cam, tiny, 9).expect("world-restir");
        let orbit = CameraPath::Orbit {
            frames: 250,
            degrees: 40.0,
        };
        gpu::render(&mut wr, 1);
        let overflows = overflows_of(&wr);
        assert!(overflows > 0, "{name}: the tiny table did not overflow");
        gpu::render_path(&mut wr, 249, orbit);
        let cut = cut_from(&cam);
        wr.set_camera(&cut).expect("cut");
        gpu::render(&mut wr, 250);
        let img = gpu::images(&wr);
        assert_eq!(img.frames, 500);
        assert_finite(&format!("{name} 500 frames"), &img.indirect);
        assert_finite(&format!("{name} 500 frames"), &img.direct);
    }
}

/// The built-in scenes without glossy materials: the glossy ones' geometry is cornell's or a
/// hall like many-lights', and the reuse leaves their glossy vertices to the path (checked on
/// them in glossy.rs).
fn diffuse_builtins() -> impl Iterator<Item = &'static str> {
    restir_world::scene::BUILTIN_NAMES
        .into_iter()
        .filter(|n| !n.contains("glossy"))
}
