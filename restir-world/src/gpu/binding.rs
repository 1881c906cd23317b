//! [`BindingSet`]: one declaration of a bind group's buffers (name, WGSL type, access) that
//! yields the WGSL header, the bind-group layout and a bind call checked by name.

use super::GpuError;

/// How a kernel accesses a buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    Uniform,
    Read,
    ReadWrite,
}

impl Access {
    fn wgsl(self) -> &'static str {
        match self {
            Access::Uniform => "uniform",
            Access::Read => "storage, read",
            Access::ReadWrite => "storage, read_write",
        }
    }

    fn buffer_type(self) -> wgpu::BufferBindingType {
        match self {
            Access::Uniform => wgpu::BufferBindingType::Uniform,
            Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
            Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
        }
    }
}

/// One declared binding: a named buffer, or a block of consecutive bindings whose WGSL a
/// primitive crate declares itself (gpu-hash's table and lookup roles).
#[derive(Debug, Clone)]
enum Slot {
    Buffer {
        name: String,
        ty: String,
        access: Access,
    },
    Block {
        name: String,
        entries: Vec<wgpu::BindGroupLayoutEntry>,
    },
    /// A top-level acceleration structure (ray queries).
    Accel { name: String },
}

impl Slot {
    fn name(&self) -> &str {
        match self {
            Slot::Buffer { name, .. } | Slot::Block { name, .. } | Slot::Accel { name } => name,
        }
    }
}

/// The buffers of one bind group, declared once: [`BindingSet::wgsl`] is the WGSL header,
/// [`BindingSet::layout`] the bind-group layout and [`BindGroupLayout::bind`] binds buffers by
/// name (a missing, unknown or repeated name is an error, never a silent misbinding).
///
/// ```
/// use restir_world::gpu::{Access, BindingSet};
/// let set = BindingSet::new("example")
///     .buffer("params", "Params", Access::Uniform)
///     .buffer("out", "array<u32>", Access::ReadWrite);
/// assert_eq!(
///     set.wgsl(3),
///     "@group(3) @binding(0) var<uniform> params: Params;\n\
///      @group(3) @binding(1) var<storage, read_write> out: array<u32>;\n"
/// );
/// ```
#[derive(Debug, Clone)]
pub struct BindingSet {
    label: String,
    slots: Vec<Slot>,
}

impl BindingSet {
    pub fn new(label: &str) -> Self {
        Self {
            label: label.to_owned(),
            slots: Vec::new(),
        }
    }

    /// A set of the buffers `(name, WGSL type, access)`, in order.
    pub fn of_buffers(label: &str, buffers: &[(&str, &str, Access)]) -> Self {
        buffers
            .iter()
            .fold(Self::new(label), |set, (name, ty, access)| {
                set.buffer(name, ty, *access)
            })
    }

    /// Declares the next binding: a buffer named `name` of WGSL type `ty`.
    pub fn buffer(mut self, name: &str, ty: &str, access: Access) -> Self {
        self.slots.push(Slot::Buffer {
            name: name.to_owned(),
            ty: ty.to_owned(),
            access,
        });
        self
    }

    /// Declares the next binding: a top-level acceleration structure named `name` (needs
    /// `Features::EXPERIMENTAL_RAY_QUERY`).
    pub fn accel(mut self, name: &str) -> Self {
        self.slots.push(Slot::Accel {
            name: name.to_owned(),
        });
        self
    }

    /// Declares a block of bindings from the next binding on, whose WGSL a primitive crate
    /// declares (`layout` gives its entries from [`BindingSet::next_binding`]); bound as one
    /// name with the primitive's own bind-group entries.
    pub fn block(
        mut self,
        name: &str,
        layout: impl FnOnce(u32) -> Vec<wgpu::BindGroupLayoutEntry>,
    ) -> Self {
        let entries = layout(self.next_binding());
        self.slots.push(Slot::Block {
            name: name.to_owned(),
            entries,
        });
        self
    }

    /// The binding number the next declaration gets.
    pub fn next_binding(&self) -> u32 {
        self.slots
            .iter()
            .map(|s| match s {
                Slot::Buffer { .. } | Slot::Accel { .. } => 1,
                Slot::Block { entries, .. } => entries.len() as u32,
            })
            .sum()
    }

    /// The WGSL declarations of the buffers (not of the blocks) at `group`.
    pub fn wgsl(&self, group: u32) -> String {
        let mut binding = 0;
        let mut out = String::new();
        for slot in &self.slots {
            match slot {
                Slot::Buffer { name, ty, access } => {
                    out.push_str(&format!(
                        "@group({group}) @binding({binding}) var<{}> {name}: {ty};\n",
                        access.wgsl()
                    ));
                    binding += 1;
                }
                Slot::Accel { name } => {
                    out.push_str(&format!(
                        "@group({group}) @binding({binding}) var {name}: acceleration_structure;\n"
                    ));
                    binding += 1;
                }
                Slot::Block { entries, .. } => binding += entries.len() as u32,
            }
        }
        out
    }

    /// The name bound at each binding, in binding order (`None` for a block's bindings, whose
    /// WGSL the block's crate declares).
    pub fn binding_names(&self) -> Vec<Option<&str>> {
        let mut out = Vec::new();
        for slot in &self.slots {
            match slot {
                Slot::Buffer { name, .. } | Slot::Accel { name } => out.push(Some(name.as_str())),
                Slot::Block { entries, .. } => out.extend(entries.iter().map(|_| None)),
            }
        }
        out
    }

    /// The layout entries, in binding order.
    pub fn layout_entries(&self) -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut binding = 0;
        let mut out = Vec::new();
        for slot in &self.slots {
            match slot {
                Slot::Buffer { access, .. } => {
                    out.push(super::buffers::layout_entry(binding, access.buffer_type()));
                    binding += 1;
                }
                Slot::Accel { .. } => {
                    out.push(wgpu::BindGroupLayoutEntry {
                        binding,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::AccelerationStructure {
                            vertex_return: false,
                        },
                        count: None,
                    });
                    binding += 1;
                }
                Slot::Block { entries, .. } => {
                    binding += entries.len() as u32;
                    out.extend(entries.iter().cloned());
                }
            }
        }
        out
    }

    /// Storage buffers the set declares (what `max_storage_buffers_per_shader_stage` counts).
    pub fn storage_buffers(&self) -> u32 {
        count_storage_buffers(&self.layout_entries())
    }

    /// Creates the layout on `device`.
    pub fn layout(&self, device: &wgpu::Device) -> BindGroupLayout {
        BindGroupLayout {
            layout: device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&self.label),
                entries: &self.layout_entries(),
            }),
            set: self.clone(),
        }
    }
}

/// Storage buffers among layout entries.
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

/// What one name is bound to.
#[derive(Debug)]
pub enum Resource<'a> {
    /// A whole buffer.
    Buffer(&'a wgpu::Buffer),
    /// A block's entries, as the primitive crate makes them for its first binding.
    Block(Vec<wgpu::BindGroupEntry<'a>>),
    /// A top-level acceleration structure.
    Accel(&'a wgpu::Tlas),
}

impl<'a> From<&'a wgpu::Buffer> for Resource<'a> {
    fn from(b: &'a wgpu::Buffer) -> Self {
        Resource::Buffer(b)
    }
}

/// A created [`BindingSet`] layout, which binds by name.
#[derive(Debug, Clone)]
pub struct BindGroupLayout {
    pub layout: wgpu::BindGroupLayout,
    set: BindingSet,
}

impl BindGroupLayout {
    /// Its entries, as created.
    pub fn entries(&self) -> Vec<wgpu::BindGroupLayoutEntry> {
        self.set.layout_entries()
    }

    /// A bind group with each declared name bound to its resource. Every declared name must
    /// be given exactly once and no other name: otherwise an error naming it.
    pub fn bind<'a>(
        &self,
        device: &wgpu::Device,
        resources: impl IntoIterator<Item = (&'a str, Resource<'a>)>,
    ) -> Result<wgpu::BindGroup, GpuError> {
        let bad =
            |msg: String| GpuError::Binding(format!("bind group {:?}: {msg}", self.set.label));
        let mut given: Vec<(&str, Resource<'_>)> = resources.into_iter().collect();
        let mut entries = Vec::new();
        let mut binding = 0u32;
        for slot in &self.set.slots {
            let at = given
                .iter()
                .position(|(n, _)| *n == slot.name())
                .ok_or_else(|| bad(format!("{:?} is not bound", slot.name())))?;
            let (name, resource) = given.swap_remove(at);
            if given.iter().any(|(n, _)| *n == name) {
                return Err(bad(format!("{name:?} is bound twice")));
            }
            match (slot, resource) {
                (Slot::Buffer { .. }, Resource::Buffer(b)) => {
                    entries.push(wgpu::BindGroupEntry {
                        binding,
                        resource: b.as_entire_binding(),
                    });
                    binding += 1;
                }
                (Slot::Accel { .. }, Resource::Accel(tlas)) => {
                    entries.push(wgpu::BindGroupEntry {
                        binding,
                        resource: wgpu::BindingResource::AccelerationStructure(tlas),
                    });
                    binding += 1;
                }
                (
                    Slot::Block {
                        entries: layout, ..
                    },
                    Resource::Block(block),
                ) => {
                    let want: Vec<u32> = layout.iter().map(|e| e.binding).collect();
                    let got: Vec<u32> = block.iter().map(|e| e.binding).collect();
                    if want != got {
                        return Err(bad(format!(
                            "block {name:?} binds {got:?}, its layout declares {want:?}"
                        )));
                    }
                    binding += block.len() as u32;
                    entries.extend(block);
                }
                _ => {
                    return Err(bad(format!(
                        "{name:?} is bound to the wrong kind of resource"
                    )));
                }
            }
        }
        if let Some((name, _)) = given.first() {
            return Err(bad(format!("{name:?} is not declared")));
        }
        Ok(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&self.set.label),
            layout: &self.layout,
            entries: &entries,
        }))
    }
}
