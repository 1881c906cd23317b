//! One method's run over a scene's frames: each frame's GPU time and errors, then the run's
//! summary (times over the timed frames, errors over the second half, the accumulated image,
//! FLIP, bias).

use anyhow::{Context, Result};
use indicatif::ProgressBar;
use restir_world::GpuContext;
use restir_world::gpu::PassTimes;
use restir_world::images::FrameImages;
use restir_world::methods::{FrameLoop, MethodSettings, Readback, run_frames};
use restir_world::metrics;
use restir_world::render::RenderOptions;
use restir_world::scene::{Camera, Scene};

use super::reference::{Reference, Refs};
use super::report::{
    CacheUse, DenoisedErrors, Err2, FrameError, FrameRecord, ImageErrors, MethodRun, PerImage,
    RunImages, Stage,
};
use super::{CameraMode, CompareOptions, Rgb, TIMING_WARMUP_FRAMES};

/// What every run on one scene shares.
pub struct SceneRuns<'a> {
    pub ctx: &'a GpuContext,
    pub scene: &'a Scene,
    pub base: Camera,
    pub opts: &'a CompareOptions,
    /// The listed methods' settings, in `--methods` order.
    pub settings: &'a [MethodSettings],
    pub refs: Refs,
    pub bar: ProgressBar,
}

/// A run of a method and its last evaluated combined image (for the strip).
pub struct Finished {
    pub run: MethodRun,
    pub last_combined: Option<Rgb>,
}

impl SceneRuns<'_> {
    /// Every `--methods` entry at one sample per pixel per frame, over `--frames` frames.
    pub fn run_listed(&self, label: &str) -> Result<Vec<(String, Finished)>> {
        let opts = self.opts;
        let mut done = Vec::new();
        for (spec, settings) in opts.methods.iter().zip(self.settings) {
            self.bar.set_message(spec.clone());
            let bias = opts.plant_bias.iter().find(|(m, _)| m == spec);
            let run = RunSpec {
                spec,
                settings,
                spp: 1,
                frames: opts.frames,
                bias: bias.map(|(_, b)| *b),
            };
            let start = std::time::Instant::now();
            super::log_line(&self.bar, || {
                format!(
                    "{label}: {spec}: {} frames (its kernels compile on their first use: \
                     minutes on a CPU adapter)",
                    opts.frames
                )
            });
            let finished = self
                .run(&run)
                .with_context(|| format!("{label}: method {spec}"))?;
            super::log_line(&self.bar, || {
                format!(
                    "{label}: {spec}: done in {:.1} s",
                    start.elapsed().as_secs_f64()
                )
            });
            done.push((spec.clone(), finished));
        }
        Ok(done)
    }

    /// `spec` at `spp` samples per pixel per frame over `--equal-time-frames` frames.
    /// Listed method `i` at `spp` samples per pixel per frame.
    pub fn run_equal_time(&self, i: usize, spp: u32) -> Result<MethodRun> {
        let spec = &self.opts.methods[i];
        let frames = self.opts.equal_time_frames.clamp(1, self.opts.frames);
        self.bar.inc_length(u64::from(frames));
        self.bar.set_message(format!("{spec} x{spp} spp"));
        let run = RunSpec {
            spec,
            settings: &self.settings[i],
            spp,
            frames,
            bias: None,
        };
        Ok(self.run(&run)?.run)
    }

    fn run(&self, run: &RunSpec) -> Result<Finished> {
        let (ctx, opts) = (self.ctx, self.opts);
        let options = RenderOptions {
            seed: opts.seed,
            paths: opts.paths,
            ..Default::default()
        };
        let settings = MethodSettings {
            denoise: opts.denoise,
            ..*run.settings
        };
        let mut m = crate::render_cmd::build(&settings, ctx, self.scene, &self.base, &options)?;
        let pixels = (self.base.width * self.base.height) as usize;
        let static_camera = opts.camera == CameraMode::Static;
        let mut tally = Tally::new(static_camera.then(|| Accumulator::new(pixels)));
        // The spans of the record in progress (spp frames, one submission each).
        let mut spans = PassTimes::default();
        let l = FrameLoop {
            records: run.frames,
            samples: run.spp,
            path: opts.camera.per_frame(opts.frames),
            restart: true,
            ..FrameLoop::frames(run.frames)
        };
        run_frames(ctx, m.as_mut(), &l, |m, s| -> Result<()> {
            if let Some(t) = s.times {
                spans.add(t);
            }
            tally.dispatches.0 += u64::from(s.dispatches);
            tally.dispatches.1 += u64::from(s.frames);
            if !s.record_done {
                return Ok(());
            }
            let record = std::mem::take(&mut spans);
            let times = s.times.map(|_| PassTimes {
                frames: 1,
                ..record
            });
            let images = method_images(m.read(ctx, Readback::Accumulated)?, run.bias);
            let denoised = m.read_denoised(ctx)?.map(|d| d.combined());
            let overflows = m.grid_overflows(ctx)?;
            if let Some(c) = m.cache_stats(ctx)? {
                tally.cache = Some(CacheUse::add(tally.cache, &c));
            }
            let frame = Frame {
                index: s.record,
                images,
                denoised,
                times,
                grid_overflows: overflows,
            };
            tally.record(frame, self.refs.get(s.record))?;
            self.bar.inc(1);
            Ok(())
        })?;
        tally.reuse_bytes_per_pixel = m.reuse_bytes().map(|b| b as f64 / pixels as f64);
        tally.bytes_per_pixel = m.frame_bytes() as f64 / pixels as f64;
        tally.finish(run, &self.refs)
    }
}

/// One run: a method at `spp` samples per pixel per frame over `frames` frames; `bias`
/// scales its indirect image (a planted defect).
struct RunSpec<'a> {
    spec: &'a str,
    settings: &'a MethodSettings,
    spp: u32,
    frames: u32,
    bias: Option<f32>,
}

/// A frame's images as the run measures them: the indirect image scaled by a planted `bias`,
/// the combined image the sum of direct and (scaled) indirect.
fn method_images(mut images: FrameImages, bias: Option<f32>) -> PerImage<Rgb> {
    if let Some(b) = bias {
        for p in &mut images.indirect {
            *p = p.map(|v| v * b);
        }
    }
    let combined = images.combined();
    PerImage {
        direct: images.direct,
        indirect: images.indirect,
        combined,
    }
}

/// The running sum of a static camera's frames, in f64.
struct Accumulator {
    direct: Vec<[f64; 3]>,
    indirect: Vec<[f64; 3]>,
    frames: u32,
}

impl Accumulator {
    fn new(pixels: usize) -> Self {
        Self {
            direct: vec![[0.0; 3]; pixels],
            indirect: vec![[0.0; 3]; pixels],
            frames: 0,
        }
    }

    fn add(&mut self, images: &PerImage<Rgb>) {
        for (sum, image) in [
            (&mut self.direct, &images.direct),
            (&mut self.indirect, &images.indirect),
        ] {
            for (s, p) in sum.iter_mut().zip(image) {
                for c in 0..3 {
                    s[c] += f64::from(p[c]);
                }
            }
        }
        self.frames += 1;
    }

    /// The average of each image; combined as the sum of the direct and indirect averages.
    fn average(&self) -> PerImage<Rgb> {
        let n = f64::from(self.frames.max(1));
        let average = |sum: &[[f64; 3]]| sum.iter().map(|s| s.map(|v| (v / n) as f32)).collect();
        let combined = self.indirect.iter().zip(&self.direct);
        PerImage {
            direct: average(&self.direct),
            indirect: average(&self.indirect),
            combined: combined
                .map(|(i, d)| [0, 1, 2].map(|c| ((i[c] + d[c]) / n) as f32))
                .collect(),
        }
    }
}

/// One frame of a run as read back.
struct Frame {
    index: u32,
    images: PerImage<Rgb>,
    /// The frame denoised (combined), with `--denoise`.
    denoised: Option<Rgb>,
    times: Option<PassTimes>,
    grid_overflows: Option<u32>,
}

/// The denoised frames of a run: their errors and stability.
#[derive(Default)]
struct DenoisedTally {
    /// Per channel: sums of the denoised and the reference pixels over the evaluated frames.
    sums: Option<[[f64; 3]; 2]>,
    /// The last evaluated frame: its index, denoised image and raw combined image, and its
    /// reference's combined image.
    last: Option<(u32, Rgb, Rgb, Rgb)>,
    /// Per evaluated frame whose frame before was evaluated too: the denoised and the raw
    /// frame-to-frame change against the reference's.
    changes: Vec<(f64, f64)>,
}

/// What a run gathers frame by frame.
struct Tally {
    records: Vec<FrameRecord>,
    /// Each record's spans as one frame (`None` without timestamps), in record order.
    times: Vec<Option<PassTimes>>,
    cumulative_ms: f64,
    /// Per image and channel: sums of the method's and the reference's pixels over the
    /// evaluated frames.
    sums: PerImage<Option<[[f64; 3]; 2]>>,
    /// The running sum of the frames (static camera only).
    accumulated: Option<Accumulator>,
    /// The last frame with a reference and its images.
    last_eval: Option<(u32, PerImage<Rgb>)>,
    cache: Option<CacheUse>,
    reuse_bytes_per_pixel: Option<f64>,
    bytes_per_pixel: f64,
    denoised: DenoisedTally,
    /// Compute dispatches and the frames they were recorded for.
    dispatches: (u64, u64),
}

/// Mean over pixels and channels of ((a - a_before) - (r - r_before))^2 / (r^2 + 0.01): the
/// change of an image from one frame to the next against its reference's change.
fn change_error(a: &Rgb, a_before: &Rgb, r: &Rgb, r_before: &Rgb) -> f64 {
    let n = (a.len() * 3).max(1) as f64;
    let mut sum = 0.0;
    for (((p, pb), q), qb) in a.iter().zip(a_before).zip(r).zip(r_before) {
        for c in 0..3 {
            let d = f64::from(p[c] - pb[c]) - f64::from(q[c] - qb[c]);
            let r = f64::from(q[c]);
            sum += d * d / (r * r + 0.01);
        }
    }
    sum / n
}

impl Tally {
    fn new(accumulated: Option<Accumulator>) -> Self {
        Self {
            records: Vec::new(),
            times: Vec::new(),
            cumulative_ms: 0.0,
            sums: PerImage::default(),
            accumulated,
            last_eval: None,
            cache: None,
            reuse_bytes_per_pixel: None,
            bytes_per_pixel: 0.0,
            denoised: DenoisedTally::default(),
            dispatches: (0, 0),
        }
    }

    /// Records a frame: its times, and its errors when it has a `reference`.
    fn record(&mut self, f: Frame, reference: Option<&Reference>) -> Result<()> {
        let Frame {
            index: frame,
            images,
            denoised,
            times,
            grid_overflows,
        } = f;
        let denoised_error = match (&denoised, reference) {
            (Some(d), Some(r)) => Some(self.evaluate_denoised(frame, d, &images.combined, r)?),
            _ => None,
        };
        let gpu_ms = times.as_ref().map(PassTimes::total_ms);
        self.cumulative_ms += gpu_ms.unwrap_or(0.0);
        if let Some(acc) = &mut self.accumulated {
            acc.add(&images);
        }
        let errors = match reference {
            Some(r) => self.evaluate(&images, r)?,
            None => PerImage::default(),
        };
        if reference.is_some() {
            self.last_eval = Some((frame, images));
        }
        self.records.push(FrameRecord {
            frame,
            gpu_ms,
            cumulative_gpu_ms: gpu_ms.map(|_| self.cumulative_ms),
            stages: times
                .as_ref()
                .map_or_else(Vec::new, |t| Stage::list(t.passes.clone())),
            images: errors,
            denoised: denoised_error,
            grid_overflows,
        });
        self.times.push(times);
        Ok(())
    }

    /// A frame's error on each image the reference has; adds to the bias sums.
    fn evaluate(
        &mut self,
        images: &PerImage<Rgb>,
        r: &Reference,
    ) -> Result<PerImage<Option<FrameError>>> {
        let average = self.accumulated.as_ref().map(Accumulator::average);
        PerImage::try_from_fn(|k| {
            let Some(reference) = r.image(k) else {
                return Ok(None);
            };
            add_channel_sums(self.sums.get_mut(k), images.get(k), reference);
            let accumulated_rel_mse = match &average {
                Some(avg) => Some(metrics::rel_mse(avg.get(k), reference)?),
                None => None,
            };
            Ok(Some(FrameError {
                error: metrics::errors(images.get(k), reference)?.into(),
                accumulated_rel_mse,
            }))
        })
    }

    /// The denoised frame `frame` (`raw`: its combined image) against `r`: its error; adds to
    /// the bias sums and, when the frame before was evaluated, the frame-to-frame changes.
    fn evaluate_denoised(
        &mut self,
        frame: u32,
        denoised: &Rgb,
        raw: &Rgb,
        r: &Reference,
    ) -> Result<FrameError> {
        let t = &mut self.denoised;
        add_channel_sums(&mut t.sums, denoised, &r.combined);
        if let Some((before, d0, raw0, r0)) = &t.last
            && before + 1 == frame
        {
            t.changes.push((
                change_error(denoised, d0, &r.combined, r0),
                change_error(raw, raw0, &r.combined, r0),
            ));
        }
        t.last = Some((frame, denoised.clone(), raw.clone(), r.combined.clone()));
        Ok(FrameError {
            error: metrics::errors(denoised, &r.combined)?.into(),
            accumulated_rel_mse: None,
        })
    }

    /// The denoised frames' errors over the run (as [`Self::image_errors`]' combined image's).
    fn denoised_errors(&self, refs: &Refs) -> Result<Option<DenoisedErrors>> {
        let t = &self.denoised;
        let Some((frame, image, _, _)) = &t.last else {
            return Ok(None);
        };
        let frames = self.records.len() as u32;
        let errors: Vec<Err2> = self
            .records
            .iter()
            .filter(|r| r.frame >= frames / 2 || frames == 1)
            .filter_map(|r| r.denoised.map(|e| e.error))
            .collect();
        let mut e = ImageErrors {
            frame: Err2::mean(&errors),
            bias: t.sums.map(channel_ratio),
            ..ImageErrors::default()
        };
        if let Some(r) = refs.get(*frame) {
            let exposure = metrics::auto_exposure(&r.combined);
            e.frame_flip = Some(metrics::flip(image, &r.combined, r.width, r.height, exposure)?.0);
        }
        let n = t.changes.len() as f64;
        let mean = |pick: fn(&(f64, f64)) -> f64| {
            (n > 0.0).then(|| t.changes.iter().map(pick).sum::<f64>() / n)
        };
        Ok(Some(DenoisedErrors {
            errors: e,
            temporal_change: mean(|c| c.0),
            raw_temporal_change: mean(|c| c.1),
        }))
    }

    /// The run's report and its last evaluated combined image.
    fn finish(self, run: &RunSpec, refs: &Refs) -> Result<Finished> {
        let frames = self.records.len() as u32;
        let skip = TIMING_WARMUP_FRAMES.min(frames.saturating_sub(1)) as usize;
        let timed: Vec<PassTimes> = self.times[skip..].iter().flatten().cloned().collect();
        let sum = (!timed.is_empty()).then(|| PassTimes::sum(&timed));
        let by_stage = sum.as_ref().map_or_else(Vec::new, PassTimes::per_frame);
        let report = MethodRun {
            method: run.spec.to_owned(),
            about: run.settings.entry.about.to_owned(),
            spp_per_frame: run.spp,
            planted_bias: run.bias,
            frames: run.frames,
            timed_frames: frames - skip as u32,
            ms_per_frame: sum.as_ref().map(PassTimes::ms_per_frame),
            ms_per_frame_median: PassTimes::median_ms_per_frame(&timed),
            ms_per_frame_by_stage: Stage::list(by_stage),
            ms_per_frame_by_stage_median: Stage::list(PassTimes::median_per_frame(&timed)),
            max_grid_overflows: self.records.iter().filter_map(|r| r.grid_overflows).max(),
            cache: self.cache,
            reuse_bytes_per_pixel: self.reuse_bytes_per_pixel,
            bytes_per_pixel: self.bytes_per_pixel,
            dispatches_per_frame: self.dispatches.0 as f64 / self.dispatches.1.max(1) as f64,
            images: RunImages {
                raw: self.image_errors(refs)?,
                denoised: self.denoised_errors(refs)?,
            },
            per_frame: self.records,
        };
        Ok(Finished {
            run: report,
            last_combined: self.last_eval.map(|(_, images)| images.combined),
        })
    }

    /// Each image's errors over the run: the mean frame error over the second half, FLIP of
    /// the last evaluated frame, the accumulated image's errors and the bias.
    fn image_errors(&self, refs: &Refs) -> Result<PerImage<ImageErrors>> {
        let frames = self.records.len() as u32;
        let second_half = self
            .records
            .iter()
            .filter(|r| r.frame >= frames / 2 || frames == 1);
        let last = self
            .last_eval
            .as_ref()
            .and_then(|(f, images)| Some((refs.get(*f)?, images)));
        let average = self.accumulated.as_ref().map(Accumulator::average);
        PerImage::try_from_fn(|k| -> Result<ImageErrors> {
            let errors: Vec<Err2> = second_half
                .clone()
                .filter_map(|r| r.images.get(k).map(|e| e.error))
                .collect();
            let mut e = ImageErrors {
                frame: Err2::mean(&errors),
                bias: self.sums.get(k).map(channel_ratio),
                ..ImageErrors::default()
            };
            let Some((r, images)) = last else {
                return Ok(e);
            };
            let Some(reference) = r.image(k) else {
                return Ok(e);
            };
            let exposure = metrics::auto_exposure(reference);
            let flip = |image: &Rgb| -> Result<f64> {
                Ok(metrics::flip(image, reference, r.width, r.height, exposure)?.0)
            };
            e.frame_flip = Some(flip(images.get(k))?);
            if let Some(avg) = &average {
                e.accumulated = Some(metrics::errors(avg.get(k), reference)?.into());
                e.accumulated_flip = Some(flip(avg.get(k))?);
            }
            Ok(e)
        })
    }
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
