//! Benchmark plumbing: GPU-timestamp timing for criterion's `iter_custom`, and the `RESULT` line.

use std::time::Duration;

use restir_world::{GpuContext, GpuTimer};

/// GPU time of `iters` repetitions of `record`, recorded into one encoder between two
/// timestamps. Panics with a clear message when the adapter has no timestamp queries: a
/// benchmark without GPU timing has nothing honest to report.
pub fn gpu_time(
    ctx: &GpuContext,
    iters: u64,
    mut record: impl FnMut(&mut wgpu::CommandEncoder),
) -> Duration {
    let mut timer = GpuTimer::new(ctx);
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("bench"),
        });
    timer.span(&mut encoder, "bench", |enc| {
        for _ in 0..iters {
            record(enc);
        }
    });
    timer.resolve(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let times = timer
        .read(ctx)
        .unwrap_or_else(|e| panic!("benchmark needs GPU timestamps: {e}"));
    Duration::from_secs_f64(times.total() * 1e-3)
}

/// Mean GPU milliseconds of one `record` over `reps` timed runs (after one warm-up run).
pub fn gpu_ms(
    ctx: &GpuContext,
    reps: u32,
    mut record: impl FnMut(&mut wgpu::CommandEncoder),
) -> f64 {
    gpu_time(ctx, 1, &mut record);
    let total: f64 = (0..reps)
        .map(|_| gpu_time(ctx, 1, &mut record).as_secs_f64())
        .sum();
    total * 1e3 / f64::from(reps.max(1))
}

/// Formats `RESULT <name> k=v ... device=<adapter>`; values with spaces are quoted.
pub fn result_line(ctx: &GpuContext, name: &str, pairs: &[(&str, String)]) -> String {
    let mut line = format!("RESULT {name}");
    let device = ("device", ctx.info.name.clone());
    for (k, v) in pairs.iter().chain(std::iter::once(&device)) {
        if v.contains(char::is_whitespace) {
            line.push_str(&format!(" {k}={v:?}"));
        } else {
            line.push_str(&format!(" {k}={v}"));
        }
    }
    line
}

/// Prints the `RESULT` line (see [`result_line`]).
pub fn print_result(ctx: &GpuContext, name: &str, pairs: &[(&str, String)]) {
    println!("{}", result_line(ctx, name, pairs));
}

/// Formats a rate with three significant figures in scientific notation (`1.23e9`).
pub fn sci(x: f64) -> String {
    format!("{x:.3e}")
}

/// GPU ms per frame of the spans named `names` in `t`, together (0 when none ran).
pub fn span_ms(t: &restir_world::gpu::PassTimes, names: &[&str]) -> f64 {
    t.per_frame()
        .iter()
        .filter(|(n, _)| names.contains(&n.as_str()))
        .map(|(_, v)| v)
        .sum::<f64>()
        .max(0.0) // an empty sum is -0.0
}

/// Per-span GPU times of `frames` frames of `m` (one per submission, through the one frame
/// loop) after `warm_up` untimed-in-the-result frames.
pub fn frame_times(
    ctx: &GpuContext,
    m: &mut dyn restir_world::methods::FrameMethod,
    warm_up: u32,
    frames: u32,
) -> restir_world::gpu::PassTimes {
    use restir_world::methods::{FrameLoop, MethodError, run_frames};
    let mut run = |frames| {
        run_frames(ctx, m, &FrameLoop::frames(frames), |_, _| {
            Ok::<(), MethodError>(())
        })
        .expect("render")
        .expect("benchmark needs GPU timestamps")
    };
    run(warm_up);
    run(frames)
}

/// The image side a benchmark runs at: the environment variable `var` (e.g. `GI_BENCH_SIZE`),
/// else 128.
pub fn side_from_env(var: &str) -> u32 {
    std::env::var(var)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(128)
}

/// Built-in scene `name` at `side` x `side` and its camera.
pub fn builtin_square(
    name: &str,
    side: u32,
) -> (restir_world::scene::Scene, restir_world::scene::Camera) {
    let opts = restir_world::scene::BuiltinOptions {
        width: side,
        height: side,
        ..Default::default()
    };
    let scene = restir_world::scene::builtin(name, &opts).expect(name);
    let cam = scene.camera_or_default(side, side);
    (scene, cam)
}
