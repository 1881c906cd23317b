//! gpu-scan microbenchmark: the single-pass exclusive scan against the vec4 copy floor (reads n,
//! writes n), our three-dispatch reduce-then-scan, and a serial scan on the host, at
//! n = 2^20, 2^24, 2^25 (clamped to the adapter's binding limit; `SCAN_BENCH_SIZES=20,24`
//! picks others, `SCAN_BENCH_CRITERION=0` skips the criterion groups and prints only the
//! RESULT lines, `SCAN_BENCH_WG` / `SCAN_BENCH_ITEMS` override the kernel shape). GPU work is
//! timed with GPU timestamps; every ratio compares kernels measured in the same run on the same
//! device.
//!
//! Besides the ratios, each RESULT line carries what explains them on a device that falls
//! short: the per-tile cost, the look-back's failed polls and fallbacks (from a run with debug
//! counters), and `tile_vs_copy`: the speed, relative to the copy, of a tile-local scan pass
//! with no inter-tile communication at all (the reduce-then-scan downsweep alone: scalar loads
//! staged through workgroup memory, workgroup scan, store). When `scan_vs_copy` is close to
//! `tile_vs_copy` and the look-back needs about one step per tile with almost no fallbacks, the
//! device's per-tile compute, not the look-back, is what keeps the scan from the copy floor.

use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use gpu_scan::{Scan, ScanCounters, ScanDescriptor, ScanKind};
use rand::{Rng, SeedableRng, rngs::StdRng};
use tests::floors::{CopyKernel, ReduceThenScan, RtsStages};
use tests::{bench, buffers, gpu};

/// `SCAN_BENCH_SIZES`: comma-separated log2 sizes (default `20,24,25`).
fn sizes_log2() -> Vec<u32> {
    match std::env::var("SCAN_BENCH_SIZES") {
        Ok(v) => v
            .split(',')
            .map(|s| {
                s.trim()
                    .parse()
                    .expect("SCAN_BENCH_SIZES: log2 sizes, e.g. 20,24,25")
            })
            .collect(),
        Err(_) => vec![20, 24, 25],
    }
}

/// An optional `u32` from the environment (kernel-shape experiments).
fn env_u32(name: &str) -> Option<u32> {
    std::env::var(name)
        .ok()
        .map(|v| v.parse().unwrap_or_else(|_| panic!("{name}: a u32")))
}

fn scan_bench(c: &mut Criterion) {
    let ctx = gpu::context();
    let max = u32::try_from(ctx.max_storage_u32s()).unwrap_or(u32::MAX);
    let sizes: Vec<u32> = sizes_log2()
        .into_iter()
        .map(|l| (1u32 << l).min(max & !3))
        .collect();
    // SCAN_BENCH_CRITERION=0 skips the criterion groups: only the RESULT runs.
    let with_criterion = std::env::var("SCAN_BENCH_CRITERION").map_or(true, |v| v != "0");
    let max_n = *sizes.iter().max().unwrap();
    let desc = ScanDescriptor {
        items_per_thread: env_u32("SCAN_BENCH_ITEMS"),
        workgroup_size: env_u32("SCAN_BENCH_WG"),
        ..ScanDescriptor::for_device(&ctx.device, max_n)
    };
    let scan = Scan::new(&ctx.device, &desc).expect("scan");
    let counting = Scan::new(
        &ctx.device,
        &ScanDescriptor {
            debug_counters: true,
            ..desc
        },
    )
    .expect("scan with counters");
    // The peer: lampshade's prefix sum (multi-pass), recorded into the same encoder on the
    // same device over the same buffers. Its workspace is allocated on its first recording,
    // which the warm-up run of every timing does.
    let lampshade = std::cell::RefCell::new(lampshade::Scanner::new_for_adapter(
        &ctx.device,
        &ctx.queue,
        &ctx.info,
    ));
    let copy = CopyKernel::new(&ctx.device);
    let rts = ReduceThenScan::new(&ctx.device, max_n);
    let mut rng = StdRng::seed_from_u64(1);
    let host_input: Vec<u32> = (0..max_n).map(|_| rng.random()).collect();
    let input = buffers::storage_from(&ctx.device, "input", &host_input);
    let output = buffers::storage_zeroed(&ctx.device, "output", u64::from(max_n) * 4);
    let mut host_output = vec![0u32; max_n as usize];
    let host_scan = |input: &[u32], output: &mut [u32]| {
        let mut sum = 0u32;
        for (o, &x) in output.iter_mut().zip(input) {
            *o = sum;
            sum = sum.wrapping_add(x);
        }
    };

    let mut lines = Vec::new();
    for &n in &sizes {
        let bound = scan
            .bind(&ctx.device, &input, &output, n, ScanKind::Exclusive, None)
            .expect("bind");
        let record_scan =
            |enc: &mut wgpu::CommandEncoder| scan.encode(enc, &bound).expect("encode");
        let record_copy =
            |enc: &mut wgpu::CommandEncoder| copy.encode(&ctx.device, enc, &input, &output, n / 4);
        let record_rts = |enc: &mut wgpu::CommandEncoder| {
            rts.encode(&ctx.device, enc, &input, &output, n, RtsStages::All)
        };
        let record_lampshade = |enc: &mut wgpu::CommandEncoder| {
            lampshade
                .borrow_mut()
                .record_exclusive_scan(enc, &input, &output, n)
                .expect("lampshade scan")
        };
        let record_tile = |enc: &mut wgpu::CommandEncoder| {
            rts.encode(
                &ctx.device,
                enc,
                &input,
                &output,
                n,
                RtsStages::DownsweepOnly,
            )
        };

        if with_criterion {
            let label = format!("2^{}", n.ilog2());
            let mut group = c.benchmark_group(format!("gpu-scan/{label}"));
            group.throughput(Throughput::Elements(u64::from(n)));
            group.sample_size(10);
            group.warm_up_time(Duration::from_millis(500));
            group.measurement_time(Duration::from_secs(if n >= 1 << 24 { 6 } else { 2 }));
            group.bench_function("scan_exclusive", |b| {
                b.iter_custom(|iters| bench::gpu_time(ctx, iters, record_scan))
            });
            group.bench_function("copy_vec4", |b| {
                b.iter_custom(|iters| bench::gpu_time(ctx, iters, record_copy))
            });
            group.bench_function("lampshade_scan", |b| {
                b.iter_custom(|iters| bench::gpu_time(ctx, iters, record_lampshade))
            });
            group.bench_function("reduce_then_scan", |b| {
                b.iter_custom(|iters| bench::gpu_time(ctx, iters, record_rts))
            });
            group.bench_function("host_scan", |b| {
                b.iter(|| {
                    host_scan(
                        std::hint::black_box(&host_input[..n as usize]),
                        &mut host_output[..n as usize],
                    )
                })
            });
            group.finish();
        }

        // The RESULT numbers: interleaved timed runs so that drift hits every kernel alike.
        let reps = if n >= 1 << 24 { 5 } else { 15 };
        let (mut scan_ms, mut copy_ms, mut rts_ms, mut tile_ms, mut ls_ms) =
            (0.0, 0.0, 0.0, 0.0, 0.0);
        for _ in 0..reps {
            scan_ms += bench::gpu_ms(ctx, 1, record_scan);
            copy_ms += bench::gpu_ms(ctx, 1, record_copy);
            rts_ms += bench::gpu_ms(ctx, 1, record_rts);
            tile_ms += bench::gpu_ms(ctx, 1, record_tile);
            ls_ms += bench::gpu_ms(ctx, 1, record_lampshade);
        }
        let r = f64::from(reps);
        let (scan_ms, copy_ms, rts_ms, tile_ms, ls_ms) =
            (scan_ms / r, copy_ms / r, rts_ms / r, tile_ms / r, ls_ms / r);
        // The peer's output must be the same scan (checked once per size, first words).
        check_peer(ctx, &scan, &input, &output, n, record_lampshade);
        let t0 = std::time::Instant::now(); // the host has no GPU timestamps
        let host_reps = 5;
        for _ in 0..host_reps {
            host_scan(
                std::hint::black_box(&host_input[..n as usize]),
                &mut host_output[..n as usize],
            );
        }
        let host_ms = t0.elapsed().as_secs_f64() * 1e3 / f64::from(host_reps);

        // Look-back behaviour at this size, from one run with debug counters.
        let mut counters = ScanCounters::default();
        let runs = 3;
        for _ in 0..runs {
            gpu::run(ctx, |enc| {
                counting.clear_counters(enc);
                counting
                    .bind_and_encode(
                        &ctx.device,
                        enc,
                        &input,
                        &output,
                        n,
                        ScanKind::Exclusive,
                        None,
                    )
                    .expect("encode");
            });
            let words: Vec<u32> =
                buffers::read(ctx, counting.counters_buffer().expect("counters")).unwrap();
            let c: ScanCounters = bytemuck::pod_read_unaligned(bytemuck::cast_slice(&words[..4]));
            counters.tiles += c.tiles;
            counters.lookback_steps += c.lookback_steps;
            counters.failed_polls += c.failed_polls;
            counters.fallbacks += c.fallbacks;
        }
        let tiles = n.div_ceil(scan.tile_len());
        let per_tile = |x: u32| f64::from(x) / f64::from(counters.tiles.max(1));
        let eps = |ms: f64| bench::sci(f64::from(n) / ms * 1e3);
        let line = bench::result_line(
            ctx,
            "gpu-scan",
            &[
                ("n", n.to_string()),
                ("scan_vs_copy", format!("{:.3}", copy_ms / scan_ms)),
                ("scan_vs_rts", format!("{:.3}", rts_ms / scan_ms)),
                ("scan_vs_lampshade", format!("{:.3}", ls_ms / scan_ms)),
                ("scan_vs_host", format!("{:.3}", host_ms / scan_ms)),
                ("tile_vs_copy", format!("{:.3}", copy_ms / tile_ms)),
                ("scan_elem_s", eps(scan_ms)),
                ("copy_elem_s", eps(copy_ms)),
                ("rts_elem_s", eps(rts_ms)),
                ("lampshade_elem_s", eps(ls_ms)),
                ("host_elem_s", eps(host_ms)),
                ("tiles", tiles.to_string()),
                (
                    "us_per_tile",
                    format!("{:.2}", scan_ms * 1e3 / f64::from(tiles)),
                ),
                (
                    "lookback_steps_per_tile",
                    format!("{:.3}", per_tile(counters.lookback_steps)),
                ),
                (
                    "failed_polls_per_tile",
                    format!("{:.3}", per_tile(counters.failed_polls)),
                ),
                (
                    "fallbacks_per_tile",
                    format!("{:.4}", per_tile(counters.fallbacks)),
                ),
                ("subgroups", desc.use_subgroups.to_string()),
                ("workgroup_size", scan.config().workgroup_size.to_string()),
                (
                    "items_per_thread",
                    scan.config().items_per_thread.to_string(),
                ),
            ],
        );
        println!("{line}");
        lines.push(line);
    }
    // Repeat them together at the end (the last one is the largest n).
    println!();
    for line in lines {
        println!("{line}");
    }
}

/// Runs our scan and the peer's on the same input and compares a sample of the outputs, so the
/// comparison is between two kernels that compute the same thing.
fn check_peer(
    ctx: &tests::GpuContext,
    scan: &Scan,
    input: &wgpu::Buffer,
    output: &wgpu::Buffer,
    n: u32,
    record_peer: impl FnOnce(&mut wgpu::CommandEncoder),
) {
    let bytes = u64::from(n.min(1 << 16)) * 4;
    let tail = u64::from(n) * 4 - bytes;
    gpu::run(ctx, |enc| {
        scan.bind_and_encode(
            &ctx.device,
            enc,
            input,
            output,
            n,
            ScanKind::Exclusive,
            None,
        )
        .expect("encode")
    });
    let ours: Vec<u32> = buffers::read_range(ctx, output, tail, bytes).unwrap();
    gpu::run(ctx, |enc| enc.clear_buffer(output, 0, None));
    gpu::run(ctx, record_peer);
    let theirs: Vec<u32> = buffers::read_range(ctx, output, tail, bytes).unwrap();
    assert!(
        ours == theirs,
        "lampshade's exclusive scan differs from ours at n = {n}"
    );
}

criterion_group!(benches, scan_bench);
criterion_main!(benches);
