//! `restir-demo view`: a window onto a method of the registry, live.
//!
//! A thin layer over the renderer API the CLI uses: the method is built from its spec
//! (`MethodSettings::build`), each frame is one call of the one frame loop (`run_frames`, timed,
//! the spans `compare` reports), the shown image is read back as `render` reads it
//! (`FrameMethod::read` / `debug_image`), tone-mapped by `image_io::tone_map` and drawn by egui
//! into a surface of the device that computes. Screenshots are written by `image_io`.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context as _, Result};
use glam::{Quat, Vec3};
use restir_world::GpuContext;
use restir_world::denoise::DenoiseConfig;
use restir_world::gpu::PassTimes;
use restir_world::image_io::{self, Image};
use restir_world::knobs::{Knob, KnobKind, Knobs};
use restir_world::methods::{
    self, FrameLoop, FrameMethod, MethodError, MethodSettings, Readback, run_frames,
};
use restir_world::render::{DebugView, Paths, RenderOptions};
use restir_world::scene::{Camera, CameraPath, Scene};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::{Window, WindowId};

use crate::camera::Motion;
use crate::scenes;

/// `restir-demo view` flags.
#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// A built-in scene (cornell, cornell-glossy, many-lights, colonnade, glossy, furnace,
    /// furnace-sphere) or a .gltf/.glb/.obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[command(flatten)]
    scene_opts: scenes::SceneArgs,
    /// A method of the registry as `name` or `name:variant` (as `render --method`); the window
    /// switches methods and edits world-restir's knobs live.
    #[arg(long, default_value = "world-restir")]
    method: String,
    /// Render size at scale 1, WxH (default: the scene camera's, or 256x256).
    #[arg(long, value_parser = crate::parse_size)]
    size: Option<(u32, u32)>,
    /// Render-resolution scale (the window's slider): the frame is --size times this.
    #[arg(long, default_value_t = 1.0)]
    scale: f32,
    #[arg(long, default_value_t = 0)]
    seed: u32,
    #[command(flatten)]
    paths: crate::paths::PathArgs,
    /// Exposure multiplier of the shown image and of screenshot PNGs (EXRs stay linear).
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// The image shown (default: the last frame denoised; `combined` is the accumulation).
    #[arg(long, value_enum, default_value_t = Shown::Denoised)]
    show: Shown,
    /// The denoiser after the method (SVGF; on by default): its knobs as key=value joined by
    /// + (e.g. iterations=3+alpha=0.1), or `off`. The window switches it and edits its knobs.
    #[arg(long, default_value = "", value_name = "KNOBS|off")]
    denoise: String,
    /// Exit after rendering N frames (for tests and measurements).
    #[arg(long)]
    exit_after_frames: Option<u32>,
    /// Write the shown image at exit: FILE.png (tone-mapped, as shown) and FILE.exr (linear).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Scripted camera motion (static, orbit, dolly), compare's pace: 1 degree or 1% of the
    /// eye-target distance per frame, for the first --camera-path-frames frames; then still.
    #[arg(long, value_enum, default_value_t = Motion::Static)]
    camera_path: Motion,
    #[arg(long, default_value_t = 10)]
    camera_path_frames: u32,
    /// Directory of the screenshots taken in the window (P key or the button).
    #[arg(long, default_value = "out/view")]
    shots: PathBuf,
}

/// What the window shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Shown {
    /// The last frame after the denoiser (the accumulated combined image with it off).
    Denoised,
    Combined,
    Direct,
    Indirect,
    /// Debug view: a colour per hash-grid cell (world-restir).
    Cells,
    /// Debug view: heat map of the reservoirs' M (world-restir, restir-gi).
    M,
    /// Debug view: vertices that found their bucket full (world-restir).
    Overflow,
    /// Debug view: the share of each pixel's reconnections rejected (restir-gi).
    Rejected,
    /// Debug view: the radiance cache's cell at each pixel, by radiance (+cache methods).
    CacheRadiance,
    /// Debug view: the radiance cache's cells by age (+cache methods).
    CacheAge,
    /// Debug view: the radiance cache's cells by sample count (+cache methods).
    CacheSamples,
    /// Debug view: the denoiser's history length per pixel.
    DenoiseHistory,
    /// Debug view: the denoiser's luminance variance per pixel.
    DenoiseVariance,
    /// Debug view: where world-restir-gi's temporal neighbour came from.
    History,
    /// Debug view: how old world-restir-gi's temporal neighbour's sample is.
    HistoryAge,
    /// Debug view: why path reuse refused each pixel's reconnections.
    Refused,
}

impl Shown {
    const ALL: [(Shown, &'static str); 16] = [
        (Shown::Denoised, "denoised (last frame)"),
        (Shown::Combined, "combined (accumulated)"),
        (Shown::Direct, "direct"),
        (Shown::Indirect, "indirect"),
        (Shown::Cells, "debug: cells"),
        (Shown::M, "debug: M heat map"),
        (Shown::Overflow, "debug: overflow"),
        (Shown::Rejected, "debug: rejected reconnections"),
        (Shown::CacheRadiance, "debug: cache radiance"),
        (Shown::CacheAge, "debug: cache age"),
        (Shown::CacheSamples, "debug: cache samples"),
        (Shown::DenoiseHistory, "debug: denoiser history length"),
        (Shown::DenoiseVariance, "debug: denoiser variance"),
        (Shown::History, "debug: temporal history's origin"),
        (Shown::HistoryAge, "debug: temporal history's age"),
        (Shown::Refused, "debug: why reconnections were refused"),
    ];

    fn debug(self) -> Option<DebugView> {
        match self {
            Shown::Cells => Some(DebugView::Cells),
            Shown::M => Some(DebugView::M),
            Shown::Overflow => Some(DebugView::Overflow),
            Shown::Rejected => Some(DebugView::Rejected),
            Shown::CacheRadiance => Some(DebugView::CacheRadiance),
            Shown::DenoiseHistory => Some(DebugView::DenoiseHistory),
            Shown::DenoiseVariance => Some(DebugView::DenoiseVariance),
            Shown::CacheAge => Some(DebugView::CacheAge),
            Shown::CacheSamples => Some(DebugView::CacheSamples),
            Shown::History => Some(DebugView::History),
            Shown::HistoryAge => Some(DebugView::HistoryAge),
            Shown::Refused => Some(DebugView::Refused),
            _ => None,
        }
    }

    /// Whether a method of `settings` draws it (every image; the debug views its stages have).
    fn available(self, settings: &MethodSettings) -> bool {
        self.debug()
            .is_none_or(|v| settings.debug_views().contains(&v))
    }

    fn label(self) -> &'static str {
        Shown::ALL
            .iter()
            .find(|(s, _)| *s == self)
            .map_or("", |s| s.1)
    }
}

/// Width of the overlay's panel, pixels.
const PANEL_WIDTH: f32 = 320.0;

/// Render-resolution scales offered in the window.
const SCALES: [f32; 6] = [0.25, 0.5, 0.75, 1.0, 1.5, 2.0];

/// Everything checked before a window opens.
struct Setup {
    scene: Scene,
    scene_name: String,
    camera: Camera,
    base_size: (u32, u32),
    settings: MethodSettings,
    spec: String,
    /// The depth of the paths at start (`--bounces`, `--roulette-from`, `--mis`).
    paths: Paths,
    args: ViewArgs,
    /// (PNG, EXR) of --screenshot.
    screenshot: Option<(PathBuf, PathBuf)>,
    /// World units per second of the fly camera at speed 1.
    speed: f32,
}

/// `restir-demo view`. A failed run removes the directories --screenshot created.
pub fn view(args: ViewArgs) -> Result<()> {
    let mut created = Vec::new();
    let result = view_with(args, &mut created);
    if result.is_err() {
        crate::remove_created(&created);
    }
    result
}

fn view_with(args: ViewArgs, created: &mut Vec<PathBuf>) -> Result<()> {
    let setup = check(args, created)?;
    check_display()?;
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow::anyhow!(
            "cannot open the display ({}): {e}. {}",
            display_name(),
            SUGGEST_RENDER
        )
    })?;
    let mut app = App {
        setup: Some(setup),
        viewer: None,
        result: Ok(()),
        display: Box::new(event_loop.owned_display_handle()),
    };
    event_loop
        .run_app(&mut app)
        .context("the window's event loop failed")?;
    app.result?;
    match app.viewer {
        Some(v) => v.finish(),
        None => Ok(()),
    }
}

const SUGGEST_RENDER: &str = "Run `view` on a desktop or under a virtual X server \
     (xvfb-run -a -s \"-screen 0 1280x1024x24\" restir-demo view ...), or render offline \
     without a window: restir-demo render --scene ... --method ...";

fn display_name() -> String {
    let get = |v: &str| std::env::var(v).ok().filter(|s| !s.is_empty());
    match (get("WAYLAND_DISPLAY"), get("DISPLAY")) {
        (Some(w), _) => format!("WAYLAND_DISPLAY={w}"),
        (None, Some(d)) => format!("DISPLAY={d}"),
        (None, None) => "no DISPLAY or WAYLAND_DISPLAY".into(),
    }
}

/// On Linux and the BSDs a window needs an X11 or Wayland display: say so before winit does.
fn check_display() -> Result<()> {
    if cfg!(all(
        unix,
        not(target_os = "macos"),
        not(target_os = "android")
    )) {
        let set = |v: &str| std::env::var_os(v).is_some_and(|s| !s.is_empty());
        if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
            anyhow::bail!(
                "no display: `view` opens a window, but neither DISPLAY nor WAYLAND_DISPLAY is \
                 set (a headless machine or an SSH session without X forwarding). \
                 {SUGGEST_RENDER}"
            );
        }
    }
    Ok(())
}

fn check(args: ViewArgs, created: &mut Vec<PathBuf>) -> Result<Setup> {
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        anyhow::bail!("--exposure must be a positive number");
    }
    if !SCALES.contains(&args.scale) {
        anyhow::bail!("--scale must be one of {SCALES:?}, got {}", args.scale);
    }
    if args.exit_after_frames == Some(0) {
        anyhow::bail!("--exit-after-frames must be at least 1");
    }
    if args.camera_path != Motion::Static && args.camera_path_frames < 2 {
        anyhow::bail!("--camera-path-frames must be at least 2 (frame 0 is the start)");
    }
    let mut settings = methods::parse_spec(&args.method)?;
    settings.denoise = match args.denoise.as_str() {
        "off" => None,
        k => Some(DenoiseConfig::parse(k).map_err(|e| anyhow::anyhow!("--denoise: {e}"))?),
    };
    if !args.show.available(&settings) {
        let name =
            |s: Shown| clap::ValueEnum::to_possible_value(&s).map(|v| v.get_name().to_owned());
        let offered: Vec<String> = Shown::ALL
            .iter()
            .filter(|(s, _)| s.available(&settings))
            .filter_map(|(s, _)| name(*s))
            .collect();
        anyhow::bail!(
            "--show {}: {} has no such view; it shows: {}",
            name(args.show).unwrap_or_default(),
            args.method,
            offered.join(", ")
        );
    }
    let paths = args.paths.paths()?;
    let screenshot = args
        .screenshot
        .as_deref()
        .map(|f| screenshot_paths(f, created))
        .transpose()?;
    let scene = scenes::load(&args.scene, &args.scene_opts, args.size)?;
    for w in settings.scene_warnings(&scene) {
        eprintln!("warning: --method {}: {w}", args.method);
    }
    let base_size = args
        .size
        .or(scene.camera.map(|c| (c.width, c.height)))
        .unwrap_or((256, 256));
    let camera = scene.camera_or_default(base_size.0, base_size.1);
    camera.validate()?;
    let camera = Camera {
        width: scaled(base_size.0, args.scale),
        height: scaled(base_size.1, args.scale),
        ..camera
    };
    settings.check_camera(&camera).with_context(|| {
        format!(
            "--size {}x{} at --scale {} (with --method {})",
            base_size.0, base_size.1, args.scale, args.method
        )
    })?;
    let speed = scene
        .bounds()
        .map_or(1.0, |(lo, hi)| 0.25 * (hi - lo).length())
        .max(1e-3);
    Ok(Setup {
        scene,
        scene_name: args.scene.clone(),
        camera,
        base_size,
        settings,
        paths,
        spec: args.method.clone(),
        args,
        screenshot,
        speed,
    })
}

fn scaled(n: u32, scale: f32) -> u32 {
    ((n as f32 * scale).round() as u32).max(1)
}

/// FILE.png and FILE.exr of `--screenshot FILE[.png|.exr]`; the directory must be creatable.
fn screenshot_paths(file: &Path, created: &mut Vec<PathBuf>) -> Result<(PathBuf, PathBuf)> {
    let stem = match file.extension().and_then(|e| e.to_str()) {
        Some("png" | "exr") => file.with_extension(""),
        _ => file.to_path_buf(),
    };
    if stem.file_name().is_none() {
        anyhow::bail!("--screenshot {}: not a file name", file.display());
    }
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        *created = crate::prepare_out_dir(dir)
            .with_context(|| format!("--screenshot {}", file.display()))?;
    }
    let with = |ext: &str| {
        let mut p = stem.clone().into_os_string();
        p.push(".");
        p.push(ext);
        PathBuf::from(p)
    };
    Ok((with("png"), with("exr")))
}

struct App {
    setup: Option<Setup>,
    viewer: Option<Viewer>,
    result: Result<()>,
    display: Box<winit::event_loop::OwnedDisplayHandle>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let Some(setup) = self.setup.take() else {
            return;
        };
        match Viewer::new(event_loop, setup, &self.display) {
            Ok(v) => self.viewer = Some(v),
            Err(e) => {
                self.result = Err(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(v) = self.viewer.as_mut() else {
            return;
        };
        let response = v.egui_state.on_window_event(&v.window, &event);
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => event_loop.exit(),
            WindowEvent::Resized(size) => v.resize(size.width, size.height),
            WindowEvent::RedrawRequested => match v.redraw() {
                Ok(true) => {}
                Ok(false) => event_loop.exit(),
                Err(e) => {
                    self.result = Err(e);
                    event_loop.exit();
                }
            },
            _ if response.repaint => v.window.request_redraw(),
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(v) = self.viewer.as_ref().filter(|v| !v.controls.paused) {
            v.window.request_redraw();
        }
    }
}

/// What the user set in the window.
#[derive(Debug, Clone)]
struct Controls {
    exposure: f32,
    scale: f32,
    shown: Shown,
    accumulate: bool,
    paused: bool,
    /// Multiplier of the fly speed.
    speed: f32,
    /// The method spec being typed.
    spec_text: String,
    /// Knob values being typed (KNOBS order).
    knob_text: Vec<String>,
    /// The depth of the paths (bounces, MIS).
    paths: Paths,
    /// The denoiser after the method (`None`: off); every build takes it.
    denoise: Option<DenoiseConfig>,
    /// The denoiser's knob values being typed (its KNOBS order).
    denoise_text: Vec<String>,
}

/// What the last overlay pass asked for.
#[derive(Debug, Default)]
struct Actions {
    /// Camera moves: translation in (right, up, forward) world units and look deltas (yaw,
    /// pitch) in radians.
    translate: Vec3,
    look: (f32, f32),
    settings: Option<MethodSettings>,
    rebuild: bool,
    restart: bool,
    screenshot: bool,
}

/// Timings, counts and the last image.
#[derive(Debug, Default)]
struct Stats {
    /// Frames rendered since the window opened.
    frames: u32,
    /// GPU spans since the method was (re)built.
    since_build: PassTimes,
    /// The last frames' spans and wall-clock milliseconds, for the overlay.
    recent: VecDeque<FrameTimes>,
    /// Wall-clock frame milliseconds since the build (its first two frames left out).
    wall_sum: f64,
    /// Milliseconds from recording a frame until the GPU finished it (and its timestamps were
    /// read), over the same frames.
    done_sum: f64,
    wall_frames: u32,
    /// Of those frames' wall clock, milliseconds spent in: the frame (recording, submission,
    /// waiting for the GPU, timestamps and grid readback), the image's readback and tone
    /// mapping, the overlay and presentation.
    parts: [f64; 3],
    frames_since_build: u32,
    last_frame_end: Option<Instant>,
    overflows: Option<u32>,
    /// The radiance cache's use after the last frame (+cache methods).
    cache: Option<restir_world::cache::CacheStats>,
    /// The shown image, linear, and the exposure it is shown with.
    image: Option<(Image, f32)>,
    message: Option<String>,
}

const RECENT: usize = 30;

/// One frame's times.
#[derive(Debug, Default)]
struct FrameTimes {
    /// The timestamp spans.
    spans: PassTimes,
    /// Wall-clock milliseconds since the previous frame.
    wall: f64,
    /// Milliseconds from recording the frame until the GPU finished it.
    done: f64,
}

/// Whether timestamp spans summing to `spans` ms cannot be right for a frame that took `done`
/// ms from recording until its timestamps were read: they cover less than half of it, or more
/// than all of it. Mesa 22.3.6's llvmpipe does so in a process that also draws (this window):
/// world-restir at 256x256 gave spans of 24 ms/frame where frames took 400 ms (and 402 ms of
/// spans with the drawing left out). Mesa 25.0.7's agree with the wall clock.
fn spans_disagree(spans: f64, done: f64) -> bool {
    done > 2.0 && (spans < 0.5 * done || spans > 1.1 * done + 0.5)
}

const SPANS_DISAGREE: &str = "the timestamp spans disagree with the time the frame took \
     (older llvmpipe's timestamps go wrong in a process that also draws, as this window does): \
     trust the wall clock here, and `render` or `compare` for per-stage times";

struct Viewer {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    surface_config: wgpu::SurfaceConfiguration,
    ctx: GpuContext,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    texture: Option<egui::TextureHandle>,
    setup: Setup,
    method: Box<dyn FrameMethod>,
    settings: MethodSettings,
    /// The depth of the paths the method was built with.
    paths: Paths,
    /// The render-resolution scale the method was built at.
    scale: f32,
    camera: Camera,
    start_camera: Camera,
    controls: Controls,
    actions: Actions,
    stats: Stats,
    shots_taken: u32,
    last_ui: Instant,
    restart_pending: bool,
}

impl Viewer {
    fn new(
        event_loop: &ActiveEventLoop,
        setup: Setup,
        display: &winit::event_loop::OwnedDisplayHandle,
    ) -> Result<Self> {
        let window = open_window(event_loop, &setup)?;
        let (surface, ctx) = surface_and_context(&window, display)?;
        let surface_config = surface_config(&surface, &ctx, window.inner_size())?;
        surface.configure(&ctx.device, &surface_config);
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(ctx.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer =
            egui_wgpu::Renderer::new(&ctx.device, surface_config.format, Default::default());
        let options = RenderOptions {
            seed: setup.args.seed,
            paths: setup.paths,
            ..Default::default()
        };
        let method =
            crate::render_cmd::build(&setup.settings, &ctx, &setup.scene, &setup.camera, &options)?;
        let controls = Controls {
            exposure: setup.args.exposure,
            scale: setup.args.scale,
            shown: setup.args.show,
            accumulate: true,
            paused: false,
            speed: 1.0,
            spec_text: setup.spec.clone(),
            knob_text: knob_texts(&setup.settings),
            paths: setup.paths,
            denoise: setup.settings.denoise,
            denoise_text: denoise_texts(setup.settings.denoise),
        };
        Ok(Self {
            window,
            surface,
            surface_config,
            egui_ctx,
            egui_state,
            egui_renderer,
            texture: None,
            settings: setup.settings,
            paths: setup.paths,
            scale: setup.args.scale,
            camera: setup.camera,
            start_camera: setup.camera,
            method,
            ctx,
            setup,
            controls,
            actions: Actions::default(),
            stats: Stats::default(),
            shots_taken: 0,
            last_ui: Instant::now(),
            restart_pending: false,
        })
    }

    fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            self.surface_config.width = width;
            self.surface_config.height = height;
            self.surface
                .configure(&self.ctx.device, &self.surface_config);
        }
    }

    /// One frame: apply the overlay's actions, render and read back, draw. `Ok(false)`: done.
    fn redraw(&mut self) -> Result<bool> {
        let t0 = Instant::now();
        // A change while paused restarts the accumulation at the next rendered frame.
        let restart = self.apply_actions()?;
        self.restart_pending |= restart;
        let rendered = !self.controls.paused;
        if rendered {
            let restart = std::mem::take(&mut self.restart_pending);
            self.render_frame(restart)?;
        }
        let t1 = Instant::now();
        self.show_image()?;
        let t2 = Instant::now();
        self.draw_ui()?;
        let t3 = Instant::now();
        if rendered && self.stats.frames_since_build > 2 {
            let ms = |a: Instant, b: Instant| b.duration_since(a).as_secs_f64() * 1e3;
            let parts = [ms(t0, t1), ms(t1, t2), ms(t2, t3)];
            for (sum, part) in self.stats.parts.iter_mut().zip(parts) {
                *sum += part;
            }
        }
        if self.actions.screenshot {
            self.actions.screenshot = false;
            self.take_shot()?;
        }
        Ok(self
            .setup
            .args
            .exit_after_frames
            .is_none_or(|n| self.stats.frames < n))
    }

    /// Applies the camera script and the overlay's actions; returns whether accumulation
    /// restarts.
    fn apply_actions(&mut self) -> Result<bool> {
        let a = std::mem::take(&mut self.actions);
        let mut camera = self.camera;
        let args = &self.setup.args;
        let frame = self.stats.frames;
        if args.camera_path != Motion::Static && frame < args.camera_path_frames {
            let path: CameraPath = args.camera_path.per_frame(args.camera_path_frames);
            let c = path.camera(&self.start_camera, frame);
            camera.eye = c.eye;
            camera.target = c.target;
        }
        fly(&mut camera, a.translate, a.look);
        if let Some(s) = a.settings {
            self.rebuild(s, camera)?;
        } else if a.rebuild || (camera.width, camera.height) != self.size_for_scale() {
            self.rebuild(self.settings, camera)?;
        } else if camera != self.camera {
            if camera.validate().is_ok() {
                self.method.set_camera(&camera)?;
                self.camera = camera;
                return Ok(true);
            }
        } else if a.restart {
            return Ok(true);
        }
        Ok(false)
    }

    fn size_for_scale(&self) -> (u32, u32) {
        let (w, h) = self.setup.base_size;
        (
            scaled(w, self.controls.scale),
            scaled(h, self.controls.scale),
        )
    }

    /// Builds `settings` at the current scale; on failure keeps the method it had and says
    /// why in the overlay.
    fn rebuild(&mut self, settings: MethodSettings, camera: Camera) -> Result<()> {
        let settings = MethodSettings {
            denoise: self.controls.denoise,
            ..settings
        };
        let (width, height) = self.size_for_scale();
        let camera = Camera {
            width,
            height,
            ..camera
        };
        let options = RenderOptions {
            seed: self.setup.args.seed,
            paths: self.controls.paths,
            ..Default::default()
        };
        match settings.build_with(&self.ctx, &self.setup.scene, &camera, &options) {
            Ok(m) => {
                self.method = m;
                self.settings = settings;
                self.paths = self.controls.paths;
                self.scale = self.controls.scale;
                self.camera = camera;
                self.controls.knob_text = knob_texts(&settings);
                self.controls.denoise_text = denoise_texts(settings.denoise);
                self.controls.spec_text = settings.spec();
                let frames = self.stats.frames;
                self.stats = Stats {
                    frames,
                    message: None,
                    ..Stats::default()
                };
            }
            Err(e) => {
                self.controls.knob_text = knob_texts(&self.settings);
                self.controls.denoise = self.settings.denoise;
                self.controls.denoise_text = denoise_texts(self.settings.denoise);
                self.controls.paths = self.paths;
                self.controls.scale = self.scale;
                self.stats.message = Some(format!("not applied: {e}"));
            }
        }
        Ok(())
    }

    /// One frame of the method through the one frame loop, timed.
    fn render_frame(&mut self, restart: bool) -> Result<()> {
        let l = FrameLoop {
            records: 1,
            samples: 1,
            path: CameraPath::Static,
            restart: restart || !self.controls.accumulate,
            timed: true,
            batch: 1,
        };
        let start = Instant::now();
        let times = run_frames(&self.ctx, self.method.as_mut(), &l, |_, _| {
            Ok::<(), MethodError>(())
        })?;
        let done = start.elapsed().as_secs_f64() * 1e3;
        self.stats.overflows = self.method.grid_overflows(&self.ctx)?;
        self.stats.cache = self.method.cache_stats(&self.ctx)?;
        let now = Instant::now();
        let s = &mut self.stats;
        let wall = s
            .last_frame_end
            .map_or(0.0, |t| now.duration_since(t).as_secs_f64() * 1e3);
        s.last_frame_end = Some(now);
        s.frames += 1;
        s.frames_since_build += 1;
        if s.frames_since_build > 2 {
            s.wall_sum += wall;
            s.done_sum += done;
            s.wall_frames += 1;
        }
        let times = times.unwrap_or_default();
        s.since_build.merge(&times);
        s.recent.push_back(FrameTimes {
            spans: times,
            wall,
            done,
        });
        if s.recent.len() > RECENT {
            s.recent.pop_front();
        }
        Ok(())
    }

    /// Reads the shown image back and hands it to egui.
    fn show_image(&mut self) -> Result<()> {
        let (w, h) = (self.camera.width, self.camera.height);
        let debug = match self.controls.shown.debug() {
            Some(view) => self.method.debug_image(&self.ctx, view)?,
            None => None,
        };
        let (pixels, exposure) = match debug {
            Some(px) => (px, 1.0),
            None => {
                let denoised = match self.controls.shown {
                    Shown::Denoised => self.method.read_denoised(&self.ctx)?,
                    _ => None,
                };
                let images = match denoised {
                    Some(d) => d,
                    None => self.method.read(&self.ctx, Readback::Accumulated)?,
                };
                let px = match self.controls.shown {
                    Shown::Direct => images.direct,
                    Shown::Indirect => images.indirect,
                    _ => images.combined(),
                };
                (px, self.controls.exposure)
            }
        };
        let image = Image::from_pixels(w, h, pixels).map_err(|e| anyhow::anyhow!("{e}"))?;
        let rgb: Vec<u8> = image
            .pixels
            .iter()
            .flat_map(|&p| image_io::tone_map(p, exposure))
            .collect();
        let color = egui::ColorImage::from_rgb([w as usize, h as usize], &rgb);
        let options = egui::TextureOptions::NEAREST;
        match self.texture.as_mut() {
            Some(t) => t.set(color, options),
            None => {
                self.texture = Some(self.egui_ctx.load_texture("frame", color, options));
            }
        }
        self.stats.image = Some((image, exposure));
        Ok(())
    }

    fn draw_ui(&mut self) -> Result<()> {
        let raw = self.egui_state.take_egui_input(&self.window);
        let now = Instant::now();
        let dt = now.duration_since(self.last_ui).as_secs_f32().min(0.1);
        self.last_ui = now;
        let info = Info {
            adapter: format!("{} ({:?})", self.ctx.info.name, self.ctx.info.backend),
            timestamps: self.ctx.features.timestamps,
            size: (self.camera.width, self.camera.height),
            accumulated: self.method.renderer().accumulated(),
            settings: self.settings,
            speed: self.setup.speed,
            dt,
            render_cmd: self.render_command(),
        };
        let texture = self.texture.as_ref().map(|t| t.id());
        let (controls, stats, actions) = (&mut self.controls, &self.stats, &mut self.actions);
        let out = self.egui_ctx.clone().run_ui(raw, |ui| {
            overlay(ui, &info, controls, stats, actions, texture);
        });
        self.egui_state
            .handle_platform_output(&self.window, out.platform_output);
        let prims = self.egui_ctx.tessellate(out.shapes, out.pixels_per_point);
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let mut textures = out.textures_delta;
        for (id, deltas) in textures.set.drain() {
            for delta in &deltas {
                self.egui_renderer.update_texture(device, queue, id, delta);
            }
        }
        let free: Vec<egui::TextureId> = textures.free.drain().collect();
        let painted = self.paint(&prims, out.pixels_per_point);
        for id in &free {
            self.egui_renderer.free_texture(id);
        }
        painted
    }

    /// Draws the overlay's primitives into the surface and presents.
    fn paint(&mut self, prims: &[egui::ClippedPrimitive], pixels_per_point: f32) -> Result<()> {
        let (device, queue) = (&self.ctx.device, &self.ctx.queue);
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(device, &self.surface_config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(());
            }
            other => anyhow::bail!(
                "the window's surface failed ({other:?}): the adapter cannot present to it. \
                 {SUGGEST_RENDER}"
            ),
        };
        let target = frame.texture.create_view(&Default::default());
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.surface_config.width, self.surface_config.height],
            pixels_per_point,
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        let mut commands =
            self.egui_renderer
                .update_buffers(device, queue, &mut encoder, prims, &screen);
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("view overlay"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &target,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    ..Default::default()
                })
                .forget_lifetime();
            self.egui_renderer.render(&mut pass, prims, &screen);
        }
        commands.push(encoder.finish());
        queue.submit(commands);
        self.window.pre_present_notify();
        queue.present(frame);
        Ok(())
    }

    /// The `render` command that renders what the window shows (at its frame count).
    fn render_command(&self) -> String {
        let c = &self.camera;
        let v = |v: Vec3| format!("{},{},{}", v.x, v.y, v.z);
        format!(
            "restir-demo render --scene {} --method {} --size {}x{} --seed {} --bounces {} \
             --roulette-from {} --mis {} --frames {} --eye {} --target {} --up {} --fov {}{}",
            self.setup.scene_name,
            self.settings.spec(),
            c.width,
            c.height,
            self.setup.args.seed,
            self.paths.bounces,
            self.paths.roulette_from,
            if self.paths.mis { "on" } else { "off" },
            self.method.renderer().accumulated().max(1),
            v(c.eye),
            v(c.target),
            v(c.up),
            c.vfov_deg,
            match self.settings.denoise {
                Some(d) => format!(" --denoise {}", d.knobs_spec())
                    .trim_end()
                    .to_owned(),
                None => String::new(),
            }
        )
    }

    /// Writes the shown image as PNG (as shown) + EXR (linear) into --shots.
    fn take_shot(&mut self) -> Result<()> {
        let dir = self.setup.args.shots.clone();
        if let Err(e) = std::fs::create_dir_all(&dir) {
            self.stats.message = Some(format!("cannot create {}: {e}", dir.display()));
            return Ok(());
        }
        self.shots_taken += 1;
        let stem = dir.join(format!(
            "view-{}-{}-{:03}",
            std::process::id(),
            self.stats.frames,
            self.shots_taken
        ));
        let paths = (stem.with_extension("png"), stem.with_extension("exr"));
        self.stats.message = Some(match self.write_shot(&paths) {
            Ok(()) => format!("wrote {}", paths.0.display()),
            Err(e) => format!("screenshot failed: {e:#}"),
        });
        Ok(())
    }

    fn write_shot(&self, (png, exr): &(PathBuf, PathBuf)) -> Result<()> {
        let (image, exposure) = self.stats.image.as_ref().context("no image rendered yet")?;
        image_io::write_png(png, image, *exposure)?;
        image_io::write_exr(exr, image)?;
        Ok(())
    }

    /// At exit: --screenshot and the summary.
    fn finish(self) -> Result<()> {
        let s = &self.stats;
        let spec = self.settings.spec();
        println!(
            "view: {} frames of {spec} at {}x{} on {:?}, accumulated {}",
            s.frames,
            self.camera.width,
            self.camera.height,
            self.ctx.info.name,
            self.method.renderer().accumulated()
        );
        if s.since_build.frames > 0 && !s.since_build.passes.is_empty() {
            println!(
                "view: GPU {:.3} ms/frame ({}) over {} frames",
                s.since_build.ms_per_frame(),
                s.since_build.line(),
                s.since_build.frames
            );
        }
        if s.wall_frames > 0 {
            let n = f64::from(s.wall_frames);
            println!(
                "view: frame {:.2} ms (wall clock, mean of {} frames: frame and wait {:.2}, \
                 readback and tone map {:.2}, overlay and present {:.2}); recorded until done \
                 {:.2} ms",
                s.wall_sum / n,
                s.wall_frames,
                s.parts[0] / n,
                s.parts[1] / n,
                s.parts[2] / n,
                s.done_sum / n
            );
            let spans = s.since_build.ms_per_frame();
            if !s.since_build.passes.is_empty() && spans_disagree(spans, s.done_sum / n) {
                println!("view: warning: {SPANS_DISAGREE}");
            }
        }
        let c = &self.camera;
        println!(
            "view: camera eye {},{},{} target {},{},{}",
            c.eye.x, c.eye.y, c.eye.z, c.target.x, c.target.y, c.target.z
        );
        if let Some(o) = s.overflows {
            println!("view: grid overflows (last frame) {o}");
        }
        if let Some(c) = &s.cache {
            println!("view: {}", cache_line(c));
        }
        if let Some(paths) = &self.setup.screenshot {
            self.write_shot(paths)?;
            println!(
                "view: wrote {} and {}",
                paths.0.display(),
                paths.1.display()
            );
        }
        Ok(())
    }
}

/// The window: the image at an integer zoom of about 512 pixels, the overlay's panel beside
/// it.
fn open_window(event_loop: &ActiveEventLoop, setup: &Setup) -> Result<Arc<Window>> {
    let (w, h) = (setup.camera.width, setup.camera.height);
    let zoom = (512 / w.max(h)).clamp(1, 8);
    let attrs = Window::default_attributes()
        .with_title(format!("restir-demo view: {}", setup.scene_name))
        .with_inner_size(winit::dpi::PhysicalSize::new(
            (w * zoom).clamp(320, 1600) + PANEL_WIDTH as u32,
            (h * zoom).clamp(600, 1200),
        ));
    let window = event_loop
        .create_window(attrs)
        .map_err(|e| anyhow::anyhow!("cannot create a window: {e}. {SUGGEST_RENDER}"))?;
    Ok(Arc::new(window))
}

/// A surface for `window` and a GPU context on an adapter that can present to it (tracing
/// with `--tracer`).
fn surface_and_context(
    window: &Arc<Window>,
    display: &winit::event_loop::OwnedDisplayHandle,
) -> Result<(wgpu::Surface<'static>, GpuContext)> {
    let mut desc =
        wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(display.clone()));
    desc.backends = GpuContext::backends_from_env()?;
    let instance = wgpu::Instance::new(desc);
    let surface = instance.create_surface(window.clone()).map_err(|e| {
        anyhow::anyhow!(
            "no surface support: cannot create a wgpu surface for the window: {e}. \
             {SUGGEST_RENDER}"
        )
    })?;
    let mut ctx = pollster::block_on(GpuContext::for_surface(&instance, &surface))
        .map_err(|e| anyhow::anyhow!("{e}. {SUGGEST_RENDER}"))?;
    crate::apply_tracer(&mut ctx)?;
    eprintln!("{}", ctx.describe());
    Ok((surface, ctx))
}

/// The surface's configuration at `size`: a gamma-space format when there is one (egui draws
/// into those preferably), vsync.
fn surface_config(
    surface: &wgpu::Surface,
    ctx: &GpuContext,
    size: winit::dpi::PhysicalSize<u32>,
) -> Result<wgpu::SurfaceConfiguration> {
    let caps = surface.get_capabilities(&ctx.adapter);
    let format = caps
        .formats
        .iter()
        .copied()
        .find(|f| !f.is_srgb())
        .or(caps.formats.first().copied())
        .with_context(|| {
            format!(
                "the adapter {:?} cannot present to this window (no surface format). {}",
                ctx.info.name, SUGGEST_RENDER
            )
        })?;
    Ok(wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        width: size.width.max(1),
        height: size.height.max(1),
        present_mode: wgpu::PresentMode::AutoVsync,
        desired_maximum_frame_latency: 2,
        alpha_mode: caps
            .alpha_modes
            .first()
            .copied()
            .unwrap_or(wgpu::CompositeAlphaMode::Auto),
        view_formats: vec![],
        color_space: wgpu::SurfaceColorSpace::Auto,
    })
}

/// Moves `camera` by `translate` (right, up, forward) and turns it by `look` (yaw, pitch),
/// keeping the eye-target distance; never lets the view direction reach the up axis.
fn fly(camera: &mut Camera, translate: Vec3, (yaw, pitch): (f32, f32)) {
    let up = camera.up.normalize_or(Vec3::Y);
    let mut forward = (camera.target - camera.eye).normalize_or(Vec3::NEG_Z);
    let dist = (camera.target - camera.eye).length().max(1e-3);
    if yaw != 0.0 || pitch != 0.0 {
        forward = Quat::from_axis_angle(up, yaw) * forward;
        let right = forward.cross(up).normalize_or(Vec3::X);
        let turned = Quat::from_axis_angle(right, pitch) * forward;
        if turned.dot(up).abs() < 0.99 {
            forward = turned;
        }
        camera.target = camera.eye + forward * dist;
    }
    if translate != Vec3::ZERO {
        let right = forward.cross(up).normalize_or(Vec3::X);
        let d = right * translate.x + up * translate.y + forward * translate.z;
        camera.eye += d;
        camera.target += d;
    }
}

/// What the overlay shows without changing.
struct Info {
    adapter: String,
    timestamps: bool,
    size: (u32, u32),
    accumulated: u32,
    settings: MethodSettings,
    speed: f32,
    dt: f32,
    render_cmd: String,
}

/// The specs the method list offers: every registry entry, then each entry's named variants
/// that parse.
fn method_specs() -> Vec<String> {
    let entries = methods::registry();
    let mut v: Vec<String> = entries.iter().map(|e| e.name.to_owned()).collect();
    for e in entries {
        let variants = e.variants().into_iter().filter(|x| x.name != "both");
        let specs = variants.map(|x| format!("{}:{}", e.name, x.name));
        v.extend(specs.filter(|s| methods::check_spec(s).is_ok()));
    }
    v
}

/// The editable texts of the method's knobs, in order.
fn knob_texts(settings: &MethodSettings) -> Vec<String> {
    settings.knobs().into_iter().map(|(_, v)| v).collect()
}

/// The denoiser's knobs and their values (its defaults' when it is off).
fn denoise_knobs(d: Option<DenoiseConfig>) -> Vec<(Knob, String)> {
    let d = d.unwrap_or_default();
    DenoiseConfig::KNOBS
        .iter()
        .map(|k| (*k, d.get(k.name).unwrap_or_default()))
        .collect()
}

/// The editable texts of the denoiser's knobs, in order.
fn denoise_texts(d: Option<DenoiseConfig>) -> Vec<String> {
    denoise_knobs(d).into_iter().map(|(_, v)| v).collect()
}

fn overlay(
    ui: &mut egui::Ui,
    info: &Info,
    c: &mut Controls,
    s: &Stats,
    a: &mut Actions,
    texture: Option<egui::TextureId>,
) {
    egui::Panel::right("controls")
        .default_size(PANEL_WIDTH - 20.0)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| controls_ui(ui, info, c, s, a));
        });
    egui::CentralPanel::no_frame().show(ui, |ui| {
        let rect = ui.available_rect_before_wrap();
        let Some(tex) = texture else {
            return;
        };
        let (w, h) = (info.size.0 as f32, info.size.1 as f32);
        let zoom = (rect.width() / w).min(rect.height() / h);
        let shown = egui::Rect::from_center_size(rect.center(), egui::vec2(w * zoom, h * zoom));
        let response = ui.allocate_rect(rect, egui::Sense::drag());
        ui.painter().image(
            tex,
            shown,
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            egui::Color32::WHITE,
        );
        if response.dragged() {
            let d = response.drag_delta();
            a.look = (-d.x * 0.004, -d.y * 0.004);
        }
    });
    // Fly keys, unless a text field has the keyboard.
    if !ui.ctx().egui_wants_keyboard_input() {
        ui.input(|i| {
            let key = |k: egui::Key| if i.key_down(k) { 1.0 } else { 0.0 };
            let dir = Vec3::new(
                key(egui::Key::D) - key(egui::Key::A),
                key(egui::Key::E) - key(egui::Key::Q),
                key(egui::Key::W) - key(egui::Key::S),
            );
            let boost = if i.modifiers.shift { 4.0 } else { 1.0 };
            a.translate = dir * info.speed * c.speed * boost * info.dt;
            let turn = 1.5 * info.dt;
            a.look.0 += (key(egui::Key::ArrowLeft) - key(egui::Key::ArrowRight)) * turn;
            a.look.1 += (key(egui::Key::ArrowUp) - key(egui::Key::ArrowDown)) * turn;
            a.screenshot |= i.key_pressed(egui::Key::P);
            a.restart |= i.key_pressed(egui::Key::R);
            if i.key_pressed(egui::Key::Space) {
                c.paused = !c.paused;
            }
        });
    }
}

fn controls_ui(ui: &mut egui::Ui, info: &Info, c: &mut Controls, s: &Stats, a: &mut Actions) {
    status_ui(ui, info, s);
    ui.separator();
    times_ui(ui, info, s);
    ui.separator();
    method_ui(ui, info, c, a);
    ui.separator();
    denoise_ui(ui, c, a);
    ui.separator();
    image_ui(ui, info, c, a);
    ui.separator();
    ui.label("WASD move, Q/E down/up, shift faster; drag the image or arrows to look");
    ui.collapsing("the same image offline", |ui| {
        ui.add(egui::Label::new(egui::RichText::new(&info.render_cmd).monospace()).wrap());
    });
}

/// The adapter, the frame size and counts, and the last message.
fn status_ui(ui: &mut egui::Ui, info: &Info, s: &Stats) {
    ui.heading("restir-demo view");
    ui.label(format!("adapter: {}", info.adapter));
    ui.label(format!(
        "{}x{}, {} frames accumulated ({} rendered)",
        info.size.0, info.size.1, info.accumulated, s.frames
    ));
    if let Some(o) = s.overflows {
        ui.label(format!("grid overflows (last frame): {o}"));
    }
    if let Some(c) = &s.cache {
        ui.label(cache_line(c));
    }
    if let Some(m) = &s.message {
        ui.colored_label(egui::Color32::YELLOW, m);
    }
}

/// The recent frames' wall-clock time and GPU spans.
fn times_ui(ui: &mut egui::Ui, info: &Info, s: &Stats) {
    let recent = PassTimes::sum(s.recent.iter().map(|t| &t.spans));
    let n = s.recent.len().max(1) as f64;
    let wall = s.recent.iter().map(|t| t.wall).sum::<f64>() / n;
    let done = s.recent.iter().map(|t| t.done).sum::<f64>() / n;
    ui.label(format!(
        "frame {wall:.1} ms (wall clock); recorded until done {done:.1} ms"
    ));
    if !info.timestamps {
        ui.label("GPU timings: no timestamp queries on this adapter");
        return;
    }
    ui.label(format!("GPU spans {:.2} ms/frame:", recent.ms_per_frame()));
    if spans_disagree(recent.ms_per_frame(), done) {
        ui.colored_label(egui::Color32::YELLOW, SPANS_DISAGREE);
    }
    egui::Grid::new("spans").striped(true).show(ui, |ui| {
        for (name, ms) in recent.per_frame() {
            ui.label(name);
            ui.label(format!("{ms:.3} ms"));
            ui.end_row();
        }
    });
}

/// The method list, the spec field and the method's knobs.
fn method_ui(ui: &mut egui::Ui, info: &Info, c: &mut Controls, a: &mut Actions) {
    ui.label("method");
    egui::ComboBox::from_id_salt("method")
        .selected_text(info.settings.spec())
        .width(260.0)
        .show_ui(ui, |ui| {
            for spec in method_specs() {
                if ui.selectable_label(false, &spec).clicked() {
                    apply_spec(&spec, c, a);
                }
            }
        });
    ui.horizontal(|ui| {
        let r = ui.text_edit_singleline(&mut c.spec_text);
        if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
            let spec = c.spec_text.trim().to_owned();
            apply_spec(&spec, c, a);
        }
    });
    if !info.settings.knobs().is_empty() {
        egui::CollapsingHeader::new("knobs")
            .default_open(true)
            .show(ui, |ui| knobs_ui(ui, &info.settings, c, a));
    }
}

/// Switches to the method `spec`, or says in the spec field why not.
fn apply_spec(spec: &str, c: &mut Controls, a: &mut Actions) {
    match methods::parse_spec(spec) {
        Ok(set) => a.settings = Some(set),
        Err(e) => c.spec_text = format!("{spec}: {e}"),
    }
}

/// What is shown and how: the image, exposure, resolution, accumulation, fly speed,
/// screenshot and restart.
fn image_ui(ui: &mut egui::Ui, info: &Info, c: &mut Controls, a: &mut Actions) {
    egui::ComboBox::from_label("shown")
        .selected_text(c.shown.label())
        .show_ui(ui, |ui| {
            for (shown, label) in Shown::ALL {
                if !shown.available(&info.settings) {
                    continue;
                }
                ui.selectable_value(&mut c.shown, shown, label);
            }
        });
    if !c.shown.available(&info.settings) {
        c.shown = Shown::Combined;
    }
    ui.add(
        egui::Slider::new(&mut c.exposure, 0.05..=20.0)
            .logarithmic(true)
            .text("exposure"),
    );
    let before = c.scale;
    egui::ComboBox::from_label("resolution scale")
        .selected_text(format!("{}", c.scale))
        .show_ui(ui, |ui| {
            for s in SCALES {
                ui.selectable_value(&mut c.scale, s, format!("{s}"));
            }
        });
    a.rebuild |= c.scale != before;
    let paths = c.paths;
    ui.add(egui::Slider::new(&mut c.paths.bounces, 1..=16).text("bounces"));
    ui.checkbox(&mut c.paths.mis, "MIS of emission hits");
    a.rebuild |= c.paths != paths;
    let acc = c.accumulate;
    ui.checkbox(&mut c.accumulate, "accumulate while still");
    a.restart |= acc != c.accumulate;
    ui.checkbox(&mut c.paused, "paused (space)");
    ui.add(
        egui::Slider::new(&mut c.speed, 0.05..=10.0)
            .logarithmic(true)
            .text("fly speed"),
    );
    ui.horizontal(|ui| {
        a.screenshot |= ui.button("screenshot (P)").clicked();
        a.restart |= ui.button("restart (R)").clicked();
    });
}

/// The method's knobs ([`knob_rows`]): an edit rebuilds the method with it.
fn knobs_ui(ui: &mut egui::Ui, settings: &MethodSettings, c: &mut Controls, a: &mut Actions) {
    if let Some((knob, value, text)) = knob_rows(ui, "knobs", settings.knobs(), &mut c.knob_text) {
        match settings.with_knob(knob.name, &value) {
            Ok(next) => a.settings = Some(next),
            Err(e) => c.knob_text[text] = format!("{value} ({e})"),
        }
    }
}

/// The denoiser's switch and knobs: an edit rebuilds the method with it.
fn denoise_ui(ui: &mut egui::Ui, c: &mut Controls, a: &mut Actions) {
    let mut on = c.denoise.is_some();
    if ui.checkbox(&mut on, "denoiser (SVGF)").changed() {
        c.denoise = on.then(DenoiseConfig::default);
        if on {
            c.shown = Shown::Denoised;
        }
        a.rebuild = true;
    }
    let Some(d) = c.denoise else {
        return;
    };
    egui::CollapsingHeader::new("denoiser knobs").show(ui, |ui| {
        let edit = knob_rows(ui, "denoise", denoise_knobs(Some(d)), &mut c.denoise_text);
        if let Some((knob, value, text)) = edit {
            let mut next = d;
            match next
                .set(knob.name, &value)
                .and_then(|_| next.validate().map_err(|e| e.to_string()))
            {
                Ok(()) => {
                    c.denoise = Some(next);
                    a.rebuild = true;
                }
                Err(e) => c.denoise_text[text] = format!("{value} ({e})"),
            }
        }
    });
}

/// One row per knob: switches as checkboxes, choices as lists, the rest as text (`texts`, in
/// the knobs' order) that is taken when Enter is pressed. Returns the edited knob, its new
/// value and its index in `texts`.
fn knob_rows(
    ui: &mut egui::Ui,
    id: &str,
    knobs: Vec<(Knob, String)>,
    texts: &mut [String],
) -> Option<(Knob, String, usize)> {
    let mut edited = None;
    egui::Grid::new(id).show(ui, |ui| {
        for (i, (knob, current)) in knobs.into_iter().enumerate() {
            let Some(text) = texts.get_mut(i) else {
                continue;
            };
            ui.label(knob.name).on_hover_text(knob.doc.trim());
            let mut apply = None;
            match knob.kind {
                KnobKind::Switch => {
                    let mut on = current == "on";
                    if ui.checkbox(&mut on, "").changed() {
                        apply = Some(if on { "on" } else { "off" }.to_owned());
                    }
                }
                KnobKind::Choice(names) => {
                    egui::ComboBox::from_id_salt(knob.name)
                        .selected_text(&current)
                        .show_ui(ui, |ui| {
                            for name in names {
                                if ui.selectable_label(*name == current, *name).clicked() {
                                    apply = Some((*name).to_owned());
                                }
                            }
                        });
                }
                KnobKind::Number => {
                    let r = ui.add(egui::TextEdit::singleline(text).desired_width(90.0));
                    if r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter)) {
                        apply = Some(text.trim().to_owned());
                    }
                }
            }
            ui.end_row();
            if let Some(value) = apply {
                edited = Some((knob, value, i));
            }
        }
    });
    edited
}

/// One line on the radiance cache's use: cells in use of the table, bytes, overflows.
fn cache_line(c: &restir_world::cache::CacheStats) -> String {
    format!(
        "cache: {} of {} cells ({} B each, {:.1} MiB), {} overflows (last frame)",
        c.cells_in_use,
        c.capacity,
        c.bytes_per_cell,
        c.bytes() as f64 / f64::from(1u32 << 20),
        c.overflows
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The method list offers every registry entry and the variants, and each entry's spec
    /// parses back to settings whose spec parses again (the list and the spec field agree).
    #[test]
    fn method_list_offers_every_method_and_variant() {
        let specs = method_specs();
        for name in ["ris", "world-restir", "restir-di", "world-restir+restir-di"] {
            assert!(specs.iter().any(|s| s == name), "{name} missing: {specs:?}");
        }
        for spec in [
            "restir-di:biased",
            "world-restir:unified",
            "world-restir+restir-di:gi-tiles",
        ] {
            assert!(specs.iter().any(|s| s == spec), "{spec} missing: {specs:?}");
        }
        assert!(
            !specs.iter().any(|s| s == "restir-di:gi-tiles"),
            "{specs:?}"
        );
        let both = methods::parse_spec("world-restir+restir-di").unwrap();
        assert_eq!(knob_texts(&both).len(), both.knobs().len());
        for spec in &specs {
            let settings = methods::parse_spec(spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
            let again = methods::parse_spec(&settings.spec()).expect("spec parses");
            assert_eq!(again, settings, "{spec}");
        }
    }
}
