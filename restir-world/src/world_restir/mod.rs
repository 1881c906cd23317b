//! World-space spatiotemporal reservoir reuse for one-bounce diffuse GI (Boissé 2021),
//! composed from `gpu-hash` (the grid), `gpu-scan` (the slot offsets) and `reservoir` (every
//! reservoir operation) on the renderer's shared passes.
//!
//! Per frame, each step its own compute pass and GPU timestamp span (DESIGN.md section 3):
//!
//! | span | passes | reads | writes |
//! |---|---|---|---|
//! | `primary`, `gi` | the renderer's | camera, BVH | G-buffer, secondary vertices |
//! | `generate` | `wr_generate` (Alg. 1) | secondary, lights | reservoirs R0 |
//! | `build` | clear table, `wr_insert`, gpu-scan, `wr_scatter`, `wr_sort_cells` (Alg. 2) | secondary | table\[p\], vertex_slot, offsets\[p\], cells\[p\] |
//! | `temporal` | `wr_reuse` over table\[1-p\] (Alg. 3) | R0, prev reservoirs | R1 |
//! | `spatial` | k x `wr_reuse` over table\[p\], ping-pong | R1/R0 | R0/R1 |
//! | `shade` | `wr_shade` | final reservoirs | `render_indirect_frame` |
//! | `shade_direct` | the renderer's, or `wr_shade_direct` when unified | | direct |
//! | `accumulate` | the renderer's | | sums |
//! | `persist` | copy final reservoirs -> prev reservoirs | | |
//!
//! The passes from `generate` to `spatial` run over the grid's items: the secondary vertices,
//! followed by the primary ones with the unified cache ([`WorldRestirConfig::unified`]).
//!
//! `p` is the frame's parity: the two hash tables, slot-offset buffers and cell storages are
//! double-buffered and swap roles each frame, so the temporal pass looks vertices up in last
//! frame's grid with last frame's eye (each table's own params uniform).
//!
//! Composition: each kernel is a `KernelDef`: its own group-3 [`BindingSet`] (plus gpu-hash's
//! table or lookup role as the block `wr_hash`) and its WGSL file, composed after
//! `render::library()` (render buffers at group 0, BVH at 1, lights at 2, rng and reservoir
//! WGSL) with `world_restir.wgsl`. No scan, hash or reservoir math is written here.

use gpu_hash::{CellSizing, HashGridParams, HashStats, HashTable, TableConfig};
use gpu_scan::{Scan, ScanBinding, ScanDescriptor, ScanKind};

use crate::gpu::{
    Access, BindGroupLayout, BindingSet, FrameEncoder, GpuContext, GpuError, Kernel, Pass,
    Resource, Tracer, WgslModule, buffers,
};
use crate::render::{self, RenderError, Renderer, SharedGroups};
use crate::restir_di::{self, RestirDi, RestirDiConfig};
use crate::scene::{Camera, Scene};

/// Library WGSL (structs and helpers shared by the passes).
pub const WGSL: &str = include_str!("world_restir.wgsl");
const GENERATE_WGSL: &str = include_str!("generate.wgsl");
const INSERT_WGSL: &str = include_str!("insert.wgsl");
const SCATTER_WGSL: &str = include_str!("scatter.wgsl");
const REUSE_WGSL: &str = include_str!("reuse.wgsl");
const SHADE_WGSL: &str = include_str!("shade.wgsl");
const DEBUG_WGSL: &str = include_str!("debug.wgsl");

/// Random-stream ids of the passes (the renderer reserves 0..4 of its 16).
const PASS_GENERATE: u32 = 4;
const PASS_BUILD: u32 = 5;
const PASS_TEMPORAL: u32 = 6;
const PASS_SPATIAL: u32 = 7;

/// The group every world-space pass binds its own buffers at (0..3 are the renderer's).
pub const GROUP: u32 = 3;

/// Errors of world-space ReSTIR.
#[derive(Debug, thiserror::Error)]
pub enum WorldRestirError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Hash(#[from] gpu_hash::HashError),
    #[error(transparent)]
    Scan(#[from] gpu_scan::ScanError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    RestirDi(#[from] crate::restir_di::RestirDiError),
    #[error("bad world-restir setting: {0}")]
    Config(String),
}

/// Combination (MIS) weights of the reuse passes (reuse.wgsl has the formulas).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// The paper's 1/M: biased (darker) where a neighbour's target is 0 at a sample the
    /// receiver can use.
    Biased = 0,
    /// 1/Z (Bitterli et al. 2020): unbiased; Z counts the merged reservoirs that could have
    /// produced the selected sample.
    OneOverZ = 1,
    /// Pairwise MIS with confidence weights: unbiased, and robust to samples whose target is
    /// far larger at the receiver than where they were drawn.
    Pairwise = 2,
}

impl Combine {
    /// Every mode with its command-line name.
    pub const ALL: [(Combine, &'static str); 3] = [
        (Combine::Biased, "biased"),
        (Combine::OneOverZ, "one-over-z"),
        (Combine::Pairwise, "pairwise"),
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(c, _)| *c == self)
            .map_or("", |(_, n)| n)
    }
}

impl std::str::FromStr for Combine {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .find(|(_, n)| *n == s)
            .map(|(c, _)| *c)
            .ok_or_else(|| {
                format!("unknown combination {s:?}; known: biased, one-over-z, pairwise")
            })
    }
}

/// Every knob of world-space ReSTIR, with the paper's defaults (Boissé 2021, section 5, and
/// AMD's public implementation where the paper is silent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldRestirConfig {
    /// Hash-grid buckets. `None` (the default): sized to the frame by [`auto_buckets`] from the
    /// number of vertices that can enter the grid; `Some(100_000)` is the paper's fixed table.
    pub buckets: Option<u32>,
    /// Slots per bucket, i.e. linear-probing length (default 32, the paper's).
    pub slots: u32,
    /// RIS light candidates per vertex, the initial M (default 16, the paper's).
    pub candidates: u32,
    /// Reservoirs merged per cell lookup at most (default 4, the paper's `max_count`).
    pub max_count: u32,
    /// Spatial reuse passes per frame (default 2; the paper's is 4). Chosen by measurement on
    /// many-lights at 256x256 (llvmpipe, equal time against ris): 2 passes had the lowest
    /// indirect relMSE per GPU millisecond; a third and fourth pass mostly re-merge the same
    /// ~4 reservoirs of a cell and cost more than they remove.
    pub spatial_passes: u32,
    /// One temporal reuse pass from last frame's grid (default on, the paper's).
    pub temporal: bool,
    /// Cap of the confidence taken from last frame, as a multiple of `candidates` (default 20:
    /// at most 20 x 16 = 320 in total; each of the n <= max_count reservoirs the temporal lookup
    /// visits is capped at 320 / n).
    pub temporal_m_cap: u32,
    /// Smallest cell edge in world units (default 0.01 = 1 cm; the cell size when
    /// `adaptive_cell_size` is off).
    pub min_cell_size: f32,
    /// Targeted projected cell size in pixels of the adaptive cell size (default 16).
    pub projected_size: f32,
    /// Tangent-plane jitter of the vertex position by up to one cell before insertion and
    /// lookup (default on).
    pub jitter: bool,
    /// Cell size adapted to the distance from the eye (paper Algorithm 4; default on). Off:
    /// every cell is `min_cell_size`.
    pub adaptive_cell_size: bool,
    /// A stored reservoir is reused only when the cosine between its vertex normal and the
    /// receiver's is at least this (default 0.8409 = 0.5^(1/4), i.e. dot^4 >= 0.5, about 33
    /// degrees, as in Capsaicin).
    pub normal_threshold: f32,
    /// GI resolution scale as a stride (default 1 = every pixel; 2 = one pixel of each 2x2
    /// block, rotating over frames, generates a reservoir and enters the grid: the paper's half
    /// resolution). Every pixel still looks the grid up and shades; GI rays are traced for every
    /// pixel by the shared `gi` pass. Needs reuse on (with no reuse the other pixels stay black).
    /// Biased above 1: a pixel without a reservoir of its own gets only samples its neighbours
    /// could draw (measured on many-lights at 128x128 with stride 2: indirect mean -15/-22/-13%
    /// per channel; 63.5 against 65.9 ms per frame with four spatial passes, single-frame relMSE
    /// 5.86 against 5.90), so the default stays 1.
    pub gi_stride: u32,
    /// How reused reservoirs are weighted (default [`Combine::Pairwise`], unbiased).
    pub combine: Combine,
    /// Order each cell's vertex list by index after the scatter, so images do not depend on
    /// the order atomics ran in (default on; not in the paper, which accepts the race).
    pub sort_cells: bool,
    /// One reservoir cache for all light (the paper's future work; default off): primary
    /// vertices enter the same grid as the secondary ones with reservoirs of their own, go
    /// through the same temporal and spatial reuse, and their final reservoirs light the
    /// direct image (one shadow ray each) instead of the renderer's RIS.
    pub unified: bool,
}

impl Default for WorldRestirConfig {
    fn default() -> Self {
        Self {
            buckets: None,
            slots: 32,
            candidates: render::DEFAULT_CANDIDATES,
            max_count: 4,
            spatial_passes: 2,
            temporal: true,
            temporal_m_cap: 20,
            min_cell_size: 0.01,
            projected_size: 16.0,
            jitter: true,
            adaptive_cell_size: true,
            normal_threshold: 0.840_896_4,
            gi_stride: 1,
            combine: Combine::Pairwise,
            sort_cells: true,
            unified: false,
        }
    }
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
        CellSizing {
            min_cell_size: self.min_cell_size,
            projected_size: self.projected_size,
            fov_y: camera.vfov_deg.to_radians(),
            width: camera.width,
            height: camera.height,
            max_level: if self.adaptive_cell_size { 24 } else { 0 },
        }
    }

    /// Sets one knob from its name (the field's, with `-` or `_`) and a value: numbers, `on` /
    /// `off` for switches, `auto` or a count for `buckets`, a [`Combine`] name for `combine`.
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), WorldRestirError> {
        fn parse<T: std::str::FromStr>(key: &str, value: &str) -> Result<T, WorldRestirError> {
            value
                .parse()
                .map_err(|_| WorldRestirError::Config(format!("{key}: cannot parse {value:?}")))
        }
        fn switch(key: &str, value: &str) -> Result<bool, WorldRestirError> {
            match value {
                "on" | "true" | "1" => Ok(true),
                "off" | "false" | "0" => Ok(false),
                _ => Err(WorldRestirError::Config(format!(
                    "{key}: expected on or off, got {value:?}"
                ))),
            }
        }
        match key.replace('-', "_").as_str() {
            "buckets" => {
                self.buckets = if value == "auto" {
                    None
                } else {
                    Some(parse(key, value)?)
                }
            }
            "slots" => self.slots = parse(key, value)?,
            "candidates" => self.candidates = parse(key, value)?,
            "max_count" => self.max_count = parse(key, value)?,
            "spatial_passes" => self.spatial_passes = parse(key, value)?,
            "temporal" => self.temporal = switch(key, value)?,
            "temporal_m_cap" => self.temporal_m_cap = parse(key, value)?,
            "min_cell_size" => self.min_cell_size = parse(key, value)?,
            "projected_size" => self.projected_size = parse(key, value)?,
            "jitter" => self.jitter = switch(key, value)?,
            "adaptive_cell_size" => self.adaptive_cell_size = switch(key, value)?,
            "normal_threshold" => self.normal_threshold = parse(key, value)?,
            "gi_stride" => self.gi_stride = parse(key, value)?,
            "combine" => {
                self.combine = value.parse().map_err(WorldRestirError::Config)?;
            }
            "sort_cells" => self.sort_cells = switch(key, value)?,
            "unified" => self.unified = switch(key, value)?,
            _ => {
                return Err(WorldRestirError::Config(format!(
                    "unknown knob {key:?}; known: {}",
                    Self::KNOBS.join(", ")
                )));
            }
        }
        Ok(())
    }

    /// The value of one knob as [`WorldRestirConfig::set`] takes it back (`set(key, get(key))`
    /// changes nothing): tools that edit knobs live list [`WorldRestirConfig::KNOBS`] with it.
    pub fn get(&self, key: &str) -> Result<String, WorldRestirError> {
        let switch = |on: bool| if on { "on" } else { "off" }.to_owned();
        Ok(match key.replace('-', "_").as_str() {
            "buckets" => self.buckets.map_or("auto".into(), |b| b.to_string()),
            "slots" => self.slots.to_string(),
            "candidates" => self.candidates.to_string(),
            "max_count" => self.max_count.to_string(),
            "spatial_passes" => self.spatial_passes.to_string(),
            "temporal" => switch(self.temporal),
            "temporal_m_cap" => self.temporal_m_cap.to_string(),
            "min_cell_size" => self.min_cell_size.to_string(),
            "projected_size" => self.projected_size.to_string(),
            "jitter" => switch(self.jitter),
            "adaptive_cell_size" => switch(self.adaptive_cell_size),
            "normal_threshold" => self.normal_threshold.to_string(),
            "gi_stride" => self.gi_stride.to_string(),
            "combine" => self.combine.name().to_owned(),
            "sort_cells" => switch(self.sort_cells),
            "unified" => switch(self.unified),
            _ => {
                return Err(WorldRestirError::Config(format!(
                    "unknown knob {key:?}; known: {}",
                    Self::KNOBS.join(", ")
                )));
            }
        })
    }

    /// The knobs where `self` differs from the default, as `key=value` joined by `+` (a
    /// `world-restir:` variant that rebuilds `self`; empty for the default).
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

    /// The knob names [`WorldRestirConfig::set`] takes.
    pub const KNOBS: [&'static str; 16] = [
        "buckets",
        "slots",
        "candidates",
        "max-count",
        "spatial-passes",
        "temporal",
        "temporal-m-cap",
        "min-cell-size",
        "projected-size",
        "jitter",
        "adaptive-cell-size",
        "normal-threshold",
        "gi-stride",
        "combine",
        "sort-cells",
        "unified",
    ];

    /// Checks every knob.
    pub fn validate(&self) -> Result<(), WorldRestirError> {
        let bad = |m: String| Err(WorldRestirError::Config(m));
        render::check_candidates(self.candidates).map_err(WorldRestirError::Config)?;
        if self.max_count == 0 {
            return bad("max_count must be at least 1".into());
        }
        if self.spatial_passes > 64 {
            return bad(format!(
                "spatial_passes {} must be <= 64",
                self.spatial_passes
            ));
        }
        if !(-1.0..=1.0).contains(&self.normal_threshold) {
            return bad(format!(
                "normal_threshold {} must be a cosine in [-1, 1]",
                self.normal_threshold
            ));
        }
        if self.gi_stride == 0 || self.gi_stride > 8 {
            return bad(format!("gi_stride {} must be in 1..=8", self.gi_stride));
        }
        if self.temporal_m_cap == 0 {
            return bad("temporal_m_cap must be at least 1".into());
        }
        if self.buckets == Some(0) {
            return bad("buckets must be at least 1 (or left to size with the frame)".into());
        }
        self.table(1, 1).validate()?;
        Ok(())
    }
}

/// Buckets of a table sized to the frame: twice as many slots as vertices, so the table's load
/// stays at most 1/2 even when every vertex has a cell of its own (a bucket of 32 slots then
/// overflows with Poisson(16) probability 1e-4; cells hold about 4 vertices at the default
/// projected size, a load near 1/8), and at least 64 buckets.
pub fn auto_buckets(vertices: u32, slots_per_bucket: u32) -> u32 {
    let slots = u64::from(vertices) * 2;
    let buckets = slots.div_ceil(u64::from(slots_per_bucket.max(1)));
    buckets.clamp(64, u64::from(u32::MAX)) as u32
}

/// WGSL `WrParams` (the knobs the kernels read).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WrParams {
    pub candidates: u32,
    pub max_count: u32,
    pub normal_threshold: f32,
    /// Absolute cap: `temporal_m_cap x candidates`.
    pub temporal_m_cap: u32,
    pub jitter: u32,
    /// [`Combine`] as u32.
    pub combine: u32,
    pub gi_stride: u32,
    pub debug_view: u32,
    /// Grid items: [`WorldRestirConfig::items`].
    pub items: u32,
    /// Light tiles the generate pass draws its candidates from (restir-di's, with its
    /// `gi-tiles`), and samples per tile; 0: from the light table.
    pub tiles: u32,
    pub tile_size: u32,
    pub _pad0: u32,
}

/// WGSL `WrPass`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WrPass {
    pub pass_index: u32,
    pub temporal: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// Debug views ([`WorldRestir::debug_image`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DebugView {
    /// A colour per grid slot (cell) of each vertex; black: not in the grid.
    Cells = 0,
    /// Heat map of log2(M) of the final reservoir (blue M = 1 .. red M >= 2^16).
    M = 1,
    /// Red where the vertex found its bucket full and kept its own reservoir.
    Overflow = 2,
}

/// Generated constants header.
pub fn constants_wgsl() -> String {
    format!(
        "const WR_PASS_GENERATE: u32 = {PASS_GENERATE}u;\nconst WR_PASS_BUILD: u32 = {PASS_BUILD}u;\n\
         const WR_PASS_TEMPORAL: u32 = {PASS_TEMPORAL}u;\nconst WR_PASS_SPATIAL: u32 = {PASS_SPATIAL}u;\n\
         const WR_NO_SLOT: u32 = {:#x}u;\nconst WR_FULL: u32 = {:#x}u;\n\
         const WR_FIRST_SENTINEL: u32 = {:#x}u;\nconst WR_VIEW_CELLS: u32 = {}u;\n\
         const WR_VIEW_M: u32 = {}u;\n\
         const WR_COMBINE_BIASED: u32 = {}u;\nconst WR_COMBINE_ONE_OVER_Z: u32 = {}u;\n\
         const WR_COMBINE_PAIRWISE: u32 = {}u;\n",
        gpu_hash::HASH_NOT_FOUND,
        gpu_hash::HASH_FULL,
        gpu_hash::HASH_FIRST_SENTINEL,
        DebugView::Cells as u32,
        DebugView::M as u32,
        Combine::Biased as u32,
        Combine::OneOverZ as u32,
        Combine::Pairwise as u32,
    )
}

/// Which gpu-hash role a kernel composes (its bindings follow the kernel's own).
#[derive(Clone, Copy, PartialEq, Eq)]
enum HashRole {
    Table,
    Lookup,
}

/// One kernel module: its own group-3 buffers and gpu-hash role, its WGSL and entry points.
struct KernelDef {
    name: &'static str,
    entries: &'static [&'static str],
    source: &'static str,
    own: &'static [(&'static str, &'static str, Access)],
    hash: Option<HashRole>,
}

const RES: &str = "array<StoredReservoir>";
const PARAMS: (&str, &str, Access) = ("wr_params", "WrParams", Access::Uniform);
const GENERATE: KernelDef = KernelDef {
    name: "generate",
    entries: &["wr_generate"],
    source: GENERATE_WGSL,
    own: &[
        PARAMS,
        ("wr_out", RES, Access::ReadWrite),
        ("light_tiles", "array<LightSample>", Access::Read),
    ],
    hash: None,
};
const INSERT: KernelDef = KernelDef {
    name: "insert",
    entries: &["wr_insert"],
    source: INSERT_WGSL,
    own: &[
        PARAMS,
        ("wr_vertex_slot", "array<vec2<u32>>", Access::ReadWrite),
    ],
    hash: Some(HashRole::Table),
};
const SCATTER: KernelDef = KernelDef {
    name: "scatter",
    entries: &["wr_scatter", "wr_sort_cells"],
    source: SCATTER_WGSL,
    own: &[
        PARAMS,
        ("wr_vertex_slot", "array<vec2<u32>>", Access::Read),
        ("wr_offsets", "array<u32>", Access::Read),
        ("wr_counters", "array<u32>", Access::Read),
        ("wr_cells", "array<u32>", Access::ReadWrite),
    ],
    hash: None,
};
const REUSE: KernelDef = KernelDef {
    name: "reuse",
    entries: &["wr_reuse"],
    source: REUSE_WGSL,
    own: &[
        PARAMS,
        ("wr_pass", "WrPass", Access::Read),
        ("wr_src", RES, Access::Read),
        ("wr_self", RES, Access::Read),
        ("wr_out", RES, Access::ReadWrite),
        ("wr_lookup_offsets", "array<u32>", Access::Read),
        ("wr_lookup_cells", "array<u32>", Access::Read),
        ("wr_prev_vertices", "array<GVertex>", Access::Read),
    ],
    hash: Some(HashRole::Lookup),
};
const SHADE: KernelDef = KernelDef {
    name: "shade",
    entries: &["wr_shade", "wr_shade_direct"],
    source: SHADE_WGSL,
    own: &[PARAMS, ("wr_final", RES, Access::Read)],
    hash: None,
};
const DEBUG: KernelDef = KernelDef {
    name: "debug",
    entries: &["wr_debug_view"],
    source: DEBUG_WGSL,
    own: &[
        PARAMS,
        ("wr_final", RES, Access::Read),
        ("wr_vertex_slot", "array<vec2<u32>>", Access::Read),
        ("wr_debug", "array<vec4<f32>>", Access::ReadWrite),
    ],
    hash: None,
};
const KERNELS: [&KernelDef; 6] = [&GENERATE, &INSERT, &SCATTER, &REUSE, &SHADE, &DEBUG];

impl KernelDef {
    /// Group 3: the kernel's own buffers, then its gpu-hash role's as the block `wr_hash`.
    fn bindings(&self) -> BindingSet {
        let set = BindingSet::of_buffers(self.name, self.own);
        match self.hash {
            Some(HashRole::Table) => set.block("wr_hash", gpu_hash::bind_group_layout_entries),
            Some(HashRole::Lookup) => {
                set.block("wr_hash", gpu_hash::lookup_bind_group_layout_entries)
            }
            None => set,
        }
    }

    /// The modules composed after the render library.
    fn modules(&self) -> Vec<WgslModule> {
        let at = gpu_hash::wgsl::BindAt {
            group: GROUP,
            first_binding: self.own.len() as u32,
        };
        let role = |r| (self.hash == Some(r)).then_some(at);
        let hash = match self.hash {
            Some(_) => gpu_hash::wgsl::compose(role(HashRole::Table), role(HashRole::Lookup)),
            None => String::new(),
        };
        let tiles = self.own.iter().any(|(name, _, _)| *name == "light_tiles");
        let mut modules = vec![
            WgslModule::new("wr-constants", &[], constants_wgsl()),
            WgslModule::new("wr-bindings", &[], self.bindings().wgsl(GROUP)),
            WgslModule::new("gpu-hash", &[], hash),
            WgslModule::new(
                "world-restir",
                &["render", "reservoir", "wr-constants"],
                WGSL,
            ),
            WgslModule::new(
                self.name,
                &["world-restir", "wr-bindings", "gpu-hash", "workgroup"],
                self.source,
            ),
        ];
        modules.extend(tiles.then(restir_di::light_tiles_module));
        modules
    }
}

/// Every WGSL module of world-space ReSTIR, composed as used.
pub fn wgsl_modules() -> Vec<(String, String)> {
    KERNELS
        .iter()
        .map(|k| {
            (
                format!("restir-world/world_restir/{}", k.name),
                render::compose_with_library(Tracer::Bvh, k.modules()),
            )
        })
        .collect()
}

/// World-space ReSTIR's buffers besides the hash tables.
#[derive(Debug)]
struct WrBuffers {
    params: wgpu::Buffer,
    offsets: [wgpu::Buffer; 2],
    cells: [wgpu::Buffer; 2],
    vertex_slot: wgpu::Buffer,
    reservoirs: [wgpu::Buffer; 2],
    prev_reservoirs: wgpu::Buffer,
    /// Last frame's grid items' vertices: secondary, then primary when unified (the temporal
    /// pass's MIS weights).
    prev_vertices: wgpu::Buffer,
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
        slots: u64,
        tiles: Option<(u32, u32)>,
    ) -> Result<Self, WorldRestirError> {
        let px = u64::from(pixels);
        let items = u64::from(config.items(pixels));
        let res_bytes = items * size_of::<render::StoredReservoir>() as u64;
        ctx.check_binding_size("the world-restir reservoirs", res_bytes)?;
        let vertex_bytes = items * size_of::<render::GVertex>() as u64;
        ctx.check_binding_size("world-restir's last-frame vertices", vertex_bytes)?;
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(&ctx.device, label, size);
        let pair = |label: &str, size: u64| [0, 1].map(|p| zeroed(&format!("{label} {p}"), size));
        let wr_params = WrParams {
            candidates: config.candidates,
            max_count: config.max_count,
            normal_threshold: config.normal_threshold,
            temporal_m_cap: config.temporal_m_cap.saturating_mul(config.candidates),
            jitter: u32::from(config.jitter),
            combine: config.combine as u32,
            gi_stride: config.gi_stride,
            debug_view: 0,
            items: config.items(pixels),
            tiles: tiles.map_or(0, |t| t.0),
            tile_size: tiles.map_or(0, |t| t.1),
            ..Default::default()
        };
        Ok(Self {
            params: buffers::with_usage(
                &ctx.device,
                "wr params",
                &[wr_params],
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            offsets: pair("wr offsets", slots * 4),
            cells: pair("wr cells", items * 4),
            vertex_slot: zeroed("wr vertex slot", items * 8),
            reservoirs: pair("wr reservoirs", res_bytes),
            prev_reservoirs: zeroed("wr prev reservoirs", res_bytes),
            prev_vertices: zeroed("wr prev vertices", vertex_bytes),
            debug: zeroed("wr debug", px * 16),
            no_tiles: zeroed("wr no light tiles", restir_di::LIGHT_SAMPLE_BYTES),
        })
    }
}

/// The frame's passes; `[p]`: for the frame of parity p.
#[derive(Debug)]
struct WrPasses {
    generate: Pass,
    insert: [Pass; 2],
    scatter: [Pass; 2],
    sort: Option<[Pass; 2]>,
    temporal: Option<[Pass; 2]>,
    spatial: [Vec<Pass>; 2],
    shade: Pass,
    /// Direct light from the unified cache (replaces the renderer's).
    shade_direct: Option<Pass>,
    debug: Pass,
    /// The reservoirs the shade pass reads.
    final_index: usize,
}

impl WrPasses {
    /// Binds every pass. Reservoir chain: generate -> R0; temporal R0 -> R1; spatial
    /// ping-pong; shade reads the last.
    fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        b: &WrBuffers,
        tables: &[HashTable; 2],
        config: &WorldRestirConfig,
        tiles: Option<&wgpu::Buffer>,
    ) -> Result<Self, WorldRestirError> {
        let device = &ctx.device;
        let kernel = |k: &KernelDef| {
            let name = format!("world-restir {}", k.name);
            shared.own_kernel(ctx, &name, &k.bindings(), k.modules(), k.entries)
        };
        let [generate, insert, scatter, reuse, shade, debug] = KERNELS.map(kernel);
        let (generate, insert, scatter) = (generate?, insert?, scatter?);
        let (reuse, shade, debug) = (reuse?, shade?, debug?);
        // A pass over the grid items (secondary vertices, + primary ones when unified), or
        // over the pixels.
        let items = config.items(shared.pixels);
        let item_pass =
            |(k, layout): &(Kernel, BindGroupLayout), entry: &str, res: Vec<(&str, Resource)>| {
                let group = layout.bind(device, res)?;
                Ok::<Pass, GpuError>(shared.pass_over(device, k, entry, Some(&group), items))
            };
        let pass =
            |(k, layout): &(Kernel, BindGroupLayout), entry: &str, res: Vec<(&str, Resource)>| {
                let group = layout.bind(device, res)?;
                Ok::<Pass, GpuError>(shared.pass(device, k, entry, Some(&group)))
            };
        let params = || ("wr_params", Resource::from(&b.params));
        let both = |f: &dyn Fn(usize) -> Result<Pass, GpuError>| -> Result<[Pass; 2], GpuError> {
            Ok([f(0)?, f(1)?])
        };
        let insert_p = |p: usize| {
            let hash = Resource::Block(tables[p].bind_group_entries(INSERT.own.len() as u32));
            let res = vec![
                params(),
                ("wr_vertex_slot", (&b.vertex_slot).into()),
                ("wr_hash", hash),
            ];
            item_pass(&insert, "wr_insert", res)
        };
        let scatter_p = |entry: &str, p: usize| {
            let res = vec![
                params(),
                ("wr_vertex_slot", (&b.vertex_slot).into()),
                ("wr_offsets", (&b.offsets[p]).into()),
                ("wr_counters", tables[p].counters().into()),
                ("wr_cells", (&b.cells[p]).into()),
            ];
            item_pass(&scatter, entry, res)
        };
        // One reuse pass: reads `src` (and `own` for the receiver), writes `out`, looks up the
        // grid of parity `grid`.
        let reuse_pass =
            |index: u32, temporal: bool, [src, own, out]: [&wgpu::Buffer; 3], grid: usize| {
                let u = WrPass {
                    pass_index: index,
                    temporal: u32::from(temporal),
                    ..Default::default()
                };
                let u = buffers::with_usage(device, "wr pass", &[u], wgpu::BufferUsages::STORAGE);
                let hash = tables[grid].lookup_bind_group_entries(REUSE.own.len() as u32);
                let res = vec![
                    params(),
                    ("wr_pass", (&u).into()),
                    ("wr_src", src.into()),
                    ("wr_self", own.into()),
                    ("wr_out", out.into()),
                    ("wr_lookup_offsets", (&b.offsets[grid]).into()),
                    ("wr_lookup_cells", (&b.cells[grid]).into()),
                    ("wr_prev_vertices", (&b.prev_vertices).into()),
                    ("wr_hash", Resource::Block(hash)),
                ];
                item_pass(&reuse, "wr_reuse", res)
            };
        let r = &b.reservoirs;
        let mut cur = 0;
        let temporal = match config.temporal {
            true => {
                cur = 1;
                let src = [&b.prev_reservoirs, &r[0], &r[1]];
                Some(both(&|p| reuse_pass(0, true, src, 1 - p))?)
            }
            false => None,
        };
        let mut spatial: [Vec<Pass>; 2] = [Vec::new(), Vec::new()];
        for j in 0..config.spatial_passes {
            for (p, list) in spatial.iter_mut().enumerate() {
                list.push(reuse_pass(j, false, [&r[cur], &r[cur], &r[1 - cur]], p)?);
            }
            cur = 1 - cur;
        }
        let last = ("wr_final", Resource::from(&r[cur]));
        let debug_res = vec![
            params(),
            last,
            ("wr_vertex_slot", (&b.vertex_slot).into()),
            ("wr_debug", (&b.debug).into()),
        ];
        Ok(Self {
            generate: item_pass(
                &generate,
                "wr_generate",
                vec![
                    params(),
                    ("wr_out", (&r[0]).into()),
                    ("light_tiles", tiles.unwrap_or(&b.no_tiles).into()),
                ],
            )?,
            insert: both(&insert_p)?,
            scatter: both(&|p| scatter_p("wr_scatter", p))?,
            sort: match config.sort_cells {
                true => Some(both(&|p| scatter_p("wr_sort_cells", p))?),
                false => None,
            },
            temporal,
            spatial,
            shade: pass(
                &shade,
                "wr_shade",
                vec![params(), ("wr_final", (&r[cur]).into())],
            )?,
            shade_direct: match config.unified {
                true => Some(pass(
                    &shade,
                    "wr_shade_direct",
                    vec![params(), ("wr_final", (&r[cur]).into())],
                )?),
                false => None,
            },
            debug: pass(&debug, "wr_debug_view", debug_res)?,
            final_index: cur,
        })
    }
}

/// World-space ReSTIR GI on top of a [`Renderer`] (which it owns and drives).
#[derive(Debug)]
pub struct WorldRestir {
    renderer: Renderer,
    config: WorldRestirConfig,
    grid_params: HashGridParams,
    tables: [HashTable; 2],
    buffers: WrBuffers,
    scan: Scan,
    /// The slot-offset scan of table p's counters into offsets[p], bound once.
    scan_bindings: [ScanBinding; 2],
    passes: WrPasses,
    parity: usize,
    /// ReSTIR DI for the direct light at the primary vertex (`world-restir+restir-di`);
    /// `None`: the `ris` baseline's.
    direct: Option<RestirDi>,
}

impl WorldRestir {
    /// A renderer for `scene` seen by `camera` whose indirect light uses world-space ReSTIR
    /// with `config`; direct light at the primary is the `ris` baseline's (RIS over
    /// `render::DEFAULT_CANDIDATES` + one shadow ray), whatever `config.candidates` (the GI
    /// vertices' candidates) is, so that direct light compares equal with `ris`; with
    /// `config.unified` it comes from the primary vertices' reservoirs in the same grid.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        config: WorldRestirConfig,
        seed: u32,
    ) -> Result<Self, WorldRestirError> {
        Self::with_direct(ctx, scene, camera, config, None, seed)
    }

    /// [`WorldRestir::new`] whose direct light at the primary vertex is ReSTIR DI with
    /// `direct` (when given) instead of the `ris` baseline's.
    pub fn with_direct(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        config: WorldRestirConfig,
        direct: Option<RestirDiConfig>,
        seed: u32,
    ) -> Result<Self, WorldRestirError> {
        config.validate()?;
        if config.unified && direct.is_some() {
            return Err(WorldRestirError::Config(
                "unified and restir-di both light the direct image: use one".into(),
            ));
        }
        let renderer = Renderer::new(ctx, scene, camera, render::ris(), seed)?;
        let direct = match direct {
            Some(c) => Some(RestirDi::new(ctx, &renderer, c)?),
            None => None,
        };
        let device = &ctx.device;
        let table = config.table(camera.width, camera.height);
        let grid_params = HashGridParams::new(&table, &config.sizing(camera), camera.eye)?;
        let tables = [0, 1].map(|_| HashTable::new(device, &ctx.queue, &grid_params));
        let [t0, t1] = tables;
        let tables = [t0?, t1?];
        let slots = u32::try_from(table.num_slots()).map_err(|_| {
            WorldRestirError::Config(format!("{} slots do not fit u32", table.num_slots()))
        })?;
        // restir-di's light tiles, when they feed the generate pass too.
        let gi_tiles = direct.as_ref().filter(|d| d.config().gi_tiles);
        let tile_dims = gi_tiles.map(|d| (d.config().tiles, d.config().tile_size));
        let buffers = WrBuffers::new(
            ctx,
            &config,
            renderer.pixels(),
            table.num_slots(),
            tile_dims,
        )?;
        let scan = Scan::new(device, &ScanDescriptor::for_device(device, slots.max(1)))?;
        let bind_scan = |p: usize| {
            let (counters, offsets) = (tables[p].counters(), &buffers.offsets[p]);
            scan.bind(device, counters, offsets, slots, ScanKind::Exclusive, None)
        };
        let scan_bindings = [bind_scan(0)?, bind_scan(1)?];
        let tiles = gi_tiles.map(RestirDi::tiles);
        let passes = WrPasses::new(ctx, &renderer.shared, &buffers, &tables, &config, tiles)?;
        Ok(Self {
            renderer,
            config,
            grid_params,
            tables,
            buffers,
            scan,
            scan_bindings,
            passes,
            parity: 0,
            direct,
        })
    }

    pub fn config(&self) -> &WorldRestirConfig {
        &self.config
    }

    /// The ReSTIR DI stage of the direct light, when it has one.
    pub fn direct(&self) -> Option<&RestirDi> {
        self.direct.as_ref()
    }

    /// The renderer underneath (camera, frame counters).
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// Moves the camera from the next recorded frame on (the grid of the last frame keeps its
    /// own eye for the temporal lookup of the next).
    pub fn set_camera(&mut self, camera: &Camera) -> Result<(), WorldRestirError> {
        self.renderer.set_camera(camera)?;
        Ok(())
    }

    /// Records one whole frame.
    pub fn encode_frame(&mut self, f: &mut FrameEncoder) -> Result<(), WorldRestirError> {
        let (p, passes) = (self.parity, &self.passes);
        let grid = self.grid_params.with_eye(self.renderer.camera().eye)?;
        f.upload(self.tables[p].params(), 0, &grid);
        self.renderer.encode_primary_and_gi(f);
        if let Some(di) = self.direct.as_ref().filter(|d| d.config().gi_tiles) {
            di.encode_tiles(f);
        }
        f.span("generate", |f| f.dispatch(&passes.generate));
        f.span("build", |f| self.encode_build(f, p))?;
        if let Some(temporal) = &passes.temporal {
            f.span("temporal", |f| f.dispatch(&temporal[p]));
        }
        if !passes.spatial[p].is_empty() {
            f.span("spatial", |f| {
                passes.spatial[p].iter().for_each(|s| f.dispatch(s))
            });
        }
        f.span("shade", |f| f.dispatch(&passes.shade));
        match (&passes.shade_direct, self.direct.as_mut()) {
            (Some(unified), _) => f.span("shade_direct", |f| f.dispatch(unified)),
            (None, Some(di)) => di.encode(f, &self.renderer),
            (None, None) => self.renderer.encode_shade_direct(f),
        }
        if self.config.temporal {
            f.span("persist", |f| self.encode_persist(f));
        }
        self.renderer.encode_accumulate(f);
        self.parity = 1 - p;
        Ok(())
    }

    /// Algorithm 2 into table `p`: clear, insert, scan the slot counts, scatter, sort cells.
    fn encode_build(&self, f: &mut FrameEncoder, p: usize) -> Result<(), WorldRestirError> {
        self.tables[p].encode_clear(f.raw());
        f.dispatch(&self.passes.insert[p]);
        self.scan.encode(f.raw(), &self.scan_bindings[p])?;
        f.dispatch(&self.passes.scatter[p]);
        self.passes
            .sort
            .iter()
            .for_each(|sort| f.dispatch(&sort[p]));
        Ok(())
    }

    /// Keeps this frame's final reservoirs and grid items' vertices (secondary, then primary
    /// when unified) for the next temporal pass.
    fn encode_persist(&self, f: &mut FrameEncoder) {
        let (b, r) = (&self.buffers, &self.renderer.buffers);
        f.copy(&b.reservoirs[self.passes.final_index], &b.prev_reservoirs);
        f.copy(&r.secondary, &b.prev_vertices);
        if self.config.unified {
            f.raw().copy_buffer_to_buffer(
                &r.gbuffer,
                0,
                &b.prev_vertices,
                r.secondary.size(),
                None,
            );
        }
    }

    /// Clears the accumulated images (the temporal history stays).
    pub fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        self.renderer.restart_accumulation(f);
    }

    /// Statistics of the last built grid (overflows = vertices left out of it).
    pub fn grid_stats(&self, ctx: &GpuContext) -> Result<HashStats, GpuError> {
        let t = &self.tables[1 - self.parity];
        let v: Vec<HashStats> = buffers::read(ctx, t.stats())?;
        Ok(v[0])
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(&self, ctx: &GpuContext) -> Result<Vec<render::StoredReservoir>, GpuError> {
        let last = &self.buffers.reservoirs[self.passes.final_index];
        let mut v: Vec<render::StoredReservoir> = buffers::read(ctx, last)?;
        v.truncate(self.renderer.pixels() as usize);
        Ok(v)
    }

    /// The last built grid, read back: per vertex (slot, index in slot) (slot >= 0xffff_fff0:
    /// not in the grid), per slot counts and exclusive offsets, and the compact cell storage.
    pub fn grid(&self, ctx: &GpuContext) -> Result<GridReadback, GpuError> {
        let p = 1 - self.parity;
        let n = self.renderer.pixels() as usize;
        let mut vertex_slot: Vec<[u32; 2]> = buffers::read(ctx, &self.buffers.vertex_slot)?;
        vertex_slot.truncate(n);
        let mut cells: Vec<u32> = buffers::read(ctx, &self.buffers.cells[p])?;
        cells.truncate(n);
        Ok(GridReadback {
            vertex_slot,
            counters: buffers::read(ctx, self.tables[p].counters())?,
            offsets: buffers::read(ctx, &self.buffers.offsets[p])?,
            cells,
        })
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
        self.renderer.read_rgb(ctx, &self.buffers.debug, 1.0)
    }
}

/// The grid of one frame, read back (see [`WorldRestir::grid`]).
#[derive(Debug, Clone, PartialEq)]
pub struct GridReadback {
    pub vertex_slot: Vec<[u32; 2]>,
    pub counters: Vec<u32>,
    pub offsets: Vec<u32>,
    pub cells: Vec<u32>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_but_measured_ones() {
        let c = WorldRestirConfig::default();
        assert_eq!((c.buckets, c.slots, c.candidates), (None, 32, 16));
        assert_eq!(c.combine, Combine::Pairwise);
        for (mode, name) in Combine::ALL {
            assert_eq!(name.parse::<Combine>(), Ok(mode));
        }
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
            ("max-count", "8"),
            ("spatial-passes", "2"),
            ("temporal", "off"),
            ("temporal-m-cap", "10"),
            ("min-cell-size", "0.02"),
            ("projected-size", "8"),
            ("jitter", "off"),
            ("adaptive-cell-size", "off"),
            ("normal-threshold", "0.5"),
            ("gi-stride", "2"),
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
                max_count: 8,
                spatial_passes: 2,
                temporal: false,
                temporal_m_cap: 10,
                min_cell_size: 0.02,
                projected_size: 8.0,
                jitter: false,
                adaptive_cell_size: false,
                normal_threshold: 0.5,
                gi_stride: 2,
                combine: Combine::OneOverZ,
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
    fn auto_buckets_keep_load_at_most_half() {
        assert_eq!(auto_buckets(9216, 32), 576);
        assert_eq!(auto_buckets(0, 32), 64);
        for v in [1u32, 1000, 9216, 65_536, 1 << 20] {
            let b = auto_buckets(v, 32);
            assert!(u64::from(b) * 32 >= 2 * u64::from(v), "{v}");
        }
        let c = WorldRestirConfig::default();
        assert_eq!(c.table(96, 96).num_buckets, 576);
        let paper = WorldRestirConfig {
            buckets: Some(100_000),
            ..c
        };
        assert_eq!(paper.table(96, 96).num_buckets, 100_000);
    }
}
