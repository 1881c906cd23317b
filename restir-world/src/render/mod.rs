//! The GPU renderer: the `nee` and `ris` baselines as small compute passes, progressively
//! accumulated, and the shared passes world-space ReSTIR builds on.
//!
//! Per frame (one sample per pixel), each step a [`Pass`] in its own timestamp span:
//!
//! 1. `primary`: camera rays with a uniform sub-pixel jitter (box filter) -> G-buffer
//!    (`render_gbuffer`, one [`GVertex`] per pixel).
//! 2. `gi`: one cosine-weighted ray from each primary hit -> secondary vertex
//!    (`render_secondary`).
//! 3. *(ReSTIR passes: read the G-buffer and secondary vertices; world-restir's shade writes
//!    step 5's first pass's outputs instead of it.)*
//! 4. `shade_direct`: emission seen at the primary + NEE there -> `render_direct_frame`
//!    (`restir_di::RestirDi` writes it instead in the `restir-di` methods).
//! 5. `shade_indirect`: NEE at the secondary vertex -> the radiance leaving it towards the
//!    primary (`render_path_radiance`) and primary albedo x that -> `render_indirect_frame`.
//!    `path` (with [`Paths::bounces`] > 1): the path goes on from the secondary vertex
//!    by cosine sampling, with NEE at every vertex, Russian roulette from
//!    [`Paths::roulette_from`]; it adds bounces 2.. to both, after whichever pass wrote
//!    bounce 1 (world-restir's shade included). The secondary vertex and the radiance leaving
//!    it are the pixel's *path sample* (WGSL `PathLight`), which ReSTIR GI resamples.
//! 6. `accumulate`: running sums of both frames; advances the GPU frame counter that seeds
//!    every pass.
//!
//! NEE is one light sample (power-proportional alias table over emissive triangles, the
//! environment and punctual lights: see [`crate::lights`]) with one shadow ray (to the light
//! point, or to infinity for the environment and directional lights); [`Estimator::Ris`] draws
//! K candidates, resamples one by RIS (target: luminance of the unshadowed contribution) and
//! traces one shadow ray. Outputs: `direct` = emission seen (the environment where a camera ray
//! escapes) + reflected direct light, `indirect` = indirect light of bounces 1..N ([`Paths`]; a GI ray that
//! escapes adds nothing: the environment it sees is direct light at the primary vertex,
//! estimated by NEE there), linear HDR. Emitters are two-sided. Shading uses the interpolated
//! vertex normals where a triangle has them ([`TriangleAttributes`], `GVertex::shading`): the
//! BRDF's cosine and the GI ray's cosine distribution; the geometric normal keeps the ray
//! offsets and the sidedness of lights (a light behind the geometric surface contributes
//! nothing; a GI direction below it ends the path). Scenes without vertex normals (the
//! built-in ones) take the flat path unchanged.
//!
//! A later pass composes [`library`] + its own kernel module and binds [`SharedGroups`]
//! (render buffers at group 0, the tracer's at 1, lights at 2) before its own groups. Rays are
//! traced by the context's [`crate::gpu::Tracer`]: the software CWBVH or the adapter's ray queries, behind
//! the same WGSL functions.

mod debug;
mod library;
mod records;
mod render_buffers;
mod stage;
mod streams;

pub use debug::{DebugView, heat, read_rgb};
pub use library::{
    ComposedKernel, PASSES_WGSL, PATH_CACHE, PATH_LIGHT, PATH_WGSL, WGSL, bindings,
    compose_with_library, constants_wgsl, kernels, library, passes_source, path_modules,
    shared_bindings,
};
pub use records::{
    ATTR_NORMALS, ATTR_TANGENT_FLIP, ATTR_TANGENTS, ATTR_UV, GVertex, RenderParams, RenderState,
    SHADING_FLAT, StoredReservoir, TEXTURE_LINEAR, TextureGpu, TriangleAttributes, oct_encode,
    pack_material, pack_tangent, ray_offset_floor, texture_tables, triangle_attributes,
};
pub(crate) use render_buffers::RenderBuffers;
pub use stage::{
    Buffer, KernelDef, OwnKernel, RESERVOIRS, REUSE_IO, ReusePass, STAGE_GROUP, SharedGroups,
    reuse_io,
};
pub use streams::{
    GRID_WORLD_RESTIR, GRID_WORLD_RESTIR_GI, STREAM_COUNT, SUB_STREAMS, Stream, SubStream,
};

use library::passes_module;

use crate::gpu::{FrameEncoder, GpuContext, GpuError, Pass, buffers};
pub use crate::images::{FrameImages, Readback};
use crate::lights::{self, GpuLights, Lights};
pub use crate::plant::Planted;
use crate::sampling::{CameraGpu, Estimator};
use crate::scene::{Camera, Material, Scene};
use crate::trace::{self, Bvh};

/// Default RIS candidate count (the paper's 16).
pub const DEFAULT_CANDIDATES: u32 = 16;

/// Most RIS candidates a method accepts: GPU drivers cap shader loop iterations (llvmpipe at
/// 65,535), so more would silently give the image of this many.
pub const MAX_CANDIDATES: u32 = crate::sampling::MAX_LOOP_ITERATIONS;

/// Checks a RIS candidate count: 1 ..= [`MAX_CANDIDATES`].
pub fn check_candidates(candidates: u32) -> Result<(), String> {
    if (1..=MAX_CANDIDATES).contains(&candidates) {
        Ok(())
    } else {
        Err(format!(
            "candidates {candidates} must be in 1..={MAX_CANDIDATES} (GPU drivers cap shader \
             loop iterations)"
        ))
    }
}
pub use crate::sampling::{
    DEFAULT_BOUNCES, DEFAULT_MIS, DEFAULT_ROULETTE_FROM, MAX_BOUNCES, Paths,
};

/// How a render runs, whatever the method: the seed of its random streams, the depth of its
/// indirect paths, and (tests' negative controls only) a defect its kernels carry out.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderOptions {
    pub seed: u32,
    pub paths: Paths,
    /// [`Planted::None`] but in tests' negative controls (see [`crate::plant`]): only with the
    /// crate's feature `planted-defects`, which the workspace's test harness enables and a
    /// library user has no reason to.
    #[cfg(feature = "planted-defects")]
    pub planted: Planted,
    /// The path pass records each pixel's path split (`render_path_split`: x2's own light, the
    /// rest, the radiance one vertex short and x3; 64 bytes a pixel), what world-restir-gi's
    /// sub-path reuse reads. Off: the buffer is one dummy record.
    pub path_split: bool,
    /// With `path_split`: a glossy secondary vertex x2 at this perceptual roughness (unorm16,
    /// as materials pack it) or rougher is sampled as a white diffuse surface (cosine ray, a
    /// light target without its BRDF) and its glossy record kept in the path split, what
    /// restir-gi's reconnection at a glossy x2 reads (its knob `x2-min-roughness`). None: no
    /// x2 is.
    pub glossy_x2: Option<u16>,
}

impl RenderOptions {
    /// `seed` and the default paths.
    pub fn seeded(seed: u32) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }

    /// The planted defect ([`Planted::None`] without the feature `planted-defects`).
    pub fn planted(&self) -> Planted {
        #[cfg(feature = "planted-defects")]
        return self.planted;
        #[cfg(not(feature = "planted-defects"))]
        Planted::None
    }
}

/// Relative ray-origin offset off surfaces (times max(1, |coordinate|)).
pub const RAY_EPS: f32 = 1e-4;
/// tmax of unbounded rays.
pub const T_MAX: f32 = 1e30;

/// [`Estimator::Ris`] with the default candidate count.
pub fn ris() -> Estimator {
    Estimator::Ris {
        candidates: DEFAULT_CANDIDATES,
    }
}

/// Errors of the renderer.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Trace(#[from] trace::TraceError),
    #[error(transparent)]
    Lights(#[from] lights::LightsError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("bad render setting: {0}")]
    Settings(String),
}

/// The renderer's passes.
#[derive(Debug)]
struct Passes {
    primary: Pass,
    gi: Pass,
    shade_direct: Pass,
    shade_indirect: Pass,
    path: Pass,
    accumulate: Pass,
}

impl Passes {
    fn new(device: &wgpu::Device, shared: &SharedGroups) -> Self {
        let entries = [
            "render_primary",
            "render_gi",
            "render_shade_direct",
            "render_shade_indirect",
            "render_path",
            "render_accumulate",
        ];
        let mut modules = vec![passes_module()];
        modules.extend(path_modules(false, false));
        let kernel = shared.kernel(device, "render passes", modules, None, &entries);
        let pass = |entry| shared.pass(device, &kernel, entry, None);
        Self {
            primary: pass(entries[0]),
            gi: pass(entries[1]),
            shade_direct: pass(entries[2]),
            shade_indirect: pass(entries[3]),
            path: pass(entries[4]),
            accumulate: pass(entries[5]),
        }
    }
}

/// The GPU renderer of one scene and camera.
#[derive(Debug)]
pub struct Renderer {
    /// The camera as given (the scene's units).
    camera: Camera,
    /// The power of two the scene and cameras are scaled by on the GPU ([`Scene::gpu_units`]).
    units: f32,
    /// [`Scene::brightest_emission`].
    brightest_emission: f32,
    /// Set by [`Renderer::set_camera`]: uploaded at the start of the next frame.
    camera_changed: bool,
    estimator: Estimator,
    options: RenderOptions,
    pub(crate) buffers: RenderBuffers,
    pub(crate) shared: SharedGroups,
    passes: Passes,
    /// Frames recorded since creation.
    frames: u32,
    /// Frames in the accumulation buffers (since the last restart).
    accumulated: u32,
}

impl Renderer {
    /// Builds the BVH and the light table, uploads them, and creates the passes. The scene
    /// should be sanitized ([`Scene::sanitize`]); `camera` gives the image size.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        estimator: Estimator,
        seed: u32,
    ) -> Result<Self, RenderError> {
        Self::with_options(ctx, scene, camera, estimator, &RenderOptions::seeded(seed))
    }

    /// [`Renderer::new`] with every option.
    pub fn with_options(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        estimator: Estimator,
        options: &RenderOptions,
    ) -> Result<Self, RenderError> {
        let candidates = match estimator {
            Estimator::Nee => 1,
            Estimator::Ris { candidates } => candidates,
        };
        check_candidates(candidates).map_err(RenderError::Settings)?;
        options
            .paths
            .check(candidates)
            .map_err(RenderError::Settings)?;
        let sets = shared_bindings(ctx.tracer);
        ctx.check_storage_buffers("render", &sets.each_ref())?;
        camera
            .validate()
            .map_err(|e| RenderError::Settings(e.to_string()))?;
        let pixels = camera
            .width
            .checked_mul(camera.height)
            .ok_or_else(|| RenderError::Settings("image too large".into()))?;
        let px = u64::from(pixels);
        ctx.check_pixel_binding("the G-buffer", px, size_of::<GVertex>() as u64)?;
        if options.path_split {
            ctx.check_pixel_binding("the path split", px, render_buffers::PATH_SPLIT_BYTES)?;
        }
        let units = scene.gpu_units();
        let scaled;
        let scene = if units == 1.0 {
            scene
        } else {
            scaled = scene.scaled(units);
            &scaled
        };
        let gpu_bvh = Bvh::build(scene)?.upload(ctx)?;
        let gpu_lights = GpuLights::new(&ctx.device, &Lights::build(scene))?;
        let attributes = triangle_attributes(scene);
        if let Some(a) = &attributes {
            let bytes = (a.len() * size_of::<TriangleAttributes>()) as u64;
            ctx.check_binding_size("the triangle attributes", bytes)?;
        }
        let textures = texture_tables(scene);
        let texel_bytes = (textures.1.len() * 4) as u64;
        ctx.check_binding_size("the scene's textures (resize them)", texel_bytes)?;
        let mut params = RenderParams::new(&camera.scaled(units), estimator, options);
        params.ray_offset_floor = ray_offset_floor(scene);
        params.attributes = u32::from(attributes.is_some());
        let normal_maps = attributes
            .as_ref()
            .is_some_and(|a| a.iter().any(|a| a.flags & ATTR_TANGENTS != 0));
        let no_material = [Material::new([0.0; 3], [0.0; 3])];
        let materials = match scene.materials.is_empty() {
            true => &no_material[..],
            false => &scene.materials,
        };
        let dummy = [bytemuck::Zeroable::zeroed()];
        let attributes = attributes.as_deref().unwrap_or(&dummy);
        let glossy = scene.glossy_materials() > 0;
        let brdf_tables = match glossy {
            true => crate::brdf::tables().as_f32(),
            false => &[0.0][..],
        };
        let buffers = RenderBuffers::new(
            &ctx.device,
            &params,
            materials,
            attributes,
            &textures,
            brdf_tables,
        );
        let layouts = sets.map(|s| s.layout(&ctx.device));
        let groups = [
            layouts[0].bind(&ctx.device, buffers.resources())?,
            layouts[1].bind(&ctx.device, gpu_bvh.resources())?,
            layouts[2].bind(&ctx.device, gpu_lights.resources())?,
        ];
        let shared = SharedGroups {
            layouts,
            groups,
            tracer: ctx.tracer,
            pixels,
            kernels: ctx.kernels.clone(),
            glossy,
            normal_maps,
            planted: options.planted() != Planted::None,
        };
        let passes = Passes::new(&ctx.device, &shared);
        Ok(Self {
            camera: *camera,
            units,
            brightest_emission: scene.brightest_emission(),
            camera_changed: false,
            estimator,
            options: *options,
            buffers,
            shared,
            passes,
            frames: 0,
            accumulated: 0,
        })
    }

    /// The largest radiance the scene emits ([`Scene::brightest_emission`]).
    pub fn brightest_emission(&self) -> f32 {
        self.brightest_emission
    }

    /// The camera of the next frame, in the scene's units.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The camera of the next frame in the GPU's units (the scene's times [`Renderer::units`]),
    /// which the stages' positions are in.
    pub fn gpu_camera(&self) -> Camera {
        self.camera.scaled(self.units)
    }

    /// The power of two the scene is scaled by on the GPU: 1 unless its extent is below
    /// [`crate::scene::SMALLEST_GPU_EXTENT`] ([`Scene::gpu_units`]). Knobs in world units
    /// (the grids' `min-cell-size`) are in the GPU's units.
    pub fn units(&self) -> f32 {
        self.units
    }

    /// The light estimator at both vertices.
    pub fn estimator(&self) -> Estimator {
        self.estimator
    }

    /// Moves the camera from the next recorded frame on (same image size; the accumulation is
    /// not reset). Used by camera animations.
    pub fn set_camera(&mut self, camera: &Camera) -> Result<(), RenderError> {
        camera
            .validate()
            .map_err(|e| RenderError::Settings(e.to_string()))?;
        if (camera.width, camera.height) != (self.camera.width, self.camera.height) {
            return Err(RenderError::Settings(
                "set_camera cannot change the image size".into(),
            ));
        }
        self.camera = *camera;
        self.camera_changed = true;
        Ok(())
    }

    /// Bytes of its per-pixel buffers (the scene's excluded).
    pub fn bytes(&self) -> u64 {
        self.buffers.pixel_bytes()
    }

    /// Pixels per frame.
    pub fn pixels(&self) -> u32 {
        self.shared.pixels
    }

    /// Frames recorded since creation.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Frames in the accumulation (since creation or the last restart).
    pub fn accumulated(&self) -> u32 {
        self.accumulated
    }

    /// Steps 1-2: the frame's camera, primary rays -> G-buffer, GI rays -> secondary vertices.
    pub fn encode_primary_and_gi(&mut self, f: &mut FrameEncoder) {
        if std::mem::take(&mut self.camera_changed) {
            // The camera is the first field of RenderParams.
            f.upload(&self.buffers.params, 0, &CameraGpu::new(&self.gpu_camera()));
        }
        f.span("primary", |f| f.dispatch(&self.passes.primary));
        f.span("gi", |f| f.dispatch(&self.passes.gi));
    }

    /// Step 4: direct light at the primary vertex -> `render_direct_frame`.
    pub fn encode_shade_direct(&self, f: &mut FrameEncoder) {
        f.span("shade_direct", |f| f.dispatch(&self.passes.shade_direct));
    }

    /// Step 5: NEE at the secondary vertex -> `render_path_radiance`, and primary albedo x
    /// that -> `render_indirect_frame`.
    pub fn encode_shade_indirect(&self, f: &mut FrameEncoder) {
        f.span("shade_indirect", |f| {
            f.dispatch(&self.passes.shade_indirect)
        });
    }

    /// Step 5b: bounces 2..=bounces of the path beyond the secondary vertex, added to
    /// `render_path_radiance` and `render_indirect_frame` (nothing with one bounce and no MIS).
    pub fn encode_path(&self, f: &mut FrameEncoder) {
        if self.options.paths.beyond_secondary() {
            f.span("path", |f| f.dispatch(&self.passes.path));
        }
    }

    /// How the renderer runs (seed, bounces).
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }

    /// Step 6: adds the frame to the running sums and advances the frame counter.
    pub fn encode_accumulate(&mut self, f: &mut FrameEncoder) {
        f.span("accumulate", |f| f.dispatch(&self.passes.accumulate));
        self.frames += 1;
        self.accumulated += 1;
    }

    /// One whole baseline frame (steps 1-6).
    pub fn encode_frame(&mut self, f: &mut FrameEncoder) {
        self.encode_primary_and_gi(f);
        self.encode_shade_direct(f);
        self.encode_shade_indirect(f);
        self.encode_path(f);
        self.encode_accumulate(f);
    }

    /// The last frame's primary vertices (G-buffer), per pixel.
    pub fn read_gbuffer(&self, ctx: &GpuContext) -> Result<Vec<GVertex>, GpuError> {
        let mut v: Vec<GVertex> = buffers::read(ctx, &self.buffers.gbuffer)?;
        v.truncate(self.pixels() as usize);
        Ok(v)
    }

    /// The last frame's secondary vertices (where each pixel's GI ray landed), per pixel.
    pub fn read_secondary(&self, ctx: &GpuContext) -> Result<Vec<GVertex>, GpuError> {
        let mut v: Vec<GVertex> = buffers::read(ctx, &self.buffers.secondary)?;
        v.truncate(self.pixels() as usize);
        Ok(v)
    }

    /// Clears the running sums (the frame counter, which seeds the passes, runs on).
    pub fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        f.raw().clear_buffer(&self.buffers.accum_direct, 0, None);
        f.raw().clear_buffer(&self.buffers.accum_indirect, 0, None);
        self.accumulated = 0;
    }

    /// Reads the images back: the mean of the frames accumulated since creation or the last
    /// restart, or the last frame alone.
    pub fn read(&self, ctx: &GpuContext, which: Readback) -> Result<FrameImages, GpuError> {
        let b = &self.buffers;
        let (sums, frames, scale) = match which {
            Readback::Accumulated => {
                let n = self.accumulated;
                let scale = if n == 0 { 0.0 } else { 1.0 / n as f32 };
                ([&b.accum_direct, &b.accum_indirect], n, scale)
            }
            Readback::LastFrame => ([&b.direct_frame, &b.indirect_frame], 1, 1.0),
        };
        Ok(FrameImages {
            width: self.camera.width,
            height: self.camera.height,
            frames,
            direct: read_rgb(ctx, sums[0], self.pixels(), scale)?,
            indirect: read_rgb(ctx, sums[1], self.pixels(), scale)?,
        })
    }
}
