//! The two tracers render the same images: the ray-query backend (where the adapter has ray
//! queries; skipped with a printed reason otherwise) against the software BVH, through the
//! method registry, same seeds. Both draw the same random numbers and trace the same rays, so
//! the images differ only where a ray grazes an edge or meets coplanar triangles: the per-channel
//! means must agree within 0.5% and the per-pixel mean absolute difference stay below 1% of the
//! mean. Negative control: the ray-query image of `ris` with its light samples' pdf overstated
//! by 10% (a defect planted on the GPU) must fail the same check, on each scene.

use restir_world::GpuContext;
use restir_world::gpu::Tracer;
use restir_world::methods::{self, Readback};
use restir_world::plant::Planted;
use restir_world::scene::{BuiltinOptions, builtin};
use tests::gpu;

const MEAN_TOL: f64 = 5e-3;
const PIXEL_TOL: f64 = 1e-2;

fn images(ctx: &GpuContext, scene: &str, spec: &str, planted: Planted) -> Vec<[f32; 3]> {
    let opts = BuiltinOptions {
        width: 48,
        height: 48,
        lights: 2000,
        ..Default::default()
    };
    let s = builtin(scene, &opts).expect("scene");
    let cam = s.camera_or_default(48, 48);
    let settings = methods::parse_spec(spec).expect(spec);
    let options = gpu::planted(5, planted);
    let mut m = settings
        .build_with(ctx, &s, &cam, &options)
        .expect("method");
    let l = methods::FrameLoop::frames(8);
    methods::run_frames(ctx, m.as_mut(), &l, |_, _| {
        Ok::<(), methods::MethodError>(())
    })
    .expect("render");
    m.read(ctx, Readback::Accumulated)
        .expect("images")
        .combined()
}

/// (largest relative difference of a channel mean, mean absolute pixel difference / mean).
fn difference(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f64, f64) {
    let mean = |img: &[[f32; 3]], c: usize| {
        img.iter().map(|p| f64::from(p[c])).sum::<f64>() / img.len() as f64
    };
    let worst_mean = (0..3)
        .map(|c| (mean(a, c) / mean(b, c) - 1.0).abs())
        .fold(0.0, f64::max);
    let total: f64 = (0..3).map(|c| mean(b, c)).sum();
    let abs: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| (0..3).map(|c| f64::from((p[c] - q[c]).abs())).sum::<f64>())
        .sum::<f64>()
        / a.len() as f64;
    (worst_mean, abs / total)
}

#[test]
fn ray_query_images_equal_bvh_images() {
    let Some(rq) = gpu::with_tracer(Tracer::RayQuery) else {
        tests::skip("tracers: this adapter has no ray queries (the ray-query tracer is untested)");
        return;
    };
    let bvh = gpu::with_tracer(Tracer::Bvh).expect("bvh");
    for scene in ["cornell", "many-lights"] {
        for spec in ["nee", "ris", "world-restir", "restir-di"] {
            let a = images(&rq, scene, spec, Planted::None);
            let b = images(&bvh, scene, spec, Planted::None);
            assert!(
                a.iter().flatten().all(|v| v.is_finite()),
                "{scene} {spec}: NaN"
            );
            let (mean, pixel) = difference(&a, &b);
            eprintln!("{scene} {spec}: means within {mean:.2e}, pixels {pixel:.2e}");
            assert!(
                mean < MEAN_TOL && pixel < PIXEL_TOL,
                "{scene} {spec}: ray-query image differs: means {mean:.3e}, pixels {pixel:.3e}"
            );
            if spec == "ris" {
                let p = images(&rq, scene, spec, Planted::LightPdfOverstated);
                let (mean, pixel) = difference(&p, &b);
                eprintln!("{scene} {spec} control (light pdf overstated): {mean:.2e}, {pixel:.2e}");
                assert!(
                    mean >= MEAN_TOL || pixel >= PIXEL_TOL,
                    "{scene} {spec}: the overstated light pdf went unnoticed"
                );
            }
        }
    }
}

#[test]
fn ray_query_is_refused_clearly_where_missing() {
    let mut ctx = gpu::context().clone();
    match ctx.set_tracer(Some(Tracer::RayQuery)) {
        Ok(()) => assert!(ctx.features.ray_query),
        Err(e) => {
            assert!(!ctx.features.ray_query);
            assert!(e.to_string().contains("ray queries"), "{e}");
        }
    }
    ctx.set_tracer(None).expect("auto");
    let cpu = ctx.info.device_type == wgpu::DeviceType::Cpu;
    let want = if ctx.features.ray_query && !cpu {
        Tracer::RayQuery
    } else {
        Tracer::Bvh
    };
    assert_eq!(ctx.tracer, want, "auto");
}

/// A scene with more triangles than one bottom-level acceleration structure may hold is refused
/// before any acceleration structure is made, with the limit named (a device whose
/// `max_blas_primitive_count` is 16 against cornell's 38 triangles).
#[test]
fn scene_beyond_the_acceleration_structure_limits_is_refused() {
    let base = gpu::context();
    let limits = wgpu::Limits {
        max_blas_primitive_count: 16,
        ..base.limits()
    };
    let (device, queue) = gpu::device_with_limits(limits);
    let ctx = GpuContext {
        device,
        queue,
        tracer: Tracer::RayQuery,
        ..base.clone()
    };
    let scene = builtin("cornell", &BuiltinOptions::default()).expect("cornell");
    let bvh = restir_world::trace::Bvh::build(&scene).expect("bvh");
    let e = bvh.upload(&ctx).expect_err("38 triangles > 16").to_string();
    assert!(
        e.contains("38") && e.contains("16") && e.contains("--tracer bvh"),
        "{e}"
    );
}
