//! Screen-space spatiotemporal ReSTIR GI (Ouyang et al. 2021): per pixel a reservoir of one
//! path sample (the secondary vertex x2 and the radiance leaving it towards the primary),
//! reused between pixels and frames by reconnection, written as a stage that replaces the
//! indirect image of the method it is combined with.
//!
//! The renderer's indirect passes (or world-restir's, in `restir-gi+world-restir`) estimate the
//! radiance leaving each pixel's x2 ([`Renderer::set_secondary_radiance`]); then, each step its
//! own compute pass and GPU timestamp span:
//!
//! | span | pass | reads | writes |
//! |---|---|---|---|
//! | `gi-initial` | `gi_initial` | G-buffer, x2, its radiance | reservoirs R0 (W = pi / cos, M = 1) |
//! | `gi-temporal` | `gi_reuse` | R0, last frame's reservoirs, G-buffer and camera | R1 |
//! | `gi-spatial` | `gi_reuse` | R(cur), G-buffer | R(1-cur) |
//! | `gi-shade` | `gi_shade` | final reservoirs | `render_indirect_frame` |
//! | `gi-persist` | copies | final reservoirs, G-buffer | last frame's |
//!
//! The target is the luminance of the sample's contribution at the receiver, albedo / pi x L x
//! cos. A neighbour's sample is shifted by reconnection with the paper's Jacobian (its Eq. 11)
//! and, by default, one visibility ray; the combination is the reservoir crate's
//! ([`reservoir::reuse`]), pairwise MIS by default. The method's own code is its target, its
//! shift and its neighbour choice (`restir_gi.wgsl`, `reuse.wgsl`).
//!
//! The stage keeps the camera of the last frame it recorded, so [`RestirGi::encode`] after a
//! `set_camera` reprojects through last frame's camera; a camera cut fails the depth and normal
//! tests and merges nothing.

use reservoir::reuse::Combination;

use crate::gpu::{
    Access, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule, buffers,
};
use crate::knobs::{Knobs, Variant, reuse_variants};
use crate::render::{
    self, Buffer, ComposedKernel, DebugView, KernelDef, RenderError, Renderer, ReusePass,
    STAGE_GROUP, SharedGroups,
};
use crate::sampling::CameraGpu;
use crate::scene::Camera;
use crate::screen_reuse::{ReuseBuffers, ReuseChain};

/// Library WGSL (structs and helpers shared by the passes).
pub const WGSL: &str = include_str!("restir_gi.wgsl");
const INITIAL_WGSL: &str = include_str!("initial.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");

/// Most spatial neighbours per pixel (`spatial-k`).
pub const MAX_SPATIAL_K: u32 = 16;
/// Largest stored confidence M (10 bits of [`GiReservoir::normal_m`]); larger sums saturate.
pub const MAX_M: u32 = 1023;

/// Errors of ReSTIR GI.
#[derive(Debug, thiserror::Error)]
pub enum RestirGiError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad restir-gi setting: {0}")]
    Config(String),
}

crate::knobs! {
    /// Every knob of ReSTIR GI with its default. The candidates are the paths themselves
    /// (one per pixel and frame, of the render's depth).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct RestirGiConfig {
        /// Temporal reuse through last frame's camera (default on).
        temporal: bool = true, "temporal";
        /// Cap of a reused reservoir's confidence M, in frames of paths (default 20).
        [gpu] temporal_m_cap: u32 = 20, "temporal-m-cap", 1..=MAX_M;
        /// Spatial neighbours per pixel (default 4; 0: no spatial pass).
        [gpu] spatial_k: u32 = 4, "spatial-k", 0..=MAX_SPATIAL_K;
        /// Radius of the spatial neighbourhood in pixels (default 8).
        [gpu] spatial_radius: f32 = 8.0, "spatial-radius", 0.0..=4096.0;
        /// A reused pixel's depth (distance to the eye) must be within this fraction of the
        /// receiver's (default 0.1).
        [gpu] depth_threshold: f32 = 0.1, "depth-threshold", 0.0..=f32::MAX;
        /// Cosine between a reused pixel's shading normal and the receiver's, at least (default
        /// 0.9, about 25 degrees).
        [gpu] normal_threshold: f32 = 0.9, "normal-threshold", -1.0..=1.0;
        /// A reconnection whose Jacobian is above this or below its inverse is rejected
        /// (default 10): such a shift stretches the neighbour's density into a firefly.
        [gpu] max_jacobian: f32 = 10.0, "max-jacobian", 1.0..=f32::MAX;
        /// Combination weights (default pairwise MIS, unbiased; `biased` is the paper's 1/M,
        /// `one-over-z` Bitterli et al.'s 1/Z).
        [gpu] combine: Combination = Combination::Pairwise, "combine";
        /// One visibility ray per reconnection (default on, unbiased). Off: none, the paper's
        /// biased mode (a reused sample occluded from the receiver still lights it).
        [gpu] visibility: bool = true, "visibility";
    }
}

/// The named variants of `restir-gi`: the reuse variants every method has (`biased` is the
/// paper's biased mode here: 1/M and no visibility rays).
pub fn variants() -> Vec<Variant> {
    reuse_variants("spatial-k=0")
        .into_iter()
        .map(|v| match v.name {
            "biased" => Variant::new(
                "biased",
                &["combine=biased", "visibility=off"],
                "the paper's biased mode: 1/M weights, no visibility rays",
            ),
            _ => v,
        })
        .collect()
}

impl RestirGiConfig {
    /// Checks every knob.
    pub fn validate(&self) -> Result<(), RestirGiError> {
        self.check_ranges().map_err(RestirGiError::Config)
    }
}

/// WGSL `GiReservoir` (32 bytes): the sample's x2 and the radiance leaving it, W, and x2's
/// normal (octahedral, two 11-bit snorm) with M in the top 10 bits.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GiReservoir {
    pub position: [f32; 3],
    pub ucw: f32,
    pub radiance: [f32; 3],
    pub normal_m: u32,
}

impl GiReservoir {
    /// The confidence M.
    pub fn m(&self) -> u32 {
        self.normal_m >> 22
    }
}

/// WGSL `GiParams`: the knobs and the frame's history, uploaded every frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GiParams {
    /// [`RestirGiConfig::gpu_words`] (WGSL `GiKnobs`).
    pub knobs: [u32; RestirGiConfig::GPU_WORDS],
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
        "const GI_MAX_NEIGHBOURS: u32 = {MAX_SPATIAL_K}u;\nconst GI_MAX_M: u32 = {MAX_M}u;\n{}",
        RestirGiConfig::wgsl_struct("GiKnobs")
    )
}

const RESERVOIRS: &str = "array<GiReservoir>";
const PARAMS: Buffer = ("gi_params", "GiParams", Access::Uniform);
const DEBUG: Buffer = ("gi_debug", "array<u32>", Access::ReadWrite);
const INITIAL: KernelDef = KernelDef::new(
    "initial",
    &["gi_initial"],
    INITIAL_WGSL,
    &[&[PARAMS, ("gi_out", RESERVOIRS, Access::ReadWrite), DEBUG]],
);
const REUSE: KernelDef = KernelDef::new(
    "reuse",
    &["gi_reuse"],
    REUSE_WGSL,
    &[
        &[PARAMS],
        &[
            ("reuse_pass", "ReusePass", Access::Read),
            ("reuse_src", RESERVOIRS, Access::Read),
            ("reuse_self", RESERVOIRS, Access::Read),
            ("reuse_out", RESERVOIRS, Access::ReadWrite),
        ],
        &[("gi_prev_gbuffer", "array<GVertex>", Access::Read), DEBUG],
    ],
);
const SHADE: KernelDef = KernelDef::new(
    "shade",
    &["gi_shade"],
    SHADE_WGSL,
    &[&[PARAMS, ("gi_final", RESERVOIRS, Access::Read)]],
);
const KERNELS: [&KernelDef; 3] = [&INITIAL, &REUSE, &SHADE];

/// The modules of kernel `k`, composed after the render library.
fn modules(k: &KernelDef) -> Vec<WgslModule> {
    vec![
        WgslModule::new("gi-constants", &[], constants_wgsl()),
        WgslModule::new(
            "gi-bindings",
            &["restir-gi"],
            k.bindings().wgsl(STAGE_GROUP),
        ),
        WgslModule::new("restir-gi", &["render", "reservoir", "gi-constants"], WGSL),
        WgslModule::new(k.name, &["restir-gi", "gi-bindings", "workgroup"], k.source),
    ]
}

/// Every kernel of ReSTIR GI, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    KERNELS
        .iter()
        .map(|k| {
            let source = render::compose_with_library(Tracer::Bvh, modules(k));
            let name = format!("restir-world/restir_gi/{}", k.name);
            ComposedKernel::stage(name, source, k.bindings())
        })
        .collect()
}

/// ReSTIR GI's buffers.
#[derive(Debug)]
struct GiBuffers {
    params: wgpu::Buffer,
    reuse: ReuseBuffers,
    /// Per pixel: neighbours merged (low 16 bits) and reconnections rejected (high 16 bits).
    debug: wgpu::Buffer,
}

impl GiBuffers {
    fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: &RestirGiConfig,
    ) -> Result<Self, GpuError> {
        let pixels = renderer.pixels();
        let reuse = ReuseBuffers::new(ctx, "restir-gi", pixels, size_of::<GiReservoir>())?;
        let device = &ctx.device;
        let params = RestirGi::params(config, renderer.camera(), false);
        Ok(Self {
            params: buffers::with_usage(
                device,
                "gi params",
                &[params],
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            reuse,
            debug: buffers::storage_zeroed(device, "gi debug", u64::from(pixels) * 4),
        })
    }
}

/// The frame's passes.
#[derive(Debug)]
struct GiPasses {
    initial: Pass,
    chain: ReuseChain,
    shade: Pass,
}

impl GiPasses {
    /// Binds every pass (the chain: [`ReuseChain`]).
    fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        b: &GiBuffers,
        config: &RestirGiConfig,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let kernel = |k: &KernelDef| {
            let name = format!("restir-gi {}", k.name);
            shared.own_kernel(ctx, &name, &k.bindings(), modules(k), k.entries)
        };
        let [initial, reuse, shade] = KERNELS.map(kernel);
        let (initial, reuse, shade) = (initial?, reuse?, shade?);
        let params = || ("gi_params", Resource::from(&b.params));
        let reuse_pass = |temporal: bool, [src, own, out]: [&wgpu::Buffer; 3]| {
            let u = ReusePass::buffer(device, temporal, 0);
            let res = vec![
                params(),
                ("reuse_pass", (&u).into()),
                ("reuse_src", src.into()),
                ("reuse_self", own.into()),
                ("reuse_out", out.into()),
                ("gi_prev_gbuffer", (&b.reuse.prev_gbuffer).into()),
                ("gi_debug", (&b.debug).into()),
            ];
            shared.bound_pass(device, &reuse, "gi_reuse", res, None)
        };
        let spans = ["gi-temporal", "gi-spatial", "gi-persist"];
        let spatial = config.spatial_k > 0;
        let chain = ReuseChain::new(&b.reuse, config.temporal, spatial, spans, reuse_pass)?;
        let r = &b.reuse.reservoirs;
        let initial_res = vec![
            params(),
            ("gi_out", (&r[0]).into()),
            ("gi_debug", (&b.debug).into()),
        ];
        let shade_res = vec![params(), ("gi_final", (&r[chain.final_index()]).into())];
        Ok(Self {
            initial: shared.bound_pass(device, &initial, "gi_initial", initial_res, None)?,
            chain,
            shade: shared.bound_pass(device, &shade, "gi_shade", shade_res, None)?,
        })
    }
}

/// The ReSTIR GI stage of a frame: built on a [`Renderer`]'s shared groups, it resamples the
/// paths whose secondary radiance the indirect passes left in `render_indirect_frame` and
/// writes the indirect image.
#[derive(Debug)]
pub struct RestirGi {
    config: RestirGiConfig,
    buffers: GiBuffers,
    passes: GiPasses,
    /// The camera of the last frame recorded (`None` before the first).
    last_camera: Option<Camera>,
}

impl RestirGi {
    /// The stage for `renderer`'s scene and image with `config`; switches the renderer's
    /// indirect passes to writing the secondary vertex's radiance.
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: RestirGiConfig,
    ) -> Result<Self, RestirGiError> {
        config.validate()?;
        let buffers = GiBuffers::new(ctx, renderer, &config)?;
        let passes = GiPasses::new(ctx, &renderer.shared, &buffers, &config)?;
        renderer.set_secondary_radiance(ctx, true);
        Ok(Self {
            config,
            buffers,
            passes,
            last_camera: None,
        })
    }

    fn params(config: &RestirGiConfig, prev: &Camera, history: bool) -> GiParams {
        GiParams {
            knobs: config.gpu_words(),
            prev_camera: CameraGpu::new(prev),
            history: u32::from(history),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }

    pub fn config(&self) -> &RestirGiConfig {
        &self.config
    }

    /// Records the stage for the frame whose camera is `renderer`'s, after the indirect passes
    /// wrote the secondary radiance: initial samples, temporal and spatial reuse, shading into
    /// `render_indirect_frame`, and keeps this frame's reservoirs, G-buffer and camera.
    pub fn encode(&mut self, f: &mut FrameEncoder, renderer: &Renderer) {
        let camera = *renderer.camera();
        let prev = self.last_camera.unwrap_or(camera);
        let history = self.last_camera.is_some();
        let params = Self::params(&self.config, &prev, history);
        f.upload(&self.buffers.params, 0, &params);
        let p = &self.passes;
        f.span("gi-initial", |f| f.dispatch(&p.initial));
        p.chain.encode(f);
        f.span("gi-shade", |f| f.dispatch(&p.shade));
        p.chain
            .persist(f, &self.buffers.reuse, &renderer.buffers.gbuffer);
        self.last_camera = Some(camera);
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(&self, ctx: &GpuContext) -> Result<Vec<GiReservoir>, GpuError> {
        let i = self.passes.chain.final_index();
        buffers::read(ctx, &self.buffers.reuse.reservoirs[i])
    }

    /// Per pixel of the last frame: (neighbours merged, reconnections rejected).
    pub fn reconnections(&self, ctx: &GpuContext) -> Result<Vec<(u32, u32)>, GpuError> {
        let v: Vec<u32> = buffers::read(ctx, &self.buffers.debug)?;
        Ok(v.iter().map(|w| (w & 0xffff, w >> 16)).collect())
    }

    /// A debug view of the last frame (RGB per pixel): [`DebugView::M`], a heat map of
    /// log2(M) of the final reservoirs (blue M = 1 .. red M = 1023), or
    /// [`DebugView::Rejected`], the share of the pixel's reconnections rejected (black: none
    /// tried, green: none rejected .. red: all); `None` for the views of a hash grid.
    pub fn debug_image(
        &self,
        ctx: &GpuContext,
        view: DebugView,
    ) -> Result<Option<Vec<[f32; 3]>>, GpuError> {
        Ok(match view {
            DebugView::M => Some(
                self.reservoirs(ctx)?
                    .iter()
                    .map(|r| match r.m() {
                        0 => [0.0; 3],
                        m => render::heat((m as f32).log2() / (MAX_M as f32).log2()),
                    })
                    .collect(),
            ),
            DebugView::Rejected => Some(
                self.reconnections(ctx)?
                    .iter()
                    .map(|&(tried, rejected)| match tried {
                        0 => [0.0; 3],
                        _ => {
                            let t = rejected as f32 / tried as f32;
                            [t, 1.0 - t, 0.0]
                        }
                    })
                    .collect(),
            ),
            _ => None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn knobs_set_get_and_validate() {
        let d = RestirGiConfig::default();
        d.validate().unwrap();
        assert_eq!(d.knobs_spec(), "");
        let mut c = d;
        c.set("spatial-k", "2").unwrap();
        c.set("combine", "biased").unwrap();
        c.set("visibility", "off").unwrap();
        assert_eq!(c.knobs_spec(), "spatial-k=2+combine=biased+visibility=off");
        crate::knobs::assert_each_refused(
            d,
            |c: &_| c.validate(),
            &[
                ("temporal-m-cap", "0"),
                ("temporal-m-cap", "1024"),
                ("spatial-k", "17"),
                ("spatial-radius", "-1"),
                ("normal-threshold", "2"),
                ("depth-threshold", "NaN"),
                ("max-jacobian", "0.5"),
            ],
        );
    }

    #[test]
    fn the_structs_are_the_wgsl_ones() {
        assert_eq!(size_of::<GiReservoir>(), 32);
        assert!(constants_wgsl().contains("struct GiKnobs {\n    temporal_m_cap: u32,"));
        assert!(WGSL.contains("struct GiReservoir {\n    position: vec3<f32>,\n    ucw: f32,"));
    }
}
