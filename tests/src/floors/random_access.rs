use wgpu::util::DeviceExt;

pub(crate) const SOURCE: &str = include_str!("random_access.wgsl");
const WORKGROUP_SIZE: u32 = 256;
/// Mixed into the item index before hashing it to a random line or word.
const SEED: u32 = 0x2545_f491;

/// Random-access floors: per item one random 128-byte line read, or one random atomic add,
/// each plus one coalesced u32 write. The floors of a hash table's find and insert.
#[derive(Debug)]
pub struct RandomAccessKernel {
    read: wgpu::ComputePipeline,
    atomic: wgpu::ComputePipeline,
}

/// Which floor to record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RandomAccess {
    /// `out[i] = xor of the 128-byte line pcg(i) % lines` of `table`.
    Read128,
    /// `out[i] = atomicAdd(table[pcg(i) % words], 1)`.
    Atomic,
}

impl RandomAccessKernel {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("floors/random_access"),
            source: wgpu::ShaderSource::Wgsl(SOURCE.into()),
        });
        let pipeline = |entry: &str| {
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
        };
        Self {
            read: pipeline("random_read_128"),
            atomic: pipeline("random_atomic"),
        }
    }

    /// Records `n` items of `kind` over `table` (128-byte lines or u32 words, its whole size)
    /// writing `out` (at least `4 n` bytes).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        kind: RandomAccess,
        table: &wgpu::Buffer,
        out: &wgpu::Buffer,
        n: u32,
    ) {
        let lines = (table.size() / 128).max(1) as u32;
        let words = (table.size() / 4).max(1) as u32;
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("floors/random_access params"),
            contents: bytemuck::cast_slice(&[n, lines, words, SEED]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let (pipeline, table_binding) = match kind {
            RandomAccess::Read128 => (&self.read, 0),
            RandomAccess::Atomic => (&self.atomic, 1),
        };
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("floors/random_access"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: table_binding,
                    resource: table.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: out.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: params.as_entire_binding(),
                },
            ],
        });
        let max = device.limits().max_compute_workgroups_per_dimension;
        let (x, y) = super::dispatch_2d(n.div_ceil(WORKGROUP_SIZE), max);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("floors/random_access"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }
}
