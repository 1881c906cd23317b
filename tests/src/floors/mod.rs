//! Floor kernels measured in the same run as a benchmark: what any kernel moving the same bytes
//! must pay on this device. Benchmarks print their speed as a ratio to these.

mod copy;
mod random_access;
mod rts;

pub use copy::CopyKernel;
pub use random_access::{RandomAccess, RandomAccessKernel};
pub use rts::{ReduceThenScan, RtsStages};

pub use restir_world::gpu::dispatch_2d;
use restir_world::gpu::workgroup_size_wgsl;

/// Workgroup size of the one-invocation-per-item floors (copy, random access).
const WORKGROUP_SIZE: u32 = 256;

/// WGSL modules of the floor kernels, for the naga checks.
pub fn wgsl_modules() -> Vec<(String, String)> {
    vec![
        ("floors/copy".into(), item_kernel_source(copy::SOURCE)),
        ("floors/rts".into(), rts::composed()),
        (
            "floors/random_access".into(),
            item_kernel_source(random_access::SOURCE),
        ),
    ]
}

/// A one-invocation-per-item floor's module: the workspace's `WORKGROUP_SIZE`, `Invocation`
/// and `item_index` header, then `source`.
fn item_kernel_source(source: &str) -> String {
    format!("{}{source}", workgroup_size_wgsl())
}

/// The pipelines of `entries` in a one-invocation-per-item floor's `source`, each with the
/// layout its entry point uses and [`WORKGROUP_SIZE`] injected.
fn item_pipelines<const N: usize>(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    entries: [&str; N],
) -> [wgpu::ComputePipeline; N] {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(item_kernel_source(source).into()),
    });
    entries.map(|entry| {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &[("WORKGROUP_SIZE", f64::from(WORKGROUP_SIZE))],
                ..Default::default()
            },
            cache: None,
        })
    })
}

/// A uniform block of four words.
fn params(device: &wgpu::Device, label: &str, words: [u32; 4]) -> wgpu::Buffer {
    crate::buffers::with_usage(device, label, &words, wgpu::BufferUsages::UNIFORM)
}

/// Records one pass of an item floor's `pipeline` over `items` invocations, with `buffers`
/// (binding number, buffer) bound in group 0.
fn dispatch_items(
    device: &wgpu::Device,
    encoder: &mut wgpu::CommandEncoder,
    (label, pipeline): (&str, &wgpu::ComputePipeline),
    buffers: &[(u32, &wgpu::Buffer)],
    items: u32,
) {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    });
    let max = device.limits().max_compute_workgroups_per_dimension;
    let (x, y) = dispatch_2d(items.div_ceil(WORKGROUP_SIZE), max);
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &bind_group, &[]);
    pass.dispatch_workgroups(x, y, 1);
}
