//! `restir-demo render`: renders a built-in scene with `nee`, `ris` or `world-restir`, static or
//! with a camera animation, and writes the direct / indirect / combined images (PNG + EXR), the
//! world-restir debug views, and the per-pass GPU times.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use restir_world::GpuContext;
use restir_world::image_io::{Image, write_exr, write_png};
use restir_world::render::{Method, PassTimes, Renderer};
use restir_world::scene::{BuiltinOptions, builtin};
use restir_world::world_restir::{
    self, CameraPath, DebugView, FrameImages, WorldRestir, WorldRestirConfig,
};

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    Nee,
    Ris,
    WorldRestir,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Animation {
    Static,
    Orbit,
    Dolly,
}

fn on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" | "1" => Ok(true),
        "off" | "false" | "0" => Ok(false),
        _ => Err(format!("expected on/off, got {s:?}")),
    }
}

/// Render arguments. Every world-restir knob has a flag; defaults are `WorldRestirConfig`'s.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Built-in scene: cornell, many-lights, furnace, furnace-sphere.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Image size, WxH.
    #[arg(long, default_value = "256x256", value_parser = crate::parse_size)]
    size: (u32, u32),
    /// Frames (one path per pixel each), accumulated.
    #[arg(long, default_value_t = 16)]
    frames: u32,
    #[arg(long, value_enum, default_value_t = MethodArg::WorldRestir)]
    method: MethodArg,
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// many-lights: number of lights.
    #[arg(long, default_value_t = 10_000)]
    lights: u32,
    /// Camera animation over --anim-frames frames (static, orbit, dolly).
    #[arg(long, value_enum, default_value_t = Animation::Static)]
    animation: Animation,
    #[arg(long, default_value_t = 32)]
    anim_frames: u32,
    /// Orbit angle in degrees over the animation.
    #[arg(long, default_value_t = 30.0)]
    orbit_degrees: f32,
    /// Dolly: fraction of the eye-target distance travelled over the animation.
    #[arg(long, default_value_t = 0.3)]
    dolly_fraction: f32,
    /// Exposure of the PNGs.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    // World-restir knobs.
    #[arg(long, default_value_t = WorldRestirConfig::default().buckets)]
    buckets: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().slots)]
    slots: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().candidates)]
    candidates: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().max_count)]
    max_count: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().spatial_passes)]
    spatial_passes: u32,
    /// Temporal reuse on/off.
    #[arg(long, default_value = "on", value_parser = on_off)]
    temporal: bool,
    /// Cap of reused previous M, as a multiple of --candidates.
    #[arg(long, default_value_t = WorldRestirConfig::default().temporal_m_cap)]
    temporal_m_cap: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().min_cell_size)]
    min_cell_size: f32,
    #[arg(long, default_value_t = WorldRestirConfig::default().projected_size)]
    projected_size: f32,
    #[arg(long, default_value = "on", value_parser = on_off)]
    jitter: bool,
    #[arg(long, default_value = "on", value_parser = on_off)]
    adaptive_cell_size: bool,
    /// Cosine threshold between stored and receiver normals.
    #[arg(long, default_value_t = WorldRestirConfig::default().normal_threshold)]
    normal_threshold: f32,
    /// GI resolution scale as a stride: 1 = full, 2 = half resolution (one pixel per 2x2 block).
    #[arg(long, default_value_t = WorldRestirConfig::default().gi_stride)]
    gi_stride: u32,
    /// Shadow ray for the selected candidate before it enters the grid.
    #[arg(long, default_value = "off", value_parser = on_off)]
    visibility: bool,
    /// Sort each cell's list (deterministic images).
    #[arg(long, default_value = "on", value_parser = on_off)]
    sort_cells: bool,
    /// Also write the debug views (cells, M heat map, overflow mask) of the last frame.
    #[arg(long)]
    debug_views: bool,
}

impl RenderArgs {
    fn config(&self) -> WorldRestirConfig {
        WorldRestirConfig {
            buckets: self.buckets,
            slots: self.slots,
            candidates: self.candidates,
            max_count: self.max_count,
            spatial_passes: self.spatial_passes,
            temporal: self.temporal,
            temporal_m_cap: self.temporal_m_cap,
            min_cell_size: self.min_cell_size,
            projected_size: self.projected_size,
            jitter: self.jitter,
            adaptive_cell_size: self.adaptive_cell_size,
            normal_threshold: self.normal_threshold,
            gi_stride: self.gi_stride,
            visibility: self.visibility,
            sort_cells: self.sort_cells,
        }
    }

    fn path(&self) -> CameraPath {
        match self.animation {
            Animation::Static => CameraPath::Static,
            Animation::Orbit => CameraPath::Orbit {
                frames: self.anim_frames,
                degrees: self.orbit_degrees,
            },
            Animation::Dolly => CameraPath::Dolly {
                frames: self.anim_frames,
                fraction: self.dolly_fraction,
            },
        }
    }
}

fn image(w: u32, h: u32, px: Vec<[f32; 3]>) -> Result<Image> {
    Image::from_pixels(w, h, px).map_err(|e| anyhow::anyhow!("{e}"))
}

fn write(out: &Path, name: &str, img: &Image, exposure: f32) -> Result<()> {
    write_png(&out.join(format!("{name}.png")), img, exposure)
        .with_context(|| format!("writing {name}.png"))?;
    write_exr(&out.join(format!("{name}.exr")), img).with_context(|| format!("writing {name}.exr"))
}

fn print_times(times: Option<PassTimes>) {
    match times {
        Some(t) => {
            let line: Vec<String> = t
                .per_frame()
                .iter()
                .map(|(n, ms)| format!("{n}={ms:.3}ms"))
                .collect();
            println!("GPU ms per frame: {}", line.join(" "));
        }
        None => println!("(no GPU timestamps on this adapter)"),
    }
}

pub fn render(args: &RenderArgs) -> Result<()> {
    let (w, h) = args.size;
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let ctx = GpuContext::new()?;
    println!("{}", ctx.describe());
    let opts = BuiltinOptions {
        width: w,
        height: h,
        lights: args.lights,
        seed: args.seed,
        ..Default::default()
    };
    let scene = builtin(&args.scene, &opts)?;
    let base = scene.camera_or_default(w, h);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let path = args.path();
    let images: FrameImages = match args.method {
        MethodArg::WorldRestir => {
            let mut wr = WorldRestir::new(&ctx, &scene, &base, args.config(), args.seed)?;
            let times = wr.render(&ctx, args.frames, Some((&path, &base)), |_| {})?;
            print_times(times);
            let stats = wr.grid_stats(&ctx)?;
            println!(
                "grid (last frame): {} vertices found their bucket full and kept their own \
                 reservoir",
                stats.overflows
            );
            if args.debug_views {
                for (view, name) in [
                    (DebugView::Cells, "debug_cells"),
                    (DebugView::M, "debug_m"),
                    (DebugView::Overflow, "debug_overflow"),
                ] {
                    let px = wr.debug_image(&ctx, view)?;
                    write(&args.out, name, &image(w, h, px)?, 1.0)?;
                }
            }
            wr.images(&ctx)?
        }
        MethodArg::Nee | MethodArg::Ris => {
            let method = if args.method == MethodArg::Nee {
                Method::Nee
            } else {
                Method::Ris {
                    candidates: args.candidates,
                }
            };
            let mut r = Renderer::new(&ctx, &scene, &base, method, args.seed)?;
            let mut timer_total = PassTimes::default();
            for f in 0..args.frames {
                r.set_camera(&ctx.queue, &path.camera(&base, f))?;
                if let Some(t) = r.render(&ctx, 1, |_| {})? {
                    for (n, ms) in t.passes {
                        match timer_total.passes.iter_mut().find(|(m, _)| *m == n) {
                            Some((_, v)) => *v += ms,
                            None => timer_total.passes.push((n, ms)),
                        }
                    }
                    timer_total.frames += 1;
                }
            }
            print_times((timer_total.frames > 0).then_some(timer_total));
            world_restir::read_accumulated(&ctx, &r)?
        }
    };
    let combined = images.combined();
    write(&args.out, "direct", &image(w, h, images.direct)?, args.exposure)?;
    write(&args.out, "indirect", &image(w, h, images.indirect)?, args.exposure)?;
    write(&args.out, "combined", &image(w, h, combined)?, args.exposure)?;
    println!(
        "wrote direct, indirect, combined (.png, .exr) to {}",
        args.out.display()
    );
    Ok(())
}
