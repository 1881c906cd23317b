//! `restir-demo`: render, compare and inspect world-space ReSTIR GI.

mod compare;
mod paths;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use restir_world::gpu::{Access, BindingSet, Kernel, Tracer, buffers, workgroup_size_wgsl};
use restir_world::lights::Lights;
use restir_world::methods::MethodSettings;
use restir_world::render::RenderOptions;
use restir_world::sampling::Estimator;
use restir_world::scene::Scene;
use restir_world::{GpuContext, GpuTimer, image_io, reference, render};

mod camera;
mod render_cmd;
mod scenes;
mod view;

/// The three commands a first user needs, shown with the help (and with no arguments).
const FIRST_STEPS: &str = "First steps:
  restir-demo render --scene cornell --method world-restir-gi --denoise --out out/
      an image of world-space ReSTIR GI, raw and denoised (EXR and PNG in out/)
  restir-demo compare --scene many-lights --methods ris,restir-gi,world-restir-gi --out out/compare
      speed against error: each method's error and GPU time against a converged reference
  restir-demo view --scene cornell --method world-restir-gi
      a window onto the method, live (needs a display)";

#[derive(Parser, Debug)]
#[command(
    name = "restir-demo",
    version,
    about,
    arg_required_else_help = true,
    after_help = FIRST_STEPS
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// How rays are traced: auto (ray queries on GPUs that have them, else the software BVH),
    /// bvh (our CWBVH traversal, every adapter) or ray-query (the adapter's ray queries).
    #[arg(long, global = true, default_value = "auto", value_parser = parse_tracer)]
    tracer: TracerChoice,
}

/// `--tracer`: `None` is auto.
#[derive(Debug, Clone, Copy)]
struct TracerChoice(Option<Tracer>);

fn parse_tracer(s: &str) -> Result<TracerChoice, String> {
    match s {
        "auto" => Ok(TracerChoice(None)),
        _ => s.parse().map(|t| TracerChoice(Some(t))),
    }
}

/// `--tracer` (`None`: auto), set once from the command line.
static TRACER: std::sync::OnceLock<Option<Tracer>> = std::sync::OnceLock::new();

/// The GPU context every command uses: the chosen adapter, tracing with `--tracer`.
pub(crate) fn gpu_context() -> Result<GpuContext> {
    let mut ctx = GpuContext::new()?;
    apply_tracer(&mut ctx)?;
    Ok(ctx)
}

/// Sets `--tracer` on a context.
pub(crate) fn apply_tracer(ctx: &mut GpuContext) -> Result<()> {
    ctx.set_tracer(TRACER.get().copied().flatten())
        .context("--tracer")
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the adapter, its optional features and its limits (and, with --scene, the
    /// scene's statistics).
    Info {
        /// A built-in scene (cornell, cornell-glossy, many-lights, colonnade, glossy, furnace,
        /// furnace-sphere) or a .gltf/.glb/.obj file.
        #[arg(long)]
        scene: Option<String>,
        #[command(flatten)]
        scene_opts: scenes::SceneArgs,
        /// A method spec whose frame to print: each step in order, with what it reads and
        /// writes (at the path flags given).
        #[arg(long)]
        method: Option<String>,
        /// With --method: the frame with the denoiser after it (its knobs as key=value joined
        /// by +, as render's --denoise).
        #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "KNOBS")]
        denoise: Option<String>,
        #[command(flatten)]
        paths: paths::PathArgs,
    },
    /// Render a scene: direct, indirect and combined images as linear EXR + sRGB PNG.
    Render(Box<RenderArgs>),
    /// Prove the device works: run a compute shader and write its image as a PNG.
    Smoke {
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Image size, WxH.
        #[arg(long, default_value = "256x256", value_parser = parse_size)]
        size: (u32, u32),
    },
    /// Speed against error: run methods over the same frames and camera, measure per-stage
    /// GPU time and the error against a converged reference, compare at equal time, and write
    /// report.md, report.json, error_vs_time.svg and strip.jpg into --out.
    Compare(Box<CompareArgs>),
    /// An interactive window onto a method, live: fly camera, method and knob switches,
    /// per-stage GPU times, debug views, screenshots (needs a display; `render` does not).
    View(Box<view::ViewArgs>),
}

#[derive(clap::Args, Debug)]
struct CompareArgs {
    /// Scenes, comma-separated: built-in names (cornell, many-lights, colonnade, furnace,
    /// furnace-sphere) or scene files (.gltf, .glb, .obj).
    #[arg(long, default_value = "many-lights", value_delimiter = ',')]
    scene: Vec<String>,
    /// Methods of the registry, comma-separated, each `name` or `name:variant`; default: every
    /// registered method that renders the paths asked for (the `+cache` methods only with
    /// unbounded paths).
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
    /// Frames per method.
    #[arg(long, default_value_t = 16)]
    frames: u32,
    /// Image size, WxH.
    #[arg(long, default_value = "128x128", value_parser = parse_size)]
    size: (u32, u32),
    /// Output directory.
    #[arg(long, default_value = "out/compare")]
    out: PathBuf,
    /// Camera motion over the frames: static, orbit (1 degree per frame) or dolly (1% of the
    /// eye-target distance per frame, at most half of it).
    #[arg(long, value_enum, default_value_t = compare::CameraMode::Static)]
    animation: compare::CameraMode,
    /// An external reference (combined image, linear EXR) instead of the GPU reference mode.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// The external reference's indirect image (linear EXR); without it indirect errors are
    /// not reported.
    #[arg(long, requires = "reference")]
    reference_indirect: Option<PathBuf>,
    /// Samples per pixel of the GPU reference, 2 to 1048576.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Reference cache directory.
    #[arg(long, default_value = "out/cache")]
    cache: PathBuf,
    /// Do not read or write the reference cache.
    #[arg(long)]
    no_cache: bool,
    #[command(flatten)]
    scene_opts: scenes::SceneArgs,
    /// Seed of the methods' random numbers.
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Frames of each equal-time run (capped at --frames).
    #[arg(long, default_value_t = 8)]
    equal_time_frames: u32,
    /// The method others are compared against at equal time (default: world-restir when
    /// listed, else the slowest method).
    #[arg(long)]
    equal_time_to: Option<String>,
    /// Moving camera: evaluate the error every N frames (and at the last), each against its
    /// own reference.
    #[arg(long, default_value_t = 8)]
    eval_every: u32,
    /// Negative control for tests: METHOD=FACTOR multiplies that method's indirect image.
    #[arg(long, hide = true, value_parser = parse_bias)]
    plant_bias: Vec<(String, f32)>,
    /// Denoise every method's frames (SVGF after the method) and measure the denoised image
    /// too (relMSE, FLIP, bias, frame-to-frame change), with the denoiser's knobs as key=value
    /// joined by + (bare --denoise: the defaults).
    #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "KNOBS")]
    denoise: Option<String>,
    /// Do not write the reference EXRs into --out.
    #[arg(long)]
    no_exr: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    paths: paths::PathArgs,
}

fn parse_bias(s: &str) -> Result<(String, f32), String> {
    let (m, f) = s
        .split_once('=')
        .ok_or_else(|| format!("expected METHOD=FACTOR, got {s:?}"))?;
    let f: f32 = f.parse().map_err(|_| format!("bad factor in {s:?}"))?;
    Ok((m.to_owned(), f))
}

#[derive(clap::Args, Debug)]
struct RenderArgs {
    /// A built-in scene (cornell, cornell-glossy, many-lights, colonnade, glossy, furnace,
    /// furnace-sphere) or a .gltf/.glb/.obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[command(flatten)]
    scene_opts: scenes::SceneArgs,
    /// A method of the registry as `name` or `name:variant` (nee, ris, ris:K, world-restir,
    /// world-restir:VARIANT or knobs key=value joined by +, e.g.
    /// world-restir:temporal+spatial-passes=4, restir-di[:VARIANT], world-restir+restir-di;
    /// see `compare --help`), or cpu-reference (the CPU
    /// reference renderer: the nee estimator, or ris with --reference-ris; f64 accumulation, all
    /// cores).
    #[arg(long, default_value = "nee")]
    method: String,
    /// cpu-reference with --reference-ris: RIS candidates, 1..=65535 (GPU methods: ris:K).
    #[arg(long,
          value_parser = clap::value_parser!(u32).range(1..=i64::from(restir_world::render::MAX_CANDIDATES)))]
    candidates: Option<u32>,
    /// cpu-reference: use the RIS estimator instead of NEE.
    #[arg(long)]
    reference_ris: bool,
    /// Samples per pixel per frame.
    #[arg(long, default_value_t = 1)]
    spp: u32,
    /// Frames accumulated progressively (total samples per pixel = spp x frames).
    #[arg(long, default_value_t = 16)]
    frames: u32,
    /// Image size, WxH (default: the scene camera's, or 256x256).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    #[arg(long, default_value_t = 0)]
    seed: u32,
    #[command(flatten)]
    paths: paths::PathArgs,
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Camera position x,y,z (overrides the scene's camera).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    eye: Option<Vec3>,
    /// Camera target x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    target: Option<Vec3>,
    /// Camera up vector x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    up: Option<Vec3>,
    /// Vertical field of view, degrees.
    #[arg(long)]
    fov: Option<f32>,
    /// Exposure multiplier of the PNGs (EXRs are always linear and unscaled). Default: the
    /// combined image's 99th-percentile luminance maps to 1, as compare's images and FLIP do.
    #[arg(long)]
    exposure: Option<f32>,
    /// Worker threads of the CPU reference (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// No progress bar (it is drawn only on a terminal anyway).
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    anim: render_cmd::AnimArgs,
}

/// `render --method` of the CPU reference renderer.
const CPU_REFERENCE: &str = "cpu-reference";

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH, got {s:?}"))?;
    let w: u32 = w.parse().map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h.parse().map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s:?} must be between 1x1 and 16384x16384"));
    }
    Ok((w, h))
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected x,y,z, got {s:?}"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers x,y,z, got {s:?}")),
    }
}

/// The command line. A value that looks like a negative number is a value, so that
/// `--bounces -1` is refused by its flag's check, not as an unknown argument.
fn parse_cli() -> Cli {
    let cmd = Cli::command().mut_subcommands(|s| {
        s.mut_args(|a| match a.get_action().takes_values() {
            true => a.allow_negative_numbers(true),
            false => a,
        })
    });
    Cli::from_arg_matches(&cmd.get_matches()).unwrap_or_else(|e| e.exit())
}

fn main() -> ExitCode {
    let cli = parse_cli();
    let _ = TRACER.set(cli.tracer.0);
    let result = match cli.command {
        Command::Info {
            scene,
            scene_opts,
            method,
            denoise,
            paths,
        } => info(
            scene.as_deref(),
            &scene_opts,
            method.as_deref(),
            denoise.as_deref(),
            &paths,
        ),
        Command::Render(args) => render(&args),
        Command::Smoke { out, size } => smoke(&out, size),
        Command::Compare(args) => compare_cmd(*args),
        Command::View(args) => view::view(*args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", elide_long_words(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}

/// Creates the output directory and checks that files can be written into it, before any
/// expensive work. Returns the directories it created (outermost first; empty when `out`
/// already existed), which a failed run removes again ([`remove_created`]).
fn prepare_out_dir(out: &Path) -> Result<Vec<PathBuf>> {
    prepare_dir(out, "the output directory")
}

/// [`prepare_out_dir`] for any directory, named `what` in messages. The probe file has a
/// random name and is created new: a link planted at some name is never followed.
pub(crate) fn prepare_dir(dir: &Path, what: &str) -> Result<Vec<PathBuf>> {
    let created = missing_ancestors(dir);
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create {what} {}", dir.display()))?;
    let probe = dir.join(format!(".restir-demo-probe-{}", image_io::unique_suffix()));
    let written = image_io::create_new(&probe)
        .map(drop)
        .with_context(|| format!("cannot write into {what} {}", dir.display()));
    if written.is_ok() {
        let _ = std::fs::remove_file(&probe);
    }
    match written {
        Ok(()) => Ok(created),
        Err(e) => {
            remove_created(&created);
            Err(e)
        }
    }
}

/// `dir` and its ancestors that do not exist yet, outermost first.
fn missing_ancestors(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = dir
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .take_while(|a| std::fs::symlink_metadata(a).is_err())
        .map(Path::to_path_buf)
        .collect();
    v.reverse();
    v
}

/// Removes directories [`prepare_dir`] created, innermost first, as long as they are empty.
pub(crate) fn remove_created(created: &[PathBuf]) {
    for d in created.iter().rev() {
        if std::fs::remove_dir(d).is_err() {
            break;
        }
    }
}

/// Runs `work` with `out` prepared; a failed run removes the directories it created again
/// when it left them empty.
pub(crate) fn with_out_dir<T>(out: &Path, work: impl FnOnce() -> Result<T>) -> Result<T> {
    let created = prepare_out_dir(out)?;
    let result = work();
    if result.is_err() {
        remove_created(&created);
    }
    result
}

/// Writes a set of files all or none: each through `write`, and when one fails, removes those
/// already written before returning the error.
pub(crate) fn write_all_or_none(
    files: &[PathBuf],
    mut write: impl FnMut(usize, &Path) -> Result<()>,
) -> Result<()> {
    for (i, f) in files.iter().enumerate() {
        if let Err(e) = write(i, f) {
            for done in &files[..i] {
                let _ = std::fs::remove_file(done);
            }
            return Err(e);
        }
    }
    Ok(())
}

fn info(
    scene_name: Option<&str>,
    opts: &scenes::SceneArgs,
    method: Option<&str>,
    denoise: Option<&str>,
    paths: &paths::PathArgs,
) -> Result<()> {
    // The method and its frame are checked before the adapter is opened.
    if denoise.is_some() && method.is_none() {
        anyhow::bail!(
            "--denoise: info prints the denoiser's place in a method's frame: give --method"
        );
    }
    let paths = paths.paths()?;
    let plan = match method {
        Some(spec) => {
            let mut settings = restir_world::methods::parse_spec(spec).context("--method")?;
            settings.denoise = denoise
                .map(|k| {
                    restir_world::denoise::DenoiseConfig::parse(k)
                        .map_err(|e| anyhow::anyhow!("--denoise: {e}"))
                })
                .transpose()?;
            settings.check_paths(&paths).context("--method")?;
            let plan = settings.plan(&paths).context("--method")?;
            Some((spec, settings, plan))
        }
        None => None,
    };
    // What needs no adapter first: the methods are listed on a machine without one too.
    print_methods();
    if let Some((spec, _, plan)) = &plan {
        println!("one frame of {spec} (each step enters its owner once):\n{plan}");
    }
    let scene = match scene_name {
        Some(name) => {
            let scene = scenes::load(name, opts, None)?;
            print_scene(name, &scene);
            scene
        }
        None => scenes::load("cornell", opts, None)?,
    };
    let ctx = gpu_context()?;
    print_adapter(&ctx);
    let methods = match plan {
        Some((spec, settings, _)) => vec![(spec.to_owned(), settings)],
        None => restir_world::methods::registry()
            .iter()
            .map(|e| {
                Ok((
                    e.name.to_owned(),
                    restir_world::methods::parse_spec(e.name)?,
                ))
            })
            .collect::<Result<_, restir_world::methods::MethodError>>()?,
    };
    print_largest_images(
        &ctx,
        scene_name.unwrap_or("cornell"),
        &scene,
        &methods,
        &paths,
    )
}

/// The largest image each of `methods` renders of `scene` on this adapter: its widest
/// per-pixel buffer against one storage binding, measured by building the method at 8x8.
fn print_largest_images(
    ctx: &GpuContext,
    scene_name: &str,
    scene: &Scene,
    methods: &[(String, MethodSettings)],
    paths: &render::Paths,
) -> Result<()> {
    println!(
        "largest image of {scene_name} on this adapter (--size above it is refused before any work):"
    );
    let camera = scene.camera_or_default(8, 8);
    for (spec, settings) in methods {
        // In the listing, the cache's methods at the unbounded paths they need.
        let paths = match settings.check_paths(paths) {
            Ok(()) => *paths,
            Err(_) => restir_world::sampling::Paths::bounces(render::MAX_BOUNCES),
        };
        let options = RenderOptions {
            paths,
            ..Default::default()
        };
        let probe = ctx.measuring_pixel_bindings();
        // A method this adapter cannot run at all (too few storage buffers on GL, say) is
        // named with its reason; the rest of `info` still stands.
        if let Err(e) = settings.build_with(&probe, scene, &camera, &options) {
            println!("  {spec}: not on this adapter: {e}");
            continue;
        }
        let Some((bytes, what, pixels)) = probe.largest_pixel_binding() else {
            continue;
        };
        // The largest 16:9 image 16k x 9k and square image that fit.
        let k = ((pixels / 144) as f64).sqrt() as u64;
        let side = (pixels as f64).sqrt() as u64;
        println!(
            "  {spec}: {pixels} pixels ({what}, {bytes} bytes a pixel): up to {}x{} at 16:9, \
             {side}x{side} square",
            16 * k,
            9 * k
        );
    }
    Ok(())
}

/// The registry: every method with what its `name:` variant accepts.
fn print_methods() {
    println!("methods (--method name or name:variant):");
    for e in restir_world::methods::registry() {
        println!("  {}: {}", e.name, e.about);
        println!("    variants: {}", e.variants_help());
    }
}

/// The adapter, its tracers, the limits that size our buffers and its subgroup sizes.
fn print_adapter(ctx: &GpuContext) {
    println!("{}", ctx.describe());
    println!(
        "tracers: bvh (software CWBVH): yes; ray-query: {}; auto picks {}; this run: {}",
        match ctx.features.ray_query {
            true => "yes",
            false => "unavailable (no EXPERIMENTAL_RAY_QUERY on this adapter)",
        },
        ctx.auto_tracer().name(),
        ctx.tracer.name()
    );
    let l = ctx.limits();
    println!(
        "limits: max_storage_buffer_binding_size={} max_buffer_size={} \
         max_compute_workgroup_storage_size={} max_compute_invocations_per_workgroup={} \
         max_compute_workgroups_per_dimension={} max_storage_buffers_per_shader_stage={}",
        l.max_storage_buffer_binding_size,
        l.max_buffer_size,
        l.max_compute_workgroup_storage_size,
        l.max_compute_invocations_per_workgroup,
        l.max_compute_workgroups_per_dimension,
        l.max_storage_buffers_per_shader_stage,
    );
    let sg = ctx.adapter.get_info();
    println!(
        "subgroup sizes: {}..{}",
        sg.subgroup_min_size, sg.subgroup_max_size
    );
}

/// A scene's statistics: geometry, lights, cameras, environment and textures.
fn print_scene(name: &str, s: &Scene) {
    let lights = Lights::build(s);
    println!(
        "scene {name}: {} triangles, {} materials, {} emissive triangles (total power {:.4e})",
        s.triangles.len(),
        s.materials.len(),
        lights.len(),
        lights.total_power
    );
    if let Some((lo, hi)) = s.bounds() {
        println!("bounds: {lo} .. {hi}");
    }
    for (i, c) in s.cameras.iter().enumerate() {
        println!("camera {i}: {:?}", c.name);
    }
    for l in &s.lights {
        println!(
            "punctual light {:?}: {:?} at {} towards {}, colour {:?}, intensity {}",
            l.name, l.kind, l.position, l.direction, l.color, l.intensity
        );
    }
    if let Some(env) = &s.environment {
        println!(
            "environment: {} ({}x{} pixels)",
            env.source, env.width, env.height
        );
    }
    if !s.textures.is_empty() {
        println!(
            "textures: {} images, {} uses",
            s.textures.len(),
            s.texture_refs.len()
        );
    }
    match s.camera {
        Some(c) => println!(
            "camera: eye {} target {} up {} fov {} deg, {}x{}",
            c.eye, c.target, c.up, c.vfov_deg, c.width, c.height
        ),
        None => {
            let c = s.camera_or_default(256, 256);
            println!(
                "camera: none in the file; the default framing: eye {} target {} up {} fov {} \
                 deg",
                c.eye, c.target, c.up, c.vfov_deg
            );
        }
    }
}

/// `--quiet`: no progress bars.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// A progress bar of `len` steps on stderr (done, elapsed, estimated remaining): drawn only on
/// a terminal (indicatif hides it when stderr is a file or a pipe, as in logs), never under
/// `--quiet`; it ticks by itself so that a long first step (pipeline compilation) shows.
fn progress_bar(len: u64, what: &str) -> ProgressBar {
    if QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.enable_steady_tick(std::time::Duration::from_millis(500));
    pb.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_owned());
    pb
}

fn render(args: &RenderArgs) -> Result<()> {
    QUIET.store(args.quiet, std::sync::atomic::Ordering::Relaxed);
    if args.spp == 0 || args.frames == 0 {
        anyhow::bail!("--spp and --frames must be at least 1");
    }
    let samples = args
        .spp
        .checked_mul(args.frames)
        .context("--spp x --frames overflows")?;
    let scene = scenes::load(&args.scene, &args.scene_opts, args.size)?;
    let (w, h) = args
        .size
        .or(scene.camera.map(|c| (c.width, c.height)))
        .unwrap_or((256, 256));
    let mut camera = scene.camera_or_default(w, h);
    if let Some(e) = args.eye {
        camera.eye = e;
    }
    if let Some(t) = args.target {
        camera.target = t;
    }
    if let Some(u) = args.up {
        camera.up = u;
    }
    if let Some(f) = args.fov {
        camera.vfov_deg = f;
    }
    camera.validate()?;
    if let Some(e) = args.exposure
        && !(e.is_finite() && e > 0.0)
    {
        anyhow::bail!("--exposure must be a positive number");
    }
    // The method spec, parsed once: checked here, built by render_method.
    let mut settings = None;
    if args.method != CPU_REFERENCE {
        let mut s = restir_world::methods::parse_spec(&args.method)?;
        s.denoise = args.anim.denoise_config()?;
        s.check_paths(&args.paths.paths()?)?;
        args.anim.validate()?;
        s.check_camera(&camera).with_context(|| {
            format!(
                "--size {}x{} (with --method {})",
                camera.width, camera.height, args.method
            )
        })?;
        if args.candidates.is_some() || args.reference_ris {
            anyhow::bail!(
                "--candidates and --reference-ris are cpu-reference options (GPU methods: \
                 --method ris:K)"
            );
        }
        for w in s.scene_warnings(&scene) {
            eprintln!("warning: --method {}: {w}", args.method);
        }
        settings = Some(s);
    } else if args.anim.used() {
        anyhow::bail!(
            "--animation, --debug-views and --denoise are options of GPU methods, not \
             cpu-reference"
        );
    } else {
        let bytes = reference::reference_bytes(camera.width, camera.height);
        if bytes > reference::MAX_REFERENCE_BYTES {
            anyhow::bail!(
                "cpu-reference: a {}x{} image needs about {:.1} GiB of memory, above the limit \
                 of {} GiB: render a smaller --size",
                camera.width,
                camera.height,
                bytes as f64 / f64::from(1u32 << 30),
                reference::MAX_REFERENCE_BYTES >> 30
            );
        }
    }
    with_out_dir(&args.out, || {
        render_into(args, settings.as_ref(), &scene, &camera, samples)
    })
}

/// Renders `args.method` (its parsed `settings`, `None` for the CPU reference) and writes the
/// images.
fn render_into(
    args: &RenderArgs,
    settings: Option<&MethodSettings>,
    scene: &Scene,
    camera: &restir_world::scene::Camera,
    samples: u32,
) -> Result<()> {
    let scene_tag: String = Path::new(&args.scene)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let method_tag: String = args
        .method
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '-'
            }
        })
        .collect();
    let images = match settings {
        None => {
            let method = if args.reference_ris {
                Estimator::Ris {
                    candidates: args.candidates.unwrap_or(render::DEFAULT_CANDIDATES),
                }
            } else {
                Estimator::Nee
            };
            let r = reference::ReferenceRenderer::new(scene)?;
            let pb = progress_bar(u64::from(camera.height), "cpu-reference rows");
            let start = std::time::Instant::now();
            eprintln!(
                "cpu-reference ({method:?}): {}x{} x {samples} spp, {} bounces, on the CPU",
                camera.width,
                camera.height,
                args.paths.paths()?.bounces
            );
            let out = r.render(
                camera,
                &reference::ReferenceOptions {
                    method,
                    spp: samples,
                    seed: args.seed,
                    threads: args.threads,
                    paths: args.paths.paths()?,
                },
                Some(&|rows| pb.set_position(u64::from(rows))),
            )?;
            pb.finish_and_clear();
            println!(
                "cpu-reference ({method:?}): {}x{} x {samples} spp in {:.2} s (CPU wall clock)",
                camera.width,
                camera.height,
                start.elapsed().as_secs_f64()
            );
            render_cmd::MethodRender {
                images: out,
                denoised: None,
                debug_views: Vec::new(),
            }
        }
        Some(settings) => render_cmd::render_method(
            &args.method,
            settings,
            &args.anim,
            scene,
            camera,
            samples,
            &RenderOptions {
                seed: args.seed,
                paths: args.paths.paths()?,
                ..Default::default()
            },
        )?,
    };
    write_images(args, &format!("{scene_tag}-{method_tag}"), &images)
}

/// Writes the direct, indirect and combined images of a render (and the denoised last frame) as `TAG-KIND.exr` and `.png`
/// into `--out`, and its debug views as `TAG-VIEW.png`: every file or none (a failed write
/// removes the ones before it).
fn write_images(args: &RenderArgs, tag: &str, render: &render_cmd::MethodRender) -> Result<()> {
    let images = &render.images;
    let mut sets = vec![
        ("direct", &images.direct),
        ("indirect", &images.indirect),
        ("combined", &images.combined),
    ];
    if let Some(d) = &render.denoised {
        sets.push(("denoised", d));
    }
    let (mut files, mut bases) = (Vec::new(), Vec::new());
    for (kind, _) in &sets {
        // Appended, not `with_extension`: a stem with dots ("a.b") would lose its tail.
        let base = args.out.join(format!("{tag}-{kind}"));
        bases.push(base.clone());
        for ext in ["exr", "png"] {
            let mut p = base.clone().into_os_string();
            p.push(".");
            p.push(ext);
            files.push(PathBuf::from(p));
        }
    }
    let views = &render.debug_views;
    files.extend(
        views
            .iter()
            .map(|(name, _)| args.out.join(format!("{tag}-{name}.png"))),
    );
    // One exposure for every image of the render (the combined image's), so they compare.
    let exposure = args
        .exposure
        .unwrap_or_else(|| restir_world::metrics::auto_exposure(&images.combined.pixels));
    write_all_or_none(&files, |i, f| {
        match i.checked_sub(2 * sets.len()) {
            // Debug views are colours already: no exposure.
            Some(v) => image_io::write_png(f, &views[v].1, 1.0)?,
            None if i % 2 == 0 => image_io::write_exr(f, sets[i / 2].1)?,
            None => image_io::write_png(f, sets[i / 2].1, exposure)?,
        }
        Ok(())
    })?;
    if args.exposure.is_none() {
        println!(
            "PNG exposure {} (the combined image's 99th-percentile luminance to 1; --exposure sets it)",
            exposure_text(exposure)
        );
    }
    for (i, (_, img)) in sets.iter().enumerate() {
        let m = img.mean();
        println!(
            "wrote {}.{{exr,png}} (mean {:.4} {:.4} {:.4})",
            bases[i].display(),
            m[0],
            m[1],
            m[2]
        );
    }
    for f in &files[2 * sets.len()..] {
        println!("wrote {}", f.display());
    }
    Ok(())
}

const SMOKE_WGSL: &str = r#"
struct Params { width: u32, height: u32 }

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(id: Invocation) {
    let i = item_index(id);
    if i >= params.width * params.height { return; }
    let xy = vec2<u32>(i % params.width, i / params.width);
    let uv = vec2<f32>(xy) / vec2<f32>(f32(params.width), f32(params.height));
    let checker = f32(((xy.x / 32u) + (xy.y / 32u)) % 2u);
    let rgb = vec3<f32>(uv.x, uv.y, 0.25 + 0.5 * checker);
    pixels[i] = pack4x8unorm(vec4<f32>(rgb, 1.0));
}
"#;

fn smoke(out: &Path, size: (u32, u32)) -> Result<()> {
    with_out_dir(out, || smoke_into(out, size))
}

fn smoke_into(out: &Path, (width, height): (u32, u32)) -> Result<()> {
    let ctx = gpu_context()?;
    println!("{}", ctx.describe());
    let bytes = u64::from(width) * u64::from(height) * 4;
    let limit = ctx.max_storage_u32s() * 4;
    if bytes > limit {
        anyhow::bail!(
            "smoke: a {width}x{height} image needs {bytes} bytes in one storage buffer, above \
             the adapter's limit of {limit} bytes (max_storage_buffer_binding_size / \
             max_buffer_size): use a smaller --size"
        );
    }
    let device = &ctx.device;
    let set = BindingSet::new("smoke")
        .buffer("pixels", "array<u32>", Access::ReadWrite)
        .buffer("params", "Params", Access::Uniform);
    let source = format!("{}{}{SMOKE_WGSL}", workgroup_size_wgsl(), set.wgsl(0));
    let layout = set.layout(device);
    let kernel = Kernel::new(device, "smoke", &source, &[&layout], &["main"]);
    let pixels = buffers::storage_zeroed(device, "pixels", u64::from(width * height) * 4);
    let params = [width, height, 0, 0];
    let params = buffers::with_usage(device, "params", &params, wgpu::BufferUsages::UNIFORM);
    let res = [("pixels", (&pixels).into()), ("params", (&params).into())];
    let group = layout.bind(device, res)?;
    let pass = kernel.pass(device, "main", &[&group], width * height);
    let mut timer = GpuTimer::new(&ctx);
    let mut encoder = device.create_command_encoder(&Default::default());
    timer.span(&mut encoder, "smoke", |enc| pass.record(enc));
    timer.resolve(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let words: Vec<u32> = buffers::read(&ctx, &pixels)?;
    match timer.read(&ctx) {
        Ok(t) => println!("GPU time: {t}"),
        Err(e) => println!("GPU time: {e}"),
    }
    let bytes: Vec<u8> = bytemuck::cast_slice(&words[..(width * height) as usize]).to_vec();
    let img = image::RgbaImage::from_raw(width, height, bytes).context("image size")?;
    let path = out.join("smoke.png");
    image_io::write_png8(&path, img)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// compare's methods when `--methods` is not given: every registered method that renders
/// `paths` (the `+cache` methods need unbounded paths, so at the default 3 bounces they are
/// left out rather than refused).
fn default_compare_methods(paths: &restir_world::sampling::Paths) -> Vec<String> {
    restir_world::methods::registry()
        .iter()
        .filter(|e| e.settings(None).is_ok_and(|s| s.check_paths(paths).is_ok()))
        .map(|e| e.name.to_owned())
        .collect()
}

fn compare_cmd(a: CompareArgs) -> Result<()> {
    let paths = a.paths.paths()?;
    let denoise = a
        .denoise
        .as_deref()
        .map(|k| {
            restir_world::denoise::DenoiseConfig::parse(k)
                .map_err(|e| anyhow::anyhow!("--denoise: {e}"))
        })
        .transpose()?;
    let methods = if a.methods.is_empty() {
        default_compare_methods(&paths)
    } else {
        a.methods
    };
    let opts = compare::CompareOptions {
        scenes: a.scene,
        methods,
        frames: a.frames,
        size: a.size,
        out: a.out,
        camera: a.animation,
        reference: a.reference,
        reference_indirect: a.reference_indirect,
        reference_spp: a.reference_spp,
        cache: (!a.no_cache).then_some(a.cache),
        scene_opts: a.scene_opts,
        seed: a.seed,
        paths,
        equal_time_frames: a.equal_time_frames,
        equal_time_to: a.equal_time_to,
        eval_every: a.eval_every,
        plant_bias: a.plant_bias,
        denoise,
        write_exr: !a.no_exr,
        progress: !a.quiet,
    };
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let settings = compare::check(&opts)?;
    let ctx = gpu_context()?;
    eprintln!("{}", ctx.describe());
    let report = compare::run(&ctx, &opts, &settings, command)?;
    for sc in &report.scenes {
        for m in &sc.methods {
            let errors: Vec<String> = m
                .images
                .iter()
                .map(|(kind, e)| {
                    let rel = e.frame.map_or("-".into(), |e| format!("{:.4e}", e.rel_mse));
                    format!("{} {rel}", kind.name())
                })
                .collect();
            println!(
                "{:>12} {:>14}: {} ms/frame, frame relMSE {}",
                sc.scene,
                m.method,
                m.ms_per_frame.map_or("-".into(), |v| format!("{v:.3}")),
                errors.join(" "),
            );
        }
    }
    println!("report: {}", opts.out.join("report.md").display());
    Ok(())
}

/// Longest word an error message shows whole: a message echoes what it refuses (a method
/// name, a knob, a path), and a 10 KB argument made a 10 KB line.
const LONGEST_WORD: usize = 120;

/// `message` with every word longer than [`LONGEST_WORD`] characters cut to its start and end
/// and its length.
fn elide_long_words(message: &str) -> String {
    message
        .split(' ')
        .map(|w| {
            let n = w.chars().count();
            if n <= LONGEST_WORD {
                return w.to_owned();
            }
            let head: String = w.chars().take(60).collect();
            let tail: String = w.chars().skip(n - 20).collect();
            format!("{head}...({n} characters)...{tail}")
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// An exposure as `--exposure` takes it back: four decimals, or five significant digits in
/// scientific notation outside [1e-3, 1e4] (a scene emitting 1e10 has an exposure near 1e-10,
/// printed 0.0000 before).
fn exposure_text(e: f32) -> String {
    if (1e-3..1e4).contains(&e) {
        format!("{e:.4}")
    } else {
        format!("{e:.4e}")
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_exposure_prints_as_the_flag_takes_it_back() {
        for e in [1e-10f32, 2.5e-4, 0.0123, 1.0, 27.13, 5e6] {
            let t = super::exposure_text(e);
            let back: f32 = t.parse().unwrap();
            assert!(back > 0.0 && (back / e - 1.0).abs() < 1e-3, "{e}: {t}");
        }
    }

    use super::default_compare_methods;
    use restir_world::sampling::Paths;

    /// compare without `--methods` lists what renders the paths: no `+cache` method at the
    /// default 3 bounces (they refuse bounded paths, and the whole run failed on them), all of
    /// them with unbounded paths.
    #[test]
    fn default_compare_methods_render_the_paths() {
        let bounded = default_compare_methods(&Paths::default());
        assert!(bounded.iter().any(|m| m == "world-restir"));
        assert!(
            !bounded.iter().any(|m| m.ends_with("+cache")),
            "{bounded:?}"
        );
        let unbounded = Paths {
            bounces: 64,
            ..Paths::default()
        };
        let all = default_compare_methods(&unbounded);
        assert!(all.iter().any(|m| m == "ris+cache"), "{all:?}");
        assert!(all.len() > bounded.len());
    }
}
