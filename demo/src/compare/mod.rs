//! `restir-demo compare`: speed against error. Runs each method of the registry over the same
//! frames and camera, records per-stage GPU time and the error of every frame against a
//! converged reference, runs the equal-time comparison, and writes report.md, report.json,
//! error_vs_time.svg and strip.png.

mod output;
mod plot;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use restir_world::GpuContext;
use restir_world::gpu::PassTimes;
use restir_world::gpu_reference::{self, GpuReference, ReferenceSettings};
use restir_world::methods::{self, FrameLoop, FrameMethod, Readback, run_frames};
use restir_world::metrics;
use restir_world::scene::{self, Camera, Scene};
use serde::Serialize;

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
    pub equal_time_frames: u32,
    pub equal_time_to: Option<String>,
    pub eval_every: u32,
    pub plant_bias: Vec<(String, f32)>,
    pub write_exr: bool,
    pub progress: bool,
}

/// How the camera moves over the frames.
pub use crate::camera::Motion as CameraMode;

fn camera_at(base: &Camera, mode: CameraMode, frames: u32, frame: u32) -> Camera {
    mode.per_frame(frames).camera(base, frame)
}

// ---------------------------------------------------------------- report data (report.json)

/// MSE, relMSE and relMSE without the 0.1% largest per-pixel errors of one image.
#[derive(Debug, Clone, Copy, Serialize, Default)]
pub struct Err2 {
    pub mse: f64,
    pub rel_mse: f64,
    pub rel_mse_trimmed: f64,
}

impl From<metrics::Errors> for Err2 {
    fn from(e: metrics::Errors) -> Self {
        Self {
            mse: e.mse,
            rel_mse: e.rel_mse,
            rel_mse_trimmed: e.rel_mse_trimmed,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Stage {
    pub name: String,
    pub ms: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct FrameRecord {
    pub frame: u32,
    /// GPU milliseconds of this frame (sum of its stages); null without timestamps.
    pub gpu_ms: Option<f64>,
    pub cumulative_gpu_ms: Option<f64>,
    pub stages: Vec<Stage>,
    /// Error of this frame's image (null when the frame has no reference: animated camera
    /// between evaluation frames, or no indirect reference).
    pub indirect: Option<Err2>,
    pub combined: Option<Err2>,
    /// Error of the direct image (the reference's combined minus its indirect).
    pub direct: Option<Err2>,
    /// relMSE of the running average of frames 0..=frame (static camera only).
    pub accumulated_rel_mse_indirect: Option<f64>,
    pub accumulated_rel_mse_combined: Option<f64>,
    /// Vertices left out of this frame's hash grid (methods with a grid).
    pub grid_overflows: Option<u32>,
}

/// Frames left out of the timing at the start of each run: the first holds pipeline
/// compilation and first-use costs (1369 ms against 77 ms for world-restir's later frames on
/// llvmpipe), the second still some first-use costs.
pub const TIMING_WARMUP_FRAMES: u32 = 2;

#[derive(Debug, Clone, Serialize)]
pub struct MethodRun {
    pub method: String,
    pub about: String,
    pub spp_per_frame: u32,
    /// A planted multiplicative bias on the indirect image (negative control), if any.
    pub planted_bias: Option<f32>,
    pub frames: u32,
    /// Frames the times are taken over: all but the first [`TIMING_WARMUP_FRAMES`] (all but
    /// the first when the run is that short).
    pub timed_frames: u32,
    /// Mean and median GPU milliseconds per timed frame, total and by stage (null without
    /// timestamps). Equal-time budgets use the median.
    pub ms_per_frame: Option<f64>,
    pub ms_per_frame_median: Option<f64>,
    pub ms_per_frame_by_stage: Vec<Stage>,
    pub ms_per_frame_by_stage_median: Vec<Stage>,
    /// Mean of the method's images over the reference's, per channel, summed over the
    /// evaluated frames (1 = no bias in the mean).
    pub bias_indirect: Option<[f64; 3]>,
    pub bias_combined: Option<[f64; 3]>,
    pub bias_direct: Option<[f64; 3]>,
    /// Most vertices left out of a frame's hash grid (methods with a grid).
    pub max_grid_overflows: Option<u32>,
    /// Mean per-frame error over the evaluated frames of the second half of the run
    /// (after warm-up for methods with temporal reuse).
    pub frame_indirect: Option<Err2>,
    pub frame_combined: Option<Err2>,
    pub frame_direct: Option<Err2>,
    /// FLIP (mean) of the last evaluated frame, tone-mapped.
    pub frame_flip_combined: Option<f64>,
    pub frame_flip_indirect: Option<f64>,
    /// Error of the average of all frames (static camera only).
    pub accumulated_indirect: Option<Err2>,
    pub accumulated_combined: Option<Err2>,
    pub accumulated_flip_combined: Option<f64>,
    pub per_frame: Vec<FrameRecord>,
}

#[derive(Debug, Clone, Serialize)]
pub struct EqualTimeEntry {
    pub method: String,
    /// Samples per pixel per frame that fit the target's GPU time per frame.
    pub spp_per_frame: u32,
    pub ms_per_frame: Option<f64>,
    pub frame_indirect: Option<Err2>,
    pub frame_combined: Option<Err2>,
    pub frame_direct: Option<Err2>,
    /// relMSE of this method at equal time divided by the target's (>1: the target is better).
    pub rel_mse_ratio_indirect: Option<f64>,
    pub rel_mse_ratio_combined: Option<f64>,
    pub rel_mse_ratio_direct: Option<f64>,
    /// The same ratio of the trimmed relMSE (robust to fireflies).
    pub rel_mse_trimmed_ratio_indirect: Option<f64>,
    pub rel_mse_trimmed_ratio_combined: Option<f64>,
    pub rel_mse_trimmed_ratio_direct: Option<f64>,
    /// GPU time this method needs to reach the target's per-frame relMSE (1/N variance law
    /// from its equal-time error) divided by the target's time per frame.
    pub equal_error_speedup_indirect: Option<f64>,
    pub equal_error_speedup_combined: Option<f64>,
    /// The same from the trimmed relMSE of the indirect image.
    pub equal_error_speedup_indirect_trimmed: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct EqualTime {
    pub target: String,
    pub target_ms_per_frame: f64,
    pub target_frame_indirect: Option<Err2>,
    pub target_frame_combined: Option<Err2>,
    pub target_frame_direct: Option<Err2>,
    pub entries: Vec<EqualTimeEntry>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ReferenceInfo {
    /// "gpu" (rendered now), "cache" or "external".
    pub source: String,
    pub estimator: String,
    pub samples: u32,
    /// Estimated relMSE of the reference itself (from two independent halves).
    pub self_rel_mse_combined: Option<f64>,
    pub self_rel_mse_indirect: Option<f64>,
    pub key: String,
    /// References rendered for an animated camera (one per evaluated frame).
    pub count: u32,
}

#[derive(Debug, Clone, Serialize)]
pub struct SceneReport {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub camera: CameraMode,
    pub frames: u32,
    pub triangles: usize,
    pub emissive_triangles: usize,
    pub reference: ReferenceInfo,
    pub methods: Vec<MethodRun>,
    pub equal_time: Option<EqualTime>,
    /// Exposure used to tone-map images for FLIP and PNGs.
    pub exposure: f32,
}

#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub device: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub timestamps: bool,
    pub version: String,
    pub command: String,
    pub rel_mse_eps: f64,
    pub scenes: Vec<SceneReport>,
}

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

/// Everything a method run needs to evaluate frames.
struct Refs {
    /// Frame index -> reference (static: one reference for every frame, key 0).
    by_frame: Vec<(u32, GpuReference)>,
    static_camera: bool,
}

impl Refs {
    fn get(&self, frame: u32) -> Option<&GpuReference> {
        if self.static_camera {
            self.by_frame.first().map(|(_, r)| r)
        } else {
            self.by_frame
                .iter()
                .find(|(f, _)| *f == frame)
                .map(|(_, r)| r)
        }
    }
}

fn style(bar: &ProgressBar) {
    if let Ok(s) = ProgressStyle::with_template(
        "{prefix:>12} [{elapsed_precise}] {wide_bar} {pos}/{len} eta {eta} {msg}",
    ) {
        bar.set_style(s);
    }
}

/// Runs one method over the frames with `spp` samples per pixel per frame.
#[allow(clippy::too_many_arguments)]
fn run_method(
    ctx: &GpuContext,
    scene: &Scene,
    base: &Camera,
    opts: &CompareOptions,
    spec: &str,
    spp: u32,
    frames: u32,
    refs: &Refs,
    bias: Option<f32>,
    bar: &ProgressBar,
    keep_last: &mut Option<Vec<[f32; 3]>>,
) -> Result<MethodRun> {
    let entry = methods::entry(spec)?;
    let mut m: Box<dyn FrameMethod> = methods::build_method(spec, ctx, scene, base, opts.seed)?;
    let pixels = (base.width * base.height) as usize;
    let static_camera = opts.camera == CameraMode::Static;
    let mut acc_ind = vec![[0f64; 3]; pixels];
    let mut acc_dir = vec![[0f64; 3]; pixels];
    let mut cumulative = 0.0f64;
    let mut records = Vec::with_capacity(frames as usize);
    // (indirect, combined, frame) of the last frame with a reference.
    let mut last_eval: Option<(Rgb, Rgb, u32)> = None;
    // Per channel: sums of the method's and the reference's pixels over the evaluated frames.
    let mut sums_indirect: Option<[[f64; 3]; 2]> = None;
    let mut sums_combined: Option<[[f64; 3]; 2]> = None;
    let mut sums_direct: Option<[[f64; 3]; 2]> = None;
    // The spans of the record in progress (spp frames, one submission each).
    let mut stages = PassTimes::default();
    let l = FrameLoop {
        records: frames,
        samples: spp,
        path: opts.camera.per_frame(opts.frames),
        restart: true,
        ..FrameLoop::frames(frames)
    };
    run_frames(ctx, m.as_mut(), &l, |m, s| -> Result<()> {
        if let Some(t) = s.times {
            stages.add(t);
        }
        if !s.record_done {
            return Ok(());
        }
        let f = s.record;
        let timed = std::mem::take(&mut stages);
        let gpu_ms = s.times.map(|_| timed.total_ms());
        if let Some(ms) = gpu_ms {
            cumulative += ms;
        }
        let images = m.read(ctx, Readback::Accumulated)?;
        let direct = images.direct;
        let mut indirect = images.indirect;
        if let Some(b) = bias {
            for p in &mut indirect {
                *p = p.map(|v| v * b);
            }
        }
        let combined: Vec<[f32; 3]> = direct
            .iter()
            .zip(&indirect)
            .map(|(d, i)| [d[0] + i[0], d[1] + i[1], d[2] + i[2]])
            .collect();
        let mut rec = FrameRecord {
            frame: f,
            gpu_ms,
            cumulative_gpu_ms: gpu_ms.map(|_| cumulative),
            stages: timed
                .passes
                .into_iter()
                .map(|(name, ms)| Stage { name, ms })
                .collect(),
            indirect: None,
            combined: None,
            direct: None,
            accumulated_rel_mse_indirect: None,
            accumulated_rel_mse_combined: None,
            grid_overflows: m.grid_overflows(ctx)?,
        };
        if let Some(r) = refs.get(f) {
            add_channel_sums(&mut sums_combined, &combined, &r.combined);
            if let Some(ri) = &r.indirect {
                add_channel_sums(&mut sums_indirect, &indirect, ri);
            }
            rec.combined = Some(metrics::errors(&combined, &r.combined)?.into());
            if let Some(ri) = &r.indirect {
                rec.indirect = Some(metrics::errors(&indirect, ri)?.into());
                let rd = r.direct().context("reference direct image")?;
                add_channel_sums(&mut sums_direct, &direct, &rd);
                rec.direct = Some(metrics::errors(&direct, &rd)?.into());
            }
            if static_camera {
                let n = f64::from(f + 1);
                for (a, p) in acc_ind.iter_mut().zip(&indirect) {
                    for c in 0..3 {
                        a[c] += f64::from(p[c]);
                    }
                }
                for (a, p) in acc_dir.iter_mut().zip(&direct) {
                    for c in 0..3 {
                        a[c] += f64::from(p[c]);
                    }
                }
                let avg_ind: Vec<[f32; 3]> =
                    acc_ind.iter().map(|a| a.map(|v| (v / n) as f32)).collect();
                let avg_comb: Vec<[f32; 3]> = acc_ind
                    .iter()
                    .zip(&acc_dir)
                    .map(|(i, d)| [0, 1, 2].map(|c| ((i[c] + d[c]) / n) as f32))
                    .collect();
                rec.accumulated_rel_mse_combined = Some(metrics::rel_mse(&avg_comb, &r.combined)?);
                if let Some(ri) = &r.indirect {
                    rec.accumulated_rel_mse_indirect = Some(metrics::rel_mse(&avg_ind, ri)?);
                }
            }
            last_eval = Some((indirect, combined, f));
        }
        records.push(rec);
        bar.inc(1);
        Ok(())
    })?;

    let half = frames / 2;
    let mean_err = |pick: fn(&FrameRecord) -> Option<Err2>| -> Option<Err2> {
        let v: Vec<Err2> = records
            .iter()
            .filter(|r| r.frame >= half || frames == 1)
            .filter_map(pick)
            .collect();
        let n = v.len() as f64;
        (!v.is_empty()).then(|| Err2 {
            mse: v.iter().map(|e| e.mse).sum::<f64>() / n,
            rel_mse: v.iter().map(|e| e.rel_mse).sum::<f64>() / n,
            rel_mse_trimmed: v.iter().map(|e| e.rel_mse_trimmed).sum::<f64>() / n,
        })
    };
    let frame_indirect = mean_err(|r| r.indirect);
    let frame_combined = mean_err(|r| r.combined);
    let frame_direct = mean_err(|r| r.direct);
    let timed = &records[TIMING_WARMUP_FRAMES.min(frames.saturating_sub(1)) as usize..];
    let times = TimeSummary::of(timed, ctx.features.timestamps);
    let mut run = MethodRun {
        method: spec.to_owned(),
        about: entry.about.to_owned(),
        spp_per_frame: spp,
        planted_bias: bias,
        frames,
        timed_frames: timed.len() as u32,
        ms_per_frame: times.mean,
        ms_per_frame_median: times.median,
        ms_per_frame_by_stage: times.stage_means,
        ms_per_frame_by_stage_median: times.stage_medians,
        bias_indirect: sums_indirect.map(channel_ratio),
        bias_combined: sums_combined.map(channel_ratio),
        bias_direct: sums_direct.map(channel_ratio),
        max_grid_overflows: records.iter().filter_map(|r| r.grid_overflows).max(),
        frame_indirect,
        frame_combined,
        frame_direct,
        frame_flip_combined: None,
        frame_flip_indirect: None,
        accumulated_indirect: None,
        accumulated_combined: None,
        accumulated_flip_combined: None,
        per_frame: records,
    };
    if let Some((ind, comb, f)) = last_eval
        && let Some(r) = refs.get(f)
    {
        let (w, h) = (r.width, r.height);
        let exposure = metrics::auto_exposure(&r.combined);
        run.frame_flip_combined = Some(metrics::flip(&comb, &r.combined, w, h, exposure)?.0);
        if let Some(ri) = &r.indirect {
            let e = metrics::auto_exposure(ri);
            run.frame_flip_indirect = Some(metrics::flip(&ind, ri, w, h, e)?.0);
        }
        if static_camera {
            let n = f64::from(frames);
            let avg_ind: Vec<[f32; 3]> =
                acc_ind.iter().map(|a| a.map(|v| (v / n) as f32)).collect();
            let avg_comb: Vec<[f32; 3]> = acc_ind
                .iter()
                .zip(&acc_dir)
                .map(|(i, d)| [0, 1, 2].map(|c| ((i[c] + d[c]) / n) as f32))
                .collect();
            run.accumulated_combined = Some(metrics::errors(&avg_comb, &r.combined)?.into());
            run.accumulated_flip_combined =
                Some(metrics::flip(&avg_comb, &r.combined, w, h, exposure)?.0);
            if let Some(ri) = &r.indirect {
                run.accumulated_indirect = Some(metrics::errors(&avg_ind, ri)?.into());
            }
        }
        *keep_last = Some(comb);
    }
    Ok(run)
}

/// Adds the per-channel sums of `img` and `reference` to `sums`.
fn add_channel_sums(sums: &mut Option<[[f64; 3]; 2]>, img: &[[f32; 3]], reference: &[[f32; 3]]) {
    let s = sums.get_or_insert([[0.0; 3]; 2]);
    for (a, r) in img.iter().zip(reference) {
        for c in 0..3 {
            s[0][c] += f64::from(a[c]);
            s[1][c] += f64::from(r[c]);
        }
    }
}

/// Method sum over reference sum, per channel (NaN where the reference is 0).
fn channel_ratio(sums: [[f64; 3]; 2]) -> [f64; 3] {
    [0, 1, 2].map(|c| sums[0][c] / sums[1][c])
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// Mean and median GPU time per frame, total and by stage, over some frames.
struct TimeSummary {
    mean: Option<f64>,
    median: Option<f64>,
    stage_means: Vec<Stage>,
    stage_medians: Vec<Stage>,
}

impl TimeSummary {
    fn of(frames: &[FrameRecord], timestamps: bool) -> Self {
        let totals: Vec<f64> = frames.iter().filter_map(|r| r.gpu_ms).collect();
        if !timestamps || totals.is_empty() {
            return Self {
                mean: None,
                median: None,
                stage_means: Vec::new(),
                stage_medians: Vec::new(),
            };
        }
        let n = totals.len() as f64;
        let mut names: Vec<&str> = Vec::new();
        for st in frames.iter().flat_map(|r| &r.stages) {
            if !names.contains(&st.name.as_str()) {
                names.push(&st.name);
            }
        }
        let per_stage = |name: &str| -> Vec<f64> {
            frames
                .iter()
                .map(|r| {
                    r.stages
                        .iter()
                        .filter(|s| s.name == name)
                        .map(|s| s.ms)
                        .sum()
                })
                .collect()
        };
        let stage = |name: &str, ms: f64| Stage {
            name: name.to_owned(),
            ms,
        };
        Self {
            mean: Some(totals.iter().sum::<f64>() / n),
            median: median(totals),
            stage_means: names
                .iter()
                .map(|&name| stage(name, per_stage(name).iter().sum::<f64>() / n))
                .collect(),
            stage_medians: names
                .iter()
                .map(|&name| stage(name, median(per_stage(name)).unwrap_or(0.0)))
                .collect(),
        }
    }
}

fn make_references(
    ctx: &GpuContext,
    scene: &Scene,
    base: &Camera,
    opts: &CompareOptions,
    bar: &ProgressBar,
) -> Result<(Refs, ReferenceInfo)> {
    let settings = ReferenceSettings {
        spp: opts.reference_spp,
        ..Default::default()
    };
    let estimator = format!("{:?}", settings.method);
    if let Some(path) = &opts.reference {
        if opts.camera != CameraMode::Static {
            bail!("--reference needs --animation static (one image for every frame)");
        }
        let r = gpu_reference::external(path, opts.reference_indirect.as_deref(), base)?;
        let info = ReferenceInfo {
            source: "external".into(),
            estimator: format!("external file {}", path.display()),
            samples: 0,
            self_rel_mse_combined: None,
            self_rel_mse_indirect: None,
            key: String::new(),
            count: 1,
        };
        return Ok((
            Refs {
                by_frame: vec![(0, r)],
                static_camera: true,
            },
            info,
        ));
    }
    let eval: Vec<u32> = match opts.camera {
        CameraMode::Static => vec![0],
        CameraMode::Orbit | CameraMode::Dolly => {
            let every = opts.eval_every.max(1);
            let mut v: Vec<u32> = (0..opts.frames).filter(|f| (f + 1) % every == 0).collect();
            if v.last() != Some(&(opts.frames - 1)) {
                v.push(opts.frames - 1);
            }
            v
        }
    };
    let mut by_frame = Vec::new();
    let mut sources = Vec::new();
    for &f in &eval {
        let cam = camera_at(base, opts.camera, opts.frames, f);
        let r = gpu_reference::load_or_render(
            ctx,
            scene,
            &cam,
            &settings,
            opts.cache.as_deref(),
            |n| bar.inc(u64::from(n)),
        )?;
        if let Some(note) = &r.cache_note {
            bar.suspend(|| eprintln!("warning: {note}"));
        }
        sources.push(r.from_cache);
        by_frame.push((f, r));
    }
    let first = &by_frame[0].1;
    let mean = |pick: fn(&GpuReference) -> Option<f64>| -> Option<f64> {
        let v: Vec<f64> = by_frame.iter().filter_map(|(_, r)| pick(r)).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let info = ReferenceInfo {
        source: if sources.iter().all(|&c| c) {
            "cache".into()
        } else {
            "gpu".into()
        },
        estimator,
        samples: first.samples,
        self_rel_mse_combined: mean(|r| r.self_rel_mse.map(|x| x.0)),
        self_rel_mse_indirect: mean(|r| r.self_rel_mse.map(|x| x.1)),
        key: first.key.clone(),
        count: by_frame.len() as u32,
    };
    Ok((
        Refs {
            by_frame,
            static_camera: opts.camera == CameraMode::Static,
        },
        info,
    ))
}

/// The method equal-time comparisons are measured against: `--equal-time-to`, else the first
/// listed method the registry marks as the target (world-space ReSTIR), else the slowest.
fn equal_time_target(opts: &CompareOptions, runs: &[MethodRun]) -> Option<usize> {
    if let Some(t) = &opts.equal_time_to {
        return runs.iter().position(|r| &r.method == t);
    }
    if let Some(i) = runs.iter().position(|r| {
        methods::entry(&r.method).is_ok_and(|e| e.equal_time_target) && r.planted_bias.is_none()
    }) {
        return Some(i);
    }
    runs.iter()
        .enumerate()
        .filter(|(_, r)| r.planted_bias.is_none())
        .filter_map(|(i, r)| r.ms_per_frame_median.map(|ms| (i, ms)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

fn ratio(a: Option<Err2>, b: Option<Err2>, pick: fn(&Err2) -> f64) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if pick(&b) > 0.0 => Some(pick(&a) / pick(&b)),
        _ => None,
    }
}

fn compare_scene(
    ctx: &GpuContext,
    label: String,
    scene: Scene,
    opts: &CompareOptions,
    strip: &mut Vec<output::StripRow>,
) -> Result<SceneReport> {
    let base = scene.camera_or_default(opts.size.0, opts.size.1);
    // On a terminal only (indicatif hides it in logs); it ticks by itself so that the
    // reference's first frames (pipeline compilation) show.
    let bar = if opts.progress {
        let b = ProgressBar::new(0);
        b.enable_steady_tick(std::time::Duration::from_millis(500));
        b
    } else {
        ProgressBar::hidden()
    };
    style(&bar);
    bar.set_prefix(label.clone());
    let ref_frames = if opts.reference.is_some() {
        0
    } else {
        u64::from(opts.reference_spp.div_ceil(2) * 2)
    };
    bar.set_length(ref_frames + opts.methods.len() as u64 * u64::from(opts.frames));
    bar.set_message("reference");
    let (refs, ref_info) = make_references(ctx, &scene, &base, opts, &bar)?;
    if ref_info.source == "cache" {
        bar.set_length(opts.methods.len() as u64 * u64::from(opts.frames));
        bar.set_position(0);
    }

    let mut runs = Vec::new();
    let mut lasts = Vec::new();
    for spec in &opts.methods {
        bar.set_message(spec.clone());
        let bias = opts
            .plant_bias
            .iter()
            .find(|(m, _)| m == spec)
            .map(|(_, b)| *b);
        let mut last = None;
        let run = run_method(
            ctx,
            &scene,
            &base,
            opts,
            spec,
            1,
            opts.frames,
            &refs,
            bias,
            &bar,
            &mut last,
        )
        .with_context(|| format!("{label}: method {spec}"))?;
        lasts.push((spec.clone(), last));
        runs.push(run);
    }

    // Equal time: each other method at the spp that fits the target's GPU time per frame.
    let mut equal_time = None;
    if let Some(t) = equal_time_target(opts, &runs)
        && let Some(t_ms) = runs[t].ms_per_frame_median
    {
        let target = runs[t].clone();
        let mut entries = Vec::new();
        for (i, run) in runs.iter().enumerate() {
            if i == t || run.planted_bias.is_some() {
                continue;
            }
            let Some(ms1) = run.ms_per_frame_median else {
                continue;
            };
            let k = ((t_ms / ms1.max(1e-9)).floor() as u32).clamp(1, 4096);
            let eq = if k == 1 {
                run.clone()
            } else {
                let frames = opts.equal_time_frames.clamp(1, opts.frames);
                bar.inc_length(u64::from(frames));
                bar.set_message(format!("{} x{k} spp", run.method));
                run_method(
                    ctx,
                    &scene,
                    &base,
                    opts,
                    &run.method,
                    k,
                    frames,
                    &refs,
                    None,
                    &bar,
                    &mut None,
                )?
            };
            let speedup = |e: Option<Err2>, te: Option<Err2>, pick: fn(&Err2) -> f64| {
                let (e, te, ms) = (e?, te?, eq.ms_per_frame_median?);
                (pick(&te) > 0.0).then(|| ms * (pick(&e) / pick(&te)) / t_ms)
            };
            let rel: fn(&Err2) -> f64 = |e| e.rel_mse;
            let trim: fn(&Err2) -> f64 = |e| e.rel_mse_trimmed;
            entries.push(EqualTimeEntry {
                method: run.method.clone(),
                spp_per_frame: k,
                ms_per_frame: eq.ms_per_frame_median,
                frame_indirect: eq.frame_indirect,
                frame_combined: eq.frame_combined,
                frame_direct: eq.frame_direct,
                rel_mse_ratio_indirect: ratio(eq.frame_indirect, target.frame_indirect, rel),
                rel_mse_ratio_combined: ratio(eq.frame_combined, target.frame_combined, rel),
                rel_mse_ratio_direct: ratio(eq.frame_direct, target.frame_direct, rel),
                rel_mse_trimmed_ratio_indirect: ratio(
                    eq.frame_indirect,
                    target.frame_indirect,
                    trim,
                ),
                rel_mse_trimmed_ratio_combined: ratio(
                    eq.frame_combined,
                    target.frame_combined,
                    trim,
                ),
                rel_mse_trimmed_ratio_direct: ratio(eq.frame_direct, target.frame_direct, trim),
                equal_error_speedup_indirect: speedup(
                    eq.frame_indirect,
                    target.frame_indirect,
                    rel,
                ),
                equal_error_speedup_combined: speedup(
                    eq.frame_combined,
                    target.frame_combined,
                    rel,
                ),
                equal_error_speedup_indirect_trimmed: speedup(
                    eq.frame_indirect,
                    target.frame_indirect,
                    trim,
                ),
            });
        }
        equal_time = Some(EqualTime {
            target: target.method.clone(),
            target_ms_per_frame: t_ms,
            target_frame_indirect: target.frame_indirect,
            target_frame_combined: target.frame_combined,
            target_frame_direct: target.frame_direct,
            entries,
        });
    }
    bar.finish_and_clear();

    let last_ref = &refs.by_frame.last().context("no reference")?.1;
    let exposure = metrics::auto_exposure(&last_ref.combined);
    strip.push(output::StripRow {
        width: last_ref.width,
        height: last_ref.height,
        reference: last_ref.combined.clone(),
        // The strip shows the methods without a variant (one column each), all when every
        // listed method is a variant: variants live in the tables and the plot.
        methods: {
            let plain: Vec<_> = lasts
                .iter()
                .filter(|(n, _)| !n.contains(':'))
                .cloned()
                .collect();
            if plain.is_empty() { lasts } else { plain }
        },
        exposure,
    });
    if opts.write_exr {
        let img = restir_world::image_io::Image::from_pixels(
            last_ref.width,
            last_ref.height,
            last_ref.combined.clone(),
        )?;
        restir_world::image_io::write_exr(&opts.out.join(format!("reference_{label}.exr")), &img)?;
        if let Some(ind) = &last_ref.indirect {
            let img = restir_world::image_io::Image::from_pixels(
                last_ref.width,
                last_ref.height,
                ind.clone(),
            )?;
            restir_world::image_io::write_exr(
                &opts.out.join(format!("reference_{label}.indirect.exr")),
                &img,
            )?;
        }
    }
    Ok(SceneReport {
        scene: label,
        width: opts.size.0,
        height: opts.size.1,
        camera: opts.camera,
        frames: opts.frames,
        triangles: scene.triangles.len(),
        emissive_triangles: scene.emissive_triangles(),
        reference: ref_info,
        methods: runs,
        equal_time,
        exposure,
    })
}

/// Checks the options without a GPU and without rendering: every method spec parses, no
/// method is listed twice, `--equal-time-to` and `--plant-bias` name listed methods, the
/// reference settings make sense. [`run`] calls it first; tools may call it earlier.
pub fn check(opts: &CompareOptions) -> Result<()> {
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
    Ok(())
}

/// `--out` must not be a scene file's directory (report.md, strip.png, ... would overwrite
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
                     strip.png, reference EXRs) would overwrite files next to it (its \
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

/// Runs the whole comparison and writes every output into `opts.out`; returns the report.
pub fn run(ctx: &GpuContext, opts: &CompareOptions, command: String) -> Result<Report> {
    check(opts)?;
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
        for spec in &opts.methods {
            methods::check_camera(spec, &base).with_context(|| {
                format!(
                    "--size {}x{}: method {spec} on {label}: use a larger --size",
                    opts.size.0, opts.size.1
                )
            })?;
        }
    }
    crate::with_out_dir(&opts.out, || run_scenes(ctx, opts, command, loaded))
}

fn run_scenes(
    ctx: &GpuContext,
    opts: &CompareOptions,
    command: String,
    loaded: Vec<(String, Scene)>,
) -> Result<Report> {
    let mut scenes = Vec::new();
    let mut strip = Vec::new();
    for (label, scene) in loaded {
        scenes.push(compare_scene(ctx, label, scene, opts, &mut strip)?);
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
        scenes,
    };
    output::write_all(&opts.out, &report, &strip)?;
    Ok(report)
}
