//! A portable denoiser after any method: SVGF (Schied et al., HPG 2017) in WGSL on the
//! renderer's G-buffer and frames. The direct and the indirect light are filtered apart, each
//! demodulated by the primary vertex's albedo and remodulated at the end; temporal
//! accumulation reprojects through last frame's camera (bilinear, each tap kept only on the
//! same surface: plane distance and normal), clamps the history to this frame's neighbourhood
//! and tracks each pixel's history length and luminance moments; the variance they give
//! (or, for a history under 4 frames, a 7x7 neighbourhood's) steers an edge-aware a-trous
//! wavelet filter (3x3 B-spline taps, `iterations` passes of step 1, 2, 4, ...).
//!
//! [`Denoiser::encode`] records its passes after a method's frame, under one span `denoise`;
//! its output is [`Denoiser::read`] (the last frame, denoised). The passes are in
//! `denoise.wgsl`; every knob is [`DenoiseConfig`]'s.

use crate::gpu::{
    Access, BindingSet, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule,
    buffers,
};
use crate::images::FrameImages;
use crate::knobs::Knobs;
use crate::render::{ComposedKernel, DebugView, GVertex, RenderError, Renderer, STAGE_GROUP, heat};
use crate::sampling::CameraGpu;
use crate::scene::Camera;

const WGSL: &str = include_str!("denoise.wgsl");

/// Most a-trous iterations (step 2^(iterations-1) pixels).
pub const MAX_ITERATIONS: u32 = 8;

crate::knobs! {
    /// Every knob of the denoiser with its default (SVGF's where it has one).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct DenoiseConfig {
        /// Edge-aware a-trous iterations (default 4: steps 1, 2, 4, 8 pixels, a 31-pixel
        /// footprint; 0: temporal accumulation only. SVGF's 5 measured no lower error on
        /// cornell at 128x128 for 23% more of the denoiser's time).
        iterations: u32 = 4, "iterations", 0..=MAX_ITERATIONS;
        /// Least weight of the new frame in the temporal blend (default 0.2: about the last
        /// 5-10 frames; 1: no history).
        [gpu] alpha: f32 = 0.2, "alpha", 0.001..=1.0;
        /// Least weight of the new frame in the luminance moments' blend (default 0.2).
        [gpu] moments_alpha: f32 = 0.2, "moments-alpha", 0.001..=1.0;
        /// The history is clamped to this frame's 3x3 neighbourhood's mean -/+ this many
        /// standard deviations, per channel (default 0: no clamping; for lighting that
        /// changes. Measured on 1-sample frames: at 4 it darkened colonnade by 9-12%, the
        /// window's few samples rarely holding the outliers the history averages).
        [gpu] clamp_sigma: f32 = 0.0, "clamp-sigma", 0.0..=f32::MAX;
        /// Luminance edge-stopping: a neighbour's weight falls by e per this many standard
        /// deviations of luminance, the larger of the two pixels' (symmetric, so that an
        /// outlier's energy is shared, not lost; default 4). Above 0: at 0 a pixel's weight
        /// of itself is 0 x infinity (NaN pixels).
        [gpu] phi_luminance: f32 = 4.0, "phi-luminance", 1e-6..=f32::MAX;
        /// Normal edge-stopping: the weight is the normals' cosine to this power (default 128).
        [gpu] phi_normal: f32 = 128.0, "phi-normal", 0.0..=f32::MAX;
        /// Plane-distance edge-stopping: the weight falls by e per this many pixel footprints
        /// of distance from the receiver's plane, per pixel of screen distance (default 1).
        [gpu] phi_depth: f32 = 1.0, "phi-depth", 1e-6..=f32::MAX;
        /// History is the same surface within this fraction of the distance to the eye, off
        /// the receiver's plane (default 0.01).
        [gpu] depth_threshold: f32 = 0.01, "depth-threshold", 0.0..=f32::MAX;
        /// ... and with shading normals' cosine at least this (default 0.9).
        [gpu] normal_threshold: f32 = 0.9, "normal-threshold", -1.0..=1.0;
        /// A glossy pixel takes the a-trous levels whose step is at most this many times its
        /// lobe's radius on the screen (WGSL `dn_lobe_pixels`), so that a reflection is not
        /// blurred far beyond what its roughness blurs it (default 4; 0: every level, as a
        /// diffuse pixel). Measured on `glossy` (128x128, 16 frames, seed 1, ris / restir-gi
        /// denoised relMSE): 0: 0.60 / 0.50, 1: 0.98 / 0.80 (too little filtering: residual
        /// noise), 2: 0.63 / 0.48, 4: 0.55 / 0.44, 8: 0.59 / 0.49, 16: 0.61 / 0.51.
        [gpu] lobe_scale: f32 = 4.0, "lobe-scale", 0.0..=f32::MAX;
    }
}

impl DenoiseConfig {
    /// Parses `key=value` knobs joined by `+` (empty: the defaults) and checks them.
    pub fn parse(text: &str) -> Result<Self, RenderError> {
        let c: Self = crate::knobs::parse_config(&[], (!text.is_empty()).then_some(text))
            .map_err(|e| RenderError::Settings(format!("denoise: {e}")))?;
        c.validate()?;
        Ok(c)
    }

    /// Checks every knob.
    pub fn validate(&self) -> Result<(), RenderError> {
        self.check_ranges()
            .map_err(|e| RenderError::Settings(format!("denoise: {e}")))
    }
}

/// WGSL `DnPair`: per pixel, the direct and the indirect signal, rgb and luminance variance.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DnPair {
    pub direct: [f32; 4],
    pub indirect: [f32; 4],
}

/// WGSL `DnState`: per pixel and frame, the surface, luminance moments and history length.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DnState {
    pub position: [f32; 3],
    /// Oct-packed shading normal, or [`NO_SURFACE`].
    pub normal: u32,
    pub moments: [f32; 4],
    pub length: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// [`DnState::normal`] of a pixel whose camera ray escaped.
pub const NO_SURFACE: u32 = 0x8000_8000;

/// WGSL `DenoisePass`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct DenoisePass {
    step: u32,
    first: u32,
    _pad: [u32; 2],
}

const ENTRIES: [&str; 4] = [
    "denoise_temporal",
    "denoise_variance",
    "denoise_atrous",
    "denoise_modulate",
];

/// The denoiser's group-3 bindings (one set for every pass; each binds its own buffers).
pub fn bindings() -> BindingSet {
    let rw = Access::ReadWrite;
    BindingSet::new("denoise")
        .buffer("denoise_params", "DenoiseParams", Access::Uniform)
        .buffer("dn_pass", "DenoisePass", Access::Read)
        .buffer("dn_state_prev", "array<DnState>", Access::Read)
        .buffer("dn_state", "array<DnState>", rw)
        .buffer("dn_history", "array<DnPair>", rw)
        .buffer("dn_src", "array<DnPair>", Access::Read)
        .buffer("dn_dst", "array<DnPair>", rw)
        .buffer("dn_out", "array<DnPair>", rw)
}

fn modules() -> Vec<WgslModule> {
    let constants = DenoiseConfig::wgsl_struct("DenoiseKnobs");
    vec![
        WgslModule::new("denoise-constants", &[], constants),
        WgslModule::new(
            "denoise-bindings",
            &["denoise-lib"],
            bindings().wgsl(STAGE_GROUP),
        ),
        WgslModule::new("denoise-lib", &["render", "denoise-constants"], ""),
        WgslModule::new("denoise", &["denoise-bindings", "workgroup"], WGSL),
    ]
}

/// The denoiser's kernel, composed as used, with its binding sets.
pub fn kernels() -> Vec<ComposedKernel> {
    let source = crate::render::compose_with_library(Tracer::Bvh, modules());
    vec![ComposedKernel::stage(
        "restir-world/denoise".into(),
        source,
        bindings(),
    )]
}

/// The words of WGSL `DenoiseParams`: the knobs, last frame's camera and whether there is
/// history.
fn params_words(config: &DenoiseConfig, prev: &Camera, history: bool) -> Vec<u32> {
    let mut words = config.gpu_words().to_vec();
    words.extend_from_slice(bytemuck::cast_slice(&[CameraGpu::new(prev)]));
    words.extend([u32::from(history), 0, 0, 0]);
    words
}

/// Bytes per pixel of the denoiser's buffers.
pub const BYTES_PER_PIXEL: u64 = 2 * size_of::<DnState>() as u64 + 5 * size_of::<DnPair>() as u64;

/// The denoiser's buffers, per pixel.
#[derive(Debug)]
struct DenoiseBuffers {
    params: wgpu::Buffer,
    state_prev: wgpu::Buffer,
    state: wgpu::Buffer,
    history: wgpu::Buffer,
    /// Temporal accumulation's output (the filter's input, kept for the debug views).
    integrated: wgpu::Buffer,
    ping: [wgpu::Buffer; 2],
    out: wgpu::Buffer,
}

/// The denoiser on one renderer: its buffers, bound passes and last frame's camera.
#[derive(Debug)]
pub struct Denoiser {
    config: DenoiseConfig,
    pixels: u32,
    buffers: DenoiseBuffers,
    temporal: Pass,
    variance: Pass,
    /// One per iteration (ping-pong).
    atrous: Vec<Pass>,
    modulate: Pass,
    last_camera: Option<Camera>,
}

impl Denoiser {
    /// The denoiser of `renderer`'s frames with `config` (checked here).
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        config: &DenoiseConfig,
    ) -> Result<Self, RenderError> {
        config.validate()?;
        let device = &ctx.device;
        let pixels = renderer.pixels();
        let px = u64::from(pixels);
        let state_bytes = px * size_of::<DnState>() as u64;
        let pair_bytes = px * size_of::<DnPair>() as u64;
        ctx.check_pixel_binding("the denoiser's state", px, size_of::<DnState>() as u64)?;
        ctx.check_pixel_binding("the denoiser's colours", px, size_of::<DnPair>() as u64)?;
        let zeroed = |label: &str, size| buffers::storage_zeroed(device, label, size);
        let words = params_words(config, &renderer.gpu_camera(), false);
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let b = DenoiseBuffers {
            params: buffers::with_usage(device, "denoise params", &words, usage),
            state_prev: zeroed("denoise state prev", state_bytes),
            state: zeroed("denoise state", state_bytes),
            history: zeroed("denoise history", pair_bytes),
            integrated: zeroed("denoise integrated", pair_bytes),
            ping: [0, 1].map(|p| zeroed(&format!("denoise ping {p}"), pair_bytes)),
            out: zeroed("denoise out", pair_bytes),
        };
        let kernel =
            renderer
                .shared
                .own_kernel(ctx, "denoise", &bindings(), modules(), &ENTRIES)?;
        let pass_uniform = |step: u32, first: bool| {
            let u = DenoisePass {
                step,
                first: u32::from(first),
                ..Default::default()
            };
            buffers::with_usage(device, "denoise pass", &[u], wgpu::BufferUsages::STORAGE)
        };
        let mut pass_uniforms = vec![pass_uniform(0, false)];
        pass_uniforms.extend((0..config.iterations).map(|k| pass_uniform(1 << k, k == 0)));
        let bind = |entry: &str, pass: &wgpu::Buffer, src: &wgpu::Buffer, dst: &wgpu::Buffer| {
            let res: Vec<(&str, Resource)> = vec![
                ("denoise_params", (&b.params).into()),
                ("dn_pass", pass.into()),
                ("dn_state_prev", (&b.state_prev).into()),
                ("dn_state", (&b.state).into()),
                ("dn_history", (&b.history).into()),
                ("dn_src", src.into()),
                ("dn_dst", dst.into()),
                ("dn_out", (&b.out).into()),
            ];
            renderer
                .shared
                .bound_pass(device, &kernel, entry, res, None)
        };
        // temporal -> integrated; variance integrated -> ping 0; a-trous ping k%2 -> (k+1)%2.
        let temporal = bind(ENTRIES[0], &pass_uniforms[0], &b.ping[1], &b.integrated)?;
        let variance = bind(ENTRIES[1], &pass_uniforms[0], &b.integrated, &b.ping[0])?;
        let atrous = (0..config.iterations as usize)
            .map(|k| {
                let (src, dst) = (&b.ping[k % 2], &b.ping[(k + 1) % 2]);
                bind(ENTRIES[2], &pass_uniforms[k + 1], src, dst)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let final_index = config.iterations as usize % 2;
        let modulate = bind(
            ENTRIES[3],
            &pass_uniforms[0],
            &b.ping[final_index],
            &b.ping[1 - final_index],
        )?;
        Ok(Self {
            config: *config,
            pixels,
            buffers: b,
            temporal,
            variance,
            atrous,
            modulate,
            last_camera: None,
        })
    }

    /// Its knobs.
    pub fn config(&self) -> &DenoiseConfig {
        &self.config
    }

    /// Records the denoiser for the frame `renderer` just recorded (span `denoise`), and keeps
    /// this frame's state and camera for the next.
    pub fn encode(&mut self, f: &mut FrameEncoder, renderer: &Renderer) {
        let camera = renderer.gpu_camera();
        let prev = self.last_camera.unwrap_or(camera);
        let words = params_words(&self.config, &prev, self.last_camera.is_some());
        let b = &self.buffers;
        f.upload_slice(&b.params, 0, &words);
        f.span("denoise", |f| {
            f.dispatch(&self.temporal);
            f.dispatch(&self.variance);
            for p in &self.atrous {
                f.dispatch(p);
            }
            if self.atrous.is_empty() {
                // No a-trous pass writes the colour history: the accumulation is it.
                f.copy(&b.integrated, &b.history);
            }
            f.dispatch(&self.modulate);
            f.copy(&b.state, &b.state_prev);
        });
        self.last_camera = Some(camera);
    }

    /// Forgets the history (the next frame starts afresh, as after a cut).
    pub fn reset(&mut self) {
        self.last_camera = None;
    }

    /// Bytes of its buffers.
    pub fn bytes(&self) -> u64 {
        u64::from(self.pixels) * BYTES_PER_PIXEL
    }

    /// The last frame, denoised (direct and indirect; one frame).
    pub fn read(&self, ctx: &GpuContext, camera: &Camera) -> Result<FrameImages, GpuError> {
        let pairs: Vec<DnPair> = buffers::read(ctx, &self.buffers.out)?;
        let pixels = self.pixels as usize;
        let rgb = |p: [f32; 4]| [p[0], p[1], p[2]];
        Ok(FrameImages {
            width: camera.width,
            height: camera.height,
            frames: 1,
            direct: pairs.iter().take(pixels).map(|p| rgb(p.direct)).collect(),
            indirect: pairs.iter().take(pixels).map(|p| rgb(p.indirect)).collect(),
        })
    }

    /// The last frame's per-pixel state (surface, moments, history length).
    pub fn read_state(&self, ctx: &GpuContext) -> Result<Vec<DnState>, GpuError> {
        let mut v: Vec<DnState> = buffers::read(ctx, &self.buffers.state)?;
        v.truncate(self.pixels as usize);
        Ok(v)
    }

    /// A debug view of the last frame: [`DebugView::DenoiseHistory`] (heat map of the
    /// history length up to 1 / alpha frames), [`DebugView::DenoiseVariance`] (heat map of
    /// log10 of the luminance variance of both signals, 1e-4 .. 1e2); `None` for others.
    pub fn debug_image(
        &self,
        ctx: &GpuContext,
        view: DebugView,
    ) -> Result<Option<Vec<[f32; 3]>>, GpuError> {
        let state = match view {
            DebugView::DenoiseHistory | DebugView::DenoiseVariance => self.read_state(ctx)?,
            _ => return Ok(None),
        };
        let full = 1.0 / self.config.alpha;
        let image = state.iter().map(|s| {
            if s.normal == NO_SURFACE {
                return [0.0; 3];
            }
            match view {
                DebugView::DenoiseHistory => heat(s.length / full),
                _ => {
                    let m = s.moments;
                    let var = (m[1] - m[0] * m[0]).max(0.0) + (m[3] - m[2] * m[2]).max(0.0);
                    heat((var.max(1e-12).log10() + 4.0) / 6.0)
                }
            }
        });
        Ok(Some(image.collect()))
    }

    /// The last frame's image after each a-trous iteration (0: the temporal accumulation
    /// before filtering; then 1 ..= iterations), combined (direct + indirect), remodulated
    /// with `renderer`'s G-buffer: the filter runs again on the kept accumulation.
    pub fn iteration_images(
        &self,
        ctx: &GpuContext,
        renderer: &Renderer,
    ) -> Result<Vec<Vec<[f32; 3]>>, GpuError> {
        let b = &self.buffers;
        let size = u64::from(self.pixels) * size_of::<DnPair>() as u64;
        let copies: Vec<wgpu::Buffer> = (0..=self.config.iterations)
            .map(|k| buffers::storage_zeroed(&ctx.device, &format!("denoise iteration {k}"), size))
            .collect();
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut f = FrameEncoder::new(&ctx.device, &mut encoder, None);
            f.dispatch(&self.variance);
            f.copy(&b.ping[0], &copies[0]);
            for (k, p) in self.atrous.iter().enumerate() {
                f.dispatch(p);
                f.copy(&b.ping[(k + 1) % 2], &copies[k + 1]);
            }
        }
        ctx.queue.submit([encoder.finish()]);
        let gbuffer = renderer.read_gbuffer(ctx)?;
        let eye = renderer.gpu_camera().eye;
        let direct = renderer
            .read(ctx, crate::images::Readback::LastFrame)?
            .direct;
        copies
            .iter()
            .map(|c| {
                let pairs: Vec<DnPair> = buffers::read(ctx, c)?;
                Ok(remodulate(&pairs, &gbuffer, &direct, eye))
            })
            .collect()
    }
}

/// albedo x (direct + indirect illumination) + emission per pixel (WGSL `denoise_modulate`'s
/// twin, both signals summed; the albedo [`demodulating_albedo`]'s); the raw direct frame where
/// the camera ray escaped.
fn remodulate(
    pairs: &[DnPair],
    gbuffer: &[GVertex],
    direct: &[[f32; 3]],
    eye: glam::Vec3,
) -> Vec<[f32; 3]> {
    gbuffer
        .iter()
        .zip(pairs)
        .zip(direct)
        .map(|((g, p), d)| {
            if g.prim == crate::trace::NO_HIT {
                return *d;
            }
            let albedo = demodulating_albedo(g, eye);
            [0, 1, 2].map(|c| {
                let a = if albedo[c] > 1e-3 { albedo[c] } else { 0.0 };
                g.emission[c] + a * (p.direct[c] + p.indirect[c])
            })
        })
        .collect()
}

/// Twin of WGSL `dn_demodulating_albedo`: the base colour of a diffuse vertex, a glossy one's
/// directional albedo towards `eye` (its base colour where its shading normal faces away).
fn demodulating_albedo(g: &GVertex, eye: glam::Vec3) -> [f32; 3] {
    let s = g.brdf();
    let position = glam::Vec3::from(g.position);
    let (n, wo) = (g.shading_normal(), (eye - position).normalize());
    // NaN (a degenerate normal) takes the base colour too, as the WGSL's `!(cos > 0)`.
    if s.diffuse || n.dot(wo).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return g.albedo;
    }
    let a = crate::brdf::Brdf::new(crate::brdf::tables()).albedo(&s, n.as_dvec3(), wo.as_dvec3());
    a.as_vec3().to_array()
}
