//! World-space ReSTIR GI (`world-restir-gi`): restir-gi's path samples, target and
//! reconnection shift, with neighbours found in a world-space grid instead of on the screen.
//! Each frame the pixels' primary vertices x1 enter a [`crate::grid::WorldGrid`] (adaptive
//! cells, the normal's axis folded into the key, on `gpu-hash` and `gpu-scan`); a pixel's
//! record is its path-sample reservoir. Beside the pixels the grid holds a *pool*: one record
//! per cell (its first pixel's final reservoir and primary vertex) kept across frames, which
//! ages while its cell is out of view and goes after `history-frames` frames ([`Pool`],
//! `world_pool.wgsl`). The temporal pass merges last frame's pixel that saw the receiver's
//! primary vertex (restir-gi's reprojection, `reproject`) and, where there is none (a
//! disocclusion, a cut), a path sample that last frame's pixels or the pool left in the
//! receiver's cell of last frame's grid (the cell is where the surface is, whatever the camera
//! did, and a surface seen again finds its cell's record); the spatial pass merges those this
//! frame's pixels left in its cell of this frame's grid, the lookup jittered by up to a cell.
//! The method's own code is its neighbour choice (`world_neighbours.wgsl`) and its cells
//! (`world_items.wgsl`, the pool, [`WorldRestirGiConfig::grid`]); the chain of passes is
//! [`crate::screen_reuse`]'s and the combination the reservoir crate's.
//!
//! With `subpath-k` above 0 (the variant `subpath`), sub-path reuse (Zhang & Wang 2023), which
//! no screen-space method can do: before the initial pass each pixel's secondary vertex x2 is
//! a receiver too, resampling the light it reflects from the path samples this frame's pixels
//! left in x2's cell (`world_subpath.wgsl`, restir-gi's shift and MIS with x2 as the receiver).
//! It reads the path split the renderer records when asked
//! ([`crate::render::RenderOptions::path_split`]): x2's own light apart from the rest, and the
//! radiance one vertex short that a path reconnecting from x2 keeps its depth with.
//!
//! | span | what |
//! |---|---|
//! | `wgi-build` | this frame's grid of the pixels and the pool |
//! | `wgi-subpath` | (`subpath-k` > 0) each pixel's x2 resamples path samples of its cell |
//! | `wgi-initial` .. `wgi-persist` | [`crate::screen_reuse`]'s chain |
//! | `wgi-pool` | the pool's records into the history, then the next pool: gpu-scan of the items the grid's sort flagged (each cell's first), scatter |

use gpu_hash::{CellSizing, TableConfig};
use gpu_scan::{Scan, ScanBinding, ScanDescriptor, ScanKind};
use reservoir::reuse::Combination;

use super::{DEBUG, GiReservoir, INITIAL_WGSL, MAX_M, REUSE_WGSL, SHADE_WGSL, Visibility};
use crate::gpu::{
    Access, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule, buffers,
};
use crate::grid::{self, CellHook, GridItems, GridSettings, auto_buckets};
use crate::knobs::{Knobs, Variant};
use crate::render::{
    Buffer, ComposedKernel, GRID_WORLD_RESTIR_GI, GVertex, KernelDef, STAGE_GROUP, SharedGroups,
    compose_with_library,
};
use crate::scene::Camera;
use crate::screen_reuse::{self, ScreenReuseError, ScreenStage};

const NEIGHBOURS_WGSL: &str = include_str!("world_neighbours.wgsl");
const ITEMS_WGSL: &str = include_str!("world_items.wgsl");
const POOL_WGSL: &str = include_str!("world_pool.wgsl");
const SUBPATH_WGSL: &str = include_str!("world_subpath.wgsl");
const POOL_PARAMS_WGSL: &str = include_str!("world_pool_params.wgsl");
const POOL_CELLS_WGSL: &str = include_str!("world_pool_cells.wgsl");
const POOL_SCATTER_WGSL: &str = include_str!("world_pool_scatter.wgsl");

crate::knobs! {
    /// Every knob of world-space ReSTIR GI with its default: restir-gi's reuse knobs, and the
    /// cells its neighbours are found in.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct WorldRestirGiConfig {
        /// Temporal reuse from the receiver's cell in last frame's grid (default on).
        temporal: bool = true, "temporal";
        /// Cap of a reused reservoir's confidence M, in frames of paths (default 20).
        [gpu] temporal_m_cap: u32 = 20, "temporal-m-cap", 1..=MAX_M;
        /// Cap of a pooled record's confidence M when the temporal pass merges it (default 1).
        [gpu] pool_m_cap: u32 = 1, "pool-m-cap", 1..=MAX_M;
        /// The temporal pass merges last frame's pixel that saw the receiver's primary vertex
        /// (reprojection) first, the cell's items only past it or where it fails (default on).
        [gpu] reproject: bool = true, "reproject";
        /// Path samples of last frame's cell merged per pixel (default 1).
        [gpu] temporal_k: u32 = 1, "temporal-k", 1..=screen_reuse::MAX_SPATIAL_K;
        /// Path samples of this frame's cell merged per pixel (default 4; 0: no spatial pass).
        [gpu] spatial_k: u32 = 4, "spatial-k", 0..=screen_reuse::MAX_SPATIAL_K;
        /// Sub-path reuse: path samples of the cell of each pixel's secondary vertex x2 that
        /// x2 resamples for the light it reflects, before the initial pass (default 0: none).
        [gpu] subpath_k: u32 = 0, "subpath-k", 0..=screen_reuse::MAX_SPATIAL_K;
        /// A reused pixel's depth (distance to the eye) must be within this fraction of the
        /// receiver's (default 0.1).
        [gpu] depth_threshold: f32 = 0.1, "depth-threshold", 0.0..=f32::MAX;
        /// Cosine between a reused pixel's shading normal and the receiver's, at least (default
        /// 0.9, about 25 degrees).
        [gpu] normal_threshold: f32 = 0.9, "normal-threshold", -1.0..=1.0;
        /// A reconnection whose Jacobian is above this or below its inverse is rejected
        /// (default 10).
        [gpu] max_jacobian: f32 = 10.0, "max-jacobian", 1.0..=f32::MAX;
        /// Combination weights (default pairwise MIS, unbiased; `biased`: 1/M).
        [gpu] combine: Combination = Combination::Pairwise, "combine";
        /// Visibility rays of the reconnections (default `selected`; `on`, `final`, `off`:
        /// [`Visibility`]).
        [gpu] visibility: Visibility = Visibility::Selected, "visibility";
        /// Perceptual roughness below which a glossy primary vertex x1 holds no path sample
        /// (default 1: only glossy x1 at roughness 1 are reused; restir-gi's knob). A glossy x1 that holds one
        /// merges its cells' samples but enters no cell.
        [gpu] min_roughness: f32 = 1.0, "min-roughness", 0.0..=1.0;
        /// Perceptual roughness below which a glossy secondary vertex x2 is no reconnection
        /// vertex (default 0.5; restir-gi's knob).
        x2_min_roughness: f32 = 0.5, "x2-min-roughness", 0.0..=1.0;
        /// Targeted projected cell size in pixels (default 8: a cell holds about 8 x 8 pixels'
        /// primary vertices where it faces the camera).
        projected_size: f32 = 8.0, "projected-size", 0.5..=4096.0;
        /// Smallest cell edge in world units (default 0.001).
        min_cell_size: f32 = 0.001, "min-cell-size", 1e-6..=f32::MAX;
        /// Tangent-plane jitter of the lookups and the insertion by up to one cell (default on).
        jitter: bool = true, "jitter";
        /// Slots per hash bucket (default 32).
        slots: u32 = 32, "slots", 1..=1024;
        /// Frames a cell's pooled record outlives the last frame its cell was in view (default
        /// 32; 0: the pool holds last frame's records only).
        history_frames: u32 = 32, "history-frames", 0..=MAX_HISTORY_FRAMES;
    }
}

/// The named variants of `world-restir-gi`: the reuse variants every method has, `biased`
/// restir-gi's (1/M weights, no visibility rays), and `subpath` (sub-path reuse on).
pub fn variants() -> Vec<Variant> {
    let mut v = super::variants_with("spatial-k=0");
    v.push(Variant::new(
        "subpath",
        &["subpath-k=1"],
        "sub-path reuse: each pixel's secondary vertex resamples a path sample of its cell",
    ));
    v
}

impl WorldRestirGiConfig {
    /// Checks every knob.
    pub fn validate(&self) -> Result<(), ScreenReuseError> {
        self.check_ranges()
            .map_err(ScreenReuseError::config("world-restir-gi"))?;
        self.table(1)
            .validate()
            .map_err(|e| ScreenReuseError::config("world-restir-gi")(e.to_string()))
    }

    /// The hash table's dimensions for frames of `pixels` (the grid's items: the pixels and
    /// the pool's records).
    pub fn table(&self, pixels: u32) -> TableConfig {
        TableConfig {
            num_buckets: auto_buckets(grid_item_count(pixels), self.slots),
            slots_per_bucket: self.slots,
            probe_buckets: 1,
        }
    }

    /// The cell sizing for `camera`.
    pub fn sizing(&self, camera: &Camera) -> CellSizing {
        grid::cell_sizing(camera, self.min_cell_size, self.projected_size, true)
    }

    /// The grid of frames seen by `camera`: adaptive cells with the normal's axis folded into
    /// the key (the faces of a corner share no path samples), lists ordered by pixel.
    pub fn grid(&self, camera: &Camera) -> GridSettings {
        GridSettings {
            table: self.table(camera.width.saturating_mul(camera.height)),
            sizing: self.sizing(camera),
            jitter: self.jitter,
            fold_normal: true,
            sort_cells: true,
        }
    }
}

/// Generated constants header: the largest M and the knobs' struct.
pub fn constants_wgsl() -> String {
    format!(
        "const GI_MAX_M: u32 = {MAX_M}u;\n{}{}",
        Visibility::wgsl(),
        WorldRestirGiConfig::wgsl_struct("ScreenKnobs")
    )
}

/// World-space ReSTIR GI as a reuse stage: restir-gi's with the world-space neighbour choice.
pub static STAGE: ScreenStage = ScreenStage {
    name: "world-restir-gi",
    short: "wgi",
    reservoirs: "array<GiReservoir>",
    reservoir_size: size_of::<GiReservoir>(),
    library: super::WGSL,
    constants: constants_wgsl,
    sources: [INITIAL_WGSL, REUSE_WGSL, SHADE_WGSL],
    own: [&[DEBUG], &[DEBUG, HISTORY_AGE], &[]],
    extra_modules: |_| Vec::new(),
    neighbours: NEIGHBOURS_WGSL,
    grid_lookup: true,
    subpath: Some(SUBPATH_WGSL),
};

/// Most frames a pooled record may outlive its cell's last view (`history-frames`).
pub const MAX_HISTORY_FRAMES: u32 = 1000;

/// Pixels per record the pool has room for. It keeps one record per cell: on many-lights at
/// 256x256 (small lights, each face its own cell) 9,098 of them for 65,536 pixels with a still
/// camera, 1,141 for 4,096 at 64x64, so a quarter leaves room for cells out of view (when more
/// want in, the oldest are dropped: they come last in item order), and the pixels' and the
/// pool's 48-byte reservoirs fit one 128 MiB binding at 1920x1080 (a half did not).
pub const PIXELS_PER_POOL_RECORD: u32 = 4;

/// The records the pool of a frame of `pixels` keeps at most.
pub fn pool_capacity(pixels: u32) -> u32 {
    pixels.div_ceil(PIXELS_PER_POOL_RECORD)
}

/// The grid's items for a frame of `pixels`: the pixels, then the pool's records.
pub fn grid_item_count(pixels: u32) -> u32 {
    pixels.saturating_add(pool_capacity(pixels))
}

/// What the grid's items read of the pool: its records' vertices and its count.
const ITEM_BINDINGS: &[Buffer] = &[
    ("wgi_pool_vertices", "array<PackedVertex>", Access::Read),
    ("wgi_pool_count", "array<u32>", Access::Read),
];

/// What the pool's flags, set in the grid's sort pass, bind.
const CELL_BINDINGS: &[Buffer] = &[
    POOL_PARAMS,
    ("wgi_pool_age", "array<u32>", Access::Read),
    ("wgi_flags", "array<u32>", Access::ReadWrite),
];

/// The pool's parameters struct, a module of the pool's kernels and of the grid's sort.
fn params_module() -> WgslModule {
    WgslModule::new("wgi-pool-params", &[], POOL_PARAMS_WGSL)
}

/// The grid's items: every pixel's primary vertex, then the pool's records; the grid's sort
/// flags each cell's first item for the pool (`pool`: its buffers, `None` for the kernels'
/// checks).
pub(super) fn grid_items<'a>(pixels: u32, pool: Option<&'a PoolBuffers>) -> GridItems<'a> {
    let cells = CellHook {
        modules: vec![
            params_module(),
            WgslModule::new("grid-cells", &["wgi-pool-params"], POOL_CELLS_WGSL),
        ],
        bindings: CELL_BINDINGS,
        buffers: pool.map_or_else(Vec::new, |p| vec![&p.params, &p.age, &p.flags]),
    };
    GridItems {
        name: "world-restir-gi",
        count: grid_item_count(pixels),
        random: GRID_WORLD_RESTIR_GI,
        modules: vec![WgslModule::new("grid-items", &["grid"], ITEMS_WGSL)],
        bindings: ITEM_BINDINGS,
        buffers: pool.map_or_else(Vec::new, |p| vec![&p.vertices, &p.count]),
        cells: Some(cells),
    }
}

/// WGSL `WgiPoolParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PoolParams {
    pub pixels: u32,
    /// Grid items: the pixels and the pool's records.
    pub items: u32,
    /// Most records the pool keeps ([`pool_capacity`]).
    pub capacity: u32,
    pub max_age: u32,
    /// Words of one stored reservoir.
    pub reservoir_words: u32,
    pub _pad: [u32; 3],
}

const POOL_PARAMS: Buffer = ("wgi_pool_params", "WgiPoolParams", Access::Uniform);
/// The ages of the pool's records in the history (after the pixels'), which the pool's passes
/// and the temporal pass (the debug view of its neighbours' age) read.
pub(super) const HISTORY_AGE: Buffer = ("wgi_history_age", "array<u32>", Access::Read);

/// [`HISTORY_AGE`]'s buffer for a pool of `capacity` records.
pub(super) fn history_age_buffer(ctx: &GpuContext, capacity: u32) -> wgpu::Buffer {
    buffers::storage_zeroed(&ctx.device, "wgi history age", u64::from(capacity) * 4)
}
const SCATTER: KernelDef = KernelDef::new(
    "wgi-pool-scatter",
    &["wgi_pool_scatter"],
    POOL_SCATTER_WGSL,
    &[&[
        POOL_PARAMS,
        HISTORY_AGE,
        ("wgi_flags", "array<u32>", Access::ReadWrite),
        ("wgi_positions", "array<u32>", Access::Read),
        ("wgi_history_reservoirs", "array<u32>", Access::Read),
        ("wgi_history_vertices", "array<u32>", Access::Read),
        ("wgi_history_pool_vertices", "array<u32>", Access::Read),
        ("wgi_pool_reservoirs", "array<u32>", Access::ReadWrite),
        ("wgi_pool_vertices", "array<u32>", Access::ReadWrite),
        ("wgi_pool_age", "array<u32>", Access::ReadWrite),
        ("wgi_pool_count", "array<u32>", Access::ReadWrite),
    ]],
);

/// The modules of pool kernel `k`: its bindings and the pool's WGSL.
fn pool_modules(k: &KernelDef) -> Vec<WgslModule> {
    let constants = format!(
        "const GRID_FIRST_SENTINEL: u32 = {:#x}u;\n",
        grid::FIRST_SENTINEL
    );
    vec![
        params_module(),
        WgslModule::new("wgi-pool-bindings", &[], k.bindings().wgsl(STAGE_GROUP)),
        WgslModule::new("wgi-pool-constants", &[], constants),
        WgslModule::new(
            "wgi-pool",
            &["wgi-pool-params", "wgi-pool-bindings", "wgi-pool-constants"],
            POOL_WGSL,
        ),
        WgslModule::new(k.name, &["wgi-pool", "workgroup"], k.source),
    ]
}

/// Every kernel of world-space ReSTIR GI (its stage's, its grid build's and its pool's),
/// composed as used.
pub fn kernels() -> Vec<ComposedKernel> {
    let mut k = STAGE.composed();
    k.extend(grid::kernels(&grid_items(0, None)));
    let source = compose_with_library(Tracer::Bvh, pool_modules(&SCATTER));
    let name = format!("restir-world/restir_gi/{}", SCATTER.name);
    k.push(ComposedKernel::stage(name, source, SCATTER.bindings()));
    k
}

/// The pool's records (reservoirs, vertices, ages) and count, written by its scatter and read
/// by the next frame's grid build and history; its parameters, and the flags of the items it
/// keeps, which the grid's sort sets and its scatter reads and clears.
#[derive(Debug)]
pub struct PoolBuffers {
    params: wgpu::Buffer,
    flags: wgpu::Buffer,
    reservoirs: wgpu::Buffer,
    vertices: wgpu::Buffer,
    age: wgpu::Buffer,
    /// \[kept, wanted\]: records in the pool, and records that wanted in (more: dropped).
    count: wgpu::Buffer,
}

impl PoolBuffers {
    /// The pool of a frame of `pixels` keeping records up to `max_age` frames, whose records
    /// are `reservoir_size`-byte reservoirs.
    pub(super) fn new(
        ctx: &GpuContext,
        (pixels, max_age, reservoir_size): (u32, u32, usize),
    ) -> Self {
        let capacity = pool_capacity(pixels);
        let items = grid_item_count(pixels);
        let params = PoolParams {
            pixels,
            items,
            capacity,
            max_age,
            reservoir_words: (reservoir_size / 4) as u32,
            _pad: [0; 3],
        };
        let n = u64::from(capacity);
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(&ctx.device, label, size);
        Self {
            params: buffers::with_usage(
                &ctx.device,
                "wgi pool params",
                &[params],
                wgpu::BufferUsages::UNIFORM,
            ),
            flags: zeroed("wgi pool flags", u64::from(items) * 4),
            reservoirs: zeroed("wgi pool reservoirs", n * reservoir_size as u64),
            vertices: zeroed("wgi pool vertices", n * size_of::<GVertex>() as u64),
            age: zeroed("wgi pool age", n * 4),
            count: zeroed("wgi pool count", 16),
        }
    }

    /// Its records' ages and \[kept, wanted\].
    pub(super) fn read(&self, ctx: &GpuContext) -> Result<(Vec<u32>, Vec<u32>), GpuError> {
        Ok((
            buffers::read(ctx, &self.age)?,
            buffers::read(ctx, &self.count)?,
        ))
    }

    pub(super) fn bytes(&self) -> u64 {
        [
            &self.flags,
            &self.reservoirs,
            &self.vertices,
            &self.age,
            &self.count,
        ]
        .map(wgpu::Buffer::size)
        .iter()
        .sum()
    }
}

/// The pool's passes and the buffers they need beyond [`PoolBuffers`]: the history's ages and
/// the flags' scan.
#[derive(Debug)]
pub struct Pool {
    history_age: wgpu::Buffer,
    positions: wgpu::Buffer,
    scan: Scan,
    scan_binding: ScanBinding,
    scatter: Pass,
    pixels: u32,
    reservoir_size: usize,
}

impl Pool {
    /// The passes of the pool in `buffers` for a frame of `pixels` whose records are
    /// `reservoir_size`-byte reservoirs; `history`: the stage's temporal sources (reservoirs,
    /// vertices) with the ages of its pool's records ([`history_age_buffer`]).
    pub(super) fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        (pixels, reservoir_size): (u32, usize),
        buffers: &PoolBuffers,
        (history, history_age): (screen_reuse::History<'_>, wgpu::Buffer),
    ) -> Result<Self, ScreenReuseError> {
        let device = &ctx.device;
        let items = grid_item_count(pixels);
        let positions = buffers::storage_zeroed(device, "wgi pool positions", u64::from(items) * 4);
        let scan = Scan::new(device, &ScanDescriptor::for_device(device, items.max(1)))?;
        let scan_binding = scan.bind(
            device,
            &buffers.flags,
            &positions,
            items,
            ScanKind::Exclusive,
            None,
        )?;
        let label = format!("world-restir-gi {}", SCATTER.name);
        let scatter_k = shared.own_kernel(
            ctx,
            &label,
            &SCATTER.bindings(),
            pool_modules(&SCATTER),
            SCATTER.entries,
        )?;
        let res: Vec<(&str, Resource)> = vec![
            ("wgi_pool_params", (&buffers.params).into()),
            ("wgi_history_age", (&history_age).into()),
            ("wgi_flags", (&buffers.flags).into()),
            ("wgi_positions", (&positions).into()),
            ("wgi_history_reservoirs", history.reservoirs.into()),
            ("wgi_history_vertices", history.vertices.into()),
            ("wgi_history_pool_vertices", history.pool_vertices.into()),
            ("wgi_pool_reservoirs", (&buffers.reservoirs).into()),
            ("wgi_pool_vertices", (&buffers.vertices).into()),
            ("wgi_pool_age", (&buffers.age).into()),
            ("wgi_pool_count", (&buffers.count).into()),
        ];
        let scatter =
            shared.bound_pass(device, &scatter_k, "wgi_pool_scatter", res, Some(items))?;
        Ok(Self {
            history_age,
            positions,
            scan,
            scan_binding,
            scatter,
            pixels,
            reservoir_size,
        })
    }

    /// Records the pool's step of a frame, after the stage's persist copies: the pool the
    /// frame's grid was built with (and flagged) into the history after the pixels' records,
    /// then the next pool.
    pub(super) fn encode(
        &self,
        f: &mut FrameEncoder,
        buffers: &PoolBuffers,
        history: screen_reuse::History<'_>,
    ) -> Result<(), ScreenReuseError> {
        let px = u64::from(self.pixels);
        f.copy_to(
            &buffers.reservoirs,
            history.reservoirs,
            px * self.reservoir_size as u64,
        );
        f.copy(&buffers.vertices, history.pool_vertices);
        f.copy(&buffers.age, &self.history_age);
        f.scan(&self.scan, &self.scan_binding)?;
        f.dispatch(&self.scatter);
        Ok(())
    }

    /// Bytes of its buffers (the pool's own excluded).
    pub(super) fn bytes(&self) -> u64 {
        [&self.history_age, &self.positions]
            .map(wgpu::Buffer::size)
            .iter()
            .sum()
    }
}
