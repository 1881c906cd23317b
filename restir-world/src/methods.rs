//! The registry of rendering methods, above the renderers: every method the tools run
//! (render, compare, the viewer) is one [`MethodEntry`], built from a spec into a
//! [`FrameMethod`], driven by the one frame loop [`run_frames`] and read back as
//! [`FrameImages`]. A new method plugs in as one more entry; the tools need no special cases.
//!
//! A method spec is `name` or `name:variant` (e.g. `ris:4` = RIS with 4 candidates,
//! `world-restir:temporal+spatial-passes=4`).

use std::fmt;

use crate::gpu::{FrameEncoder, GpuContext, GpuError, GpuTimer, PassTimes, SpanTimes};
use crate::image_io::Image;
use crate::reference::Rendered;
use crate::render::{self, RenderError, Renderer};
use crate::restir_di::{RestirDiConfig, RestirDiError, RestirDiRenderer};
use crate::sampling::Estimator;
use crate::scene::{Camera, CameraPath, Scene};
use crate::world_restir::{DebugView, WorldRestir, WorldRestirConfig, WorldRestirError};

/// What can go wrong building or running a method.
#[derive(Debug, thiserror::Error)]
pub enum MethodError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    WorldRestir(#[from] WorldRestirError),
    #[error(transparent)]
    RestirDi(#[from] RestirDiError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("unknown method {name:?}; known: {known}")]
    Unknown { name: String, known: String },
    #[error("method {method}: {msg}")]
    Variant { method: String, msg: String },
}

/// Images read back from a method, linear HDR RGB, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameImages {
    pub width: u32,
    pub height: u32,
    /// Frames averaged.
    pub frames: u32,
    pub direct: Vec<[f32; 3]>,
    pub indirect: Vec<[f32; 3]>,
}

impl FrameImages {
    /// direct + indirect.
    pub fn combined(&self) -> Vec<[f32; 3]> {
        self.direct
            .iter()
            .zip(&self.indirect)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect()
    }

    /// As the three images the CPU reference returns.
    pub fn into_rendered(self) -> Result<Rendered, MethodError> {
        let (w, h) = (self.width, self.height);
        let image = |p| {
            Image::from_pixels(w, h, p)
                .map_err(|e| MethodError::from(RenderError::Settings(e.to_string())))
        };
        let combined = self.combined();
        Ok(Rendered {
            direct: image(self.direct)?,
            indirect: image(self.indirect)?,
            combined: image(combined)?,
        })
    }
}

/// Which images [`FrameMethod::read`] returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Readback {
    /// The mean of the frames accumulated since creation or the last restart.
    Accumulated,
    /// The last frame alone.
    LastFrame,
}

/// The renderer's images, as every method reads them back.
fn read_renderer(
    ctx: &GpuContext,
    r: &Renderer,
    which: Readback,
) -> Result<FrameImages, MethodError> {
    let b = &r.buffers;
    let (sums, frames, scale) = match which {
        Readback::Accumulated => {
            let n = r.accumulated();
            let scale = if n == 0 { 0.0 } else { 1.0 / n as f32 };
            ([&b.accum_direct, &b.accum_indirect], n, scale)
        }
        Readback::LastFrame => ([&b.direct_frame, &b.indirect_frame], 1, 1.0),
    };
    Ok(FrameImages {
        width: r.camera().width,
        height: r.camera().height,
        frames,
        direct: r.read_rgb(ctx, sums[0], scale)?,
        indirect: r.read_rgb(ctx, sums[1], scale)?,
    })
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
        read_renderer(ctx, self.renderer(), which)
    }
    /// Vertices left out of the last frame's hash grid (bucket full), for methods with one.
    fn grid_overflows(&self, _ctx: &GpuContext) -> Result<Option<u32>, MethodError> {
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

impl FrameMethod for WorldRestir {
    fn renderer(&self) -> &Renderer {
        WorldRestir::renderer(self)
    }
    fn encode_frame(&mut self, f: &mut FrameEncoder) -> Result<(), MethodError> {
        Ok(WorldRestir::encode_frame(self, f)?)
    }
    fn set_camera(&mut self, camera: &Camera) -> Result<(), MethodError> {
        Ok(WorldRestir::set_camera(self, camera)?)
    }
    fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        WorldRestir::restart_accumulation(self, f);
    }
    fn grid_overflows(&self, ctx: &GpuContext) -> Result<Option<u32>, MethodError> {
        Ok(Some(self.grid_stats(ctx)?.overflows))
    }
    fn debug_image(
        &self,
        ctx: &GpuContext,
        view: DebugView,
    ) -> Result<Option<Vec<[f32; 3]>>, MethodError> {
        Ok(Some(WorldRestir::debug_image(self, ctx, view)?))
    }
}

impl FrameMethod for RestirDiRenderer {
    fn renderer(&self) -> &Renderer {
        RestirDiRenderer::renderer(self)
    }
    fn encode_frame(&mut self, f: &mut FrameEncoder) -> Result<(), MethodError> {
        RestirDiRenderer::encode_frame(self, f);
        Ok(())
    }
    fn set_camera(&mut self, camera: &Camera) -> Result<(), MethodError> {
        Ok(RestirDiRenderer::set_camera(self, camera)?)
    }
    fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        RestirDiRenderer::restart_accumulation(self, f);
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
            for _ in 0..n {
                m.encode_frame(&mut f)?;
            }
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

/// The named variants of `world-restir`, each isolating what one part buys: (name, the knobs
/// it sets, what it is).
pub const WORLD_RESTIR_VARIANTS: [(&str, &str, &str); 10] = [
    ("both", "", "temporal + spatial reuse (the default)"),
    (
        "no-reuse",
        "temporal=off+spatial-passes=0",
        "no temporal, no spatial reuse",
    ),
    ("temporal", "spatial-passes=0", "temporal reuse only"),
    ("spatial", "temporal=off", "spatial reuse only"),
    ("no-adaptive", "adaptive-cell-size=off", "fixed cell size"),
    (
        "no-jitter",
        "jitter=off",
        "no tangent jitter of the lookups",
    ),
    (
        "biased",
        "combine=biased",
        "the paper's 1/M weights instead of pairwise MIS",
    ),
    (
        "one-over-z",
        "combine=one-over-z",
        "1/Z weights instead of pairwise MIS",
    ),
    (
        "paper-grid",
        "buckets=100000",
        "the paper's fixed 100,000 x 32 table",
    ),
    (
        "unified",
        "unified=on",
        "one cache for all light: primary vertices in the grid too, direct light from it",
    ),
];

/// The configuration of a `world-restir` variant: named variants and knobs `key=value` (see
/// [`WorldRestirConfig::set`]) joined by `+`, applied in order (e.g.
/// `biased+spatial-passes=2`).
pub fn world_restir_config(variant: Option<&str>) -> Result<WorldRestirConfig, MethodError> {
    let bad = |msg: String| MethodError::Variant {
        method: "world-restir".into(),
        msg,
    };
    let mut config = WorldRestirConfig::default();
    for part in variant.unwrap_or("both").split('+') {
        let knobs = match WORLD_RESTIR_VARIANTS.iter().find(|v| v.0 == part) {
            Some((_, knobs, _)) => *knobs,
            None if part.contains('=') => part,
            None => {
                let names: Vec<&str> = WORLD_RESTIR_VARIANTS.iter().map(|v| v.0).collect();
                let known = names.join(", ");
                return Err(bad(format!("unknown variant {part:?}; known: {known}")));
            }
        };
        for (key, value) in knobs.split('+').filter_map(|k| k.split_once('=')) {
            config.set(key, value).map_err(|e| bad(e.to_string()))?;
        }
    }
    config.validate()?;
    Ok(config)
}

/// The named variants of `restir-di` (and of the direct light of `world-restir+restir-di`):
/// (name, the knobs it sets, what it is).
pub const RESTIR_DI_VARIANTS: [(&str, &str, &str); 6] = [
    (
        "both",
        "",
        "temporal + spatial reuse, pairwise MIS (the default)",
    ),
    (
        "no-reuse",
        "temporal=off+spatial-k=0",
        "initial candidates from the light tiles only",
    ),
    ("temporal", "spatial-k=0", "temporal reuse only"),
    ("spatial", "temporal=off", "spatial reuse only"),
    (
        "biased",
        "combine=biased",
        "the paper's 1/M weights instead of pairwise MIS",
    ),
    (
        "gi-tiles",
        "gi-tiles=on",
        "the light tiles also feed world-restir's generate (world-restir+restir-di only)",
    ),
];

/// The configuration of a `restir-di` variant: named variants and knobs `key=value` (see
/// [`RestirDiConfig::set`]) joined by `+`, applied in order (e.g. `biased+spatial-k=2`).
/// `method` names the method in errors.
pub fn restir_di_config(
    method: &str,
    variant: Option<&str>,
) -> Result<RestirDiConfig, MethodError> {
    let bad = |msg: String| MethodError::Variant {
        method: method.into(),
        msg,
    };
    let mut config = RestirDiConfig::default();
    for part in variant.unwrap_or("both").split('+') {
        let knobs = match RESTIR_DI_VARIANTS.iter().find(|v| v.0 == part) {
            Some((_, knobs, _)) => *knobs,
            None if part.contains('=') => part,
            None => {
                let names: Vec<&str> = RESTIR_DI_VARIANTS.iter().map(|v| v.0).collect();
                let known = names.join(", ");
                return Err(bad(format!("unknown variant {part:?}; known: {known}")));
            }
        };
        for (key, value) in knobs.split('+').filter_map(|k| k.split_once('=')) {
            config.set(key, value).map_err(|e| bad(e.to_string()))?;
        }
    }
    config.validate().map_err(|e| bad(e.to_string()))?;
    if config.gi_tiles && method == "restir-di" {
        return Err(bad(
            "gi-tiles feeds world-restir's generate pass: use world-restir+restir-di".into(),
        ));
    }
    Ok(config)
}

/// What a method spec parses to: the settings of one of the renderers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MethodSettings {
    /// `nee`, `ris[:K]`: the renderer's baselines.
    Baseline(Estimator),
    /// `world-restir[:variant]`.
    WorldRestir(WorldRestirConfig),
    /// `restir-di[:variant]`: `ris` with ReSTIR DI for the direct light.
    RestirDi(RestirDiConfig),
    /// `world-restir+restir-di[:variant]`: world-restir's indirect light (its defaults) and
    /// ReSTIR DI (the variant) for the direct light.
    WorldRestirDi(WorldRestirConfig, RestirDiConfig),
}

impl MethodSettings {
    /// Builds the method.
    pub fn build(
        self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        seed: u32,
    ) -> Result<Box<dyn FrameMethod>, MethodError> {
        Ok(match self {
            MethodSettings::Baseline(e) => Box::new(Renderer::new(ctx, scene, camera, e, seed)?),
            MethodSettings::WorldRestir(c) => {
                Box::new(WorldRestir::new(ctx, scene, camera, c, seed)?)
            }
            MethodSettings::RestirDi(c) => {
                Box::new(RestirDiRenderer::new(ctx, scene, camera, c, seed)?)
            }
            MethodSettings::WorldRestirDi(w, d) => Box::new(WorldRestir::with_direct(
                ctx,
                scene,
                camera,
                w,
                Some(d),
                seed,
            )?),
        })
    }
}

/// Parses a method's variant (`None` = the default) into its settings.
pub type ParseFn = fn(variant: Option<&str>) -> Result<MethodSettings, MethodError>;

/// One registered method.
#[derive(Clone, Copy)]
pub struct MethodEntry {
    /// Name on the command line.
    pub name: &'static str,
    /// One line for `--help` and reports.
    pub about: &'static str,
    /// The variants it accepts after `:` (documentation; `parse` validates).
    pub variants: &'static str,
    /// Whether this is the method that equal-time comparisons are measured against when the
    /// run includes it (world-space ReSTIR).
    pub equal_time_target: bool,
    pub parse: ParseFn,
}

impl fmt::Debug for MethodEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MethodEntry")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

fn parse_nee(variant: Option<&str>) -> Result<MethodSettings, MethodError> {
    match variant {
        None => Ok(MethodSettings::Baseline(Estimator::Nee)),
        Some(v) => Err(MethodError::Variant {
            method: "nee".into(),
            msg: format!("has no variants (got {v:?})"),
        }),
    }
}

/// `ris[:K]`: K candidates.
fn parse_ris(variant: Option<&str>) -> Result<MethodSettings, MethodError> {
    let bad = |msg: String| MethodError::Variant {
        method: "ris".into(),
        msg,
    };
    let candidates = match variant {
        None => render::DEFAULT_CANDIDATES,
        Some(v) => v
            .parse()
            .map_err(|_| bad(format!("ris:<candidates> wants a number, got {v:?}")))?,
    };
    render::check_candidates(candidates).map_err(bad)?;
    Ok(MethodSettings::Baseline(Estimator::Ris { candidates }))
}

fn parse_world_restir(variant: Option<&str>) -> Result<MethodSettings, MethodError> {
    world_restir_config(variant).map(MethodSettings::WorldRestir)
}

fn parse_restir_di(variant: Option<&str>) -> Result<MethodSettings, MethodError> {
    restir_di_config("restir-di", variant).map(MethodSettings::RestirDi)
}

fn parse_world_restir_di(variant: Option<&str>) -> Result<MethodSettings, MethodError> {
    let d = restir_di_config("world-restir+restir-di", variant)?;
    Ok(MethodSettings::WorldRestirDi(
        WorldRestirConfig::default(),
        d,
    ))
}

/// Parses a method spec (`name` or `name:variant`) without a GPU: the name is registered and
/// its variant parses. Tools call it before any expensive work.
pub fn parse_spec(spec: &str) -> Result<MethodSettings, MethodError> {
    let e = entry(spec)?;
    (e.parse)(spec.split_once(':').map(|(_, v)| v))
}

/// [`parse_spec`], for its errors only.
pub fn check_spec(spec: &str) -> Result<(), MethodError> {
    parse_spec(spec).map(drop)
}

/// Checks without a GPU what the method needs of the camera (before any GPU work): world-restir
/// sizes its hash grid's cells from the image size and the field of view, and a tiny image
/// (1x1, 4x4) cannot be sized.
pub fn check_camera(spec: &str, camera: &Camera) -> Result<(), MethodError> {
    let config = match parse_spec(spec)? {
        MethodSettings::WorldRestir(c) | MethodSettings::WorldRestirDi(c, _) => c,
        MethodSettings::Baseline(_) | MethodSettings::RestirDi(_) => return Ok(()),
    };
    config.validate()?;
    let table = config.table(camera.width, camera.height);
    gpu_hash::HashGridParams::new(&table, &config.sizing(camera), camera.eye)
        .map_err(WorldRestirError::from)?;
    Ok(())
}

/// Every registered method, in display order.
pub fn registry() -> &'static [MethodEntry] {
    const REGISTRY: &[MethodEntry] = &[
        MethodEntry {
            name: "nee",
            about: "one light sample + one shadow ray at each vertex",
            variants: "",
            equal_time_target: false,
            parse: parse_nee,
        },
        MethodEntry {
            name: "ris",
            about: "RIS over 16 light candidates (ris:K for K), one shadow ray, no reuse",
            variants: "K (candidate count)",
            equal_time_target: false,
            parse: parse_ris,
        },
        MethodEntry {
            name: "world-restir",
            about: "world-space ReSTIR GI: RIS + hash-grid temporal and spatial reuse",
            variants: "both, no-reuse, temporal, spatial, no-adaptive, no-jitter, biased, one-over-z, \
                       paper-grid, or knobs key=value (e.g. spatial-passes=2), joined by +",
            equal_time_target: true,
            parse: parse_world_restir,
        },
        MethodEntry {
            name: "restir-di",
            about: "ris with screen-space ReSTIR DI (light tiles, temporal + spatial reuse) for \
                    the direct light",
            variants: "both, no-reuse, temporal, spatial, biased, or knobs key=value (e.g. \
                       spatial-k=4), joined by +",
            equal_time_target: false,
            parse: parse_restir_di,
        },
        MethodEntry {
            name: "world-restir+restir-di",
            about: "world-space ReSTIR GI for the indirect light, ReSTIR DI for the direct light",
            variants: "restir-di's variants and knobs (world-restir at its defaults)",
            equal_time_target: false,
            parse: parse_world_restir_di,
        },
    ];
    REGISTRY
}

/// The registry entry of `spec` (`name` or `name:variant`).
pub fn entry(spec: &str) -> Result<&'static MethodEntry, MethodError> {
    let name = spec.split_once(':').map_or(spec, |(n, _)| n);
    registry().iter().find(|e| e.name == name).ok_or_else(|| {
        let names: Vec<&str> = registry().iter().map(|e| e.name).collect();
        MethodError::Unknown {
            name: name.into(),
            known: names.join(", "),
        }
    })
}

/// Builds the method named by `spec` (`name` or `name:variant`).
pub fn build_method(
    spec: &str,
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
) -> Result<Box<dyn FrameMethod>, MethodError> {
    parse_spec(spec)?.build(ctx, scene, camera, seed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world_restir::Combine;

    #[test]
    fn names_are_unique_and_found() {
        let r = registry();
        for (i, a) in r.iter().enumerate() {
            assert!(r[i + 1..].iter().all(|b| b.name != a.name));
            assert_eq!(entry(a.name).unwrap().name, a.name);
        }
        assert_eq!(entry("ris:4").unwrap().name, "ris");
        assert!(entry("nope").is_err());
        for good in [
            "nee",
            "ris",
            "ris:4",
            "ris:65535",
            "world-restir:biased+spatial-passes=2",
            "restir-di",
            "restir-di:no-reuse",
            "restir-di:biased+spatial-k=2",
            "world-restir+restir-di:spatial-k=4",
        ] {
            check_spec(good).unwrap();
        }
        for bad in [
            "nee:1",
            "ris:0",
            "ris:65536",
            "ris:x",
            "world-restir:bogus",
            "restir-di:bogus",
            "restir-di:spatial-k=99",
            "restir-di:tiles=0",
            "world-restir+restir-di:combine=x",
            "nope",
        ] {
            assert!(check_spec(bad).is_err(), "{bad}");
        }
    }

    /// `get` gives back what `set` takes, for every knob of every variant, and a variant's
    /// `knobs_spec` rebuilds it (the viewer edits knobs through them).
    #[test]
    fn knobs_read_back_and_rebuild() {
        for (v, _, _) in WORLD_RESTIR_VARIANTS {
            let c = world_restir_config(Some(v)).unwrap();
            for k in WorldRestirConfig::KNOBS {
                let mut d = c;
                d.set(k, &c.get(k).unwrap()).unwrap();
                assert_eq!(d, c, "{v}: {k}");
            }
            let spec = c.knobs_spec();
            let rebuilt = world_restir_config((!spec.is_empty()).then_some(spec.as_str())).unwrap();
            assert_eq!(rebuilt, c, "{v}: {spec:?}");
        }
        assert_eq!(WorldRestirConfig::default().knobs_spec(), "");
        let biased = world_restir_config(Some("biased+spatial-passes=3")).unwrap();
        assert_eq!(biased.knobs_spec(), "spatial-passes=3+combine=biased");
        assert!(WorldRestirConfig::default().get("nosuch").is_err());
    }

    #[test]
    fn restir_di_variants_parse() {
        for (v, _, _) in RESTIR_DI_VARIANTS {
            restir_di_config("world-restir+restir-di", Some(v))
                .unwrap()
                .validate()
                .unwrap();
        }
        // The shared tiles need world-restir's generate pass.
        assert!(restir_di_config("restir-di", Some("gi-tiles")).is_err());
        assert!(
            restir_di_config("world-restir+restir-di", Some("gi-tiles"))
                .unwrap()
                .gi_tiles
        );
        let n = restir_di_config("restir-di", Some("no-reuse")).unwrap();
        assert!(!n.temporal && n.spatial_k == 0);
        let k = restir_di_config("restir-di", Some("biased+spatial-k=2")).unwrap();
        assert_eq!(
            (k.combine, k.spatial_k),
            (crate::world_restir::Combine::Biased, 2)
        );
        match parse_spec("world-restir+restir-di:temporal").unwrap() {
            MethodSettings::WorldRestirDi(w, d) => {
                assert_eq!(w, WorldRestirConfig::default());
                assert!(d.temporal && d.spatial_k == 0);
            }
            other => panic!("{other:?}"),
        }
        for (bad, knob) in [
            ("spatial-k=x", "spatial-k"),
            ("tiles=0", "tiles"),
            ("bogus", "bogus"),
        ] {
            let e = restir_di_config("restir-di", Some(bad)).unwrap_err();
            assert!(e.to_string().contains(knob), "{bad}: {e}");
        }
    }

    #[test]
    fn world_restir_variants_parse() {
        for (v, _, _) in WORLD_RESTIR_VARIANTS {
            world_restir_config(Some(v)).unwrap().validate().unwrap();
        }
        let t = world_restir_config(Some("temporal")).unwrap();
        assert!(t.temporal && t.spatial_passes == 0);
        let s = world_restir_config(Some("spatial")).unwrap();
        assert!(!s.temporal && s.spatial_passes > 0);
        assert!(!world_restir_config(Some("no-jitter")).unwrap().jitter);
        assert!(
            !world_restir_config(Some("no-adaptive"))
                .unwrap()
                .adaptive_cell_size
        );
        assert!(world_restir_config(Some("bogus")).is_err());
        let k = world_restir_config(Some("biased+spatial-passes=2+max_count=8")).unwrap();
        assert_eq!(
            (k.combine, k.spatial_passes, k.max_count),
            (Combine::Biased, 2, 8)
        );
        for bad in [
            "spatial-passes=x",
            "nosuch=1",
            "candidates=0",
            "temporal+bogus",
        ] {
            assert!(world_restir_config(Some(bad)).is_err(), "{bad}");
        }
    }
}
