//! Screen-space reuse, written once for every stage that resamples between pixels and frames
//! (restir-di, restir-gi): the frame's parameters, the reservoir buffers, the neighbours a reuse
//! pass merges (`neighbours.wgsl`), the chain of passes (initial, temporal, spatial, shade,
//! persist) and the camera history. A stage is its [`ScreenStage`]: its reservoir, its three
//! kernels (initial samples; the merge of the neighbours, i.e. its target and shift; the
//! shade), its knobs and the buffers of its own its kernels bind beside the shared ones.
//!
//! Per frame, each step its own compute pass and GPU timestamp span (`di-initial`, ...):
//!
//! | span | pass | reads | writes |
//! |---|---|---|---|
//! | `*-subpath` | a stage's sub-path pass (world-restir-gi's `subpath-k`) | this frame's grid, path split | path radiance |
//! | `*-initial` | initial | G-buffer, the stage's inputs | reservoirs R0 |
//! | `*-temporal` | reuse | R0, last frame's reservoirs, G-buffer and camera | R1 |
//! | `*-spatial` | reuse | R(cur), G-buffer | R(1-cur) |
//! | `*-shade` | shade | final reservoirs | the stage's image |
//! | `*-persist` | copies | final reservoirs, G-buffer | last frame's |
//!
//! The stage keeps the camera of the last frame it recorded, so [`ScreenReuse::encode`] after a
//! `set_camera` reprojects through last frame's camera; a camera cut fails the depth and normal
//! tests and merges nothing.

use crate::gpu::{
    Access, BindingSet, FrameEncoder, GpuContext, GpuError, Pass, Resource, Tracer, WgslModule,
    buffers,
};
use crate::grid::{self, WorldGrid};
use crate::render::{
    self, Buffer, ComposedKernel, GVertex, OwnKernel, Renderer, ReusePass, STAGE_GROUP,
};
use crate::sampling::CameraGpu;
use crate::scene::Camera;

/// The shared library: `ScreenParams` (the stage's knobs and the frame's history) and the
/// similarity test.
pub const WGSL: &str = include_str!("screen_reuse.wgsl");
/// The screen-space neighbour choice of one reuse pass (a disc of pixels, last frame's
/// reprojected pixel): restir-di's and restir-gi's [`ScreenStage::neighbours`].
pub const NEIGHBOURS_WGSL: &str = include_str!("neighbours.wgsl");
/// The reuse pass's entry point and the neighbours' struct (composed into the stage's reuse
/// kernel only).
pub const REUSE_PASS_WGSL: &str = include_str!("reuse_pass.wgsl");

/// The entry point of a stage's sub-path pass ([`ScreenStage::subpath`]).
const SUBPATH_ENTRY: &str = "screen_subpath";

/// Most spatial neighbours per pixel (each stage's `spatial-k`).
pub const MAX_SPATIAL_K: u32 = 16;

/// The frame's parameters, bound by each kernel of a stage.
pub const PARAMS: Buffer = ("screen_params", "ScreenParams", Access::Uniform);
/// Last frame's G-buffer, bound by the reuse kernel.
pub const PREV_GBUFFER: Buffer = ("screen_prev_gbuffer", "array<PackedVertex>", Access::Read);
/// The vertices of a stage's pool's records in the history (after the pixels'), apart from the
/// pixels' so that each fits one storage binding at 1920x1080.
pub const PREV_POOL: Buffer = ("screen_prev_pool", "array<PackedVertex>", Access::Read);

/// Errors of a screen-space reuse stage.
#[derive(Debug, thiserror::Error)]
pub enum ScreenReuseError {
    #[error(transparent)]
    Render(#[from] render::RenderError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Grid(#[from] grid::GridError),
    #[error(transparent)]
    Scan(#[from] gpu_scan::ScanError),
    #[error("bad {stage} setting: {msg}")]
    Config { stage: &'static str, msg: String },
}

impl ScreenReuseError {
    /// A bad setting of `stage`.
    pub fn config(stage: &'static str) -> impl Fn(String) -> Self {
        move |msg| ScreenReuseError::Config { stage, msg }
    }
}

/// A screen-space reuse stage, as declared by its module: its reservoir, its WGSL and the
/// buffers of its own its kernels bind beside the shared ones.
#[derive(Debug)]
pub struct ScreenStage {
    /// `restir-di`: labels, the WGSL module of its library, its kernels' names.
    pub name: &'static str,
    /// The prefix of its spans: `di` names them `di-initial`, `di-temporal`, `di-spatial`,
    /// `di-shade`, `di-persist`.
    pub short: &'static str,
    /// The WGSL array of its stored reservoirs (`array<StoredReservoir>`), and the size of
    /// one in bytes.
    pub reservoirs: &'static str,
    pub reservoir_size: usize,
    /// Its WGSL library (structs and functions its kernels share; may be empty).
    pub library: &'static str,
    /// Its constants header: at least `struct ScreenKnobs` (its knobs' `wgsl_struct`).
    pub constants: fn() -> String,
    /// Its kernels' WGSL, by [`Kernel`]: the initial pass (entry point `screen_initial`,
    /// writes `screen_out`), the reuse pass (`screen_merge` and what else `neighbours.wgsl`
    /// asks of it: its target and shift) and the shade pass (`screen_shade`, reads
    /// `screen_final`).
    pub sources: [&'static str; 3],
    /// The buffers of its own each kernel binds after the shared ones, by [`Kernel`].
    pub own: [&'static [Buffer]; 3],
    /// Modules a kernel needs beyond these (e.g. a reader of the buffers it binds).
    pub extra_modules: fn(Kernel) -> Vec<WgslModule>,
    /// Its neighbour choice (`fn screen_neighbours`): [`NEIGHBOURS_WGSL`], the screen's, or
    /// its own.
    pub neighbours: &'static str,
    /// Whether its neighbour choice looks the world-space grid up ([`grid::LOOKUP`]): the
    /// temporal pass last frame's grid, the spatial pass this frame's.
    pub grid_lookup: bool,
    /// Its sub-path pass, if it has one (world-restir-gi's): WGSL with the entry point
    /// `screen_subpath`, composed into its reuse kernel and run over this frame's grid before
    /// the initial pass where the chain asks ([`Chain::subpath`]).
    pub subpath: Option<&'static str>,
}

/// A stage's kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    Initial = 0,
    Reuse = 1,
    Shade = 2,
}

impl Kernel {
    pub const ALL: [Kernel; 3] = [Kernel::Initial, Kernel::Reuse, Kernel::Shade];

    /// Its name (labels, modules) and entry point.
    pub fn names(self) -> (&'static str, &'static str) {
        match self {
            Kernel::Initial => ("initial", "screen_initial"),
            Kernel::Reuse => ("reuse", "screen_reuse"),
            Kernel::Shade => ("shade", "screen_shade"),
        }
    }
}

impl ScreenStage {
    /// The group-3 bindings of kernel `k`: [`PARAMS`], the reservoirs it reads and writes,
    /// then the stage's own, then (the reuse kernel of a stage that looks the grid up) the
    /// grid's lookup.
    pub fn bindings(&self, k: Kernel) -> BindingSet {
        let set = self.buffers(k);
        match k == Kernel::Reuse && self.grid_lookup {
            true => grid::with_lookup(set),
            false => set,
        }
    }

    /// [`Self::bindings`]' buffers (without gpu-hash's block).
    fn buffers(&self, k: Kernel) -> BindingSet {
        let set = BindingSet::new(k.names().0).buffer(PARAMS.0, PARAMS.1, PARAMS.2);
        let set = match k {
            Kernel::Initial => set.buffer("screen_out", self.reservoirs, Access::ReadWrite),
            Kernel::Reuse => render::reuse_io(self.reservoirs)
                .iter()
                .chain([&PREV_GBUFFER, &PREV_POOL])
                .fold(set, |set, &(name, ty, access)| set.buffer(name, ty, access)),
            Kernel::Shade => set.buffer("screen_final", self.reservoirs, Access::Read),
        };
        let grid: &[Buffer] = match k == Kernel::Reuse && self.grid_lookup {
            true => grid::LOOKUP,
            false => &[],
        };
        self.own[k as usize]
            .iter()
            .chain(grid)
            .fold(set, |set, &(name, ty, access)| set.buffer(name, ty, access))
    }

    /// The modules of kernel `k`, composed after the render library.
    pub fn modules(&self, k: Kernel) -> Vec<WgslModule> {
        let constants = format!(
            "const SCREEN_MAX_NEIGHBOURS: u32 = {MAX_SPATIAL_K}u;\n{}",
            (self.constants)()
        );
        let name = k.names().0;
        let mut needs = vec![self.name, "stage-bindings", "workgroup"];
        let mut modules = vec![
            WgslModule::new("screen-constants", &[], constants),
            WgslModule::new(
                "screen-reuse",
                &["render", "reservoir", "screen-constants"],
                WGSL,
            ),
            WgslModule::new(self.name, &["screen-reuse"], self.library),
            WgslModule::new(
                "stage-bindings",
                &[self.name],
                self.bindings(k).wgsl(STAGE_GROUP),
            ),
        ];
        if k == Kernel::Reuse {
            let mut deps = vec![self.name, "stage-bindings"];
            if self.grid_lookup {
                let own = self.buffers(k).next_binding();
                modules.extend(grid::lookup_modules(own));
                deps.push("grid-lookup");
            }
            let pass_deps = [self.name, "stage-bindings", "screen-neighbours"];
            modules.extend([
                WgslModule::new("screen-neighbours", &deps, self.neighbours),
                WgslModule::new("screen-reuse-pass", &pass_deps, REUSE_PASS_WGSL),
                crate::reuse::merge_module(),
            ]);
            needs.extend(["screen-reuse-pass", crate::reuse::MERGE]);
            if let Some(subpath) = self.subpath {
                modules.push(WgslModule::new("screen-subpath", &deps, subpath));
                needs.push("screen-subpath");
            }
        }
        modules.push(WgslModule::new(name, &needs, self.sources[k as usize]));
        modules.extend((self.extra_modules)(k));
        modules
    }

    /// Every kernel of the stage, composed as used, with its binding sets.
    pub fn composed(&self) -> Vec<ComposedKernel> {
        let dir = self.name.replace('-', "_");
        Kernel::ALL
            .iter()
            .map(|&k| {
                let source = render::compose_with_library(Tracer::Bvh, self.modules(k));
                let name = format!("restir-world/{dir}/{}", k.names().0);
                ComposedKernel::stage(name, source, self.bindings(k))
            })
            .collect()
    }
}

/// The words of WGSL `ScreenParams`: the stage's knobs (`gpu_words`, a multiple of 4), last
/// frame's camera and whether there is history.
pub fn params_words(knobs: &[u32], prev: &Camera, history: bool) -> Vec<u32> {
    let mut words = knobs.to_vec();
    words.extend_from_slice(bytemuck::cast_slice(&[CameraGpu::new(prev)]));
    words.extend([u32::from(history), 0, 0, 0]);
    words
}

/// The byte offsets of `ScreenParams`' fields for knobs of `knob_words` words, and its size:
/// [`params_words`]' layout, for checking against the WGSL.
pub fn params_layout(knob_words: usize) -> (usize, [(&'static str, usize); 6]) {
    let camera = 4 * knob_words;
    let history = camera + size_of::<CameraGpu>();
    let fields = [
        ("knobs", 0),
        ("prev_camera", camera),
        ("history", history),
        ("_pad0", history + 4),
        ("_pad1", history + 8),
        ("_pad2", history + 12),
    ];
    (history + 16, fields)
}

/// A stage's reservoir buffers: this frame's pair (the passes write one from the other), last
/// frame's final reservoirs and last frame's G-buffer (the temporal pass's history; a stage's
/// pool of older records after the pixels' when it keeps one: their reservoirs after the
/// pixels', their vertices in `prev_pool`).
#[derive(Debug)]
struct ReuseBuffers {
    reservoirs: [wgpu::Buffer; 2],
    prev_reservoirs: wgpu::Buffer,
    prev_gbuffer: wgpu::Buffer,
    prev_pool: wgpu::Buffer,
}

/// The temporal pass's sources, record by record: last frame's pixels, then a stage's pool.
#[derive(Debug, Clone, Copy)]
pub struct History<'a> {
    /// Every record's reservoir.
    pub reservoirs: &'a wgpu::Buffer,
    /// The pixels' vertices (last frame's G-buffer).
    pub vertices: &'a wgpu::Buffer,
    /// The pool's records' vertices (one unused record when the stage keeps no pool).
    pub pool_vertices: &'a wgpu::Buffer,
}

impl ReuseBuffers {
    /// Buffers for `pixels` reservoirs of `reservoir_size` bytes, labelled `stage`, and a
    /// history of `pixels + pool` records; each must fit one storage binding of the device.
    fn new(
        ctx: &GpuContext,
        stage: &str,
        pixels: u32,
        pool: u32,
        reservoir_size: usize,
    ) -> Result<Self, GpuError> {
        let px = u64::from(pixels);
        let history = px + u64::from(pool);
        let bytes = px * reservoir_size as u64;
        let history_bytes = history * reservoir_size as u64;
        let vertex_bytes = px * size_of::<GVertex>() as u64;
        let pool_bytes = u64::from(pool.max(1)) * size_of::<GVertex>() as u64;
        ctx.check_binding_size(&format!("the {stage} reservoirs"), history_bytes)?;
        let gvertex = size_of::<GVertex>() as u64;
        ctx.check_pixel_binding(&format!("the {stage} history's vertices"), px, gvertex)?;
        ctx.check_binding_size(&format!("the {stage} pool's vertices"), pool_bytes)?;
        let zeroed = |label: String, size| buffers::storage_zeroed(&ctx.device, &label, size);
        Ok(Self {
            reservoirs: [0, 1].map(|p| zeroed(format!("{stage} reservoirs {p}"), bytes)),
            prev_reservoirs: zeroed(format!("{stage} prev reservoirs"), history_bytes),
            prev_gbuffer: zeroed(format!("{stage} prev gbuffer"), vertex_bytes),
            prev_pool: zeroed(format!("{stage} prev pool vertices"), pool_bytes),
        })
    }
}

/// The buffers of its own a stage's kernels bind beside the shared ones, by binding name.
#[derive(Debug, Default)]
pub struct StageBuffers<'a> {
    pub initial: Vec<(&'static str, &'a wgpu::Buffer)>,
    pub reuse: Vec<(&'static str, &'a wgpu::Buffer)>,
    pub shade: Vec<(&'static str, &'a wgpu::Buffer)>,
    /// The grid the reuse kernel of a stage with [`ScreenStage::grid_lookup`] looks up.
    pub grid: Option<&'a WorldGrid>,
}

/// Which reuse passes the chain has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Chain {
    pub temporal: bool,
    pub spatial: bool,
    /// Records of older frames a stage keeps after last frame's pixels in the temporal pass's
    /// sources ([`ScreenReuse::history`]; 0: none).
    pub pool: u32,
    /// The stage's sub-path pass ([`ScreenStage::subpath`]) before the initial pass.
    pub subpath: bool,
}

/// The pass of `entry` of `kernel` over every pixel, binding the stage's parameters, `res`
/// and the stage's own buffers `own`.
fn bind_pass<'a>(
    renderer: &Renderer,
    device: &wgpu::Device,
    (kernel, entry): (&OwnKernel, &str),
    params: &'a wgpu::Buffer,
    mut res: Vec<(&'a str, Resource<'a>)>,
    own: &[(&'static str, &'a wgpu::Buffer)],
) -> Result<Pass, GpuError> {
    res.insert(0, (PARAMS.0, params.into()));
    res.extend(own.iter().map(|&(n, b)| (n, b.into())));
    renderer.shared.bound_pass(device, kernel, entry, res, None)
}

/// A reuse pass's bound passes: one, or one per grid parity (index: the parity of this
/// frame's grid) for a stage that looks the grid up.
type ReusePasses = Vec<Pass>;

/// A screen-space reuse stage built on a [`Renderer`]: its buffers, its bound passes and its
/// camera history. Reservoir chain: initial -> R0; temporal R0 (+ last frame's) -> R1;
/// spatial R(cur) -> R(1-cur); the shade pass reads the final pair member.
#[derive(Debug)]
pub struct ScreenReuse {
    params: wgpu::Buffer,
    buffers: ReuseBuffers,
    initial: Pass,
    subpath: Option<ReusePasses>,
    temporal: Option<ReusePasses>,
    spatial: Option<ReusePasses>,
    shade: Pass,
    /// Which of the pair holds the final reservoirs.
    final_index: usize,
    knobs: Vec<u32>,
    /// Its spans: initial, temporal, spatial, shade, persist, subpath.
    spans: [String; 6],
    /// The camera of the last frame recorded (`None` before the first).
    last_camera: Option<Camera>,
}

impl ScreenReuse {
    /// `stage` on `renderer`'s scene and image with its knobs' `gpu_words` and `chain`, its
    /// kernels also binding `own`.
    pub fn new(
        ctx: &GpuContext,
        renderer: &Renderer,
        stage: &'static ScreenStage,
        knobs: &[u32],
        chain: Chain,
        own: StageBuffers<'_>,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let b = ReuseBuffers::new(
            ctx,
            stage.name,
            renderer.pixels(),
            chain.pool,
            stage.reservoir_size,
        )?;
        let words = params_words(knobs, &renderer.gpu_camera(), false);
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        let label = format!("{} params", stage.name);
        let params = buffers::with_usage(device, &label, &words, usage);
        if chain.subpath && stage.subpath.is_none() {
            return Err(GpuError::Binding(format!(
                "{} has no sub-path pass",
                stage.name
            )));
        }
        let kernel = |k: Kernel| {
            let label = format!("{} {}", stage.name, k.names().0);
            let own = stage.bindings(k);
            let mut entries = vec![k.names().1];
            if k == Kernel::Reuse && chain.subpath {
                entries.push(SUBPATH_ENTRY);
            }
            let kernel = renderer
                .shared
                .own_kernel(ctx, &label, &own, stage.modules(k), &entries);
            kernel.map(|kernel| (kernel, k.names().1))
        };
        let [initial_k, reuse_k, shade_k] = Kernel::ALL.map(kernel);
        let (initial_k, reuse_k, shade_k) = (initial_k?, reuse_k?, shade_k?);
        let grid = match (stage.grid_lookup, own.grid) {
            (false, _) => None,
            (true, Some(g)) => Some(g),
            (true, None) => {
                return Err(GpuError::Binding(format!(
                    "{} looks up a world-space grid: none given",
                    stage.name
                )));
            }
        };
        let first_hash = stage.buffers(Kernel::Reuse).next_binding();
        // The temporal pass looks up last frame's grid, the spatial and sub-path passes this
        // frame's.
        let reuse = |(temporal, entry): (bool, &str), [src, receivers, out]: [&wgpu::Buffer; 3]| {
            let parities = if grid.is_some() { 2 } else { 1 };
            (0..parities)
                .map(|p| {
                    let u = ReusePass::buffer(device, temporal, 0);
                    let mut res = vec![
                        ("reuse_pass", (&u).into()),
                        ("reuse_src", src.into()),
                        ("reuse_self", receivers.into()),
                        ("reuse_out", out.into()),
                        (PREV_GBUFFER.0, (&b.prev_gbuffer).into()),
                        (PREV_POOL.0, (&b.prev_pool).into()),
                    ];
                    if let Some(g) = grid {
                        let looked_up = if temporal { 1 - p } else { p };
                        res.extend(g.lookup_resources(looked_up, first_hash));
                    }
                    bind_pass(
                        renderer,
                        device,
                        (&reuse_k.0, entry),
                        &params,
                        res,
                        &own.reuse,
                    )
                })
                .collect::<Result<ReusePasses, GpuError>>()
        };
        let r = &b.reservoirs;
        let mut cur = 0;
        let temporal = match chain.temporal {
            true => {
                cur = 1;
                Some(reuse(
                    (true, reuse_k.1),
                    [&b.prev_reservoirs, &r[0], &r[1]],
                )?)
            }
            false => None,
        };
        let spatial = match chain.spatial {
            true => {
                let p = reuse((false, reuse_k.1), [&r[cur], &r[cur], &r[1 - cur]])?;
                cur = 1 - cur;
                Some(p)
            }
            false => None,
        };
        // It reads and writes render buffers only: the reservoirs are bound as the spatial
        // pass's.
        let subpath = match chain.subpath {
            true => Some(reuse((false, SUBPATH_ENTRY), [&r[0], &r[0], &r[1]])?),
            false => None,
        };
        let out = ("screen_out", Resource::from(&r[0]));
        let initial = (&initial_k.0, initial_k.1);
        let initial = bind_pass(renderer, device, initial, &params, vec![out], &own.initial)?;
        let fin = ("screen_final", Resource::from(&r[cur]));
        let shade = (&shade_k.0, shade_k.1);
        let shade = bind_pass(renderer, device, shade, &params, vec![fin], &own.shade)?;
        Ok(Self {
            params,
            buffers: b,
            initial,
            subpath,
            temporal,
            spatial,
            shade,
            final_index: cur,
            knobs: knobs.to_vec(),
            spans: [
                "initial", "temporal", "spatial", "shade", "persist", "subpath",
            ]
            .map(|step| format!("{}-{step}", stage.short)),
            last_camera: None,
        })
    }

    /// Records the stage for the frame whose camera is `renderer`'s (after the passes that
    /// write its inputs): initial samples, temporal and spatial reuse, the shade pass, and keeps
    /// this frame's reservoirs, G-buffer and camera for the next. `parity`: that of this
    /// frame's grid (0 for a stage that looks none up).
    pub fn encode(&mut self, f: &mut FrameEncoder, renderer: &Renderer, parity: usize) {
        let camera = renderer.gpu_camera();
        let prev = self.last_camera.unwrap_or(camera);
        let words = params_words(&self.knobs, &prev, self.last_camera.is_some());
        f.upload_slice(&self.params, 0, &words);
        let [initial, temporal, spatial, shade, persist, subpath] = &self.spans;
        if let Some(s) = &self.subpath {
            f.span(subpath, |f| f.dispatch(&s[parity % s.len()]));
        }
        f.span(initial, |f| f.dispatch(&self.initial));
        if let Some(t) = &self.temporal {
            f.span(temporal, |f| f.dispatch(&t[parity % t.len()]));
        }
        if let Some(s) = &self.spatial {
            f.span(spatial, |f| f.dispatch(&s[parity % s.len()]));
        }
        f.span(shade, |f| f.dispatch(&self.shade));
        if self.temporal.is_some() {
            let b = &self.buffers;
            f.span(persist, |f| {
                f.copy(&b.reservoirs[self.final_index], &b.prev_reservoirs);
                f.copy(&renderer.buffers.gbuffer, &b.prev_gbuffer);
            });
        }
        self.last_camera = Some(camera);
    }

    /// The temporal pass's sources: last frame's final reservoirs and G-buffer, per pixel,
    /// then (a stage with [`Chain::pool`]) its pool's records.
    pub fn history(&self) -> History<'_> {
        History {
            reservoirs: &self.buffers.prev_reservoirs,
            vertices: &self.buffers.prev_gbuffer,
            pool_vertices: &self.buffers.prev_pool,
        }
    }

    /// Bytes of its buffers (parameters, reservoirs, last frame's reservoirs and G-buffer).
    pub fn bytes(&self) -> u64 {
        let b = &self.buffers;
        [
            &self.params,
            &b.reservoirs[0],
            &b.reservoirs[1],
            &b.prev_reservoirs,
            &b.prev_gbuffer,
            &b.prev_pool,
        ]
        .iter()
        .map(|x| x.size())
        .sum()
    }

    /// The last frame's final reservoirs, per pixel.
    pub fn reservoirs<T: bytemuck::Pod>(&self, ctx: &GpuContext) -> Result<Vec<T>, GpuError> {
        buffers::read(ctx, &self.buffers.reservoirs[self.final_index])
    }
}

#[cfg(test)]
mod tests {
    use crate::knobs::Knobs;

    // The screen-space stages' knob tables, side by side.
    #[test]
    fn restir_di_knobs_set_get_and_validate() {
        let d = crate::restir_di::RestirDiConfig::default();
        crate::knobs::assert_knob_table(
            d,
            |c: &_| c.validate(),
            &[
                ("spatial-k", "2"),
                ("combine", "biased"),
                ("temporal", "off"),
            ],
            "temporal=off+spatial-k=2+combine=biased",
            &[
                ("tiles", "0"),
                ("tile-size", "0"),
                ("candidates", "0"),
                ("temporal-m-cap", "0"),
                ("spatial-k", "17"),
                ("spatial-radius", "-1"),
                ("normal-threshold", "2"),
                ("depth-threshold", "NaN"),
            ],
        );
        let mut c = d;
        c.set("tiles", "70000").unwrap();
        c.set("tile-size", "65535").unwrap();
        assert!(c.validate().unwrap_err().to_string().contains("fit u32"));
    }

    #[test]
    fn restir_gi_knobs_set_get_and_validate() {
        let d = crate::restir_gi::RestirGiConfig::default();
        crate::knobs::assert_knob_table(
            d,
            |c: &_| c.validate(),
            &[
                ("spatial-k", "2"),
                ("combine", "biased"),
                ("visibility", "off"),
            ],
            "spatial-k=2+combine=biased+visibility=off",
            &[
                ("temporal-m-cap", "0"),
                ("temporal-m-cap", "1024"),
                ("spatial-k", "17"),
                ("spatial-radius", "-1"),
                ("normal-threshold", "2"),
                ("depth-threshold", "NaN"),
                ("max-jacobian", "0.5"),
            ],
        );
    }
}
