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
use gpu_scan::{Scan, ScanBinding, ScanCounters, ScanDescriptor, ScanKind};
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
    let bench = Bench::new(ctx, *sizes.iter().max().unwrap());
    let mut lines = Vec::new();
    for &n in &sizes {
        let line = bench.measure(c, n, with_criterion);
        println!("{line}");
        lines.push(line);
    }
    // Repeat them together at the end (the last one is the largest n).
    println!();
    for line in lines {
        println!("{line}");
    }
}

/// What every size is measured with: our scan (and one with debug counters), the peer, the
/// floors and the input.
struct Bench {
    ctx: &'static tests::GpuContext,
    desc: ScanDescriptor,
    scan: Scan,
    counting: Scan,
    lampshade: std::cell::RefCell<lampshade::Scanner>,
    copy: CopyKernel,
    rts: ReduceThenScan,
    host_input: Vec<u32>,
    input: wgpu::Buffer,
    output: wgpu::Buffer,
}

impl Bench {
    fn new(ctx: &'static tests::GpuContext, max_n: u32) -> Self {
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
        Self {
            ctx,
            desc,
            scan,
            counting,
            lampshade,
            copy,
            rts,
            host_input,
            input,
            output,
        }
    }

    /// Records kernel `k` over the first `n` elements (`bound`: our scan bound to them).
    fn record(&self, k: Kernel, n: u32, bound: &ScanBinding, enc: &mut wgpu::CommandEncoder) {
        let (device, input, output) = (&self.ctx.device, &self.input, &self.output);
        match k {
            Kernel::Scan => self.scan.encode(enc, bound).expect("encode"),
            Kernel::Copy => self.copy.encode(device, enc, input, output, n / 4),
            Kernel::Rts => self
                .rts
                .encode(device, enc, input, output, n, RtsStages::All),
            Kernel::Tile => {
                let stages = RtsStages::DownsweepOnly;
                self.rts.encode(device, enc, input, output, n, stages)
            }
            Kernel::Lampshade => self
                .lampshade
                .borrow_mut()
                .record_exclusive_scan(enc, input, output, n)
                .expect("lampshade scan"),
        }
    }

    /// Size `n`: its criterion group (`with_criterion`) and its RESULT line.
    fn measure(&self, c: &mut Criterion, n: u32, with_criterion: bool) -> String {
        let mut host_output = vec![0u32; n as usize];
        let (input, output) = (&self.input, &self.output);
        let exclusive = ScanKind::Exclusive;
        let bound = &(self.scan)
            .bind(&self.ctx.device, input, output, n, exclusive, None)
            .expect("bind");
        let record =
            |k: Kernel| move |enc: &mut wgpu::CommandEncoder| self.record(k, n, bound, enc);
        let [scan, copy, rts, tile, peer] = Kernel::ALL.map(record);

        if with_criterion {
            let kernels: [(&str, Record); 4] = [
                ("scan_exclusive", &scan),
                ("copy_vec4", &copy),
                ("lampshade_scan", &peer),
                ("reduce_then_scan", &rts),
            ];
            criterion_group_of(c, self.ctx, n, &kernels, &mut || {
                host_scan(
                    std::hint::black_box(&self.host_input[..n as usize]),
                    &mut host_output[..n as usize],
                )
            });
        }

        // The RESULT numbers: interleaved timed runs so that drift hits every kernel alike.
        let reps = if n >= 1 << 24 { 5 } else { 15 };
        let kernels: [Record; 5] = [&scan, &copy, &rts, &tile, &peer];
        let [scan_ms, copy_ms, rts_ms, tile_ms, ls_ms] = interleaved_ms(self.ctx, reps, kernels);
        // The peer's output must be the same scan (checked once per size, first words).
        check_peer(self.ctx, &self.scan, input, output, n, peer);
        let host_ms = host_ms(&self.host_input[..n as usize], &mut host_output);

        // Look-back behaviour at this size, from runs with debug counters.
        let counters = lookback_counters(self.ctx, &self.counting, &self.input, &self.output, n);
        let times = Times {
            scan: scan_ms,
            copy: copy_ms,
            rts: rts_ms,
            tile: tile_ms,
            lampshade: ls_ms,
            host: host_ms,
        };
        result_line(
            self.ctx,
            &self.scan,
            self.desc.use_subgroups,
            n,
            &times,
            &counters,
        )
    }
}

/// Mean wall milliseconds of the host's scan of `input` (the host has no GPU timestamps).
fn host_ms(input: &[u32], output: &mut [u32]) -> f64 {
    let t0 = std::time::Instant::now();
    let reps = 5;
    for _ in 0..reps {
        host_scan(std::hint::black_box(input), output);
    }
    t0.elapsed().as_secs_f64() * 1e3 / f64::from(reps)
}

/// A kernel's recording into an encoder.
type Record<'a> = &'a dyn Fn(&mut wgpu::CommandEncoder);

/// The kernels each size times.
#[derive(Clone, Copy)]
enum Kernel {
    /// Ours, exclusive.
    Scan,
    /// The vec4 copy floor.
    Copy,
    /// Our reduce-then-scan.
    Rts,
    /// The reduce-then-scan's downsweep alone (a tile-local scan).
    Tile,
    /// The peer.
    Lampshade,
}

impl Kernel {
    const ALL: [Kernel; 5] = [
        Kernel::Scan,
        Kernel::Copy,
        Kernel::Rts,
        Kernel::Tile,
        Kernel::Lampshade,
    ];
}

/// Records `scan` bound now as an exclusive scan of `n` elements, input to output.
fn encode_exclusive(
    ctx: &tests::GpuContext,
    scan: &Scan,
    enc: &mut wgpu::CommandEncoder,
    [input, output]: [&wgpu::Buffer; 2],
    n: u32,
) {
    let kind = ScanKind::Exclusive;
    (scan.bind_and_encode(&ctx.device, enc, input, output, n, kind, None)).expect("encode")
}

/// The host's serial exclusive scan.
fn host_scan(input: &[u32], output: &mut [u32]) {
    let mut sum = 0u32;
    for (o, &x) in output.iter_mut().zip(input) {
        *o = sum;
        sum = sum.wrapping_add(x);
    }
}

/// Mean GPU milliseconds of one run of each of `kernels`, over `reps` rounds that run each
/// once in turn.
fn interleaved_ms<const K: usize>(
    ctx: &tests::GpuContext,
    reps: u32,
    kernels: [Record; K],
) -> [f64; K] {
    let mut ms = [0.0; K];
    for _ in 0..reps {
        for (sum, record) in ms.iter_mut().zip(kernels) {
            *sum += bench::gpu_ms(ctx, 1, record);
        }
    }
    ms.map(|m| m / f64::from(reps))
}

/// The criterion group of size `n`: each GPU kernel timed with GPU timestamps, and the host
/// scan.
fn criterion_group_of(
    c: &mut Criterion,
    ctx: &tests::GpuContext,
    n: u32,
    kernels: &[(&str, Record)],
    host: &mut dyn FnMut(),
) {
    let mut group = c.benchmark_group(format!("gpu-scan/2^{}", n.ilog2()));
    group.throughput(Throughput::Elements(u64::from(n)));
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(if n >= 1 << 24 { 6 } else { 2 }));
    for (name, record) in kernels {
        group.bench_function(*name, |b| {
            b.iter_custom(|iters| bench::gpu_time(ctx, iters, record))
        });
    }
    group.bench_function("host_scan", |b| b.iter(&mut *host));
    group.finish();
}

/// The look-back's counters summed over 3 runs of `counting` (a scan with debug counters).
fn lookback_counters(
    ctx: &tests::GpuContext,
    counting: &Scan,
    input: &wgpu::Buffer,
    output: &wgpu::Buffer,
    n: u32,
) -> ScanCounters {
    let mut counters = ScanCounters::default();
    for _ in 0..3 {
        gpu::run(ctx, |enc| {
            counting.clear_counters(enc);
            encode_exclusive(ctx, counting, enc, [input, output], n);
        });
        let words: Vec<u32> =
            buffers::read(ctx, counting.counters_buffer().expect("counters")).unwrap();
        let c: ScanCounters = bytemuck::pod_read_unaligned(bytemuck::cast_slice(&words[..4]));
        counters.tiles += c.tiles;
        counters.lookback_steps += c.lookback_steps;
        counters.failed_polls += c.failed_polls;
        counters.fallbacks += c.fallbacks;
    }
    counters
}

/// Mean milliseconds of one run of each kernel at one size.
struct Times {
    scan: f64,
    copy: f64,
    rts: f64,
    tile: f64,
    lampshade: f64,
    host: f64,
}

/// The RESULT line of size `n`.
fn result_line(
    ctx: &tests::GpuContext,
    scan: &Scan,
    subgroups: bool,
    n: u32,
    t: &Times,
    counters: &ScanCounters,
) -> String {
    let tiles = n.div_ceil(scan.tile_len());
    let per_tile = |x: u32| f64::from(x) / f64::from(counters.tiles.max(1));
    let eps = |ms: f64| bench::sci(f64::from(n) / ms * 1e3);
    bench::result_line(
        ctx,
        "gpu-scan",
        &[
            ("n", n.to_string()),
            ("scan_vs_copy", format!("{:.3}", t.copy / t.scan)),
            ("scan_vs_rts", format!("{:.3}", t.rts / t.scan)),
            ("scan_vs_lampshade", format!("{:.3}", t.lampshade / t.scan)),
            ("scan_vs_host", format!("{:.3}", t.host / t.scan)),
            ("tile_vs_copy", format!("{:.3}", t.copy / t.tile)),
            ("scan_elem_s", eps(t.scan)),
            ("copy_elem_s", eps(t.copy)),
            ("rts_elem_s", eps(t.rts)),
            ("lampshade_elem_s", eps(t.lampshade)),
            ("host_elem_s", eps(t.host)),
            ("tiles", tiles.to_string()),
            (
                "us_per_tile",
                format!("{:.2}", t.scan * 1e3 / f64::from(tiles)),
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
            ("subgroups", subgroups.to_string()),
            ("workgroup_size", scan.config().workgroup_size.to_string()),
            (
                "items_per_thread",
                scan.config().items_per_thread.to_string(),
            ),
        ],
    )
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
        encode_exclusive(ctx, scan, enc, [input, output], n)
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
