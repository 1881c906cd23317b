//! World-space spatiotemporal reservoir reuse for one-bounce diffuse GI (Boissé 2021),
//! composed from `gpu-hash` (the grid), `gpu-scan` (the slot offsets) and `reservoir` (every
//! reservoir operation) on the renderer's shared passes.
//!
//! Per frame, each step its own compute pass and GPU timestamp span (DESIGN.md section 3):
//!
//! | span | passes | reads | writes |
//! |---|---|---|---|
//! | `primary`, `gi` | the renderer's | camera, BVH | G-buffer, secondary vertices |
//! | `generate` | `wr_generate` (Alg. 1), with each vertex's MIS estimate | secondary, lights | reservoirs R0, estimates |
//! | `build` | the [`WorldGrid`]'s (Alg. 2): clear, insert, gpu-scan, scatter, sort cells | secondary | grid\[p\] |
//! | `temporal` | `wr_reuse` over table\[1-p\] (Alg. 3) | R0, prev reservoirs | R1 |
//! | `spatial` | k x `wr_reuse` over table\[p\], ping-pong | R1/R0 | R0/R1 |
//! | `shade` | `wr_shade` | final reservoirs | `render_indirect_frame` |
//! | `shade_direct` | the renderer's, or `wr_shade_direct` when unified | | direct |
//! | `accumulate` | the renderer's | | sums |
//! | `persist` | copy final reservoirs -> prev reservoirs | | |
//! | `path` | `wr_path`: the renderer's path, each vertex's MIS estimate and (`path-reservoirs`) one of its cell's final reservoirs from grid\[p\] ([`WorldRestir::encode_path`]) | estimates, final reservoirs | path radiance, indirect |
//!
//! The passes from `generate` to `spatial` run over the grid's items: the secondary vertices,
//! followed by the primary ones with the unified cache ([`WorldRestirConfig::unified`]).
//!
//! `p` is the frame's parity: the grid ([`crate::grid`]) is double-buffered and its two
//! halves swap roles each frame, so the temporal pass looks vertices up in last frame's grid
//! with last frame's eye.
//!
//! Composition: each kernel is a `KernelDef`: its own group-3 [`BindingSet`] (plus the grid's
//! lookup for the reuse pass) and its WGSL file, composed after `render::library()` (render
//! buffers at group 0, BVH at 1, lights at 2, rng and reservoir WGSL) with `world_restir.wgsl`.
//! No grid, scan, hash or reservoir math is written here: the grid items are the secondary
//! vertices (`items.wgsl`), the record per item is a light reservoir.

use gpu_hash::{CellSizing, HashStats, TableConfig};

use reservoir::reuse::Combination;

use crate::gpu::{
    Access, BindingSet, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule,
    buffers,
};
use crate::grid::{self, GridError, GridItems, GridSettings, WorldGrid};
use crate::knobs::{Knobs, Variant, reuse_variants};
use crate::light_tiles::{self, LightTiles};
use crate::render::{
    self, Buffer, ComposedKernel, DebugView, GRID_WORLD_RESTIR, KernelDef, OwnKernel, RESERVOIRS,
    REUSE_IO, RenderError, Renderer, ReusePass, STAGE_GROUP, SharedGroups,
};
use crate::scene::Camera;

pub use crate::grid::{GridReadback, auto_buckets};

/// Library WGSL (structs and helpers shared by the passes).
pub const WGSL: &str = include_str!("world_restir.wgsl");
const GENERATE_WGSL: &str = include_str!("generate.wgsl");
const ITEMS_WGSL: &str = include_str!("items.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");
const DEBUG_WGSL: &str = include_str!("debug.wgsl");
const ESTIMATE_WGSL: &str = include_str!("estimate.wgsl");
const PATH_WGSL: &str = include_str!("path.wgsl");
const PATH_LIGHT_WGSL: &str = include_str!("path_light.wgsl");

/// Errors of world-space ReSTIR.
#[derive(Debug, thiserror::Error)]
pub enum WorldRestirError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Hash(#[from] gpu_hash::HashError),
    #[error(transparent)]
    Grid(#[from] GridError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad world-restir setting: {0}")]
    Config(String),
}

crate::knobs! {
    /// Every knob of world-space ReSTIR, with the paper's defaults (Boissé 2021, section 5, and
    /// AMD's public implementation where the paper is silent).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct WorldRestirConfig {
        /// Hash-grid buckets. `auto` (the default): sized to the frame by [`auto_buckets`] from
        /// the number of vertices that can enter the grid; 100000 is the paper's fixed table.
        buckets: Option<u32> = None, "buckets", Some(1)..=Some(u32::MAX);
        /// Slots per bucket, i.e. linear-probing length (default 32, the paper's).
        slots: u32 = 32, "slots";
        /// RIS light candidates per vertex, the initial M (default 16, the paper's).
        [gpu] candidates: u32 = render::DEFAULT_CANDIDATES, "candidates", 1..=render::MAX_CANDIDATES;
        /// Light samples of the light table per vertex, apart from the reservoir's, that estimate
        /// its mean incident light, the normaliser of the MIS density that follows the
        /// resampled distribution (default 4; 0: MIS with the light table's density, as `ris`).
        [gpu] mis_candidates: u32 = 4, "mis-candidates", 0..=render::MAX_CANDIDATES;
        /// Reservoirs merged per cell lookup at most (default 4, the paper's `max_count`).
        [gpu] max_count: u32 = 4, "max-count", 1..=u32::MAX;
        /// Spatial reuse passes per frame (default 2; the paper's is 4). Chosen by measurement
        /// on many-lights at 256x256 (llvmpipe, equal time against ris): 2 passes had the lowest
        /// indirect relMSE per GPU millisecond; a third and fourth pass mostly re-merge the same
        /// ~4 reservoirs of a cell and cost more than they remove.
        spatial_passes: u32 = 2, "spatial-passes", 0..=64;
        /// One temporal reuse pass from last frame's grid (default on, the paper's).
        temporal: bool = true, "temporal";
        /// Cap of the confidence taken from last frame, as a multiple of `candidates` (default
        /// 20: at most 20 x 16 = 320 in total; each of the n <= max_count reservoirs the temporal
        /// lookup visits is capped at 320 / n).
        [gpu] temporal_m_cap: u32 = 20, "temporal-m-cap", 1..=65_535;
        /// Smallest cell edge in world units (default 0.01 = 1 cm; the cell size when
        /// `adaptive_cell_size` is off).
        min_cell_size: f32 = 0.01, "min-cell-size";
        /// Targeted projected cell size in pixels of the adaptive cell size (default 16).
        projected_size: f32 = 16.0, "projected-size";
        /// Tangent-plane jitter of the vertex position by up to one cell before insertion and
        /// lookup (default on).
        jitter: bool = true, "jitter";
        /// Cell size adapted to the distance from the eye (paper Algorithm 4; default on). Off:
        /// every cell is `min_cell_size`.
        adaptive_cell_size: bool = true, "adaptive-cell-size";
        /// The axis the vertex normal points along most folded into the cell's key (as the
        /// radiance cache's cells): the faces of a corner never share a cell (default off, the
        /// paper's grid; `normal-threshold` skips reservoirs of other orientations).
        fold_normal: bool = false, "fold-normal";
        /// A stored reservoir is reused only when the cosine between its vertex normal and the
        /// receiver's is at least this (default 0.8409 = 0.5^(1/4), i.e. dot^4 >= 0.5, about 33
        /// degrees, as in Capsaicin).
        [gpu] normal_threshold: f32 = 0.840_896_4, "normal-threshold", -1.0..=1.0;
        /// GI resolution scale as a stride (default 1 = every pixel; 2 = one pixel of each 2x2
        /// block, rotating over frames, generates a reservoir and enters the grid: the paper's
        /// half resolution). Every pixel still looks the grid up and shades. Needs reuse on (with
        /// no reuse the other pixels stay black). Biased above 1: a pixel without a reservoir of
        /// its own gets only samples its neighbours could draw (measured on many-lights at
        /// 128x128 with stride 2: indirect mean -15/-22/-13% per channel), so the default stays 1.
        [gpu] gi_stride: u32 = 1, "gi-stride", 1..=8;
        /// World-space reservoirs at every path vertex past the secondary one (default on): the
        /// vertex's RIS reservoir (the renderer's `candidates`) merges one final reservoir of
        /// its cell in this frame's grid before its shadow ray. Off: the renderer's RIS there.
        [gpu] path_reservoirs: bool = false, "path-reservoirs";
        /// How reused reservoirs are weighted (default pairwise MIS, unbiased; `biased` is the
        /// paper's 1/M, `one-over-z` Bitterli et al.'s 1/Z).
        [gpu] combine: Combination = Combination::Pairwise, "combine";
        /// Order each cell's vertex list by index after the scatter, so images do not depend on
        /// the order atomics ran in (default on; not in the paper, which accepts the race).
        sort_cells: bool = true, "sort-cells";
        /// One reservoir cache for all light (the paper's future work; default off): primary
        /// vertices enter the same grid as the secondary ones with reservoirs of their own, go
        /// through the same temporal and spatial reuse, and their final reservoirs light the
        /// direct image (one shadow ray each) instead of the renderer's RIS.
        unified: bool = false, "unified";
    }
}

/// The named variants of `world-restir`: the reuse variants every method has, then its own.
pub fn variants() -> Vec<Variant> {
    let mut v = reuse_variants("spatial-passes=0");
    v.extend([
        Variant::new(
            "no-adaptive",
            &["adaptive-cell-size=off"],
            "fixed cell size",
        ),
        Variant::new(
            "no-jitter",
            &["jitter=off"],
            "no tangent jitter of the lookups",
        ),
        Variant::new(
            "one-over-z",
            &["combine=one-over-z"],
            "1/Z weights instead of pairwise MIS",
        ),
        Variant::new(
            "paper-grid",
            &["buckets=100000"],
            "the paper's fixed 100,000 x 32 table",
        ),
        Variant::new(
            "unified",
            &["unified=on"],
            "one cache for all light: primary vertices in the grid too, direct light from it",
        ),
    ]);
    v
}

impl WorldRestirConfig {
    /// No temporal and no spatial reuse: the `ris` baseline's estimator.
    pub fn no_reuse() -> Self {
        Self {
            temporal: false,
            spatial_passes: 0,
            ..Self::default()
        }
    }

    /// Most vertices that enter the grid in one frame at `width` x `height`: one per pixel of
    /// each `gi_stride` x `gi_stride` block, plus every pixel's primary vertex when unified.
    pub fn max_vertices(&self, width: u32, height: u32) -> u32 {
        let secondary =
            width.div_ceil(self.gi_stride.max(1)) * height.div_ceil(self.gi_stride.max(1));
        secondary.saturating_add(if self.unified { width * height } else { 0 })
    }

    /// Grid items (vertices with a reservoir slot) of a frame of `pixels`: the secondary
    /// vertices, then the primary ones when unified.
    pub fn items(&self, pixels: u32) -> u32 {
        pixels.saturating_mul(if self.unified { 2 } else { 1 })
    }

    /// The hash table's dimensions for frames of `width` x `height`.
    pub fn table(&self, width: u32, height: u32) -> TableConfig {
        let vertices = self.max_vertices(width, height);
        TableConfig {
            num_buckets: self
                .buckets
                .unwrap_or_else(|| auto_buckets(vertices, self.slots)),
            slots_per_bucket: self.slots,
            probe_buckets: 1,
        }
    }

    /// The cell sizing for `camera`.
    pub fn sizing(&self, camera: &Camera) -> CellSizing {
        grid::cell_sizing(
            camera,
            self.min_cell_size,
            self.projected_size,
            self.adaptive_cell_size,
        )
    }

    /// The grid of frames seen by `camera`.
    pub fn grid(&self, camera: &Camera) -> GridSettings {
        GridSettings {
            table: self.table(camera.width, camera.height),
            sizing: self.sizing(camera),
            jitter: self.jitter,
            fold_normal: self.fold_normal,
            sort_cells: self.sort_cells,
        }
    }

    /// Checks every knob.
    pub fn validate(&self) -> Result<(), WorldRestirError> {
        self.check_ranges().map_err(WorldRestirError::Config)?;
        self.table(1, 1).validate()?;
        Ok(())
    }
}

/// WGSL `WrParams`: the knobs the kernels read and the frame's layout.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WrParams {
    /// [`WorldRestirConfig::gpu_words`] (WGSL `WrKnobs`).
    pub knobs: [u32; WorldRestirConfig::GPU_WORDS],
    pub debug_view: u32,
    /// Grid items: [`WorldRestirConfig::items`].
    pub items: u32,
    /// Light tiles the generate pass draws its candidates from, and samples per tile; 0: from
    /// the light table.
    pub tiles: u32,
    pub tile_size: u32,
}

/// Generated constants header and the knobs' struct.
pub fn constants_wgsl() -> String {
    format!(
        "const WR_FULL: u32 = {:#x}u;\n\
         const WR_FIRST_SENTINEL: u32 = {:#x}u;\nconst WR_VIEW_CELLS: u32 = {}u;\n\
         const WR_VIEW_M: u32 = {}u;\n{}",
        gpu_hash::HASH_FULL,
        gpu_hash::HASH_FIRST_SENTINEL,
        DebugView::Cells as u32,
        DebugView::M as u32,
        WorldRestirConfig::wgsl_struct("WrKnobs"),
    )
}

const PARAMS: Buffer = ("wr_params", "WrParams", Access::Uniform);
const GENERATE: KernelDef = KernelDef::new(
    "generate",
    &["wr_generate"],
    GENERATE_WGSL,
    &[&[
        PARAMS,
        ("wr_out", RESERVOIRS, Access::ReadWrite),
        light_tiles::BINDING,
        ESTIMATES[0],
        ESTIMATES[1],
    ]],
);
/// Each item's estimate of its vertex's unshadowed incident luminance for the MIS of its light
/// sample (WGSL `render_light_density`; 0: none): `wr_estimate_raw` the generate pass's from
/// its own light samples, `wr_estimate` what the shading uses (the first spatial pass's mean
/// over the cell).
const ESTIMATE: &str = "array<f32>";
const ESTIMATES: [Buffer; 2] = [
    ("wr_estimate", ESTIMATE, Access::ReadWrite),
    ("wr_estimate_raw", ESTIMATE, Access::ReadWrite),
];
const REUSE: KernelDef = KernelDef::new(
    "reuse",
    &["wr_reuse"],
    REUSE_WGSL,
    &[
        &[PARAMS],
        REUSE_IO,
        grid::LOOKUP,
        &[
            ("wr_prev_vertices", "array<PackedVertex>", Access::Read),
            ("wr_prev_primary", "array<PackedVertex>", Access::Read),
            ESTIMATES[0],
            RAW_ESTIMATES,
        ],
    ],
);
/// The generate pass's estimates, as the kernels that look the grid up read them.
const RAW_ESTIMATES: Buffer = ("wr_estimate_raw", ESTIMATE, Access::Read);
const PATH: KernelDef = KernelDef::new(
    "path",
    &["wr_path"],
    PATH_WGSL,
    &[
        &[
            PARAMS,
            RAW_ESTIMATES,
            ("wr_final", RESERVOIRS, Access::Read),
        ],
        grid::LOOKUP,
    ],
);
const SHADE: KernelDef = KernelDef::new(
    "shade",
    &["wr_shade", "wr_shade_direct"],
    SHADE_WGSL,
    &[&[
        PARAMS,
        ("wr_final", RESERVOIRS, Access::Read),
        ("wr_estimate", ESTIMATE, Access::Read),
    ]],
);
const DEBUG: KernelDef = KernelDef::new(
    "debug",
    &["wr_debug_view"],
    DEBUG_WGSL,
    &[&[
        PARAMS,
        ("wr_final", RESERVOIRS, Access::Read),
        ("wr_item_slot", "array<vec2<u32>>", Access::Read),
        ("wr_debug", "array<vec4<f32>>", Access::ReadWrite),
    ]],
);
/// The kernels and whether each looks the grid up.
const KERNELS: [(&KernelDef, bool); 5] = [
    (&GENERATE, false),
    (&REUSE, true),
    (&SHADE, false),
    (&DEBUG, false),
    (&PATH, true),
];

/// Group 3 of kernel `k`: its own buffers, then the grid's lookup block when it looks up.
fn bindings(k: &KernelDef, lookup: bool) -> BindingSet {
    match lookup {
        true => grid::with_lookup(k.bindings()),
        false => k.bindings(),
    }
}

/// The library modules of every world-restir kernel (the grid's items among them).
fn library_modules() -> Vec<WgslModule> {
    vec![
        WgslModule::new("wr-constants", &[], constants_wgsl()),
        WgslModule::new(
            "world-restir",
            &["render", "reservoir", "wr-constants"],
            WGSL,
        ),
    ]
}

/// The modules of kernel `k`, composed after the render library.
fn modules(k: &KernelDef, lookup: bool) -> Vec<WgslModule> {
    let mut modules = library_modules();
    modules.push(WgslModule::new(
        "wr-bindings",
        &[],
        bindings(k, lookup).wgsl(STAGE_GROUP),
    ));
    let mut deps = vec!["world-restir", "wr-bindings", "workgroup"];
    if lookup {
        modules.extend(grid::lookup_modules(k.buffers().count() as u32));
        modules.push(WgslModule::new(
            "wr-estimate",
            &["world-restir", "wr-bindings", "grid-lookup"],
            ESTIMATE_WGSL,
        ));
        deps.extend(["grid-lookup", "wr-estimate"]);
    }
    if k.name == PATH.name {
        modules.extend(render::path_modules(false, true));
        modules.push(WgslModule::new(
            render::PATH_LIGHT,
            &["wr-estimate", crate::reuse::MERGE],
            PATH_LIGHT_WGSL,
        ));
        deps.push("render-path");
    }
    if k.name == PATH.name || k.name == REUSE.name {
        modules.push(crate::reuse::merge_module());
        deps.push(crate::reuse::MERGE);
    }
    modules.push(WgslModule::new(k.name, &deps, k.source));
    modules.extend(k.binds("light_tiles").then(light_tiles::reader_module));
    modules
}

/// The grid's items: the secondary vertices (then the primary ones, unified) that generate a
/// reservoir this frame; `params`: the `wr_params` they read (none to compose the kernels).
fn grid_items(params: Option<&wgpu::Buffer>, count: u32) -> GridItems<'_> {
    let mut modules = library_modules();
    modules.push(WgslModule::new(
        "grid-items",
        &["world-restir", "grid"],
        ITEMS_WGSL,
    ));
    GridItems {
        name: "world-restir",
        count,
        random: GRID_WORLD_RESTIR,
        modules,
        bindings: &[PARAMS],
        buffers: params.into_iter().collect(),
        cells: None,
    }
}

/// Every kernel of world-space ReSTIR, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    KERNELS
        .iter()
        .map(|(k, lookup)| {
            let source = render::compose_with_library(Tracer::Bvh, modules(k, *lookup));
            let name = format!("restir-world/world_restir/{}", k.name);
            ComposedKernel::stage(name, source, bindings(k, *lookup))
        })
        .chain(grid::kernels(&grid_items(None, 0)))
        .collect()
}

/// World-space ReSTIR's buffers besides the grid.
#[derive(Debug)]
struct WrBuffers {
    params: wgpu::Buffer,
    reservoirs: [wgpu::Buffer; 2],
    prev_reservoirs: wgpu::Buffer,
    /// Last frame's secondary vertices (the temporal pass's MIS weights).
    prev_vertices: wgpu::Buffer,
    /// Last frame's primary vertices when unified (their items follow the secondary ones);
    /// one unused record otherwise.
    prev_primary: wgpu::Buffer,
    /// Each item's MIS estimates ([`ESTIMATES`]): used, raw.
    estimate: [wgpu::Buffer; 2],
    debug: wgpu::Buffer,
    /// Bound as the generate pass's light tiles when it draws from the light table.
    no_tiles: wgpu::Buffer,
}

impl WrBuffers {
    /// `tiles`: (tile count, samples per tile) of the light tiles generate draws from, if any.
    fn new(
        ctx: &GpuContext,
        config: &WorldRestirConfig,
        pixels: u32,
        tiles: Option<(u32, u32)>,
    ) -> Result<Self, WorldRestirError> {
        let px = u64::from(pixels);
        let items = u64::from(config.items(pixels));
        let res_bytes = items * size_of::<render::StoredReservoir>() as u64;
        ctx.check_binding_size("the world-restir reservoirs", res_bytes)?;
        let vertex_bytes = px * size_of::<render::GVertex>() as u64;
        let primary_bytes = match config.unified {
            true => vertex_bytes,
            false => size_of::<render::GVertex>() as u64,
        };
        let gvertex = size_of::<render::GVertex>() as u64;
        ctx.check_pixel_binding("world-restir's last-frame vertices", px, gvertex)?;
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(&ctx.device, label, size);
        let pair = |label: &str, size: u64| [0, 1].map(|p| zeroed(&format!("{label} {p}"), size));
        let wr_params = WrParams {
            knobs: config.gpu_words(),
            debug_view: 0,
            items: config.items(pixels),
            tiles: tiles.map_or(0, |t| t.0),
            tile_size: tiles.map_or(0, |t| t.1),
        };
        Ok(Self {
            params: buffers::with_usage(
                &ctx.device,
                "wr params",
                &[wr_params],
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            reservoirs: pair("wr reservoirs", res_bytes),
            prev_reservoirs: zeroed("wr prev reservoirs", res_bytes),
            prev_vertices: zeroed("wr prev vertices", vertex_bytes),
            prev_primary: zeroed("wr prev primary vertices", primary_bytes),
            estimate: pair("wr estimate", items * 4),
            debug: zeroed("wr debug", px * 16),
            no_tiles: zeroed("wr no light tiles", light_tiles::LIGHT_SAMPLE_BYTES),
        })
    }
}

/// The created kernels, in [`KERNELS`] order.
struct WrKernels([OwnKernel; 5]);

impl WrKernels {
    fn new(ctx: &GpuContext, shared: &SharedGroups) -> Result<Self, GpuError> {
        let kernel = |(k, lookup): (&KernelDef, bool)| {
            let name = format!("world-restir {}", k.name);
            shared.own_kernel(
                ctx,
                &name,
                &bindings(k, lookup),
                modules(k, lookup),
                k.entries,
            )
        };
        let [a, b, c, d, e] = KERNELS.map(kernel);
        Ok(Self([a?, b?, c?, d?, e?]))
    }
}

/// The frame's passes; `[p]`: for the frame of parity p.
#[derive(Debug)]
struct WrPasses {
    generate: Pass,
    temporal: Option<[Pass; 2]>,
    spatial: [Vec<Pass>; 2],
    shade: Pass,
    /// Direct light from the unified cache (replaces the renderer's).
    shade_direct: Option<Pass>,
    debug: Pass,
    /// The path beyond the secondary vertex with the grid's MIS estimates (this frame's grid).
    path: [Pass; 2],
    /// The reservoirs the shade pass reads.
    final_index: usize,
}

/// What binding a pass needs: the buffers, tables and kernels of one world-restir stage.
struct Binder<'a> {
    ctx: &'a GpuContext,
    shared: &'a SharedGroups,
    b: &'a WrBuffers,
    grid: &'a WorldGrid,
    k: WrKernels,
    items: u32,
}

impl Binder<'_> {
    fn params(&self) -> (&'static str, Resource<'_>) {
        ("wr_params", (&self.b.params).into())
    }

    /// A pass of kernel `i` over the grid items (`over_items`) or the pixels.
    fn pass(
        &self,
        i: usize,
        entry: &str,
        res: Vec<(&str, Resource)>,
        over_items: bool,
    ) -> Result<Pass, GpuError> {
        let items = over_items.then_some(self.items);
        self.shared
            .bound_pass(&self.ctx.device, &self.k.0[i], entry, res, items)
    }

    /// One reuse pass: reads `src` (and `own` for the receiver), writes `out`, looks up the
    /// grid of parity `grid`.
    fn reuse(
        &self,
        index: u32,
        temporal: bool,
        [src, own, out]: [&wgpu::Buffer; 3],
        grid: usize,
    ) -> Result<Pass, GpuError> {
        let u = ReusePass::buffer(&self.ctx.device, temporal, index);
        let first = REUSE.buffers().count() as u32;
        let mut res = vec![
            self.params(),
            ("reuse_pass", (&u).into()),
            ("reuse_src", src.into()),
            ("reuse_self", own.into()),
            ("reuse_out", out.into()),
            ("wr_prev_vertices", (&self.b.prev_vertices).into()),
            ("wr_prev_primary", (&self.b.prev_primary).into()),
            ("wr_estimate", (&self.b.estimate[0]).into()),
            ("wr_estimate_raw", (&self.b.estimate[1]).into()),
        ];
        res.extend(self.grid.lookup_resources(grid, first));
        self.pass(1, "wr_reuse", res, true)
    }

    /// The path pass over the pixels, looking up the grid of parity `grid` and its final
    /// reservoirs `last`.
    fn path(&self, grid: usize, last: &wgpu::Buffer) -> Result<Pass, GpuError> {
        let first = PATH.buffers().count() as u32;
        let mut res = vec![
            self.params(),
            ("wr_estimate_raw", (&self.b.estimate[1]).into()),
            ("wr_final", last.into()),
        ];
        res.extend(self.grid.lookup_resources(grid, first));
        self.pass(4, "wr_path", res, false)
    }

    fn both(&self, f: impl Fn(usize) -> Result<Pass, GpuError>) -> Result<[Pass; 2], GpuError> {
        Ok([f(0)?, f(1)?])
    }

    /// The reuse chain: generate -> R0; temporal R0 (+ last frame's) -> R1; spatial ping-pong.
    /// Returns (temporal, spatial, the index of the final reservoirs).
    #[allow(clippy::type_complexity)]
    fn reuse_chain(
        &self,
        config: &WorldRestirConfig,
    ) -> Result<(Option<[Pass; 2]>, [Vec<Pass>; 2], usize), GpuError> {
        let r = &self.b.reservoirs;
        let mut cur = 0;
        let temporal = match config.temporal {
            true => {
                cur = 1;
                let src = [&self.b.prev_reservoirs, &r[0], &r[1]];
                Some(self.both(|p| self.reuse(0, true, src, 1 - p))?)
            }
            false => None,
        };
        let mut spatial: [Vec<Pass>; 2] = [Vec::new(), Vec::new()];
        for j in 0..config.spatial_passes {
            for (p, list) in spatial.iter_mut().enumerate() {
                list.push(self.reuse(j, false, [&r[cur], &r[cur], &r[1 - cur]], p)?);
            }
            cur = 1 - cur;
        }
        Ok((temporal, spatial, cur))
    }
}

impl WrPasses {
    /// Binds every pass; shade reads the last reservoirs of the reuse chain.
    fn new(
        binder: &Binder,
        config: &WorldRestirConfig,
        tiles: Option<&wgpu::Buffer>,
    ) -> Result<Self, GpuError> {
        let (b, params) = (binder.b, || binder.params());
        let (temporal, spatial, cur) = binder.reuse_chain(config)?;
        let last = || ("wr_final", Resource::from(&b.reservoirs[cur]));
        let shade_res = || vec![params(), last(), ("wr_estimate", (&b.estimate[0]).into())];
        let generate_res = vec![
            params(),
            ("wr_out", (&b.reservoirs[0]).into()),
            ("light_tiles", tiles.unwrap_or(&b.no_tiles).into()),
            ("wr_estimate", (&b.estimate[0]).into()),
            ("wr_estimate_raw", (&b.estimate[1]).into()),
        ];
        let debug_res = vec![
            params(),
            last(),
            ("wr_item_slot", binder.grid.item_slots().into()),
            ("wr_debug", (&b.debug).into()),
        ];
        Ok(Self {
            generate: binder.pass(0, "wr_generate", generate_res, true)?,
            temporal,
            spatial,
            shade: binder.pass(2, "wr_shade", shade_res(), false)?,
            shade_direct: match config.unified {
                true => Some(binder.pass(2, "wr_shade_direct", shade_res(), false)?),
                false => None,
            },
            debug: binder.pass(3, "wr_debug_view", debug_res, false)?,
            path: binder.both(|p| binder.path(p, &b.reservoirs[cur]))?,
            final_index: cur,
        })
    }
}

/// The world-space ReSTIR stage of a frame: built on a [`Renderer`]'s shared groups, it
/// records the indirect image (and with [`WorldRestirConfig::unified`] the direct one) in
/// place of the renderer's shading.
#[derive(Debug)]
pub struct WorldRestir {
    config: WorldRestirConfig,
    pixels: u32,
    grid: WorldGrid,
    buffers: WrBuffers,
    passes: WrPasses,
    /// The parity of the grid the last frame built (its path pass looks it up).
    parity: usize,
}

impl WorldRestir {
    /// Bytes of its buffers: the grid, the reservoirs, last frame's vertices, the estimates.
    pub fn bytes(&self) -> u64 {
        let b = &self.buffers;
        let own: u64 = [
            &b.params,
            &b.reservoirs[0],
            &b.reservoirs[1],
            &b.prev_reservoirs,
            &b.prev_vertices,
            &b.prev_primary,
            &b.estimate[0],
            &b.estimate[1],
            &b.debug,
            &b.no_tiles,
        ]
        .map(wgpu::Buffer::size)
        .iter()
        .sum();
        own + self.grid.bytes()
    }

    /// The stage for `renderer`'s scene and image with `config`; its generate pass draws its
    /// candidates from `tiles` when given (filled by their owner every frame before
    /// [`WorldRestir::encode`]), else from the light table.
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: WorldRestirConfig,
        tiles: Option<&LightTiles>,
    ) -> Result<Self, WorldRestirError> {
        config.validate()?;
        let camera = &renderer.gpu_camera();
        let pixels = renderer.pixels();
        let items = config.items(pixels);
        let dims = tiles.map(LightTiles::dims);
        let buffers = WrBuffers::new(ctx, &config, pixels, dims)?;
        let shared = &renderer.shared;
        let grid_items = grid_items(Some(&buffers.params), items);
        let grid = WorldGrid::new(ctx, shared, config.grid(camera), grid_items, camera.eye)?;
        let binder = Binder {
            ctx,
            shared,
            b: &buffers,
            grid: &grid,
            k: WrKernels::new(ctx, shared)?,
            items,
        };
        let passes = WrPasses::new(&binder, &config, tiles.map(LightTiles::buffer))?;
        Ok(Self {
            config,
            pixels,
            grid,
            buffers,
            passes,
            parity: 0,
        })
    }

    pub fn config(&self) -> &WorldRestirConfig {
        &self.config
    }

    /// Whether the stage also lights the direct image (the unified cache).
    pub fn lights_direct(&self) -> bool {
        self.config.unified
    }

    /// Records the stage for the frame whose camera is `renderer`'s (after its primary and GI
    /// passes): generate, build, temporal, spatial, shade (and the unified cache's direct
    /// light), and keeps this frame's reservoirs and vertices for the next.
    pub fn encode(
        &mut self,
        f: &mut FrameEncoder,
        renderer: &Renderer,
    ) -> Result<(), WorldRestirError> {
        let passes = &self.passes;
        f.span("generate", |f| f.dispatch(&passes.generate));
        let (grid, eye) = (&mut self.grid, renderer.gpu_camera().eye);
        let p = f.span("build", |f| grid.encode_build(f, eye))?;
        self.parity = p;
        if let Some(temporal) = &passes.temporal {
            f.span("temporal", |f| f.dispatch(&temporal[p]));
        }
        if !passes.spatial[p].is_empty() {
            f.span("spatial", |f| {
                passes.spatial[p].iter().for_each(|s| f.dispatch(s))
            });
        }
        f.span("shade", |f| f.dispatch(&passes.shade));
        if let Some(direct) = &passes.shade_direct {
            f.span("shade_direct", |f| f.dispatch(direct));
        }
        if self.config.temporal {
            f.span("persist", |f| self.encode_persist(f, renderer));
        }
        Ok(())
    }

    /// The path beyond the secondary vertex (after [`WorldRestir::encode`] this frame), its
    /// vertices' MIS weighed with the estimates of this frame's grid: the renderer's path
    /// pass otherwise ([`Renderer::encode_path`]); nothing with one bounce and no MIS.
    pub fn encode_path(&self, f: &mut FrameEncoder, renderer: &Renderer) {
        if renderer.options().paths.beyond_secondary() {
            f.span("path", |f| f.dispatch(&self.passes.path[self.parity]));
        }
    }

    /// Keeps this frame's final reservoirs and grid items' vertices (secondary, then primary
    /// when unified) for the next temporal pass.
    fn encode_persist(&self, f: &mut FrameEncoder, renderer: &Renderer) {
        let (b, r) = (&self.buffers, &renderer.buffers);
        f.copy(&b.reservoirs[self.passes.final_index], &b.prev_reservoirs);
        f.copy(&r.secondary, &b.prev_vertices);
        if self.config.unified {
            f.copy(&r.gbuffer, &b.prev_primary);
        }
    }

    /// The grid its items are gathered in.
    pub fn world_grid(&self) -> &WorldGrid {
        &self.grid
    }

    /// Statistics of the last built grid (overflows = vertices left out of it).
    pub fn grid_stats(&self, ctx: &GpuContext) -> Result<HashStats, GpuError> {
        self.grid.stats(ctx)
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(&self, ctx: &GpuContext) -> Result<Vec<render::StoredReservoir>, GpuError> {
        let last = &self.buffers.reservoirs[self.passes.final_index];
        let mut v: Vec<render::StoredReservoir> = buffers::read(ctx, last)?;
        v.truncate(self.pixels as usize);
        Ok(v)
    }

    /// The last built grid, read back: per vertex (slot, index in slot) (slot >= 0xffff_fff0:
    /// not in the grid), per slot counts and exclusive offsets, and the compact cell storage.
    pub fn grid(&self, ctx: &GpuContext) -> Result<GridReadback, GpuError> {
        self.grid.read(ctx, self.pixels as usize)
    }

    /// Renders a debug view of the last frame (RGB per pixel, row-major).
    pub fn debug_image(
        &self,
        ctx: &GpuContext,
        view: DebugView,
    ) -> Result<Vec<[f32; 3]>, GpuError> {
        ctx.queue.write_buffer(
            &self.buffers.params,
            std::mem::offset_of!(WrParams, debug_view) as u64,
            bytemuck::bytes_of(&(view as u32)),
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        self.passes.debug.record(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        render::read_rgb(ctx, &self.buffers.debug, self.pixels, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_but_measured_ones() {
        let c = WorldRestirConfig::default();
        assert_eq!((c.buckets, c.slots, c.candidates), (None, 32, 16));
        assert_eq!(c.combine, Combination::Pairwise);
        assert_eq!(
            (c.max_count, c.spatial_passes, c.temporal_m_cap),
            (4, 2, 20)
        );
        assert!(c.temporal && c.jitter && c.adaptive_cell_size);
        assert!((c.normal_threshold.powi(4) - 0.5).abs() < 1e-5);
        c.validate().unwrap();
    }

    #[test]
    fn bad_knobs_are_rejected() {
        for c in [
            WorldRestirConfig {
                candidates: 0,
                ..Default::default()
            },
            WorldRestirConfig {
                buckets: Some(0),
                ..Default::default()
            },
            WorldRestirConfig {
                normal_threshold: 2.0,
                ..Default::default()
            },
            WorldRestirConfig {
                gi_stride: 0,
                ..Default::default()
            },
        ] {
            assert!(c.validate().is_err(), "{c:?}");
        }
    }

    #[test]
    fn every_knob_can_be_set_by_name() {
        let mut c = WorldRestirConfig::default();
        for (key, value) in [
            ("buckets", "100000"),
            ("slots", "16"),
            ("candidates", "8"),
            ("mis-candidates", "2"),
            ("max-count", "8"),
            ("spatial-passes", "2"),
            ("temporal", "off"),
            ("temporal-m-cap", "10"),
            ("min-cell-size", "0.02"),
            ("projected-size", "8"),
            ("jitter", "off"),
            ("adaptive-cell-size", "off"),
            ("fold-normal", "on"),
            ("normal-threshold", "0.5"),
            ("gi-stride", "2"),
            ("path-reservoirs", "on"),
            ("combine", "one-over-z"),
            ("sort-cells", "off"),
            ("unified", "on"),
        ] {
            c.set(key, value).unwrap_or_else(|e| panic!("{key}: {e}"));
        }
        assert_eq!(
            c,
            WorldRestirConfig {
                buckets: Some(100_000),
                slots: 16,
                candidates: 8,
                mis_candidates: 2,
                max_count: 8,
                spatial_passes: 2,
                temporal: false,
                temporal_m_cap: 10,
                min_cell_size: 0.02,
                projected_size: 8.0,
                jitter: false,
                adaptive_cell_size: false,
                fold_normal: true,
                normal_threshold: 0.5,
                gi_stride: 2,
                path_reservoirs: true,
                combine: Combination::OneOverZ,
                sort_cells: false,
                unified: true,
            }
        );
        c.set("buckets", "auto").unwrap();
        assert_eq!(c.buckets, None);
        for (key, value) in [("nosuch", "1"), ("slots", "x"), ("jitter", "maybe")] {
            assert!(c.set(key, value).is_err(), "{key}={value}");
        }
    }

    #[test]
    fn the_table_is_sized_to_the_frame_unless_set() {
        let c = WorldRestirConfig::default();
        assert_eq!(c.table(96, 96).num_buckets, 576);
        let paper = WorldRestirConfig {
            buckets: Some(100_000),
            ..c
        };
        assert_eq!(paper.table(96, 96).num_buckets, 100_000);
    }
}
