//! Screen-space spatiotemporal ReSTIR GI (Ouyang et al. 2021): per pixel a reservoir of one
//! path sample (the secondary vertex x2 and the radiance leaving it towards the primary),
//! reused between pixels and frames by reconnection, written as a stage that replaces the
//! indirect image of the method it is combined with.
//!
//! The renderer's indirect passes (or world-restir's, in `restir-gi+world-restir`) record each
//! pixel's path sample (x2 and the radiance leaving it, `render_path_radiance`); then the chain of
//! [`crate::screen_reuse`]: `gi-initial` (each pixel's own path sample: W = pi / cos, M = 1 ->
//! reservoirs R0), `gi-temporal`, `gi-spatial`, `gi-shade` (-> `render_indirect_frame`),
//! `gi-persist`.
//!
//! The target is the luminance of the sample's contribution at the receiver, albedo / pi x L x
//! cos. A neighbour's sample is shifted by reconnection with the paper's Jacobian (its Eq. 11)
//! and, by default, one visibility ray; the combination is the reservoir crate's
//! ([`reservoir::reuse`]), pairwise MIS by default. The method's own code is its target, its
//! shift and its neighbour choice (`restir_gi.wgsl`, `reuse.wgsl`).

use reservoir::reuse::Combination;

use gpu_hash::HashStats;

use crate::gpu::{Access, FrameEncoder, GpuContext, GpuError, buffers};
use crate::grid::WorldGrid;
use crate::knobs::{Knobs, Variant, reuse_variants};
use crate::render::{self, Buffer, ComposedKernel, DebugView, Renderer};
use crate::screen_reuse::{self, Chain, ScreenReuse, ScreenReuseError, ScreenStage, StageBuffers};

/// Library WGSL (structs and helpers shared by the passes).
pub const WGSL: &str = include_str!("restir_gi.wgsl");
const INITIAL_WGSL: &str = include_str!("initial.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");

pub mod world;
pub use world::WorldRestirGiConfig;
use world::{Pool, PoolBuffers};

/// Which reconnections trace a visibility ray. A merge shifts each neighbour's sample to the
/// receiver (the *forward* ray: the receiver's x1 to the neighbour's x2) and, for pairwise MIS,
/// the receiver's own sample to each neighbour (the *back* ray: the neighbour's x1 to the
/// receiver's x2, so that a neighbour is never credited with a sample it could not hold).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Visibility {
    /// None: an occluded sample lights the receiver (the paper's biased mode).
    Off = 0,
    /// Both rays for every neighbour: the targets include visibility (unbiased; the default
    /// until 2026-12-05).
    On = 1,
    /// The default: the back rays for every neighbour and the forward ray only for the sample
    /// the merge selects: where it is occluded the neighbours' part counts as 0 and the
    /// receiver keeps its own sample (unbiased: the targets leave visibility out, the integrand
    /// and the MIS weights keep it).
    Selected = 2,
    /// Only the forward ray of the selected sample, no back rays (biased: a neighbour is
    /// credited with samples occluded from it, which darkens the image).
    Final = 3,
}

impl Visibility {
    /// Every mode with its name, in declaration order.
    pub const ALL: [(Visibility, &'static str); 4] = [
        (Self::Off, "off"),
        (Self::On, "on"),
        (Self::Selected, "selected"),
        (Self::Final, "final"),
    ];

    /// The mode's name as the knob takes it.
    pub fn name(self) -> &'static str {
        Self::ALL[self as usize].1
    }

    /// The WGSL constants the passes compare `knobs.visibility` with.
    pub(crate) fn wgsl() -> String {
        Self::ALL
            .iter()
            .map(|(v, name)| {
                format!(
                    "const GI_VISIBILITY_{}: u32 = {}u;\n",
                    name.to_uppercase(),
                    *v as u32
                )
            })
            .collect()
    }
}

crate::choice_knob!(Visibility);

/// Largest stored confidence M (10 bits of [`GiReservoir::normal_m`]); larger sums saturate.
pub const MAX_M: u32 = 1023;

/// Errors of ReSTIR GI (those of every screen-space reuse stage).
pub type RestirGiError = ScreenReuseError;

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
        [gpu] spatial_k: u32 = 4, "spatial-k", 0..=screen_reuse::MAX_SPATIAL_K;
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
        /// Visibility rays of the reconnections (default `selected`: the back ray per neighbour
        /// and the receiver's ray only for the sample a pass selects, unbiased; `on`: both
        /// ways per neighbour, unbiased; `final`: only the selected sample's ray, biased;
        /// `off`: none, the paper's biased mode).
        [gpu] visibility: Visibility = Visibility::Selected, "visibility";
        /// Perceptual roughness below which a glossy primary vertex x1 holds no path sample
        /// and keeps its own path (default 1: only glossy x1 at roughness 1, glTF's default, are
        /// reused; on cornell-glossy reusing every x1 measured break-even). A reconnection
        /// vertex x2 is taken by the knob below.
        [gpu] min_roughness: f32 = 1.0, "min-roughness", 0.0..=1.0;
        /// Perceptual roughness below which a glossy secondary vertex x2 is no reconnection
        /// vertex (its light stays the pixel's own path's); at or above it the sample keeps
        /// x2's BRDF and the directions and weights of its light sample and its path's ray,
        /// and each receiver evaluates x2's BRDF towards itself; such an x2 is sampled as a
        /// diffuse one (RenderOptions::glossy_x2) (default 0.5).
        x2_min_roughness: f32 = 0.5, "x2-min-roughness", 0.0..=1.0;
    }
}

/// The named variants of `restir-gi`: the reuse variants every method has (`biased` is the
/// paper's biased mode here: 1/M and no visibility rays).
pub fn variants() -> Vec<Variant> {
    variants_with("spatial-k=0")
}

/// The reuse variants with `spatial_off` turning spatial reuse off; `biased` is 1/M weights
/// without visibility rays; the two other visibility modes ([`Visibility`]): every ray, and
/// only the final sample's.
fn variants_with(spatial_off: &'static str) -> Vec<Variant> {
    let mut v: Vec<Variant> = reuse_variants(spatial_off)
        .into_iter()
        .map(|v| match v.name {
            "biased" => Variant::new(
                "biased",
                &["combine=biased", "visibility=off"],
                "the paper's biased mode: 1/M weights, no visibility rays",
            ),
            _ => v,
        })
        .collect();
    v.push(Variant::new(
        "all-visibility",
        &["visibility=on"],
        "both rays for every neighbour (unbiased; the default traces the receiver's ray only \
         for the sample a merge selects)",
    ));
    v.push(Variant::new(
        "final-visibility",
        &["visibility=final"],
        "biased: only the selected sample's ray, no rays for the MIS weights",
    ));
    v
}

impl RestirGiConfig {
    /// Checks every knob.
    pub fn validate(&self) -> Result<(), RestirGiError> {
        self.check_ranges()
            .map_err(ScreenReuseError::config("restir-gi"))
    }
}

/// WGSL `GiReservoir` (48 bytes, so that world-restir-gi's pixels' and pool's reservoirs fit
/// one 128 MiB binding at 1920x1080): the sample's x2, W, the radiance leaving x2 (f32 bits),
/// and x2's normal (octahedral, two 11-bit snorm) with M in the top 10 bits; at a glossy x2
/// (`material` not 0) `radiance` holds its continuation's weight (shared-exponent RGB) and the
/// directions of its light sample and its path's ray (octahedral snorm16 x2), and the rest its
/// BRDF (the material word, base colour as unorm10 x3, the shading normal) and its light
/// sample's weight (shared-exponent RGB).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GiReservoir {
    pub position: [f32; 3],
    pub ucw: f32,
    pub radiance: [u32; 3],
    pub normal_m: u32,
    pub material: u32,
    pub base: u32,
    pub shading: u32,
    pub light: u32,
}

impl GiReservoir {
    /// The confidence M.
    pub fn m(&self) -> u32 {
        self.normal_m >> 22
    }
}

/// Generated constants header: the largest M and the knobs' struct, as the shared
/// screen-space WGSL reads it.
pub fn constants_wgsl() -> String {
    format!(
        "const GI_MAX_M: u32 = {MAX_M}u;\n{}{}",
        Visibility::wgsl(),
        RestirGiConfig::wgsl_struct("ScreenKnobs")
    )
}

const DEBUG: Buffer = ("gi_debug", "array<u32>", Access::ReadWrite);

/// ReSTIR GI as a screen-space reuse stage: path samples ([`GiReservoir`]) shifted by
/// reconnection.
pub static STAGE: ScreenStage = ScreenStage {
    name: "restir-gi",
    short: "gi",
    reservoirs: "array<GiReservoir>",
    reservoir_size: size_of::<GiReservoir>(),
    library: WGSL,
    constants: constants_wgsl,
    sources: [INITIAL_WGSL, REUSE_WGSL, SHADE_WGSL],
    own: [&[DEBUG], &[DEBUG], &[]],
    extra_modules: |_| Vec::new(),
    neighbours: screen_reuse::NEIGHBOURS_WGSL,
    grid_lookup: false,
    subpath: None,
};

/// Every kernel of ReSTIR GI, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    STAGE.composed()
}

/// world-restir-gi's world-space part: the grid of the pixels' primary vertices and the pool
/// of records kept across frames.
#[derive(Debug)]
struct WorldCells {
    grid: WorldGrid,
    /// Its `history-frames` (the age view's scale).
    history_frames: u32,
    pool_buffers: PoolBuffers,
    pool: Pool,
}

/// The ReSTIR GI stage of a frame: built on a [`Renderer`], it resamples the path samples the
/// indirect passes recorded (`render_secondary`, `render_path_radiance`) and rewrites the
/// indirect image; its neighbours are the screen's (`restir-gi`) or a world-space grid's
/// (`world-restir-gi`, [`world`]).
#[derive(Debug)]
pub struct RestirGi {
    reuse: ScreenReuse,
    /// The image's pixels (the buffers may hold more: padding, the pool).
    pixels: u32,
    /// Per pixel: neighbours merged (low 16 bits) and reconnections rejected (high 16 bits).
    debug: wgpu::Buffer,
    world: Option<WorldCells>,
}

/// The debug buffer and the reuse chain of `stage` (its reuse kernel looking up `grid` and
/// binding `reuse` beside the debug buffer).
fn reuse_stage(
    ctx: &GpuContext,
    renderer: &Renderer,
    (stage, words, chain): (&'static ScreenStage, &[u32], Chain),
    (grid, reuse): (Option<&WorldGrid>, Vec<(&'static str, &wgpu::Buffer)>),
) -> Result<(ScreenReuse, wgpu::Buffer), RestirGiError> {
    let bytes = u64::from(renderer.pixels()) * 4;
    let debug = buffers::storage_zeroed(&ctx.device, "gi debug", bytes);
    let mut reuse_own = vec![(DEBUG.0, &debug)];
    reuse_own.extend(reuse);
    let own = StageBuffers {
        initial: vec![(DEBUG.0, &debug)],
        reuse: reuse_own,
        grid,
        ..Default::default()
    };
    let reuse = ScreenReuse::new(ctx, renderer, stage, words, chain, own)?;
    Ok((reuse, debug))
}

impl RestirGi {
    /// Screen-space ReSTIR GI for `renderer`'s scene and image with `config`.
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: RestirGiConfig,
    ) -> Result<Self, RestirGiError> {
        config.validate()?;
        let chain = Chain {
            temporal: config.temporal,
            spatial: config.spatial_k > 0,
            pool: 0,
            subpath: false,
        };
        let words = config.gpu_words();
        let stage = (&STAGE, words.as_slice(), chain);
        let (reuse, debug) = reuse_stage(ctx, renderer, stage, (None, Vec::new()))?;
        Ok(Self {
            reuse,
            pixels: renderer.pixels(),
            debug,
            world: None,
        })
    }

    /// World-space ReSTIR GI for `renderer`'s scene and image with `config`.
    pub fn world(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: WorldRestirGiConfig,
    ) -> Result<Self, RestirGiError> {
        config.validate()?;
        if config.subpath_k > 0 && !renderer.options().path_split {
            return Err(ScreenReuseError::config("world-restir-gi")(
                "subpath-k needs a renderer that records the path split \
                 (RenderOptions::path_split)"
                    .into(),
            ));
        }
        let pixels = renderer.pixels();
        let capacity = world::pool_capacity(pixels);
        let chain = Chain {
            temporal: config.temporal,
            spatial: config.spatial_k > 0,
            pool: capacity,
            // One bounce: x2 has no light beyond its own to resample.
            subpath: config.subpath_k > 0 && renderer.options().paths.bounces >= 2,
        };
        let camera = &renderer.gpu_camera();
        let size = size_of::<GiReservoir>();
        let pool_buffers = PoolBuffers::new(ctx, (pixels, config.history_frames, size));
        let items = world::grid_items(pixels, Some(&pool_buffers));
        let grid = WorldGrid::new(
            ctx,
            &renderer.shared,
            config.grid(camera),
            items,
            camera.eye,
        )?;
        let words = config.gpu_words();
        let stage = (&world::STAGE, words.as_slice(), chain);
        let history_age = world::history_age_buffer(ctx, capacity);
        let ages = vec![(world::HISTORY_AGE.0, &history_age)];
        let (reuse, debug) = reuse_stage(ctx, renderer, stage, (Some(&grid), ages))?;
        let history = (reuse.history(), history_age);
        let pool = Pool::new(
            ctx,
            &renderer.shared,
            (pixels, size),
            &pool_buffers,
            history,
        )?;
        Ok(Self {
            reuse,
            pixels: renderer.pixels(),
            debug,
            world: Some(WorldCells {
                grid,
                history_frames: config.history_frames,
                pool_buffers,
                pool,
            }),
        })
    }

    /// Records the stage for the frame whose camera is `renderer`'s, after the indirect passes
    /// recorded the path samples: (world-restir-gi) this frame's grid of the primary vertices,
    /// initial samples, temporal and spatial reuse, shading into `render_indirect_frame`, keeps
    /// this frame's reservoirs, G-buffer and camera, and (world-restir-gi) the next pool.
    pub fn encode(
        &mut self,
        f: &mut FrameEncoder,
        renderer: &Renderer,
    ) -> Result<(), RestirGiError> {
        let Some(w) = &mut self.world else {
            self.reuse.encode(f, renderer, 0);
            return Ok(());
        };
        let eye = renderer.gpu_camera().eye;
        let parity = f.span("wgi-build", |f| w.grid.encode_build(f, eye))?;
        self.reuse.encode(f, renderer, parity);
        let history = self.reuse.history();
        let (pool, buffers) = (&w.pool, &w.pool_buffers);
        f.span("wgi-pool", |f| pool.encode(f, buffers, history))?;
        Ok(())
    }

    /// Bytes of its buffers: the reservoirs and history, the debug counts and
    /// (world-restir-gi) the grid and the pool.
    pub fn bytes(&self) -> u64 {
        let world = self.world.as_ref().map_or(0, |w| {
            w.grid.bytes() + w.pool_buffers.bytes() + w.pool.bytes()
        });
        self.reuse.bytes() + self.debug.size() + world
    }

    /// The pool after the last frame (world-restir-gi): the ages of its records, and how many
    /// records wanted in (more than it holds: the rest were dropped).
    pub fn pool(&self, ctx: &GpuContext) -> Result<Option<(Vec<u32>, u32)>, GpuError> {
        let Some(w) = &self.world else {
            return Ok(None);
        };
        let (mut ages, count) = w.pool_buffers.read(ctx)?;
        ages.truncate(count[0] as usize);
        Ok(Some((ages, count[1])))
    }

    /// Statistics of the last built grid (world-restir-gi).
    pub fn grid_stats(&self, ctx: &GpuContext) -> Result<Option<HashStats>, GpuError> {
        self.world.as_ref().map(|w| w.grid.stats(ctx)).transpose()
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(&self, ctx: &GpuContext) -> Result<Vec<GiReservoir>, GpuError> {
        let mut v: Vec<GiReservoir> = self.reuse.reservoirs(ctx)?;
        v.truncate(self.pixels as usize);
        Ok(v)
    }

    /// Per pixel of the last frame: (neighbours merged, reconnections rejected).
    pub fn reconnections(&self, ctx: &GpuContext) -> Result<Vec<(u32, u32)>, GpuError> {
        Ok(self
            .debug_words(ctx)?
            .iter()
            .map(|w| (w & 0xff, (w >> 8) & 0xff))
            .collect())
    }

    /// Per pixel of the last frame, why its reconnections were refused ([`Refusals`]).
    pub fn refusals(&self, ctx: &GpuContext) -> Result<Vec<Refusals>, GpuError> {
        Ok(self
            .debug_words(ctx)?
            .iter()
            .map(|w| Refusals {
                x1_smooth: w & (1 << 28) != 0,
                x2_smooth: w & (1 << 29) != 0,
                shift: w & (1 << 30) != 0,
                occluded: w & (1 << 31) != 0,
            })
            .collect())
    }

    /// Per pixel of the last frame, where world-restir-gi's temporal neighbour came from;
    /// `None` for restir-gi.
    pub fn history_origins(
        &self,
        ctx: &GpuContext,
    ) -> Result<Option<Vec<HistoryOrigin>>, GpuError> {
        if self.world.is_none() {
            return Ok(None);
        }
        let origin = |w: &u32| match (w >> 16) & 3 {
            1 => HistoryOrigin::Reprojected,
            2 => HistoryOrigin::CellPixel,
            3 => HistoryOrigin::Pool,
            _ => HistoryOrigin::None,
        };
        Ok(Some(self.debug_words(ctx)?.iter().map(origin).collect()))
    }

    /// Per pixel of the last frame, how many frames old world-restir-gi's temporal
    /// neighbour's sample was (1: last frame's pixel; a pooled record more; 0: none merged);
    /// `None` for restir-gi.
    pub fn history_ages(&self, ctx: &GpuContext) -> Result<Option<Vec<u32>>, GpuError> {
        if self.world.is_none() {
            return Ok(None);
        }
        Ok(Some(
            self.debug_words(ctx)?
                .iter()
                .map(|w| (w >> 18) & 0x3ff)
                .collect(),
        ))
    }

    /// gi_debug's word per pixel: bits 0-7 the neighbours merged, 8-15 the reconnections
    /// rejected, and (world-restir-gi) 16-17 the temporal neighbour's origin, 18-27 its age.
    fn debug_words(&self, ctx: &GpuContext) -> Result<Vec<u32>, GpuError> {
        let mut v: Vec<u32> = buffers::read(ctx, &self.debug)?;
        v.truncate(self.pixels as usize);
        Ok(v)
    }
    /// A debug view of the last frame (RGB per pixel): [`DebugView::M`], a heat map of
    /// log2(M) of the final reservoirs (blue M = 1 .. red M = 1023), or
    /// [`DebugView::Rejected`], the share of the pixel's reconnections rejected (black: none
    /// tried, green: none rejected .. red: all), or (world-restir-gi) [`DebugView::History`];
    /// `None` for the other views.
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
            DebugView::Refused => Some(
                self.refusals(ctx)?
                    .iter()
                    .map(|r| {
                        let on = |b: bool| if b { 1.0f32 } else { 0.0 };
                        match r.x1_smooth {
                            true => [0.5; 3],
                            false => [on(r.shift), on(r.occluded), on(r.x2_smooth)],
                        }
                    })
                    .collect(),
            ),
            DebugView::HistoryAge => {
                let most = self.world.as_ref().map_or(1, |w| w.history_frames + 2);
                self.history_ages(ctx)?.map(|ages| {
                    ages.iter()
                        .map(|&a| match a {
                            0 => [0.0; 3],
                            a => render::heat((a - 1) as f32 / (most - 1).max(1) as f32),
                        })
                        .collect()
                })
            }
            DebugView::History => self.history_origins(ctx)?.map(|o| {
                o.iter()
                    .map(|o| match o {
                        HistoryOrigin::None => [0.0; 3],
                        HistoryOrigin::Reprojected => [0.0, 0.0, 1.0],
                        HistoryOrigin::CellPixel => [0.0, 1.0, 0.0],
                        HistoryOrigin::Pool => [1.0, 0.0, 0.0],
                    })
                    .collect()
            }),
            _ => None,
        })
    }
}

/// Why path reuse refused a pixel's reconnections in the last frame (WGSL `GI_REFUSED_*`,
/// [`RestirGi::refusals`], [`DebugView::Refused`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Refusals {
    /// Its primary vertex is glossy below `min-roughness`: it takes no part in the reuse.
    pub x1_smooth: bool,
    /// Its own secondary vertex is glossy below `x2-min-roughness`: no reconnection vertex.
    pub x2_smooth: bool,
    /// A neighbour's shift to it was refused (Jacobian out of range, x2 facing away; with
    /// `visibility=on` also occluded).
    pub shift: bool,
    /// The selected sample was occluded (`visibility=selected` or `final`).
    pub occluded: bool,
}

/// Where a pixel's temporal neighbour came from (world-restir-gi, [`RestirGi::history_origins`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HistoryOrigin {
    /// No temporal neighbour merged (the first frame, nothing similar found).
    None,
    /// Last frame's pixel that saw the receiver's primary vertex.
    Reprojected,
    /// Another pixel of last frame's cell: the reprojection failed.
    CellPixel,
    /// A record the pool kept: the cell was out of view last frame.
    Pool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_structs_are_the_wgsl_ones() {
        assert_eq!(size_of::<GiReservoir>(), 48);
        assert!(constants_wgsl().contains("struct ScreenKnobs {\n    temporal_m_cap: u32,"));
        assert!(WGSL.contains("struct GiReservoir {\n    position: vec3<f32>,\n    ucw: f32,"));
    }

    /// The visibility knob takes each mode's name (and only those), shows it back, and the
    /// WGSL constants the passes compare it with are the GPU words it writes.
    #[test]
    fn visibility_modes_round_trip() {
        use crate::knobs::KnobValue;
        let wgsl = constants_wgsl();
        for (mode, name) in Visibility::ALL {
            assert_eq!(Visibility::parse_knob(name), Some(mode));
            assert_eq!(mode.show_knob(), name);
            let line = format!(
                "const GI_VISIBILITY_{}: u32 = {}u;",
                name.to_uppercase(),
                mode.gpu_word()
            );
            assert!(wgsl.contains(&line), "{line}");
            let mut c = RestirGiConfig::default();
            c.set("visibility", name).unwrap();
            assert_eq!(
                (c.visibility, c.get("visibility").unwrap()),
                (mode, name.into())
            );
        }
        assert_eq!(Visibility::parse_knob("maybe"), None);
        let e = RestirGiConfig::default()
            .set("visibility", "true")
            .unwrap_err();
        assert!(e.contains("off, on, selected, final"), "{e}");
        assert_eq!(RestirGiConfig::default().visibility, Visibility::Selected);
        assert_eq!(
            WorldRestirGiConfig::default().visibility,
            Visibility::Selected
        );
    }
}
