//! The report of a compare run, as written to report.json (and read by report.md and the plot).

use restir_world::metrics;
use serde::Serialize;

use super::CameraMode;

/// Which image of a render: direct light, indirect light (bounces 1..N), or their sum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageKind {
    Direct,
    Indirect,
    Combined,
}

impl ImageKind {
    pub const ALL: [ImageKind; 3] = [ImageKind::Direct, ImageKind::Indirect, ImageKind::Combined];

    pub fn name(self) -> &'static str {
        match self {
            ImageKind::Direct => "direct",
            ImageKind::Indirect => "indirect",
            ImageKind::Combined => "combined",
        }
    }
}

/// One `T` for each image of a render, so that a metric is written once for all three.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct PerImage<T> {
    pub direct: T,
    pub indirect: T,
    pub combined: T,
}

impl<T> PerImage<T> {
    pub fn from_fn(mut f: impl FnMut(ImageKind) -> T) -> Self {
        Self {
            direct: f(ImageKind::Direct),
            indirect: f(ImageKind::Indirect),
            combined: f(ImageKind::Combined),
        }
    }

    /// [`PerImage::from_fn`] for a function that can fail (stops at the first error).
    pub fn try_from_fn<E>(mut f: impl FnMut(ImageKind) -> Result<T, E>) -> Result<Self, E> {
        Ok(Self {
            direct: f(ImageKind::Direct)?,
            indirect: f(ImageKind::Indirect)?,
            combined: f(ImageKind::Combined)?,
        })
    }

    pub fn get(&self, kind: ImageKind) -> &T {
        match kind {
            ImageKind::Direct => &self.direct,
            ImageKind::Indirect => &self.indirect,
            ImageKind::Combined => &self.combined,
        }
    }

    pub fn get_mut(&mut self, kind: ImageKind) -> &mut T {
        match kind {
            ImageKind::Direct => &mut self.direct,
            ImageKind::Indirect => &mut self.indirect,
            ImageKind::Combined => &mut self.combined,
        }
    }

    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> PerImage<U> {
        PerImage {
            direct: f(self.direct),
            indirect: f(self.indirect),
            combined: f(self.combined),
        }
    }

    /// The images in [`ImageKind::ALL`] order, each with its kind.
    pub fn iter(&self) -> impl Iterator<Item = (ImageKind, &T)> {
        ImageKind::ALL.into_iter().map(|k| (k, self.get(k)))
    }
}

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

impl Err2 {
    /// The mean of each error over `errors`; `None` when empty.
    pub fn mean(errors: &[Err2]) -> Option<Err2> {
        let n = errors.len() as f64;
        let mean = |pick: fn(&Err2) -> f64| errors.iter().map(pick).sum::<f64>() / n;
        (!errors.is_empty()).then(|| Err2 {
            mse: mean(|e| e.mse),
            rel_mse: mean(|e| e.rel_mse),
            rel_mse_trimmed: mean(|e| e.rel_mse_trimmed),
        })
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Stage {
    pub name: String,
    pub ms: f64,
}

impl Stage {
    /// Stages from `(name, milliseconds)` pairs.
    pub fn list(passes: Vec<(String, f64)>) -> Vec<Stage> {
        passes
            .into_iter()
            .map(|(name, ms)| Stage { name, ms })
            .collect()
    }
}

/// One image of one frame against its reference.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FrameError {
    pub error: Err2,
    /// relMSE of the running average of frames 0..=frame (static camera only).
    pub accumulated_rel_mse: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct FrameRecord {
    pub frame: u32,
    /// GPU milliseconds of this frame (sum of its stages); null without timestamps.
    pub gpu_ms: Option<f64>,
    pub cumulative_gpu_ms: Option<f64>,
    pub stages: Vec<Stage>,
    /// Each image's error; null when the frame has no reference for it (an animated camera
    /// between evaluation frames; direct and indirect without an indirect reference). The
    /// direct reference is the reference's combined image minus its indirect one.
    pub images: PerImage<Option<FrameError>>,
    /// The denoised frame's error against the combined reference (`--denoise`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoised: Option<FrameError>,
    /// Vertices left out of this frame's hash grid (methods with a grid).
    pub grid_overflows: Option<u32>,
}

/// A method's errors on one image over a run.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct ImageErrors {
    /// Mean per-frame error over the evaluated frames of the second half of the run (after
    /// warm-up for methods with temporal reuse).
    pub frame: Option<Err2>,
    /// FLIP (mean) of the last evaluated frame, tone-mapped with the exposure of its
    /// reference image.
    pub frame_flip: Option<f64>,
    /// Error of the average of all frames (static camera only).
    pub accumulated: Option<Err2>,
    pub accumulated_flip: Option<f64>,
    /// Mean of the method's images over the reference's, per channel, summed over the
    /// evaluated frames (1 = no bias in the mean).
    pub bias: Option<[f64; 3]>,
}

#[derive(Debug, Clone, Serialize)]
pub struct MethodRun {
    pub method: String,
    pub about: String,
    pub spp_per_frame: u32,
    /// A planted multiplicative bias on the indirect image (negative control), if any.
    pub planted_bias: Option<f32>,
    pub frames: u32,
    /// Frames the times are taken over: all but the first
    /// [`TIMING_WARMUP_FRAMES`](super::TIMING_WARMUP_FRAMES) (all but the first when the run
    /// is that short).
    pub timed_frames: u32,
    /// Mean and median GPU milliseconds per timed frame, total and by stage (null without
    /// timestamps). Equal-time budgets use the median.
    pub ms_per_frame: Option<f64>,
    pub ms_per_frame_median: Option<f64>,
    pub ms_per_frame_by_stage: Vec<Stage>,
    pub ms_per_frame_by_stage_median: Vec<Stage>,
    /// Most vertices left out of a frame's hash grid (methods with a grid).
    pub max_grid_overflows: Option<u32>,
    /// The radiance cache's size and use (`+cache` methods).
    pub cache: Option<CacheUse>,
    /// Bytes per pixel of the buffers its path-resampling stage keeps (restir-gi,
    /// world-restir-gi: reservoirs, history, grid and pool).
    pub reuse_bytes_per_pixel: Option<f64>,
    /// Bytes per pixel of every per-frame buffer the method keeps (the renderer's per-pixel
    /// buffers and each stage's, the denoiser's too; the scene's not).
    pub bytes_per_pixel: f64,
    /// Compute dispatches a frame records (mean over the run's frames): its fixed cost, which
    /// a GPU pays per dispatch where lavapipe hardly does.
    pub dispatches_per_frame: f64,
    pub images: RunImages,
    pub per_frame: Vec<FrameRecord>,
}

/// A run's errors per image: direct, indirect, combined and (`--denoise`) the denoised
/// frames, each with the same fields.
#[derive(Debug, Clone, Serialize)]
pub struct RunImages {
    #[serde(flatten)]
    pub raw: PerImage<ImageErrors>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoised: Option<DenoisedErrors>,
}

impl std::ops::Deref for RunImages {
    type Target = PerImage<ImageErrors>;
    fn deref(&self) -> &Self::Target {
        &self.raw
    }
}

/// The denoised frames' errors (the combined image denoised, against the combined
/// reference; `accumulated` is not measured: a denoised frame is shown, not averaged) and
/// their temporal stability.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct DenoisedErrors {
    #[serde(flatten)]
    pub errors: ImageErrors,
    /// The frame-to-frame change of the denoised image against the reference's own change:
    /// mean over pixels and channels of ((D_t - D_t-1) - (R_t - R_t-1))^2 / (R_t^2 + 0.01),
    /// averaged over the evaluated frames t whose frame before has a reference too (lower:
    /// steadier; 0: it changes exactly as the reference does).
    pub temporal_change: Option<f64>,
    /// The same of the raw combined frames, measured in the same run.
    pub raw_temporal_change: Option<f64>,
}

/// A radiance cache over a run: its table and the most it used.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CacheUse {
    pub capacity_cells: u32,
    pub bytes_per_cell: u32,
    /// Most cells in use after a frame.
    pub max_cells_in_use: u32,
    /// Most inserts of a frame that found their bucket full.
    pub max_overflows: u32,
}

impl CacheUse {
    /// Folds in the stats after one frame.
    pub fn add(this: Option<Self>, s: &restir_world::cache::CacheStats) -> Self {
        let (cells, overflows) = this.map_or((0, 0), |c| (c.max_cells_in_use, c.max_overflows));
        Self {
            capacity_cells: s.capacity,
            bytes_per_cell: s.bytes_per_cell,
            max_cells_in_use: cells.max(s.cells_in_use),
            max_overflows: overflows.max(s.overflows),
        }
    }
}

impl MethodRun {
    /// The mean per-frame error of each image.
    pub fn frame_errors(&self) -> PerImage<Option<Err2>> {
        self.images.raw.map(|e| e.frame)
    }
}

/// One image of a method at equal time against the target's.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct EqualTimeImage {
    pub frame: Option<Err2>,
    /// relMSE of this method at equal time divided by the target's (>1: the target is better).
    pub rel_mse_ratio: Option<f64>,
    /// The same ratio of the trimmed relMSE (robust to fireflies).
    pub rel_mse_trimmed_ratio: Option<f64>,
    /// GPU time this method needs to reach the target's per-frame relMSE (1/N variance law
    /// from its equal-time error) divided by the target's time per frame.
    pub equal_error_speedup: Option<f64>,
    /// The same from the trimmed relMSE.
    pub equal_error_speedup_trimmed: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct EqualTimeEntry {
    pub method: String,
    /// Samples per pixel per frame that fit the target's GPU time per frame.
    pub spp_per_frame: u32,
    pub ms_per_frame: Option<f64>,
    pub images: PerImage<EqualTimeImage>,
}

#[derive(Debug, Clone, Serialize)]
pub struct EqualTime {
    pub target: String,
    pub target_ms_per_frame: f64,
    pub target_frame: PerImage<Option<Err2>>,
    pub entries: Vec<EqualTimeEntry>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ReferenceInfo {
    /// "gpu" (rendered now), "cache" or "external".
    pub source: String,
    pub estimator: String,
    pub samples: u32,
    /// Estimated relMSE of the reference itself (from two independent halves); none for the
    /// direct image (the combined image minus the indirect one).
    pub self_rel_mse: PerImage<Option<f64>>,
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
    /// Bounces of indirect light of every method and the reference.
    pub bounces: u32,
    /// Russian roulette from this bounce on (0: never).
    pub roulette_from: u32,
    /// Multiple importance sampling of emission hits.
    pub mis: bool,
    pub scenes: Vec<SceneReport>,
}
