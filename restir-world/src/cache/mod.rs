//! A world-space radiance cache on `gpu-hash` (after NVIDIA's SHaRC and Bevy Solari's world
//! cache): paths end in it after a few bounces, so a frame pays for the first bounces and gets
//! every further one from the cache.
//!
//! The cells are gpu-hash's (the same adaptive cell size as world-restir's grid, distance-scaled
//! from the eye), with the normal's axis folded into the key, in one table that lives across
//! frames (never cleared). A cell holds the radiance a white diffuse surface there reflects
//! (direct and indirect light: the cache is demodulated by albedo, so textures stay sharp):
//! the fixed-point sums of its samples, their count and its age, 16 bytes, plus gpu-hash's
//! checksum and slot counter: [`BYTES_PER_CELL`].
//!
//! Per frame, each step its own pass and GPU timestamp span:
//!
//! | span | pass | what |
//! |---|---|---|
//! | `cache-update` | `cache_update`, `cache_accumulate` | `update-fraction` of the pixels (one drawn per stratum) trace `update-depth` vertices from their secondary vertex (where a diffuse bounce lands, as the vertices that read the cache), then on unbounded; each vertex's reflected radiance (light estimate + what the path beyond it brings) is one sample of its cell (find-or-insert now; added to the cell's atomic fixed-point sums by the next pass, so that no update reads half-added sums) |
//! | `cache-resolve` | `cache_resolve` | per bucket: the frame's samples join the history (at most `history` samples, the sums scaled down beyond), cells without a sample age and go after `evict-after` frames, the kept ones move to the front of the bucket |
//! | `path` | `cache_path` | the renderer's path (render/path.wgsl); from bounce `after` on, a vertex whose cell has samples ends it with albedo x the cell's mean |
//!
//! The update paths feed on the cache at their last vertex, so the cached radiance converges
//! to that of unbounded paths over frames. What it costs in bias: a cell's mean stands for
//! every point of the cell (and every incoming path), and it lags a moving light or camera by
//! its history.
//!
//! The table's size is fixed from the frame ([`CacheConfig::table`]); an insert into a full
//! bucket is counted (`overflows` in [`CacheStats`]) and that vertex's sample dropped.

use gpu_hash::{CellSizing, HashGridParams, HashStats, HashTable, TableConfig};

use crate::gpu::{
    Access, BindingSet, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule,
    buffers,
};
use crate::grid;
use crate::knobs::{Knobs, Variant};
use crate::render::{
    self, Buffer, ComposedKernel, DebugView, GVertex, KernelDef, MAX_BOUNCES, OwnKernel,
    RenderError, Renderer, STAGE_GROUP,
};
use crate::scene::{Camera, Scene};

/// Library WGSL (parameters, cells, keys, the path's hook).
pub const WGSL: &str = include_str!("cache.wgsl");
const PASSES_WGSL: &str = include_str!("passes.wgsl");

/// Most vertices of an update path (`update-depth`).
pub const MAX_UPDATE_DEPTH: u32 = 8;
/// Most samples a cell keeps (`history`).
pub const MAX_HISTORY: u32 = 512;
/// Most samples a cell takes in one frame (later ones are dropped).
pub const MAX_NEW: u32 = 256;
/// Fixed-point units per unit of radiance in a cell's sums.
pub const SCALE: f32 = 64.0;
/// A sample's channels are clamped to this (f16's largest): with [`MAX_HISTORY`] +
/// [`MAX_NEW`] samples in [`SCALE`] units the sums stay below 2^32.
pub const MAX_VALUE: f32 = 65504.0;
/// Most frames a cell may go without a sample (`evict-after`; the age has 16 bits).
pub const MAX_AGE: u32 = 1000;
/// Bytes of one cell: gpu-hash's checksum and slot counter (4 + 4) and the cell record (16).
pub const BYTES_PER_CELL: u32 = 24;

const _: () =
    assert!((MAX_HISTORY + MAX_NEW) as f64 * SCALE as f64 * MAX_VALUE as f64 <= u32::MAX as f64);

/// The unit of radiance the cache's cells hold for a scene whose brightest emission is
/// `brightest` ([`Scene::brightest_emission`]): 1, or the power of two that brings that
/// emission to at most 1/16 of [`MAX_VALUE`] (room for interreflection). A surface reflects at
/// most the brightest radiance it sees (more only by interreflection), so no cell is clipped;
/// a scale-free power of two leaves the image of a scene within range bit for bit as before.
/// (Cells in radiance units clipped a lamp of 1e10 at 65504: 37% dark against `ris`.)
pub fn radiance_unit(brightest: f32) -> f32 {
    let room = MAX_VALUE / 16.0;
    if !(brightest.is_finite() && brightest > room) {
        return 1.0;
    }
    2f32.powi((brightest / room).log2().ceil() as i32)
}

/// What a scene does to the cache that its image would not say. Its cells hold radiance in
/// steps of 1 / [`SCALE`] of their unit ([`radiance_unit`], finer values rounded at random,
/// exact in expectation): a scene bright enough for a unit above 1 rounds its dim light
/// coarsely (noisier, not darker). And an albedo of 1: the cache's paths are unbounded, so a
/// closed scene of such surfaces keeps all of its light at every bounce and its true radiance
/// is infinite (the cache's image grows with the frames).
pub fn scene_warnings(scene: &Scene) -> Vec<String> {
    let mut warnings = Vec::new();
    let max = scene.brightest_emission();
    let unit = radiance_unit(max);
    if unit > 1.0 {
        warnings.push(format!(
            "the scene emits radiance up to {max:e}: the radiance cache holds it in units of \
             {unit:e} (steps of 1/{SCALE} unit, rounded at random), so its cells are noisy where \
             the light is far dimmer than that"
        ));
    }
    if let Some(i) = scene
        .materials
        .iter()
        .position(|m| m.albedo.iter().any(|&a| a >= 1.0))
    {
        warnings.push(format!(
            "material {i} has albedo {:?}: with the cache's unbounded paths a closed scene of \
             such surfaces keeps all of its light at every bounce, so its radiance does not \
             converge (it grows with the frames); a method without the cache renders the \
             --bounces asked for",
            scene.materials[i].albedo
        ));
    }
    warnings
}

/// Errors of the radiance cache.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Hash(#[from] gpu_hash::HashError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad cache setting: {0}")]
    Config(String),
}

crate::knobs! {
    /// Every knob of the radiance cache with its default.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CacheConfig {
        /// Paths end in the cache from this bounce on (default 2: the path's third vertex
        /// reads the cache; the secondary vertex's light stays the method's). 2..=64.
        [gpu] after: u32 = 2, "after", 2..=MAX_BOUNCES;
        /// From bounce `after` on, a path ends in the cache only where its footprint (the
        /// spread of its diffuse bounces, Mueller et al. 2021) covers the cell (default on):
        /// a path arriving from close by goes on.
        [gpu] footprint: bool = true, "footprint";
        /// Share of the pixels that trace an update path each frame (default 0.04).
        [gpu] update_fraction: f32 = 0.04, "update-fraction", 0.0001..=1.0;
        /// Vertices an update path samples before it reads the cache (default 3).
        [gpu] update_depth: u32 = 3, "update-depth", 1..=MAX_UPDATE_DEPTH;
        /// Update paths end in the cache after `update-depth` vertices (SHaRC's feedback: the
        /// cache learns one more stretch of path each time its history turns over, biased low
        /// until then). Off (the default): they go on as the render's paths do, with Russian
        /// roulette, so every sample is unbiased from the first frame on.
        [gpu] feedback: bool = false, "feedback";
        /// Samples a cell keeps (default 256): more average more noise away and lag longer.
        [gpu] history: u32 = 256, "history", 1..=MAX_HISTORY;
        /// Frames without a sample after which a cell is evicted (default 32).
        [gpu] evict_after: u32 = 32, "evict-after", 1..=MAX_AGE;
        /// Cells (table slots). `auto` (the default): one per pixel ([`auto_cells`]).
        cells: Option<u32> = None, "cells", Some(64)..=Some(1 << 28);
        /// Slots per bucket (default 16).
        slots: u32 = 16, "slots", 1..=256;
        /// Smallest cell edge in world units (default 0.01).
        min_cell_size: f32 = 0.01, "min-cell-size", f32::MIN_POSITIVE..=f32::MAX;
        /// Targeted projected cell size in pixels (default 16, world-restir's).
        projected_size: f32 = 16.0, "projected-size", 0.01..=f32::MAX;
    }
}

/// The named variants of the cache (the knobs of a `+cache` method).
pub fn variants() -> Vec<Variant> {
    vec![
        Variant::new("default", &[], "paths end in the cache from bounce 2 on"),
        Variant::new(
            "after-3",
            &["after=3"],
            "paths end in the cache from bounce 3 on",
        ),
        Variant::new(
            "frequent",
            &["update-fraction=0.16"],
            "16% of the pixels update the cache each frame",
        ),
    ]
}

/// Cells of a table sized to a frame of `pixels`: one per pixel, at least 4096. Measured at
/// 256x256 (static camera, 18 frames): cornell used at most 1,835 cells, many-lights (a hall
/// of 10,000 lamps, each face a cell of its own) 31,065 of 65,536 with at most 5 inserts a
/// frame refused; it filled a table of one cell per 4 pixels.
pub fn auto_cells(pixels: u32) -> u32 {
    pixels.max(4096)
}

impl CacheConfig {
    /// The table's dimensions for frames of `pixels` (whole buckets, one probe bucket: the
    /// resolve pass compacts each bucket on its own).
    pub fn table(&self, pixels: u32) -> TableConfig {
        let cells = self.cells.unwrap_or_else(|| auto_cells(pixels));
        TableConfig {
            num_buckets: cells.div_ceil(self.slots.max(1)).max(1),
            slots_per_bucket: self.slots,
            probe_buckets: 1,
        }
    }

    /// The cell sizing for `camera`.
    pub fn sizing(&self, camera: &Camera) -> CellSizing {
        grid::cell_sizing(camera, self.min_cell_size, self.projected_size, true)
    }

    /// Update paths per frame of `pixels`: `update-fraction` of them, at least one.
    pub fn update_paths(&self, pixels: u32) -> u32 {
        ((f64::from(pixels) * f64::from(self.update_fraction)).ceil() as u32)
            .clamp(1, pixels.max(1))
    }

    /// Checks every knob.
    pub fn validate(&self) -> Result<(), CacheError> {
        self.check_ranges().map_err(CacheError::Config)?;
        self.table(1).validate()?;
        Ok(())
    }
}

/// WGSL `CacheParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CacheParams {
    /// [`CacheConfig::gpu_words`] (WGSL `CacheKnobs`).
    pub knobs: [u32; CacheConfig::GPU_WORDS],
    pub debug_view: u32,
    /// [`CacheConfig::update_paths`] of the frame.
    pub update_paths: u32,
    /// [`radiance_unit`] of the scene: cells hold radiance / unit.
    pub unit: f32,
    pub _pad2: u32,
}

/// One cell as read back: the mean of its samples (demodulated radiance), their count and the
/// frames since its last sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellValue {
    pub mean: [f32; 3],
    pub samples: u32,
    pub age: u32,
}

/// WGSL `CacheCell`, as stored.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CacheCell {
    /// The sums of the samples' channels in [`SCALE`] units.
    pub r: u32,
    pub g: u32,
    pub b: u32,
    /// Samples in the sums (low 16 bits) | frames since the last sample << 16.
    pub info: u32,
}

impl CacheCell {
    /// Its value, the mean in the cells' unit ([`radiance_unit`]; 1 in most scenes).
    pub fn value(&self) -> CellValue {
        let samples = self.info & 0xffff;
        let n = samples.max(1) as f32 * SCALE;
        CellValue {
            mean: [self.r, self.g, self.b].map(|s| s as f32 / n),
            samples,
            age: self.info >> 16,
        }
    }
}

/// The cache's size and use after the last frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CacheStats {
    /// Cells holding a surface after the resolve pass.
    pub cells_in_use: u32,
    /// Cells the table has room for.
    pub capacity: u32,
    pub bytes_per_cell: u32,
    /// Inserts of the last frame that found their bucket full (those samples were dropped).
    pub overflows: u32,
    /// Vertices or samples of the last frame left out for non-finite or out-of-range values.
    pub rejected: u32,
    /// Buckets with every slot in use.
    pub full_buckets: u32,
}

impl CacheStats {
    /// The table's memory in bytes.
    pub fn bytes(&self) -> u64 {
        u64::from(self.capacity) * u64::from(self.bytes_per_cell)
    }
}

/// Generated constants header and the knobs' struct.
pub fn constants_wgsl() -> String {
    format!(
        "const CACHE_MAX_UPDATE_DEPTH: u32 = {MAX_UPDATE_DEPTH}u;\n\
         const CACHE_MAX_NEW: u32 = {MAX_NEW}u;\nconst CACHE_SCALE: f32 = {SCALE:?};\n\
         const CACHE_MAX_VALUE: f32 = {MAX_VALUE:?};\n\
         const CACHE_MAX_BOUNCES: u32 = {MAX_BOUNCES}u;\n\
         const CACHE_VIEW_AGE: u32 = {}u;\nconst CACHE_VIEW_SAMPLES: u32 = {}u;\n{}",
        DebugView::CacheAge as u32,
        DebugView::CacheSamples as u32,
        CacheConfig::wgsl_struct("CacheKnobs")
    )
}

const OWN: &[Buffer] = &[
    ("cache_params", "CacheParams", Access::Uniform),
    ("cache_cells", "array<CacheCell>", Access::ReadWrite),
    ("cache_debug_image", "array<vec4<f32>>", Access::ReadWrite),
    (
        "cache_update_samples",
        "array<CacheSample>",
        Access::ReadWrite,
    ),
];
const KERNEL: KernelDef = KernelDef::new(
    "cache-passes",
    &[
        "cache_update",
        "cache_accumulate",
        "cache_resolve",
        "cache_path",
        "cache_debug",
    ],
    PASSES_WGSL,
    &[OWN],
);

/// Group 3: the cache's buffers, then gpu-hash's table role as the block `cache_hash`.
fn bindings() -> BindingSet {
    KERNEL
        .bindings()
        .block("cache_hash", gpu_hash::bind_group_layout_entries)
}

/// The kernel's modules, composed after the render library.
fn modules() -> Vec<WgslModule> {
    let at = gpu_hash::wgsl::BindAt {
        group: STAGE_GROUP,
        first_binding: OWN.len() as u32,
    };
    let mut m = vec![
        WgslModule::new("cache-constants", &[], constants_wgsl()),
        WgslModule::new("cache-bindings", &["cache"], bindings().wgsl(STAGE_GROUP)),
        WgslModule::new("gpu-hash", &[], gpu_hash::wgsl::compose(Some(at), None)),
        grid::cell_module(),
        WgslModule::new("cache", &["render", "grid", "cache-constants"], WGSL),
        WgslModule::new(
            render::PATH_CACHE,
            &["cache", "cache-bindings"],
            String::new(),
        ),
        WgslModule::new(
            KERNEL.name,
            &["cache", "cache-bindings", "render-path", "workgroup"],
            KERNEL.source,
        ),
    ];
    m.extend(render::path_modules(true, false));
    m
}

/// The cache's kernel, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    let source = render::compose_with_library(Tracer::Bvh, modules());
    vec![ComposedKernel::stage(
        "restir-world/cache".into(),
        source,
        bindings(),
    )]
}

#[derive(Debug)]
struct CachePasses {
    update: Pass,
    accumulate: Pass,
    resolve: Pass,
    path: Pass,
    debug: Pass,
}

/// The radiance cache of a renderer's frames: built on its shared groups, it updates before the
/// indirect passes and replaces the renderer's path pass with one that ends in the cache.
#[derive(Debug)]
pub struct RadianceCache {
    config: CacheConfig,
    pixels: u32,
    grid_params: HashGridParams,
    table: HashTable,
    params: wgpu::Buffer,
    cells: wgpu::Buffer,
    debug: wgpu::Buffer,
    passes: CachePasses,
    /// [`radiance_unit`] of the scene.
    unit: f32,
}

impl RadianceCache {
    /// Bytes of its buffers: the hash table and the cells.
    pub fn bytes(&self) -> u64 {
        let t = &self.table;
        [t.checksums(), t.counters(), t.stats(), t.params()]
            .into_iter()
            .chain([&self.params, &self.cells, &self.debug])
            .map(wgpu::Buffer::size)
            .sum()
    }

    /// The cache for `renderer`'s scene and image with `config`.
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: CacheConfig,
    ) -> Result<Self, CacheError> {
        config.validate()?;
        let (device, camera) = (&ctx.device, &renderer.gpu_camera());
        let pixels = renderer.pixels();
        let table_config = config.table(pixels);
        let slots = table_config.num_slots();
        let cell_bytes = slots * size_of::<CacheCell>() as u64;
        ctx.check_binding_size("the radiance cache's cells", cell_bytes)?;
        let grid_params = HashGridParams::new(&table_config, &config.sizing(camera), camera.eye)?;
        let table = HashTable::new(device, &ctx.queue, &grid_params)?;
        let unit = radiance_unit(renderer.brightest_emission());
        let params = CacheParams {
            knobs: config.gpu_words(),
            debug_view: 0,
            update_paths: config.update_paths(pixels),
            unit,
            _pad2: 0,
        };
        let params = buffers::with_usage(
            device,
            "cache params",
            &[params],
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let cells = buffers::storage_zeroed(device, "cache cells", cell_bytes);
        let debug = buffers::storage_zeroed(device, "cache debug", u64::from(pixels) * 16);
        let update_paths = config.update_paths(pixels);
        let sample_items = update_paths * MAX_UPDATE_DEPTH;
        let samples =
            buffers::storage_zeroed(device, "cache samples", u64::from(sample_items) * 16);
        let shared = &renderer.shared;
        let kernel: OwnKernel = shared.own_kernel(
            ctx,
            "radiance cache",
            &bindings(),
            modules(),
            KERNEL.entries,
        )?;
        let pass = |entry: &str, items: Option<u32>| {
            let hash = Resource::Block(table.bind_group_entries(OWN.len() as u32));
            let res = vec![
                ("cache_params", Resource::from(&params)),
                ("cache_cells", (&cells).into()),
                ("cache_debug_image", (&debug).into()),
                ("cache_update_samples", (&samples).into()),
                ("cache_hash", hash),
            ];
            shared.bound_pass(device, &kernel, entry, res, items)
        };
        let passes = CachePasses {
            update: pass("cache_update", Some(update_paths))?,
            accumulate: pass("cache_accumulate", Some(sample_items))?,
            resolve: pass("cache_resolve", Some(table_config.num_buckets))?,
            path: pass("cache_path", None)?,
            debug: pass("cache_debug", None)?,
        };
        Ok(Self {
            config,
            pixels,
            grid_params,
            table,
            params,
            cells,
            debug,
            passes,
            unit,
        })
    }

    pub fn config(&self) -> &CacheConfig {
        &self.config
    }

    /// Records the frame's update and resolve (after the renderer's primary pass: the update
    /// paths start at the primary vertices), with the cells sized from `renderer`'s eye.
    pub fn encode_update(
        &mut self,
        f: &mut FrameEncoder,
        renderer: &Renderer,
    ) -> Result<(), CacheError> {
        let grid = self.grid_params.with_eye(renderer.gpu_camera().eye)?;
        f.upload(self.table.params(), 0, &grid);
        f.raw().clear_buffer(self.table.stats(), 0, None);
        f.span("cache-update", |f| {
            f.dispatch(&self.passes.update);
            f.dispatch(&self.passes.accumulate);
        });
        f.span("cache-resolve", |f| f.dispatch(&self.passes.resolve));
        Ok(())
    }

    /// Records the renderer's path beyond the secondary vertex, ending in the cache (in place
    /// of [`Renderer::encode_path`]).
    pub fn encode_path(&self, f: &mut FrameEncoder) {
        f.span("path", |f| f.dispatch(&self.passes.path));
    }

    /// The table's size and use after the last frame.
    pub fn stats(&self, ctx: &GpuContext) -> Result<CacheStats, GpuError> {
        let s: Vec<HashStats> = buffers::read(ctx, self.table.stats())?;
        let s = s[0];
        Ok(CacheStats {
            cells_in_use: s.used_slots,
            capacity: self.table.config().num_slots() as u32,
            bytes_per_cell: BYTES_PER_CELL,
            overflows: s.overflows,
            rejected: s.rejected(),
            full_buckets: s.full_buckets,
        })
    }

    /// Every slot's checksum (0: empty) and cell, read back.
    pub fn read_cells(&self, ctx: &GpuContext) -> Result<Vec<(u32, CacheCell)>, GpuError> {
        let checksums: Vec<u32> = buffers::read(ctx, self.table.checksums())?;
        let cells: Vec<CacheCell> = buffers::read(ctx, &self.cells)?;
        Ok(checksums.into_iter().zip(cells).collect())
    }

    /// The cell a surface vertex at `position` with geometric normal `normal` falls in, seen
    /// from `eye` (twin of WGSL `cache_cell`): the grid's cell with the normal folded into the key; `None` where gpu-hash rejects it.
    pub fn cell_of(
        &self,
        eye: glam::Vec3,
        position: glam::Vec3,
        normal: glam::Vec3,
    ) -> Option<gpu_hash::HashCell> {
        let params = self.grid_params.with_eye(eye).ok()?;
        grid::cell_of(&params, position, normal, true)
    }

    /// The cell of `v` in `cells` (as [`RadianceCache::read_cells`] gives them), as the GPU's
    /// `cache_find` would find it seen from `eye`.
    pub fn find(
        &self,
        cells: &[(u32, CacheCell)],
        eye: glam::Vec3,
        v: &GVertex,
    ) -> Option<CellValue> {
        let c = self.cell_of(eye, v.position.into(), v.normal.into())?;
        let spb = self.table.config().slots_per_bucket as usize;
        let base = c.bucket as usize * spb;
        cells[base..base + spb]
            .iter()
            .take_while(|(checksum, _)| *checksum != 0)
            .find(|(checksum, _)| *checksum == c.checksum)
            .map(|(_, cell)| {
                let v = cell.value();
                CellValue {
                    mean: v.mean.map(|m| m * self.unit),
                    ..v
                }
            })
    }

    /// A debug view of the cells at the last frame's primary vertices: [`DebugView::CacheRadiance`]
    /// (x / (1 + x)), [`DebugView::CacheAge`] or [`DebugView::CacheSamples`] (heat maps); `None`
    /// for the views of other stages.
    pub fn debug_image(
        &self,
        ctx: &GpuContext,
        view: DebugView,
    ) -> Result<Option<Vec<[f32; 3]>>, GpuError> {
        if !view.is_cache_view() {
            return Ok(None);
        }
        ctx.queue.write_buffer(
            &self.params,
            std::mem::offset_of!(CacheParams, debug_view) as u64,
            bytemuck::bytes_of(&(view as u32)),
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        self.passes.debug.record(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        render::read_rgb(ctx, &self.debug, self.pixels, 1.0).map(Some)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn knobs_set_get_and_validate() {
        let d = CacheConfig::default();
        crate::knobs::assert_knob_table(
            d,
            |c: &_| c.validate(),
            &[("after", "3"), ("update-fraction", "0.5")],
            "after=3+update-fraction=0.5",
            &[
                ("after", "1"),
                ("after", "65"),
                ("update-fraction", "0"),
                ("update-fraction", "1.5"),
                ("update-depth", "9"),
                ("history", "0"),
                ("history", "513"),
                ("evict-after", "0"),
                ("cells", "10"),
                ("slots", "0"),
                ("min-cell-size", "-1"),
                ("projected-size", "NaN"),
            ],
        );
    }

    #[test]
    fn the_structs_are_the_wgsl_ones() {
        assert_eq!(size_of::<CacheCell>(), 16);
        assert_eq!(BYTES_PER_CELL as usize, size_of::<CacheCell>() + 8);
        assert!(constants_wgsl().contains("struct CacheKnobs {\n    after: u32,"));
        assert!(WGSL.contains("struct CacheCell {\n    r: atomic<u32>,"));
    }

    #[test]
    fn auto_cells_scale_with_the_frame() {
        assert_eq!(auto_cells(256 * 256), 65536);
        assert_eq!(auto_cells(16), 4096);
        let t = CacheConfig::default().table(256 * 256);
        assert_eq!((t.num_buckets, t.slots_per_bucket), (4096, 16));
    }
}
