//! The kit a stage above the renderer is built from: the shared bind groups, a stage's kernel
//! declarations ([`KernelDef`]) and what every reuse pass binds.

use super::library::{compose_with_library, shared_bindings};
use crate::gpu::{
    Access, BindGroupLayout, BindingSet, Constants, GpuContext, GpuError, Kernel, KernelCache,
    Pass, Resource, Tracer, WgslModule, buffers,
};

/// The shared bind groups (render buffers, tracer, lights) with their layouts, the tracer
/// and the frame's pixel count: what a pixel pass is made from.
#[derive(Debug, Clone)]
pub struct SharedGroups {
    pub layouts: [BindGroupLayout; 3],
    pub groups: [wgpu::BindGroup; 3],
    pub tracer: Tracer,
    pub pixels: u32,
    /// Where its kernels come from: the context's, so that a build again reuses them.
    pub kernels: KernelCache,
    /// Whether the scene has glossy materials: its kernels are specialized with the render
    /// library's `RENDER_GLOSSY` (a diffuse scene's kernels are today's, with no BRDF code).
    pub glossy: bool,
    /// Whether a triangle has a normal map (its material's normal texture, its tangents:
    /// `render::ATTR_TANGENTS`): its kernels are specialized with the render library's
    /// `RENDER_NORMAL_MAPS` (a scene without is shaded by kernels that fold the normal map's
    /// branch away).
    pub normal_maps: bool,
    /// Whether a test's negative control planted a defect ([`crate::plant`]): its kernels
    /// are specialized with `RENDER_PLANTED`, which the library's own builds never set, so
    /// their planted branches are compiled out.
    pub planted: bool,
}

impl SharedGroups {
    /// A kernel over the shared layouts (+ `own`, bound at group 3) composed from the
    /// [`super::library()`] and `modules`.
    pub fn kernel(
        &self,
        device: &wgpu::Device,
        label: &str,
        modules: Vec<WgslModule>,
        own: Option<&BindGroupLayout>,
        entry_points: &[&str],
    ) -> Kernel {
        let mut layouts: Vec<&BindGroupLayout> = self.layouts.iter().collect();
        layouts.extend(own);
        let source = compose_with_library(self.tracer, modules);
        let overrides: Vec<(&str, f64)> = [
            ("RENDER_GLOSSY", self.glossy),
            ("RENDER_NORMAL_MAPS", self.normal_maps),
            ("RENDER_PLANTED", self.planted),
        ]
        .into_iter()
        .filter_map(|(name, on)| on.then_some((name, 1.0)))
        .collect();
        let constants = Constants {
            workgroup_size: crate::gpu::WORKGROUP_SIZE,
            overrides: &overrides,
        };
        self.kernels
            .kernel(device, label, &source, &layouts, entry_points, constants)
    }

    /// A kernel with its own group-3 bindings `own`, after checking that the stage's storage
    /// buffers (shared + own) fit the device: the kernel and `own`'s layout.
    pub fn own_kernel(
        &self,
        ctx: &GpuContext,
        label: &str,
        own: &BindingSet,
        modules: Vec<WgslModule>,
        entry_points: &[&str],
    ) -> Result<(Kernel, BindGroupLayout), GpuError> {
        let sets = shared_bindings(self.tracer);
        ctx.check_storage_buffers(label, &[&sets[0], &sets[1], &sets[2], own])?;
        let layout = own.layout(&ctx.device);
        let kernel = self.kernel(&ctx.device, label, modules, Some(&layout), entry_points);
        Ok((kernel, layout))
    }

    /// A pass of `entry` of `kernel` over `items` invocations (`None`: every pixel), its own
    /// group 3 bound to `resources` by name.
    pub fn bound_pass(
        &self,
        device: &wgpu::Device,
        (kernel, layout): &OwnKernel,
        entry: &str,
        resources: Vec<(&str, Resource)>,
        items: Option<u32>,
    ) -> Result<Pass, GpuError> {
        let group = layout.bind(device, resources)?;
        let items = items.unwrap_or(self.pixels);
        Ok(self.pass_over(device, kernel, entry, Some(&group), items))
    }

    /// A pass of `entry` over every pixel with the shared groups (+ `own` at group 3).
    pub fn pass(
        &self,
        device: &wgpu::Device,
        kernel: &Kernel,
        entry: &str,
        own: Option<&wgpu::BindGroup>,
    ) -> Pass {
        self.pass_over(device, kernel, entry, own, self.pixels)
    }

    /// A pass of `entry` over `items` invocations with the shared groups (+ `own`).
    pub fn pass_over(
        &self,
        device: &wgpu::Device,
        kernel: &Kernel,
        entry: &str,
        own: Option<&wgpu::BindGroup>,
        items: u32,
    ) -> Pass {
        let mut groups: Vec<&wgpu::BindGroup> = self.groups.iter().collect();
        groups.extend(own);
        kernel.pass(device, entry, &groups, items)
    }
}

/// The group a stage's kernels bind their own buffers at (0..3 are the renderer's: see
/// [`SharedGroups`]).
pub const STAGE_GROUP: u32 = 3;

/// A buffer a kernel binds: name, WGSL type, access.
pub type Buffer = (&'static str, &'static str, Access);

/// One kernel module of a stage above the renderer: its WGSL file, entry points and own
/// group-3 buffers, in runs (e.g. the stage's parameters, then [`REUSE_IO`], then its own).
/// Each stage composes it after the render library with its own library modules
/// ([`SharedGroups::own_kernel`]).
#[derive(Debug)]
pub struct KernelDef {
    pub name: &'static str,
    pub entries: &'static [&'static str],
    pub source: &'static str,
    pub own: &'static [&'static [Buffer]],
}

impl KernelDef {
    pub const fn new(
        name: &'static str,
        entries: &'static [&'static str],
        source: &'static str,
        own: &'static [&'static [Buffer]],
    ) -> Self {
        Self {
            name,
            entries,
            source,
            own,
        }
    }

    /// Its group-3 buffers, in binding order.
    pub fn buffers(&self) -> impl Iterator<Item = &Buffer> {
        self.own.iter().flat_map(|run| run.iter())
    }

    /// Its group-3 bindings.
    pub fn bindings(&self) -> BindingSet {
        let buffers: Vec<Buffer> = self.buffers().copied().collect();
        BindingSet::of_buffers(self.name, &buffers)
    }

    /// Whether it binds buffer `name`.
    pub fn binds(&self, name: &str) -> bool {
        self.buffers().any(|(n, _, _)| *n == name)
    }
}

/// The stored reservoirs of the reuse methods, as their kernels bind them.
pub const RESERVOIRS: &str = "array<StoredReservoir>";

/// What every reuse pass binds after its stage's parameters: the pass's own uniform
/// ([`ReusePass`]), the source reservoirs it merges, the receivers' own reservoirs and where it
/// writes, each an array of `reservoirs` (the stage's WGSL reservoir array type).
pub const fn reuse_io(reservoirs: &'static str) -> [Buffer; 4] {
    [
        ("reuse_pass", "ReusePass", Access::Read),
        ("reuse_src", reservoirs, Access::Read),
        ("reuse_self", reservoirs, Access::Read),
        ("reuse_out", reservoirs, Access::ReadWrite),
    ]
}

/// [`reuse_io`] of the stored light reservoirs.
pub const REUSE_IO: &[Buffer] = &reuse_io(RESERVOIRS);

/// WGSL `ReusePass`: per reuse pass, whether it reads last frame's reservoirs (`temporal` = 1)
/// and its index among the stage's passes (mixed into its random stream).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReusePass {
    pub temporal: u32,
    pub pass_index: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

impl ReusePass {
    /// The uniform of a reuse pass (a storage buffer, read-only).
    pub fn buffer(device: &wgpu::Device, temporal: bool, pass_index: u32) -> wgpu::Buffer {
        let u = Self {
            temporal: u32::from(temporal),
            pass_index,
            ..Default::default()
        };
        buffers::with_usage(device, "reuse pass", &[u], wgpu::BufferUsages::STORAGE)
    }
}

/// A created kernel with the layout of its own group-3 buffers.
pub type OwnKernel = (Kernel, BindGroupLayout);
