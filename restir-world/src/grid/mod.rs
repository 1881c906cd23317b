//! The world-space grid a stage's items are gathered in, built once per frame on `gpu-hash`
//! (the cells) and `gpu-scan` (the slot offsets), double-buffered with last frame's (Boissé
//! 2021, Algorithm 2), generic over the items: a stage says which item enters where (its WGSL
//! module `grid-items`, `fn grid_item(i: u32) -> GridItem`) and keeps whatever record it likes
//! per item index (a light reservoir, a path sample); the grid keeps, per cell, the list of the
//! item indices that fell in it.
//!
//! | pass | what |
//! |---|---|
//! | clear | the table of this frame's parity |
//! | `grid_insert` | find or insert each present item's cell (adaptive size, jittered in the tangent plane, the normal's axis folded into the key where asked), count it in its slot |
//! | gpu-scan | exclusive scan of the slot counts: each cell's offset in the compact storage |
//! | `grid_scatter` | each item's index into its cell's run |
//! | `grid_sort_cells` | each cell's run ordered by item index (images that do not depend on the order atomics ran in), then the stage's [`CellHook`] on it |
//!
//! A stage's kernel looks a point up in this frame's grid or last frame's ([`LOOKUP`],
//! [`lookup_modules`], WGSL `grid_visit`): last frame's table keeps last frame's eye, so the
//! adaptive cells are those the items were inserted with. The cell of a point
//! (WGSL `grid_cell`) is shared with the radiance cache, which keeps a record per cell in a
//! table of its own that lives across frames.

use gpu_hash::{CellSizing, HashGridParams, HashStats, HashTable, TableConfig};
use gpu_scan::{Scan, ScanBinding, ScanDescriptor, ScanKind};

use crate::gpu::{
    Access, BindingSet, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule,
    buffers,
};
use crate::render::{
    Buffer, ComposedKernel, KernelDef, OwnKernel, STAGE_GROUP, SharedGroups, SubStream,
    compose_with_library,
};
use crate::scene::Camera;

/// Library WGSL: the parameters, the item contract, a point's cell (needs gpu-hash's
/// `hash.wgsl`).
pub const WGSL: &str = include_str!("grid.wgsl");
/// The lookup functions of a kernel that binds [`LOOKUP`].
pub const LOOKUP_WGSL: &str = include_str!("lookup.wgsl");
const INSERT_WGSL: &str = include_str!("insert.wgsl");
const SCATTER_WGSL: &str = include_str!("scatter.wgsl");
const SORT_WGSL: &str = include_str!("sort.wgsl");

/// Errors of the grid.
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error(transparent)]
    Hash(#[from] gpu_hash::HashError),
    #[error(transparent)]
    Scan(#[from] gpu_scan::ScanError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad grid setting: {0}")]
    Config(String),
}

/// How a grid is sized and keyed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSettings {
    /// The hash table's dimensions (each of the two).
    pub table: TableConfig,
    /// The adaptive cell size (the eye is each frame's).
    pub sizing: CellSizing,
    /// Tangent-plane jitter of the positions by up to one cell, at insertion and lookup.
    pub jitter: bool,
    /// The axis the normal points along most folded into the key: the faces of a corner or of
    /// a thin wall never share a cell.
    pub fold_normal: bool,
    /// Each cell's list ordered by item index after the scatter.
    pub sort_cells: bool,
}

/// The adaptive cell sizing of `camera`'s frames: cells of `projected_size` pixels at their
/// distance from the eye, at least `min_cell_size` (every cell that size when not `adaptive`).
pub fn cell_sizing(
    camera: &Camera,
    min_cell_size: f32,
    projected_size: f32,
    adaptive: bool,
) -> CellSizing {
    CellSizing {
        min_cell_size,
        projected_size,
        fov_y: camera.vfov_deg.to_radians(),
        width: camera.width,
        height: camera.height,
        max_level: if adaptive { 24 } else { 0 },
    }
}

/// Buckets of a table sized to the frame: twice as many slots as items, so the table's load
/// stays at most 1/2 even when every item has a cell of its own (a bucket of 32 slots then
/// overflows with Poisson(16) probability 1e-4; cells hold about 4 items at the default
/// projected size, a load near 1/8), and at least 64 buckets.
pub fn auto_buckets(items: u32, slots_per_bucket: u32) -> u32 {
    let slots = u64::from(items) * 2;
    let buckets = slots.div_ceil(u64::from(slots_per_bucket.max(1)));
    buckets.clamp(64, u64::from(u32::MAX)) as u32
}

/// The cell of a surface point at `position` with geometric normal `normal` under `params`
/// (twin of WGSL `grid_cell`): gpu-hash's cell of the position, with `fold` the bucket and
/// checksum of the key the normal's axis is folded into; `None` where gpu-hash rejects it.
pub fn cell_of(
    params: &HashGridParams,
    position: glam::Vec3,
    normal: glam::Vec3,
    fold: bool,
) -> Option<gpu_hash::HashCell> {
    let mut c = params.cell(position);
    if !c.is_ok() {
        return None;
    }
    if fold {
        let mut key = c.key();
        key.level += (params.max_level + 1) * normal_axis(normal);
        c.bucket = key.bucket(params.num_buckets);
        c.checksum = key.checksum();
    }
    Some(c)
}

/// Twin of WGSL `grid_normal_axis`: 0..5, the axis `n` points along most and its sign.
pub fn normal_axis(n: glam::Vec3) -> u32 {
    let a = n.abs();
    let (axis, positive) = if a.x >= a.y && a.x >= a.z {
        (0, n.x >= 0.0)
    } else if a.y >= a.z {
        (1, n.y >= 0.0)
    } else {
        (2, n.z >= 0.0)
    };
    2 * axis + u32::from(!positive)
}

/// WGSL `GridParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GridParams {
    /// Items that may enter the grid (one invocation each).
    pub items: u32,
    pub jitter: u32,
    pub fold_normal: u32,
    pub _pad: u32,
}

/// Slot values at and above this are not slots (gpu-hash's sentinels: not found, full,
/// rejected); an item's slot is one of them when it is not in the grid.
pub const FIRST_SENTINEL: u32 = gpu_hash::HASH_FIRST_SENTINEL;

/// The constants of the build: the sentinels and the random sub-stream of the insert's jitter.
fn constants_wgsl(random: SubStream) -> String {
    format!(
        "const GRID_NO_SLOT: u32 = {:#x}u;\nconst GRID_FIRST_SENTINEL: u32 = {FIRST_SENTINEL:#x}u;\n\
         const GRID_STREAM_BUILD: u32 = {}u;\nconst GRID_SALT_BUILD: u32 = {}u;\n",
        gpu_hash::HASH_NOT_FOUND,
        random.streams[0] as u32,
        random.first,
    )
}

const PARAMS: Buffer = ("grid_params", "GridParams", Access::Uniform);

/// What a kernel that looks the grid up binds (in this order, then gpu-hash's lookup block
/// [`with_lookup`] adds): the grid's parameters and the compact cell storage.
pub const LOOKUP: &[Buffer] = &[
    PARAMS,
    ("grid_lookup_offsets", "array<u32>", Access::Read),
    ("grid_lookup_cells", "array<u32>", Access::Read),
];

/// The name of the gpu-hash block in a kernel's bindings.
const HASH_BLOCK: &str = "grid_hash";

/// `set` (a kernel's own group-3 bindings, [`LOOKUP`] among them) with gpu-hash's lookup block
/// after them.
pub fn with_lookup(set: BindingSet) -> BindingSet {
    set.block(HASH_BLOCK, gpu_hash::lookup_bind_group_layout_entries)
}

/// The modules a kernel that looks the grid up composes (its own bindings are `own` group-3
/// buffers before gpu-hash's block): gpu-hash's lookup role, the grid library and its lookup.
pub fn lookup_modules(own: u32) -> Vec<WgslModule> {
    let at = gpu_hash::wgsl::BindAt {
        group: STAGE_GROUP,
        first_binding: own,
    };
    vec![
        WgslModule::new("gpu-hash", &[], gpu_hash::wgsl::compose(None, Some(at))),
        WgslModule::new("grid", &["gpu-hash"], WGSL),
        WgslModule::new("grid-lookup", &["grid", "rng"], LOOKUP_WGSL),
    ]
}

/// The grid library alone (a point's cell), for a kernel that composes gpu-hash itself.
pub fn cell_module() -> WgslModule {
    WgslModule::new("grid", &["gpu-hash"], WGSL)
}

/// The items a stage puts in its grid.
#[derive(Debug)]
pub struct GridItems<'a> {
    /// The stage's name (kernel labels).
    pub name: &'static str,
    /// How many (invocations of the build's passes).
    pub count: u32,
    /// The random sub-stream of the insert's jitter (of one stream).
    pub random: SubStream,
    /// The stage's modules, among them `grid-items` with `fn grid_item(i: u32) -> GridItem`
    /// (it may read the render buffers and `bindings`).
    pub modules: Vec<WgslModule>,
    /// Buffers `grid-items` binds besides the render library's, bound to `buffers`.
    pub bindings: &'static [Buffer],
    pub buffers: Vec<&'a wgpu::Buffer>,
    /// What the stage does with each cell once its list is sorted (needs
    /// [`GridSettings::sort_cells`]); `None`: nothing.
    pub cells: Option<CellHook<'a>>,
}

/// A stage's work on each cell of the grid, run by the sort pass once the cell's list is final
/// (a pass and a dispatch saved): its WGSL modules, among them `grid-cells` with `fn
/// grid_cell_sorted(start: u32, count: u32)`, which reads `grid_cells[start..start + count]`
/// (the cell's item indices, ascending) and the buffers it binds.
#[derive(Debug)]
pub struct CellHook<'a> {
    pub modules: Vec<WgslModule>,
    /// Buffers `grid-cells` binds (the sort pass alone), bound to `buffers`.
    pub bindings: &'static [Buffer],
    pub buffers: Vec<&'a wgpu::Buffer>,
}

impl GridItems<'_> {
    /// The buffers kernel `k` binds for the stage: the items', and for the sort its cells'.
    fn bindings(&self, k: &KernelDef) -> Vec<Buffer> {
        let mut b = self.bindings.to_vec();
        if k.name == SORT.name {
            b.extend(self.cells.iter().flat_map(|c| c.bindings.iter().copied()));
        }
        b
    }

    /// What [`Self::bindings`] binds for kernel `k`.
    fn resources(&self, k: &KernelDef) -> Vec<(&'static str, Resource<'_>)> {
        let names = self.bindings(k).into_iter().map(|(n, _, _)| n);
        let cells = self.cells.iter().flat_map(|c| c.buffers.iter());
        let buffers = self
            .buffers
            .iter()
            .chain(cells.filter(|_| k.name == SORT.name));
        names.zip(buffers.map(|b| Resource::from(*b))).collect()
    }

    /// The sort's modules with `grid-cells`: the stage's, or one that does nothing.
    fn cells_modules(&self) -> Vec<WgslModule> {
        self.cells.as_ref().map_or_else(
            || {
                let nothing = "fn grid_cell_sorted(start: u32, count: u32) {}\n";
                vec![WgslModule::new("grid-cells", &[], nothing)]
            },
            |c| c.modules.clone(),
        )
    }
}

const INSERT: KernelDef = KernelDef::new(
    "grid-insert",
    &["grid_insert"],
    INSERT_WGSL,
    &[&[
        PARAMS,
        ("grid_item_slot", "array<vec2<u32>>", Access::ReadWrite),
    ]],
);
const SCATTER_BUFFERS: &[Buffer] = &[
    PARAMS,
    ("grid_item_slot", "array<vec2<u32>>", Access::Read),
    ("grid_offsets", "array<u32>", Access::Read),
    ("grid_counters", "array<u32>", Access::Read),
    ("grid_cells", "array<u32>", Access::ReadWrite),
];
const SCATTER: KernelDef = KernelDef::new(
    "grid-scatter",
    &["grid_scatter"],
    SCATTER_WGSL,
    &[SCATTER_BUFFERS],
);
const SORT: KernelDef = KernelDef::new(
    "grid-sort",
    &["grid_sort_cells"],
    SORT_WGSL,
    &[SCATTER_BUFFERS],
);

/// The build kernel `k`'s group 3: the items' buffers, `k`'s own, and for the insert
/// gpu-hash's table block.
fn build_bindings(k: &KernelDef, items: &GridItems) -> BindingSet {
    let own: Vec<Buffer> = items
        .bindings(k)
        .into_iter()
        .chain(k.buffers().copied())
        .collect();
    let set = BindingSet::of_buffers(k.name, &own);
    match k.name == INSERT.name {
        true => set.block(HASH_BLOCK, gpu_hash::bind_group_layout_entries),
        false => set,
    }
}

/// The build kernel `k`'s modules after the stage's: its bindings, gpu-hash's table role (the
/// insert) or structs alone, the grid library and the build.
fn build_modules(k: &KernelDef, items: &GridItems) -> Vec<WgslModule> {
    let set = build_bindings(k, items);
    let at = gpu_hash::wgsl::BindAt {
        group: STAGE_GROUP,
        first_binding: (items.bindings(k).len() + k.buffers().count()) as u32,
    };
    let hash = match k.name == INSERT.name {
        true => gpu_hash::wgsl::compose(Some(at), None),
        false => gpu_hash::wgsl::compose(None, None),
    };
    let mut m = items.modules.clone();
    let mut deps = vec![
        "grid",
        "grid-bindings",
        "grid-constants",
        "grid-items",
        "workgroup",
    ];
    if k.name == SORT.name {
        m.extend(items.cells_modules());
        deps.push("grid-cells");
    }
    m.extend([
        WgslModule::new("grid-bindings", &[], set.wgsl(STAGE_GROUP)),
        WgslModule::new("grid-constants", &[], constants_wgsl(items.random)),
        WgslModule::new("gpu-hash", &[], hash),
        cell_module(),
        WgslModule::new(k.name, &deps, k.source),
    ]);
    m
}

/// The build's kernels for `items`, composed as used (for the workspace's checks), with their
/// binding sets.
pub fn kernels(items: &GridItems) -> Vec<ComposedKernel> {
    [&INSERT, &SCATTER, &SORT]
        .iter()
        .map(|k| {
            let source = compose_with_library(Tracer::Bvh, build_modules(k, items));
            let name = format!("restir-world/grid/{} of {}", k.name, items.name);
            ComposedKernel::stage(name, source, build_bindings(k, items))
        })
        .collect()
}

/// The grid's buffers besides the hash tables; `[p]`: the frame of parity p's.
#[derive(Debug)]
struct GridBuffers {
    params: wgpu::Buffer,
    offsets: [wgpu::Buffer; 2],
    cells: [wgpu::Buffer; 2],
    /// Per item: (slot, index in slot), or a sentinel slot when it is not in the grid.
    item_slot: wgpu::Buffer,
}

/// The build's passes, per parity.
#[derive(Debug)]
struct BuildPasses {
    insert: [Pass; 2],
    scatter: [Pass; 2],
    sort: Option<[Pass; 2]>,
}

/// A world-space grid of a stage's items: two hash tables with their compact cell storages
/// (this frame's and last frame's), the scan that lays the cells out, and the build's passes.
#[derive(Debug)]
pub struct WorldGrid {
    settings: GridSettings,
    items: u32,
    grid_params: HashGridParams,
    tables: [HashTable; 2],
    buffers: GridBuffers,
    scan: Scan,
    scan_bindings: [ScanBinding; 2],
    passes: BuildPasses,
    /// The parity of the next build.
    parity: usize,
}

impl WorldGrid {
    /// The grid of `items` on `shared`'s render library, seen first from `eye`.
    pub fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        settings: GridSettings,
        items: GridItems,
        eye: glam::Vec3,
    ) -> Result<Self, GridError> {
        let device = &ctx.device;
        settings.table.validate()?;
        if items.cells.is_some() && !settings.sort_cells {
            return Err(GridError::Config(format!(
                "{}'s cell hook runs in the sort pass: the grid must sort its cells",
                items.name
            )));
        }
        let grid_params = HashGridParams::new(&settings.table, &settings.sizing, eye)?;
        let [t0, t1] = [0, 1].map(|_| HashTable::new(device, &ctx.queue, &grid_params));
        let tables = [t0?, t1?];
        let slots = u32::try_from(settings.table.num_slots()).map_err(|_| {
            GridError::Config(format!(
                "{} slots do not fit u32",
                settings.table.num_slots()
            ))
        })?;
        let n = u64::from(items.count);
        ctx.check_binding_size("the grid's cell storage", n * 8)?;
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(device, label, size);
        let pair = |label: &str, size: u64| [0, 1].map(|p| zeroed(&format!("{label} {p}"), size));
        let params = GridParams {
            items: items.count,
            jitter: u32::from(settings.jitter),
            fold_normal: u32::from(settings.fold_normal),
            _pad: 0,
        };
        let b = GridBuffers {
            params: buffers::with_usage(
                device,
                "grid params",
                &[params],
                wgpu::BufferUsages::UNIFORM,
            ),
            offsets: pair("grid offsets", u64::from(slots) * 4),
            cells: pair("grid cells", n * 4),
            item_slot: zeroed("grid item slot", n * 8),
        };
        let scan = Scan::new(device, &ScanDescriptor::for_device(device, slots.max(1)))?;
        let bind_scan = |p: usize| {
            let (counters, offsets) = (tables[p].counters(), &b.offsets[p]);
            scan.bind(device, counters, offsets, slots, ScanKind::Exclusive, None)
        };
        let scan_bindings = [bind_scan(0)?, bind_scan(1)?];
        let passes = BuildPasses::new(ctx, shared, &settings, &items, &tables, &b)?;
        Ok(Self {
            settings,
            items: items.count,
            grid_params,
            tables,
            buffers: b,
            scan,
            scan_bindings,
            passes,
            parity: 0,
        })
    }

    pub fn settings(&self) -> &GridSettings {
        &self.settings
    }

    /// Builds this frame's grid seen from `eye` into the table of the frame's parity, which it
    /// returns (last frame's grid is the other one); the next build takes the other.
    pub fn encode_build(
        &mut self,
        f: &mut FrameEncoder,
        eye: glam::Vec3,
    ) -> Result<usize, GridError> {
        let p = self.parity;
        let grid = self.grid_params.with_eye(eye)?;
        f.upload(self.tables[p].params(), 0, &grid);
        self.tables[p].encode_clear(f.raw());
        f.dispatch(&self.passes.insert[p]);
        f.scan(&self.scan, &self.scan_bindings[p])?;
        f.dispatch(&self.passes.scatter[p]);
        if let Some(sort) = &self.passes.sort {
            f.dispatch(&sort[p]);
        }
        self.parity = 1 - p;
        Ok(p)
    }

    /// What a kernel binding [`LOOKUP`] and [`with_lookup`]'s block is bound to, to look up
    /// the grid of parity `p`; `first` is the block's first binding.
    pub fn lookup_resources(&self, p: usize, first: u32) -> Vec<(&'static str, Resource<'_>)> {
        let b = &self.buffers;
        vec![
            ("grid_params", (&b.params).into()),
            ("grid_lookup_offsets", (&b.offsets[p]).into()),
            ("grid_lookup_cells", (&b.cells[p]).into()),
            (
                HASH_BLOCK,
                Resource::Block(self.tables[p].lookup_bind_group_entries(first)),
            ),
        ]
    }

    /// Per item of the last build: (slot, index in slot), or a sentinel slot (at or above
    /// [`FIRST_SENTINEL`]) when it is not in the grid.
    pub fn item_slots(&self) -> &wgpu::Buffer {
        &self.buffers.item_slot
    }

    /// Statistics of the last built grid (overflows = items left out of it).
    pub fn stats(&self, ctx: &GpuContext) -> Result<HashStats, GpuError> {
        let v: Vec<HashStats> = buffers::read(ctx, self.tables[1 - self.parity].stats())?;
        Ok(v[0])
    }

    /// The last built grid read back, its first `n` items.
    pub fn read(&self, ctx: &GpuContext, n: usize) -> Result<GridReadback, GpuError> {
        let p = 1 - self.parity;
        let mut item_slot: Vec<[u32; 2]> = buffers::read(ctx, &self.buffers.item_slot)?;
        item_slot.truncate(n);
        let mut cells: Vec<u32> = buffers::read(ctx, &self.buffers.cells[p])?;
        cells.truncate(n);
        Ok(GridReadback {
            vertex_slot: item_slot,
            counters: buffers::read(ctx, self.tables[p].counters())?,
            offsets: buffers::read(ctx, &self.buffers.offsets[p])?,
            cells,
            checksums: buffers::read(ctx, self.tables[p].checksums())?,
        })
    }

    /// The cells' parameters (the eye is each build's: [`HashGridParams::with_eye`]).
    pub fn params(&self) -> &HashGridParams {
        &self.grid_params
    }

    /// Bytes of its buffers: the two hash tables (checksums, slot counters, statistics,
    /// parameters), the slot offsets and cell lists of both frames, the items' slots.
    pub fn bytes(&self) -> u64 {
        let b = &self.buffers;
        let tables = self.tables.iter().flat_map(|t| {
            [t.checksums(), t.counters(), t.stats(), t.params()].map(wgpu::Buffer::size)
        });
        let own = [
            &b.params,
            &b.offsets[0],
            &b.offsets[1],
            &b.cells[0],
            &b.cells[1],
        ]
        .into_iter()
        .chain([&b.item_slot])
        .map(wgpu::Buffer::size);
        tables.chain(own).sum()
    }

    /// Items per frame.
    pub fn items(&self) -> u32 {
        self.items
    }
}

impl BuildPasses {
    fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        settings: &GridSettings,
        items: &GridItems,
        tables: &[HashTable; 2],
        b: &GridBuffers,
    ) -> Result<Self, GpuError> {
        let kernel = |k: &KernelDef| -> Result<OwnKernel, GpuError> {
            let name = format!("{} {}", items.name, k.name);
            let set = build_bindings(k, items);
            shared.own_kernel(ctx, &name, &set, build_modules(k, items), k.entries)
        };
        let insert = kernel(&INSERT)?;
        let first_hash = (items.bindings(&INSERT).len() + INSERT.buffers().count()) as u32;
        let insert_pass = |p: usize| {
            let mut res = items.resources(&INSERT);
            res.extend([
                ("grid_params", (&b.params).into()),
                ("grid_item_slot", (&b.item_slot).into()),
                (
                    HASH_BLOCK,
                    Resource::Block(tables[p].bind_group_entries(first_hash)),
                ),
            ]);
            shared.bound_pass(&ctx.device, &insert, "grid_insert", res, Some(items.count))
        };
        // The scatter and the sort bind the same buffers of the grid.
        let list_pass = |k: &KernelDef, kernel: &OwnKernel, p: usize| {
            let mut res = items.resources(k);
            res.extend([
                ("grid_params", (&b.params).into()),
                ("grid_item_slot", (&b.item_slot).into()),
                ("grid_offsets", (&b.offsets[p]).into()),
                ("grid_counters", tables[p].counters().into()),
                ("grid_cells", (&b.cells[p]).into()),
            ]);
            shared.bound_pass(&ctx.device, kernel, k.entries[0], res, Some(items.count))
        };
        let scatter = kernel(&SCATTER)?;
        let sort = match settings.sort_cells {
            true => {
                let sort = kernel(&SORT)?;
                Some([list_pass(&SORT, &sort, 0)?, list_pass(&SORT, &sort, 1)?])
            }
            false => None,
        };
        Ok(Self {
            insert: [insert_pass(0)?, insert_pass(1)?],
            scatter: [
                list_pass(&SCATTER, &scatter, 0)?,
                list_pass(&SCATTER, &scatter, 1)?,
            ],
            sort,
        })
    }
}

/// A grid read back (see [`WorldGrid::read`]): per item (slot, index in slot), per slot counts,
/// exclusive offsets and the key's checksum, and the compact cell storage.
#[derive(Debug, Clone, PartialEq)]
pub struct GridReadback {
    pub vertex_slot: Vec<[u32; 2]>,
    pub counters: Vec<u32>,
    pub offsets: Vec<u32>,
    pub cells: Vec<u32>,
    pub checksums: Vec<u32>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn normal_axis_is_the_dominant_signed_axis() {
        assert_eq!(normal_axis(Vec3::X), 0);
        assert_eq!(normal_axis(-Vec3::X), 1);
        assert_eq!(normal_axis(Vec3::new(0.1, 0.9, 0.2)), 2);
        assert_eq!(normal_axis(Vec3::new(0.1, -0.9, 0.2)), 3);
        assert_eq!(normal_axis(Vec3::new(0.5, 0.5, -0.7)), 5);
    }

    #[test]
    fn auto_buckets_keep_load_at_most_half() {
        assert_eq!(auto_buckets(9216, 32), 576);
        assert_eq!(auto_buckets(0, 32), 64);
        for v in [1u32, 1000, 9216, 65_536, 1 << 20] {
            let b = auto_buckets(v, 32);
            assert!(u64::from(b) * 32 >= 2 * u64::from(v), "{v}");
        }
    }
}
