//! The registry of rendering methods, above the renderers and their stages: every method the
//! tools run (render, compare, the viewer) is one [`MethodEntry`], whose spec parses into
//! [`MethodSettings`] (a composition of the renderer and its stages), built into a
//! [`FrameMethod`] ([`Composed`]), driven by the one frame loop [`run_frames`] and read back as
//! [`FrameImages`]. A new method plugs in as one more entry; the tools need no special cases.
//!
//! A method spec is `name` or `name:variant` (e.g. `ris:4` = RIS with 4 candidates,
//! `world-restir:temporal+spatial-passes=4`).

use std::fmt;

use crate::cache::{CacheError, CacheStats};
use crate::gpu::{FrameEncoder, GpuContext, GpuError, GpuTimer, PassTimes, SpanTimes};
use crate::render::{DebugView, RenderError, Renderer};
use crate::scene::{Camera, CameraPath};
use crate::screen_reuse::ScreenReuseError;
use crate::world_restir::WorldRestirError;

mod composed;
pub mod plan;
mod registry;

pub use crate::render::{FrameImages, Readback};
pub use composed::Composed;
pub use plan::{FrameBuffer, FramePlan, Step};
pub use registry::{
    MethodEntry, MethodSettings, build_method, check_camera, check_paths, check_spec, entry,
    parse_spec, registry,
};

/// What can go wrong building or running a method.
#[derive(Debug, thiserror::Error)]
pub enum MethodError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    WorldRestir(#[from] WorldRestirError),
    /// restir-di's or restir-gi's.
    #[error(transparent)]
    ScreenReuse(#[from] ScreenReuseError),
    #[error(transparent)]
    Cache(#[from] CacheError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("unknown method {name:?}; known: {known}")]
    Unknown { name: String, known: String },
    #[error("method {method}: {msg}")]
    Variant { method: String, msg: String },
}

/// One rendering method as the tools drive it: one frame (one sample per pixel) at a time,
/// recorded into a [`FrameEncoder`], one named span per stage. Frames record back to back:
/// several may share one encoder.
pub trait FrameMethod: fmt::Debug {
    /// The renderer underneath (camera, size, frame counters).
    fn renderer(&self) -> &Renderer;
    /// Records one frame.
    fn encode_frame(&mut self, f: &mut FrameEncoder) -> Result<(), MethodError>;
    /// Moves the camera from the next recorded frame on (same image size).
    fn set_camera(&mut self, camera: &Camera) -> Result<(), MethodError>;
    /// Clears the accumulated images (from the next recorded frame on).
    fn restart_accumulation(&mut self, f: &mut FrameEncoder);
    /// Reads images back (blocks).
    fn read(&self, ctx: &GpuContext, which: Readback) -> Result<FrameImages, MethodError> {
        Ok(self.renderer().read(ctx, which)?)
    }
    /// Vertices left out of the last frame's hash grid (bucket full), for methods with one.
    fn grid_overflows(&self, _ctx: &GpuContext) -> Result<Option<u32>, MethodError> {
        Ok(None)
    }
    /// Bytes of every per-frame buffer it keeps: the renderer's per-pixel buffers and each
    /// stage's (reservoirs, histories, grids, pools, caches, the denoiser's); the scene's not.
    fn frame_bytes(&self) -> u64 {
        self.renderer().bytes()
    }
    /// Bytes of the buffers its path-resampling stage keeps (reservoirs, history, grid, pool),
    /// for methods with one.
    fn reuse_bytes(&self) -> Option<u64> {
        None
    }
    /// The radiance cache's size and use after the last frame, for methods with one.
    fn cache_stats(&self, _ctx: &GpuContext) -> Result<Option<CacheStats>, MethodError> {
        Ok(None)
    }
    /// The last frame denoised, for methods built with a denoiser.
    fn read_denoised(&self, _ctx: &GpuContext) -> Result<Option<FrameImages>, MethodError> {
        Ok(None)
    }
    /// The last frame after each of the denoiser's filter iterations (0: before the first),
    /// combined, for methods built with a denoiser.
    fn denoise_iterations(
        &self,
        _ctx: &GpuContext,
    ) -> Result<Option<Vec<Vec<[f32; 3]>>>, MethodError> {
        Ok(None)
    }
    /// A debug view of the last frame (RGB per pixel), for methods with a hash grid.
    fn debug_image(
        &self,
        _ctx: &GpuContext,
        _view: DebugView,
    ) -> Result<Option<Vec<[f32; 3]>>, MethodError> {
        Ok(None)
    }
}

impl FrameMethod for Renderer {
    fn renderer(&self) -> &Renderer {
        self
    }
    fn encode_frame(&mut self, f: &mut FrameEncoder) -> Result<(), MethodError> {
        Renderer::encode_frame(self, f);
        Ok(())
    }
    fn set_camera(&mut self, camera: &Camera) -> Result<(), MethodError> {
        Ok(Renderer::set_camera(self, camera)?)
    }
    fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        Renderer::restart_accumulation(self, f);
    }
}

/// How [`run_frames`] drives a method: `records` records of `samples` frames each, the camera
/// of record `r` on `path` (from the method's camera when the loop starts), `batch` frames
/// per submission (1 when timing, so that each span is one frame's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameLoop {
    pub records: u32,
    pub samples: u32,
    pub path: CameraPath,
    /// Restart the accumulation at the start of each record (its images are then its own).
    pub restart: bool,
    /// GPU timestamp spans (when the adapter has them).
    pub timed: bool,
    pub batch: u32,
}

impl FrameLoop {
    /// `frames` timed frames, one per submission, accumulated, static camera.
    pub fn frames(frames: u32) -> Self {
        Self {
            records: frames,
            samples: 1,
            path: CameraPath::Static,
            restart: false,
            timed: true,
            batch: 1,
        }
    }
}

/// One submission of [`run_frames`].
#[derive(Debug)]
pub struct Submitted<'a> {
    /// The record it belongs to (its camera's index on the path).
    pub record: u32,
    /// Frames in this submission.
    pub frames: u32,
    /// Whether the record is complete (its images can be read).
    pub record_done: bool,
    /// The submission's spans (`None` without timestamps or when not timed).
    pub times: Option<&'a SpanTimes>,
    /// The compute dispatches its frames recorded (a restart's clears not included).
    pub dispatches: u32,
}

/// The one frame loop: runs `l` on `m`, calling `after` after each submission (the GPU is
/// done with it), and returns every span's total (`None` without timestamps).
pub fn run_frames<E: From<MethodError>>(
    ctx: &GpuContext,
    m: &mut dyn FrameMethod,
    l: &FrameLoop,
    mut after: impl FnMut(&mut dyn FrameMethod, &Submitted) -> Result<(), E>,
) -> Result<Option<PassTimes>, E> {
    let mut timer = l
        .timed
        .then(|| GpuTimer::new(ctx))
        .filter(GpuTimer::is_available);
    let mut total = timer.as_ref().map(|_| PassTimes::default());
    let batch = if timer.is_some() { 1 } else { l.batch.max(1) };
    let base = *m.renderer().camera();
    for record in 0..l.records {
        if l.path != CameraPath::Static {
            m.set_camera(&l.path.camera(&base, record))?;
        }
        let mut done = 0;
        while done < l.samples {
            let n = batch.min(l.samples - done);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            if let Some(t) = timer.as_mut() {
                t.reset();
            }
            let mut f = FrameEncoder::new(&ctx.device, &mut encoder, timer.as_mut());
            if done == 0 && l.restart {
                m.restart_accumulation(&mut f);
            }
            let restart_dispatches = f.dispatches();
            for _ in 0..n {
                m.encode_frame(&mut f)?;
            }
            let dispatches = f.dispatches() - restart_dispatches;
            if let Some(t) = timer.as_ref() {
                t.resolve(&mut encoder);
            }
            ctx.queue.submit([encoder.finish()]);
            let times = match timer.as_ref() {
                Some(t) => Some(t.read(ctx).map_err(MethodError::from)?),
                None => {
                    ctx.wait().map_err(MethodError::from)?;
                    None
                }
            };
            if let (Some(total), Some(t)) = (total.as_mut(), times.as_ref()) {
                total.add(t);
                total.frames += n;
            }
            done += n;
            let s = Submitted {
                record,
                frames: n,
                record_done: done == l.samples,
                times: times.as_ref(),
                dispatches,
            };
            after(m, &s)?;
        }
    }
    Ok(total)
}

/// Renders `frames` frames of `m` (static camera, timed) and returns its accumulated images
/// and span totals.
pub fn render_frames(
    ctx: &GpuContext,
    m: &mut dyn FrameMethod,
    frames: u32,
) -> Result<(FrameImages, Option<PassTimes>), MethodError> {
    if frames == 0 {
        return Err(RenderError::Settings("render at least one frame".into()).into());
    }
    let times = run_frames(ctx, m, &FrameLoop::frames(frames), |_, _| {
        Ok::<(), MethodError>(())
    })?;
    Ok((m.read(ctx, Readback::Accumulated)?, times))
}
