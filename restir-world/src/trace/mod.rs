//! Ray tracing: an obvhs compressed wide BVH8 (medium build preset) built on the CPU and
//! uploaded as-is, full-f32 triangles in BVH primitive order, and our own WGSL traversal
//! (closest hit and any hit, watertight triangle test).
//!
//! The CPU twin ([`Bvh::closest_hit`], [`Bvh::any_hit`]) runs obvhs's own CPU traversal with the
//! same watertight triangle test, so GPU results can be compared hit for hit.
//!
//! WGSL composition (see the crate docs): a consumer concatenates [`constants_wgsl`],
//! [`bindings_wgsl`] (declares `bvh_nodes`, `bvh_triangles`), [`WGSL`] (structs `BvhNode`,
//! `BvhTriangle`, `Ray`, `Hit`; functions `trace_closest`, `trace_any`, `bvh_traverse`) and its own
//! kernel. [`TraceKernel`] is the standalone "trace a buffer of rays" kernel used by the tests
//! and the benchmark.

use std::time::{Duration, Instant};

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris, node::CwBvhNode},
    ray::{Ray as ObvhsRay, RayHit},
};

use crate::GpuContext;
use crate::gpu::buffers;
use crate::scene::Scene;

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
/// Workgroup size of [`TraceKernel`].
pub const WORKGROUP_SIZE: u32 = 64;

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

/// Declares `bvh_nodes` and `bvh_triangles` at `@group(group) @binding(first_binding + 0/1)`.
pub fn bindings_wgsl(group: u32, first_binding: u32) -> String {
    format!(
        "@group({group}) @binding({}) var<storage, read> bvh_nodes: array<BvhNode>;\n\
         @group({group}) @binding({}) var<storage, read> bvh_triangles: array<BvhTriangle>;\n",
        first_binding,
        first_binding + 1
    )
}

/// Layout entries matching [`bindings_wgsl`] (visible to compute).
pub fn bind_group_layout_entries(first_binding: u32) -> Vec<wgpu::BindGroupLayoutEntry> {
    (0..2)
        .map(|i| crate::gpu::buffers::storage_entry(first_binding + i, true))
        .collect()
}

/// The library as a consumer composes it (constants + bindings at group 1 + library).
pub fn composed_library(group: u32, first_binding: u32) -> String {
    format!(
        "{}{}{}",
        constants_wgsl(),
        bindings_wgsl(group, first_binding),
        WGSL
    )
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
    /// Bind group entries matching [`bind_group_layout_entries`].
    pub fn bind_group_entries(&self, first_binding: u32) -> Vec<wgpu::BindGroupEntry<'_>> {
        vec![
            wgpu::BindGroupEntry {
                binding: first_binding,
                resource: self.nodes.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: first_binding + 1,
                resource: self.triangles.as_entire_binding(),
            },
        ]
    }
}

/// Composed source of [`TraceKernel`].
pub fn kernel_source() -> String {
    format!("{}{}", composed_library(1, 0), KERNEL_WGSL)
}

/// Traces a buffer of [`Ray`]s into a buffer of [`Hit`]s (closest or any hit).
#[derive(Debug)]
pub struct TraceKernel {
    pipeline: wgpu::ComputePipeline,
    params_layout: wgpu::BindGroupLayout,
    bvh_layout: wgpu::BindGroupLayout,
}

impl TraceKernel {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("trace_rays"),
            source: wgpu::ShaderSource::Wgsl(kernel_source().into()),
        });
        let storage = crate::gpu::buffers::storage_entry;
        let params_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("trace_rays io"),
            entries: &[
                storage(0, true),
                storage(1, false),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let bvh_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("bvh"),
            entries: &bind_group_layout_entries(0),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("trace_rays"),
            bind_group_layouts: &[Some(&params_layout), Some(&bvh_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("trace_rays"),
            layout: Some(&layout),
            module: &module,
            entry_point: Some("trace_rays"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &[("WORKGROUP_SIZE", f64::from(WORKGROUP_SIZE))],
                ..Default::default()
            },
            cache: None,
        });
        Self {
            pipeline,
            params_layout,
            bvh_layout,
        }
    }

    /// Bind groups for one ray/hit buffer pair; reuse them across [`Self::encode_with`] calls.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        bvh: &GpuBvh,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        count: u32,
        any_hit: bool,
    ) -> TraceBinding {
        let params = buffers::with_usage(
            device,
            "trace_rays params",
            &[count, u32::from(any_hit), 0, 0],
            wgpu::BufferUsages::UNIFORM,
        );
        let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("trace_rays io"),
            layout: &self.params_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: rays.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: hits.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: params.as_entire_binding(),
                },
            ],
        });
        let bvh_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("bvh"),
            layout: &self.bvh_layout,
            entries: &bvh.bind_group_entries(0),
        });
        TraceBinding {
            io,
            bvh: bvh_group,
            count,
        }
    }

    /// Records the trace of `binding.count` rays.
    pub fn encode_with(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        binding: &TraceBinding,
    ) {
        let max = device.limits().max_compute_workgroups_per_dimension;
        let (x, y) = dispatch_2d(binding.count.div_ceil(WORKGROUP_SIZE), max);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("trace_rays"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &binding.io, &[]);
        pass.set_bind_group(1, &binding.bvh, &[]);
        pass.dispatch_workgroups(x, y, 1);
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
    ) {
        let binding = self.bind(device, bvh, rays, hits, count, any_hit);
        self.encode_with(device, encoder, &binding);
    }
}

/// Splits `groups` workgroups into an `(x, y)` dispatch within `max_per_dim` per dimension;
/// kernels recover the linear index as `gid.x + gid.y * num_workgroups.x * WORKGROUP_SIZE`.
pub fn dispatch_2d(groups: u32, max_per_dim: u32) -> (u32, u32) {
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

/// Bind groups of one [`TraceKernel`] dispatch.
#[derive(Debug)]
pub struct TraceBinding {
    io: wgpu::BindGroup,
    bvh: wgpu::BindGroup,
    count: u32,
}

/// The WGSL modules of the tracer, composed as used.
pub fn wgsl_modules() -> Vec<(String, String)> {
    vec![
        ("restir-world/trace".into(), composed_library(1, 0)),
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

    #[test]
    fn watertight_hits_a_shared_edge_once_from_both_sides() {
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
        for dz in [-1.0f32, 1.0] {
            let origin = Vec3::new(0.5, 0.5, -dz);
            let wt = Watertight::new(Vec3::new(0.0, 0.0, dz));
            let hits = [t0, t1]
                .iter()
                .filter(|t| wt.intersect(origin, 0.0, f32::INFINITY, t).is_some())
                .count();
            assert!(hits >= 1, "ray through the shared edge leaked (dz {dz})");
        }
    }
}
