//! Floors every other benchmark is compared against: the vec4 copy kernel's bandwidth on this
//! device, next to the host's memcpy.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use tests::{bench, buffers, floors::CopyKernel, gpu};

fn floors(c: &mut Criterion) {
    let ctx = gpu::context();
    let kernel = CopyKernel::new(&ctx.device);
    let n: u32 = 1 << 22;
    let src = buffers::storage_zeroed(&ctx.device, "src", u64::from(n) * 4);
    let dst = buffers::storage_zeroed(&ctx.device, "dst", u64::from(n) * 4);
    let mut group = c.benchmark_group("floors");
    group.throughput(Throughput::Bytes(u64::from(n) * 8));
    group.bench_function("gpu_copy_vec4_2^22", |b| {
        b.iter_custom(|iters| {
            bench::gpu_time(ctx, iters, |enc| {
                kernel.encode(&ctx.device, enc, &src, &dst, n / 4)
            })
        })
    });
    let host_src = vec![1u32; n as usize];
    let mut host_dst = vec![0u32; n as usize];
    group.bench_function("host_memcpy_2^22", |b| {
        b.iter(|| host_dst.copy_from_slice(std::hint::black_box(&host_src)))
    });
    group.finish();

    let gpu_ms = bench::gpu_ms(ctx, 10, |enc| {
        kernel.encode(&ctx.device, enc, &src, &dst, n / 4)
    });
    let t0 = std::time::Instant::now(); // host floor: the host has no GPU timestamps
    let reps = 20;
    for _ in 0..reps {
        host_dst.copy_from_slice(std::hint::black_box(&host_src));
    }
    let host_ms = t0.elapsed().as_secs_f64() * 1e3 / f64::from(reps);
    let bytes = f64::from(n) * 8.0;
    bench::print_result(
        ctx,
        "floors",
        &[
            ("n", n.to_string()),
            ("gpu_copy_gb_s", format!("{:.2}", bytes / gpu_ms * 1e-6)),
            ("host_memcpy_gb_s", format!("{:.2}", bytes / host_ms * 1e-6)),
            ("gpu_vs_host", format!("{:.3}", host_ms / gpu_ms)),
        ],
    );
}

criterion_group!(benches, floors);
criterion_main!(benches);
