//! gpu-hash: finds/s and inserts/s at 2^20 and 2^22 items, with uniform keys (all distinct,
//! table at load 0.5) and heavily duplicated keys (each key 32 times), against the random
//! 128-byte read floor (find) and the random atomic floor (insert) measured in the same run.
//!
//! Inserts are timed as a GPU timestamp span around the insert pass alone (the table is
//! cleared in a separate span before each one); finds run against the filled table.

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use gpu_hash::{CellSizing, HASH_FULL, HashBatch, HashGridParams, HashKey, HashTable, TableConfig};
use rand::{Rng, SeedableRng, rngs::StdRng, seq::SliceRandom};
use restir_world::{GpuContext, GpuTimer};
use tests::{
    bench, buffers,
    floors::{RandomAccess, RandomAccessKernel},
    gpu,
};

const REPS: u32 = 3;

struct Case {
    n: u32,
    /// Each key 32 times (else all distinct).
    dup: bool,
    table: HashTable,
    keys: wgpu::Buffer,
    slots: wgpu::Buffer,
}

fn keys(n: u32, dup: bool, seed: u64) -> Vec<HashKey> {
    let mut rng = StdRng::seed_from_u64(seed);
    let distinct = if dup { n / 32 } else { n };
    let mut seen = std::collections::HashSet::new();
    let mut unique = Vec::with_capacity(distinct as usize);
    while unique.len() < distinct as usize {
        let k = HashKey {
            coords: [rng.random(), rng.random(), rng.random()],
            level: rng.random_range(0..8),
        };
        if seen.insert(k) {
            unique.push(k);
        }
    }
    let mut all: Vec<HashKey> = (0..n as usize).map(|i| unique[i % unique.len()]).collect();
    all.shuffle(&mut rng);
    all
}

fn case(ctx: &GpuContext, n: u32, dup: bool, probe_buckets: u32) -> Case {
    // Uniform keys fill half the slots.
    let config = TableConfig {
        num_buckets: n / 16,
        probe_buckets,
        ..TableConfig::default()
    };
    let params = HashGridParams::new(&config, &CellSizing::default(), Vec3::ZERO)
        .expect("valid hash params");
    let table = HashTable::new(&ctx.device, &ctx.queue, &params).expect("hash table fits");
    let keys = buffers::storage_from(&ctx.device, "keys", &keys(n, dup, u64::from(n) + 7));
    let slots = buffers::storage_zeroed(&ctx.device, "slots", u64::from(n) * 4);
    Case {
        n,
        dup,
        table,
        keys,
        slots,
    }
}

/// Mean GPU milliseconds of the insert span (after a cleared table), over `REPS` runs.
fn insert_ms(ctx: &GpuContext, batch: &HashBatch, c: &Case) -> f64 {
    let bound = batch
        .bind(
            &ctx.device,
            gpu_hash::BatchKernel::InsertKeys,
            &c.table,
            &c.keys,
            &c.slots,
            c.n,
        )
        .expect("bind insert batch");
    let mut total = 0.0;
    for rep in 0..=REPS {
        let mut timer = GpuTimer::new(ctx);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        timer.span(&mut enc, "clear", |enc| c.table.encode_clear(enc));
        timer.span(&mut enc, "insert", |enc| {
            batch.encode(enc, &bound).expect("insert batch")
        });
        timer.resolve(&mut enc);
        ctx.queue.submit([enc.finish()]);
        let t = timer.read(ctx).expect("benchmark needs GPU timestamps");
        if rep > 0 {
            total += t.get("insert").expect("insert span");
        }
    }
    total / f64::from(REPS)
}

fn hash(c: &mut Criterion) {
    let ctx = gpu::context();
    let batch = HashBatch::new(&ctx.device).expect("hash batch");
    let floors = RandomAccessKernel::new(&ctx.device);
    let mut group = c.benchmark_group("gpu-hash");
    group.sample_size(10);
    group.warm_up_time(std::time::Duration::from_millis(500));
    group.measurement_time(std::time::Duration::from_secs(2));
    let mut lines = Vec::new();
    for n in [1u32 << 20, 1 << 22] {
        // Floors over a table of the same bytes as the hash table's checksums.
        let table_bytes = u64::from(n / 16) * 32 * 4;
        let floor_table = buffers::storage_zeroed(&ctx.device, "floor table", table_bytes);
        let floor_out = buffers::storage_zeroed(&ctx.device, "floor out", u64::from(n) * 4);
        let floor = |enc: &mut wgpu::CommandEncoder, kind| {
            floors.encode(&ctx.device, enc, kind, &floor_table, &floor_out, n)
        };
        // Criterion samples only the smaller size: on lavapipe one 2^22 insert takes seconds.
        let sampled = n == 1 << 20;
        group.throughput(Throughput::Elements(u64::from(n)));
        if sampled {
            group.bench_function(format!("floor_random_read_128/{n}"), |b| {
                b.iter_custom(|iters| {
                    bench::gpu_time(ctx, iters, |enc| floor(enc, RandomAccess::Read128))
                })
            });
            group.bench_function(format!("floor_random_atomic/{n}"), |b| {
                b.iter_custom(|iters| {
                    bench::gpu_time(ctx, iters, |enc| floor(enc, RandomAccess::Atomic))
                })
            });
        }

        // The paper's bucket-local table (probe_buckets 1) with both key sets, and uniform keys
        // with spilling into up to 7 following buckets.
        for (dup, probe_buckets) in [(false, 1), (true, 1), (false, 8)] {
            let c = case(ctx, n, dup, probe_buckets);
            let group = sampled.then_some(&mut group);
            lines.push(measure_case(ctx, &batch, group, &floor, &c, probe_buckets));
        }
    }
    group.finish();
    for pairs in &lines {
        bench::print_result(ctx, "gpu-hash", pairs);
    }
}

/// The RESULT pairs of one case (its finds and inserts against the floors measured around
/// it), and its criterion samples when `group` is given.
fn measure_case(
    ctx: &GpuContext,
    batch: &HashBatch,
    group: Option<&mut BenchmarkGroup<WallTime>>,
    floor: &dyn Fn(&mut wgpu::CommandEncoder, RandomAccess),
    c: &Case,
    probe_buckets: u32,
) -> Vec<(&'static str, String)> {
    let (n, label) = (c.n, if c.dup { "dup" } else { "uniform" });
    // Floors measured next to each case (before and after), so load from other
    // processes on a shared CPU device shifts both sides of the ratio alike.
    let floors_ms = || {
        (
            bench::gpu_ms(ctx, REPS, |enc| floor(enc, RandomAccess::Read128)),
            bench::gpu_ms(ctx, REPS, |enc| floor(enc, RandomAccess::Atomic)),
        )
    };
    let (read_before, atomic_before) = floors_ms();
    let ins_ms = insert_ms(ctx, batch, c);
    let slots: Vec<u32> = buffers::read(ctx, &c.slots).expect("readback");
    let lost = slots[..n as usize]
        .iter()
        .filter(|&&s| s == HASH_FULL)
        .count();
    let stats = batch
        .read_stats(&ctx.device, &ctx.queue, &c.table)
        .expect("stats");
    let bind = |kernel| {
        batch
            .bind(&ctx.device, kernel, &c.table, &c.keys, &c.slots, c.n)
            .expect("bind batch")
    };
    let find_bound = bind(gpu_hash::BatchKernel::FindKeys);
    let insert_bound = bind(gpu_hash::BatchKernel::InsertKeys);
    let find = |enc: &mut wgpu::CommandEncoder| batch.encode(enc, &find_bound).expect("find batch");
    if let Some(group) = group {
        group.bench_function(format!("find/{label}/p{probe_buckets}/{n}"), |b| {
            b.iter_custom(|iters| bench::gpu_time(ctx, iters, find))
        });
        group.bench_function(
            format!("clear_and_insert/{label}/p{probe_buckets}/{n}"),
            |b| {
                b.iter_custom(|iters| {
                    bench::gpu_time(ctx, iters, |enc| {
                        c.table.encode_clear(enc);
                        batch.encode(enc, &insert_bound).expect("insert batch")
                    })
                })
            },
        );
    }
    let find_ms = bench::gpu_ms(ctx, REPS, find);
    let (read_after, atomic_after) = floors_ms();
    let read_floor_ms = 0.5 * (read_before + read_after);
    let atomic_floor_ms = 0.5 * (atomic_before + atomic_after);
    let per_s = |ms: f64| f64::from(n) / ms * 1e3;
    vec![
        ("n", n.to_string()),
        ("keys", label.to_string()),
        ("probe_buckets", probe_buckets.to_string()),
        ("find_vs_floor", format!("{:.3}", read_floor_ms / find_ms)),
        (
            "insert_vs_floor",
            format!("{:.3}", atomic_floor_ms / ins_ms),
        ),
        ("finds_per_s", bench::sci(per_s(find_ms))),
        ("inserts_per_s", bench::sci(per_s(ins_ms))),
        ("read_floor_per_s", bench::sci(per_s(read_floor_ms))),
        ("atomic_floor_per_s", bench::sci(per_s(atomic_floor_ms))),
        (
            "load",
            format!("{:.3}", f64::from(stats.used_slots) / f64::from(n * 2)),
        ),
        ("lost", lost.to_string()),
        ("max_probe", stats.max_probe().to_string()),
    ]
}

criterion_group!(benches, hash);
criterion_main!(benches);
