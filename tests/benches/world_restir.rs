//! Per-stage GPU milliseconds per frame of world-space ReSTIR GI against the `ris` and `nee`
//! baselines on many-lights, timed with GPU timestamp spans around every pass of a frame, plus
//! the build's share of the frame and a vec4-copy floor over the frame's G-buffer bytes measured
//! in the same run. Criterion times whole frames of each method (GPU time, `iter_custom`).
//!
//! Size: `WR_BENCH_SIZE` (default 128: the demo's default 256x256 takes too long per frame on
//! lavapipe with 2 shared cores); many-lights with 10,000 lights. One `RESULT` line per
//! world-restir variant of the method registry (`variant=default` first: the shipped defaults),
//! each with the same frame's baselines measured in the same run; one `RESULT bounces` line per
//! method (nee, ris, world-restir) with the GPU cost of each bounce beyond the first.
//! `WR_BENCH_CRITERION=0` skips the criterion group: only the RESULT runs.

use criterion::{Criterion, criterion_group, criterion_main};
use restir_world::GpuContext;
use restir_world::gpu::{FrameEncoder, PassTimes};
use restir_world::knobs::parse_config;
use restir_world::methods::{Composed, FrameMethod};
use restir_world::render::{Paths, RenderOptions, Renderer};
use restir_world::sampling::Estimator;
use restir_world::world_restir::{self, WorldRestirConfig};
use tests::{bench, buffers, floors::CopyKernel, gpu};

const FRAMES: u32 = 6;

/// One frame of `m` into the caller's encoder (untimed).
fn frame(ctx: &GpuContext, m: &mut dyn FrameMethod, enc: &mut wgpu::CommandEncoder) {
    m.encode_frame(&mut FrameEncoder::new(&ctx.device, enc, None))
        .expect("frame");
}

fn world_restir(c: &mut Criterion) {
    let ctx = gpu::context();
    let side = bench::side_from_env("WR_BENCH_SIZE");
    let (scene, cam) = bench::builtin_square("many-lights", side);
    let mut wr = Composed::world_restir(ctx, &scene, &cam, WorldRestirConfig::default(), 1)
        .expect("world-restir");
    let ris = Estimator::Ris { candidates: 16 };
    let mut ris = Renderer::new(ctx, &scene, &cam, ris, 1).expect("ris");
    let mut nee = Renderer::new(ctx, &scene, &cam, Estimator::Nee, 1).expect("nee");

    if std::env::var("WR_BENCH_CRITERION").map_or(true, |v| v != "0") {
        let mut group = c.benchmark_group("world_restir_frame");
        group.sample_size(10);
        group.warm_up_time(std::time::Duration::from_secs(1));
        group.measurement_time(std::time::Duration::from_secs(3));
        group.bench_function(format!("world-restir_{side}"), |b| {
            b.iter_custom(|iters| bench::gpu_time(ctx, iters, |enc| frame(ctx, &mut wr, enc)))
        });
        for (name, r) in [("ris", &mut ris), ("nee", &mut nee)] {
            group.bench_function(format!("{name}_{side}"), |b| {
                b.iter_custom(|iters| bench::gpu_time(ctx, iters, |enc| frame(ctx, r, enc)))
            });
        }
        group.finish();
    }
    for spec in ["nee", "ris", "world-restir"] {
        bounce_result(ctx, &scene, &cam, spec, side);
    }

    let t_ris = bench::frame_times(ctx, &mut ris, 1, FRAMES);
    let t_nee = bench::frame_times(ctx, &mut nee, 1, FRAMES);
    eprintln!("ris per frame: {:?}", t_ris.per_frame());
    eprintln!("nee per frame: {:?}", t_nee.per_frame());

    // Floor: a vec4 copy over the G-buffer's bytes.
    let kernel = CopyKernel::new(&ctx.device);
    let bytes = u64::from(side * side) * 64;
    let src = buffers::storage_zeroed(&ctx.device, "src", bytes);
    let dst = buffers::storage_zeroed(&ctx.device, "dst", bytes);
    let floor_ms = bench::gpu_ms(ctx, 5, |enc| {
        kernel.encode(&ctx.device, enc, &src, &dst, (bytes / 16) as u32)
    });

    // Per-stage spans of the defaults, then of every other variant.
    let all = world_restir::variants();
    let named = all.iter().filter(|v| v.name != "both").map(|v| {
        let config = parse_config(&all, Some(v.name)).expect("variant");
        (v.name, config)
    });
    let variants = std::iter::once(("default", WorldRestirConfig::default())).chain(named);
    for (variant, config) in variants {
        let mut wr = Composed::world_restir(ctx, &scene, &cam, config, 1).expect("world-restir");
        stage_result(ctx, &mut wr, variant, side, &t_ris, &t_nee, floor_ms);
    }
}

/// One `RESULT world-restir` line: per-stage GPU ms per frame of `wr` after one warm-up frame.
fn stage_result(
    ctx: &GpuContext,
    wr: &mut Composed,
    variant: &str,
    side: u32,
    t_ris: &PassTimes,
    t_nee: &PassTimes,
    floor_ms: f64,
) {
    let t_wr = bench::frame_times(ctx, wr, 1, FRAMES);
    let stats = wr.world().unwrap().grid_stats(ctx).expect("stats");
    eprintln!("world-restir {variant} per frame: {:?}", t_wr.per_frame());

    let f = |x: f64| format!("{x:.3}");
    let (frame_wr, frame_ris, frame_nee) = (
        t_wr.ms_per_frame(),
        t_ris.ms_per_frame(),
        t_nee.ms_per_frame(),
    );
    let build = bench::span_ms(&t_wr, &["build"]);
    let cam = wr.renderer().camera();
    let table = wr.world().unwrap().config().table(cam.width, cam.height);
    bench::print_result(
        ctx,
        "world-restir",
        &[
            ("variant", variant.into()),
            ("scene", "many-lights".into()),
            ("size", format!("{side}x{side}")),
            ("buckets", table.num_buckets.to_string()),
            ("generate_ms", f(bench::span_ms(&t_wr, &["generate"]))),
            ("build_ms", f(build)),
            ("temporal_ms", f(bench::span_ms(&t_wr, &["temporal"]))),
            ("spatial_ms", f(bench::span_ms(&t_wr, &["spatial"]))),
            ("shade_ms", f(bench::span_ms(&t_wr, &["shade"]))),
            ("trace_ms", f(bench::span_ms(&t_wr, &["primary", "gi"]))),
            ("direct_ms", f(bench::span_ms(&t_wr, &["shade_direct"]))),
            ("path_ms", f(bench::span_ms(&t_wr, &["path"]))),
            ("frame_ms", f(frame_wr)),
            ("build_share", format!("{:.3}", build / frame_wr)),
            ("vs_ris_frame", format!("{:.3}", frame_wr / frame_ris)),
            ("ris_frame_ms", f(frame_ris)),
            (
                "ris_indirect_ms",
                f(bench::span_ms(t_ris, &["shade_indirect"])),
            ),
            ("nee_frame_ms", f(frame_nee)),
            (
                "nee_indirect_ms",
                f(bench::span_ms(t_nee, &["shade_indirect"])),
            ),
            ("floor_copy_ms", format!("{floor_ms:.4}")),
            ("overflows", stats.overflows.to_string()),
        ],
    );
}

/// Bounces timed by [`bounce_result`]: 1 to 4, without Russian roulette (every path runs the
/// whole depth, so the cost per bounce is the full one).
const BOUNCES: [u32; 4] = [1, 2, 3, 4];

/// One `RESULT bounces` line: GPU ms per frame of `spec` at 1..=4 bounces, and the cost of each
/// bounce beyond the first (least-squares slope of frame time against bounces), as a ratio to
/// the one-bounce frame too.
fn bounce_result(
    ctx: &GpuContext,
    scene: &restir_world::scene::Scene,
    cam: &restir_world::scene::Camera,
    spec: &str,
    side: u32,
) {
    let settings = restir_world::methods::parse_spec(spec).expect(spec);
    let frame_ms = BOUNCES.map(|bounces| {
        let options = RenderOptions {
            seed: 1,
            paths: Paths {
                bounces,
                roulette_from: 0,
                mis: false,
            },
            ..Default::default()
        };
        let mut m = settings.build_with(ctx, scene, cam, &options).expect(spec);
        bench::frame_times(ctx, m.as_mut(), 1, FRAMES).ms_per_frame()
    });
    let n = BOUNCES.len() as f64;
    let mean_b = BOUNCES.iter().map(|&b| f64::from(b)).sum::<f64>() / n;
    let mean_t = frame_ms.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (&b, &t) in BOUNCES.iter().zip(&frame_ms) {
        sxy += (f64::from(b) - mean_b) * (t - mean_t);
        sxx += (f64::from(b) - mean_b).powi(2);
    }
    let per_bounce = sxy / sxx;
    let mut pairs = vec![
        ("method", spec.to_string()),
        ("scene", "many-lights".into()),
        ("size", format!("{side}x{side}")),
        ("ms_per_bounce", format!("{per_bounce:.3}")),
        ("vs_one_bounce", format!("{:.3}", per_bounce / frame_ms[0])),
    ];
    let names = ["frame_ms_1", "frame_ms_2", "frame_ms_3", "frame_ms_4"];
    pairs.extend(
        names
            .iter()
            .zip(frame_ms)
            .map(|(k, t)| (*k, format!("{t:.3}"))),
    );
    bench::print_result(ctx, "bounces", &pairs);
}

criterion_group!(benches, world_restir);
criterion_main!(benches);
