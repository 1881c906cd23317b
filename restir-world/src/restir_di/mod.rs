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
//! | `di-tiles` | `di_fill_tiles` | lights | T tiles x S power-sampled light samples |
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

use crate::gpu::{
    Access, BindGroupLayout, BindingSet, FrameEncoder, GpuContext, GpuError, Kernel, Pass,
    Resource, Tracer, WgslModule, buffers,
};
use crate::render::{self, GVertex, RenderError, Renderer, SharedGroups};
use crate::sampling::CameraGpu;
use crate::scene::Camera;
use crate::world_restir::Combine;

/// Library WGSL (structs and helpers shared by the passes).
pub const WGSL: &str = include_str!("restir_di.wgsl");
const TILES_WGSL: &str = include_str!("tiles.wgsl");
const INITIAL_WGSL: &str = include_str!("initial.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");
const LIGHT_TILES_WGSL: &str = include_str!("light_tiles.wgsl");

/// Random-stream ids of the passes (the renderer reserves 0..4, world-restir 4..8).
const PASS_TILES: u32 = 8;
const PASS_TILE_PICK: u32 = 9;
const PASS_INITIAL: u32 = 10;
const PASS_TEMPORAL: u32 = 11;
const PASS_SPATIAL: u32 = 12;

/// The group every ReSTIR DI pass binds its own buffers at (0..3 are the renderer's).
pub const GROUP: u32 = 3;

/// Most spatial neighbours per pixel (`spatial-k`).
pub const MAX_SPATIAL_K: u32 = 16;

/// Bytes of one WGSL `LightSample` in an array (52 bytes of fields, 16-byte aligned).
pub const LIGHT_SAMPLE_BYTES: u64 = 64;

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

/// Every knob of ReSTIR DI with its default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestirDiConfig {
    /// Light tiles filled per frame (default 128, RTXDI's).
    pub tiles: u32,
    /// Light samples per tile (default 1024, RTXDI's). `tiles x tile_size` samples of 64 bytes
    /// must fit one storage binding of the device.
    pub tile_size: u32,
    /// RIS candidates per pixel, drawn from its block's tile (default 16, `ris`'s).
    pub candidates: u32,
    /// Temporal reuse through last frame's camera (default on).
    pub temporal: bool,
    /// Cap of a reused reservoir's confidence M, in frames of candidates (default 20).
    pub temporal_m_cap: u32,
    /// Spatial neighbours per pixel (default 4; 0: no spatial pass; at most
    /// [`MAX_SPATIAL_K`]).
    pub spatial_k: u32,
    /// Radius of the spatial neighbourhood in pixels (default 3). RTXDI's 32 is for 1080p;
    /// on many-lights at 128x128 (small lights near the surfaces: the target changes within a
    /// few pixels) the frame relMSE of the direct image was 3.07 at 30 px, 2.10 at 4, 1.53 at
    /// 3 and 1.56 at 2 (seed 1; seed 2: 1.28 at 3, 2.81 at 2: fireflies decide single runs),
    /// against 4.62 for `ris`.
    pub spatial_radius: f32,
    /// A reused pixel's depth (distance to the eye) must be within this fraction of the
    /// receiver's (default 0.1).
    pub depth_threshold: f32,
    /// Cosine between a reused pixel's shading normal and the receiver's, at least (default
    /// 0.9, about 25 degrees).
    pub normal_threshold: f32,
    /// Combination weights (default [`Combine::Pairwise`], unbiased; or [`Combine::Biased`],
    /// the paper's 1/M; 1/Z is world-restir's only).
    pub combine: Combine,
    /// The light tiles also feed world-restir's generate pass (default off; only with
    /// world-restir, i.e. `world-restir+restir-di`): its GI vertices draw their candidates from
    /// the tile of their pixel's block, filled once per frame before it.
    pub gi_tiles: bool,
}

impl Default for RestirDiConfig {
    fn default() -> Self {
        Self {
            tiles: 128,
            tile_size: 1024,
            candidates: render::DEFAULT_CANDIDATES,
            temporal: true,
            temporal_m_cap: 20,
            spatial_k: 4,
            spatial_radius: 3.0,
            depth_threshold: 0.1,
            normal_threshold: 0.9,
            combine: Combine::Pairwise,
            gi_tiles: false,
        }
    }
}

impl RestirDiConfig {
    /// The knob names [`RestirDiConfig::set`] takes.
    pub const KNOBS: [&'static str; 11] = [
        "tiles",
        "tile-size",
        "candidates",
        "temporal",
        "temporal-m-cap",
        "spatial-k",
        "spatial-radius",
        "depth-threshold",
        "normal-threshold",
        "combine",
        "gi-tiles",
    ];

    /// Sets one knob from its name (with `-` or `_`) and a value: numbers, `on` / `off` for
    /// `temporal`, `biased` / `pairwise` for `combine`.
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), RestirDiError> {
        fn parse<T: std::str::FromStr>(key: &str, value: &str) -> Result<T, RestirDiError> {
            value
                .parse()
                .map_err(|_| RestirDiError::Config(format!("{key}: cannot parse {value:?}")))
        }
        fn switch(key: &str, value: &str) -> Result<bool, RestirDiError> {
            match value {
                "on" | "true" | "1" => Ok(true),
                "off" | "false" | "0" => Ok(false),
                _ => Err(RestirDiError::Config(format!(
                    "{key}: expected on or off, got {value:?}"
                ))),
            }
        }
        match key.replace('-', "_").as_str() {
            "tiles" => self.tiles = parse(key, value)?,
            "tile_size" => self.tile_size = parse(key, value)?,
            "candidates" => self.candidates = parse(key, value)?,
            "temporal" => self.temporal = switch(key, value)?,
            "gi_tiles" => self.gi_tiles = switch(key, value)?,
            "temporal_m_cap" => self.temporal_m_cap = parse(key, value)?,
            "spatial_k" => self.spatial_k = parse(key, value)?,
            "spatial_radius" => self.spatial_radius = parse(key, value)?,
            "depth_threshold" => self.depth_threshold = parse(key, value)?,
            "normal_threshold" => self.normal_threshold = parse(key, value)?,
            "combine" => {
                self.combine = value
                    .parse()
                    .map_err(|e| RestirDiError::Config(format!("{key}: {e}")))?
            }
            _ => return Err(Self::unknown(key)),
        }
        Ok(())
    }

    fn unknown(key: &str) -> RestirDiError {
        RestirDiError::Config(format!(
            "unknown knob {key:?}; known: {}",
            Self::KNOBS.join(", ")
        ))
    }

    /// The value of one knob as [`RestirDiConfig::set`] takes it back.
    pub fn get(&self, key: &str) -> Result<String, RestirDiError> {
        Ok(match key.replace('-', "_").as_str() {
            "tiles" => self.tiles.to_string(),
            "tile_size" => self.tile_size.to_string(),
            "candidates" => self.candidates.to_string(),
            "temporal" => if self.temporal { "on" } else { "off" }.to_owned(),
            "gi_tiles" => if self.gi_tiles { "on" } else { "off" }.to_owned(),
            "temporal_m_cap" => self.temporal_m_cap.to_string(),
            "spatial_k" => self.spatial_k.to_string(),
            "spatial_radius" => self.spatial_radius.to_string(),
            "depth_threshold" => self.depth_threshold.to_string(),
            "normal_threshold" => self.normal_threshold.to_string(),
            "combine" => self.combine.name().to_owned(),
            _ => return Err(Self::unknown(key)),
        })
    }

    /// The knobs where `self` differs from the default, as `key=value` joined by `+` (empty
    /// for the default).
    pub fn knobs_spec(&self) -> String {
        let default = Self::default();
        Self::KNOBS
            .iter()
            .filter_map(|k| {
                let v = self.get(k).ok()?;
                (default.get(k).ok()? != v).then(|| format!("{k}={v}"))
            })
            .collect::<Vec<_>>()
            .join("+")
    }

    /// Checks every knob (device-independent limits; [`RestirDi::new`] also checks the tile
    /// buffer against the device).
    pub fn validate(&self) -> Result<(), RestirDiError> {
        let bad = |m: String| Err(RestirDiError::Config(m));
        if self.combine == Combine::OneOverZ {
            return bad(
                "combine: one-over-z is world-restir's only; restir-di has biased and pairwise"
                    .into(),
            );
        }
        if self.tiles == 0 {
            return bad("tiles must be at least 1".into());
        }
        if !(1..=render::MAX_CANDIDATES).contains(&self.tile_size) {
            return bad(format!(
                "tile-size {} must be in 1..={}",
                self.tile_size,
                render::MAX_CANDIDATES
            ));
        }
        if self.tiles.checked_mul(self.tile_size).is_none() {
            return bad(format!(
                "tiles x tile-size = {} x {} does not fit u32",
                self.tiles, self.tile_size
            ));
        }
        render::check_candidates(self.candidates)
            .map_err(|e| RestirDiError::Config(format!("candidates: {e}")))?;
        if self.temporal_m_cap == 0 {
            return bad("temporal-m-cap must be at least 1".into());
        }
        if self.spatial_k > MAX_SPATIAL_K {
            return bad(format!(
                "spatial-k {} must be in 0..={MAX_SPATIAL_K}",
                self.spatial_k
            ));
        }
        if !(self.spatial_radius.is_finite() && (0.0..=4096.0).contains(&self.spatial_radius)) {
            return bad(format!(
                "spatial-radius {} must be in 0..=4096 pixels",
                self.spatial_radius
            ));
        }
        if !(self.depth_threshold.is_finite() && self.depth_threshold >= 0.0) {
            return bad(format!(
                "depth-threshold {} must be a fraction >= 0",
                self.depth_threshold
            ));
        }
        if !(-1.0..=1.0).contains(&self.normal_threshold) {
            return bad(format!(
                "normal-threshold {} must be a cosine in [-1, 1]",
                self.normal_threshold
            ));
        }
        Ok(())
    }

    /// Bytes of the light tiles.
    pub fn tile_bytes(&self) -> u64 {
        u64::from(self.tiles) * u64::from(self.tile_size) * LIGHT_SAMPLE_BYTES
    }
}

/// WGSL `DiParams`: the knobs and the frame's history, uploaded every frame.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DiParams {
    pub prev_camera: CameraGpu,
    pub tiles: u32,
    pub tile_size: u32,
    pub candidates: u32,
    /// 1 when last frame's G-buffer and reservoirs exist.
    pub history: u32,
    pub temporal_m_cap: u32,
    pub spatial_k: u32,
    pub spatial_radius: f32,
    /// [`Combine`] as u32.
    pub combine: u32,
    pub depth_threshold: f32,
    pub normal_threshold: f32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// WGSL `DiPass`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DiPass {
    pub temporal: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// The reader of the presampled light tiles (light_tiles.wgsl), for kernels that bind
/// `light_tiles`: restir-di's initial candidates, and world-restir's generate when the tiles
/// feed it ([`RestirDiConfig::gi_tiles`]).
pub(crate) fn light_tiles_module() -> WgslModule {
    let source =
        format!("const LIGHT_TILES_PICK_PASS: u32 = {PASS_TILE_PICK}u;\n{LIGHT_TILES_WGSL}");
    WgslModule::new("light-tiles", &["render"], source)
}

/// Generated constants header.
pub fn constants_wgsl() -> String {
    format!(
        "const DI_PASS_TILES: u32 = {PASS_TILES}u;\n\
         const DI_PASS_INITIAL: u32 = {PASS_INITIAL}u;\nconst DI_PASS_TEMPORAL: u32 = {PASS_TEMPORAL}u;\n\
         const DI_PASS_SPATIAL: u32 = {PASS_SPATIAL}u;\nconst DI_NO_PIXEL: u32 = 0xffffffffu;\n\
         const DI_MAX_NEIGHBOURS: u32 = {MAX_SPATIAL_K}u;\n\
         const DI_COMBINE_BIASED: u32 = {}u;\nconst DI_COMBINE_PAIRWISE: u32 = {}u;\n",
        Combine::Biased as u32,
        Combine::Pairwise as u32,
    )
}

/// One kernel module: its own group-3 buffers, its WGSL and entry point.
struct KernelDef {
    name: &'static str,
    entry: &'static str,
    source: &'static str,
    own: &'static [(&'static str, &'static str, Access)],
}

const RES: &str = "array<StoredReservoir>";
const PARAMS: (&str, &str, Access) = ("di_params", "DiParams", Access::Uniform);
const TILES: KernelDef = KernelDef {
    name: "tiles",
    entry: "di_fill_tiles",
    source: TILES_WGSL,
    own: &[
        PARAMS,
        ("light_tiles", "array<LightSample>", Access::ReadWrite),
    ],
};
const INITIAL: KernelDef = KernelDef {
    name: "initial",
    entry: "di_initial",
    source: INITIAL_WGSL,
    own: &[
        PARAMS,
        ("light_tiles", "array<LightSample>", Access::Read),
        ("di_out", RES, Access::ReadWrite),
    ],
};
const REUSE: KernelDef = KernelDef {
    name: "reuse",
    entry: "di_reuse",
    source: REUSE_WGSL,
    own: &[
        PARAMS,
        ("di_pass", "DiPass", Access::Read),
        ("di_src", RES, Access::Read),
        ("di_self", RES, Access::Read),
        ("di_out", RES, Access::ReadWrite),
        ("di_prev_gbuffer", "array<GVertex>", Access::Read),
    ],
};
const SHADE: KernelDef = KernelDef {
    name: "shade",
    entry: "di_shade",
    source: SHADE_WGSL,
    own: &[PARAMS, ("di_final", RES, Access::Read)],
};
const KERNELS: [&KernelDef; 4] = [&TILES, &INITIAL, &REUSE, &SHADE];

impl KernelDef {
    fn bindings(&self) -> BindingSet {
        BindingSet::of_buffers(self.name, self.own)
    }

    /// The modules composed after the render library (+ the light-tiles reader for kernels
    /// that bind the tiles).
    fn modules(&self) -> Vec<WgslModule> {
        let tiles = self.own.iter().any(|(name, _, _)| *name == "light_tiles");
        let mut modules = vec![
            WgslModule::new("di-constants", &[], constants_wgsl()),
            WgslModule::new("di-bindings", &["restir-di"], self.bindings().wgsl(GROUP)),
            WgslModule::new("restir-di", &["render", "reservoir", "di-constants"], WGSL),
            WgslModule::new(
                self.name,
                &["restir-di", "di-bindings", "workgroup"],
                self.source,
            ),
        ];
        modules.extend(tiles.then(light_tiles_module));
        modules
    }
}

/// Every WGSL module of ReSTIR DI, composed as used.
pub fn wgsl_modules() -> Vec<(String, String)> {
    KERNELS
        .iter()
        .map(|k| {
            (
                format!("restir-world/restir_di/{}", k.name),
                render::compose_with_library(Tracer::Bvh, k.modules()),
            )
        })
        .collect()
}

/// ReSTIR DI's buffers.
#[derive(Debug)]
struct DiBuffers {
    params: wgpu::Buffer,
    tiles: wgpu::Buffer,
    reservoirs: [wgpu::Buffer; 2],
    prev_reservoirs: wgpu::Buffer,
    prev_gbuffer: wgpu::Buffer,
}

/// The frame's passes.
#[derive(Debug)]
struct DiPasses {
    tiles: Pass,
    initial: Pass,
    temporal: Option<Pass>,
    spatial: Option<Pass>,
    shade: Pass,
    /// The reservoirs the shade pass reads.
    final_index: usize,
}

/// The ReSTIR DI stage of a frame: built on a [`Renderer`]'s shared groups, it records the
/// direct image in place of [`Renderer::encode_shade_direct`].
#[derive(Debug)]
pub struct RestirDi {
    config: RestirDiConfig,
    buffers: DiBuffers,
    passes: DiPasses,
    /// The camera of the last frame recorded (`None` before the first).
    last_camera: Option<Camera>,
}

impl RestirDi {
    /// The stage for `renderer`'s scene and image with `config`.
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: RestirDiConfig,
    ) -> Result<Self, RestirDiError> {
        config.validate()?;
        ctx.check_binding_size(
            "the restir-di light tiles (lower tiles or tile-size)",
            config.tile_bytes(),
        )?;
        let px = u64::from(renderer.pixels());
        let res_bytes = px * size_of::<render::StoredReservoir>() as u64;
        ctx.check_binding_size("the restir-di reservoirs", res_bytes)?;
        let device = &ctx.device;
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(device, label, size);
        let b = DiBuffers {
            params: buffers::with_usage(
                device,
                "di params",
                &[Self::params(&config, renderer.camera(), false)],
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            tiles: zeroed("di tiles", config.tile_bytes()),
            reservoirs: [0, 1].map(|p| zeroed(&format!("di reservoirs {p}"), res_bytes)),
            prev_reservoirs: zeroed("di prev reservoirs", res_bytes),
            prev_gbuffer: zeroed("di prev gbuffer", px * size_of::<GVertex>() as u64),
        };
        let passes = Self::passes(ctx, &renderer.shared, &b, &config)?;
        Ok(Self {
            config,
            buffers: b,
            passes,
            last_camera: None,
        })
    }

    fn params(config: &RestirDiConfig, prev: &Camera, history: bool) -> DiParams {
        DiParams {
            prev_camera: CameraGpu::new(prev),
            tiles: config.tiles,
            tile_size: config.tile_size,
            candidates: config.candidates,
            history: u32::from(history),
            temporal_m_cap: config.temporal_m_cap,
            spatial_k: config.spatial_k,
            spatial_radius: config.spatial_radius,
            combine: config.combine as u32,
            depth_threshold: config.depth_threshold,
            normal_threshold: config.normal_threshold,
            _pad0: 0,
            _pad1: 0,
        }
    }

    /// Binds every pass. Reservoir chain: initial -> R0; temporal R0 (+ last frame's) -> R1;
    /// spatial R(cur) -> R(1-cur); shade reads the last.
    fn passes(
        ctx: &GpuContext,
        shared: &SharedGroups,
        b: &DiBuffers,
        config: &RestirDiConfig,
    ) -> Result<DiPasses, RestirDiError> {
        let device = &ctx.device;
        let kernel = |k: &KernelDef| {
            let name = format!("restir-di {}", k.name);
            shared.own_kernel(ctx, &name, &k.bindings(), k.modules(), &[k.entry])
        };
        let [tiles, initial, reuse, shade] = KERNELS.map(kernel);
        let (tiles, initial, reuse, shade) = (tiles?, initial?, reuse?, shade?);
        let group = |(_, layout): &(Kernel, BindGroupLayout), res: Vec<(&str, Resource)>| {
            layout.bind(device, res)
        };
        let pass = |k: &(Kernel, BindGroupLayout), entry: &str, res: Vec<(&str, Resource)>| {
            let g = group(k, res)?;
            Ok::<Pass, GpuError>(shared.pass(device, &k.0, entry, Some(&g)))
        };
        let params = || ("di_params", Resource::from(&b.params));
        let r = &b.reservoirs;
        let reuse_pass = |temporal: bool, [src, own, out]: [&wgpu::Buffer; 3]| {
            let u = DiPass {
                temporal: u32::from(temporal),
                ..Default::default()
            };
            let u = buffers::with_usage(device, "di pass", &[u], wgpu::BufferUsages::STORAGE);
            let res = vec![
                params(),
                ("di_pass", (&u).into()),
                ("di_src", src.into()),
                ("di_self", own.into()),
                ("di_out", out.into()),
                ("di_prev_gbuffer", (&b.prev_gbuffer).into()),
            ];
            pass(&reuse, "di_reuse", res)
        };
        let mut cur = 0;
        let temporal = match config.temporal {
            true => {
                cur = 1;
                Some(reuse_pass(true, [&b.prev_reservoirs, &r[0], &r[1]])?)
            }
            false => None,
        };
        let spatial = match config.spatial_k {
            0 => None,
            _ => {
                let p = reuse_pass(false, [&r[cur], &r[cur], &r[1 - cur]])?;
                cur = 1 - cur;
                Some(p)
            }
        };
        // The tile pass runs over tiles x tile_size items, not pixels.
        let tile_group = group(&tiles, vec![params(), ("light_tiles", (&b.tiles).into())])?;
        let mut groups: Vec<&wgpu::BindGroup> = shared.groups.iter().collect();
        groups.push(&tile_group);
        let tile_pass = tiles.0.pass(
            device,
            "di_fill_tiles",
            &groups,
            config.tiles * config.tile_size,
        );
        Ok(DiPasses {
            tiles: tile_pass,
            initial: pass(
                &initial,
                "di_initial",
                vec![
                    params(),
                    ("light_tiles", (&b.tiles).into()),
                    ("di_out", (&r[0]).into()),
                ],
            )?,
            temporal,
            spatial,
            shade: pass(
                &shade,
                "di_shade",
                vec![params(), ("di_final", (&r[cur]).into())],
            )?,
            final_index: cur,
        })
    }

    pub fn config(&self) -> &RestirDiConfig {
        &self.config
    }

    /// Records the stage for the frame whose camera is `camera` (the renderer's, after its
    /// primary pass): tiles, initial candidates, temporal and spatial reuse, shading into
    /// `render_direct_frame`, and keeps this frame's reservoirs, G-buffer and camera for the
    /// next.
    pub fn encode(&mut self, f: &mut FrameEncoder, renderer: &Renderer) {
        let camera = *renderer.camera();
        let prev = self.last_camera.unwrap_or(camera);
        let params = Self::params(&self.config, &prev, self.last_camera.is_some());
        f.upload(&self.buffers.params, 0, &params);
        let p = &self.passes;
        if !self.config.gi_tiles {
            self.encode_tiles(f);
        }
        f.span("di-initial", |f| f.dispatch(&p.initial));
        if let Some(t) = &p.temporal {
            f.span("di-temporal", |f| f.dispatch(t));
        }
        if let Some(s) = &p.spatial {
            f.span("di-spatial", |f| f.dispatch(s));
        }
        f.span("di-shade", |f| f.dispatch(&p.shade));
        if p.temporal.is_some() {
            let b = &self.buffers;
            f.span("di-persist", |f| {
                f.copy(&b.reservoirs[p.final_index], &b.prev_reservoirs);
                f.copy(&renderer.buffers.gbuffer, &b.prev_gbuffer);
            });
        }
        self.last_camera = Some(camera);
    }

    /// Records the fill of this frame's light tiles (span `di-tiles`). [`RestirDi::encode`] does
    /// it, except with [`RestirDiConfig::gi_tiles`]: world-restir then calls it before its
    /// generate pass, which reads the same tiles.
    pub fn encode_tiles(&self, f: &mut FrameEncoder) {
        f.span("di-tiles", |f| f.dispatch(&self.passes.tiles));
    }

    /// The light tiles buffer (`tiles x tile_size` `LightSample`s).
    pub(crate) fn tiles(&self) -> &wgpu::Buffer {
        &self.buffers.tiles
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(
        &self,
        ctx: &GpuContext,
        renderer: &Renderer,
    ) -> Result<Vec<render::StoredReservoir>, GpuError> {
        let mut v: Vec<render::StoredReservoir> =
            buffers::read(ctx, &self.buffers.reservoirs[self.passes.final_index])?;
        v.truncate(renderer.pixels() as usize);
        Ok(v)
    }
}

/// The `ris` baseline with its direct light at the primary vertex replaced by ReSTIR DI
/// (indirect: `ris`'s NEE at the secondary vertex).
#[derive(Debug)]
pub struct RestirDiRenderer {
    renderer: Renderer,
    di: RestirDi,
}

impl RestirDiRenderer {
    pub fn new(
        ctx: &GpuContext,
        scene: &crate::scene::Scene,
        camera: &Camera,
        config: RestirDiConfig,
        seed: u32,
    ) -> Result<Self, RestirDiError> {
        config.validate()?;
        if config.gi_tiles {
            return Err(RestirDiError::Config(
                "gi-tiles feeds world-restir's generate pass: use world-restir+restir-di".into(),
            ));
        }
        let renderer = Renderer::new(ctx, scene, camera, render::ris(), seed)?;
        let di = RestirDi::new(ctx, &renderer, config)?;
        Ok(Self { renderer, di })
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    pub fn di(&self) -> &RestirDi {
        &self.di
    }

    /// Moves the camera from the next recorded frame on (the DI stage keeps the last frame's
    /// for reprojection).
    pub fn set_camera(&mut self, camera: &Camera) -> Result<(), RestirDiError> {
        Ok(self.renderer.set_camera(camera)?)
    }

    /// Records one whole frame.
    pub fn encode_frame(&mut self, f: &mut FrameEncoder) {
        self.renderer.encode_primary_and_gi(f);
        self.di.encode(f, &self.renderer);
        self.renderer.encode_shade_indirect(f);
        self.renderer.encode_accumulate(f);
    }

    /// Clears the accumulated images (the temporal history stays).
    pub fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        self.renderer.restart_accumulation(f);
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
        for k in RestirDiConfig::KNOBS {
            let mut c = d;
            c.set(k, &d.get(k).unwrap()).unwrap();
            assert_eq!(c, d, "{k}");
        }
        let mut c = d;
        c.set("spatial-k", "2").unwrap();
        c.set("combine", "biased").unwrap();
        c.set("temporal", "off").unwrap();
        assert_eq!(c.knobs_spec(), "temporal=off+spatial-k=2+combine=biased");
        for (k, v) in [
            ("tiles", "0"),
            ("tile-size", "0"),
            ("candidates", "0"),
            ("temporal-m-cap", "0"),
            ("spatial-k", "17"),
            ("spatial-radius", "-1"),
            ("normal-threshold", "2"),
            ("depth-threshold", "NaN"),
        ] {
            let mut c = d;
            c.set(k, v).unwrap();
            let e = c.validate().unwrap_err().to_string();
            assert!(e.contains(k), "{k}={v}: {e}");
        }
        for (k, v) in [("nosuch", "1"), ("tiles", "x"), ("temporal", "maybe")] {
            let mut c = d;
            assert!(c.set(k, v).is_err(), "{k}={v}");
        }
    }

    #[test]
    fn the_light_sample_stride_is_the_wgsl_one() {
        // position, pdf_area, normal, light, emission, triangle, coords (8-aligned), kind:
        // 15 x 4 bytes, rounded up to the 16-byte alignment of its vec3 fields.
        assert_eq!(LIGHT_SAMPLE_BYTES, (15u64 * 4).next_multiple_of(16));
    }
}
