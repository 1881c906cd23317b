//! Screen-space spatiotemporal ReSTIR DI at the primary vertex (Bitterli et al. 2020, with
//! Wyman & Panteleev 2021's presampled light tiles), written as a stage that replaces the
//! renderer's direct-light shading (`render_direct_frame`) and leaves the indirect path of the
//! method it is combined with alone.
//!
//! Per frame, after the renderer's `primary` pass and the light tiles' fill ([`LightTiles`]:
//! T tiles x S power-sampled light samples), the chain of [`crate::screen_reuse`]: `di-initial`
//! (RIS over `candidates` drawn from the block's tile -> reservoirs R0), `di-temporal`,
//! `di-spatial`, `di-shade` (one shadow ray -> `render_direct_frame`), `di-persist`.
//!
//! Each 8x8 pixel block draws its candidates from one tile picked at random per block and
//! frame. A tile entry is a sample of the light table's power pdf (the tiles only reorder the
//! draws), so a candidate's RIS weight is p_hat / pdf as in `ris`. The target is `ris`'s:
//! luminance of the unshadowed reflected radiance. Light samples are in their own measure
//! (area, solid angle, discrete), independent of the receiver: reuse needs no Jacobian.

use reservoir::reuse::Combination;

use crate::gpu::{Access, FrameEncoder, GpuContext, GpuError, WgslModule, buffers};
use crate::knobs::{Knobs, Variant, reuse_variants};
use crate::light_tiles::{self, LightTiles};
use crate::render::{self, ComposedKernel, Renderer};
use crate::screen_reuse::{
    self, Chain, Kernel, ScreenReuse, ScreenReuseError, ScreenStage, StageBuffers,
};

const LIBRARY_WGSL: &str = include_str!("restir_di.wgsl");
const INITIAL_WGSL: &str = include_str!("initial.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");

/// Errors of ReSTIR DI (those of every screen-space reuse stage).
pub type RestirDiError = ScreenReuseError;

crate::knobs! {
    /// Every knob of ReSTIR DI with its default.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct RestirDiConfig {
        /// Light tiles filled per frame (default 128, RTXDI's).
        [gpu] tiles: u32 = 128, "tiles", 1..=u32::MAX;
        /// Light samples per tile (default 1024, RTXDI's). `tiles x tile_size` samples of 64
        /// bytes must fit one storage binding of the device.
        [gpu] tile_size: u32 = 1024, "tile-size", 1..=render::MAX_CANDIDATES;
        /// RIS candidates per pixel, drawn from its block's tile (default 16, `ris`'s).
        [gpu] candidates: u32 = render::DEFAULT_CANDIDATES, "candidates", 1..=render::MAX_CANDIDATES;
        /// Light samples of the light table per pixel, apart from the reservoir's, that estimate
        /// its mean incident light, the normaliser of the MIS density that follows the
        /// resampled distribution (default 4; 0: MIS with the light table's density, as `ris`).
        [gpu] mis_candidates: u32 = 4, "mis-candidates", 0..=render::MAX_CANDIDATES;
        /// Temporal reuse through last frame's camera (default on).
        temporal: bool = true, "temporal";
        /// Cap of a reused reservoir's confidence M, in frames of candidates (default 20).
        [gpu] temporal_m_cap: u32 = 20, "temporal-m-cap", 1..=u32::MAX;
        /// Spatial neighbours per pixel (default 4; 0: no spatial pass).
        [gpu] spatial_k: u32 = 4, "spatial-k", 0..=screen_reuse::MAX_SPATIAL_K;
        /// Radius of the spatial neighbourhood in pixels (default 3). RTXDI's 32 is for 1080p;
        /// on many-lights at 128x128 (small lights near the surfaces: the target changes within
        /// a few pixels) the frame relMSE of the direct image was 3.07 at 30 px, 2.10 at 4, 1.53
        /// at 3 and 1.56 at 2 (seed 1; seed 2: 1.28 at 3, 2.81 at 2: fireflies decide single
        /// runs), against 4.62 for `ris`.
        [gpu] spatial_radius: f32 = 3.0, "spatial-radius", 0.0..=4096.0;
        /// A reused pixel's depth (distance to the eye) must be within this fraction of the
        /// receiver's (default 0.1).
        [gpu] depth_threshold: f32 = 0.1, "depth-threshold", 0.0..=f32::MAX;
        /// Cosine between a reused pixel's shading normal and the receiver's, at least (default
        /// 0.9, about 25 degrees).
        [gpu] normal_threshold: f32 = 0.9, "normal-threshold", -1.0..=1.0;
        /// Combination weights (default pairwise MIS, unbiased; `biased` is the paper's 1/M,
        /// `one-over-z` Bitterli et al.'s 1/Z).
        [gpu] combine: Combination = Combination::Pairwise, "combine";
        /// Perceptual roughness below which a glossy primary vertex is not reused: it holds no
        /// reservoir and gets the renderer's own direct light (default 0: every vertex is
        /// reused, its target the full BRDF towards its camera).
        [gpu] min_roughness: f32 = 0.0, "min-roughness", 0.0..=1.0;
        /// The light tiles also feed world-restir's generate pass (default off; only in
        /// `world-restir+restir-di`): its GI vertices draw their candidates from the tile of
        /// their pixel's block.
        gi_tiles: bool = false, "gi-tiles";
    }
}

/// The named variants of `restir-di` (and of the direct light of `world-restir+restir-di`):
/// the reuse variants every method has, then its own.
pub fn variants() -> Vec<Variant> {
    let mut v = reuse_variants("spatial-k=0");
    v.push(Variant::new(
        "gi-tiles",
        &["gi-tiles=on"],
        "the light tiles also feed world-restir's generate (world-restir+restir-di only)",
    ));
    v
}

impl RestirDiConfig {
    /// Checks every knob (device-independent limits; [`RestirDi::new`] also checks the tile
    /// buffer against the device).
    pub fn validate(&self) -> Result<(), RestirDiError> {
        self.check_ranges()
            .map_err(ScreenReuseError::config("restir-di"))?;
        if self.tiles.checked_mul(self.tile_size).is_none() {
            return Err(ScreenReuseError::config("restir-di")(format!(
                "tiles x tile-size = {} x {} does not fit u32",
                self.tiles, self.tile_size
            )));
        }
        Ok(())
    }
}

/// ReSTIR DI as a screen-space reuse stage: light samples (the render library's
/// `StoredReservoir`), no shift.
pub static STAGE: ScreenStage = ScreenStage {
    name: "restir-di",
    short: "di",
    reservoirs: "array<StoredReservoir>",
    reservoir_size: size_of::<render::StoredReservoir>(),
    library: LIBRARY_WGSL,
    constants: constants_wgsl,
    sources: [INITIAL_WGSL, REUSE_WGSL, SHADE_WGSL],
    own: [
        &[
            light_tiles::BINDING,
            ("di_estimate", ESTIMATE, Access::ReadWrite),
        ],
        &[],
        &[("di_estimate", ESTIMATE, Access::Read)],
    ],
    extra_modules,
    neighbours: screen_reuse::NEIGHBOURS_WGSL,
    grid_lookup: false,
    subpath: None,
};

/// Each pixel's MIS estimate (WGSL `render_light_estimate`), from the initial pass to the shade.
const ESTIMATE: &str = "array<f32>";

/// The knobs' struct, as the shared screen-space WGSL reads it.
pub fn constants_wgsl() -> String {
    RestirDiConfig::wgsl_struct("ScreenKnobs")
}

/// The light-tiles reader, for the initial kernel (it binds the tiles).
fn extra_modules(k: Kernel) -> Vec<WgslModule> {
    match k {
        Kernel::Initial => vec![light_tiles::reader_module()],
        Kernel::Reuse | Kernel::Shade => Vec::new(),
    }
}

/// Every kernel of ReSTIR DI, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    STAGE.composed()
}

/// The ReSTIR DI stage of a frame: built on a [`Renderer`] and a frame's [`LightTiles`], it
/// records the direct image in place of [`Renderer::encode_shade_direct`].
#[derive(Debug)]
pub struct RestirDi {
    config: RestirDiConfig,
    reuse: ScreenReuse,
    /// Bound by the initial and shade passes ([`ESTIMATE`]).
    _estimate: wgpu::Buffer,
}

impl RestirDi {
    /// Bytes of its buffers (the reservoirs and history; the light tiles are their owner's).
    pub fn bytes(&self) -> u64 {
        self.reuse.bytes() + self._estimate.size()
    }

    /// The stage for `renderer`'s scene and image with `config`, drawing its candidates from
    /// `tiles` (filled every frame by their owner before [`RestirDi::encode`]).
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: RestirDiConfig,
        tiles: &LightTiles,
    ) -> Result<Self, RestirDiError> {
        config.validate()?;
        if tiles.dims() != (config.tiles, config.tile_size) {
            return Err(ScreenReuseError::config("restir-di")(format!(
                "the light tiles are {:?}, the configuration wants ({}, {})",
                tiles.dims(),
                config.tiles,
                config.tile_size
            )));
        }
        let chain = Chain {
            temporal: config.temporal,
            spatial: config.spatial_k > 0,
            pool: 0,
            subpath: false,
        };
        let px = u64::from(renderer.pixels());
        let estimate = buffers::storage_zeroed(&ctx.device, "di estimate", px * 4);
        let own = StageBuffers {
            initial: vec![("light_tiles", tiles.buffer()), ("di_estimate", &estimate)],
            shade: vec![("di_estimate", &estimate)],
            ..Default::default()
        };
        let reuse = ScreenReuse::new(ctx, renderer, &STAGE, &config.gpu_words(), chain, own)?;
        Ok(Self {
            config,
            reuse,
            _estimate: estimate,
        })
    }

    pub fn config(&self) -> &RestirDiConfig {
        &self.config
    }

    /// Records the stage for the frame whose camera is `renderer`'s (after its primary pass
    /// and the light tiles' fill): initial candidates, temporal and spatial reuse, shading into
    /// `render_direct_frame`, and keeps this frame's reservoirs, G-buffer and camera for the
    /// next.
    pub fn encode(&mut self, f: &mut FrameEncoder, renderer: &Renderer) {
        self.reuse.encode(f, renderer, 0);
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(
        &self,
        ctx: &GpuContext,
        renderer: &Renderer,
    ) -> Result<Vec<render::StoredReservoir>, GpuError> {
        let mut v: Vec<render::StoredReservoir> = self.reuse.reservoirs(ctx)?;
        v.truncate(renderer.pixels() as usize);
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_knob_struct_is_the_wgsl_one() {
        assert_eq!(RestirDiConfig::GPU_KNOBS, 11);
        assert!(constants_wgsl().contains("struct ScreenKnobs {\n    tiles: u32,"));
    }
}
