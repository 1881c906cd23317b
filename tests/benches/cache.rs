//! GPU milliseconds per frame of the radiance cache's passes against the frame, and of each
//! `+cache` method against the same method with unbounded paths measured in the same run, on
//! cornell and many-lights (10,000 lights), with the paths of the cache's comparisons (64
//! bounces, Russian roulette from bounce 3), timed with GPU timestamp spans around every pass
//! after a warm-up of 4 frames. One `RESULT cache` line per method and scene, with the cache's
//! cells in use, capacity, bytes per cell and overflows after the last frame.
//!
//! Size: `CACHE_BENCH_SIZE` (default 128).

use restir_world::GpuContext;
use restir_world::methods::{self, Composed, FrameMethod};
use restir_world::render::{MAX_BOUNCES, Paths, RenderOptions};
use restir_world::scene::{Camera, Scene};
use tests::{bench, gpu};

const WARM_UP: u32 = 4;
const FRAMES: u32 = 6;
const METHODS: [&str; 3] = [
    "ris+cache",
    "world-restir+cache",
    "restir-gi+world-restir+cache",
];

fn build(ctx: &GpuContext, scene: &Scene, cam: &Camera, spec: &str) -> Composed {
    let settings = methods::parse_spec(spec).expect(spec);
    let options = RenderOptions {
        seed: 1,
        paths: Paths::bounces(MAX_BOUNCES),
        ..Default::default()
    };
    Composed::with_options(ctx, scene, cam, &settings, &options).expect(spec)
}

fn main() {
    let ctx = gpu::context();
    let side = bench::side_from_env("CACHE_BENCH_SIZE");
    let f = |x: f64| format!("{x:.3}");
    for name in ["cornell", "many-lights"] {
        let (scene, cam) = bench::builtin_square(name, side);
        for spec in METHODS {
            let base = spec.trim_end_matches("+cache");
            let base_ms =
                bench::frame_times(ctx, &mut build(ctx, &scene, &cam, base), WARM_UP, FRAMES)
                    .ms_per_frame();
            let mut m = build(ctx, &scene, &cam, spec);
            let t = bench::frame_times(ctx, &mut m, WARM_UP, FRAMES);
            eprintln!("{spec} on {name} per frame: {:?}", t.per_frame());
            let s = m.cache_stats(ctx).expect("stats").expect("a cache");
            let frame_ms = t.ms_per_frame();
            let cache_ms = bench::span_ms(&t, &["cache-update", "cache-resolve"]);
            bench::print_result(
                ctx,
                "cache",
                &[
                    ("method", spec.into()),
                    ("scene", name.into()),
                    ("size", format!("{side}x{side}")),
                    ("bounces", MAX_BOUNCES.to_string()),
                    ("update_ms", f(bench::span_ms(&t, &["cache-update"]))),
                    ("resolve_ms", f(bench::span_ms(&t, &["cache-resolve"]))),
                    ("path_ms", f(bench::span_ms(&t, &["path"]))),
                    ("cache_share", format!("{:.3}", cache_ms / frame_ms)),
                    ("frame_ms", f(frame_ms)),
                    ("unbounded_frame_ms", f(base_ms)),
                    ("vs_unbounded_frame", format!("{:.3}", frame_ms / base_ms)),
                    ("cells_in_use", s.cells_in_use.to_string()),
                    ("capacity", s.capacity.to_string()),
                    ("bytes_per_cell", s.bytes_per_cell.to_string()),
                    ("overflows", s.overflows.to_string()),
                    (
                        "frame_bytes_per_pixel",
                        format!("{:.1}", m.frame_bytes() as f64 / f64::from(side * side)),
                    ),
                ],
            );
        }
    }
}
