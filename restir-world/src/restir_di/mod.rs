//! Screen-space spatiotemporal ReSTIR DI at the primary vertex (Bitterli et al. 2020, with
//! Wyman & Panteleev 2021's presampled light tiles), written as a stage that replaces the
//! renderer's direct-light shading (`render_direct_frame`) and leaves the indirect path of the
//! method it is combined with alone.
//!
//! Per frame, after the renderer's `primary` pass, each step its own compute pass and GPU
//! timestamp span:
//!
//! | span | pass | reads | writes |
//! |---|---|---|---|
//! | `light-tiles` | [`LightTiles`] | lights | T tiles x S power-sampled light samples |
//! | `di-initial` | `di_initial` | G-buffer, the block's tile | reservoirs R0 (RIS over `candidates`) |
//! | `di-temporal` | `di_reuse` | R0, last frame's reservoirs, G-buffer and camera | R1 |
//! | `di-spatial` | `di_reuse` | R(cur), G-buffer | R(1-cur) |
//! | `di-shade` | `di_shade` | final reservoirs | `render_direct_frame` (one shadow ray) |
//! | `di-persist` | copies | final reservoirs, G-buffer | last frame's |
//!
//! Each 8x8 pixel block draws its candidates from one tile picked at random per block and
//! frame. A tile entry is a sample of the light table's power pdf (the tiles only reorder the
//! draws), so a candidate's RIS weight is p_hat / pdf as in `ris`. The target is `ris`'s:
//! luminance of the unshadowed reflected radiance. Light samples are in their own measure
//! (area, solid angle, discrete), independent of the receiver: reuse needs no Jacobian.
//!
//! The stage keeps the camera of the last frame it recorded, so [`RestirDi::encode`] after a
//! `set_camera` reprojects through last frame's camera; a camera cut fails the depth and normal
//! tests and merges nothing.

use reservoir::reuse::Combination;

use crate::gpu::{
    Access, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule, buffers,
};
use crate::knobs::{Knobs, Variant, reuse_variants};
use crate::light_tiles::{self, LightTiles};
use crate::render::{
    self, ComposedKernel, KernelDef, RESERVOIRS, REUSE_IO, RenderError, Renderer, ReusePass,
    STAGE_GROUP, SharedGroups,
};
use crate::sampling::CameraGpu;
use crate::scene::Camera;
use crate::screen_reuse::{ReuseBuffers, ReuseChain};

/// Library WGSL (structs and helpers shared by the passes).
pub const WGSL: &str = include_str!("restir_di.wgsl");
const INITIAL_WGSL: &str = include_str!("initial.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");

/// Most spatial neighbours per pixel (`spatial-k`).
pub const MAX_SPATIAL_K: u32 = 16;

/// Errors of ReSTIR DI.
#[derive(Debug, thiserror::Error)]
pub enum RestirDiError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad restir-di setting: {0}")]
    Config(String),
}

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
        /// Temporal reuse through last frame's camera (default on).
        temporal: bool = true, "temporal";
        /// Cap of a reused reservoir's confidence M, in frames of candidates (default 20).
        [gpu] temporal_m_cap: u32 = 20, "temporal-m-cap", 1..=u32::MAX;
        /// Spatial neighbours per pixel (default 4; 0: no spatial pass).
        [gpu] spatial_k: u32 = 4, "spatial-k", 0..=MAX_SPATIAL_K;
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
        self.check_ranges().map_err(RestirDiError::Config)?;
        if self.tiles.checked_mul(self.tile_size).is_none() {
            return Err(RestirDiError::Config(format!(
                "tiles x tile-size = {} x {} does not fit u32",
                self.tiles, self.tile_size
            )));
        }
        Ok(())
    }
}

/// WGSL `DiParams`: the knobs and the frame's history, uploaded every frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DiParams {
    /// [`RestirDiConfig::gpu_words`] (WGSL `DiKnobs`).
    pub knobs: [u32; RestirDiConfig::GPU_WORDS],
    pub prev_camera: CameraGpu,
    /// 1 when last frame's G-buffer and reservoirs exist.
    pub history: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Generated constants header and the knobs' struct.
pub fn constants_wgsl() -> String {
    format!(
        "const DI_MAX_NEIGHBOURS: u32 = {MAX_SPATIAL_K}u;\n{}",
        RestirDiConfig::wgsl_struct("DiKnobs")
    )
}

const PARAMS: (&str, &str, Access) = ("di_params", "DiParams", Access::Uniform);
const INITIAL: KernelDef = KernelDef::new(
    "initial",
    &["di_initial"],
    INITIAL_WGSL,
    &[&[
        PARAMS,
        light_tiles::BINDING,
        ("di_out", RESERVOIRS, Access::ReadWrite),
    ]],
);
const REUSE: KernelDef = KernelDef::new(
    "reuse",
    &["di_reuse"],
    REUSE_WGSL,
    &[
        &[PARAMS],
        REUSE_IO,
        &[("di_prev_gbuffer", "array<GVertex>", Access::Read)],
    ],
);
const SHADE: KernelDef = KernelDef::new(
    "shade",
    &["di_shade"],
    SHADE_WGSL,
    &[&[PARAMS, ("di_final", RESERVOIRS, Access::Read)]],
);
const KERNELS: [&KernelDef; 3] = [&INITIAL, &REUSE, &SHADE];

/// The modules of kernel `k`, composed after the render library (+ the light-tiles reader for
/// kernels that bind the tiles).
fn modules(k: &KernelDef) -> Vec<WgslModule> {
    let mut modules = vec![
        WgslModule::new("di-constants", &[], constants_wgsl()),
        WgslModule::new(
            "di-bindings",
            &["restir-di"],
            k.bindings().wgsl(STAGE_GROUP),
        ),
        WgslModule::new("restir-di", &["render", "reservoir", "di-constants"], WGSL),
        WgslModule::new(k.name, &["restir-di", "di-bindings", "workgroup"], k.source),
    ];
    modules.extend(k.binds("light_tiles").then(light_tiles::reader_module));
    modules
}

/// Every kernel of ReSTIR DI, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    KERNELS
        .iter()
        .map(|k| {
            let source = render::compose_with_library(Tracer::Bvh, modules(k));
            let name = format!("restir-world/restir_di/{}", k.name);
            ComposedKernel::stage(name, source, k.bindings())
        })
        .collect()
}

/// ReSTIR DI's buffers.
#[derive(Debug)]
struct DiBuffers {
    params: wgpu::Buffer,
    reuse: ReuseBuffers,
}

impl DiBuffers {
    fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: &RestirDiConfig,
    ) -> Result<Self, GpuError> {
        let reservoir_size = size_of::<render::StoredReservoir>();
        let reuse = ReuseBuffers::new(ctx, "restir-di", renderer.pixels(), reservoir_size)?;
        let params = RestirDi::params(config, renderer.camera(), false);
        Ok(Self {
            params: buffers::with_usage(
                &ctx.device,
                "di params",
                &[params],
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            reuse,
        })
    }
}

/// The frame's passes.
#[derive(Debug)]
struct DiPasses {
    initial: Pass,
    chain: ReuseChain,
    shade: Pass,
}

impl DiPasses {
    /// Binds every pass (the chain: [`ReuseChain`]).
    fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        b: &DiBuffers,
        config: &RestirDiConfig,
        tiles: &LightTiles,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let kernel = |k: &KernelDef| {
            let name = format!("restir-di {}", k.name);
            shared.own_kernel(ctx, &name, &k.bindings(), modules(k), k.entries)
        };
        let [initial, reuse, shade] = KERNELS.map(kernel);
        let (initial, reuse, shade) = (initial?, reuse?, shade?);
        let params = || ("di_params", Resource::from(&b.params));
        let reuse_pass = |temporal: bool, [src, own, out]: [&wgpu::Buffer; 3]| {
            let u = ReusePass::buffer(device, temporal, 0);
            let res = vec![
                params(),
                ("reuse_pass", (&u).into()),
                ("reuse_src", src.into()),
                ("reuse_self", own.into()),
                ("reuse_out", out.into()),
                ("di_prev_gbuffer", (&b.reuse.prev_gbuffer).into()),
            ];
            shared.bound_pass(device, &reuse, "di_reuse", res, None)
        };
        let spans = ["di-temporal", "di-spatial", "di-persist"];
        let spatial = config.spatial_k > 0;
        let chain = ReuseChain::new(&b.reuse, config.temporal, spatial, spans, reuse_pass)?;
        let r = &b.reuse.reservoirs;
        let initial_res = vec![
            params(),
            ("light_tiles", tiles.buffer().into()),
            ("di_out", (&r[0]).into()),
        ];
        let shade_res = vec![params(), ("di_final", (&r[chain.final_index()]).into())];
        Ok(Self {
            initial: shared.bound_pass(device, &initial, "di_initial", initial_res, None)?,
            chain,
            shade: shared.bound_pass(device, &shade, "di_shade", shade_res, None)?,
        })
    }
}

/// The ReSTIR DI stage of a frame: built on a [`Renderer`]'s shared groups and a frame's
/// [`LightTiles`], it records the direct image in place of
/// [`Renderer::encode_shade_direct`].
#[derive(Debug)]
pub struct RestirDi {
    config: RestirDiConfig,
    buffers: DiBuffers,
    passes: DiPasses,
    /// The camera of the last frame recorded (`None` before the first).
    last_camera: Option<Camera>,
}

impl RestirDi {
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
            return Err(RestirDiError::Config(format!(
                "the light tiles are {:?}, the configuration wants ({}, {})",
                tiles.dims(),
                config.tiles,
                config.tile_size
            )));
        }
        let buffers = DiBuffers::new(ctx, renderer, &config)?;
        let passes = DiPasses::new(ctx, &renderer.shared, &buffers, &config, tiles)?;
        Ok(Self {
            config,
            buffers,
            passes,
            last_camera: None,
        })
    }

    fn params(config: &RestirDiConfig, prev: &Camera, history: bool) -> DiParams {
        DiParams {
            knobs: config.gpu_words(),
            prev_camera: CameraGpu::new(prev),
            history: u32::from(history),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }

    pub fn config(&self) -> &RestirDiConfig {
        &self.config
    }

    /// Records the stage for the frame whose camera is `renderer`'s (after its primary pass
    /// and the light tiles' fill): initial candidates, temporal and spatial reuse, shading into
    /// `render_direct_frame`, and keeps this frame's reservoirs, G-buffer and camera for the
    /// next.
    pub fn encode(&mut self, f: &mut FrameEncoder, renderer: &Renderer) {
        let camera = *renderer.camera();
        let prev = self.last_camera.unwrap_or(camera);
        let params = Self::params(&self.config, &prev, self.last_camera.is_some());
        f.upload(&self.buffers.params, 0, &params);
        let p = &self.passes;
        f.span("di-initial", |f| f.dispatch(&p.initial));
        p.chain.encode(f);
        f.span("di-shade", |f| f.dispatch(&p.shade));
        p.chain
            .persist(f, &self.buffers.reuse, &renderer.buffers.gbuffer);
        self.last_camera = Some(camera);
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(
        &self,
        ctx: &GpuContext,
        renderer: &Renderer,
    ) -> Result<Vec<render::StoredReservoir>, GpuError> {
        let mut v: Vec<render::StoredReservoir> = buffers::read(
            ctx,
            &self.buffers.reuse.reservoirs[self.passes.chain.final_index()],
        )?;
        v.truncate(renderer.pixels() as usize);
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn knobs_set_get_and_validate() {
        let d = RestirDiConfig::default();
        d.validate().unwrap();
        assert_eq!(d.knobs_spec(), "");
        let mut c = d;
        c.set("spatial-k", "2").unwrap();
        c.set("combine", "biased").unwrap();
        c.set("temporal", "off").unwrap();
        assert_eq!(c.knobs_spec(), "temporal=off+spatial-k=2+combine=biased");
        crate::knobs::assert_each_refused(
            d,
            |c: &_| c.validate(),
            &[
                ("tiles", "0"),
                ("tile-size", "0"),
                ("candidates", "0"),
                ("temporal-m-cap", "0"),
                ("spatial-k", "17"),
                ("spatial-radius", "-1"),
                ("normal-threshold", "2"),
                ("depth-threshold", "NaN"),
            ],
        );
        let mut c = d;
        c.set("tiles", "70000").unwrap();
        c.set("tile-size", "65535").unwrap();
        assert!(c.validate().unwrap_err().to_string().contains("fit u32"));
    }

    #[test]
    fn the_knob_struct_is_the_wgsl_one() {
        assert_eq!(RestirDiConfig::GPU_KNOBS, 9);
        assert!(constants_wgsl().contains("struct DiKnobs {\n    tiles: u32,"));
    }
}
