//! Presampled light tiles (Wyman & Panteleev 2021): once per frame, `tiles` tiles of
//! `tile_size` light samples drawn by power from the light table; each 8x8 pixel block then
//! draws its RIS candidates from one tile picked at random per block and frame (coherent
//! memory, the same draws' distribution: a candidate's RIS weight stays p_hat / pdf).
//!
//! [`LightTiles`] fills them (span `light-tiles`); a kernel that draws from them binds
//! [`BINDING`] and composes [`reader_module`] (`light_tiles_first`, `light_tiles_ris`).
//! restir-di's initial candidates read them, and world-restir's generate pass too when a
//! method shares them.

use crate::gpu::{Access, GpuContext, Pass, WgslModule, buffers};
use crate::render::{ComposedKernel, KernelDef, RenderError, STAGE_GROUP, SharedGroups};

const FILL_WGSL: &str = include_str!("fill.wgsl");
const READ_WGSL: &str = include_str!("read.wgsl");

/// Bytes of one WGSL `LightSample` in an array (52 bytes of fields, 16-byte aligned).
pub const LIGHT_SAMPLE_BYTES: u64 = 64;

/// The binding a kernel that reads the tiles declares among its own buffers.
pub const BINDING: (&str, &str, Access) = ("light_tiles", "array<LightSample>", Access::Read);

/// WGSL `LightTilesParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightTilesParams {
    pub tiles: u32,
    pub tile_size: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

const FILL: KernelDef = KernelDef::new(
    "light-tiles",
    &["light_tiles_fill"],
    FILL_WGSL,
    &[&[
        ("light_tiles_params", "LightTilesParams", Access::Uniform),
        ("light_tiles", "array<LightSample>", Access::ReadWrite),
    ]],
);

/// The reader of the tiles (`light_tiles_first`, `light_tiles_ris`), for kernels that bind
/// [`BINDING`].
pub fn reader_module() -> WgslModule {
    WgslModule::new("light-tiles", &["render"], READ_WGSL)
}

fn fill_modules() -> Vec<WgslModule> {
    vec![
        WgslModule::new(
            "light-tiles-bindings",
            &["lights"],
            FILL.bindings().wgsl(STAGE_GROUP),
        ),
        WgslModule::new(
            "light-tiles-fill",
            &["render", "light-tiles-bindings", "workgroup"],
            FILL.source,
        ),
    ]
}

/// The fill kernel, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    let source = crate::render::compose_with_library(crate::gpu::Tracer::Bvh, fill_modules());
    let name = "restir-world/light_tiles/fill".to_owned();
    vec![ComposedKernel::stage(name, source, FILL.bindings())]
}

/// The tiles of a frame and their fill pass.
#[derive(Debug)]
pub struct LightTiles {
    tiles: u32,
    tile_size: u32,
    buffer: wgpu::Buffer,
    fill: Pass,
}

impl LightTiles {
    /// Bytes of its buffer.
    pub fn bytes(&self) -> u64 {
        self.buffer.size()
    }

    /// `tiles` tiles of `tile_size` samples for the renderer of `shared` (the caller checks
    /// the counts; the buffer is checked against the device's binding limit here).
    pub fn new(
        ctx: &GpuContext,
        shared: &SharedGroups,
        tiles: u32,
        tile_size: u32,
    ) -> Result<Self, RenderError> {
        let count = tiles.checked_mul(tile_size).ok_or_else(|| {
            RenderError::Settings(format!("{tiles} x {tile_size} light tile samples"))
        })?;
        let bytes = u64::from(count) * LIGHT_SAMPLE_BYTES;
        ctx.check_binding_size("the light tiles (lower tiles or tile-size)", bytes)?;
        let device = &ctx.device;
        let params = LightTilesParams {
            tiles,
            tile_size,
            ..Default::default()
        };
        let params = buffers::with_usage(
            device,
            "light tiles params",
            &[params],
            wgpu::BufferUsages::UNIFORM,
        );
        let buffer = buffers::storage_zeroed(device, "light tiles", bytes);
        let kernel = shared.own_kernel(
            ctx,
            "light tiles",
            &FILL.bindings(),
            fill_modules(),
            FILL.entries,
        )?;
        let resources = vec![
            ("light_tiles_params", (&params).into()),
            ("light_tiles", (&buffer).into()),
        ];
        let fill = shared.bound_pass(device, &kernel, FILL.entries[0], resources, Some(count))?;
        Ok(Self {
            tiles,
            tile_size,
            buffer,
            fill,
        })
    }

    /// Records this frame's fill (span `light-tiles`).
    pub fn encode(&self, f: &mut crate::gpu::FrameEncoder) {
        f.span("light-tiles", |f| f.dispatch(&self.fill));
    }

    /// The buffer to bind as [`BINDING`].
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// (tiles, samples per tile).
    pub fn dims(&self) -> (u32, u32) {
        (self.tiles, self.tile_size)
    }
}
