//! The registry of rendering methods: every method the tools can run (render, compare) is one
//! [`MethodEntry`] here, built by name into a [`FrameMethod`]. A new method (world-space
//! ReSTIR and its variants) plugs in as one more entry; the tools need no special cases.
//!
//! A method spec is `name` or `name:variant` (e.g. `ris:4` = RIS with 4 candidates).

use std::fmt;

use super::{Method, RenderError, Renderer};
use crate::scene::{Camera, Scene};
use crate::{GpuContext, GpuTimer};

/// One rendering method as the tools drive it: one frame (one sample per pixel of this
/// method) at a time, recorded into the caller's encoder. Each frame leaves its image in the
/// renderer's `direct_frame` / `indirect_frame` buffers and adds it to the accumulation
/// buffers (`accum_direct` / `accum_indirect`), which the caller may clear between frames.
pub trait FrameMethod: fmt::Debug {
    /// The spec it was built from (`name` or `name:variant`).
    fn spec(&self) -> &str;
    /// The renderer whose buffers hold the images.
    fn renderer(&self) -> &Renderer;
    /// Records one frame into `encoder`, one named timestamp span per stage.
    fn encode_frame(&mut self, encoder: &mut wgpu::CommandEncoder, timer: Option<&mut GpuTimer>);
    /// The most timestamp spans one frame records (the timer's capacity per frame).
    fn spans_per_frame(&self) -> u32;
    /// Moves the camera for the next frames (same image size).
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<(), RenderError>;
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
    fn encode_frame(&mut self, encoder: &mut wgpu::CommandEncoder, timer: Option<&mut GpuTimer>) {
        self.renderer.encode_frame(encoder, timer);
    }
    fn spans_per_frame(&self) -> u32 {
        5
    }
    fn set_camera(&mut self, ctx: &GpuContext, camera: &Camera) -> Result<(), RenderError> {
        self.renderer.set_camera(ctx, camera)
    }
}

/// Builds a method of the registry from its variant (`None` = the default).
pub type BuildFn = fn(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
    variant: Option<&str>,
) -> Result<Box<dyn FrameMethod>, RenderError>;

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
) -> Result<Box<dyn FrameMethod>, RenderError> {
    if let Some(v) = variant {
        return Err(RenderError::Settings(format!(
            "nee has no variants (got {v:?})"
        )));
    }
    Ok(Box::new(Baseline {
        spec: spec_of("nee", variant),
        renderer: Renderer::new(ctx, scene, camera, Method::Nee, seed)?,
    }))
}

fn build_ris(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
    variant: Option<&str>,
) -> Result<Box<dyn FrameMethod>, RenderError> {
    let method = match variant {
        None => Method::ris(),
        Some(v) => Method::Ris {
            candidates: v.parse().map_err(|_| {
                RenderError::Settings(format!("ris:<candidates> wants a number, got {v:?}"))
            })?,
        },
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
    ];
    REGISTRY
}

/// The registry entry of `spec` (`name` or `name:variant`).
pub fn entry(spec: &str) -> Result<&'static MethodEntry, RenderError> {
    let name = spec.split_once(':').map_or(spec, |(n, _)| n);
    registry().iter().find(|e| e.name == name).ok_or_else(|| {
        let names: Vec<&str> = registry().iter().map(|e| e.name).collect();
        RenderError::Settings(format!(
            "unknown method {name:?}; known: {}",
            names.join(", ")
        ))
    })
}

/// Builds the method named by `spec` (`name` or `name:variant`).
pub fn build_method(
    spec: &str,
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
) -> Result<Box<dyn FrameMethod>, RenderError> {
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
    }
}
