//! GPU tests of `gpu-scan` against its CPU twin (bit-exact), on awkward sizes up to the
//! adapter's binding maximum, hard inputs, both workgroup-scan variants, many scans in one
//! submit, the indirect variant, the forced fallback and the error contract.

use gpu_scan::{Scan, ScanCounters, ScanDescriptor, ScanError, ScanKind, cpu};
use rand::{Rng, SeedableRng, rngs::StdRng};
use tests::{GpuContext, buffers, gpu};

const KINDS: [ScanKind; 2] = [ScanKind::Exclusive, ScanKind::Inclusive];

#[derive(Debug, Clone, Copy)]
enum Pattern {
    /// Uniform over all of u32: totals wrap past 2^32 many times.
    Random(u64),
    Zeros,
    AllOnes,
}

fn make_input(pattern: Pattern, n: usize) -> Vec<u32> {
    match pattern {
        Pattern::Random(seed) => {
            let mut rng = StdRng::seed_from_u64(seed);
            (0..n).map(|_| rng.random()).collect()
        }
        Pattern::Zeros => vec![0; n],
        Pattern::AllOnes => vec![u32::MAX; n],
    }
}

/// The largest n one storage binding holds on this adapter (2^25 on lavapipe).
fn adapter_max(ctx: &GpuContext) -> u32 {
    u32::try_from(ctx.max_storage_u32s()).unwrap_or(u32::MAX)
}

/// The scan variants this adapter can run: always the shared-memory one, plus subgroups when
/// the adapter has them.
fn variants(ctx: &GpuContext, desc: ScanDescriptor, test: &str) -> Vec<(&'static str, Scan)> {
    let mut out = vec![(
        "no subgroups",
        Scan::new(
            &ctx.device,
            &ScanDescriptor {
                use_subgroups: false,
                ..desc
            },
        )
        .unwrap(),
    )];
    if gpu::with_subgroups(test).is_some() {
        out.push((
            "subgroups",
            Scan::new(
                &ctx.device,
                &ScanDescriptor {
                    use_subgroups: true,
                    ..desc
                },
            )
            .unwrap(),
        ));
    }
    out
}

/// Scans `input` on the GPU, returns (output, total).
fn gpu_scan(ctx: &GpuContext, scan: &Scan, input: &[u32], kind: ScanKind) -> (Vec<u32>, u32) {
    let n = u32::try_from(input.len()).unwrap();
    let in_buf = buffers::storage_from(&ctx.device, "input", input);
    let out_buf = buffers::storage_zeroed(&ctx.device, "output", u64::from(n) * 4);
    let total = buffers::storage_from(&ctx.device, "total", &[0xDEAD_BEEFu32]);
    gpu::run(ctx, |enc| {
        scan.bind_and_encode(&ctx.device, enc, &in_buf, &out_buf, n, kind, Some(&total))
            .unwrap()
    });
    drop(in_buf);
    let got = buffers::read_range(ctx, &out_buf, 0, u64::from(n) * 4).unwrap();
    let total: Vec<u32> = buffers::read_range(ctx, &total, 0, 4).unwrap();
    (got, total[0])
}

/// Panics with the first mismatch (index, got, expected) instead of printing 2^25 numbers.
fn assert_scan_eq(got: &[u32], input: &[u32], kind: ScanKind, what: &str) {
    let expected = cpu::scan(input, kind);
    assert_eq!(got.len(), expected.len(), "{what}: length");
    if let Some(i) = got.iter().zip(&expected).position(|(g, e)| g != e) {
        let tail = got.iter().zip(&expected).filter(|(g, e)| g != e).count();
        panic!(
            "{what}: first mismatch at {i}: got {} expected {} ({tail} mismatches)",
            got[i], expected[i]
        );
    }
}

fn check(ctx: &GpuContext, scan: &Scan, name: &str, pattern: Pattern, n: u32, kind: ScanKind) {
    let input = make_input(pattern, n as usize);
    let (got, total) = gpu_scan(ctx, scan, &input, kind);
    let what = format!("{name} {pattern:?} n={n} {kind:?}");
    assert_scan_eq(&got, &input, kind, &what);
    assert_eq!(total, cpu::total(&input), "{what}: total");
}

#[test]
fn awkward_sizes_match_cpu_twin() {
    let ctx = gpu::context();
    let desc = ScanDescriptor::new(adapter_max(ctx));
    for (name, scan) in variants(ctx, desc, "awkward_sizes_match_cpu_twin (subgroup half)") {
        let t = scan.tile_len();
        let sizes = [
            0,
            1,
            2,
            3,
            31,
            32,
            33,
            t - 1,
            t,
            t + 1,
            2 * t - 1,
            2 * t + 1,
            1_000_003,
        ];
        for (i, &n) in sizes.iter().enumerate() {
            for kind in KINDS {
                check(ctx, &scan, name, Pattern::Random(i as u64), n, kind);
            }
        }
    }
}

/// The thread-coarsened kernel over several (workgroup size, items per thread) shapes: the GPU
/// default, the CPU default, short and non-power-of-two runs; sizes around run, tile and vec4
/// boundaries; both workgroup-scan variants; and the forced fallback (which reduces whole
/// predecessor tiles).
#[test]
fn kernel_shapes_match_cpu_twin_on_awkward_sizes() {
    let ctx = gpu::context();
    let shapes = [(256u32, 16u32), (32, 1024), (32, 4), (64, 12), (128, 8)];
    for (wg, items) in shapes {
        for spin_limit in [gpu_scan::DEFAULT_SPIN_LIMIT, 0] {
            let desc = ScanDescriptor {
                workgroup_size: Some(wg),
                items_per_thread: Some(items),
                spin_limit,
                ..ScanDescriptor::new(1 << 20)
            };
            for (name, scan) in variants(ctx, desc, "kernel_shapes (subgroup half)") {
                assert_eq!(scan.tile_len(), wg * items);
                let t = scan.tile_len();
                let name = format!("{name} {wg}x{items} spin {spin_limit}");
                for (i, n) in [
                    1,
                    items - 1,
                    items + 1,
                    items + 3,
                    t - 3,
                    t + 2,
                    3 * t + items + 1,
                    5 * t - 1,
                    (1 << 20) - 1,
                ]
                .into_iter()
                .enumerate()
                {
                    let kind = KINDS[i % 2];
                    check(ctx, &scan, &name, Pattern::Random(i as u64 + 40), n, kind);
                }
            }
        }
    }
}

/// The API shape: bind once, encode many times (here three times into one encoder and once
/// more in a later submit) with no allocation per encode; a binding only works with the scan
/// that made it; the timestamp span hook sees the pass name.
#[test]
fn bind_once_encode_many() {
    let ctx = gpu::context();
    let scan = Scan::new(&ctx.device, &ScanDescriptor::new(1 << 18)).unwrap();
    let other = Scan::new(&ctx.device, &ScanDescriptor::new(1 << 18)).unwrap();
    let input = make_input(Pattern::Random(77), 200_003);
    let in_buf = buffers::storage_from(&ctx.device, "input", &input);
    let out_buf = buffers::storage_zeroed(&ctx.device, "output", input.len() as u64 * 4);
    let total = buffers::storage_zeroed(&ctx.device, "total", 4);
    let n = input.len() as u32;
    let kind = ScanKind::Inclusive;
    let bound = scan
        .bind(&ctx.device, &in_buf, &out_buf, n, kind, Some(&total))
        .unwrap();
    let mut names = Vec::new();
    gpu::run(ctx, |enc| {
        for _ in 0..3 {
            scan.encode(enc, &bound).unwrap();
        }
        scan.encode_timed(enc, &bound, &mut |name| {
            names.push(name);
            None
        })
        .unwrap();
        assert_eq!(other.encode(enc, &bound), Err(ScanError::ForeignBinding));
    });
    assert_eq!(names, ["gpu-scan"]);
    let got: Vec<u32> = buffers::read(ctx, &out_buf).unwrap();
    assert_scan_eq(&got[..input.len()], &input, kind, "bound, encoded 4 times");
    gpu::run(ctx, |enc| enc.clear_buffer(&out_buf, 0, None));
    gpu::run(ctx, |enc| scan.encode(enc, &bound).unwrap());
    let got: Vec<u32> = buffers::read(ctx, &out_buf).unwrap();
    assert_scan_eq(&got[..input.len()], &input, kind, "bound, later submit");
    let t: Vec<u32> = buffers::read_range(ctx, &total, 0, 4).unwrap();
    assert_eq!(t[0], cpu::total(&input));
}

#[test]
fn random_totals_wrap_past_2_32() {
    // The inputs of the other tests are uniform over u32; make sure that means wrapping.
    let input = make_input(Pattern::Random(1), 1000);
    let wide: u64 = input.iter().map(|&x| u64::from(x)).sum();
    assert!(wide > 100 * (1u64 << 32));
    let ctx = gpu::context();
    let scan = Scan::new(
        &ctx.device,
        &ScanDescriptor::for_device(&ctx.device, 1 << 16),
    )
    .unwrap();
    let (got, total) = gpu_scan(ctx, &scan, &input, ScanKind::Inclusive);
    assert_eq!(u64::from(total), wide % (1u64 << 32));
    assert_eq!(got[999], total);
}

#[test]
fn zeros_and_all_ones() {
    let ctx = gpu::context();
    let desc = ScanDescriptor::new(1 << 21);
    for (name, scan) in variants(ctx, desc, "zeros_and_all_ones (subgroup half)") {
        for pattern in [Pattern::Zeros, Pattern::AllOnes] {
            for (n, kind) in [
                (3 * scan.tile_len() + 5, ScanKind::Exclusive),
                (1_000_003, ScanKind::Inclusive),
            ] {
                check(ctx, &scan, name, pattern, n, kind);
            }
        }
    }
}

#[test]
fn large_sizes_cover_each_variant_kind_and_pattern() {
    // A cross product that touches each axis at 2^22 + 7 and at the adapter's maximum without
    // running all of them (each maximum-size run moves 3 x 128 MiB on lavapipe).
    let ctx = gpu::context();
    let max = adapter_max(ctx);
    let desc = ScanDescriptor::new(max);
    let scans = variants(ctx, desc, "large_sizes (subgroup half)");
    let last = scans.len() - 1; // the subgroup variant when the adapter has it
    let cases = [
        (
            last,
            Pattern::Random(22),
            (1 << 22) + 7,
            ScanKind::Exclusive,
        ),
        (0, Pattern::AllOnes, (1 << 22) + 7, ScanKind::Inclusive),
        (last, Pattern::Random(25), max, ScanKind::Exclusive),
        (0, Pattern::Random(26), max, ScanKind::Inclusive),
    ];
    for (v, pattern, n, kind) in cases {
        let (name, scan) = &scans[v];
        check(ctx, scan, name, pattern, n, kind);
    }
}

#[test]
fn hundred_scans_in_one_submit() {
    let ctx = gpu::context();
    // Up to 5 tiles + 3 per scan (tiles are 32768 elements on CPU adapters).
    let desc = ScanDescriptor::for_device(&ctx.device, 1 << 18);
    let scan = Scan::new(&ctx.device, &desc).unwrap();
    let t = scan.tile_len() as usize;
    assert!(5 * t + 3 <= 1 << 18);
    let mut rng = StdRng::seed_from_u64(100);
    struct Job {
        input: Vec<u32>,
        kind: ScanKind,
        out: wgpu::Buffer,
        total: wgpu::Buffer,
    }
    // One shared input buffer too: several scans read it with different n.
    let shared_input = make_input(Pattern::Random(7), 5 * t + 3);
    let shared_buf = buffers::storage_from(&ctx.device, "shared input", &shared_input);
    let mut jobs = Vec::new();
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    for i in 0..100 {
        let n = match i % 4 {
            0 => rng.random_range(0..40),
            1 => rng.random_range(0..3 * t),
            2 => rng.random_range(3 * t..5 * t + 3),
            _ => t * rng.random_range(1..4),
        };
        let kind = KINDS[i % 2];
        let out = buffers::storage_zeroed(&ctx.device, "out", n as u64 * 4);
        let total = buffers::storage_zeroed(&ctx.device, "total", 4);
        let input = if i % 5 == 0 {
            scan.bind_and_encode(
                &ctx.device,
                &mut encoder,
                &shared_buf,
                &out,
                n as u32,
                kind,
                Some(&total),
            )
            .unwrap();
            shared_input[..n].to_vec()
        } else {
            let input = make_input(Pattern::Random(1000 + i as u64), n);
            let buf = buffers::storage_from(&ctx.device, "input", &input);
            scan.bind_and_encode(
                &ctx.device,
                &mut encoder,
                &buf,
                &out,
                n as u32,
                kind,
                Some(&total),
            )
            .unwrap();
            input
        };
        jobs.push(Job {
            input,
            kind,
            out,
            total,
        });
    }
    ctx.queue.submit([encoder.finish()]);
    ctx.wait().unwrap();
    for (i, job) in jobs.iter().enumerate() {
        let n = job.input.len() as u64;
        let got: Vec<u32> = buffers::read_range(ctx, &job.out, 0, n * 4).unwrap();
        assert_scan_eq(
            &got,
            &job.input,
            job.kind,
            &format!("scan {i} of 100 (n={n})"),
        );
        let total: Vec<u32> = buffers::read_range(ctx, &job.total, 0, 4).unwrap();
        assert_eq!(total[0], cpu::total(&job.input), "scan {i}: total");
    }
}

#[test]
fn indirect_length_read_on_the_gpu() {
    let ctx = gpu::context();
    let max_len = 300_000;
    for (name, scan) in variants(
        ctx,
        ScanDescriptor::new(max_len),
        "indirect (subgroup half)",
    ) {
        let t = scan.tile_len();
        let input = make_input(Pattern::Random(9), max_len as usize + 100);
        let in_buf = buffers::storage_from(&ctx.device, "input", &input);
        // n at word 3 of the length buffer, after junk. The last case exceeds max_len and is
        // clamped to it; the one before exceeds the (smaller) output buffer and is clamped to it.
        let cases: [(u32, u64, u32); 6] = [
            (0, 4 * max_len as u64, 0),
            (1, 4 * max_len as u64, 1),
            (t + 1, 4 * max_len as u64, t + 1),
            (123_457, 4 * max_len as u64, 123_457),
            (200_000, 4 * 150_001, 150_001),
            (u32::MAX, 4 * max_len as u64, max_len),
        ];
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let mut jobs = Vec::new();
        for (i, &(gpu_n, out_bytes, effective)) in cases.iter().enumerate() {
            let len = buffers::storage_from(&ctx.device, "len", &[7u32, 7, 7, gpu_n, 7]);
            let out = buffers::storage_zeroed(&ctx.device, "out", out_bytes);
            let total = buffers::storage_from(&ctx.device, "total", &[0xDEAD_BEEFu32]);
            let kind = KINDS[i % 2];
            let bound = scan
                .bind_indirect(&ctx.device, &in_buf, &out, &len, 12, kind, Some(&total))
                .unwrap();
            scan.encode(&mut encoder, &bound).unwrap();
            jobs.push((out, total, kind, effective));
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait().unwrap();
        for (out, total, kind, effective) in jobs {
            let what = format!("{name} indirect n={effective} {kind:?}");
            let want = &input[..effective as usize];
            let got: Vec<u32> =
                buffers::read_range(ctx, &out, 0, u64::from(effective) * 4).unwrap();
            assert_scan_eq(&got, want, kind, &what);
            let total: Vec<u32> = buffers::read_range(ctx, &total, 0, 4).unwrap();
            assert_eq!(total[0], cpu::total(want), "{what}: total");
            if effective == 0 {
                // n = 0 must not touch the output.
                let first: Vec<u32> = buffers::read_range(ctx, &out, 0, 4).unwrap();
                assert_eq!(first[0], 0);
            }
        }
    }
}

/// [`variants`] of a scan of up to 2^21 elements with `spin_limit` and debug counters.
fn counted_variants(ctx: &GpuContext, spin_limit: u32, test: &str) -> Vec<(&'static str, Scan)> {
    let desc = ScanDescriptor {
        spin_limit,
        debug_counters: true,
        ..ScanDescriptor::new(1 << 21)
    };
    variants(ctx, desc, test)
}

fn read_counters(ctx: &GpuContext, scan: &Scan) -> ScanCounters {
    let words: Vec<u32> = buffers::read(ctx, scan.counters_buffer().unwrap()).unwrap();
    bytemuck::pod_read_unaligned(bytemuck::cast_slice(&words[..4]))
}

#[test]
fn forced_fallback_is_exact() {
    // spin_limit 0: every tile reduces its predecessor itself and publishes it with atomicMax,
    // racing the predecessor's own publishes; the result must still be exact.
    let ctx = gpu::context();
    for (name, scan) in counted_variants(ctx, 0, "forced_fallback_is_exact (subgroup half)") {
        for (n, kind, seed) in [
            (33, ScanKind::Exclusive, 1),
            ((1 << 20) + 3, ScanKind::Inclusive, 2),
            ((1 << 21) - 1, ScanKind::Exclusive, 3),
        ] {
            gpu::run(ctx, |enc| scan.clear_counters(enc));
            check(ctx, &scan, name, Pattern::Random(seed), n, kind);
            let c = read_counters(ctx, &scan);
            let tiles = n.div_ceil(scan.tile_len());
            eprintln!("{name} forced fallback n={n}: {c:?}");
            assert_eq!(c.tiles, tiles, "{name}: every tile counted once");
            assert!(
                c.fallbacks >= tiles - 1,
                "{name}: every tile > 0 must fall back: {c:?}"
            );
        }
    }
}

#[test]
fn short_spin_limit_is_exact_and_counted() {
    // spin_limit 1: tiles fall back whenever a predecessor is not ready on the second poll,
    // the natural (not forced) fallback path, racing real publishes.
    let ctx = gpu::context();
    for (name, scan) in counted_variants(ctx, 1, "short_spin_limit (subgroup half)") {
        gpu::run(ctx, |enc| scan.clear_counters(enc));
        let n = (1 << 21) - 5;
        for seed in 0..4 {
            check(
                ctx,
                &scan,
                name,
                Pattern::Random(seed),
                n,
                KINDS[seed as usize % 2],
            );
        }
        let c = read_counters(ctx, &scan);
        let tiles = 4 * n.div_ceil(scan.tile_len());
        eprintln!("{name} spin_limit=1, 4 scans of n={n}: {c:?}");
        assert_eq!(c.tiles, tiles);
        // Each tile > 0 consumes at least one published state or falls back at least once.
        assert!(c.lookback_steps + c.fallbacks >= tiles - 4, "{c:?}");
    }
}

#[test]
fn errors_are_returned_before_encoding() {
    let ctx = gpu::context();
    let max = adapter_max(ctx);
    // max_len above the binding limit.
    if let Some(over) = max.checked_add(1) {
        let err = Scan::new(&ctx.device, &ScanDescriptor::new(over)).unwrap_err();
        assert!(
            matches!(err, ScanError::MaxLenAboveBindingLimit { .. }),
            "{err}"
        );
    }
    let scan = Scan::new(&ctx.device, &ScanDescriptor::new(1000)).unwrap();
    let a = buffers::storage_zeroed(&ctx.device, "a", 4000);
    let b = buffers::storage_zeroed(&ctx.device, "b", 4000);
    let small = buffers::storage_zeroed(&ctx.device, "small", 400);
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    let ex = ScanKind::Exclusive;
    assert_eq!(
        scan.bind(&ctx.device, &a, &b, 1001, ex, None).map(|_| ()),
        Err(ScanError::TooLong {
            n: 1001,
            max_len: 1000
        })
    );
    assert_eq!(
        scan.bind(&ctx.device, &a, &a, 10, ex, None).map(|_| ()),
        Err(ScanError::Aliasing("input", "output"))
    );
    assert_eq!(
        scan.bind(&ctx.device, &a, &b, 10, ex, Some(&b)).map(|_| ()),
        Err(ScanError::Aliasing("output", "total"))
    );
    assert!(matches!(
        scan.bind(&ctx.device, &a, &small, 101, ex, None)
            .map(|_| ()),
        Err(ScanError::BufferTooSmall {
            which: "output",
            ..
        })
    ));
    let not_storage = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("uniform"),
        size: 4000,
        usage: wgpu::BufferUsages::UNIFORM,
        mapped_at_creation: false,
    });
    assert_eq!(
        scan.bind(&ctx.device, &not_storage, &b, 10, ex, None)
            .map(|_| ()),
        Err(ScanError::MissingStorageUsage { which: "input" })
    );
    assert_eq!(
        scan.bind_indirect(&ctx.device, &a, &b, &small, 2, ex, None)
            .map(|_| ()),
        Err(ScanError::UnalignedLenOffset(2))
    );
    assert!(matches!(
        scan.bind_indirect(&ctx.device, &a, &b, &small, 400, ex, None)
            .map(|_| ()),
        Err(ScanError::BufferTooSmall {
            which: "length",
            ..
        })
    ));
    // n = 0 without a total records nothing; the encoder is still valid afterwards.
    scan.bind_and_encode(&ctx.device, &mut enc, &a, &b, 0, ex, None)
        .unwrap();
    ctx.queue.submit([enc.finish()]);
    ctx.wait().unwrap();
    // n = 0 with a total writes 0.
    let total = buffers::storage_from(&ctx.device, "total", &[5u32]);
    gpu::run(ctx, |enc| {
        scan.bind_and_encode(&ctx.device, enc, &a, &b, 0, ex, Some(&total))
            .unwrap()
    });
    let t: Vec<u32> = buffers::read_range(ctx, &total, 0, 4).unwrap();
    assert_eq!(t[0], 0);
}

#[test]
fn own_device_without_subgroups() {
    // A user's device without SUBGROUP: requesting subgroups is an error, the portable path
    // scans correctly.
    let ctx = gpu::context();
    let (device, queue) = gpu::block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("plain device"),
        required_limits: ctx.adapter.limits(),
        ..Default::default()
    }))
    .expect("a plain device on the same adapter");
    assert!(!device.features().contains(wgpu::Features::SUBGROUP));
    let desc = ScanDescriptor {
        use_subgroups: true,
        ..ScanDescriptor::new(1 << 16)
    };
    assert_eq!(
        Scan::new(&device, &desc).unwrap_err(),
        ScanError::SubgroupsUnavailable
    );
    let desc = ScanDescriptor::for_device(&device, 1 << 16);
    assert!(!desc.use_subgroups);
    let scan = Scan::new(&device, &desc).unwrap();
    let plain = GpuContext {
        device,
        queue,
        ..ctx.clone()
    };
    let input = make_input(Pattern::Random(5), 50_000);
    let (got, total) = gpu_scan(&plain, &scan, &input, ScanKind::Inclusive);
    assert_scan_eq(&got, &input, ScanKind::Inclusive, "own device");
    assert_eq!(total, cpu::total(&input));
}

/// Issue 13.2: a device below the kernel's needs (8 storage buffers per stage) gets a typed
/// error from `Scan::new`, never a wgpu validation panic.
#[test]
fn downlevel_device_gets_a_typed_error() {
    for limits in [
        wgpu::Limits::downlevel_defaults(),
        gpu::limits_with_storage_buffers(7),
    ] {
        let (device, _queue) = gpu::device_with_limits(limits);
        let err = Scan::new(&device, &ScanDescriptor::new(1 << 16)).unwrap_err();
        assert!(
            matches!(
                err,
                ScanError::DeviceLimit {
                    limit: "max_storage_buffers_per_shader_stage",
                    needed: 8,
                    ..
                }
            ),
            "{err}"
        );
    }
    // Exactly 8 is enough.
    let (device, _queue) = gpu::device_with_limits(gpu::limits_with_storage_buffers(8));
    Scan::new(&device, &ScanDescriptor::new(1 << 16)).unwrap();
}

/// Issue 13.5: unsupported `items_per_thread` values are the caller's error, not silently
/// changed and not blamed on the device.
#[test]
fn invalid_items_per_thread_are_rejected() {
    let ctx = gpu::context();
    for items in [0u32, 2, 6] {
        let desc = ScanDescriptor {
            items_per_thread: Some(items),
            ..ScanDescriptor::new(1 << 16)
        };
        assert_eq!(
            Scan::new(&ctx.device, &desc).unwrap_err(),
            ScanError::InvalidItemsPerThread(items)
        );
    }
}

#[test]
fn differential_check_catches_a_planted_error() {
    // Negative control for the checks above: one flipped bit in a GPU result must be caught.
    let ctx = gpu::context();
    let scan = Scan::new(&ctx.device, &ScanDescriptor::new(1 << 16)).unwrap();
    let input = make_input(Pattern::Random(3), 20_000);
    let (mut got, _) = gpu_scan(ctx, &scan, &input, ScanKind::Exclusive);
    got[12_345] ^= 1 << 7;
    let caught =
        std::panic::catch_unwind(|| assert_scan_eq(&got, &input, ScanKind::Exclusive, "planted"));
    assert!(caught.is_err());
}

#[test]
fn params_layout_matches_wgsl() {
    let src = [
        gpu_scan::KernelConfig {
            workgroup_size: 256,
            items_per_thread: 16,
            spin_limit: 1,
            counters: false,
            max_len: 1,
            max_groups_x: 1,
            subgroups: false,
        }
        .constants_header()
        .as_str(),
        gpu_scan::shaders::COMMON_WGSL,
    ]
    .join("\n");
    tests::assert_wgsl_layout!(
        gpu_scan::ScanParams,
        src,
        "ScanParams",
        [n, inclusive, write_total, len_index]
    );
}

#[test]
fn reduce_then_scan_baseline_matches_cpu() {
    // The benchmark's baseline must be a correct scan too.
    use tests::floors::{ReduceThenScan, RtsStages};
    let ctx = gpu::context();
    let rts = ReduceThenScan::new(&ctx.device, 1 << 21);
    for n in [1, ReduceThenScan::TILE + 1, (1 << 21) - 3] {
        let input = make_input(Pattern::Random(u64::from(n)), n as usize);
        let in_buf = buffers::storage_from(&ctx.device, "input", &input);
        let out = buffers::storage_zeroed(&ctx.device, "output", u64::from(n) * 4);
        gpu::run(ctx, |enc| {
            rts.encode(&ctx.device, enc, &in_buf, &out, n, RtsStages::All)
        });
        let got: Vec<u32> = buffers::read_range(ctx, &out, 0, u64::from(n) * 4).unwrap();
        assert_scan_eq(&got, &input, ScanKind::Exclusive, &format!("rts n={n}"));
    }
}
