//! The foundation's GPU tests: a real dispatch read back and checked, and the timer.

use tests::{buffers, floors::CopyKernel, gpu};

#[test]
fn copy_kernel_matches_cpu_on_awkward_sizes() {
    let ctx = gpu::context();
    let kernel = CopyKernel::new(&ctx.device);
    // 0, 1, workgroup +- 1, and past one dispatch dimension (65535 * 256 vec4s on most adapters)
    // is too big for a quick test; 2^20 + 3 crosses many workgroups.
    for n_vec4 in [0u32, 1, 255, 256, 257, (1 << 20) + 3] {
        let src: Vec<u32> = (0..n_vec4 * 4)
            .map(|i| i.wrapping_mul(2_654_435_761))
            .collect();
        let src_buf = buffers::storage_from(&ctx.device, "src", &src);
        let dst_buf = buffers::storage_zeroed(&ctx.device, "dst", u64::from(n_vec4) * 16);
        gpu::run(ctx, |enc| {
            kernel.encode(&ctx.device, enc, &src_buf, &dst_buf, n_vec4)
        });
        let got: Vec<u32> = buffers::read(ctx, &dst_buf).unwrap();
        assert_eq!(&got[..src.len()], &src[..], "n_vec4 = {n_vec4}");
    }
}

#[test]
fn timer_reports_spans_or_says_unavailable() {
    let ctx = gpu::context();
    let kernel = CopyKernel::new(&ctx.device);
    let n_vec4 = 1 << 18;
    let src = buffers::storage_zeroed(&ctx.device, "src", u64::from(n_vec4) * 16);
    let dst = buffers::storage_zeroed(&ctx.device, "dst", u64::from(n_vec4) * 16);
    // More spans than one query set holds: the timer grows.
    let spans: Vec<String> = (0..2 * restir_world::gpu::SPANS_PER_SET + 3)
        .map(|i| format!("span{i}"))
        .collect();
    let mut timer = restir_world::GpuTimer::new(ctx);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    for name in &spans {
        timer.span(&mut encoder, name, |enc| {
            kernel.encode(&ctx.device, enc, &src, &dst, n_vec4)
        });
    }
    timer.resolve(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    match timer.read(ctx) {
        Ok(times) => {
            assert!(ctx.features.timestamps);
            let names: Vec<&str> = times.0.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(names, spans);
            for (name, ms) in &times.0 {
                // A 4 MiB copy takes measurable time on any device; 0 would mean a broken timer.
                assert!(
                    ms.is_finite() && *ms > 0.0 && *ms < 10_000.0,
                    "{name}: {ms} ms"
                );
            }
        }
        Err(e) => {
            assert!(!ctx.features.timestamps);
            assert!(e.to_string().contains("unavailable"), "{e}");
        }
    }
}

#[test]
fn readback_of_empty_and_unaligned_ranges() {
    let ctx = gpu::context();
    let data: Vec<u32> = (0..7).collect();
    let buf = buffers::storage_from(&ctx.device, "data", &data);
    let none: Vec<u32> = buffers::read_range(ctx, &buf, 0, 0).unwrap();
    assert!(none.is_empty());
    let three: Vec<u32> = buffers::read_range(ctx, &buf, 4, 12).unwrap();
    assert_eq!(three, [1, 2, 3]);
    // Padded to 16 bytes: tiny inputs still make a valid binding.
    let tiny = buffers::storage_from::<u32>(&ctx.device, "tiny", &[]);
    assert_eq!(tiny.size(), 16);
}
