//! The registry of rendering methods: every method the tools can run (render, compare) is one
//! [`MethodEntry`] here, built by name into a [`FrameMethod`]. A new method (world-space
//! ReSTIR and its variants) plugs in as one more entry; the tools need no special cases.
//!
//! A method spec is `name` or `name:variant` (e.g. `ris:4` = RIS with 4 candidates).

use std::fmt;

use super::{Method, RenderError, Renderer};
use crate::scene::{Camera, Scene};
use crate::world_restir::{Combine, WorldRestir, WorldRestirConfig, WorldRestirError};
use crate::{GpuContext, GpuTimer};

/// What can go wrong building or running a method.
#[derive(Debug, thiserror::Error)]
pub enum MethodError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    WorldRestir(#[from] WorldRestirError),
    #[error("unknown method {name:?}; known: {known}")]
    Unknown { name: String, known: String },
    #[error("method {method}: {msg}")]
    Variant { method: String, msg: String },
}

/// One rendering method as the tools drive it: one frame (one sample per pixel of this
/// method) at a time, recorded into the caller's encoder. Each frame leaves its image in the
/// renderer's `direct_frame` / `indirect_frame` buffers and adds it to the accumulation
/// buffers (`accum_direct` / `accum_indirect`), which the caller may clear between frames.
pub trait FrameMethod: fmt::Debug {
    /// The spec it was built from (`name` or `name:variant`).
    fn spec(&self) -> &str;
    /// The renderer whose buffers hold the images.
    fn renderer(&self) -> &Renderer;
    /// Records one frame into `encoder`, one named timestamp span per stage. A method may
    /// write small uniforms through `ctx.queue` (world-space ReSTIR does): callers that record
    /// several frames of such a method submit after each (see [`FrameMethod::one_frame_per_submit`]).
    fn encode_frame(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut GpuTimer>,
    ) -> Result<(), MethodError>;
    /// The most timestamp spans one frame records (the timer's capacity per frame).
    fn spans_per_frame(&self) -> u32;
    /// Whether each frame must be submitted before the next is recorded.
    fn one_frame_per_submit(&self) -> bool {
        false
    }
    /// Moves the camera for the next frames (same image size).
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<(), MethodError>;
    /// Vertices left out of the last frame's hash grid (bucket full), for methods with one.
    fn grid_overflows(&self, _ctx: &GpuContext) -> Result<Option<u32>, MethodError> {
        Ok(None)
    }
}

/// A baseline (`nee`, `ris`): the renderer itself.
#[derive(Debug)]
pub struct Baseline {
    spec: String,
    pub renderer: Renderer,
}

impl FrameMethod for Baseline {
    fn spec(&self) -> &str {
        &self.spec
    }
    fn renderer(&self) -> &Renderer {
        &self.renderer
    }
    fn encode_frame(
        &mut self,
        _ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut GpuTimer>,
    ) -> Result<(), MethodError> {
        self.renderer.encode_frame(encoder, timer);
        Ok(())
    }
    fn spans_per_frame(&self) -> u32 {
        5
    }
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<(), MethodError> {
        Ok(self.renderer.set_camera(&ctx.queue, camera)?)
    }
}

/// World-space ReSTIR GI (and its variants).
#[derive(Debug)]
pub struct WorldRestirMethod {
    spec: String,
    pub inner: WorldRestir,
}

impl FrameMethod for WorldRestirMethod {
    fn spec(&self) -> &str {
        &self.spec
    }
    fn renderer(&self) -> &Renderer {
        &self.inner.renderer
    }
    fn encode_frame(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        timer: Option<&mut GpuTimer>,
    ) -> Result<(), MethodError> {
        Ok(self.inner.encode_frame(&ctx.queue, encoder, timer)?)
    }
    fn spans_per_frame(&self) -> u32 {
        // primary, gi, generate, build, temporal, spatial, shade, shade_direct, persist,
        // accumulate.
        10
    }
    fn one_frame_per_submit(&self) -> bool {
        true
    }
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<(), MethodError> {
        Ok(self.inner.set_camera(&ctx.queue, camera)?)
    }
    fn grid_overflows(&self, ctx: &GpuContext) -> Result<Option<u32>, MethodError> {
        let stats = self
            .inner
            .grid_stats(ctx)
            .map_err(|e| MethodError::WorldRestir(e.into()))?;
        Ok(Some(stats.overflows))
    }
}

/// The variants of `world-restir`, each isolating what one part buys.
pub const WORLD_RESTIR_VARIANTS: [(&str, &str); 9] = [
    ("both", "temporal + spatial reuse (the default)"),
    ("no-reuse", "no temporal, no spatial reuse"),
    ("temporal", "temporal reuse only"),
    ("spatial", "spatial reuse only"),
    ("no-adaptive", "fixed cell size (adaptive cell size off)"),
    ("no-jitter", "no tangent jitter of the lookups"),
    (
        "biased",
        "the paper's 1/M combination weights instead of pairwise MIS",
    ),
    (
        "one-over-z",
        "1/Z combination weights instead of pairwise MIS",
    ),
    (
        "paper-grid",
        "the paper's fixed 100,000 x 32 table instead of one sized to the frame",
    ),
];

/// The configuration of a `world-restir` variant: a named variant, knobs `key=value` (see
/// [`WorldRestirConfig::set`]), or several of them joined by `+`, applied in order (e.g.
/// `biased+spatial-passes=2`).
pub fn world_restir_config(variant: Option<&str>) -> Result<WorldRestirConfig, MethodError> {
    let mut config = WorldRestirConfig::default();
    for part in variant.unwrap_or("both").split('+') {
        config = match part.split_once('=') {
            Some((key, value)) => {
                let mut c = config;
                c.set(key, value).map_err(|e| MethodError::Variant {
                    method: "world-restir".into(),
                    msg: e.to_string(),
                })?;
                c
            }
            None => named_variant(config, part)?,
        };
    }
    config.validate()?;
    Ok(config)
}

/// `d` changed as the named variant says.
fn named_variant(d: WorldRestirConfig, name: &str) -> Result<WorldRestirConfig, MethodError> {
    Ok(match name {
        "both" => d,
        "no-reuse" => WorldRestirConfig {
            temporal: false,
            spatial_passes: 0,
            ..d
        },
        "temporal" => WorldRestirConfig {
            spatial_passes: 0,
            ..d
        },
        "spatial" => WorldRestirConfig {
            temporal: false,
            ..d
        },
        "no-adaptive" => WorldRestirConfig {
            adaptive_cell_size: false,
            ..d
        },
        "no-jitter" => WorldRestirConfig { jitter: false, ..d },
        "biased" => WorldRestirConfig {
            combine: Combine::Biased,
            ..d
        },
        "one-over-z" => WorldRestirConfig {
            combine: Combine::OneOverZ,
            ..d
        },
        "paper-grid" => WorldRestirConfig {
            buckets: Some(100_000),
            ..d
        },
        other => {
            let names: Vec<&str> = WORLD_RESTIR_VARIANTS.iter().map(|v| v.0).collect();
            return Err(MethodError::Variant {
                method: "world-restir".into(),
                msg: format!("unknown variant {other:?}; known: {}", names.join(", ")),
            });
        }
    })
}

fn build_world_restir(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
    variant: Option<&str>,
) -> Result<Box<dyn FrameMethod>, MethodError> {
    let config = world_restir_config(variant)?;
    Ok(Box::new(WorldRestirMethod {
        spec: spec_of("world-restir", variant),
        inner: WorldRestir::new(ctx, scene, camera, config, seed)?,
    }))
}

/// Builds a method of the registry from its variant (`None` = the default).
pub type BuildFn = fn(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
    variant: Option<&str>,
) -> Result<Box<dyn FrameMethod>, MethodError>;

/// One registered method.
#[derive(Clone, Copy)]
pub struct MethodEntry {
    /// Name on the command line.
    pub name: &'static str,
    /// One line for `--help` and reports.
    pub about: &'static str,
    /// The variants it accepts after `:` (documentation; the builder validates).
    pub variants: &'static str,
    /// Whether this is the method that equal-time comparisons are measured against when the
    /// run includes it (world-space ReSTIR).
    pub equal_time_target: bool,
    pub build: BuildFn,
}

impl fmt::Debug for MethodEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MethodEntry")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

fn spec_of(name: &str, variant: Option<&str>) -> String {
    match variant {
        Some(v) => format!("{name}:{v}"),
        None => name.to_owned(),
    }
}

fn build_nee(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
    variant: Option<&str>,
) -> Result<Box<dyn FrameMethod>, MethodError> {
    nee_variant(variant)?;
    Ok(Box::new(Baseline {
        spec: spec_of("nee", variant),
        renderer: Renderer::new(ctx, scene, camera, Method::Nee, seed)?,
    }))
}

/// The candidate count of `ris[:K]`.
fn ris_candidates(variant: Option<&str>) -> Result<u32, MethodError> {
    let bad = |msg: String| MethodError::Variant {
        method: "ris".into(),
        msg,
    };
    let Some(v) = variant else {
        return Ok(super::DEFAULT_CANDIDATES);
    };
    let k: u32 = v
        .parse()
        .map_err(|_| bad(format!("ris:<candidates> wants a number, got {v:?}")))?;
    super::check_candidates(k).map_err(bad)?;
    Ok(k)
}

fn nee_variant(variant: Option<&str>) -> Result<(), MethodError> {
    match variant {
        None => Ok(()),
        Some(v) => Err(MethodError::Variant {
            method: "nee".into(),
            msg: format!("has no variants (got {v:?})"),
        }),
    }
}

/// Checks a method spec (`name` or `name:variant`) without a GPU: the name is registered and
/// its variant parses. Tools call it before any expensive work.
pub fn check_spec(spec: &str) -> Result<(), MethodError> {
    let e = entry(spec)?;
    let variant = spec.split_once(':').map(|(_, v)| v);
    match e.name {
        "nee" => nee_variant(variant),
        "ris" => ris_candidates(variant).map(drop),
        "world-restir" => world_restir_config(variant).map(drop),
        _ => Ok(()),
    }
}

fn build_ris(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
    variant: Option<&str>,
) -> Result<Box<dyn FrameMethod>, MethodError> {
    let method = Method::Ris {
        candidates: ris_candidates(variant)?,
    };
    Ok(Box::new(Baseline {
        spec: spec_of("ris", variant),
        renderer: Renderer::new(ctx, scene, camera, method, seed)?,
    }))
}

/// Every registered method, in display order.
pub fn registry() -> &'static [MethodEntry] {
    const REGISTRY: &[MethodEntry] = &[
        MethodEntry {
            name: "nee",
            about: "one light sample + one shadow ray at each vertex",
            variants: "",
            equal_time_target: false,
            build: build_nee,
        },
        MethodEntry {
            name: "ris",
            about: "RIS over 16 light candidates (ris:K for K), one shadow ray, no reuse",
            variants: "K (candidate count)",
            equal_time_target: false,
            build: build_ris,
        },
        MethodEntry {
            name: "world-restir",
            about: "world-space ReSTIR GI: RIS + hash-grid temporal and spatial reuse",
            variants: "both, no-reuse, temporal, spatial, no-adaptive, no-jitter, biased, one-over-z, \
                       paper-grid, or knobs key=value (e.g. spatial-passes=2), joined by +",
            equal_time_target: true,
            build: build_world_restir,
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
    let e = entry(spec)?;
    let variant = spec.split_once(':').map(|(_, v)| v);
    (e.build)(ctx, scene, camera, seed, variant)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        ] {
            check_spec(good).unwrap();
        }
        for bad in [
            "nee:1",
            "ris:0",
            "ris:65536",
            "ris:x",
            "world-restir:bogus",
            "nope",
        ] {
            assert!(check_spec(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn world_restir_variants_parse() {
        for (v, _) in WORLD_RESTIR_VARIANTS {
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
