//! Reservoir merges per second on the GPU against the same-harness copy floor.
//!
//! `merge1`: one merge per invocation over a buffer of 2^22 packed reservoirs (8 bytes each):
//! unpack `src[i]`, merge it into an empty receiver with a per-invocation p_hat and u from the
//! shared RNG, finalize, pack into `dst[i]` (reads 8 bytes, writes 8 bytes).
//! `merge4`: four merges per invocation (`src[i + k * stride]`, k = 0..4, like a spatial-reuse
//! pass with max_count 4), same bytes written.
//! `copy`: [`CopyKernel`] copying the same 2^22 * 8 bytes (the floor).
//!
//! RESULT keys: `merges_per_s` (merge1), `vs_copy` = merge1 GPU time / copy GPU time (1.0 means
//! as fast as copying the reservoirs; larger is slower), `merges4_per_s`, `copy_gb_s`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use reservoir::{PackedReservoir, rng::Rng};
use restir_world::gpu::{Access, BindingSet, Pass};
use tests::{bench, buffers, floors::CopyKernel, gpu};

const WORKGROUP: u32 = 256;

const KERNEL_WGSL: &str = "
struct Params { n: u32, frame: u32, stride: u32, _pad: u32 }


@compute @workgroup_size(WORKGROUP_SIZE)
fn merge1(id: Invocation) {
    let i = item_index(id);
    if i >= params.n { return; }
    var rng = rng_seed(i, params.frame, 0u);
    let p_hat = 0.5 + rng_next_f32(&rng);
    var r = reservoir_empty();
    reservoir_merge(&r, reservoir_unpack(src[i], i), p_hat, rng_next_f32(&rng));
    reservoir_finalize(&r, p_hat);
    dst[i] = reservoir_pack(r);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn merge4(id: Invocation) {
    let i = item_index(id);
    if i >= params.n { return; }
    var rng = rng_seed(i, params.frame, 0u);
    var r = reservoir_empty();
    var p_sel = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let j = (i + k * params.stride) % params.n;
        let p_hat = 0.5 + rng_next_f32(&rng);
        if reservoir_merge(&r, reservoir_unpack(src[j], j), p_hat, rng_next_f32(&rng)) {
            p_sel = p_hat;
        }
    }
    reservoir_finalize(&r, p_sel);
    dst[i] = reservoir_pack(r);
}
";

struct MergeBench {
    merge1: Pass,
    merge4: Pass,
}

impl MergeBench {
    fn new(ctx: &tests::GpuContext, src: &wgpu::Buffer, dst: &wgpu::Buffer, n: u32) -> Self {
        let set = BindingSet::new("reservoir bench")
            .buffer("src", "array<PackedReservoir>", Access::Read)
            .buffer("dst", "array<PackedReservoir>", Access::ReadWrite)
            .buffer("params", "Params", Access::Uniform);
        let device = &ctx.device;
        let entries = ["merge1", "merge4"];
        let (kernel, layout) =
            gpu::reservoir_kernel("reservoir bench", &set, KERNEL_WGSL, &entries, WORKGROUP);
        let params = buffers::with_usage(
            device,
            "params",
            &[n, 1, 7919, 0],
            wgpu::BufferUsages::UNIFORM,
        );
        let res = [
            ("src", src.into()),
            ("dst", dst.into()),
            ("params", (&params).into()),
        ];
        let group = layout.bind(device, res).expect("bind");
        let pass = |entry| kernel.pass(device, entry, &[&group], n);
        Self {
            merge1: pass("merge1"),
            merge4: pass("merge4"),
        }
    }

    fn encode(&self, encoder: &mut wgpu::CommandEncoder, four: bool) {
        if four { &self.merge4 } else { &self.merge1 }.record(encoder);
    }
}

fn reservoir_merges(c: &mut Criterion) {
    let ctx = gpu::context();
    let n: u32 = 1 << 22;
    let mut rng = Rng::seed(1, 2, 3);
    let data: Vec<PackedReservoir> = (0..n)
        .map(|_| PackedReservoir {
            ucw: 0.1 + rng.next_f32(),
            m: 1 + rng.next_u32() % 20,
        })
        .collect();
    let src = buffers::storage_from(&ctx.device, "src", &data);
    let dst = buffers::storage_zeroed(&ctx.device, "dst", u64::from(n) * 8);
    let kernel = MergeBench::new(ctx, &src, &dst, n);
    // If the layout ever stops being 8 bytes, the copy floor below must follow.
    assert_eq!(size_of::<PackedReservoir>(), 8);
    let copy = CopyKernel::new(&ctx.device);
    let n_vec4 = n * 8 / 16;

    let mut group = c.benchmark_group("reservoir");
    group.sample_size(10);
    group.warm_up_time(std::time::Duration::from_secs(1));
    group.measurement_time(std::time::Duration::from_secs(4));
    group.throughput(Throughput::Elements(u64::from(n)));
    group.bench_function("merge1_2^22", |b| {
        b.iter_custom(|iters| bench::gpu_time(ctx, iters, |enc| kernel.encode(enc, false)))
    });
    group.bench_function("merge4_2^22", |b| {
        b.iter_custom(|iters| bench::gpu_time(ctx, iters, |enc| kernel.encode(enc, true)))
    });
    group.bench_function("copy_2^22x8B", |b| {
        b.iter_custom(|iters| {
            bench::gpu_time(ctx, iters, |enc| {
                copy.encode(&ctx.device, enc, &src, &dst, n_vec4)
            })
        })
    });
    group.finish();

    let reps = 10;
    let merge1_ms = bench::gpu_ms(ctx, reps, |enc| kernel.encode(enc, false));
    let merge4_ms = bench::gpu_ms(ctx, reps, |enc| kernel.encode(enc, true));
    let copy_ms = bench::gpu_ms(ctx, reps, |enc| {
        copy.encode(&ctx.device, enc, &src, &dst, n_vec4)
    });
    let n = f64::from(n);
    bench::print_result(
        ctx,
        "reservoir",
        &[
            ("n", format!("{n}")),
            ("merges_per_s", bench::sci(n / (merge1_ms * 1e-3))),
            ("vs_copy", format!("{:.2}", merge1_ms / copy_ms)),
            ("merges4_per_s", bench::sci(4.0 * n / (merge4_ms * 1e-3))),
            (
                "copy_gb_s",
                format!("{:.2}", n * 16.0 / (copy_ms * 1e-3) * 1e-9),
            ),
        ],
    );
}

criterion_group!(benches, reservoir_merges);
criterion_main!(benches);
