//! [`Kernel`] (a composed WGSL module's pipelines) and [`Pass`] (one of them with its bind
//! groups and grid, ready to dispatch in a frame).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use super::binding::BindGroupLayout;

/// Workgroup size of every one-invocation-per-item kernel in this crate, injected into WGSL as
/// the pipeline-overridable constant `WORKGROUP_SIZE` (declared by [`workgroup_size_wgsl`]).
pub const WORKGROUP_SIZE: u32 = 64;

/// The WGSL every one-invocation-per-item kernel starts from: `WORKGROUP_SIZE` (its value
/// comes from [`Kernel::new`]), the entry-point input `Invocation` and `item_index`, the 1-D
/// index of an invocation on a [`dispatch_2d`] grid. A kernel reads:
///
/// ```wgsl
/// @compute @workgroup_size(WORKGROUP_SIZE)
/// fn my_kernel(id: Invocation) {
///     let i = item_index(id);
///     if i >= count { return; }
/// ```
pub fn workgroup_size_wgsl() -> String {
    "override WORKGROUP_SIZE: u32;\n\
     struct Invocation {\n    \
         @builtin(global_invocation_id) gid: vec3<u32>,\n    \
         @builtin(num_workgroups) groups: vec3<u32>,\n}\n\
     fn item_index(id: Invocation) -> u32 {\n    \
         return id.gid.x + id.gid.y * id.groups.x * WORKGROUP_SIZE;\n}\n"
        .to_owned()
}

/// Splits `groups` (at most `max_per_dim` squared) workgroups over x and y so that neither
/// exceeds `max_per_dim` (kernels
/// rebuild the 1-D index with `item_index`).
pub fn dispatch_2d(groups: u32, max_per_dim: u32) -> (u32, u32) {
    if groups <= max_per_dim {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max_per_dim);
        (groups.div_ceil(y), y)
    }
}

/// The compute pipelines of one composed WGSL module, one per entry point, on one pipeline
/// layout (bind groups 0, 1, ... in order).
#[derive(Debug, Clone)]
pub struct Kernel {
    label: String,
    pipelines: Vec<(String, wgpu::ComputePipeline)>,
    workgroup_size: u32,
}

impl Kernel {
    /// Compiles `source` and creates a pipeline per entry point, with `WORKGROUP_SIZE`
    /// injected ([`WORKGROUP_SIZE`]).
    pub fn new(
        device: &wgpu::Device,
        label: &str,
        source: &str,
        layouts: &[&BindGroupLayout],
        entry_points: &[&str],
    ) -> Self {
        Self::with_workgroup_size(device, label, source, layouts, entry_points, WORKGROUP_SIZE)
    }

    /// [`Kernel::new`] with another `WORKGROUP_SIZE` (benchmarks matching a floor's).
    pub fn with_workgroup_size(
        device: &wgpu::Device,
        label: &str,
        source: &str,
        layouts: &[&BindGroupLayout],
        entry_points: &[&str],
        workgroup_size: u32,
    ) -> Self {
        let constants = Constants {
            workgroup_size,
            overrides: &[],
        };
        Self::specialized(device, label, source, layouts, entry_points, constants)
    }

    /// [`Kernel::with_workgroup_size`] with values for the module's other pipeline-overridable
    /// constants ([`Constants::overrides`]).
    pub fn specialized(
        device: &wgpu::Device,
        label: &str,
        source: &str,
        layouts: &[&BindGroupLayout],
        entry_points: &[&str],
        constants: Constants,
    ) -> Self {
        let workgroup_size = constants.workgroup_size;
        let mut values = vec![("WORKGROUP_SIZE", f64::from(workgroup_size))];
        values.extend_from_slice(constants.overrides);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> =
            layouts.iter().map(|l| Some(&l.layout)).collect();
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
        let pipelines = entry_points
            .iter()
            .map(|entry| {
                let p = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &values,
                        ..Default::default()
                    },
                    cache: None,
                });
                ((*entry).to_owned(), p)
            })
            .collect();
        Self {
            label: label.to_owned(),
            pipelines,
            workgroup_size,
        }
    }

    /// The pipeline of `entry`.
    ///
    /// # Panics
    /// When the kernel was not created with that entry point (a programming error).
    pub fn pipeline(&self, entry: &str) -> &wgpu::ComputePipeline {
        self.pipelines
            .iter()
            .find(|(e, _)| e == entry)
            .map(|(_, p)| p)
            .unwrap_or_else(|| panic!("kernel {:?} has no entry point {entry:?}", self.label))
    }

    /// A pass of `entry` over `items` invocations (one per item) with `groups` bound at 0, 1, ...
    pub fn pass(
        &self,
        device: &wgpu::Device,
        entry: &str,
        groups: &[&wgpu::BindGroup],
        items: u32,
    ) -> Pass {
        Pass {
            label: entry.to_owned(),
            pipeline: self.pipeline(entry).clone(),
            groups: groups.iter().map(|g| (*g).clone()).collect(),
            workgroups: dispatch_2d(
                items.div_ceil(self.workgroup_size),
                device.limits().max_compute_workgroups_per_dimension,
            ),
        }
    }
}

/// The pipeline-overridable constants (WGSL `override`) a kernel's pipelines are created with.
#[derive(Debug, Clone, Copy)]
pub struct Constants<'a> {
    /// `WORKGROUP_SIZE` ([`workgroup_size_wgsl`]).
    pub workgroup_size: u32,
    /// The module's other overrides, by name: the driver folds the branches they decide, so a
    /// feature a scene does not use costs its kernels nothing.
    pub overrides: &'a [(&'a str, f64)],
}

/// What makes a kernel's pipelines: the device, the composed source, the entry points, the
/// workgroup size, the other overrides (values as bits) and the entries of each bind group
/// layout.
#[derive(Debug, PartialEq, Eq, Hash)]
struct KernelKey {
    device: wgpu::Device,
    source: String,
    entry_points: Vec<String>,
    workgroup_size: u32,
    overrides: Vec<(String, u64)>,
    layouts: Vec<Vec<wgpu::BindGroupLayoutEntry>>,
}

/// The kernels created on a context, shared by its clones: a method built again (another
/// seed, the viewer switching back to it, compare's next run) takes its kernels' pipelines
/// from here instead of compiling them again. A pipeline created for one build's bind group
/// layouts accepts another build's bind groups: wgpu hands out one layout object for equal
/// entries (while one is alive, as the cached pipelines keep theirs).
#[derive(Debug, Clone, Default)]
pub struct KernelCache(Arc<Mutex<HashMap<KernelKey, Kernel>>>);

impl KernelCache {
    /// [`Kernel::specialized`], created once per distinct key.
    pub fn kernel(
        &self,
        device: &wgpu::Device,
        label: &str,
        source: &str,
        layouts: &[&BindGroupLayout],
        entry_points: &[&str],
        constants: Constants,
    ) -> Kernel {
        let key = KernelKey {
            device: device.clone(),
            source: source.to_owned(),
            entry_points: entry_points.iter().map(|e| (*e).to_owned()).collect(),
            workgroup_size: constants.workgroup_size,
            overrides: constants
                .overrides
                .iter()
                .map(|(k, v)| ((*k).to_owned(), v.to_bits()))
                .collect(),
            layouts: layouts.iter().map(|l| l.entries()).collect(),
        };
        let mut kernels = self.0.lock().unwrap_or_else(|e| e.into_inner());
        kernels
            .entry(key)
            .or_insert_with(|| {
                Kernel::specialized(device, label, source, layouts, entry_points, constants)
            })
            .clone()
    }

    /// Kernels held.
    pub fn len(&self) -> usize {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One dispatch, ready to record: a pipeline, its bind groups and its grid.
#[derive(Debug, Clone)]
pub struct Pass {
    label: String,
    pipeline: wgpu::ComputePipeline,
    groups: Vec<wgpu::BindGroup>,
    workgroups: (u32, u32),
}

impl Pass {
    /// Records the dispatch as its own compute pass.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(&self.label),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        for (i, g) in self.groups.iter().enumerate() {
            pass.set_bind_group(i as u32, g, &[]);
        }
        pass.dispatch_workgroups(self.workgroups.0, self.workgroups.1, 1);
    }
}

#[cfg(test)]
mod tests {
    use super::dispatch_2d;

    #[test]
    fn dispatch_2d_covers_every_group_within_the_limit() {
        for (groups, max) in [
            (1, 65_535),
            (65_535, 65_535),
            (65_536, 65_535),
            (999_999, 1000),
            (1 << 26, 65_535),
        ] {
            let (x, y) = dispatch_2d(groups, max);
            assert!(x <= max && y <= max, "{groups} {max}");
            assert!(u64::from(x) * u64::from(y) >= u64::from(groups));
            assert!(u64::from(x) * u64::from(y - 1) < u64::from(groups));
        }
    }
}
