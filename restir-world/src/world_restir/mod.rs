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
//! | `shade_direct`, `accumulate` | the renderer's | | direct, sums |
//! | `persist` | copy final reservoirs -> prev reservoirs | | |
//!
//! `p` is the frame's parity: the two hash tables, slot-offset buffers and cell storages are
//! double-buffered and swap roles each frame, so the temporal pass looks vertices up in last
//! frame's grid with last frame's eye (each table's own params uniform).
//!
//! Composition: every kernel module is `render::library()` (render buffers in group 0, BVH in 1,
//! lights in 2; it carries the rng and reservoir WGSL) + (for the grid passes) `gpu_hash::wgsl::compose(..)` in the
//! table role (insert) or the lookup role (reuse) + this module's constants and group-3 header +
//! `world_restir.wgsl` + the kernel file. No scan, hash or reservoir math is written here.

use glam::Vec3;
use gpu_hash::{CellSizing, HashGridParams, HashStats, HashTable, TableConfig};
use gpu_scan::{Scan, ScanBinding, ScanDescriptor, ScanKind};

use crate::gpu::{SpanTimes, buffers};
use crate::render::{self, Method, PassTimes, RenderError, Renderer};
use crate::scene::{Camera, Scene};
use crate::trace::dispatch_2d;
use crate::{GpuContext, GpuError, GpuTimer};

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
    /// each `gi_stride` x `gi_stride` block.
    pub fn max_vertices(&self, width: u32, height: u32) -> u32 {
        width.div_ceil(self.gi_stride.max(1)) * height.div_ceil(self.gi_stride.max(1))
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
            _ => {
                return Err(WorldRestirError::Config(format!(
                    "unknown knob {key:?}; known: {}",
                    Self::KNOBS.join(", ")
                )));
            }
        }
        Ok(())
    }

    /// The knob names [`WorldRestirConfig::set`] takes.
    pub const KNOBS: [&'static str; 15] = [
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

/// A vertex's stored reservoir (WGSL `WrReservoir`): the selected light sample, reservoir's
/// packed (W, M) and the normal of the vertex that generated it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WrReservoir {
    pub light_position: [f32; 3],
    pub ucw: f32,
    pub light_normal: [f32; 3],
    pub m: u32,
    pub light_emission: [f32; 3],
    pub _pad0: u32,
    pub vertex_normal: [f32; 3],
    pub _pad1: u32,
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
         const WR_VIEW_M: u32 = {}u;\noverride WORKGROUP_SIZE: u32 = {}u;\n\
         const WR_COMBINE_BIASED: u32 = {}u;\nconst WR_COMBINE_ONE_OVER_Z: u32 = {}u;\n\
         const WR_COMBINE_PAIRWISE: u32 = {}u;\n",
        gpu_hash::HASH_NOT_FOUND,
        gpu_hash::HASH_FULL,
        gpu_hash::HASH_FIRST_SENTINEL,
        DebugView::Cells as u32,
        DebugView::M as u32,
        render::WORKGROUP_SIZE,
        Combine::Biased as u32,
        Combine::OneOverZ as u32,
        Combine::Pairwise as u32,
    )
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Access {
    Uniform,
    Read,
    ReadWrite,
}

/// One kernel module's own group-3 buffers (before any gpu-hash role, which follows them).
struct Kernel {
    name: &'static str,
    entry: &'static [&'static str],
    source: &'static str,
    own: &'static [(&'static str, &'static str, Access)],
    hash_table: bool,
    hash_lookup: bool,
}

const RES: &str = "array<WrReservoir>";
const KERNELS: [Kernel; 6] = [
    Kernel {
        name: "generate",
        entry: &["wr_generate"],
        source: GENERATE_WGSL,
        own: &[
            ("wr_params", "WrParams", Access::Uniform),
            ("wr_out", RES, Access::ReadWrite),
        ],
        hash_table: false,
        hash_lookup: false,
    },
    Kernel {
        name: "insert",
        entry: &["wr_insert"],
        source: INSERT_WGSL,
        own: &[
            ("wr_params", "WrParams", Access::Uniform),
            ("wr_vertex_slot", "array<vec2<u32>>", Access::ReadWrite),
        ],
        hash_table: true,
        hash_lookup: false,
    },
    Kernel {
        name: "scatter",
        entry: &["wr_scatter", "wr_sort_cells"],
        source: SCATTER_WGSL,
        own: &[
            ("wr_vertex_slot", "array<vec2<u32>>", Access::Read),
            ("wr_offsets", "array<u32>", Access::Read),
            ("wr_counters", "array<u32>", Access::Read),
            ("wr_cells", "array<u32>", Access::ReadWrite),
        ],
        hash_table: false,
        hash_lookup: false,
    },
    Kernel {
        name: "reuse",
        entry: &["wr_reuse"],
        source: REUSE_WGSL,
        own: &[
            ("wr_params", "WrParams", Access::Uniform),
            ("wr_pass", "WrPass", Access::Read),
            ("wr_src", RES, Access::Read),
            ("wr_self", RES, Access::Read),
            ("wr_out", RES, Access::ReadWrite),
            ("wr_lookup_offsets", "array<u32>", Access::Read),
            ("wr_lookup_cells", "array<u32>", Access::Read),
            ("wr_prev_vertices", "array<GVertex>", Access::Read),
        ],
        hash_table: false,
        hash_lookup: true,
    },
    Kernel {
        name: "shade",
        entry: &["wr_shade"],
        source: SHADE_WGSL,
        own: &[
            ("wr_params", "WrParams", Access::Uniform),
            ("wr_final", RES, Access::Read),
        ],
        hash_table: false,
        hash_lookup: false,
    },
    Kernel {
        name: "debug",
        entry: &["wr_debug_view"],
        source: DEBUG_WGSL,
        own: &[
            ("wr_params", "WrParams", Access::Uniform),
            ("wr_final", RES, Access::Read),
            ("wr_vertex_slot", "array<vec2<u32>>", Access::Read),
            ("wr_debug", "array<vec4<f32>>", Access::ReadWrite),
        ],
        hash_table: false,
        hash_lookup: false,
    },
];

const K_GENERATE: usize = 0;
const K_INSERT: usize = 1;
const K_SCATTER: usize = 2;
const K_REUSE: usize = 3;
const K_SHADE: usize = 4;
const K_DEBUG: usize = 5;

impl Kernel {
    fn header(&self) -> String {
        self.own
            .iter()
            .enumerate()
            .map(|(b, (name, ty, access))| {
                let a = match access {
                    Access::Uniform => "uniform",
                    Access::Read => "storage, read",
                    Access::ReadWrite => "storage, read_write",
                };
                format!("@group({GROUP}) @binding({b}) var<{a}> {name}: {ty};\n")
            })
            .collect()
    }

    fn hash_first(&self) -> u32 {
        self.own.len() as u32
    }

    /// The composed module.
    fn source(&self) -> String {
        let at = gpu_hash::wgsl::BindAt {
            group: GROUP,
            first_binding: self.hash_first(),
        };
        let mut parts = vec![render::library()];
        if self.hash_table || self.hash_lookup {
            parts.push(gpu_hash::wgsl::compose(
                self.hash_table.then_some(at),
                self.hash_lookup.then_some(at),
            ));
        }
        parts.push(constants_wgsl());
        parts.push(self.header());
        parts.push(WGSL.to_string());
        parts.push(self.source.to_string());
        parts.join("\n")
    }

    fn layout_entries(&self) -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut v: Vec<wgpu::BindGroupLayoutEntry> = self
            .own
            .iter()
            .enumerate()
            .map(|(b, (_, _, access))| {
                crate::gpu::buffers::layout_entry(
                    b as u32,
                    match access {
                        Access::Uniform => wgpu::BufferBindingType::Uniform,
                        Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
                        Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                    },
                )
            })
            .collect();
        if self.hash_table {
            v.extend(gpu_hash::bind_group_layout_entries(self.hash_first()));
        }
        if self.hash_lookup {
            v.extend(gpu_hash::lookup_bind_group_layout_entries(
                self.hash_first(),
            ));
        }
        v
    }
}

/// Every WGSL module of world-space ReSTIR, composed as used.
pub fn wgsl_modules() -> Vec<(String, String)> {
    KERNELS
        .iter()
        .map(|k| (format!("restir-world/world_restir/{}", k.name), k.source()))
        .collect()
}

/// Accumulated images read back from a renderer's sums, linear HDR RGB, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameImages {
    pub width: u32,
    pub height: u32,
    /// Frames averaged.
    pub frames: u32,
    pub direct: Vec<[f32; 3]>,
    pub indirect: Vec<[f32; 3]>,
}

impl FrameImages {
    /// direct + indirect.
    pub fn combined(&self) -> Vec<[f32; 3]> {
        self.direct
            .iter()
            .zip(&self.indirect)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect()
    }
}

fn read_rgb(
    ctx: &GpuContext,
    b: &wgpu::Buffer,
    n: usize,
    scale: f32,
) -> Result<Vec<[f32; 3]>, GpuError> {
    let v: Vec<[f32; 4]> = buffers::read(ctx, b)?;
    Ok(v.iter()
        .take(n)
        .map(|p| [p[0] * scale, p[1] * scale, p[2] * scale])
        .collect())
}

/// The accumulated (mean) images of any renderer (baselines included).
pub fn read_accumulated(ctx: &GpuContext, r: &Renderer) -> Result<FrameImages, GpuError> {
    let n = r.pixels() as usize;
    let scale = if r.frames() == 0 {
        0.0
    } else {
        1.0 / r.frames() as f32
    };
    Ok(FrameImages {
        width: r.camera.width,
        height: r.camera.height,
        frames: r.frames(),
        direct: read_rgb(ctx, &r.buffers.accum_direct, n, scale)?,
        indirect: read_rgb(ctx, &r.buffers.accum_indirect, n, scale)?,
    })
}

/// The last frame's images (one sample per pixel) of any renderer.
pub fn read_last_frame(ctx: &GpuContext, r: &Renderer) -> Result<FrameImages, GpuError> {
    let n = r.pixels() as usize;
    Ok(FrameImages {
        width: r.camera.width,
        height: r.camera.height,
        frames: 1,
        direct: read_rgb(ctx, &r.buffers.direct_frame, n, 1.0)?,
        indirect: read_rgb(ctx, &r.buffers.indirect_frame, n, 1.0)?,
    })
}

/// Adds one frame's span times to a running total.
pub fn add_times(total: &mut PassTimes, frame: &SpanTimes) {
    for (name, ms) in &frame.0 {
        match total.passes.iter_mut().find(|(n, _)| n == name) {
            Some((_, t)) => *t += ms,
            None => total.passes.push((name.clone(), *ms)),
        }
    }
    total.frames += 1;
}

/// A camera animation over `frames` frames (then it repeats).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraPath {
    Static,
    /// Orbit around the target by `degrees` about the up axis over `frames` frames.
    Orbit {
        frames: u32,
        degrees: f32,
    },
    /// Move towards the target by `fraction` of the eye-target distance over `frames` frames.
    Dolly {
        frames: u32,
        fraction: f32,
    },
}

impl CameraPath {
    /// The camera of frame `frame` of the path starting at `base`.
    pub fn camera(&self, base: &Camera, frame: u32) -> Camera {
        match *self {
            CameraPath::Static => *base,
            CameraPath::Orbit { frames, degrees } => {
                let t = (frame % frames.max(1)) as f32 / frames.max(1) as f32;
                let rot =
                    glam::Quat::from_axis_angle(base.up.normalize(), (degrees * t).to_radians());
                Camera {
                    eye: base.target + rot * (base.eye - base.target),
                    ..*base
                }
            }
            CameraPath::Dolly { frames, fraction } => {
                let t = (frame % frames.max(1)) as f32 / frames.max(1) as f32;
                Camera {
                    eye: base.eye + (base.target - base.eye) * (fraction * t),
                    ..*base
                }
            }
        }
    }
}

/// World-space ReSTIR GI on top of a [`Renderer`] (which it owns and drives).
#[derive(Debug)]
pub struct WorldRestir {
    pub renderer: Renderer,
    config: WorldRestirConfig,
    grid_params: HashGridParams,
    tables: [HashTable; 2],
    offsets: [wgpu::Buffer; 2],
    cells: [wgpu::Buffer; 2],
    vertex_slot: wgpu::Buffer,
    reservoirs: [wgpu::Buffer; 2],
    prev_reservoirs: wgpu::Buffer,
    /// Last frame's secondary vertices (the temporal pass's 1/Z test).
    prev_vertices: wgpu::Buffer,
    params: wgpu::Buffer,
    debug: wgpu::Buffer,
    scan: Scan,
    /// The slot-offset scan of table p's counters into offsets[p], bound once.
    scan_bindings: [ScanBinding; 2],
    pipelines: Vec<Vec<wgpu::ComputePipeline>>,
    generate_group: wgpu::BindGroup,
    insert_groups: [wgpu::BindGroup; 2],
    scatter_groups: [wgpu::BindGroup; 2],
    temporal_groups: Option<[wgpu::BindGroup; 2]>,
    spatial_groups: [Vec<wgpu::BindGroup>; 2],
    shade_group: wgpu::BindGroup,
    debug_group: wgpu::BindGroup,
    final_index: usize,
    parity: usize,
    max_groups_per_dim: u32,
}

impl WorldRestir {
    /// A renderer for `scene` seen by `camera` whose indirect light uses world-space ReSTIR
    /// with `config`; direct light at the primary is the `ris` baseline's (RIS over
    /// `render::DEFAULT_CANDIDATES` + one shadow ray), whatever `config.candidates` (the GI
    /// vertices' candidates) is, so that direct light compares equal with `ris`.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        config: WorldRestirConfig,
        seed: u32,
    ) -> Result<Self, WorldRestirError> {
        config.validate()?;
        // Refuse before any work when a pipeline declares more storage buffers than the device
        // allows (GL: 16).
        let mut shared = render::bind_group_layout_entries();
        shared.extend(crate::trace::bind_group_layout_entries(0));
        shared.extend(crate::lights::bind_group_layout_entries(0));
        let shared = render::count_storage_buffers(&shared);
        for k in &KERNELS {
            let own = render::count_storage_buffers(&k.layout_entries());
            render::check_storage_buffers(ctx, &format!("world-restir {}", k.name), shared + own)?;
        }
        let renderer = Renderer::new(
            ctx,
            scene,
            camera,
            Method::Ris {
                candidates: render::DEFAULT_CANDIDATES,
            },
            seed,
        )?;
        let device = &ctx.device;
        let limits = ctx.limits();
        let table = config.table(camera.width, camera.height);
        let grid_params = HashGridParams::new(&table, &config.sizing(camera), camera.eye)?;
        let tables = [
            HashTable::new(device, &ctx.queue, &grid_params)?,
            HashTable::new(device, &ctx.queue, &grid_params)?,
        ];
        let slots = table.num_slots();
        let slots_u32 = u32::try_from(slots)
            .map_err(|_| WorldRestirError::Config(format!("{slots} slots do not fit u32")))?;
        let px = u64::from(renderer.pixels());
        let res_bytes = px * size_of::<WrReservoir>() as u64;
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        if res_bytes > limit {
            return Err(RenderError::TooLarge {
                bytes: res_bytes,
                limit,
            }
            .into());
        }
        let zeroed = |label: &str, size: u64| buffers::storage_zeroed(device, label, size);
        let offsets = [
            zeroed("wr offsets 0", slots * 4),
            zeroed("wr offsets 1", slots * 4),
        ];
        let cells = [zeroed("wr cells 0", px * 4), zeroed("wr cells 1", px * 4)];
        let vertex_slot = zeroed("wr vertex slot", px * 8);
        let reservoirs = [
            zeroed("wr reservoirs 0", res_bytes),
            zeroed("wr reservoirs 1", res_bytes),
        ];
        let prev_reservoirs = zeroed("wr prev reservoirs", res_bytes);
        let prev_vertices = zeroed("wr prev vertices", renderer.buffers.secondary.size());
        let debug = zeroed("wr debug", px * 16);
        let wr_params = WrParams {
            candidates: config.candidates,
            max_count: config.max_count,
            normal_threshold: config.normal_threshold,
            temporal_m_cap: config.temporal_m_cap.saturating_mul(config.candidates),
            jitter: u32::from(config.jitter),
            combine: config.combine as u32,
            gi_stride: config.gi_stride,
            debug_view: 0,
        };
        let params = buffers::with_usage(
            device,
            "wr params",
            &[wr_params],
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let scan = Scan::new(
            device,
            &ScanDescriptor::for_device(device, slots_u32.max(1)),
        )?;
        let bind_scan = |p: usize| {
            scan.bind(
                device,
                tables[p].counters(),
                &offsets[p],
                slots_u32,
                ScanKind::Exclusive,
                None,
            )
        };
        let scan_bindings = [bind_scan(0)?, bind_scan(1)?];

        // Pipelines, one layout per kernel module.
        let (render_group, render_layout) = renderer.bind_group();
        let _ = render_group;
        let [(_, bvh_layout), (_, lights_layout)] = renderer.scene_bind_groups();
        let mut layouts = Vec::new();
        let mut pipelines = Vec::new();
        for k in &KERNELS {
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(k.name),
                entries: &k.layout_entries(),
            });
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(k.name),
                source: wgpu::ShaderSource::Wgsl(k.source().into()),
            });
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(k.name),
                bind_group_layouts: &[
                    Some(render_layout),
                    Some(bvh_layout),
                    Some(lights_layout),
                    Some(&layout),
                ],
                immediate_size: 0,
            });
            pipelines.push(
                k.entry
                    .iter()
                    .map(|e| {
                        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                            label: Some(e),
                            layout: Some(&pl),
                            module: &module,
                            entry_point: Some(e),
                            compilation_options: wgpu::PipelineCompilationOptions {
                                constants: &[("WORKGROUP_SIZE", f64::from(render::WORKGROUP_SIZE))],
                                ..Default::default()
                            },
                            cache: None,
                        })
                    })
                    .collect::<Vec<_>>(),
            );
            layouts.push(layout);
        }
        let group = |k: usize, bufs: &[&wgpu::Buffer], extra: Vec<wgpu::BindGroupEntry<'_>>| {
            let mut entries: Vec<wgpu::BindGroupEntry<'_>> = bufs
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource: b.as_entire_binding(),
                })
                .collect();
            entries.extend(extra);
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(KERNELS[k].name),
                layout: &layouts[k],
                entries: &entries,
            })
        };
        let generate_group = group(K_GENERATE, &[&params, &reservoirs[0]], vec![]);
        let insert_groups = [0, 1].map(|p| {
            group(
                K_INSERT,
                &[&params, &vertex_slot],
                tables[p].bind_group_entries(KERNELS[K_INSERT].hash_first()),
            )
        });
        let scatter_groups = [0, 1].map(|p| {
            group(
                K_SCATTER,
                &[&vertex_slot, &offsets[p], tables[p].counters(), &cells[p]],
                vec![],
            )
        });
        let pass_uniform = |index: u32, temporal: bool| {
            buffers::with_usage(
                device,
                "wr pass",
                &[WrPass {
                    pass_index: index,
                    temporal: u32::from(temporal),
                    ..Default::default()
                }],
                wgpu::BufferUsages::STORAGE,
            )
        };
        let reuse_first = KERNELS[K_REUSE].hash_first();
        // Reservoir chain: generate -> R0; temporal R0 -> R1; spatial ping-pong.
        let mut cur = 0usize;
        let temporal_groups = if config.temporal {
            let u = pass_uniform(0, true);
            let g = [0, 1].map(|p| {
                let prev = 1 - p;
                group(
                    K_REUSE,
                    &[
                        &params,
                        &u,
                        &prev_reservoirs,
                        &reservoirs[0],
                        &reservoirs[1],
                        &offsets[prev],
                        &cells[prev],
                        &prev_vertices,
                    ],
                    tables[prev].lookup_bind_group_entries(reuse_first),
                )
            });
            cur = 1;
            Some(g)
        } else {
            None
        };
        let mut spatial_groups: [Vec<wgpu::BindGroup>; 2] = [Vec::new(), Vec::new()];
        for j in 0..config.spatial_passes {
            let u = pass_uniform(j, false);
            for (p, list) in spatial_groups.iter_mut().enumerate() {
                list.push(group(
                    K_REUSE,
                    &[
                        &params,
                        &u,
                        &reservoirs[cur],
                        &reservoirs[cur],
                        &reservoirs[1 - cur],
                        &offsets[p],
                        &cells[p],
                        &prev_vertices,
                    ],
                    tables[p].lookup_bind_group_entries(reuse_first),
                ));
            }
            cur = 1 - cur;
        }
        let shade_group = group(K_SHADE, &[&params, &reservoirs[cur]], vec![]);
        let debug_group = group(
            K_DEBUG,
            &[&params, &reservoirs[cur], &vertex_slot, &debug],
            vec![],
        );
        Ok(Self {
            max_groups_per_dim: limits.max_compute_workgroups_per_dimension,
            renderer,
            config,
            grid_params,
            tables,
            offsets,
            cells,
            vertex_slot,
            reservoirs,
            prev_reservoirs,
            prev_vertices,
            params,
            debug,
            scan,
            scan_bindings,
            pipelines,
            generate_group,
            insert_groups,
            scatter_groups,
            temporal_groups,
            spatial_groups,
            shade_group,
            debug_group,
            final_index: cur,
            parity: 0,
        })
    }

    pub fn config(&self) -> &WorldRestirConfig {
        &self.config
    }

    fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
    ) {
        let (x, y) = dispatch_2d(
            self.renderer.pixels().div_ceil(render::WORKGROUP_SIZE),
            self.max_groups_per_dim,
        );
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, self.renderer.bind_group().0, &[]);
        let [(bvh, _), (lights, _)] = self.renderer.scene_bind_groups();
        pass.set_bind_group(1, bvh, &[]);
        pass.set_bind_group(2, lights, &[]);
        pass.set_bind_group(GROUP, group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    fn span<R>(
        timer: &mut Option<&mut GpuTimer>,
        encoder: &mut wgpu::CommandEncoder,
        name: &str,
        body: impl FnOnce(&mut wgpu::CommandEncoder) -> R,
    ) -> R {
        match timer {
            Some(t) => t.span(encoder, name, body),
            None => body(encoder),
        }
    }

    /// Moves the camera for the next frame (the grid of this frame keeps this frame's eye for
    /// the temporal lookup of the next).
    pub fn set_camera(
        &mut self,
        queue: &wgpu::Queue,
        camera: &Camera,
    ) -> Result<(), WorldRestirError> {
        self.renderer.set_camera(queue, camera)?;
        Ok(())
    }

    /// Records one whole frame. Writes this frame's grid params (eye) through `queue`, so
    /// submit each frame before encoding the next.
    pub fn encode_frame(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut GpuTimer>,
    ) -> Result<(), WorldRestirError> {
        let p = self.parity;
        let eye: Vec3 = self.renderer.camera.eye;
        self.tables[p].set_params(queue, &self.grid_params.with_eye(eye)?)?;
        self.renderer
            .encode_primary_and_gi(encoder, timer.as_deref_mut());
        Self::span(&mut timer, encoder, "generate", |enc| {
            self.dispatch(
                enc,
                "wr generate",
                &self.pipelines[K_GENERATE][0],
                &self.generate_group,
            )
        });
        Self::span(
            &mut timer,
            encoder,
            "build",
            |enc| -> Result<(), WorldRestirError> {
                self.tables[p].encode_clear(enc);
                self.dispatch(
                    enc,
                    "wr insert",
                    &self.pipelines[K_INSERT][0],
                    &self.insert_groups[p],
                );
                self.scan.encode(enc, &self.scan_bindings[p])?;
                self.dispatch(
                    enc,
                    "wr scatter",
                    &self.pipelines[K_SCATTER][0],
                    &self.scatter_groups[p],
                );
                if self.config.sort_cells {
                    self.dispatch(
                        enc,
                        "wr sort",
                        &self.pipelines[K_SCATTER][1],
                        &self.scatter_groups[p],
                    );
                }
                Ok(())
            },
        )?;
        if let Some(groups) = &self.temporal_groups {
            Self::span(&mut timer, encoder, "temporal", |enc| {
                self.dispatch(enc, "wr temporal", &self.pipelines[K_REUSE][0], &groups[p])
            });
        }
        if !self.spatial_groups[p].is_empty() {
            Self::span(&mut timer, encoder, "spatial", |enc| {
                for g in &self.spatial_groups[p] {
                    self.dispatch(enc, "wr spatial", &self.pipelines[K_REUSE][0], g);
                }
            });
        }
        Self::span(&mut timer, encoder, "shade", |enc| {
            self.dispatch(
                enc,
                "wr shade",
                &self.pipelines[K_SHADE][0],
                &self.shade_group,
            )
        });
        self.renderer
            .encode_shade_direct(encoder, timer.as_deref_mut());
        if self.config.temporal {
            Self::span(&mut timer, encoder, "persist", |enc| {
                enc.copy_buffer_to_buffer(
                    &self.reservoirs[self.final_index],
                    0,
                    &self.prev_reservoirs,
                    0,
                    None,
                );
                enc.copy_buffer_to_buffer(
                    &self.renderer.buffers.secondary,
                    0,
                    &self.prev_vertices,
                    0,
                    None,
                );
            });
        }
        self.renderer.encode_accumulate(encoder, timer);
        self.parity = 1 - p;
        Ok(())
    }

    /// Renders `frames` frames, one submission each, moving the camera along `path` (frame
    /// numbers continue from the frames already rendered). Returns the per-pass GPU times when
    /// the adapter has timestamps.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        frames: u32,
        path: Option<(&CameraPath, &Camera)>,
        mut progress: impl FnMut(u32),
    ) -> Result<Option<PassTimes>, WorldRestirError> {
        let mut timer = GpuTimer::new(ctx, 16);
        let mut times = timer.is_available().then(PassTimes::default);
        for f in 0..frames {
            if let Some((path, base)) = path {
                let cam = path.camera(base, self.renderer.frames());
                self.set_camera(&ctx.queue, &cam)?;
            }
            timer.reset();
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("world-restir frame"),
                });
            self.encode_frame(&ctx.queue, &mut encoder, Some(&mut timer))?;
            timer.resolve(&mut encoder);
            ctx.queue.submit([encoder.finish()]);
            if let Some(t) = times.as_mut() {
                add_times(t, &timer.read(ctx)?);
            } else {
                ctx.wait()?;
            }
            progress(f + 1);
        }
        Ok(times)
    }

    /// Clears the accumulation, the frame counter and the temporal history (last grid and
    /// reservoirs): the next frames repeat the first ones for the same seed and camera.
    pub fn reset(&mut self, ctx: &GpuContext) {
        self.renderer.reset(ctx);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        for t in &self.tables {
            t.encode_clear(&mut encoder);
        }
        encoder.clear_buffer(&self.prev_reservoirs, 0, None);
        ctx.queue.submit([encoder.finish()]);
        self.parity = 0;
    }

    /// The accumulated images.
    pub fn images(&self, ctx: &GpuContext) -> Result<FrameImages, GpuError> {
        read_accumulated(ctx, &self.renderer)
    }

    /// The last frame's images.
    pub fn last_frame(&self, ctx: &GpuContext) -> Result<FrameImages, GpuError> {
        read_last_frame(ctx, &self.renderer)
    }

    /// Statistics of the last built grid (overflows = vertices left out of it).
    pub fn grid_stats(&self, ctx: &GpuContext) -> Result<HashStats, GpuError> {
        let t = &self.tables[1 - self.parity];
        let v: Vec<HashStats> = buffers::read(ctx, t.stats())?;
        Ok(v[0])
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs(&self, ctx: &GpuContext) -> Result<Vec<WrReservoir>, GpuError> {
        let mut v: Vec<WrReservoir> = buffers::read(ctx, &self.reservoirs[self.final_index])?;
        v.truncate(self.renderer.pixels() as usize);
        Ok(v)
    }

    /// The last built grid, read back: per vertex (slot, index in slot) (slot >= 0xffff_fff0:
    /// not in the grid), per slot counts and exclusive offsets, and the compact cell storage.
    pub fn grid(&self, ctx: &GpuContext) -> Result<GridReadback, GpuError> {
        let p = 1 - self.parity;
        let n = self.renderer.pixels() as usize;
        let mut vertex_slot: Vec<[u32; 2]> = buffers::read(ctx, &self.vertex_slot)?;
        vertex_slot.truncate(n);
        let mut cells: Vec<u32> = buffers::read(ctx, &self.cells[p])?;
        cells.truncate(n);
        Ok(GridReadback {
            vertex_slot,
            counters: buffers::read(ctx, self.tables[p].counters())?,
            offsets: buffers::read(ctx, &self.offsets[p])?,
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
            &self.params,
            std::mem::offset_of!(WrParams, debug_view) as u64,
            bytemuck::bytes_of(&(view as u32)),
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        self.dispatch(
            &mut encoder,
            "wr debug",
            &self.pipelines[K_DEBUG][0],
            &self.debug_group,
        );
        ctx.queue.submit([encoder.finish()]);
        read_rgb(ctx, &self.debug, self.renderer.pixels() as usize, 1.0)
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

    #[test]
    fn orbit_keeps_the_distance_to_the_target() {
        let base = Camera {
            eye: Vec3::new(0.0, 1.0, -5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 40.0,
            width: 8,
            height: 8,
        };
        let path = CameraPath::Orbit {
            frames: 10,
            degrees: 90.0,
        };
        for f in 0..10 {
            let c = path.camera(&base, f);
            assert!(((c.eye - c.target).length() - (base.eye - base.target).length()).abs() < 1e-4);
        }
    }
}
