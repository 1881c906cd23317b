//! Ready-made kernels over a whole batch: insert or find keys and points, cell keys, stats.
//! They compose the library exactly as a consumer would (see `insert_module`/`lookup_module`).

use std::num::NonZeroU64;

use wgpu::util::DeviceExt;

use crate::wgsl::{self, BindAt};
use crate::{HashError, HashStats, HashTable};

const IO_WGSL: &str = include_str!("wgsl/batch_io.wgsl");
const INSERT_WGSL: &str = include_str!("wgsl/batch_insert.wgsl");
const LOOKUP_WGSL: &str = include_str!("wgsl/batch_lookup.wgsl");

/// Threads per workgroup of the batch kernels (injected as the `WORKGROUP_SIZE` override).
pub const WORKGROUP_SIZE: u32 = 256;

const ROLE_AT: BindAt = BindAt {
    group: 0,
    first_binding: 0,
};

pub(crate) fn insert_module() -> String {
    format!(
        "{}\n{IO_WGSL}\n{INSERT_WGSL}",
        wgsl::compose(Some(ROLE_AT), None)
    )
}

pub(crate) fn lookup_module() -> String {
    format!(
        "{}\n{IO_WGSL}\n{LOOKUP_WGSL}",
        wgsl::compose(None, Some(ROLE_AT))
    )
}

/// The batch kernels of one device. Each `encode_*` records one compute pass into the
/// caller's encoder; item `i` reads `input[i]` (16 bytes) and writes `output` at a per-kernel
/// stride.
#[derive(Debug)]
pub struct HashBatch {
    io_layout: wgpu::BindGroupLayout,
    table_layout: wgpu::BindGroupLayout,
    lookup_layout: wgpu::BindGroupLayout,
    insert_keys: wgpu::ComputePipeline,
    insert_points: wgpu::ComputePipeline,
    table_stats: wgpu::ComputePipeline,
    find_keys: wgpu::ComputePipeline,
    find_points: wgpu::ComputePipeline,
    cells: wgpu::ComputePipeline,
    hash_values: wgpu::ComputePipeline,
    jitter: wgpu::ComputePipeline,
}

/// Words written per item by each kernel.
#[derive(Debug, Clone, Copy)]
enum Kernel {
    InsertKeys,
    InsertPoints,
    FindKeys,
    FindPoints,
    Cells,
    HashValues,
    Jitter,
}

impl Kernel {
    fn out_words(self) -> u64 {
        match self {
            Kernel::InsertKeys | Kernel::FindKeys => 1,
            Kernel::InsertPoints | Kernel::FindPoints | Kernel::HashValues => 2,
            Kernel::Jitter => 4,
            Kernel::Cells => 8,
        }
    }

    fn in_vec4s(self) -> u64 {
        match self {
            Kernel::Jitter => 3,
            _ => 1,
        }
    }
}

/// Storage buffers the insert kernels bind in one stage: the table role's checksums, counters
/// and stats, plus the batch's input and output.
pub const BATCH_STORAGE_BUFFERS_PER_STAGE: u32 = 5;

/// Checks the device limits the batch kernels need (the README's device requirements table).
pub(crate) fn check_batch_limits(limits: &wgpu::Limits) -> Result<(), HashError> {
    let what = "HashBatch";
    let checks = [
        (
            "max_storage_buffers_per_shader_stage",
            BATCH_STORAGE_BUFFERS_PER_STAGE,
            limits.max_storage_buffers_per_shader_stage,
        ),
        (
            "max_uniform_buffers_per_shader_stage",
            2,
            limits.max_uniform_buffers_per_shader_stage,
        ),
        ("max_bind_groups", 2, limits.max_bind_groups),
        (
            "max_compute_invocations_per_workgroup",
            WORKGROUP_SIZE,
            limits.max_compute_invocations_per_workgroup,
        ),
        (
            "max_compute_workgroup_size_x",
            WORKGROUP_SIZE,
            limits.max_compute_workgroup_size_x,
        ),
    ];
    crate::check_limits(what, &checks)
}

impl HashBatch {
    /// Builds the batch pipelines, after checking the device limits they need
    /// ([`HashError::DeviceLimit`] otherwise).
    pub fn new(device: &wgpu::Device) -> Result<Self, HashError> {
        check_batch_limits(&device.limits())?;
        let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            })
        };
        let buffer_entry =
            |binding: u32, ty: wgpu::BufferBindingType, min: u64| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty,
                    has_dynamic_offset: false,
                    min_binding_size: NonZeroU64::new(min),
                },
                count: None,
            };
        let io_layout = layout(
            "gpu-hash batch io",
            &[
                buffer_entry(0, wgpu::BufferBindingType::Uniform, 4),
                buffer_entry(1, wgpu::BufferBindingType::Storage { read_only: true }, 16),
                buffer_entry(2, wgpu::BufferBindingType::Storage { read_only: false }, 4),
            ],
        );
        let table_layout = layout(
            "gpu-hash table",
            &crate::bind_group_layout_entries(ROLE_AT.first_binding),
        );
        let lookup_layout = layout(
            "gpu-hash lookup",
            &crate::lookup_bind_group_layout_entries(ROLE_AT.first_binding),
        );
        let pipeline_layout = |label: &str, role: &wgpu::BindGroupLayout, io: bool| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(role), io.then_some(&io_layout)],
                immediate_size: 0,
            })
        };
        let insert_layout = pipeline_layout("gpu-hash batch insert", &table_layout, true);
        let stats_layout = pipeline_layout("gpu-hash batch stats", &table_layout, false);
        let find_layout = pipeline_layout("gpu-hash batch lookup", &lookup_layout, true);
        let insert_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gpu-hash batch insert"),
            source: wgpu::ShaderSource::Wgsl(insert_module().into()),
        });
        let lookup_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gpu-hash batch lookup"),
            source: wgpu::ShaderSource::Wgsl(lookup_module().into()),
        });
        let pipeline = |layout: &wgpu::PipelineLayout, module: &wgpu::ShaderModule, entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &[("WORKGROUP_SIZE", f64::from(WORKGROUP_SIZE))],
                    ..Default::default()
                },
                cache: None,
            })
        };
        Ok(Self {
            insert_keys: pipeline(&insert_layout, &insert_module, "insert_keys"),
            insert_points: pipeline(&insert_layout, &insert_module, "insert_points"),
            table_stats: pipeline(&stats_layout, &insert_module, "table_stats"),
            find_keys: pipeline(&find_layout, &lookup_module, "find_keys"),
            find_points: pipeline(&find_layout, &lookup_module, "find_points"),
            cells: pipeline(&find_layout, &lookup_module, "cells"),
            hash_values: pipeline(&find_layout, &lookup_module, "hash_values"),
            jitter: pipeline(&find_layout, &lookup_module, "jitter"),
            io_layout,
            table_layout,
            lookup_layout,
        })
    }

    fn pipeline(&self, kernel: Kernel) -> (&wgpu::ComputePipeline, bool) {
        match kernel {
            Kernel::InsertKeys => (&self.insert_keys, true),
            Kernel::InsertPoints => (&self.insert_points, true),
            Kernel::FindKeys => (&self.find_keys, false),
            Kernel::FindPoints => (&self.find_points, false),
            Kernel::Cells => (&self.cells, false),
            Kernel::HashValues => (&self.hash_values, false),
            Kernel::Jitter => (&self.jitter, false),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn encode(
        &self,
        kernel: Kernel,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        let need_in = u64::from(n) * 16 * kernel.in_vec4s();
        if input.size() < need_in {
            return Err(HashError::BufferTooSmall {
                name: "input",
                have: input.size(),
                need: need_in,
            });
        }
        let need_out = u64::from(n) * 4 * kernel.out_words();
        if output.size() < need_out {
            return Err(HashError::BufferTooSmall {
                name: "output",
                have: output.size(),
                need: need_out,
            });
        }
        if n == 0 {
            return Ok(());
        }
        // Bind exactly the ranges the kernel reads and writes, so a caller's buffer may be
        // larger than one binding; a range that itself exceeds the limit is an error here.
        let limit = device.limits().max_storage_buffer_binding_size;
        for (name, bytes) in [("input", need_in), ("output", need_out)] {
            if bytes > limit {
                return Err(HashError::BindingTooLarge { name, bytes, limit });
            }
        }
        let (pipeline, writes_table) = self.pipeline(kernel);
        let role = if writes_table {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("gpu-hash table"),
                layout: &self.table_layout,
                entries: &table.bind_group_entries(ROLE_AT.first_binding),
            })
        } else {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("gpu-hash lookup"),
                layout: &self.lookup_layout,
                entries: &table.lookup_bind_group_entries(ROLE_AT.first_binding),
            })
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("gpu-hash batch params"),
            contents: bytemuck::cast_slice(&[n, 0, 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gpu-hash batch io"),
            layout: &self.io_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: input,
                        offset: 0,
                        size: wgpu::BufferSize::new(need_in),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: output,
                        offset: 0,
                        size: wgpu::BufferSize::new(need_out),
                    }),
                },
            ],
        });
        let (x, y) = dispatch_2d(n.div_ceil(WORKGROUP_SIZE), device);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gpu-hash batch"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &role, &[]);
        pass.set_bind_group(1, &io, &[]);
        pass.dispatch_workgroups(x, y, 1);
        Ok(())
    }

    /// `output[i]` (u32) = `find_or_insert` of key `input[i]` ([`crate::HashKey`]): a slot or
    /// [`crate::HASH_FULL`]. Slot counters are not touched (use
    /// [`HashBatch::encode_insert_points`] or `hash_slot_append` to count items).
    pub fn encode_insert_keys(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        keys: &wgpu::Buffer,
        slots: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(Kernel::InsertKeys, device, encoder, table, keys, slots, n)
    }

    /// Inserts the cell of each point (`input[i]` = `vec4<f32>`, w ignored; no jitter) and
    /// appends it to its slot: `output[2i]` = slot, `output[2i + 1]` = the point's index in its
    /// slot (the slot counter's old value). A point without a cell (non-finite or out of range,
    /// counted in the stats) writes `(HASH_REJECTED, HASH_NOT_FOUND)`; one whose probe sequence
    /// is full (an overflow, counted) writes `(HASH_FULL, HASH_NOT_FOUND)`; neither touches a
    /// counter.
    pub fn encode_insert_points(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        points: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(
            Kernel::InsertPoints,
            device,
            encoder,
            table,
            points,
            output,
            n,
        )
    }

    /// `output[i]` = `find` of key `input[i]` through the read-only lookup role: a slot or
    /// [`crate::HASH_NOT_FOUND`].
    pub fn encode_find_keys(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        keys: &wgpu::Buffer,
        slots: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(Kernel::FindKeys, device, encoder, table, keys, slots, n)
    }

    /// Finds the cell of each point under the table's own params: `output[2i]` = slot (or
    /// [`crate::HASH_NOT_FOUND`] / [`crate::HASH_REJECTED`]), `output[2i + 1]` = items counted
    /// in the slot (0 without a slot).
    pub fn encode_find_points(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        points: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(
            Kernel::FindPoints,
            device,
            encoder,
            table,
            points,
            output,
            n,
        )
    }

    /// `output[8i..8i + 8]` = the [`crate::HashCell`] of point `input[i]` under the table's
    /// params.
    pub fn encode_cells(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        points: &wgpu::Buffer,
        cells: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(Kernel::Cells, device, encoder, table, points, cells, n)
    }

    /// `output[2i]` = pcg(`input[i].x`), `output[2i + 1]` = xxhash32(`input[i].x`) (input is
    /// `vec4<u32>`; `table` only provides the bindings).
    pub fn encode_hash_values(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        values: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(
            Kernel::HashValues,
            device,
            encoder,
            table,
            values,
            output,
            n,
        )
    }

    /// Item `i` reads `input[3i]` = position, `input[3i + 1]` = normal, `input[3i + 2]` =
    /// (u.x, u.y, cell_size) as `vec4<f32>`; `output[4i..4i + 3]` = `hash_jitter` of them.
    pub fn encode_jitter(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        self.encode(Kernel::Jitter, device, encoder, table, input, output, n)
    }

    /// Recomputes `used_slots`, `max_bucket_fill` and `full_buckets` of `table`'s stats from
    /// its checksums (the insert-time counters are kept).
    pub fn encode_stats(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        table: &HashTable,
    ) {
        encoder.clear_buffer(table.stats(), HashStats::COMPUTED_OFFSET, None);
        let role = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gpu-hash table"),
            layout: &self.table_layout,
            entries: &table.bind_group_entries(ROLE_AT.first_binding),
        });
        let (x, y) = dispatch_2d(table.config().num_buckets.div_ceil(WORKGROUP_SIZE), device);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gpu-hash stats"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.table_stats);
        pass.set_bind_group(0, &role, &[]);
        pass.dispatch_workgroups(x, y, 1);
    }

    /// Computes and reads back `table`'s stats: submits its own command buffer and blocks.
    pub fn read_stats(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        table: &HashTable,
    ) -> Result<HashStats, HashError> {
        let size = size_of::<HashStats>() as u64;
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("gpu-hash stats readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("gpu-hash stats"),
        });
        self.encode_stats(device, &mut encoder, table);
        encoder.copy_buffer_to_buffer(table.stats(), 0, &staging, 0, size);
        queue.submit([encoder.finish()]);
        let slice = staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| HashError::Readback(e.to_string()))?;
        rx.recv()
            .map_err(|e| HashError::Readback(e.to_string()))?
            .map_err(|e| HashError::Readback(e.to_string()))?;
        let view = slice
            .get_mapped_range()
            .map_err(|e| HashError::Readback(e.to_string()))?;
        let stats: HashStats = bytemuck::pod_read_unaligned(&view[..size as usize]);
        drop(view);
        staging.unmap();
        Ok(stats)
    }
}

/// `(x, y)` workgroup counts covering `groups` within the per-dimension limit.
fn dispatch_2d(groups: u32, device: &wgpu::Device) -> (u32, u32) {
    let max = device.limits().max_compute_workgroups_per_dimension.max(1);
    if groups <= max {
        (groups, 1)
    } else {
        let y = groups.div_ceil(max);
        (groups.div_ceil(y), y)
    }
}
