//! Ray tracing: an obvhs compressed wide BVH8 (medium build preset) built on the CPU and
//! uploaded as-is, full-f32 triangles in BVH primitive order, and our own WGSL traversal
//! (closest hit and any hit, watertight triangle test).
//!
//! The CPU twin ([`Bvh::closest_hit`], [`Bvh::any_hit`]) runs obvhs's own CPU traversal with the
//! same watertight triangle test, so GPU results can be compared hit for hit.
//!
//! WGSL: a consumer composes [`modules`] (the traversal library and its [`bindings`] at a group
//! of its choice) with its own kernel. [`TraceKernel`] is the standalone "trace a buffer of
//! rays" kernel used by the tests and the benchmark.

use std::time::{Duration, Instant};

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris, node::CwBvhNode},
    ray::Ray as ObvhsRay,
};

use crate::gpu::{
    Access, BindGroupLayout, BindingSet, Kernel, Pass, Resource, Tracer, WgslModule, buffers,
    compose, workgroup_size_wgsl,
};
use crate::scene::Scene;
use crate::{GpuContext, GpuError};

/// The software traversal (structs and functions, no bindings).
pub const WGSL: &str = include_str!("trace.wgsl");
/// The ray-query backend: the same functions on the adapter's acceleration structures.
pub const RAY_QUERY_WGSL: &str = include_str!("trace_rq.wgsl");
/// The types both backends share (`Ray`, `Hit`, `BvhTriangle`).
pub const TYPES_WGSL: &str = include_str!("trace_types.wgsl");
/// The standalone ray-buffer kernel.
pub const KERNEL_WGSL: &str = include_str!("trace_rays.wgsl");

/// Depth of the traversal stack of node groups (obvhs validates CWBVH depth below 32).
pub const STACK_SIZE: u32 = 32;
/// `Hit::prim` of a miss.
pub const NO_HIT: u32 = u32::MAX;
/// Nearest t at which node boxes are entered (beyond the ray's own tmin). 0: obvhs's CPU node
/// test clamps to an absolute 1e-4, which loses every hit nearer than that, and so the near
/// walls of a scene in small units (a box of 1e-3 lost 7.6% of its indirect light); the
/// differential tests count the few rays where only the GPU sees such a hit.
pub const NODE_TMIN: f32 = 0.0;

/// Errors building or uploading the BVH.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    #[error("the scene has no triangles to build a BVH over")]
    Empty,
    #[error(
        "the scene is too large for this adapter: {what} need {bytes} bytes, the adapter allows {limit} per storage buffer"
    )]
    TooLarge {
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
    #[error(
        "the scene is too large for this adapter's ray queries: {needed} {what}, the adapter \
         allows {limit} (use --tracer bvh)"
    )]
    AccelLimit {
        what: &'static str,
        needed: u64,
        limit: u64,
    },
    #[error("building the acceleration structures failed: {0}")]
    Gpu(String),
}

/// Rust mirror of the WGSL `BvhNode`: the same 80 bytes as [`CwBvhNode`] with the byte arrays
/// packed into words the shader reads.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhNode {
    pub p: [f32; 3],
    /// `e[0] | e[1] << 8 | e[2] << 16 | imask << 24`.
    pub e_imask: u32,
    pub child_base_idx: u32,
    pub primitive_base_idx: u32,
    pub child_meta: [u32; 2],
    pub child_min_x: [u32; 2],
    pub child_max_x: [u32; 2],
    pub child_min_y: [u32; 2],
    pub child_max_y: [u32; 2],
    pub child_min_z: [u32; 2],
    pub child_max_z: [u32; 2],
}

const _: () = assert!(size_of::<BvhNode>() == size_of::<CwBvhNode>());

/// A triangle in BVH primitive order (48 bytes): full f32 vertices, material index, and the
/// index of the triangle in [`Scene::triangles`].
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BvhTriangle {
    pub v0: [f32; 3],
    pub material: u32,
    pub v1: [f32; 3],
    pub index: u32,
    pub v2: [f32; 3],
    pub flags: u32,
}

/// What one ray's traversal visited (WGSL `bvh_visits`, read by `trace_rays_counted`): node
/// boxes tested (80 bytes each fetched) and triangles tested (48 bytes each).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Visits {
    pub nodes: u32,
    pub triangles: u32,
}

impl Visits {
    /// The bytes of nodes and triangles these visits fetched.
    pub fn bytes(&self) -> u64 {
        u64::from(self.nodes) * size_of::<CwBvhNode>() as u64
            + u64::from(self.triangles) * size_of::<BvhTriangle>() as u64
    }
}

/// A ray as the GPU reads it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Ray {
    pub origin: [f32; 3],
    pub tmin: f32,
    pub dir: [f32; 3],
    pub tmax: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Self {
            origin: origin.to_array(),
            tmin,
            dir: dir.to_array(),
            tmax,
        }
    }
}

/// A hit as the GPU writes it: `prim` indexes the BVH-order triangles ([`NO_HIT`] on a miss),
/// `(b1, b2)` are the barycentric weights of `v1` and `v2`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub b1: f32,
    pub b2: f32,
}

impl Hit {
    pub fn is_hit(&self) -> bool {
        self.prim != NO_HIT
    }
}

/// The generated constants header every composed tracing shader starts with.
pub fn constants_wgsl() -> String {
    format!(
        "const BVH_STACK_SIZE: u32 = {STACK_SIZE}u;\nconst BVH_NO_HIT: u32 = {NO_HIT}u;\nconst BVH_NODE_TMIN: f32 = {NODE_TMIN:e};\n"
    )
}

/// The tracer's bindings: the BVH's `bvh_nodes`, or the ray-query backend's `bvh_accel`
/// (top-level acceleration structure), then `bvh_triangles` (what a hit's `prim` indexes).
pub fn bindings(tracer: Tracer) -> BindingSet {
    let set = BindingSet::new("bvh");
    let set = match tracer {
        Tracer::Bvh => set.buffer("bvh_nodes", "array<BvhNode>", Access::Read),
        Tracer::RayQuery => set.accel("bvh_accel"),
    };
    set.buffer("bvh_triangles", "array<BvhTriangle>", Access::Read)
}

/// The tracer's WGSL modules with its bindings at `group`: `bvh-constants`, `bvh-bindings`,
/// `trace-types` (structs `BvhTriangle`, `Ray`, `Hit`) and `trace` (functions
/// `trace_closest`, `trace_any`, `bvh_traverse`), whichever the backend.
pub fn modules(group: u32, tracer: Tracer) -> Vec<WgslModule> {
    let source = match tracer {
        Tracer::Bvh => WGSL,
        Tracer::RayQuery => RAY_QUERY_WGSL,
    };
    vec![
        WgslModule::new("bvh-constants", &[], constants_wgsl()),
        WgslModule::new("bvh-bindings", &[], bindings(tracer).wgsl(group)),
        WgslModule::new("trace-types", &[], TYPES_WGSL),
        WgslModule::new(
            "trace",
            &["bvh-constants", "bvh-bindings", "trace-types"],
            source,
        ),
    ]
}

/// Per-ray constants of the watertight test.
struct Watertight {
    k: [usize; 3],
    s: [f32; 3],
}

impl Watertight {
    fn new(dir: Vec3) -> Self {
        let a = dir.abs();
        let kz = if a.y > a.x && a.y >= a.z {
            1
        } else if a.z > a.x && a.z > a.y {
            2
        } else {
            0
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self {
            k: [kx, ky, kz],
            s: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]],
        }
    }

    /// Twin of `bvh_intersect_triangle`: `(t, b1, b2)` or `None`.
    fn intersect(
        &self,
        origin: Vec3,
        tmin: f32,
        tmax: f32,
        tri: &BvhTriangle,
    ) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let a = Vec3::from(tri.v0) - origin;
        let b = Vec3::from(tri.v1) - origin;
        let c = Vec3::from(tri.v2) - origin;
        let ax = a[kx] - self.s[0] * a[kz];
        let ay = a[ky] - self.s[1] * a[kz];
        let bx = b[kx] - self.s[0] * b[kz];
        let by = b[ky] - self.s[1] * b[kz];
        let cx = c[kx] - self.s[0] * c[kz];
        let cy = c[ky] - self.s[1] * c[kz];
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        let az = self.s[2] * a[kz];
        let bz = self.s[2] * b[kz];
        let cz = self.s[2] * c[kz];
        let tt = u * az + v * bz + w * cz;
        let rcp = 1.0 / det;
        let t = tt * rcp;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        Some((t, v * rcp, w * rcp))
    }
}

/// The CPU side of the tracer: the obvhs CWBVH and the triangles in its primitive order.
#[derive(Debug, Clone)]
pub struct Bvh {
    pub cwbvh: CwBvh,
    /// Triangles in BVH primitive order (`triangles[i]` is scene triangle
    /// `triangles[i].index`).
    pub triangles: Vec<BvhTriangle>,
    /// Wall time of the obvhs build (CPU).
    pub build_time: Duration,
}

impl Bvh {
    /// Builds the CWBVH (obvhs medium preset) over the scene's triangles.
    pub fn build(scene: &Scene) -> Result<Self, TraceError> {
        if scene.triangles.is_empty() {
            return Err(TraceError::Empty);
        }
        let start = Instant::now();
        let tris: Vec<obvhs::triangle::Triangle> = scene
            .triangles
            .iter()
            .map(|t| obvhs::triangle::Triangle {
                v0: t.v[0].into(),
                v1: t.v[1].into(),
                v2: t.v[2].into(),
            })
            .collect();
        let mut core = Duration::ZERO;
        let cwbvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut core);
        let triangles = cwbvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = &scene.triangles[i as usize];
                BvhTriangle {
                    v0: t.v[0].to_array(),
                    material: t.material,
                    v1: t.v[1].to_array(),
                    index: i,
                    v2: t.v[2].to_array(),
                    flags: 0,
                }
            })
            .collect();
        Ok(Self {
            cwbvh,
            triangles,
            build_time: start.elapsed(),
        })
    }

    fn obvhs_ray(ray: &Ray) -> ObvhsRay {
        ObvhsRay::new(
            Vec3A::from(ray.origin),
            Vec3A::from(ray.dir),
            ray.tmin,
            ray.tmax,
        )
    }

    /// Closest hit by obvhs's CPU traversal with the watertight test (twin of `trace_closest`).
    pub fn closest_hit(&self, ray: &Ray) -> Hit {
        self.traverse(ray, false).0
    }

    /// Whether anything blocks the ray within [tmin, tmax] (twin of `trace_any`).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.traverse(ray, true).0.is_hit()
    }

    /// obvhs's CPU traversal (its `traverse!`, as its `ray_traverse` and `ray_traverse_miss`
    /// run it) with the watertight test: the closest hit, or with `any_hit` the first hit
    /// found, and the nodes and triangles it visited (twin of `bvh_traverse` and its
    /// `bvh_visits`).
    pub fn traverse(&self, ray: &Ray, any_hit: bool) -> (Hit, Visits) {
        use glam::UVec2; // The macro names it unqualified.
        let wt = Watertight::new(Vec3::from(ray.dir));
        let origin = Vec3::from(ray.origin);
        let mut best = Hit {
            t: ray.tmax,
            prim: NO_HIT,
            b1: 0.0,
            b2: 0.0,
        };
        let mut visits = Visits::default();
        if self.cwbvh.nodes.is_empty() {
            return (best, visits);
        }
        let mut obvhs_ray = Self::obvhs_ray(ray);
        let mut state = self.cwbvh.new_traversal(obvhs_ray.direction);
        let mut node;
        // A labelled block: a `break` inside the macro's primitive loop would only end that loop.
        'traversal: {
            obvhs::traverse!(
                self.cwbvh,
                node,
                state,
                {
                    visits.nodes += 1;
                    node.intersect_ray(&obvhs_ray, state.oct_inv4)
                },
                {
                    visits.triangles += 1;
                    let id = state.primitive_id as usize;
                    if let Some((t, b1, b2)) =
                        wt.intersect(origin, ray.tmin, obvhs_ray.tmax, &self.triangles[id])
                        && t < obvhs_ray.tmax
                    {
                        best = Hit {
                            t,
                            prim: id as u32,
                            b1,
                            b2,
                        };
                        if any_hit {
                            break 'traversal;
                        }
                        obvhs_ray.tmax = t;
                    }
                }
            );
        }
        (best, visits)
    }

    /// Uploads nodes (as-is) and triangles, and for [`Tracer::RayQuery`] (`ctx.tracer`) builds
    /// the acceleration structures; fails before creating any buffer when the scene exceeds the
    /// adapter's storage-binding, buffer or acceleration-structure limits.
    pub fn upload(&self, ctx: &GpuContext) -> Result<GpuBvh, TraceError> {
        let limits = ctx.limits();
        let limit = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let nodes: &[u8] = bytemuck::cast_slice(&self.cwbvh.nodes);
        let tris: &[u8] = bytemuck::cast_slice(&self.triangles);
        for (what, bytes) in [("BVH nodes", nodes.len()), ("triangles", tris.len())] {
            if bytes as u64 > limit {
                return Err(TraceError::TooLarge {
                    what,
                    bytes: bytes as u64,
                    limit,
                });
            }
        }
        let accel = match ctx.tracer {
            Tracer::Bvh => None,
            Tracer::RayQuery => Some(AccelStructures::build(ctx, &self.triangles)?),
        };
        Ok(GpuBvh {
            nodes: buffers::storage_from(&ctx.device, "bvh nodes", nodes),
            triangles: buffers::storage_from(&ctx.device, "bvh triangles", tris),
            node_count: self.cwbvh.nodes.len() as u32,
            triangle_count: self.triangles.len() as u32,
            accel,
        })
    }
}

/// The ray-query backend's acceleration structures: one BLAS over the triangles in BVH order
/// (so a hit's primitive index is its `bvh_triangles` index) in one identity instance.
#[derive(Debug)]
pub struct AccelStructures {
    pub blas: wgpu::Blas,
    pub tlas: wgpu::Tlas,
}

impl AccelStructures {
    /// Builds both (submits and waits).
    pub fn build(ctx: &GpuContext, triangles: &[BvhTriangle]) -> Result<Self, TraceError> {
        let limits = ctx.limits();
        let count = u32::try_from(triangles.len()).unwrap_or(u32::MAX);
        if u64::from(count) > u64::from(limits.max_blas_primitive_count) {
            return Err(TraceError::AccelLimit {
                what: "triangles in one bottom-level acceleration structure",
                needed: u64::from(count),
                limit: u64::from(limits.max_blas_primitive_count),
            });
        }
        let vertices: Vec<[f32; 3]> = triangles.iter().flat_map(|t| [t.v0, t.v1, t.v2]).collect();
        let bytes = (vertices.len() * 12) as u64;
        if bytes > limits.max_buffer_size {
            return Err(TraceError::TooLarge {
                what: "acceleration-structure vertices",
                bytes,
                limit: limits.max_buffer_size,
            });
        }
        let device = &ctx.device;
        let usage = wgpu::BufferUsages::BLAS_INPUT;
        let vertex_buffer = buffers::with_usage(device, "blas vertices", &vertices, usage);
        let size = wgpu::BlasTriangleGeometrySizeDescriptor {
            vertex_format: wgpu::VertexFormat::Float32x3,
            vertex_count: count * 3,
            index_format: None,
            index_count: None,
            flags: wgpu::AccelerationStructureGeometryFlags::OPAQUE,
        };
        let blas = device.create_blas(
            &wgpu::CreateBlasDescriptor {
                label: Some("scene blas"),
                flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
                update_mode: wgpu::AccelerationStructureUpdateMode::Build,
            },
            wgpu::BlasGeometrySizeDescriptors::Triangles {
                descriptors: vec![size.clone()],
            },
        );
        let mut tlas = device.create_tlas(&wgpu::CreateTlasDescriptor {
            label: Some("scene tlas"),
            max_instances: 1,
            flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
            update_mode: wgpu::AccelerationStructureUpdateMode::Build,
        });
        let identity = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        tlas[0] = Some(wgpu::TlasInstance::new(&blas, identity, 0, 0xff));
        let geometry = wgpu::BlasTriangleGeometry {
            size: &size,
            vertex_buffer: &vertex_buffer,
            first_vertex: 0,
            vertex_stride: 12,
            index_buffer: None,
            first_index: None,
            transform_buffer: None,
            transform_buffer_offset: None,
        };
        let entry = wgpu::BlasBuildEntry {
            blas: &blas,
            geometry: wgpu::BlasGeometries::TriangleGeometries(vec![geometry]),
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.build_acceleration_structures([&entry], [&tlas]);
        ctx.queue.submit([encoder.finish()]);
        ctx.wait().map_err(|e| TraceError::Gpu(e.to_string()))?;
        Ok(Self { blas, tlas })
    }
}

/// The BVH on the GPU.
#[derive(Debug)]
pub struct GpuBvh {
    pub nodes: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
    pub node_count: u32,
    pub triangle_count: u32,
    /// The ray-query backend's acceleration structures (uploaded for [`Tracer::RayQuery`]).
    pub accel: Option<AccelStructures>,
}

impl GpuBvh {
    /// The buffers of [`bindings`] for the backend it was uploaded for, by name.
    pub fn resources(&self) -> Vec<(&'static str, Resource<'_>)> {
        let first = match &self.accel {
            None => ("bvh_nodes", (&self.nodes).into()),
            Some(a) => ("bvh_accel", Resource::Accel(&a.tlas)),
        };
        vec![first, ("bvh_triangles", (&self.triangles).into())]
    }

    /// The backend it was uploaded for.
    pub fn tracer(&self) -> Tracer {
        match self.accel {
            None => Tracer::Bvh,
            Some(_) => Tracer::RayQuery,
        }
    }
}

/// The ray and hit buffers of [`TraceKernel`].
pub fn io_bindings() -> BindingSet {
    BindingSet::new("trace_rays io")
        .buffer("trace_rays_in", "array<Ray>", Access::Read)
        .buffer("trace_hits_out", "array<Hit>", Access::ReadWrite)
        .buffer("trace_params", "TraceParams", Access::Uniform)
}

/// The counting kernel's entry point: `trace_rays`, and each ray's [`Visits`] written beside
/// its hit (the software traversal only).
const COUNTED_KERNEL_WGSL: &str = "
@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays_counted(id: Invocation) {
    let i = item_index(id);
    if i >= trace_params.count { return; }
    bvh_visits = vec2<u32>(0u);
    trace_hits_out[i] = bvh_traverse(trace_rays_in[i], trace_params.any_hit != 0u);
    trace_counts_out[i] = bvh_visits;
}
";

/// The counting kernel's output: one [`Visits`] per ray.
fn counts_bindings() -> BindingSet {
    BindingSet::new("trace_rays counts").buffer(
        "trace_counts_out",
        "array<vec2<u32>>",
        Access::ReadWrite,
    )
}

/// Composed source of [`TraceKernel`] on `tracer`.
pub fn kernel_source(tracer: Tracer) -> String {
    compose(&kernel_modules(tracer)).expect("the tracer's modules compose")
}

fn kernel_modules(tracer: Tracer) -> Vec<WgslModule> {
    let mut m = modules(1, tracer);
    m.push(WgslModule::new("workgroup", &[], workgroup_size_wgsl()));
    m.push(WgslModule::new("trace-io", &[], io_bindings().wgsl(0)));
    m.push(WgslModule::new(
        "trace_rays",
        &["trace", "trace-io", "workgroup"],
        KERNEL_WGSL,
    ));
    m
}

/// Traces a buffer of [`Ray`]s into a buffer of [`Hit`]s (closest or any hit).
#[derive(Debug)]
pub struct TraceKernel {
    kernel: Kernel,
    io_layout: BindGroupLayout,
    bvh_layout: BindGroupLayout,
    /// [`TraceKernel::counting`]'s output layout.
    counts_layout: Option<BindGroupLayout>,
}

impl TraceKernel {
    /// The kernel on `tracer` (bind BVHs uploaded for the same tracer).
    pub fn new(device: &wgpu::Device, tracer: Tracer) -> Self {
        let io_layout = io_bindings().layout(device);
        let bvh_layout = bindings(tracer).layout(device);
        let kernel = Kernel::new(
            device,
            "trace_rays",
            &kernel_source(tracer),
            &[&io_layout, &bvh_layout],
            &["trace_rays"],
        );
        Self {
            kernel,
            io_layout,
            bvh_layout,
            counts_layout: None,
        }
    }

    /// The software traversal's kernel that also counts what each ray visited
    /// ([`TraceKernel::bind_counted`]): the GPU side of the traversal counts that
    /// [`Bvh::traverse`] gives on the CPU.
    pub fn counting(device: &wgpu::Device) -> Self {
        let io_layout = io_bindings().layout(device);
        let bvh_layout = bindings(Tracer::Bvh).layout(device);
        let counts_layout = counts_bindings().layout(device);
        let mut m = kernel_modules(Tracer::Bvh);
        m.push(WgslModule::new(
            "trace-counts",
            &[],
            counts_bindings().wgsl(2),
        ));
        m.push(WgslModule::new(
            "trace_rays_counted",
            &["trace_rays", "trace-counts"],
            COUNTED_KERNEL_WGSL,
        ));
        let source = compose(&m).expect("the counting kernel's modules compose");
        let kernel = Kernel::new(
            device,
            "trace_rays_counted",
            &source,
            &[&io_layout, &bvh_layout, &counts_layout],
            &["trace_rays_counted"],
        );
        Self {
            kernel,
            io_layout,
            bvh_layout,
            counts_layout: Some(counts_layout),
        }
    }

    /// The dispatch of `count` rays from `rays` into `hits`; record it with
    /// [`Self::encode_with`] as often as needed.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        bvh: &GpuBvh,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        count: u32,
        any_hit: bool,
    ) -> Result<TraceBinding, GpuError> {
        self.bind_with(device, bvh, (rays, hits, None), count, any_hit)
    }

    /// [`Self::bind`] of a [`TraceKernel::counting`] kernel, each ray's [`Visits`] into
    /// `counts`.
    #[allow(clippy::too_many_arguments)]
    pub fn bind_counted(
        &self,
        device: &wgpu::Device,
        bvh: &GpuBvh,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        counts: &wgpu::Buffer,
        count: u32,
        any_hit: bool,
    ) -> Result<TraceBinding, GpuError> {
        self.bind_with(device, bvh, (rays, hits, Some(counts)), count, any_hit)
    }

    fn bind_with(
        &self,
        device: &wgpu::Device,
        bvh: &GpuBvh,
        (rays, hits, counts): (&wgpu::Buffer, &wgpu::Buffer, Option<&wgpu::Buffer>),
        count: u32,
        any_hit: bool,
    ) -> Result<TraceBinding, GpuError> {
        let params = buffers::with_usage(
            device,
            "trace_rays params",
            &[count, u32::from(any_hit), 0, 0],
            wgpu::BufferUsages::UNIFORM,
        );
        let io = self.io_layout.bind(
            device,
            [
                ("trace_rays_in", rays.into()),
                ("trace_hits_out", hits.into()),
                ("trace_params", (&params).into()),
            ],
        )?;
        let bvh = self.bvh_layout.bind(device, bvh.resources())?;
        let (entry, groups) = match (&self.counts_layout, counts) {
            (None, None) => ("trace_rays", vec![io, bvh]),
            (Some(layout), Some(counts)) => {
                let out = layout.bind(device, [("trace_counts_out", counts.into())])?;
                ("trace_rays_counted", vec![io, bvh, out])
            }
            _ => {
                return Err(GpuError::Binding(
                    "a counting trace kernel binds with bind_counted, the other with bind".into(),
                ));
            }
        };
        let groups: Vec<&wgpu::BindGroup> = groups.iter().collect();
        Ok(TraceBinding(
            self.kernel.pass(device, entry, &groups, count),
        ))
    }

    /// Records the trace of a bound dispatch.
    pub fn encode_with(&self, encoder: &mut wgpu::CommandEncoder, binding: &TraceBinding) {
        binding.0.record(encoder);
    }

    /// Records the trace of `count` rays from `rays` into `hits`.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        bvh: &GpuBvh,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        count: u32,
        any_hit: bool,
    ) -> Result<(), GpuError> {
        let binding = self.bind(device, bvh, rays, hits, count, any_hit)?;
        self.encode_with(encoder, &binding);
        Ok(())
    }
}

/// One bound [`TraceKernel`] dispatch.
#[derive(Debug)]
pub struct TraceBinding(Pass);

/// The WGSL modules of the tracer, composed as used.
pub fn wgsl_modules() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for tracer in [Tracer::Bvh, Tracer::RayQuery] {
        let name = tracer.name();
        let library = compose(&modules(1, tracer)).expect("the tracer's modules compose");
        out.push((format!("restir-world/trace/{name}"), library));
        out.push((
            format!("restir-world/trace_rays/{name}"),
            kernel_source(tracer),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::offset_of;

    #[test]
    fn node_mirror_matches_obvhs_layout() {
        assert_eq!(offset_of!(BvhNode, p), offset_of!(CwBvhNode, p));
        assert_eq!(offset_of!(BvhNode, e_imask), offset_of!(CwBvhNode, e));
        assert_eq!(offset_of!(CwBvhNode, imask), offset_of!(CwBvhNode, e) + 3);
        // The fields both structs name alike sit at the same offsets.
        macro_rules! same_offsets {
            ($($field:ident),*) => {
                $(assert_eq!(
                    offset_of!(BvhNode, $field),
                    offset_of!(CwBvhNode, $field),
                    stringify!($field)
                );)*
            };
        }
        same_offsets!(
            child_base_idx,
            primitive_base_idx,
            child_meta,
            child_min_x,
            child_max_x,
            child_min_y,
            child_max_y,
            child_min_z,
            child_max_z
        );
    }

    /// Rays through points of the diagonal edge two triangles share (points where x + y
    /// rounds to 1 either way) hit at least one of them from both sides: the watertight test
    /// never lets a ray slip between them. Control: the same rays moved off the quad hit
    /// nothing, so the count can fail.
    #[test]
    fn watertight_never_lets_a_ray_through_a_shared_edge() {
        let t0 = BvhTriangle {
            v0: [0.0, 0.0, 0.0],
            material: 0,
            v1: [1.0, 0.0, 0.0],
            index: 0,
            v2: [0.0, 1.0, 0.0],
            flags: 0,
        };
        let t1 = BvhTriangle {
            v0: [1.0, 0.0, 0.0],
            v1: [1.0, 1.0, 0.0],
            v2: [0.0, 1.0, 0.0],
            ..t0
        };
        let hits = |origin: Vec3, dir: Vec3| {
            let wt = Watertight::new(dir);
            [t0, t1]
                .iter()
                .filter(|t| wt.intersect(origin, 0.0, f32::INFINITY, t).is_some())
                .count()
        };
        for i in 1..1000 {
            let x = i as f32 / 1000.0;
            for dz in [-1.0f32, 1.0] {
                let dir = Vec3::new(0.0, 0.0, dz);
                let on_edge = Vec3::new(x, 1.0 - x, -dz);
                let n = hits(on_edge, dir);
                assert!((1..=2).contains(&n), "{n} hits at x {x} (dz {dz})");
                let off_quad = Vec3::new(x + 1.0, 1.0 - x, -dz);
                assert_eq!(hits(off_quad, dir), 0, "phantom hit at x {x}");
            }
        }
    }
}
