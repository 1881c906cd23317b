//! GPU tests of gpu-hash on the shared device: every kernel against its Rust twin, the table
//! under heavy duplication, adversarial buckets, load, bad positions, and a consumer kernel that
//! composes both roles (build this frame, look up the last).

use glam::Vec3;
use gpu_hash::{
    BatchKernel, CellSizing, CpuHashTable, HASH_FULL, HASH_NOT_FOUND, HASH_REJECTED, HashBatch,
    HashCell, HashGridParams, HashKey, HashStats, HashTable, TableConfig, cell,
};
use rand::{Rng, SeedableRng, rngs::StdRng, seq::SliceRandom};
use tests::{GpuContext, buffers, gpu};

struct Fixture {
    ctx: &'static GpuContext,
    batch: HashBatch,
}

fn fixture() -> Fixture {
    let ctx = gpu::context();
    Fixture {
        ctx,
        batch: HashBatch::new(&ctx.device).expect("hash batch"),
    }
}

fn params(config: TableConfig, eye: Vec3) -> HashGridParams {
    HashGridParams::new(&config, &CellSizing::default(), eye).unwrap()
}

impl Fixture {
    fn table(&self, p: &HashGridParams) -> HashTable {
        let t = HashTable::new(&self.ctx.device, &self.ctx.queue, p).unwrap();
        gpu::run(self.ctx, |enc| t.encode_clear(enc));
        t
    }

    fn stats(&self, t: &HashTable) -> HashStats {
        self.batch
            .read_stats(&self.ctx.device, &self.ctx.queue, t)
            .unwrap()
    }

    fn insert_keys(&self, t: &HashTable, keys: &[HashKey]) -> Vec<u32> {
        self.keys_kernel(t, keys, true)
    }

    fn find_keys(&self, t: &HashTable, keys: &[HashKey]) -> Vec<u32> {
        self.keys_kernel(t, keys, false)
    }

    fn keys_kernel(&self, t: &HashTable, keys: &[HashKey], insert: bool) -> Vec<u32> {
        let kernel = match insert {
            true => BatchKernel::InsertKeys,
            false => BatchKernel::FindKeys,
        };
        let input = buffers::storage_from(&self.ctx.device, "keys", keys);
        self.run_batch(t, kernel, &input, keys.len())
    }

    /// (slot, index in slot) per point on insert, (slot, count) on find.
    fn points_kernel(&self, t: &HashTable, points: &[Vec3], insert: bool) -> Vec<[u32; 2]> {
        let kernel = match insert {
            true => BatchKernel::InsertPoints,
            false => BatchKernel::FindPoints,
        };
        let p4: Vec<[f32; 4]> = points.iter().map(|p| p.extend(1.0).to_array()).collect();
        let input = buffers::storage_from(&self.ctx.device, "points", &p4);
        self.run_batch(t, kernel, &input, points.len())
    }

    /// Runs `kernel` on `t` over the first `n` items of `input`; returns one `T` per item.
    fn run_batch<T: bytemuck::Pod>(
        &self,
        t: &HashTable,
        kernel: BatchKernel,
        input: &wgpu::Buffer,
        n: usize,
    ) -> Vec<T> {
        let d = &self.ctx.device;
        let out = buffers::storage_zeroed(d, "out", (n * size_of::<T>()) as u64);
        gpu::run(self.ctx, |enc| {
            self.batch
                .bind_and_encode(d, enc, kernel, t, input, &out, n as u32)
                .unwrap()
        });
        let mut v: Vec<T> = buffers::read(self.ctx, &out).unwrap();
        v.truncate(n);
        v
    }

    fn checksums(&self, t: &HashTable) -> Vec<u32> {
        buffers::read(self.ctx, t.checksums()).unwrap()
    }
}

fn random_keys(rng: &mut StdRng, n: usize, level: u32) -> Vec<HashKey> {
    let mut seen = std::collections::HashSet::new();
    let mut keys = Vec::with_capacity(n);
    while keys.len() < n {
        let k = HashKey {
            coords: [
                rng.random_range(-100_000..100_000),
                rng.random_range(-100_000..100_000),
                rng.random_range(-100_000..100_000),
            ],
            level,
        };
        if seen.insert(k) {
            keys.push(k);
        }
    }
    keys
}

#[test]
fn layouts_match_naga() {
    use gpu_hash::wgsl::{BindAt, compose};
    let src = compose(
        Some(BindAt {
            group: 0,
            first_binding: 0,
        }),
        None,
    );
    tests::assert_wgsl_layout!(
        HashGridParams,
        src,
        "HashGridParams",
        [
            eye,
            level_scale,
            min_cell_size,
            inv_min_cell_size,
            max_level,
            num_buckets,
            slots_per_bucket,
            probe_buckets
        ]
    );
    tests::assert_wgsl_layout!(HashKey, src, "HashKey", [coords, level]);
    tests::assert_wgsl_layout!(
        HashCell,
        src,
        "HashCell",
        [coords, level, bucket, checksum, cell_size, status]
    );
    tests::assert_wgsl_layout!(
        HashStats,
        src,
        "HashStatsAtomic",
        [
            overflows,
            rejected_nonfinite,
            rejected_out_of_range,
            max_spill_probe,
            used_slots,
            max_bucket_fill,
            full_buckets,
            reserved
        ]
    );
}

#[test]
fn gpu_hashes_are_bit_identical_to_twins() {
    let f = fixture();
    let t = f.table(&params(TableConfig::default(), Vec3::ZERO));
    let mut rng = StdRng::seed_from_u64(1);
    let mut values: Vec<u32> = (0..1 << 16).map(|_| rng.random()).collect();
    values.extend([0, 1, 2, 0x7fff_ffff, 0x8000_0000, u32::MAX]);
    let input: Vec<[u32; 4]> = values.iter().map(|&v| [v, 0, 0, 0]).collect();
    let inb = buffers::storage_from(&f.ctx.device, "values", &input);
    let got: Vec<[u32; 2]> = f.run_batch(&t, BatchKernel::HashValues, &inb, values.len());
    for (v, g) in values.iter().zip(&got) {
        assert_eq!(
            *g,
            [gpu_hash::hash::pcg(*v), gpu_hash::hash::xxhash32(*v)],
            "input {v:#x}"
        );
    }
}

/// Whether `x` lies within `rel` (relative) of a boundary the float pipeline may round across.
fn near_power_of_two(x: f64, rel: f64) -> bool {
    x > 0.0 && {
        let l = x.log2();
        (l - l.round()).abs() < rel
    }
}

fn near_integer(x: f64, rel: f64) -> bool {
    (x - x.round()).abs() <= rel * x.abs().max(1.0)
}

#[test]
fn cell_keys_match_twin_on_1e5_positions_from_1e_3_to_1e4() {
    let f = fixture();
    let eye = Vec3::new(3.5, -2.25, 7.0);
    let p = params(TableConfig::default(), eye);
    let t = f.table(&p);
    let mut rng = StdRng::seed_from_u64(2);
    let mut points = vec![eye];
    while points.len() < 100_000 {
        let dir = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if dir.length_squared() < 1e-4 || dir.length_squared() > 1.0 {
            continue;
        }
        let dist = 10f32.powf(rng.random_range(-3.0..4.0));
        points.push(eye + dir.normalize() * dist);
    }
    let p4: Vec<[f32; 4]> = points.iter().map(|q| q.extend(0.0).to_array()).collect();
    let inb = buffers::storage_from(&f.ctx.device, "points", &p4);
    let got: Vec<HashCell> = f.run_batch(&t, BatchKernel::Cells, &inb, points.len());
    let mut mismatches = 0;
    let mut levels = std::collections::BTreeSet::new();
    for (q, g) in points.iter().zip(&got) {
        let want = p.cell(*q);
        assert!(want.is_ok() && g.is_ok(), "{q}: {want:?} {g:?}");
        levels.insert(want.level);
        // Hashing is exact: the GPU's bucket and checksum are the twin's for the GPU's key.
        assert_eq!(g.bucket, g.key().bucket(p.num_buckets), "{q}");
        assert_eq!(g.checksum, g.key().checksum(), "{q}");
        assert_eq!(g.cell_size, p.cell_size_at(g.level));
        if *g != want {
            // Allowed only where the GPU's sqrt/FMA may round across a level or cell boundary.
            mismatches += 1;
            let dist = f64::from((*q - eye).length());
            let ratio = dist * f64::from(p.level_scale);
            let scale = f64::from(p.inv_min_cell_size) * 2f64.powi(-(want.level as i32));
            let explained = near_power_of_two(ratio, 1e-5)
                || q.to_array()
                    .iter()
                    .any(|&c| near_integer(f64::from(c) * scale, 1e-6));
            assert!(explained, "{q}: GPU {g:?} twin {want:?}");
        }
    }
    eprintln!(
        "cells: {} positions, levels {:?}, {mismatches} boundary mismatches",
        points.len(),
        levels
    );
    assert_eq!(got[0].level, 0, "distance 0 is level 0");
    // Default sizing: level 0 up to ~0.6 m, level 13 at 1e4 m.
    assert!(
        levels.len() >= 13,
        "distances 1e-3..1e4 should span many levels: {levels:?}"
    );
    assert!(mismatches <= 20, "{mismatches} mismatches");
}

#[test]
fn jitter_matches_twin_and_stays_in_tangent_plane() {
    let f = fixture();
    let t = f.table(&params(TableConfig::default(), Vec3::ZERO));
    let mut rng = StdRng::seed_from_u64(3);
    let n = 10_000;
    let mut input = Vec::with_capacity(3 * n);
    let mut cases = Vec::with_capacity(n);
    for i in 0..n {
        let pos = Vec3::new(
            rng.random_range(-50.0..50.0),
            rng.random_range(-50.0..50.0),
            rng.random_range(-50.0..50.0),
        );
        let normal = match i {
            0 => Vec3::Z,
            1 => -Vec3::Z,
            _ => Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize_or(Vec3::X),
        };
        let u = [rng.random::<f32>(), rng.random::<f32>()];
        let size = 2f32.powi(rng.random_range(-6..6));
        input.push(pos.extend(0.0).to_array());
        input.push(normal.extend(0.0).to_array());
        input.push([u[0], u[1], size, 0.0]);
        cases.push((pos, normal, u, size));
    }
    let inb = buffers::storage_from(&f.ctx.device, "jitter in", &input);
    let got: Vec<[f32; 4]> = f.run_batch(&t, BatchKernel::Jitter, &inb, n);
    for ((pos, normal, u, size), g) in cases.iter().zip(&got) {
        let g = Vec3::new(g[0], g[1], g[2]);
        let want = gpu_hash::jitter(*pos, *normal, *u, *size);
        let tol = 1e-5 * (pos.abs().max_element() + size);
        assert!((g - want).abs().max_element() <= tol, "{g} vs {want}");
        let off = g - *pos;
        assert!(off.dot(*normal).abs() <= tol, "off-plane offset {off}");
        assert!(off.length() <= size * 0.5 * std::f32::consts::SQRT_2 + tol);
    }
}

#[test]
fn heavy_duplication_2p20_inserts_of_2p16_keys() {
    let f = fixture();
    let config = TableConfig::default();
    let p = params(config, Vec3::ZERO);
    let t = f.table(&p);
    let mut rng = StdRng::seed_from_u64(4);
    let distinct = random_keys(&mut rng, 1 << 16, 0);
    // Distinct keys never share (bucket, checksum) at this seed, so each must own a slot.
    let ids: std::collections::HashSet<(u32, u32)> = distinct
        .iter()
        .map(|k| (k.bucket(config.num_buckets), k.checksum()))
        .collect();
    assert_eq!(ids.len(), distinct.len());
    let mut which: Vec<usize> = (0..1 << 20).map(|i| i % distinct.len()).collect();
    which.shuffle(&mut rng);
    let inserts: Vec<HashKey> = which.iter().map(|&i| distinct[i]).collect();
    let slots = f.insert_keys(&t, &inserts);

    let mut slot_of = vec![u32::MAX; distinct.len()];
    for (&i, &s) in which.iter().zip(&slots) {
        assert!(s < config.num_slots() as u32, "insert returned {s:#x}");
        if slot_of[i] == u32::MAX {
            slot_of[i] = s;
        }
        assert_eq!(slot_of[i], s, "copies of key {i} got different slots");
    }
    let mut owners = std::collections::HashMap::new();
    for (i, &s) in slot_of.iter().enumerate() {
        assert!(owners.insert(s, i).is_none(), "slot {s} holds two keys");
    }
    let table = f.checksums(&t);
    let spb = config.slots_per_bucket;
    for (k, &s) in distinct.iter().zip(&slot_of) {
        assert_eq!(table[s as usize], k.checksum());
        assert_eq!(s / spb, k.bucket(config.num_buckets));
    }
    assert_eq!(table.iter().filter(|&&c| c != 0).count(), distinct.len());
    let stats = f.stats(&t);
    assert_eq!(stats.used_slots as usize, distinct.len(), "{stats:?}");
    assert_eq!((stats.overflows, stats.rejected()), (0, 0), "{stats:?}");
    // The fullest bucket as the twin (sequential, same buckets) fills it.
    let mut twin = CpuHashTable::new(config).unwrap();
    for k in &distinct {
        twin.find_or_insert(k.bucket(config.num_buckets), k.checksum());
    }
    let fullest = (0..config.num_buckets as usize)
        .map(|b| {
            twin.checksums[b * spb as usize..(b + 1) * spb as usize]
                .iter()
                .filter(|&&c| c != 0)
                .count()
        })
        .max()
        .unwrap();
    assert_eq!(stats.max_bucket_fill as usize, fullest);
    assert_eq!(stats.max_probe() as usize, fullest);
    assert_eq!(f.find_keys(&t, &distinct), slot_of);
}

#[test]
fn point_inserts_count_items_per_slot() {
    let f = fixture();
    let config = TableConfig::default();
    let p = params(config, Vec3::new(0.0, 1.0, -4.0));
    let t = f.table(&p);
    let mut rng = StdRng::seed_from_u64(5);
    // 2^18 points in a 2 m box: many points per cell, as a frame of path vertices.
    let points: Vec<Vec3> = (0..1 << 18)
        .map(|_| {
            Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
        })
        .collect();
    let ins = f.points_kernel(&t, &points, true);
    let mut members: std::collections::HashMap<u32, Vec<u32>> = Default::default();
    for (q, [slot, index]) in points.iter().zip(&ins) {
        let c = p.cell(*q);
        assert!(*slot < config.num_slots() as u32);
        assert_eq!(*slot / config.slots_per_bucket, c.bucket);
        members.entry(*slot).or_default().push(*index);
    }
    for (slot, idx) in &mut members {
        idx.sort_unstable();
        assert!(
            idx.iter().enumerate().all(|(i, &v)| v == i as u32),
            "slot {slot}: indices in slot are not 0..count"
        );
    }
    let counters: Vec<u32> = buffers::read(f.ctx, t.counters()).unwrap();
    assert_eq!(
        counters.iter().map(|&c| c as usize).sum::<usize>(),
        points.len()
    );
    let found = f.points_kernel(&t, &points, false);
    for ([slot, _], [fslot, count]) in ins.iter().zip(&found) {
        assert_eq!(slot, fslot);
        assert_eq!(*count as usize, members[slot].len());
    }
    eprintln!("{} points in {} cells", points.len(), members.len());
}

/// 33 distinct keys of one bucket (found by CPU search), inserted concurrently.
fn same_bucket_keys(config: &TableConfig, n: usize) -> (u32, Vec<HashKey>) {
    let target = HashKey {
        coords: [0, 0, 0],
        level: 0,
    }
    .bucket(config.num_buckets);
    let mut keys = Vec::new();
    let mut checksums = std::collections::HashSet::new();
    for x in 0.. {
        let k = HashKey {
            coords: [x, -7, 11],
            level: 0,
        };
        if k.bucket(config.num_buckets) == target && checksums.insert(k.checksum()) {
            keys.push(k);
            if keys.len() == n {
                break;
            }
        }
    }
    (target, keys)
}

#[test]
fn adversarial_33_keys_in_one_bucket() {
    let f = fixture();
    let config = TableConfig::default();
    let spb = config.slots_per_bucket;
    let (bucket, keys) = same_bucket_keys(&config, 33);
    let t = f.table(&params(config, Vec3::ZERO));
    let slots = f.insert_keys(&t, &keys);
    let full: Vec<usize> = (0..33).filter(|&i| slots[i] == HASH_FULL).collect();
    assert_eq!(full.len(), 1, "exactly one insert overflows: {slots:x?}");
    let mut inside: Vec<u32> = slots.iter().copied().filter(|&s| s != HASH_FULL).collect();
    inside.sort_unstable();
    let want: Vec<u32> = (bucket * spb..(bucket + 1) * spb).collect();
    assert_eq!(inside, want, "the 32 others fill the bucket");
    let table = f.checksums(&t);
    for (i, &c) in table.iter().enumerate() {
        if (i as u32) / spb != bucket {
            assert_eq!(c, 0, "slot {i} outside the bucket was touched");
        }
    }
    let counters: Vec<u32> = buffers::read(f.ctx, t.counters()).unwrap();
    assert!(counters.iter().all(|&c| c == 0));
    let stats = f.stats(&t);
    assert_eq!(
        (
            stats.overflows,
            stats.used_slots,
            stats.full_buckets,
            stats.max_probe()
        ),
        (1, 32, 1, 32),
        "{stats:?}"
    );
    let found = f.find_keys(&t, &keys);
    for i in 0..33 {
        let want = if full.contains(&i) {
            HASH_NOT_FOUND
        } else {
            slots[i]
        };
        assert_eq!(found[i], want, "key {i}");
    }
}

#[test]
fn spill_config_moves_the_33rd_key_to_the_next_bucket() {
    let f = fixture();
    let config = TableConfig {
        probe_buckets: 2,
        ..TableConfig::default()
    };
    let spb = config.slots_per_bucket;
    let (bucket, keys) = same_bucket_keys(&config, 33);
    let t = f.table(&params(config, Vec3::ZERO));
    let slots = f.insert_keys(&t, &keys);
    let next = (bucket + 1) % config.num_buckets;
    let spilled: Vec<u32> = slots
        .iter()
        .copied()
        .filter(|s| s / spb != bucket)
        .collect();
    assert_eq!(spilled, vec![next * spb], "{slots:x?}");
    let stats = f.stats(&t);
    assert_eq!(
        (stats.overflows, stats.max_spill_probe, stats.max_probe()),
        (0, 33, 33),
        "{stats:?}"
    );
    assert_eq!(f.find_keys(&t, &keys), slots);
}

/// False matches: the GPU's finds of the absent keys `queries` against the twin's walk of the
/// GPU table: (keys found, the expected number of checksum collisions over the comparisons).
fn false_matches(
    f: &Fixture,
    t: &HashTable,
    config: TableConfig,
    queries: &[HashKey],
) -> (usize, f64) {
    let (nb, spb) = (config.num_buckets, config.slots_per_bucket);
    let table = f.checksums(t);
    let view = CpuHashTable {
        config,
        checksums: table,
        overflows: 0,
    };
    let gpu_found = f.find_keys(t, queries);
    let mut comparisons = 0u64;
    let mut false_matches = 0;
    for (q, &g) in queries.iter().zip(&gpu_found) {
        let probe = view.find(q.bucket(nb), q.checksum());
        assert_eq!(probe.slot.unwrap_or(HASH_NOT_FOUND), g, "{q:?}");
        // Slots compared against an occupied checksum (the last may be empty).
        let last_empty = probe.slot.is_none()
            && view.checksums[((q.bucket(nb) + (probe.probes - 1) / spb) % nb * spb
                + (probe.probes - 1) % spb) as usize]
                == 0;
        comparisons += u64::from(probe.probes - u32::from(last_empty));
        false_matches += usize::from(g != HASH_NOT_FOUND);
    }
    (false_matches, comparisons as f64 / f64::from(u32::MAX))
}

#[test]
fn load_sweep_failed_inserts_probe_lengths_and_false_matches() {
    let f = fixture();
    let mut rng = StdRng::seed_from_u64(6);
    // False-match queries: keys at a level no inserted key has, so none is present.
    let queries = random_keys(&mut rng, 1 << 17, 30);
    eprintln!(
        "probe_buckets load   keys  failed  twin_failed mean_probe max_probe  false  expected_false"
    );
    // 1: the paper's bucket-local table; 8: bounded spill; 4096: probe the whole table.
    for probe_buckets in [1u32, 8, 4096] {
        let config = TableConfig {
            num_buckets: 4096,
            slots_per_bucket: 32,
            probe_buckets,
        };
        let nb = config.num_buckets;
        let spb = config.slots_per_bucket;
        let t = f.table(&params(config, Vec3::ZERO));
        for load in [0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99] {
            if probe_buckets == config.num_buckets && load > 0.95 {
                continue; // clusters of thousands of slots: slow to search, and proven above
            }
            gpu::run(f.ctx, |enc| t.encode_clear(enc));
            let n = (load * config.num_slots() as f64) as usize;
            let keys = random_keys(&mut rng, n, 0);
            let slots = f.insert_keys(&t, &keys);
            let stats = f.stats(&t);
            let failed = slots.iter().filter(|&&s| s == HASH_FULL).count();
            assert_eq!(failed, stats.overflows as usize);
            let mut twin = CpuHashTable::new(config).unwrap();
            let mut total = 0u64;
            let mut max = 0;
            for (k, &s) in keys.iter().zip(&slots) {
                twin.find_or_insert(k.bucket(nb), k.checksum());
                if s == HASH_FULL {
                    continue;
                }
                let home = k.bucket(nb);
                let probe = ((s / spb + nb - home) % nb) * spb + s % spb + 1;
                total += u64::from(probe);
                max = max.max(probe);
            }
            let stored = n - failed;
            assert_eq!(stats.used_slots as usize, stored);
            assert!(stats.max_probe() >= max, "{stats:?} vs {max}");
            if probe_buckets == 1 {
                // Bucket-local: who fails depends on timing, how many does not.
                assert_eq!(failed, twin.overflows as usize, "load {load}");
                assert_eq!(stats.max_probe(), max);
            } else if probe_buckets == config.num_buckets {
                // Probing the whole table only fails when every slot is taken.
                assert_eq!(failed, 0, "unbounded probing lost inserts at load {load}");
            }
            // Every stored key is found where it was put.
            let found = f.find_keys(&t, &keys);
            for ((k, &s), &g) in keys.iter().zip(&slots).zip(&found) {
                if s != HASH_FULL {
                    assert_eq!(g, s, "{k:?}");
                }
            }
            let (false_matches, expected) = false_matches(&f, &t, config, &queries);
            eprintln!(
                "{probe_buckets:>13} {load:<5} {n:>7} {failed:>6} {:>12} {:>10.3} {max:>9} {false_matches:>6} {expected:>14.2e}",
                twin.overflows,
                total as f64 / stored as f64,
            );
            // Poisson with mean `expected` (< 0.02 here): 3 or more has probability < 2e-6.
            assert!(
                false_matches < 3,
                "false matches {false_matches} vs {expected}"
            );
        }
    }
}

#[test]
fn nonfinite_and_huge_positions_are_rejected_and_counted() {
    let f = fixture();
    let eye = Vec3::new(1.0, 2.0, 3.0);
    let t = f.table(&params(TableConfig::default(), eye));
    let mut points = Vec::new();
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for axis in 0..3 {
            let mut a = [0.5f32; 3];
            a[axis] = v;
            points.push(Vec3::from_array(a));
        }
    }
    let nonfinite = points.len();
    points.extend([
        Vec3::new(1e20, 0.0, 0.0),
        Vec3::new(0.0, -3e38, 0.0),
        Vec3::splat(f32::MAX),
    ]);
    let huge = points.len() - nonfinite;
    points.extend([eye, Vec3::new(4.0, 5.0, 6.0)]);
    let ins = f.points_kernel(&t, &points, true);
    for (i, [slot, index]) in ins.iter().enumerate() {
        if i < nonfinite + huge {
            assert_eq!(
                (*slot, *index),
                (HASH_REJECTED, HASH_NOT_FOUND),
                "{}",
                points[i]
            );
        } else {
            assert!(*slot < TableConfig::default().num_slots() as u32);
        }
    }
    let stats = f.stats(&t);
    assert_eq!(
        (
            stats.rejected_nonfinite as usize,
            stats.rejected_out_of_range as usize,
            stats.used_slots,
            stats.overflows
        ),
        (nonfinite, huge, 2, 0),
        "{stats:?}"
    );
    let found = f.points_kernel(&t, &points, false);
    for (i, ([slot, _], [fslot, count])) in ins.iter().zip(&found).enumerate() {
        assert_eq!(slot, fslot);
        assert_eq!(*count, u32::from(i >= nonfinite + huge));
    }
    // The distance-0 point is a level-0 cell.
    assert_eq!(t.config().num_buckets, 100_000);
    assert_eq!(
        ins[nonfinite + huge][0] / 32,
        params(TableConfig::default(), eye).cell(eye).bucket
    );
    assert_eq!(
        cell::STATUS_OK,
        params(TableConfig::default(), eye).cell(eye).status
    );
}

#[test]
fn clear_resets_table_counters_and_stats() {
    let f = fixture();
    let t = f.table(&params(TableConfig::default(), Vec3::ZERO));
    let pts = vec![Vec3::ONE, Vec3::NAN, Vec3::new(0.3, 0.2, 0.1)];
    f.points_kernel(&t, &pts, true);
    assert_ne!(f.stats(&t), HashStats::default());
    gpu::run(f.ctx, |enc| t.encode_clear(enc));
    assert_eq!(f.stats(&t), HashStats::default());
    assert!(f.checksums(&t).iter().all(|&c| c == 0));
    let counters: Vec<u32> = buffers::read(f.ctx, t.counters()).unwrap();
    assert!(counters.iter().all(|&c| c == 0));
}

/// A consumer kernel composing both roles: insert into this frame's table (group 0) while
/// looking up last frame's (group 1, its own eye), with its own bindings in group 2.
const CONSUMER_KERNEL: &str = "
@group(2) @binding(0) var<storage, read> points: array<vec4<f32>>;
@group(2) @binding(1) var<storage, read_write> out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn build_and_reuse(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&points) {
        return;
    }
    let p = points[i].xyz;
    let slot = hash_insert_position(p);
    var index = HASH_NOT_FOUND;
    if hash_is_slot(slot) {
        index = hash_slot_append(slot);
    }
    let prev = hash_lookup_position(p);
    var prev_count = 0u;
    if hash_lookup_is_slot(prev) {
        prev_count = hash_lookup_slot_count(prev);
    }
    out[i] = vec4<u32>(slot, index, prev, prev_count);
}
";

/// The consumer kernel's pipeline and its three group layouts (the table being built, last
/// frame's in the lookup role, the points and results).
fn consumer_pipeline(d: &wgpu::Device) -> (wgpu::ComputePipeline, [wgpu::BindGroupLayout; 3]) {
    use gpu_hash::wgsl::{BindAt, compose};
    let source = format!(
        "{}\n{CONSUMER_KERNEL}",
        compose(
            Some(BindAt {
                group: 0,
                first_binding: 0
            }),
            Some(BindAt {
                group: 1,
                first_binding: 0
            }),
        )
    );
    tests::wgsl::validate("consumer", &source).unwrap();
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("consumer"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let io_entry = tests::buffers::storage_entry;
    let l0 = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &gpu_hash::bind_group_layout_entries(0),
    });
    let l1 = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &gpu_hash::lookup_bind_group_layout_entries(0),
    });
    let l2 = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[io_entry(0, true), io_entry(1, false)],
    });
    let layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&l0), Some(&l1), Some(&l2)],
        immediate_size: 0,
    });
    let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("consumer"),
        layout: Some(&layout),
        module: &module,
        entry_point: Some("build_and_reuse"),
        compilation_options: Default::default(),
        cache: None,
    });
    (pipeline, [l0, l1, l2])
}

/// Runs the consumer kernel over `points`: per point (slot in `cur`, index in slot, slot in
/// `prev`, its count there).
fn run_consumer(f: &Fixture, cur: &HashTable, prev: &HashTable, points: &[Vec3]) -> Vec<[u32; 4]> {
    let d = &f.ctx.device;
    let (pipeline, [l0, l1, l2]) = consumer_pipeline(d);
    let p4: Vec<[f32; 4]> = points.iter().map(|q| q.extend(1.0).to_array()).collect();
    let pts = buffers::storage_from(d, "points", &p4);
    let out = buffers::storage_zeroed(d, "out", points.len() as u64 * 16);
    let g0 = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &l0,
        entries: &cur.bind_group_entries(0),
    });
    let g1 = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &l1,
        entries: &prev.lookup_bind_group_entries(0),
    });
    let g2 = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &l2,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: pts.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: out.as_entire_binding(),
            },
        ],
    });
    gpu::run(f.ctx, |enc| {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &g0, &[]);
        pass.set_bind_group(1, &g1, &[]);
        pass.set_bind_group(2, &g2, &[]);
        pass.dispatch_workgroups((points.len() as u32).div_ceil(64), 1, 1);
    });
    buffers::read(f.ctx, &out).unwrap()
}

#[test]
fn previous_frame_lookup_while_building_the_current_frame() {
    let f = fixture();
    let config = TableConfig::default();
    let eye_a = Vec3::new(0.0, 0.0, 0.0);
    let eye_b = Vec3::new(0.7, 0.0, -0.4);
    let (pa, pb) = (params(config, eye_a), params(config, eye_b));
    let prev = f.table(&pa);
    let cur = f.table(&pb);
    let mut rng = StdRng::seed_from_u64(7);
    let frame = |rng: &mut StdRng| -> Vec<Vec3> {
        (0..20_000)
            .map(|_| {
                Vec3::new(
                    rng.random_range(-8.0..8.0),
                    rng.random_range(-8.0..8.0),
                    rng.random_range(-8.0..8.0),
                )
            })
            .collect()
    };
    let frame_a = frame(&mut rng);
    // Half the vertices revisit last frame's positions, half are new.
    let frame_b: Vec<Vec3> = frame(&mut rng)
        .into_iter()
        .enumerate()
        .map(|(i, q)| if i % 2 == 0 { frame_a[i] } else { q })
        .collect();
    // Last frame's grid, built by the batch kernel.
    let built_a = f.points_kernel(&prev, &frame_a, true);

    let got = run_consumer(&f, &cur, &prev, &frame_b);

    // Twin of last frame: its own eye decides the cells, its table decides the slots.
    let prev_table = CpuHashTable {
        config,
        checksums: f.checksums(&prev),
        overflows: 0,
    };
    let mut prev_count = std::collections::HashMap::<u32, u32>::new();
    for [slot, _] in &built_a {
        *prev_count.entry(*slot).or_default() += 1;
    }
    let mut hits = 0;
    for (q, g) in frame_b.iter().zip(&got) {
        let c = pa.cell(*q);
        let want = prev_table
            .find(c.bucket, c.checksum)
            .slot
            .unwrap_or(HASH_NOT_FOUND);
        assert_eq!(g[2], want, "{q}");
        if want != HASH_NOT_FOUND {
            hits += 1;
            assert_eq!(g[3], prev_count[&want]);
        }
        // This frame's insert used this frame's eye.
        assert_eq!(g[0] / config.slots_per_bucket, pb.cell(*q).bucket);
    }
    assert!(
        hits > frame_b.len() * 2 / 5,
        "only {hits} lookups hit last frame's grid"
    );
    // The current table answers its own finds like the batch kernel.
    let found = f.points_kernel(&cur, &frame_b, false);
    for (g, [slot, _]) in got.iter().zip(&found) {
        assert_eq!(g[0], *slot);
    }
    eprintln!("{hits} of {} lookups hit last frame's grid", frame_b.len());
}

/// `err` says the device has fewer than `needed` storage buffers per shader stage.
fn assert_storage_buffer_limit(err: gpu_hash::HashError, needed: u64) {
    let gpu_hash::HashError::DeviceLimit {
        limit, needed: n, ..
    } = &err
    else {
        panic!("not a device limit: {err}");
    };
    let want = ("max_storage_buffers_per_shader_stage", needed);
    assert_eq!((*limit, *n), want, "{err}");
}

/// Issue 13.3: a device below the batch kernels' needs (5 storage buffers per stage) gets a
/// typed error from `HashBatch::new`; the table itself (3 storage buffers) still works there,
/// and a device below the table role's needs gets a typed error from `HashTable::new`.
#[test]
fn downlevel_device_gets_typed_errors() {
    let config = TableConfig {
        num_buckets: 1024,
        ..TableConfig::default()
    };
    let p = params(config, Vec3::ZERO);
    for limits in [
        wgpu::Limits::downlevel_defaults(),
        gpu::limits_with_storage_buffers(4),
    ] {
        let (device, queue) = gpu::device_with_limits(limits);
        assert_storage_buffer_limit(HashBatch::new(&device).unwrap_err(), 5);
        HashTable::new(&device, &queue, &p).unwrap();
    }
    let (device, queue) = gpu::device_with_limits(gpu::limits_with_storage_buffers(2));
    assert_storage_buffer_limit(HashTable::new(&device, &queue, &p).unwrap_err(), 3);
    let (device, _queue) = gpu::device_with_limits(gpu::limits_with_storage_buffers(5));
    HashBatch::new(&device).unwrap();
}

/// Issue 13.4: `encode_*` binds only the ranges it uses, so a points buffer larger than one
/// binding works for a small `n`; a range that itself exceeds the limit is an error at encode
/// time, before wgpu sees it.
#[test]
fn buffers_larger_than_a_binding_are_bound_by_range() {
    let ctx = gpu::context();
    const LIMIT: u64 = 1 << 20;
    let (device, queue) = gpu::device_with_limits(wgpu::Limits {
        max_storage_buffer_binding_size: LIMIT,
        ..ctx.adapter.limits()
    });
    let small = GpuContext {
        device,
        queue,
        ..ctx.clone()
    };
    let d = &small.device;
    let batch = HashBatch::new(d).unwrap();
    let config = TableConfig {
        num_buckets: 4096,
        ..TableConfig::default()
    };
    let p = params(config, Vec3::new(0.0, 1.0, -4.0));
    let t = HashTable::new(d, &small.queue, &p).unwrap();
    gpu::run(&small, |enc| t.encode_clear(enc));
    let n = 1000u32;
    let mut rng = StdRng::seed_from_u64(13);
    let mut host = vec![[0f32; 4]; (LIMIT as usize + 16) / 16];
    for q in host.iter_mut().take(n as usize) {
        *q = [
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            1.0,
        ];
    }
    let points = buffers::storage_from(d, "points 16 bytes over the binding limit", &host);
    assert_eq!(points.size(), LIMIT + 16);
    let out = buffers::storage_zeroed(d, "out", LIMIT + 16);
    gpu::run(&small, |enc| {
        batch
            .bind_and_encode(
                d,
                enc,
                gpu_hash::BatchKernel::InsertPoints,
                &t,
                &points,
                &out,
                n,
            )
            .unwrap()
    });
    let got: Vec<[u32; 2]> = buffers::read_range(&small, &out, 0, u64::from(n) * 8).unwrap();
    for (q, [slot, _]) in host.iter().zip(&got) {
        let c = p.cell(Vec3::new(q[0], q[1], q[2]));
        assert_eq!(*slot / config.slots_per_bucket, c.bucket);
    }
    // n whose range exceeds the binding: an error at encode time.
    let too_many = (LIMIT / 16 + 1) as u32;
    let mut enc = d.create_command_encoder(&Default::default());
    let err = batch
        .bind_and_encode(
            d,
            &mut enc,
            gpu_hash::BatchKernel::InsertPoints,
            &t,
            &points,
            &out,
            too_many,
        )
        .unwrap_err();
    assert!(
        matches!(
            err,
            gpu_hash::HashError::BindingTooLarge { name: "input", .. }
        ),
        "{err}"
    );
}

/// The API shape: a kernel bound once to a table and buffers is encoded many times (clearing
/// the table between builds) with no allocation; a binding only works with the batch that made
/// it; the timestamp span hook sees the pass names.
#[test]
fn bind_once_encode_many() {
    let f = fixture();
    let d = &f.ctx.device;
    let other = HashBatch::new(d).unwrap();
    let config = TableConfig {
        num_buckets: 1024,
        ..TableConfig::default()
    };
    let p = params(config, Vec3::ZERO);
    let t = f.table(&p);
    let mut rng = StdRng::seed_from_u64(31);
    let keys = random_keys(&mut rng, 5000, 2);
    let input = buffers::storage_from(d, "keys", &keys);
    let out = buffers::storage_zeroed(d, "slots", keys.len() as u64 * 4);
    let n = keys.len() as u32;
    let insert = f
        .batch
        .bind(d, gpu_hash::BatchKernel::InsertKeys, &t, &input, &out, n)
        .unwrap();
    let stats = f.batch.bind_stats(d, &t);
    let mut names = Vec::new();
    gpu::run(f.ctx, |enc| {
        for _ in 0..3 {
            t.encode_clear(enc);
            f.batch.encode(enc, &insert).unwrap();
        }
        f.batch
            .encode_timed(enc, &stats, &mut |name| {
                names.push(name);
                None
            })
            .unwrap();
        assert!(matches!(
            other.encode(enc, &insert),
            Err(gpu_hash::HashError::ForeignBinding)
        ));
    });
    assert_eq!(names, ["gpu-hash table_stats"]);
    let slots: Vec<u32> = buffers::read(f.ctx, &out).unwrap();
    assert!(slots.iter().all(|&s| s < config.num_slots() as u32));
    assert_eq!(f.find_keys(&t, &keys), slots);
    let used = slots.iter().collect::<std::collections::HashSet<_>>().len();
    let st: HashStats = buffers::read::<HashStats>(f.ctx, t.stats()).unwrap()[0];
    assert_eq!(
        st.used_slots as usize, used,
        "three builds of one table, one set of slots"
    );
}
