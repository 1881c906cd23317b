//! `restir-demo render --method world-restir`: world-space ReSTIR GI with every knob as a flag,
//! static or with a camera animation (orbit or dolly over F frames), the debug views (PNG) and
//! the per-pass GPU times.

use std::path::Path;

use anyhow::Result;
use clap::{Args, ValueEnum};
use restir_world::GpuContext;
use restir_world::image_io::{Image, write_png};
use restir_world::reference::Rendered;
use restir_world::render::PassTimes;
use restir_world::scene::{Camera, Scene};
use restir_world::world_restir::{CameraPath, Combine, DebugView, WorldRestir, WorldRestirConfig};

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

/// World-restir arguments (used with `--method world-restir`). Defaults are
/// `WorldRestirConfig`'s.
#[derive(Args, Debug)]
pub struct WorldArgs {
    /// world-restir: camera animation over --anim-frames frames (static, orbit, dolly).
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
    // World-restir knobs.
    /// Hash-grid buckets (default: sized to the frame; the paper's is 100000).
    #[arg(long)]
    buckets: Option<u32>,
    #[arg(long, default_value_t = WorldRestirConfig::default().slots)]
    slots: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().max_count)]
    max_count: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().spatial_passes)]
    spatial_passes: u32,
    /// Temporal reuse on/off.
    #[arg(long, default_value = "on", value_parser = on_off, action = clap::ArgAction::Set)]
    temporal: bool,
    /// Cap of reused previous M, as a multiple of --candidates.
    #[arg(long, default_value_t = WorldRestirConfig::default().temporal_m_cap)]
    temporal_m_cap: u32,
    #[arg(long, default_value_t = WorldRestirConfig::default().min_cell_size)]
    min_cell_size: f32,
    #[arg(long, default_value_t = WorldRestirConfig::default().projected_size)]
    projected_size: f32,
    #[arg(long, default_value = "on", value_parser = on_off, action = clap::ArgAction::Set)]
    jitter: bool,
    #[arg(long, default_value = "on", value_parser = on_off, action = clap::ArgAction::Set)]
    adaptive_cell_size: bool,
    /// Cosine threshold between stored and receiver normals.
    #[arg(long, default_value_t = WorldRestirConfig::default().normal_threshold)]
    normal_threshold: f32,
    /// GI resolution scale as a stride: 1 = full, 2 = half resolution (one pixel per 2x2 block).
    #[arg(long, default_value_t = WorldRestirConfig::default().gi_stride)]
    gi_stride: u32,
    /// Combination weights of reuse: pairwise (MIS, unbiased), one-over-z (unbiased) or biased
    /// (the paper's 1/M).
    #[arg(long, default_value = "pairwise")]
    combine: Combine,
    /// Sort each cell's list (deterministic images).
    #[arg(long, default_value = "on", value_parser = on_off, action = clap::ArgAction::Set)]
    sort_cells: bool,
    /// Also write the debug views (cells, M heat map, overflow mask) of the last frame.
    #[arg(long)]
    debug_views: bool,
}

impl WorldArgs {
    fn config(&self, candidates: u32) -> WorldRestirConfig {
        WorldRestirConfig {
            buckets: self.buckets,
            slots: self.slots,
            candidates,
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
            combine: self.combine,
            sort_cells: self.sort_cells,
        }
    }

    /// Whether a camera animation was asked for.
    pub fn animated(&self) -> bool {
        self.animation != Animation::Static
    }

    /// Checks the animation and the knobs before any work.
    pub fn validate(&self, candidates: u32) -> Result<()> {
        if self.animated() && self.anim_frames == 0 {
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
        self.config(candidates)
            .validate()
            .map_err(anyhow::Error::from)
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

fn print_times(times: Option<PassTimes>) {
    match times {
        Some(t) => {
            let line: Vec<String> = t
                .per_frame()
                .iter()
                .map(|(n, ms)| format!("{n}={ms:.3}"))
                .collect();
            println!(
                "world-restir: {} frames, GPU {:.3} ms/frame ({})",
                t.frames,
                t.total_ms() / f64::from(t.frames.max(1)),
                line.join(" ")
            );
        }
        None => println!("(no GPU timestamps on this adapter)"),
    }
}

/// Renders `frames` frames of world-space ReSTIR (candidates = `candidates`) and returns the
/// accumulated images; writes the debug views into `out` when asked.
#[allow(clippy::too_many_arguments)]
pub fn render_world_restir(
    args: &WorldArgs,
    scene: &Scene,
    camera: &Camera,
    frames: u32,
    candidates: u32,
    seed: u32,
    out: &Path,
    tag: &str,
) -> Result<Rendered> {
    let ctx = GpuContext::new()?;
    eprintln!("{}", ctx.describe());
    let (w, h) = (camera.width, camera.height);
    let path = args.path();
    let mut wr = WorldRestir::new(&ctx, scene, camera, args.config(candidates), seed)?;
    let times = wr.render(&ctx, frames, Some((&path, camera)), |_| {})?;
    print_times(times);
    let stats = wr.grid_stats(&ctx)?;
    println!(
        "grid (last frame): {} vertices found their bucket full and kept their own reservoir",
        stats.overflows
    );
    if args.debug_views {
        for (view, name) in [
            (DebugView::Cells, "debug-cells"),
            (DebugView::M, "debug-m"),
            (DebugView::Overflow, "debug-overflow"),
        ] {
            let px = wr.debug_image(&ctx, view)?;
            let file = out.join(format!("{tag}-world-restir-{name}.png"));
            write_png(&file, &image(w, h, px)?, 1.0)?;
            println!("wrote {}", file.display());
        }
    }
    let img = wr.images(&ctx)?;
    let combined = img.combined();
    Ok(Rendered {
        direct: image(w, h, img.direct)?,
        indirect: image(w, h, img.indirect)?,
        combined: image(w, h, combined)?,
    })
}
