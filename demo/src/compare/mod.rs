//! `restir-demo compare`: speed against error. Runs each method of the registry over the same
//! frames and camera, records per-stage GPU time and the error of every frame against a
//! converged reference, runs the equal-time comparison, and writes report.md, report.json,
//! error_vs_time.svg and strip.jpg.

mod equal_time;
mod method_run;
mod output;
mod plot;
mod reference;
mod report;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use restir_world::GpuContext;
use restir_world::image_io::{self, Image};
use restir_world::methods;
use restir_world::metrics;
use restir_world::render::Paths;
use restir_world::scene::{self, Scene};

use method_run::SceneRuns;
use reference::{Reference, make_references};
pub use report::Report;
use report::SceneReport;

/// A linear RGB image's pixels.
type Rgb = Vec<[f32; 3]>;

/// Options of one compare run (the CLI fills it; tests may too).
#[derive(Debug, Clone)]
pub struct CompareOptions {
    pub scenes: Vec<String>,
    pub methods: Vec<String>,
    pub frames: u32,
    pub size: (u32, u32),
    pub out: PathBuf,
    pub camera: CameraMode,
    pub reference: Option<PathBuf>,
    pub reference_indirect: Option<PathBuf>,
    pub reference_spp: u32,
    pub cache: Option<PathBuf>,
    pub scene_opts: crate::scenes::SceneArgs,
    pub seed: u32,
    /// The depth of every method's paths and of the reference's.
    pub paths: Paths,
    pub equal_time_frames: u32,
    pub equal_time_to: Option<String>,
    pub eval_every: u32,
    pub plant_bias: Vec<(String, f32)>,
    /// The denoiser after every method (`--denoise`): its frames measured too.
    pub denoise: Option<restir_world::denoise::DenoiseConfig>,
    pub write_exr: bool,
    pub progress: bool,
}

/// How the camera moves over the frames.
pub use crate::camera::Motion as CameraMode;

/// Frames left out of the timing at the start of each run: the first holds pipeline
/// compilation and first-use costs (1369 ms against 77 ms for world-restir's later frames on
/// llvmpipe), the second still some first-use costs.
pub const TIMING_WARMUP_FRAMES: u32 = 2;

// ---------------------------------------------------------------- running

/// A scene of `--scene` with its label in the report.
fn load_scene(name: &str, label: String, opts: &CompareOptions) -> Result<(String, Scene)> {
    let s = crate::scenes::load(name, &opts.scene_opts, Some(opts.size))
        .with_context(|| format!("loading {name}"))?;
    Ok((label, s))
}

/// The labels of `--scene` in the report and the output names: a built-in scene's name, a
/// file's stem; files whose stems repeat get their position in `--scene` appended (`tri-1`,
/// `tri-2`), so that no scene's rows and reference overwrite another's.
fn scene_labels(scenes: &[String]) -> Vec<String> {
    let stem = |name: &str| -> String {
        match scene::BUILTIN_NAMES.contains(&name) {
            true => name.to_owned(),
            false => Path::new(name)
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("scene")
                .to_owned(),
        }
    };
    let stems: Vec<String> = scenes.iter().map(|n| stem(n)).collect();
    stems
        .iter()
        .enumerate()
        .map(|(i, s)| match stems.iter().filter(|t| *t == s).count() {
            1 => s.clone(),
            _ => format!("{s}-{}", i + 1),
        })
        .collect()
}

/// What [`compare_scene`] runs on a scene: the options, the listed methods' settings (in
/// `--methods` order) and the scene's label.
struct SceneJob<'a> {
    opts: &'a CompareOptions,
    settings: &'a [methods::MethodSettings],
    label: String,
}

/// Runs every method on one scene against its references, then the equal-time comparison;
/// adds the scene's row to the image strip and writes its reference EXRs (`--no-exr`: not).
fn compare_scene(
    ctx: &GpuContext,
    SceneJob {
        opts,
        settings,
        label,
    }: SceneJob,
    scene: Scene,
    strip: &mut Vec<output::StripRow>,
) -> Result<SceneReport> {
    let base = scene.camera_or_default(opts.size.0, opts.size.1);
    let bar = progress_bar(opts, &label);
    let (refs, reference) = make_references(ctx, &scene, &base, opts, &bar)?;
    if reference.source == "cache" {
        bar.set_length(opts.methods.len() as u64 * u64::from(opts.frames));
        bar.set_position(0);
    }
    let job = SceneRuns {
        ctx,
        scene: &scene,
        base,
        opts,
        settings,
        refs,
        bar,
    };
    let (runs, lasts): (Vec<_>, Vec<_>) = job
        .run_listed(&label)?
        .into_iter()
        .map(|(spec, f)| (f.run, (spec, f.last_combined)))
        .unzip();
    let equal_time = equal_time::compare(&job, &runs)?;
    job.bar.finish_and_clear();

    let last_ref = job.refs.last().context("no reference")?;
    let exposure = metrics::auto_exposure(&last_ref.combined);
    strip.push(output::StripRow::new(last_ref, lasts, exposure));
    if opts.write_exr {
        write_reference_exrs(&opts.out, &label, last_ref)?;
    }
    Ok(SceneReport {
        scene: label,
        width: opts.size.0,
        height: opts.size.1,
        camera: opts.camera,
        frames: opts.frames,
        triangles: scene.triangles.len(),
        emissive_triangles: scene.emissive_triangles(),
        reference,
        methods: runs,
        equal_time,
        exposure,
    })
}

/// A line on stderr where the progress bar is not drawn (`--quiet`, a log): long work (a
/// reference, a method's kernels compiling and its frames) is never silent there.
fn log_line(bar: &ProgressBar, line: impl FnOnce() -> String) {
    if bar.is_hidden() {
        eprintln!("{}", line());
    }
}

/// The scene's progress bar: the reference's frames (unless external), then every method's.
/// On a terminal only (indicatif hides it in logs); it ticks by itself so that the
/// reference's first frames (pipeline compilation) show.
fn progress_bar(opts: &CompareOptions, label: &str) -> ProgressBar {
    let bar = if opts.progress {
        let b = ProgressBar::new(0);
        b.enable_steady_tick(std::time::Duration::from_millis(500));
        b
    } else {
        ProgressBar::hidden()
    };
    if let Ok(s) = ProgressStyle::with_template(
        "{prefix:>12} [{elapsed_precise}] {wide_bar} {pos}/{len} eta {eta} {msg}",
    ) {
        bar.set_style(s);
    }
    bar.set_prefix(label.to_owned());
    let ref_frames = match opts.reference {
        Some(_) => 0,
        None => u64::from(opts.reference_spp.div_ceil(2) * 2),
    };
    bar.set_length(ref_frames + opts.methods.len() as u64 * u64::from(opts.frames));
    bar.set_message("reference");
    bar
}

/// `reference_LABEL.exr` (combined) and `reference_LABEL.indirect.exr` into `out`.
fn write_reference_exrs(out: &Path, label: &str, r: &Reference) -> Result<()> {
    let write = |name: String, pixels: &Vec<[f32; 3]>| -> Result<()> {
        let img = Image::from_pixels(r.width, r.height, pixels.clone())?;
        Ok(image_io::write_exr(&out.join(name), &img)?)
    };
    write(format!("reference_{label}.exr"), &r.combined)?;
    if let Some(indirect) = &r.indirect {
        write(format!("reference_{label}.indirect.exr"), indirect)?;
    }
    Ok(())
}

/// Checks the options without a GPU and without rendering: every method spec parses, no
/// method is listed twice, `--equal-time-to` and `--plant-bias` name listed methods, the
/// reference settings make sense. Returns each listed method's settings, in `--methods` order
/// (the one parse of each spec), which [`run`] takes.
pub fn check(opts: &CompareOptions) -> Result<Vec<methods::MethodSettings>> {
    if opts.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if opts.methods.is_empty() {
        bail!("--methods is empty");
    }
    if opts.scenes.is_empty() {
        bail!("--scene is empty");
    }
    // Compared by their parsed settings (`world-restir` is `world-restir:both`); a method
    // with a planted bias is a negative control and may repeat another's settings.
    let mut parsed: Vec<(&String, methods::MethodSettings)> = Vec::new();
    for m in &opts.methods {
        let settings = methods::parse_spec(m).with_context(|| format!("--methods {m}"))?;
        settings
            .check_paths(&opts.paths)
            .with_context(|| format!("--methods {m} with --bounces {}", opts.paths.bounces))?;
        let planted = |name: &String| opts.plant_bias.iter().any(|(p, _)| p == name);
        if let Some((first, _)) = parsed
            .iter()
            .find(|(n, s)| *s == settings && (*n == m || !(planted(n) || planted(m))))
        {
            if *first == m {
                bail!("--methods lists {m:?} twice (a method compared with itself)");
            }
            bail!(
                "--methods lists {first:?} and {m:?}, the same configuration (a method compared \
                 with itself)"
            );
        }
        parsed.push((m, settings));
    }
    for (i, sc) in opts.scenes.iter().enumerate() {
        if opts.scenes[..i].contains(sc) {
            bail!("--scene lists {sc:?} twice");
        }
    }
    for (m, _) in &opts.plant_bias {
        if !opts.methods.contains(m) {
            bail!("--plant-bias names {m:?}, which is not in --methods");
        }
    }
    if let Some(t) = &opts.equal_time_to
        && !opts.methods.contains(t)
    {
        bail!(
            "--equal-time-to names {t:?}, which is not in --methods ({})",
            opts.methods.join(", ")
        );
    }
    if opts.reference.is_none() && opts.reference_spp < 2 {
        bail!(
            "--reference-spp must be at least 2 (the reference is two independent halves), got {}",
            opts.reference_spp
        );
    }
    let max_spp = restir_world::gpu_reference::MAX_SPP;
    if opts.reference.is_none() && opts.reference_spp > max_spp {
        bail!(
            "--reference-spp must be at most {max_spp}, got {}",
            opts.reference_spp
        );
    }
    check_out_and_cache(opts)?;
    for p in opts.reference.iter().chain(&opts.reference_indirect) {
        let exr = p
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if !exr {
            bail!(
                "reference {}: must be a linear OpenEXR (.exr) image; an 8-bit sRGB image \
                 (PNG, JPEG) is tone-mapped and clipped, not radiance",
                p.display()
            );
        }
        if !p.is_file() {
            bail!("reference {}: missing or not a regular file", p.display());
        }
    }
    Ok(parsed.into_iter().map(|(_, settings)| settings).collect())
}

/// `--out` must not be a scene file's directory (report.md, strip.jpg, ... would overwrite
/// files next to the scene, its textures among them); `--cache` must be a directory that can
/// be created and written (checked by creating it, then removing what was created).
fn check_out_and_cache(opts: &CompareOptions) -> Result<()> {
    if let Ok(out) = opts.out.canonicalize() {
        for sc in opts
            .scenes
            .iter()
            .filter(|s| !scene::BUILTIN_NAMES.contains(&s.as_str()))
        {
            let dir = Path::new(sc).parent().filter(|d| !d.as_os_str().is_empty());
            let dir = dir.unwrap_or(Path::new("."));
            if dir.canonicalize().is_ok_and(|d| d == out) {
                bail!(
                    "--out {}: is the directory of the scene file {sc}: the outputs (report.md, \
                     strip.jpg, reference EXRs) would overwrite files next to it (its \
                     textures); choose another directory",
                    opts.out.display()
                );
            }
        }
    }
    if let Some(cache) = &opts.cache {
        let created = crate::prepare_dir(cache, "--cache")?;
        crate::remove_created(&created);
    }
    Ok(())
}

/// Runs the whole comparison of the methods [`check`] parsed (`settings`) and writes every
/// output into `opts.out`; returns the report.
pub fn run(
    ctx: &GpuContext,
    opts: &CompareOptions,
    settings: &[methods::MethodSettings],
    command: String,
) -> Result<Report> {
    if opts.frames <= TIMING_WARMUP_FRAMES {
        eprintln!(
            "warning: --frames {} is not above the {TIMING_WARMUP_FRAMES} warm-up frames GPU \
             times leave out: this run's times include them (pipeline compilation, first-use \
             costs); report.md says so",
            opts.frames
        );
    }
    // Every scene loads, and is checked against every method, before anything is rendered
    // or written.
    let loaded: Vec<(String, Scene)> = opts
        .scenes
        .iter()
        .zip(scene_labels(&opts.scenes))
        .map(|(name, label)| load_scene(name, label, opts))
        .collect::<Result<_>>()?;
    for (label, scene) in &loaded {
        let base = scene.camera_or_default(opts.size.0, opts.size.1);
        for (spec, settings) in opts.methods.iter().zip(settings) {
            settings.check_camera(&base).with_context(|| {
                format!(
                    "--size {}x{}: method {spec} on {label}",
                    opts.size.0, opts.size.1
                )
            })?;
            for w in settings.scene_warnings(scene) {
                eprintln!("warning: method {spec} on {label}: {w}");
            }
        }
    }
    crate::with_out_dir(&opts.out, || {
        run_scenes(ctx, opts, settings, command, loaded)
    })
}

fn run_scenes(
    ctx: &GpuContext,
    opts: &CompareOptions,
    settings: &[methods::MethodSettings],
    command: String,
    loaded: Vec<(String, Scene)>,
) -> Result<Report> {
    let mut scenes = Vec::new();
    let mut strip = Vec::new();
    for (label, scene) in loaded {
        let job = SceneJob {
            opts,
            settings,
            label,
        };
        scenes.push(compare_scene(ctx, job, scene, &mut strip)?);
    }
    let report = Report {
        device: ctx.info.name.clone(),
        backend: format!("{:?}", ctx.info.backend),
        device_type: format!("{:?}", ctx.info.device_type),
        driver: format!("{} {}", ctx.info.driver, ctx.info.driver_info),
        timestamps: ctx.features.timestamps,
        version: env!("CARGO_PKG_VERSION").into(),
        command,
        rel_mse_eps: metrics::REL_MSE_EPS,
        bounces: opts.paths.bounces,
        roulette_from: opts.paths.roulette_from,
        mis: opts.paths.mis,
        scenes,
    };
    output::write_all(&opts.out, &report, &strip)?;
    Ok(report)
}
