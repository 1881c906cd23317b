//! Per-stage GPU milliseconds per frame of ReSTIR GI, screen space (`restir-gi`) and world
//! space (`world-restir-gi`), against the `ris` baseline measured in the same run, on
//! many-lights (10,000 lights), timed with GPU timestamp spans around every pass after a
//! warm-up of 4 frames (temporal history built). One `RESULT restir-gi` line per variant of the
//! registry's `restir-gi` (`variant=default` first), per composition
//! (`restir-gi+world-restir`, `restir-di+restir-gi+world-restir`) and per world-space method
//! (`world-restir-gi`, `world-restir-gi+world-restir`, `world-restir-gi:subpath` with its
//! sub-path pass, `subpath_ms`, and its two visibility modes that trace fewer rays), each with
//! the share of its
//! reconnections rejected in the last frame and the bytes its buffers hold per pixel (the
//! world-space grid's included) and those of every per-frame buffer of the method.
//!
//! Size: `GI_BENCH_SIZE` (default 128).

use restir_world::GpuContext;
use restir_world::methods::{self, Composed, FrameMethod};
use restir_world::restir_gi;
use restir_world::scene::{Camera, Scene};
use tests::{bench, gpu};

const WARM_UP: u32 = 4;
/// Every pass of the stage, after its span prefix (`gi`, `wgi`).
const GI_STEPS: [&str; 8] = [
    "build", "subpath", "initial", "temporal", "spatial", "shade", "persist", "pool",
];
const FRAMES: u32 = 6;

fn build(ctx: &GpuContext, scene: &Scene, cam: &Camera, spec: &str) -> Composed {
    let settings = methods::parse_spec(spec).expect(spec);
    Composed::new(ctx, scene, cam, &settings, 1).expect(spec)
}

/// (method, variant) of every line: restir-gi's default and each variant but `both`, then the
/// compositions.
fn specs() -> Vec<(&'static str, String)> {
    let variants = restir_gi::variants();
    std::iter::once(("restir-gi", "default".to_string()))
        .chain(
            variants
                .iter()
                .filter(|v| v.name != "both")
                .map(|v| ("restir-gi", v.name.to_string())),
        )
        .chain(
            [
                "restir-gi+world-restir",
                "restir-di+restir-gi+world-restir",
                "world-restir-gi",
                "world-restir-gi+world-restir",
            ]
            .map(|m| (m, "default".to_string())),
        )
        .chain(
            ["subpath", "all-visibility", "final-visibility"]
                .map(|v| ("world-restir-gi", v.to_string())),
        )
        .collect()
}

fn main() {
    let ctx = gpu::context();
    let side = bench::side_from_env("GI_BENCH_SIZE");
    let (scene, cam) = bench::builtin_square("many-lights", side);
    let ris_ms = bench::frame_times(ctx, &mut build(ctx, &scene, &cam, "ris"), WARM_UP, FRAMES)
        .ms_per_frame();
    let f = |x: f64| format!("{x:.3}");
    for (method, variant) in specs() {
        let spec = match variant.as_str() {
            "default" => method.to_string(),
            v => format!("{method}:{v}"),
        };
        let mut m = build(ctx, &scene, &cam, &spec);
        let t = bench::frame_times(ctx, &mut m, WARM_UP, FRAMES);
        eprintln!("{spec} per frame: {:?}", t.per_frame());
        let tried_rejected = m.gi().unwrap().reconnections(ctx).expect("reconnections");
        let (tried, rejected) = tried_rejected.iter().fold((0u64, 0u64), |(a, b), &(t, r)| {
            (a + u64::from(t), b + u64::from(r))
        });
        let frame_ms = t.ms_per_frame();
        let prefix = if method.contains("world-restir-gi") {
            "wgi"
        } else {
            "gi"
        };
        let span = |step: &str| format!("{prefix}-{step}");
        let ms = |step: &str| bench::span_ms(&t, &[span(step).as_str()]);
        let all: Vec<String> = GI_STEPS.iter().map(|s| span(s)).collect();
        let all: Vec<&str> = all.iter().map(String::as_str).collect();
        let bytes = m.gi().unwrap().bytes() as f64 / f64::from(side * side);
        let frame_bytes = m.frame_bytes() as f64 / f64::from(side * side);
        bench::print_result(
            ctx,
            "restir-gi",
            &[
                ("method", method.into()),
                ("variant", variant),
                ("scene", "many-lights".into()),
                ("size", format!("{side}x{side}")),
                ("build_ms", f(ms("build"))),
                ("subpath_ms", f(ms("subpath"))),
                ("initial_ms", f(ms("initial"))),
                ("temporal_ms", f(ms("temporal"))),
                ("spatial_ms", f(ms("spatial"))),
                ("shade_ms", f(ms("shade"))),
                ("pool_ms", f(ms("pool"))),
                ("reuse_share", f(bench::span_ms(&t, &all) / frame_ms)),
                ("frame_ms", f(frame_ms)),
                ("ris_frame_ms", f(ris_ms)),
                ("vs_ris_frame", format!("{:.3}", frame_ms / ris_ms)),
                ("merged", tried.to_string()),
                (
                    "rejected_share",
                    format!("{:.3}", rejected as f64 / tried.max(1) as f64),
                ),
                ("bytes_per_pixel", format!("{bytes:.1}")),
                ("frame_bytes_per_pixel", format!("{frame_bytes:.1}")),
            ],
        );
    }
}
