//! Rays per second of both GPU tracers, our WGSL CWBVH traversal (`bvh_rays_per_s`) and the
//! adapter's ray queries (`rq_rays_per_s`, "unavailable" without them), for coherent primary
//! rays, incoherent GI rays and shadow rays (any hit), against obvhs's CPU traversal (same
//! watertight test) on all host cores on the same rays, in one run. Also reports the BVH build
//! time (CPU, obvhs medium preset) and the acceleration structures' build time (upload + build,
//! wall clock, waited for).
//!
//! On lavapipe the "GPU" is the same CPU, so the CPU traversal is the honest peer: the ratios
//! bvh_rays_per_s / cpu_rays_per_s and rq_rays_per_s / cpu_rays_per_s are the numbers to read.
//!
//! What a ray costs, device-independently: the nodes and triangles our GPU traversal tests a
//! ray (`gpu_nodes_per_ray`, `gpu_tris_per_ray`, and the bytes of both it fetches) beside
//! obvhs's CPU traversal of the same BVH and rays (`cpu_*`).

use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rand::{Rng, SeedableRng, rngs::StdRng};
use restir_world::GpuContext;
use restir_world::gpu::Tracer;
use restir_world::sampling::CameraGpu;
use restir_world::scene::{BuiltinOptions, Scene, builtin};
use restir_world::trace::{Bvh, Hit, Ray, TraceBinding, TraceKernel, Visits};
use tests::{bench, buffers, gpu};

const SIDE: u32 = 256;

fn scenes() -> Vec<(&'static str, Scene)> {
    let opts = BuiltinOptions {
        width: SIDE,
        height: SIDE,
        ..Default::default()
    };
    let mut out: Vec<(&'static str, Scene)> = ["cornell", "many-lights"]
        .into_iter()
        .map(|name| (name, builtin(name, &opts).expect("built-in scene")))
        .collect();
    if let Some(dir) = tests::scenes_dir() {
        let path = dir.join("sponza-capsaicin/Sponza.gltf");
        let sponza = restir_world::scene::load(&path).expect("Sponza loads");
        out.push(("sponza", sponza.scene));
    }
    out
}

/// Pinhole rays through pixel centres.
fn primary_rays(scene: &Scene) -> Vec<Ray> {
    let cam = CameraGpu::new(&scene.camera_or_default(SIDE, SIDE));
    let mut rays = Vec::new();
    for y in 0..SIDE {
        for x in 0..SIDE {
            let d = cam.ray_dir([x, y], glam::Vec2::splat(0.5));
            rays.push(Ray::new(Vec3::from(cam.eye), d, 0.0, f32::MAX));
        }
    }
    rays
}

fn hit_frame(bvh: &Bvh, ray: &Ray, hit: &Hit) -> (Vec3, Vec3) {
    let t = &bvh.triangles[hit.prim as usize];
    let (v0, v1, v2) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
    let mut n = (v1 - v0).cross(v2 - v0).normalize();
    if n.dot(Vec3::from(ray.dir)) > 0.0 {
        n = -n;
    }
    let p = v0 + (v1 - v0) * hit.b1 + (v2 - v0) * hit.b2;
    (p + n * 1e-4, n)
}

/// One cosine-weighted GI ray and one shadow ray (to a random point on a random emissive
/// triangle, or a random direction when there is none) per primary hit.
fn secondary_rays(scene: &Scene, bvh: &Bvh, primary: &[Ray], hits: &[Hit]) -> (Vec<Ray>, Vec<Ray>) {
    let mut rng = StdRng::seed_from_u64(7);
    let emissive: Vec<usize> = (0..scene.triangles.len())
        .filter(|&i| {
            scene
                .materials
                .get(scene.triangles[i].material as usize)
                .is_some_and(|m| m.is_emissive())
        })
        .collect();
    let (mut gi, mut shadow) = (Vec::new(), Vec::new());
    for (ray, hit) in primary.iter().zip(hits) {
        if !hit.is_hit() {
            continue;
        }
        let (p, n) = hit_frame(bvh, ray, hit);
        let (u1, u2): (f32, f32) = (rng.random(), rng.random());
        let (b1, b2) = n.any_orthonormal_pair();
        let r = u1.sqrt();
        let phi = std::f32::consts::TAU * u2;
        let d = b1 * (r * phi.cos()) + b2 * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
        gi.push(Ray::new(p, d.normalize(), 0.0, f32::MAX));
        if emissive.is_empty() {
            shadow.push(Ray::new(p, d.normalize(), 0.0, 1.0));
        } else {
            let t = &scene.triangles[emissive[rng.random_range(0..emissive.len())]];
            let (mut a, mut b): (f32, f32) = (rng.random(), rng.random());
            if a + b > 1.0 {
                a = 1.0 - a;
                b = 1.0 - b;
            }
            let q = t.v[0] + (t.v[1] - t.v[0]) * a + (t.v[2] - t.v[0]) * b;
            let to = q - p;
            let dist = to.length();
            shadow.push(Ray::new(p, to / dist, 0.0, dist * (1.0 - 1e-3)));
        }
    }
    (gi, shadow)
}

/// obvhs CPU traversal on all host cores; returns rays per second (best of 3).
fn cpu_rays_per_s(bvh: &Bvh, rays: &[Ray], any_hit: bool) -> f64 {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = rays.len().div_ceil(threads);
    let mut best = f64::MAX;
    for _ in 0..3 {
        let t0 = Instant::now();
        let hits: usize = std::thread::scope(|s| {
            let handles: Vec<_> = rays
                .chunks(chunk)
                .map(|c| {
                    s.spawn(move || {
                        c.iter()
                            .filter(|r| {
                                if any_hit {
                                    bvh.any_hit(r)
                                } else {
                                    bvh.closest_hit(r).is_hit()
                                }
                            })
                            .count()
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap_or(0)).sum()
        });
        std::hint::black_box(hits);
        best = best.min(t0.elapsed().as_secs_f64());
    }
    rays.len() as f64 / best
}

/// A bound dispatch of `rays` on one tracer.
struct Traced {
    kernel: TraceKernel,
    binding: TraceBinding,
}

/// GPU milliseconds of one trace of the bound rays (after a warm-up), timed with criterion too.
fn gpu_ms(ctx: &GpuContext, t: &Traced) -> f64 {
    bench::gpu_ms(ctx, 5, |enc| t.kernel.encode_with(enc, &t.binding))
}

/// Rays per second of each tracer on one kind of ray, their BVHs' build times, and what a
/// ray visits on the GPU and in obvhs's CPU traversal.
struct Rates {
    bvh: f64,
    ray_query: Option<f64>,
    cpu: f64,
    bvh_build_ms: f64,
    rq_build_ms: Option<f64>,
    gpu_visits: VisitsPerRay,
    cpu_visits: VisitsPerRay,
}

/// Nodes, triangles and bytes a ray, averaged over a kind of ray.
struct VisitsPerRay {
    nodes: f64,
    triangles: f64,
    bytes: f64,
}

impl VisitsPerRay {
    fn of(visits: &[Visits]) -> Self {
        let n = visits.len().max(1) as f64;
        let sum = |f: &dyn Fn(&Visits) -> f64| visits.iter().map(f).sum::<f64>() / n;
        Self {
            nodes: sum(&|v| f64::from(v.nodes)),
            triangles: sum(&|v| f64::from(v.triangles)),
            bytes: sum(&|v| v.bytes() as f64),
        }
    }
}

/// What each ray visits in our GPU traversal (the counting kernel, once).
fn gpu_visits(
    ctx: &GpuContext,
    bvh: &restir_world::trace::GpuBvh,
    rays: &wgpu::Buffer,
    hits: &wgpu::Buffer,
    n: u32,
    any_hit: bool,
) -> Vec<Visits> {
    let kernel = TraceKernel::counting(&ctx.device);
    let bytes = u64::from(n) * size_of::<Visits>() as u64;
    let counts = buffers::storage_zeroed(&ctx.device, "visits", bytes);
    let binding = kernel
        .bind_counted(&ctx.device, bvh, rays, hits, &counts, n, any_hit)
        .expect("bind");
    gpu::run(ctx, |enc| kernel.encode_with(enc, &binding));
    let mut v: Vec<Visits> = buffers::read(ctx, &counts).expect("readback");
    v.truncate(n as usize);
    v
}

/// The RESULT pairs of one scene's kind of ray (`unavailable` where the adapter has no ray
/// queries).
fn result_pairs(
    scene: &str,
    kind: &str,
    rays: u32,
    triangles: usize,
    r: &Rates,
) -> Vec<(&'static str, String)> {
    let unavailable = || "unavailable".to_string();
    vec![
        ("scene", scene.to_string()),
        ("kind", kind.to_string()),
        ("rays", rays.to_string()),
        ("triangles", triangles.to_string()),
        ("bvh_rays_per_s", bench::sci(r.bvh)),
        (
            "rq_rays_per_s",
            r.ray_query.map_or_else(unavailable, bench::sci),
        ),
        ("cpu_rays_per_s", bench::sci(r.cpu)),
        ("bvh_vs_cpu", format!("{:.3}", r.bvh / r.cpu)),
        (
            "rq_vs_cpu",
            r.ray_query
                .map_or_else(unavailable, |q| format!("{:.3}", q / r.cpu)),
        ),
        ("bvh_build_ms", format!("{:.3}", r.bvh_build_ms)),
        (
            "rq_build_ms",
            r.rq_build_ms
                .map_or_else(unavailable, |ms| format!("{ms:.3}")),
        ),
        ("gpu_nodes_per_ray", format!("{:.2}", r.gpu_visits.nodes)),
        ("cpu_nodes_per_ray", format!("{:.2}", r.cpu_visits.nodes)),
        ("gpu_tris_per_ray", format!("{:.2}", r.gpu_visits.triangles)),
        ("cpu_tris_per_ray", format!("{:.2}", r.cpu_visits.triangles)),
        ("gpu_bytes_per_ray", format!("{:.0}", r.gpu_visits.bytes)),
        ("cpu_bytes_per_ray", format!("{:.0}", r.cpu_visits.bytes)),
        (
            "cpu_threads",
            std::thread::available_parallelism()
                .map_or(1, |n| n.get())
                .to_string(),
        ),
    ]
}

fn trace(c: &mut Criterion) {
    let ctx = gpu::context();
    let rq_ctx = gpu::with_tracer(Tracer::RayQuery);
    let mut bvh_ctx = ctx.clone();
    bvh_ctx.set_tracer(Some(Tracer::Bvh)).expect("bvh");
    let mut lines = Vec::new();
    for (name, scene) in scenes() {
        let bvh = Bvh::build(&scene).expect("bvh build");
        let build_ms = bvh.build_time.as_secs_f64() * 1e3;
        let gpu_bvh = bvh.upload(&bvh_ctx).expect("upload");
        let rq = rq_ctx.as_ref().map(|rq| {
            let t0 = Instant::now();
            let up = bvh.upload(rq).expect("ray-query upload");
            (up, t0.elapsed().as_secs_f64() * 1e3)
        });
        let primary = primary_rays(&scene);
        let primary_hits: Vec<Hit> = primary.iter().map(|r| bvh.closest_hit(r)).collect();
        let (gi, shadow) = secondary_rays(&scene, &bvh, &primary, &primary_hits);
        let mut group = c.benchmark_group(format!("trace/{name}"));
        group.sample_size(10);
        for (kind, rays, any_hit) in [
            ("primary", &primary, false),
            ("gi", &gi, false),
            ("shadow", &shadow, true),
        ] {
            let n = rays.len() as u32;
            let rays_buf = buffers::storage_from(&ctx.device, "rays", rays);
            let hits_buf = buffers::storage_zeroed(
                &ctx.device,
                "hits",
                u64::from(n) * size_of::<Hit>() as u64,
            );
            let bind = |kernel: TraceKernel, up: &restir_world::trace::GpuBvh| {
                let binding = kernel
                    .bind(&ctx.device, up, &rays_buf, &hits_buf, n, any_hit)
                    .expect("bind");
                Traced { kernel, binding }
            };
            let sw = bind(TraceKernel::new(&ctx.device, Tracer::Bvh), &gpu_bvh);
            group.throughput(Throughput::Elements(u64::from(n)));
            group.bench_function(kind, |b| {
                b.iter_custom(|iters| {
                    bench::gpu_time(ctx, iters, |enc| sw.kernel.encode_with(enc, &sw.binding))
                })
            });
            let gpu_rps = f64::from(n) / (gpu_ms(ctx, &sw) * 1e-3);
            let rq_rps = rq.as_ref().map(|(up, _)| {
                let hw = bind(TraceKernel::new(&ctx.device, Tracer::RayQuery), up);
                f64::from(n) / (gpu_ms(ctx, &hw) * 1e-3)
            });
            let cpu_rps = cpu_rays_per_s(&bvh, rays, any_hit);
            let gv = gpu_visits(ctx, &gpu_bvh, &rays_buf, &hits_buf, n, any_hit);
            let cv: Vec<Visits> = rays.iter().map(|r| bvh.traverse(r, any_hit).1).collect();
            let rates = Rates {
                gpu_visits: VisitsPerRay::of(&gv),
                cpu_visits: VisitsPerRay::of(&cv),
                bvh: gpu_rps,
                ray_query: rq_rps,
                cpu: cpu_rps,
                bvh_build_ms: build_ms,
                rq_build_ms: rq.as_ref().map(|(_, ms)| *ms),
            };
            let pairs = result_pairs(name, kind, n, scene.triangles.len(), &rates);
            lines.push((name, kind, pairs));
        }
        group.finish();
    }
    for (_, _, pairs) in &lines {
        bench::print_result(ctx, "trace", pairs);
    }
}

criterion_group!(benches, trace);
criterion_main!(benches);
