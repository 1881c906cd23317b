//! The GPU renderer: the `nee` and `ris` baselines as small compute passes, progressively
//! accumulated. World-space ReSTIR (a later issue) plugs in between the GI ray and the shading.
//!
//! Per frame (one sample per pixel), each step its own compute pass and GPU timestamp span:
//!
//! 1. `primary`: camera rays with a uniform sub-pixel jitter (box filter) -> G-buffer
//!    ([`RenderBuffers::gbuffer`], one [`GVertex`] per pixel).
//! 2. `gi`: one cosine-weighted ray from each primary hit -> secondary vertex
//!    ([`RenderBuffers::secondary`]).
//! 3. *(ReSTIR passes: read `gbuffer`/`secondary`, write `indirect_frame` instead of step 5.)*
//! 4. `shade_direct`: emission seen at the primary + NEE there -> `direct_frame`.
//! 5. `shade_indirect`: primary albedo x NEE at the secondary vertex -> `indirect_frame`.
//! 6. `accumulate`: running sums of `direct_frame` and `indirect_frame`; advances the GPU frame
//!    counter that seeds every pass.
//!
//! NEE is one light sample (power-proportional alias table, uniform on the triangle) with one
//! shadow ray; [`Method::Ris`] draws K candidates, resamples one by RIS (target: luminance of
//! the unshadowed contribution) and traces one shadow ray. Outputs: `direct` =
//! emission seen + reflected direct light, `indirect` = one-bounce indirect light, `combined` =
//! their sum; linear HDR ([`Rendered`], as the CPU reference returns them). Emitters are two-sided; shading uses the geometric normal.
//!
//! WGSL: [`bindings_wgsl`] declares every render buffer at fixed `render_*` names, so a later
//! pass composes `render::library(..)` + its own kernel and binds [`Renderer::bind_group`]
//! (group 0), the BVH (group 1) and the lights (group 2) from [`Renderer::scene_bind_groups`].

use crate::gpu::buffers;
use crate::image_io::Image;
use crate::lights::{self, GpuLights, Lights};
use crate::reference::Rendered;
use crate::sampling::CameraGpu;
use crate::scene::{Camera, Material, Scene};
use crate::trace::{self, Bvh, GpuBvh, dispatch_2d};
use crate::{GpuContext, GpuError, GpuTimer};

pub mod methods;

pub use methods::{FrameMethod, MethodEntry, MethodError, build_method, registry};

/// The renderer's library (structs + functions).
pub const WGSL: &str = include_str!("render.wgsl");
/// The pass kernels.
pub const PASSES_WGSL: &str = include_str!("passes.wgsl");

/// Workgroup size of every render pass.
pub const WORKGROUP_SIZE: u32 = 64;
/// Default RIS candidate count (the paper's 16).
pub const DEFAULT_CANDIDATES: u32 = 16;

/// Most RIS candidates a method accepts: GPU drivers cap shader loop iterations (llvmpipe at
/// 65,535), so more would silently give the image of this many.
pub const MAX_CANDIDATES: u32 = 65_535;

/// Storage buffers in a set of bind group layouts (one pipeline's).
pub fn count_storage_buffers(entries: &[wgpu::BindGroupLayoutEntry]) -> u32 {
    entries
        .iter()
        .filter(|e| {
            matches!(
                e.ty,
                wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { .. },
                    ..
                }
            )
        })
        .map(|e| e.count.map_or(1, std::num::NonZeroU32::get))
        .sum()
}

/// Checks that a pipeline declaring `needed` storage buffers fits the device's
/// `max_storage_buffers_per_shader_stage`.
pub fn check_storage_buffers(
    ctx: &GpuContext,
    pipeline: &str,
    needed: u32,
) -> Result<(), RenderError> {
    let limit = ctx.limits().max_storage_buffers_per_shader_stage;
    if needed > limit {
        return Err(RenderError::TooManyStorageBuffers {
            pipeline: pipeline.to_owned(),
            needed,
            limit,
            backend: format!("{:?}", ctx.info.backend),
            adapter: ctx.info.name.clone(),
        });
    }
    Ok(())
}

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
/// Relative ray-origin offset off surfaces (times max(1, |coordinate|)).
pub const RAY_EPS: f32 = 1e-4;
/// tmax of unbounded rays.
pub const T_MAX: f32 = 1e30;

/// Pass ids mixed into the random seeds (each pass draws its own stream).
const PASS_PRIMARY: u32 = 0;
const PASS_GI: u32 = 1;
const PASS_DIRECT: u32 = 2;
const PASS_INDIRECT: u32 = 3;
/// Room for later passes (ReSTIR) to take ids 4..16.
pub const PASS_COUNT: u32 = 16;

const METHOD_NEE: u32 = 0;
const METHOD_RIS: u32 = 1;

/// Light sampling at both vertices: the CPU reference's estimator type, shared.
pub use crate::reference::Method;

/// [`Method::Ris`] with the default candidate count.
pub fn ris() -> Method {
    Method::Ris {
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
    #[error("the image needs {bytes} bytes per buffer, above the adapter's limit of {limit}")]
    TooLarge { bytes: u64, limit: u64 },
    #[error(
        "the {pipeline} pipeline needs {needed} storage buffers per shader stage; the {backend} \
         backend (adapter {adapter:?}) allows {limit} (max_storage_buffers_per_shader_stage). \
         Use a backend that allows more, e.g. WGPU_BACKEND=vulkan"
    )]
    TooManyStorageBuffers {
        pipeline: String,
        needed: u32,
        limit: u32,
        backend: String,
        adapter: String,
    },
}

/// WGSL `GVertex`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GVertex {
    pub position: [f32; 3],
    pub prim: u32,
    pub normal: [f32; 3],
    pub _pad0: u32,
    pub albedo: [f32; 3],
    pub _pad1: u32,
    pub emission: [f32; 3],
    pub _pad2: u32,
}

/// WGSL `RenderParams`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RenderParams {
    pub camera: CameraGpu,
    pub pixel_count: u32,
    pub seed: u32,
    pub method: u32,
    pub candidates: u32,
    /// Smallest scale ray offsets are relative to: [`ray_offset_floor`] of the scene.
    pub ray_offset_floor: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// The floor of the ray-offset scale for `scene`: its extent (largest side of its bounding
/// box), capped at 1. Offsets are `RAY_EPS` times the larger of this and the point's largest
/// coordinate, so scenes of extent 1 and more keep absolute 1e-4 offsets near the origin while a
/// scene in small units (a box of 1e-5) keeps the same relative ones instead of offsetting rays
/// past its walls.
pub fn ray_offset_floor(scene: &Scene) -> f32 {
    let extent = scene
        .bounds()
        .map_or(1.0, |(lo, hi)| (hi - lo).max_element());
    if extent.is_finite() && extent > 0.0 {
        extent.min(1.0)
    } else {
        1.0
    }
}

/// WGSL `RenderState`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RenderState {
    pub frame: u32,
    pub _pad: [u32; 3],
}

/// Constants header of the render WGSL.
pub fn constants_wgsl() -> String {
    format!(
        "const RENDER_METHOD_NEE: u32 = {METHOD_NEE}u;\nconst RENDER_METHOD_RIS: u32 = {METHOD_RIS}u;\n\
         const RENDER_PASS_PRIMARY: u32 = {PASS_PRIMARY}u;\nconst RENDER_PASS_GI: u32 = {PASS_GI}u;\n\
         const RENDER_PASS_DIRECT: u32 = {PASS_DIRECT}u;\nconst RENDER_PASS_INDIRECT: u32 = {PASS_INDIRECT}u;\n\
         const RENDER_PASS_COUNT: u32 = {PASS_COUNT}u;\nconst RENDER_RAY_EPS: f32 = {RAY_EPS:e};\n\
         const RENDER_T_MAX: f32 = {T_MAX:e};\n"
    )
}

/// `(binding, name, WGSL type, access)` of the render buffers in their group.
const BINDINGS: [(u32, &str, &str, &str); 9] = [
    (0, "render_params", "RenderParams", "uniform"),
    (1, "render_state", "RenderState", "storage, read_write"),
    (2, "render_gbuffer", "array<GVertex>", "storage, read_write"),
    (
        3,
        "render_secondary",
        "array<GVertex>",
        "storage, read_write",
    ),
    (
        4,
        "render_direct_frame",
        "array<vec4<f32>>",
        "storage, read_write",
    ),
    (
        5,
        "render_indirect_frame",
        "array<vec4<f32>>",
        "storage, read_write",
    ),
    (
        6,
        "render_accum_direct",
        "array<vec4<f32>>",
        "storage, read_write",
    ),
    (
        7,
        "render_accum_indirect",
        "array<vec4<f32>>",
        "storage, read_write",
    ),
    (8, "render_materials", "array<Material>", "storage, read"),
];

/// Declares the render buffers (`render_params`, `render_state`, `render_gbuffer`,
/// `render_secondary`, `render_direct_frame`, `render_indirect_frame`, `render_accum_direct`,
/// `render_accum_indirect`, `render_materials`) at bindings 0..9 of `group`.
pub fn bindings_wgsl(group: u32) -> String {
    BINDINGS
        .iter()
        .map(|(b, name, ty, access)| {
            format!("@group({group}) @binding({b}) var<{access}> {name}: {ty};\n")
        })
        .collect()
}

/// Layout entries matching [`bindings_wgsl`].
pub fn bind_group_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    BINDINGS
        .iter()
        .map(|(b, _, _, access)| {
            crate::gpu::buffers::layout_entry(
                *b,
                if *access == "uniform" {
                    wgpu::BufferBindingType::Uniform
                } else {
                    wgpu::BufferBindingType::Storage {
                        read_only: *access == "storage, read",
                    }
                },
            )
        })
        .collect()
}

/// Everything a render pass composes before its own kernel: constants, the render buffers
/// (group 0), the BVH (group 1), the lights (group 2) and the libraries (rng, sampling,
/// lights, trace, render).
pub fn library() -> String {
    [
        trace::constants_wgsl(),
        constants_wgsl(),
        bindings_wgsl(0),
        trace::bindings_wgsl(1, 0),
        reservoir::rng::WGSL.to_string(),
        reservoir::wgsl(),
        lights::composed_wgsl(2, 0),
        trace::WGSL.to_string(),
        WGSL.to_string(),
    ]
    .join("\n")
}

/// The composed pass module.
pub fn passes_source() -> String {
    format!("{}\n{}", library(), PASSES_WGSL)
}

/// WGSL modules of the renderer, composed as used.
pub fn wgsl_modules() -> Vec<(String, String)> {
    vec![("restir-world/render".into(), passes_source())]
}

/// The render buffers (per pixel unless noted), exposed for passes inserted between the GI
/// ray and the shading.
#[derive(Debug)]
pub struct RenderBuffers {
    pub params: wgpu::Buffer,
    pub state: wgpu::Buffer,
    pub gbuffer: wgpu::Buffer,
    pub secondary: wgpu::Buffer,
    pub direct_frame: wgpu::Buffer,
    pub indirect_frame: wgpu::Buffer,
    pub accum_direct: wgpu::Buffer,
    pub accum_indirect: wgpu::Buffer,
    /// Per material.
    pub materials: wgpu::Buffer,
}

/// Total GPU milliseconds per pass over the frames rendered so far.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PassTimes {
    pub frames: u32,
    pub passes: Vec<(String, f64)>,
}

impl PassTimes {
    fn add(&mut self, times: &crate::gpu::SpanTimes) {
        for (name, ms) in &times.0 {
            match self.passes.iter_mut().find(|(n, _)| n == name) {
                Some((_, total)) => *total += ms,
                None => self.passes.push((name.clone(), *ms)),
            }
        }
    }
    /// Total over all passes and frames.
    pub fn total_ms(&self) -> f64 {
        self.passes.iter().map(|(_, ms)| ms).sum()
    }
    /// Mean milliseconds per frame of each pass.
    pub fn per_frame(&self) -> Vec<(String, f64)> {
        let f = f64::from(self.frames.max(1));
        self.passes
            .iter()
            .map(|(n, ms)| (n.clone(), ms / f))
            .collect()
    }
}

/// The GPU renderer of one scene and camera.
#[derive(Debug)]
pub struct Renderer {
    pub camera: Camera,
    pub method: Method,
    pub bvh: Bvh,
    pub gpu_bvh: GpuBvh,
    pub gpu_lights: GpuLights,
    pub buffers: RenderBuffers,
    render_group: wgpu::BindGroup,
    bvh_group: wgpu::BindGroup,
    lights_group: wgpu::BindGroup,
    layouts: [wgpu::BindGroupLayout; 3],
    primary: wgpu::ComputePipeline,
    gi: wgpu::ComputePipeline,
    shade_direct: wgpu::ComputePipeline,
    shade_indirect: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    pixels: u32,
    frames: u32,
    max_groups_per_dim: u32,
}

impl Renderer {
    /// Builds the BVH and the light table, uploads them, and creates the passes. The scene
    /// should be sanitized ([`Scene::sanitize`]); `camera` gives the image size.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        method: Method,
        seed: u32,
    ) -> Result<Self, RenderError> {
        if let Method::Ris { candidates } = method {
            check_candidates(candidates).map_err(RenderError::Settings)?;
        }
        let mut entries = bind_group_layout_entries();
        entries.extend(trace::bind_group_layout_entries(0));
        entries.extend(lights::bind_group_layout_entries(0));
        check_storage_buffers(ctx, "render", count_storage_buffers(&entries))?;
        camera
            .validate()
            .map_err(|e| RenderError::Settings(e.to_string()))?;
        let pixels = camera
            .width
            .checked_mul(camera.height)
            .ok_or_else(|| RenderError::Settings("image too large".into()))?;
        let limits = ctx.limits();
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let gbytes = u64::from(pixels) * size_of::<GVertex>() as u64;
        if gbytes > limit {
            return Err(RenderError::TooLarge {
                bytes: gbytes,
                limit,
            });
        }
        let bvh = Bvh::build(scene)?;
        let gpu_bvh = bvh.upload(ctx)?;
        let gpu_lights = GpuLights::new(&ctx.device, &Lights::build(scene))?;
        let device = &ctx.device;

        let params = RenderParams {
            camera: CameraGpu::new(camera),
            pixel_count: pixels,
            seed,
            method: match method {
                Method::Nee => METHOD_NEE,
                Method::Ris { .. } => METHOD_RIS,
            },
            candidates: match method {
                Method::Nee => 1,
                Method::Ris { candidates } => candidates,
            },
            ray_offset_floor: ray_offset_floor(scene),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let materials: &[Material] = if scene.materials.is_empty() {
            &[Material::new([0.0; 3], [0.0; 3])]
        } else {
            &scene.materials
        };
        let px = u64::from(pixels);
        let buffers = RenderBuffers {
            params: buffers::with_usage(
                device,
                "render_params",
                &[params],
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            state: buffers::storage_zeroed(device, "render_state", size_of::<RenderState>() as u64),
            gbuffer: buffers::storage_zeroed(device, "render_gbuffer", gbytes),
            secondary: buffers::storage_zeroed(device, "render_secondary", gbytes),
            direct_frame: buffers::storage_zeroed(device, "render_direct_frame", px * 16),
            indirect_frame: buffers::storage_zeroed(device, "render_indirect_frame", px * 16),
            accum_direct: buffers::storage_zeroed(device, "render_accum_direct", px * 16),
            accum_indirect: buffers::storage_zeroed(device, "render_accum_indirect", px * 16),
            materials: buffers::storage_from(device, "render_materials", materials),
        };

        let layouts = [
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("render buffers"),
                entries: &bind_group_layout_entries(),
            }),
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("render bvh"),
                entries: &trace::bind_group_layout_entries(0),
            }),
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("render lights"),
                entries: &lights::bind_group_layout_entries(0),
            }),
        ];
        let b = &buffers;
        let render_entries: Vec<wgpu::BindGroupEntry<'_>> = [
            &b.params,
            &b.state,
            &b.gbuffer,
            &b.secondary,
            &b.direct_frame,
            &b.indirect_frame,
            &b.accum_direct,
            &b.accum_indirect,
            &b.materials,
        ]
        .iter()
        .enumerate()
        .map(|(i, buf)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: buf.as_entire_binding(),
        })
        .collect();
        let render_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("render buffers"),
            layout: &layouts[0],
            entries: &render_entries,
        });
        let bvh_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("render bvh"),
            layout: &layouts[1],
            entries: &gpu_bvh.bind_group_entries(0),
        });
        let lights_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("render lights"),
            layout: &layouts[2],
            entries: &gpu_lights.bind_group_entries(0),
        });

        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("render passes"),
            source: wgpu::ShaderSource::Wgsl(passes_source().into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("render"),
            bind_group_layouts: &[Some(&layouts[0]), Some(&layouts[1]), Some(&layouts[2])],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &[("WORKGROUP_SIZE", f64::from(WORKGROUP_SIZE))],
                    ..Default::default()
                },
                cache: None,
            })
        };
        Ok(Self {
            camera: *camera,
            method,
            primary: pipeline("render_primary"),
            gi: pipeline("render_gi"),
            shade_direct: pipeline("render_shade_direct"),
            shade_indirect: pipeline("render_shade_indirect"),
            accumulate: pipeline("render_accumulate"),
            bvh,
            gpu_bvh,
            gpu_lights,
            buffers,
            render_group,
            bvh_group,
            lights_group,
            layouts,
            pixels,
            frames: 0,
            max_groups_per_dim: limits.max_compute_workgroups_per_dimension,
        })
    }

    /// Bind group 0 (render buffers) and its layout, for passes inserted by later stages.
    pub fn bind_group(&self) -> (&wgpu::BindGroup, &wgpu::BindGroupLayout) {
        (&self.render_group, &self.layouts[0])
    }

    /// Bind groups 1 (BVH) and 2 (lights) with their layouts.
    pub fn scene_bind_groups(&self) -> [(&wgpu::BindGroup, &wgpu::BindGroupLayout); 2] {
        [
            (&self.bvh_group, &self.layouts[1]),
            (&self.lights_group, &self.layouts[2]),
        ]
    }

    /// Moves the camera for the next submitted frame (same image size; the accumulation is not
    /// reset). Used by camera animations.
    pub fn set_camera(&mut self, queue: &wgpu::Queue, camera: &Camera) -> Result<(), RenderError> {
        camera
            .validate()
            .map_err(|e| RenderError::Settings(e.to_string()))?;
        if (camera.width, camera.height) != (self.camera.width, self.camera.height) {
            return Err(RenderError::Settings(
                "set_camera cannot change the image size".into(),
            ));
        }
        // The camera is the first field of RenderParams.
        queue.write_buffer(
            &self.buffers.params,
            0,
            bytemuck::bytes_of(&CameraGpu::new(camera)),
        );
        self.camera = *camera;
        Ok(())
    }

    /// Pixels per frame.
    pub fn pixels(&self) -> u32 {
        self.pixels
    }

    /// Frames accumulated so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Records one pass over all pixels with the render bind groups set (group 0..2); later
    /// stages can use it for their own pipelines built on the same layouts.
    pub fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
    ) {
        let max = self.max_groups_per_dim;
        let (x, y) = dispatch_2d(self.pixels.div_ceil(WORKGROUP_SIZE), max);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.render_group, &[]);
        pass.set_bind_group(1, &self.bvh_group, &[]);
        pass.set_bind_group(2, &self.lights_group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    fn timed(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timer: &mut Option<&mut GpuTimer>,
        name: &str,
        pipeline: &wgpu::ComputePipeline,
    ) {
        match timer {
            Some(t) => t.span(encoder, name, |enc| self.dispatch(enc, name, pipeline)),
            None => self.dispatch(encoder, name, pipeline),
        }
    }

    /// Steps 1-2: primary rays -> G-buffer, GI rays -> secondary vertices.
    pub fn encode_primary_and_gi(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut GpuTimer>,
    ) {
        self.timed(encoder, &mut timer, "primary", &self.primary);
        self.timed(encoder, &mut timer, "gi", &self.gi);
    }

    /// Step 4: direct light at the primary vertex -> `direct_frame`.
    pub fn encode_shade_direct(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut GpuTimer>,
    ) {
        self.timed(encoder, &mut timer, "shade_direct", &self.shade_direct);
    }

    /// Step 5 (baselines): one-bounce indirect by NEE/RIS at the secondary vertex ->
    /// `indirect_frame`. World-space ReSTIR replaces this step with its own shading.
    pub fn encode_shade_indirect(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut GpuTimer>,
    ) {
        self.timed(encoder, &mut timer, "shade_indirect", &self.shade_indirect);
    }

    /// Step 6: adds the frame to the running sums and advances the frame counter.
    pub fn encode_accumulate(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut GpuTimer>,
    ) {
        self.timed(encoder, &mut timer, "accumulate", &self.accumulate);
        self.frames += 1;
    }

    /// One whole baseline frame (steps 1-6) into the caller's encoder.
    pub fn encode_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut GpuTimer>,
    ) {
        self.encode_primary_and_gi(encoder, timer.as_deref_mut());
        self.encode_shade_direct(encoder, timer.as_deref_mut());
        self.encode_shade_indirect(encoder, timer.as_deref_mut());
        self.encode_accumulate(encoder, timer);
    }

    /// Clears the sums and restarts the frame counter (same seed: the same images again).
    pub fn reset(&mut self, ctx: &GpuContext) {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        for b in [
            &self.buffers.state,
            &self.buffers.accum_direct,
            &self.buffers.accum_indirect,
        ] {
            encoder.clear_buffer(b, 0, None);
        }
        ctx.queue.submit([encoder.finish()]);
        self.frames = 0;
    }

    /// Renders `frames` frames, one submission each, timing every pass when the adapter has
    /// timestamps (`None` otherwise); `progress` gets the number of frames done.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        frames: u32,
        mut progress: impl FnMut(u32),
    ) -> Result<Option<PassTimes>, RenderError> {
        let mut timer = GpuTimer::new(ctx, 8);
        let mut times = timer.is_available().then(PassTimes::default);
        for f in 0..frames {
            timer.reset();
            let mut encoder = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("render frame"),
                });
            self.encode_frame(&mut encoder, Some(&mut timer));
            timer.resolve(&mut encoder);
            ctx.queue.submit([encoder.finish()]);
            if let Some(t) = times.as_mut() {
                t.add(&timer.read(ctx)?);
                t.frames += 1;
            } else {
                ctx.wait()?;
            }
            progress(f + 1);
        }
        Ok(times)
    }

    /// The accumulated images (averages over the frames so far; black before any frame).
    pub fn images(&self, ctx: &GpuContext) -> Result<Rendered, RenderError> {
        let n = self.pixels as usize;
        let read = |b: &wgpu::Buffer| -> Result<Vec<[f32; 4]>, GpuError> {
            let mut v: Vec<[f32; 4]> = buffers::read(ctx, b)?;
            v.truncate(n);
            Ok(v)
        };
        let d = read(&self.buffers.accum_direct)?;
        let i = read(&self.buffers.accum_indirect)?;
        let scale = if self.frames == 0 {
            0.0
        } else {
            1.0 / self.frames as f32
        };
        let rgb = |v: &[f32; 4]| [v[0] * scale, v[1] * scale, v[2] * scale];
        let direct: Vec<[f32; 3]> = d.iter().map(rgb).collect();
        let indirect: Vec<[f32; 3]> = i.iter().map(rgb).collect();
        let combined = direct
            .iter()
            .zip(&indirect)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect();
        let (w, h) = (self.camera.width, self.camera.height);
        let image =
            |p| Image::from_pixels(w, h, p).map_err(|e| RenderError::Settings(e.to_string()));
        Ok(Rendered {
            direct: image(direct)?,
            indirect: image(indirect)?,
            combined: image(combined)?,
        })
    }
}

/// One-call render for the demo and tests: builds a [`Renderer`], renders `frames` frames (one
/// sample per pixel each), and returns the averaged images and the per-pass GPU times (`None`
/// without timestamp queries). `progress` gets the number of frames done.
pub fn render_images(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    method: Method,
    seed: u32,
    frames: u32,
    progress: impl FnMut(u32),
) -> Result<(Rendered, Option<PassTimes>), RenderError> {
    if frames == 0 {
        return Err(RenderError::Settings("at least one frame".into()));
    }
    let mut renderer = Renderer::new(ctx, scene, camera, method, seed)?;
    let times = renderer.render(ctx, frames, progress)?;
    Ok((renderer.images(ctx)?, times))
}

#[cfg(test)]
mod tests {
    #[test]
    fn bindings_header_names_every_binding_once() {
        let h = super::bindings_wgsl(0);
        assert_eq!(h.lines().count(), super::BINDINGS.len());
        assert_eq!(
            super::bind_group_layout_entries().len(),
            super::BINDINGS.len()
        );
    }
}
