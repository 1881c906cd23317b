//! The radiance cache (`+cache` methods): layouts, the closed furnace with unbounded bounces,
//! the cells of cornell against the CPU reference at their centres, and a moving camera with a
//! cut (finite images, bounded cells, overflows counted). Each statistical check has a control
//! that runs the cache with a defect planted on the GPU (the update paths lose their tail: the
//! cells learn only the first `update-depth` vertices' light) and must fail the same bound. (A
//! cache that never updates is no defect here: a path whose cell has no sample goes on.)

use glam::Vec3;
use restir_world::cache::{self, CacheCell, CacheConfig, CacheParams};
use restir_world::methods::{self, Composed, FrameMethod};
use restir_world::plant::Planted;
use restir_world::reference::{ReferenceOptions, ReferenceRenderer};
use restir_world::render::{DebugView, Paths, RenderOptions};
use restir_world::sampling::Estimator;
use restir_world::scene::{BuiltinOptions, Camera, Scene, furnace_sphere};
use tests::bias::{channel_means, relative, within};
use tests::gpu;
use tests::scenes::{builtin_square, orbit_then_cut};

/// Unbounded paths: Russian roulette from bounce 3, at most 64 bounces (the most a render
/// takes), MIS on: what the `+cache` methods are compared against.
fn unbounded(seed: u32) -> RenderOptions {
    RenderOptions {
        seed,
        paths: Paths::bounces(render_max()),
        ..Default::default()
    }
}

fn render_max() -> u32 {
    restir_world::render::MAX_BOUNCES
}

/// `spec` at unbounded paths, seeded.
fn build(spec: &str, s: &Scene, cam: &Camera, seed: u32) -> Composed {
    build_planted(spec, s, cam, seed, Planted::None)
}

/// [`build`] with `planted` compiled in (the controls: update paths without their tail).
fn build_planted(spec: &str, s: &Scene, cam: &Camera, seed: u32, planted: Planted) -> Composed {
    let settings = methods::parse_spec(spec).expect(spec);
    let options = RenderOptions {
        planted,
        ..unbounded(seed)
    };
    Composed::with_options(gpu::context(), s, cam, &settings, &options).expect(spec)
}

/// The control's defect: update paths without their tail.
fn no_tail(planted: bool) -> Planted {
    match planted {
        true => Planted::CacheUpdateWithoutTail,
        false => Planted::None,
    }
}

#[test]
fn layouts_match_wgsl() {
    let src = &cache::kernels()[0].source;
    tests::assert_wgsl_layout!(CacheCell, src, "CacheCell", [r, g, b, info]);
    tests::assert_wgsl_layout!(
        CacheParams,
        src,
        "CacheParams",
        [knobs, debug_view, update_paths, unit, _pad2]
    );
    tests::assert_knobs_layout!(CacheConfig, src, "CacheKnobs");
}

/// The furnace's albedo and emission.
const RHO: f32 = 0.8;
const LE: f32 = 1.0;
/// The check's bound, per channel (the bias bound for every `+cache` method).
const BOUND: f64 = 0.05;

/// The mean of frames `from + 1 ..= to` of `m`'s accumulated (direct + indirect) image, per
/// channel, rendering on from where `m` is.
fn mean_of_frames(m: &mut Composed, from: u32, to: u32) -> [f64; 3] {
    let sum = |m: &Composed| {
        let img = gpu::images(m);
        let (d, i) = (channel_means(&img.direct), channel_means(&img.indirect));
        [0, 1, 2].map(|c| d[c] + i[c])
    };
    let before = if from == 0 { [0.0; 3] } else { sum(m) };
    gpu::render(m, to - from);
    let after = sum(m);
    [0, 1, 2]
        .map(|c| (after[c] * f64::from(to) - before[c] * f64::from(from)) / f64::from(to - from))
}

/// The closed furnace (albedo 0.8, emission 1 everywhere; radiance Le / (1 - rho) = 5 at every
/// pixel with unbounded bounces, of which paths of three bounces carry 59%): `ris+cache` at its
/// defaults (paths end in the cache from their third vertex on; update paths of 3 vertices and
/// an unbounded tail) converges to Le / (1 - rho) within 5% per channel (24x24; mean of frames
/// 65-128, once every cell has its history). Control: the update paths without their tail (the
/// cells learn three vertices' light, 49% of a cell's) must fail the same bound.
#[test]
fn closed_furnace_converges_to_le_over_one_minus_rho() {
    const SIDE: u32 = 24;
    let s = furnace_sphere(RHO, LE, SIDE, SIDE).expect("furnace");
    let cam = s.camera_or_default(SIDE, SIDE);
    let want = f64::from(LE) / (1.0 - f64::from(RHO));
    let run = |planted: bool| {
        let mut m = build_planted("ris+cache", &s, &cam, 7, no_tail(planted));
        gpu::render(&mut m, 64);
        relative(mean_of_frames(&mut m, 64, 128), [want; 3])
    };
    let d = run(false);
    let control = run(true);
    tests::bias::assert_checked(
        "ris+cache on the closed furnace",
        d,
        BOUND,
        control,
        "update paths without their tail",
    );
}

/// The cells of cornell's back and side walls (96x96, `ris+cache` at its defaults, 128 frames,
/// static): each cell's radiance (demodulated) against the CPU reference's white-surface
/// radiance at the cell's centre projected onto its wall (1024 samples of unbounded paths,
/// about 2% noise), over the cells of the walls' pixels that lie wholly on their wall (not the
/// floor, which the blocks stand on, nor the ceiling, lit at close range by the two-sided
/// lamp) and hold at least 32 samples. The mean of the per-cell ratios is within 5% per
/// channel and no cell is off by more than 50% (a cell's mean holds 32-256 path samples: the
/// worst of 69 cells measured 0.290 on lavapipe and 0.368 on an NVIDIA H200, whose streams
/// differ in rounding; 35% failed there). Control: the update paths without their tail must
/// fail the mean's bound.
#[test]
fn cornell_cells_match_the_cpu_reference_at_their_centres() {
    const SIDE: u32 = 96;
    const CELL_BOUND: f64 = 0.5;
    let (s, cam) = builtin_square("cornell", SIDE, BuiltinOptions::default());
    let cells = wall_cells(&s, &cam, false);
    assert!(cells.len() >= 16, "only {} wall cells", cells.len());
    let want = reference_at(&s, &cells);
    let (mean, worst) = compare(&want, &cells, "ris+cache");
    assert!(within(mean, BOUND), "cells off the reference: {mean:+.4?}");
    assert!(worst < CELL_BOUND, "a cell is off by {worst:.3}");
    let control = wall_cells(&s, &cam, true);
    let (control, _) = compare(&want, &control, "update paths without their tail");
    assert!(
        !within(control, BOUND),
        "the control (update paths without their tail) passed: {control:+.4?}"
    );
}

/// A wall cell of the cornell test: the centre of the cell projected onto its wall, the wall's
/// normal and the cell's mean.
type WallCells = std::collections::HashMap<u32, (Vec3, Vec3, [f32; 3])>;

/// The cells of `ris+cache` (update paths without their tail when `planted`) after 128 frames
/// at the pixels of the side and back walls that lie wholly on their wall and hold at least 32
/// samples.
fn wall_cells(s: &Scene, cam: &Camera, planted: bool) -> WallCells {
    const FRAMES: u32 = 128;
    const MIN_SAMPLES: u32 = 32;
    let (lo, hi) = s.bounds().expect("bounds");
    let margin = 0.01 * (hi - lo);
    // The walls: a vertex on the box's bounds along its normal's axis (x: sides, z: back).
    let on_a_wall = |p: Vec3, n: Vec3| {
        [0, 2].into_iter().find(|&k| {
            n[k].abs() > 0.99
                && ((p[k] - lo[k]).abs() < margin[k] || (p[k] - hi[k]).abs() < margin[k])
        })
    };
    let mut m = build_planted("ris+cache", s, cam, 3, no_tail(planted));
    gpu::render(&mut m, FRAMES);
    let ctx = gpu::context();
    let cache = m.cache().expect("cache");
    let cells = cache.read_cells(ctx).expect("cells");
    let gbuffer = m.renderer().read_gbuffer(ctx).expect("gbuffer");
    let mut seen = std::collections::HashMap::new();
    for v in gbuffer.iter().filter(|v| v.prim != u32::MAX) {
        let (p, n) = (Vec3::from(v.position), Vec3::from(v.normal));
        let Some(axis) = on_a_wall(p, n) else {
            continue;
        };
        let c = cache.cell_of(cam.eye, p, n).expect("a cell");
        let centre = (Vec3::from(c.coords.map(|x| x as f32)) + 0.5) * c.cell_size;
        let on_wall = centre - n * (centre - p).dot(n);
        let half = 0.5 * c.cell_size;
        let inside = (0..3)
            .filter(|&k| k != axis)
            .all(|k| on_wall[k] - half > lo[k] && on_wall[k] + half < hi[k]);
        if inside && !seen.contains_key(&c.checksum) {
            let got = cache
                .find(&cells, cam.eye, v)
                .expect("the cell is in the table");
            if got.samples >= MIN_SAMPLES {
                seen.insert(c.checksum, (on_wall, n, got.mean));
            }
        }
    }
    seen
}

/// The CPU reference's white-surface radiance at each cell's point (1024 samples of unbounded
/// paths, two threads).
fn reference_at(s: &Scene, cells: &WallCells) -> std::collections::HashMap<u32, Vec3> {
    let reference = ReferenceRenderer::new(s).expect("reference");
    let opts = ReferenceOptions {
        method: Estimator::Nee,
        spp: 1024,
        seed: 11,
        threads: 1,
        paths: unbounded(0).paths,
    };
    let all: Vec<_> = cells.iter().map(|(k, (p, n, _))| (*k, *p, *n)).collect();
    std::thread::scope(|scope| {
        let jobs: Vec<_> = all
            .chunks(all.len().div_ceil(2))
            .map(|chunk| {
                let (reference, opts) = (&reference, &opts);
                scope.spawn(move || {
                    chunk
                        .iter()
                        .map(|&(k, p, n)| (k, reference.reflected_white(p, n, opts)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        jobs.into_iter()
            .flat_map(|j| j.join().expect("reference"))
            .collect()
    })
}

/// Per channel the mean of the cells' ratios to the reference, minus 1, and the worst ratio's
/// distance from 1.
fn compare(
    want: &std::collections::HashMap<u32, Vec3>,
    cells: &WallCells,
    what: &str,
) -> ([f64; 3], f64) {
    let ratios: Vec<[f64; 3]> = cells
        .iter()
        .filter_map(|(k, (_, _, got))| {
            let w = want.get(k)?;
            Some([0, 1, 2].map(|c| f64::from(got[c]) / f64::from(w[c])))
        })
        .collect();
    let n = ratios.len() as f64;
    let mean = [0, 1, 2].map(|c| ratios.iter().map(|r| r[c]).sum::<f64>() / n - 1.0);
    let worst = ratios
        .iter()
        .flatten()
        .fold(0.0f64, |w, x| w.max((x - 1.0).abs()));
    eprintln!(
        "cornell walls, {what} ({} cells): mean ratio - 1 {mean:+.4?}, worst {worst:.3}",
        ratios.len()
    );
    (mean, worst)
}

/// 500 frames of orbit, stillness and a cut that turns the camera away (colonnade, 32x32)
/// with a table too small for the scene (`cells=64`): every frame's image stays finite, the
/// cells in use never exceed the table, every inserted vertex that found its bucket full is
/// counted, no cell outlives `evict-after` frames without a sample or holds more than
/// `history` samples, after the cut the cells of the view left behind are evicted, and the
/// cache's debug views draw finite, lit images.
#[test]
fn a_moving_camera_and_a_cut_stay_finite_and_bounded() {
    const SIDE: u32 = 32;
    let (s, cam) = builtin_square("colonnade", SIDE, BuiltinOptions::default());
    let ctx = gpu::context();
    let mut m = build("ris+cache:cells=64", &s, &cam, 5);
    let config = *m.cache().expect("cache").config();
    let mut overflows = 0u64;
    let mut checksums_at_cut = Vec::new();
    // The stats are read every 10th frame (the frames between render in one batch).
    for frame in (9..500).step_by(10) {
        let frames = frame - 9..frame + 1;
        gpu::render_cameras(&mut m, frames, |k| Some(orbit_then_cut(&cam, k)));
        let cache = m.cache().expect("cache");
        let stats = cache.stats(ctx).expect("stats");
        assert!(
            stats.cells_in_use <= stats.capacity,
            "frame {frame}: {stats:?}"
        );
        overflows += u64::from(stats.overflows);
        if frame % 50 == 49 || frame == tests::scenes::CUT_FRAME - 1 {
            let img = gpu::last_frame(&m);
            let finite = |i: &[[f32; 3]]| i.iter().flatten().all(|x| x.is_finite());
            assert!(
                finite(&img.direct) && finite(&img.indirect),
                "frame {frame}: non-finite pixels"
            );
            let cells = cache.read_cells(ctx).expect("cells");
            for (checksum, cell) in cells.iter().filter(|(c, _)| *c != 0) {
                let v = cell.value();
                assert!(
                    v.age <= config.evict_after && v.samples <= config.history,
                    "frame {frame}: cell {checksum:#x} {v:?}"
                );
                assert!(v.mean.iter().all(|x| x.is_finite() && *x >= 0.0));
            }
            if frame == tests::scenes::CUT_FRAME - 1 {
                checksums_at_cut = cells.iter().map(|(c, _)| *c).filter(|c| *c != 0).collect();
            }
        }
    }
    assert!(
        overflows > 0,
        "a 64-cell table never overflowed: not counted?"
    );
    // Long after the cut, few of the cells the old view kept are left (only those the new
    // view's paths still reach).
    let now: std::collections::HashSet<u32> = m
        .cache()
        .expect("cache")
        .read_cells(ctx)
        .expect("cells")
        .iter()
        .map(|(c, _)| *c)
        .collect();
    let kept = checksums_at_cut.iter().filter(|c| now.contains(c)).count();
    eprintln!(
        "{} cells before the cut, {kept} of them left 250 frames later; {overflows} overflows",
        checksums_at_cut.len()
    );
    assert!(
        kept < checksums_at_cut.len(),
        "no cell of the old view was evicted"
    );
    check_cache_debug_views(&m);
}

/// The cache's debug views draw the cells at the pixels (some lit, all finite); the views of
/// other stages are not the cache's.
fn check_cache_debug_views(m: &Composed) {
    let ctx = gpu::context();
    for view in [
        DebugView::CacheRadiance,
        DebugView::CacheAge,
        DebugView::CacheSamples,
    ] {
        let img = m
            .debug_image(ctx, view)
            .expect("view")
            .expect("a cache view");
        assert!(
            img.iter()
                .flatten()
                .all(|x| x.is_finite() && (0.0..=1.0).contains(x))
        );
        assert!(
            img.iter().any(|p| p.iter().any(|x| *x > 0.0)),
            "{view:?} is black"
        );
    }
    assert!(
        m.debug_image(ctx, DebugView::Rejected)
            .expect("view")
            .is_none()
    );
}
