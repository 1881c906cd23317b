//! Reduce-then-scan exclusive prefix sum in three dispatches (reduce, spine, downsweep): the
//! baseline the single-pass `gpu-scan` is compared with. Same tile shape and the same kind of
//! workgroup scan (no subgroups) as the single-pass kernel, so the difference measured is the
//! extra pass over the input and the extra dispatches.

use gpu_scan::shaders::WG_SHARED_WGSL;

pub(crate) const SOURCE: &str = include_str!("rts.wgsl");
const WORKGROUP_SIZE: u32 = 256;
const ITEMS: u32 = 16;
/// Chunk length of the workgroup scan: gpu-scan's for this workgroup size.
const RAKE: u32 = 16;

/// The composed module: generated constants, gpu-scan's workgroup scan, `rts.wgsl`.
pub(crate) fn composed() -> String {
    format!(
        "const RTS_WG: u32 = {WORKGROUP_SIZE}u;\nconst RTS_ITEMS: u32 = {ITEMS}u;\n\
         const SCAN_WG: u32 = RTS_WG;\nconst SCAN_RAKE: u32 = {RAKE}u;\n{WG_SHARED_WGSL}\n\
         {SOURCE}"
    )
}

/// What [`ReduceThenScan::encode`] records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RtsStages {
    /// The whole scan: reduce, spine, downsweep.
    All,
    /// Only the downsweep (with whatever the partials hold): the per-tile work of a scan
    /// (load, workgroup scan, store) without any inter-tile communication. Benchmarks use it
    /// to separate a single-pass scan's tile cost from its look-back cost.
    DownsweepOnly,
}

/// Three-dispatch exclusive scan of `u32` (modulo 2^32).
#[derive(Debug)]
pub struct ReduceThenScan {
    layout: wgpu::BindGroupLayout,
    reduce: wgpu::ComputePipeline,
    spine: wgpu::ComputePipeline,
    downsweep: wgpu::ComputePipeline,
    partials: wgpu::Buffer,
    max_len: u32,
}

impl ReduceThenScan {
    /// Elements per tile (one workgroup).
    pub const TILE: u32 = WORKGROUP_SIZE * ITEMS;

    pub fn new(device: &wgpu::Device, max_len: u32) -> Self {
        let entry = crate::buffers::layout_entry;
        use wgpu::BufferBindingType as B;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("floors/rts"),
            entries: &[
                entry(0, B::Storage { read_only: true }),
                entry(1, B::Storage { read_only: false }),
                entry(2, B::Storage { read_only: false }),
                entry(3, B::Uniform),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("floors/rts"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("floors/rts"),
            source: wgpu::ShaderSource::Wgsl(composed().into()),
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let tiles = max_len.div_ceil(Self::TILE).max(1);
        let partials = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("floors/rts partials"),
            size: u64::from(tiles) * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Self {
            layout,
            reduce: pipeline("rts_reduce"),
            spine: pipeline("rts_spine_scan"),
            downsweep: pipeline("rts_downsweep"),
            partials,
            max_len,
        }
    }

    /// Records `stages` of an exclusive scan of the first `n` (<= max_len, > 0) elements of
    /// `input`.
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
        stages: RtsStages,
    ) {
        assert!(n > 0 && n <= self.max_len, "n = {n} out of range");
        let tiles = n.div_ceil(Self::TILE);
        let params = super::params(device, "floors/rts params", [n, tiles, 0, 0]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("floors/rts"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: input.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: output.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.partials.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: params.as_entire_binding(),
                },
            ],
        });
        let max = device.limits().max_compute_workgroups_per_dimension;
        let (x, y) = super::dispatch_2d(tiles, max);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("floors/rts"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &bind_group, &[]);
        if stages == RtsStages::All {
            pass.set_pipeline(&self.reduce);
            pass.dispatch_workgroups(x, y, 1);
            pass.set_pipeline(&self.spine);
            pass.dispatch_workgroups(1, 1, 1);
        }
        pass.set_pipeline(&self.downsweep);
        pass.dispatch_workgroups(x, y, 1);
    }
}
