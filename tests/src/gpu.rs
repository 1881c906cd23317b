//! The GPU context shared by all tests of one test binary.

use std::sync::OnceLock;

use restir_world::GpuContext;
use restir_world::gpu::{
    BindGroupLayout, BindingSet, FrameEncoder, Kernel, PassTimes, workgroup_size_wgsl,
};
use restir_world::methods::{
    Composed, FrameImages, FrameLoop, FrameMethod, MethodError, Readback, run_frames,
};
use restir_world::plant::Planted;
use restir_world::render::{Paths, RenderOptions};
use restir_world::scene::{Camera, CameraPath, Scene};

/// The shared context. Panics with the fix (install lavapipe) when no adapter exists: GPU tests
/// must fail loudly, never pass vacuously.
pub fn context() -> &'static GpuContext {
    static CTX: OnceLock<Result<GpuContext, String>> = OnceLock::new();
    let ctx = CTX.get_or_init(|| {
        let ctx = GpuContext::new().map_err(|e| e.to_string())?;
        eprintln!("GPU tests run on {}", ctx.describe());
        Ok(ctx)
    });
    match ctx {
        Ok(ctx) => ctx,
        Err(e) => panic!("GPU test needs an adapter: {e}"),
    }
}

/// The shared context if it has `SUBGROUP`; otherwise prints why the caller skips and returns
/// `None`.
pub fn with_subgroups(test: &str) -> Option<&'static GpuContext> {
    let ctx = context();
    if ctx.features.subgroup {
        Some(ctx)
    } else {
        eprintln!("SKIPPED {test}: adapter {:?} lacks SUBGROUP", ctx.info.name);
        None
    }
}

/// Records work with `record`, submits it and waits for it.
pub fn run(ctx: &GpuContext, record: impl FnOnce(&mut wgpu::CommandEncoder)) {
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("test"),
        });
    record(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    ctx.wait().expect("GPU wait failed");
}

/// A second device on the shared adapter with `limits` (and no optional features), e.g.
/// [`wgpu::Limits::downlevel_defaults`], to check that primitives reject a device that falls
/// short with their own typed errors. Its uncaptured-error handler panics, like wgpu's default,
/// so any validation error a primitive lets through fails the test.
pub fn device_with_limits(limits: wgpu::Limits) -> (wgpu::Device, wgpu::Queue) {
    let ctx = context();
    let (device, queue) = block_on(ctx.adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("limited test device"),
        required_limits: limits,
        ..Default::default()
    }))
    .expect("a device with lower limits on the shared adapter");
    (device, queue)
}

/// The shared adapter's limits with fewer storage buffers per shader stage.
pub fn limits_with_storage_buffers(per_stage: u32) -> wgpu::Limits {
    wgpu::Limits {
        max_storage_buffers_per_shader_stage: per_stage,
        ..context().adapter.limits()
    }
}

/// A minimal executor for wgpu's native futures (ready once the call returns).
pub fn block_on<F: std::future::Future>(f: F) -> F::Output {
    let waker = std::task::Waker::noop();
    let mut cx = std::task::Context::from_waker(waker);
    let mut f = std::pin::pin!(f);
    loop {
        if let std::task::Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
        std::thread::yield_now();
    }
}

/// A copy of the shared context tracing with `tracer`, or `None` when the adapter cannot.
///
/// # Panics
/// When it cannot and `RESTIR_REQUIRE_RAY_QUERY=1` (set by `cargo xtask test` where it
/// provides a driver with ray queries): tests must not skip the tracer silently there.
pub fn with_tracer(tracer: restir_world::gpu::Tracer) -> Option<GpuContext> {
    let mut ctx = context().clone();
    match ctx.set_tracer(Some(tracer)) {
        Ok(()) => Some(ctx),
        Err(e) if std::env::var("RESTIR_REQUIRE_RAY_QUERY").is_ok_and(|v| v == "1") => {
            panic!("RESTIR_REQUIRE_RAY_QUERY=1 but {e} ({})", ctx.describe())
        }
        Err(_) => None,
    }
}

/// Frames recorded per submission by [`render`] and [`render_path`]: one fence wait per
/// batch instead of one per frame (these loops are not timed).
pub const FRAMES_PER_SUBMIT: u32 = 16;

/// `frames` untimed frames of `m` on the shared context (static camera), in batches of
/// [`FRAMES_PER_SUBMIT`].
pub fn render(m: &mut dyn FrameMethod, frames: u32) {
    render_path(m, frames, CameraPath::Static);
}

/// [`render`] with the camera moving along `path` (frame indices from 0, from the method's
/// camera when called).
pub fn render_path(m: &mut dyn FrameMethod, frames: u32, path: CameraPath) {
    let base = *m.renderer().camera();
    let camera = |k: u32| (path != CameraPath::Static).then(|| path.camera(&base, k));
    render_cameras(m, 0..frames, camera);
}

/// Frames `frames` of `m`, frame k seen by `camera(k)` (`None`: the camera stays), in untimed
/// batches of [`FRAMES_PER_SUBMIT`]. Each frame's camera is uploaded by its own commands, so
/// frames of different cameras share a submission.
pub fn render_cameras(
    m: &mut dyn FrameMethod,
    frames: std::ops::Range<u32>,
    camera: impl Fn(u32) -> Option<Camera>,
) {
    let ctx = context();
    let mut next = frames.start;
    while next < frames.end {
        let end = frames.end.min(next + FRAMES_PER_SUBMIT);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let mut f = FrameEncoder::new(&ctx.device, &mut encoder, None);
        for k in next..end {
            if let Some(c) = camera(k) {
                m.set_camera(&c).expect("camera");
            }
            m.encode_frame(&mut f).expect("frame");
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait().expect("GPU wait failed");
        next = end;
    }
}

/// `frames` timed frames of `m` through the one frame loop (one per submission, as the tools
/// time them): the span totals when the adapter has timestamps.
pub fn render_timed(m: &mut dyn FrameMethod, frames: u32) -> Option<PassTimes> {
    run_frames(context(), m, &FrameLoop::frames(frames), |_, _| {
        Ok::<(), MethodError>(())
    })
    .expect("render")
}

/// `spec` (a registry method spec) built on the shared context, rendering with `options`.
pub fn build(spec: &str, s: &Scene, cam: &Camera, options: RenderOptions) -> Composed {
    let settings = restir_world::methods::parse_spec(spec).expect(spec);
    Composed::with_options(context(), s, cam, &settings, &options).expect(spec)
}

/// Options of the default paths with `seed` and `planted` compiled in.
pub fn planted(seed: u32, planted: Planted) -> RenderOptions {
    RenderOptions {
        seed,
        planted,
        ..Default::default()
    }
}

/// The accumulated images of `m`.
pub fn images(m: &dyn FrameMethod) -> FrameImages {
    m.read(context(), Readback::Accumulated).expect("images")
}

/// The last frame's images of `m`.
pub fn last_frame(m: &dyn FrameMethod) -> FrameImages {
    m.read(context(), Readback::LastFrame).expect("last frame")
}

/// A kernel on the shared context composed as a user of the `reservoir` crate writes one: the
/// workspace's `WORKGROUP_SIZE` / `Invocation` / `item_index` header, the reservoir library and
/// its RNG, the buffers of `set` (group 0), then `kernel_src`, run `workgroup_size`
/// invocations a workgroup. naga validates it first, so that a broken kernel fails with its
/// diagnostic.
pub fn reservoir_kernel(
    label: &str,
    set: &BindingSet,
    kernel_src: &str,
    entries: &[&str],
    workgroup_size: u32,
) -> (Kernel, BindGroupLayout) {
    let source = format!(
        "{}\n{}\n{}\n{}{kernel_src}",
        workgroup_size_wgsl(),
        reservoir::wgsl(),
        reservoir::rng::WGSL,
        set.wgsl(0)
    );
    if let Err(e) = crate::wgsl::validate(label, &source) {
        panic!("{e}");
    }
    let device = &context().device;
    let layout = set.layout(device);
    let kernel =
        Kernel::with_workgroup_size(device, label, &source, &[&layout], entries, workgroup_size);
    (kernel, layout)
}

/// Render options of one bounce without MIS seeded by `seed` (the paths every method had before
/// paths had a depth), for tests whose subject is direct light or the one-bounce estimate and
/// whose tolerances were calibrated there: depth and MIS are checked per estimator in paths.rs.
pub fn one_bounce(seed: u32) -> RenderOptions {
    RenderOptions {
        seed,
        paths: Paths {
            mis: false,
            ..Paths::bounces(1)
        },
        ..Default::default()
    }
}

/// The camera-cut check of a screen-space reuse stage: renders `m` along
/// [`crate::scenes::orbit_then_cut`] of `cam` to each of [`crate::scenes::cut_checkpoints`];
/// every checked frame and the accumulated images are finite; the frame before the cut has
/// reused history (some final reservoir's M, read by `max_m`, above 1 + `spatial_k`), the cut
/// frame has none (every M at most 1 + `spatial_k`: the reprojection found nothing).
pub fn check_cut_drops_history(
    m: &mut Composed,
    cam: &Camera,
    spatial_k: u32,
    max_m: impl Fn(&Composed) -> u32,
) {
    use crate::scenes::{CUT_FRAME, cut_checkpoints, orbit_then_cut};
    let finite = |img: &[[f32; 3]]| img.iter().flatten().all(|v| v.is_finite());
    let mut next = 0;
    for frame in cut_checkpoints() {
        render_cameras(m, next..frame + 1, |k| Some(orbit_then_cut(cam, k)));
        next = frame + 1;
        let last = last_frame(m);
        assert!(finite(&last.direct), "frame {frame}: direct not finite");
        assert!(finite(&last.indirect), "frame {frame}: indirect not finite");
        if frame == CUT_FRAME - 1 {
            assert!(max_m(m) > 1 + spatial_k, "no history reused before the cut");
        }
        if frame == CUT_FRAME {
            let after = max_m(m);
            assert!(
                after <= 1 + spatial_k,
                "history survived the cut: M up to {after}"
            );
        }
    }
    let acc = images(m);
    assert!(finite(&acc.direct) && finite(&acc.indirect));
}

/// `run(spec, seed)` renders the same images twice at `seed`, and at `seed + 1` another
/// `image` (the one the stage under test writes); every image is finite.
pub fn check_seeded(
    run: impl Fn(&str, u32) -> FrameImages,
    spec: &str,
    seed: u32,
    image: fn(&FrameImages) -> &Vec<[f32; 3]>,
) {
    let a = run(spec, seed);
    assert_eq!(a, run(spec, seed), "{spec}: same seed, different images");
    assert_ne!(
        image(&a),
        image(&run(spec, seed + 1)),
        "{spec}: the seed changes nothing"
    );
    let finite = |img: &[[f32; 3]]| img.iter().flatten().all(|v| v.is_finite());
    assert!(
        finite(&a.direct) && finite(&a.indirect),
        "{spec}: not finite"
    );
}
