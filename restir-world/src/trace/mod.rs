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
    ray::{Ray as ObvhsRay, RayHit},
};

use crate::gpu::{
    Access, BindGroupLayout, BindingSet, Kernel, Pass, Resource, WgslModule, buffers, compose,
    workgroup_size_wgsl,
};
use crate::scene::Scene;
use crate::{GpuContext, GpuError};

/// The traversal library (structs and functions, no bindings).
pub const WGSL: &str = include_str!("trace.wgsl");
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

/// The BVH's bindings: `bvh_nodes` and `bvh_triangles`.
pub fn bindings() -> BindingSet {
    BindingSet::new("bvh")
        .buffer("bvh_nodes", "array<BvhNode>", Access::Read)
        .buffer("bvh_triangles", "array<BvhTriangle>", Access::Read)
}

/// The tracer's WGSL modules with its bindings at `group`: `bvh-constants`, `bvh-bindings`
/// and `trace` (structs `BvhNode`, `BvhTriangle`, `Ray`, `Hit`; functions `trace_closest`,
/// `trace_any`, `bvh_traverse`).
pub fn modules(group: u32) -> Vec<WgslModule> {
    vec![
        WgslModule::new("bvh-constants", &[], constants_wgsl()),
        WgslModule::new("bvh-bindings", &[], bindings().wgsl(group)),
        WgslModule::new("trace", &["bvh-constants", "bvh-bindings"], WGSL),
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
        let wt = Watertight::new(Vec3::from(ray.dir));
        let origin = Vec3::from(ray.origin);
        let mut best = Hit {
            t: ray.tmax,
            prim: NO_HIT,
            b1: 0.0,
            b2: 0.0,
        };
        let mut hit = RayHit::none();
        self.cwbvh
            .ray_traverse(Self::obvhs_ray(ray), &mut hit, |r, id| {
                match wt.intersect(origin, ray.tmin, r.tmax, &self.triangles[id]) {
                    Some((t, b1, b2)) if t < r.tmax => {
                        best = Hit {
                            t,
                            prim: id as u32,
                            b1,
                            b2,
                        };
                        t
                    }
                    _ => f32::INFINITY,
                }
            });
        best
    }

    /// Whether anything blocks the ray within [tmin, tmax] (twin of `trace_any`).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        let wt = Watertight::new(Vec3::from(ray.dir));
        let origin = Vec3::from(ray.origin);
        !self.cwbvh.ray_traverse_miss(Self::obvhs_ray(ray), |r, id| {
            match wt.intersect(origin, ray.tmin, r.tmax, &self.triangles[id]) {
                Some((t, _, _)) => t,
                None => f32::INFINITY,
            }
        })
    }

    /// Uploads nodes (as-is) and triangles; fails before creating any buffer when either is
    /// larger than the adapter's storage-binding or buffer limits.
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
        Ok(GpuBvh {
            nodes: buffers::storage_from(&ctx.device, "bvh nodes", nodes),
            triangles: buffers::storage_from(&ctx.device, "bvh triangles", tris),
            node_count: self.cwbvh.nodes.len() as u32,
            triangle_count: self.triangles.len() as u32,
        })
    }
}

/// The BVH on the GPU.
#[derive(Debug)]
pub struct GpuBvh {
    pub nodes: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
    pub node_count: u32,
    pub triangle_count: u32,
}

impl GpuBvh {
    /// The buffers of [`bindings`], by name.
    pub fn resources(&self) -> [(&'static str, Resource<'_>); 2] {
        [
            ("bvh_nodes", (&self.nodes).into()),
            ("bvh_triangles", (&self.triangles).into()),
        ]
    }
}

/// The ray and hit buffers of [`TraceKernel`].
pub fn io_bindings() -> BindingSet {
    BindingSet::new("trace_rays io")
        .buffer("trace_rays_in", "array<Ray>", Access::Read)
        .buffer("trace_hits_out", "array<Hit>", Access::ReadWrite)
        .buffer("trace_params", "TraceParams", Access::Uniform)
}

/// Composed source of [`TraceKernel`].
pub fn kernel_source() -> String {
    let mut m = modules(1);
    m.push(WgslModule::new("workgroup", &[], workgroup_size_wgsl()));
    m.push(WgslModule::new("trace-io", &[], io_bindings().wgsl(0)));
    m.push(WgslModule::new(
        "trace_rays",
        &["trace", "trace-io", "workgroup"],
        KERNEL_WGSL,
    ));
    compose(&m).expect("the tracer's modules compose")
}

/// Traces a buffer of [`Ray`]s into a buffer of [`Hit`]s (closest or any hit).
#[derive(Debug)]
pub struct TraceKernel {
    kernel: Kernel,
    io_layout: BindGroupLayout,
    bvh_layout: BindGroupLayout,
}

impl TraceKernel {
    pub fn new(device: &wgpu::Device) -> Self {
        let io_layout = io_bindings().layout(device);
        let bvh_layout = bindings().layout(device);
        let kernel = Kernel::new(
            device,
            "trace_rays",
            &kernel_source(),
            &[&io_layout, &bvh_layout],
            &["trace_rays"],
        );
        Self {
            kernel,
            io_layout,
            bvh_layout,
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
        Ok(TraceBinding(self.kernel.pass(
            device,
            "trace_rays",
            &[&io, &bvh],
            count,
        )))
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
    vec![
        (
            "restir-world/trace".into(),
            compose(&modules(1)).expect("the tracer's modules compose"),
        ),
        ("restir-world/trace_rays".into(), kernel_source()),
    ]
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
        assert_eq!(
            offset_of!(BvhNode, child_base_idx),
            offset_of!(CwBvhNode, child_base_idx)
        );
        assert_eq!(
            offset_of!(BvhNode, primitive_base_idx),
            offset_of!(CwBvhNode, primitive_base_idx)
        );
        assert_eq!(
            offset_of!(BvhNode, child_meta),
            offset_of!(CwBvhNode, child_meta)
        );
        assert_eq!(
            offset_of!(BvhNode, child_min_x),
            offset_of!(CwBvhNode, child_min_x)
        );
        assert_eq!(
            offset_of!(BvhNode, child_max_x),
            offset_of!(CwBvhNode, child_max_x)
        );
        assert_eq!(
            offset_of!(BvhNode, child_min_y),
            offset_of!(CwBvhNode, child_min_y)
        );
        assert_eq!(
            offset_of!(BvhNode, child_max_y),
            offset_of!(CwBvhNode, child_max_y)
        );
        assert_eq!(
            offset_of!(BvhNode, child_min_z),
            offset_of!(CwBvhNode, child_min_z)
        );
        assert_eq!(
            offset_of!(BvhNode, child_max_z),
            offset_of!(CwBvhNode, child_max_z)
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
