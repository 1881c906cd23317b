//! `restir-demo render` with a GPU method of the registry: static or with a camera animation
//! (orbit or dolly over F frames), the per-pass GPU times, and the debug views (PNG) of
//! methods that have them.

use anyhow::Result;
use clap::Args;
use restir_world::GpuContext;
use restir_world::denoise::DenoiseConfig;
use restir_world::image_io::Image;
use restir_world::methods::{
    FrameLoop, FrameMethod, MethodError, MethodSettings, Readback, run_frames,
};
use restir_world::reference::Rendered;
use restir_world::render::{DebugView, RenderOptions};
use restir_world::scene::{Camera, CameraPath, Scene};

use crate::camera::Motion;
use crate::progress_bar;

/// Camera animation and debug-view flags of GPU methods.
#[derive(Args, Debug)]
pub struct AnimArgs {
    /// Camera animation over --anim-frames frames (static, orbit, dolly).
    #[arg(long, value_enum, default_value_t = Motion::Static)]
    animation: Motion,
    #[arg(long, default_value_t = 32)]
    anim_frames: u32,
    /// Orbit angle in degrees over the animation.
    #[arg(long, default_value_t = 30.0)]
    orbit_degrees: f32,
    /// Dolly: fraction of the eye-target distance travelled over the animation.
    #[arg(long, default_value_t = 0.3)]
    dolly_fraction: f32,
    /// Also write the last frame's debug views the method draws (TAG-debug-VIEW.png: a hash
    /// grid's cells, M and overflow; path reuse's M, rejected and refused reconnections,
    /// temporal history; the cache's; the denoiser's).
    #[arg(long)]
    debug_views: bool,
    /// Also write the last frame denoised (TAG-denoised.exr/png; SVGF after the method), with
    /// the denoiser's knobs as key=value joined by + (e.g. --denoise iterations=3+alpha=0.1;
    /// bare --denoise: the defaults). With --debug-views, also its history length, variance
    /// and each filter iteration.
    #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "KNOBS")]
    pub denoise: Option<String>,
}

impl AnimArgs {
    /// Whether a camera animation or debug views were asked for (GPU methods only).
    pub fn used(&self) -> bool {
        self.animation != Motion::Static || self.debug_views || self.denoise.is_some()
    }

    /// The denoiser's knobs from --denoise (`None`: not asked for).
    pub fn denoise_config(&self) -> Result<Option<DenoiseConfig>> {
        self.denoise
            .as_deref()
            .map(|k| DenoiseConfig::parse(k).map_err(|e| anyhow::anyhow!("--denoise: {e}")))
            .transpose()
    }

    /// Checks the animation before any work.
    pub fn validate(&self) -> Result<()> {
        if self.animation != Motion::Static && self.anim_frames == 0 {
            anyhow::bail!(
                "--anim-frames must be at least 1 with --animation {:?} (0 would leave the \
                 camera static)",
                format!("{:?}", self.animation).to_lowercase()
            );
        }
        if !self.orbit_degrees.is_finite() {
            anyhow::bail!("--orbit-degrees must be a finite number");
        }
        if !(self.dolly_fraction.is_finite() && self.dolly_fraction < 1.0) {
            anyhow::bail!(
                "--dolly-fraction must be a finite number below 1 (1 reaches the target)"
            );
        }
        Ok(())
    }

    /// Checks the camera of each of the first `frames` frames of the animation from the
    /// scene's camera `base` before any work: a dolly far backwards (`--dolly-fraction -1e38`)
    /// would leave floats.
    pub fn check_cameras(&self, base: &Camera, frames: u32) -> Result<()> {
        let path = self.path();
        for frame in 0..self.anim_frames.min(frames).max(1) {
            if let Err(e) = path.camera(base, frame).validate() {
                let flag = match self.animation {
                    Motion::Dolly => format!("--dolly-fraction {:?}", self.dolly_fraction),
                    _ => format!("--orbit-degrees {:?}", self.orbit_degrees),
                };
                anyhow::bail!("{flag}: frame {frame}'s camera is not valid: {e}");
            }
        }
        Ok(())
    }

    fn path(&self) -> CameraPath {
        self.animation
            .path(self.anim_frames, self.orbit_degrees, self.dolly_fraction)
    }
}

/// A method's render: the accumulated images, and the debug views of its last frame when asked
/// (each with its file name's suffix, e.g. `debug-m`), written together by the caller.
pub struct MethodRender {
    pub images: Rendered,
    /// The last frame denoised (combined), with --denoise.
    pub denoised: Option<Image>,
    pub debug_views: Vec<(&'static str, Image)>,
}

/// Renders `frames` frames of the registry method `spec` (parsed: `settings`) and returns the
/// accumulated images, and the debug views when asked.
pub fn render_method(
    spec: &str,
    settings: &MethodSettings,
    args: &AnimArgs,
    scene: &Scene,
    camera: &Camera,
    frames: u32,
    options: &RenderOptions,
) -> Result<MethodRender> {
    args.check_cameras(camera, frames)?;
    let ctx = crate::gpu_context()?;
    eprintln!("{}", ctx.describe());
    // Said before the build: a method's kernels compile on their first use on this machine,
    // which takes minutes on a CPU adapter, with no progress bar yet (and none in a log).
    eprintln!("{spec}: building (its kernels compile on first use: minutes on a CPU adapter)");
    let start = std::time::Instant::now();
    let mut m = build(settings, &ctx, scene, camera, options)?;
    eprintln!(
        "{spec}: built in {:.1} s; rendering {frames} frames at {}x{}",
        start.elapsed().as_secs_f64(),
        camera.width,
        camera.height
    );
    let l = FrameLoop {
        path: args.path(),
        ..FrameLoop::frames(frames)
    };
    let pb = progress_bar(u64::from(frames), &format!("{spec} frames"));
    let times = run_frames(&ctx, m.as_mut(), &l, |_, s| {
        pb.inc(u64::from(s.frames));
        Ok::<(), MethodError>(())
    })?;
    pb.finish_and_clear();
    match times {
        Some(t) => println!(
            "{spec}: {} frames, GPU {:.3} ms/frame ({}) on {}",
            t.frames,
            t.ms_per_frame(),
            t.line(),
            ctx.info.name
        ),
        None => println!("{spec}: {frames} frames (adapter has no timestamps)"),
    }
    print_stage_stats(&ctx, m.as_ref())?;
    let debug_views = match args.debug_views {
        true => debug_views(&ctx, m.as_ref(), spec, camera)?,
        false => Vec::new(),
    };
    let denoised = match m.read_denoised(&ctx)? {
        Some(d) => Some(d.into_rendered()?.combined),
        None => None,
    };
    Ok(MethodRender {
        images: m.read(&ctx, Readback::Accumulated)?.into_rendered()?,
        denoised,
        debug_views,
    })
}

/// The hash grid's and the radiance cache's use in the last frame, for methods with them.
fn print_stage_stats(ctx: &GpuContext, m: &dyn FrameMethod) -> Result<()> {
    if let Some(overflows) = m.grid_overflows(ctx)? {
        println!(
            "grid (last frame): {overflows} vertices found their bucket full and kept their own \
             reservoir"
        );
    }
    if let Some(s) = m.cache_stats(ctx)? {
        println!(
            "radiance cache (last frame): {} of {} cells in use, {} bytes per cell ({:.1} MiB), \
             {} inserts found their bucket full, {} non-finite or out-of-range left out",
            s.cells_in_use,
            s.capacity,
            s.bytes_per_cell,
            s.bytes() as f64 / f64::from(1u32 << 20),
            s.overflows,
            s.rejected
        );
    }
    Ok(())
}

/// The debug views `m` draws, each with its file name's suffix.
fn debug_views(
    ctx: &GpuContext,
    m: &dyn FrameMethod,
    spec: &str,
    camera: &Camera,
) -> Result<Vec<(&'static str, Image)>> {
    let mut views = Vec::new();
    for (view, name) in [
        (DebugView::Cells, "debug-cells"),
        (DebugView::M, "debug-m"),
        (DebugView::Overflow, "debug-overflow"),
        (DebugView::Rejected, "debug-rejected"),
        (DebugView::CacheRadiance, "debug-cache-radiance"),
        (DebugView::CacheAge, "debug-cache-age"),
        (DebugView::CacheSamples, "debug-cache-samples"),
        (DebugView::DenoiseHistory, "debug-denoise-history"),
        (DebugView::DenoiseVariance, "debug-denoise-variance"),
        (DebugView::History, "debug-history"),
        (DebugView::HistoryAge, "debug-history-age"),
        (DebugView::Refused, "debug-refused"),
    ] {
        // Each method draws the views it has.
        let Some(px) = m.debug_image(ctx, view)? else {
            continue;
        };
        let img = Image::from_pixels(camera.width, camera.height, px)
            .map_err(|e| anyhow::anyhow!("{spec}'s debug view {name}: {e}"))?;
        views.push((name, img));
    }
    const ITERATIONS: [&str; 1 + restir_world::denoise::MAX_ITERATIONS as usize] = [
        "debug-denoise-iteration-0",
        "debug-denoise-iteration-1",
        "debug-denoise-iteration-2",
        "debug-denoise-iteration-3",
        "debug-denoise-iteration-4",
        "debug-denoise-iteration-5",
        "debug-denoise-iteration-6",
        "debug-denoise-iteration-7",
        "debug-denoise-iteration-8",
    ];
    // The denoiser's iterations: radiance, written as PNGs like the views (exposure 1).
    for (k, px) in m.denoise_iterations(ctx)?.into_iter().flatten().enumerate() {
        let img = Image::from_pixels(camera.width, camera.height, px)
            .map_err(|e| anyhow::anyhow!("{spec}'s denoiser iteration {k}: {e}"))?;
        views.push((ITERATIONS[k], img));
    }
    if views.is_empty() {
        eprintln!("warning: {spec} has no debug views");
    }
    Ok(views)
}

/// `settings` built on `ctx` (`MethodSettings::build_with`); an image too large for one of
/// the adapter's bindings is refused naming `--size` and a height that fits at its width.
pub fn build(
    settings: &MethodSettings,
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    options: &RenderOptions,
) -> Result<Box<dyn FrameMethod>> {
    settings
        .build_with(ctx, scene, camera, options)
        .map_err(|e| size_error(&e.to_string(), camera.width, camera.height))
}

/// An error message with `--size` named where it says the image is too large
/// ([`restir_world::gpu::IMAGE_TOO_LARGE`]), else the message as it is.
pub fn size_error(message: &str, width: u32, height: u32) -> anyhow::Error {
    let fit = message
        .split(restir_world::gpu::IMAGE_TOO_LARGE)
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next()?.parse::<u64>().ok());
    match fit {
        Some(pixels) => {
            let h = (pixels / u64::from(width.max(1))).min(u64::from(height));
            let hint = match h {
                0 => format!("a width of at most {pixels}"),
                h => format!("e.g. --size {width}x{h}"),
            };
            anyhow::anyhow!("--size {width}x{height}: {message}; {hint}")
        }
        None => anyhow::anyhow!("{message}"),
    }
}
