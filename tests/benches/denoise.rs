//! GPU milliseconds per frame of the denoiser (SVGF, span `denoise`) after `ris` and
//! `restir-gi`, against the method's own frame measured in the same frames (the peer: what the
//! denoiser adds to a frame), on cornell and many-lights (10,000 lights), timed with GPU
//! timestamp spans after a warm-up of 4 frames (its history built). One `RESULT denoise` line per
//! scene and method, with the bytes its buffers hold per pixel.
//!
//! Size: `DENOISE_BENCH_SIZE` (default 128).

use restir_world::denoise::{BYTES_PER_PIXEL, DenoiseConfig};
use restir_world::methods::{self, Composed, MethodSettings};
use tests::{bench, gpu};

const WARM_UP: u32 = 4;
const FRAMES: u32 = 6;

fn main() {
    let ctx = gpu::context();
    let side = bench::side_from_env("DENOISE_BENCH_SIZE");
    let f = |x: f64| format!("{x:.3}");
    for name in ["cornell", "many-lights"] {
        let (scene, cam) = bench::builtin_square(name, side);
        for spec in ["ris", "restir-gi"] {
            let settings = MethodSettings {
                denoise: Some(DenoiseConfig::default()),
                ..methods::parse_spec(spec).expect(spec)
            };
            let mut m = Composed::new(ctx, &scene, &cam, &settings, 1).expect(spec);
            let t = bench::frame_times(ctx, &mut m, WARM_UP, FRAMES);
            let frame_ms = t.ms_per_frame();
            let denoise_ms = bench::span_ms(&t, &["denoise"]);
            let method_ms = frame_ms - denoise_ms;
            bench::print_result(
                ctx,
                "denoise",
                &[
                    ("scene", name.into()),
                    ("method", spec.into()),
                    ("size", format!("{side}x{side}")),
                    (
                        "iterations",
                        DenoiseConfig::default().iterations.to_string(),
                    ),
                    ("denoise_ms", f(denoise_ms)),
                    ("method_frame_ms", f(method_ms)),
                    ("vs_method_frame", f(denoise_ms / method_ms)),
                    ("bytes_per_pixel", BYTES_PER_PIXEL.to_string()),
                ],
            );
        }
    }
}
