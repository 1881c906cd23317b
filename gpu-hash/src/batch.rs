//! Ready-made kernels over a whole batch: insert or find keys and points, cell keys, stats.
//! They compose the library exactly as a consumer would (see `insert_module`/`lookup_module`).

use std::num::NonZeroU64;

use wgpu::util::DeviceExt;

use crate::wgsl::{self, BindAt, GridBinding};
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
const TABLE_AT: GridBinding = GridBinding::table(0, 0);
const LOOKUP_AT: GridBinding = GridBinding::lookup(0, 0);

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

/// The batch kernels of one device, created once ([`HashBatch::new`] checks the device's
/// limits); no device is stored. Bind a kernel to a table and your buffers once
/// ([`HashBatch::bind`]), then record it any number of times ([`HashBatch::encode`]) with no
/// allocation. Item `i` reads `input[i]` (16 bytes, `3 x 16` for [`BatchKernel::Jitter`]) and
/// writes `output` at the kernel's stride ([`BatchKernel::output_words`]).
#[derive(Debug)]
pub struct HashBatch {
    id: u64,
    io_layout: wgpu::BindGroupLayout,
    table_layout: wgpu::BindGroupLayout,
    lookup_layout: wgpu::BindGroupLayout,
    /// Indexed by [`BatchKernel`].
    pipelines: Vec<wgpu::ComputePipeline>,
    stats: wgpu::ComputePipeline,
}

/// The batch kernels. Inputs are `vec4` per item; outputs `u32` words.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BatchKernel {
    /// `output[i]` = `hash_find_or_insert` of key `input[i]` ([`crate::HashKey`]): a slot or
    /// [`crate::HASH_FULL`]. Slot counters are not touched (use [`BatchKernel::InsertPoints`]
    /// or `hash_slot_append` to count items).
    InsertKeys,
    /// Inserts the cell of each point (`input[i]` = `vec4<f32>`, w ignored; no jitter) and
    /// appends it to its slot: `output[2i]` = slot, `output[2i + 1]` = the point's index in
    /// its slot (the slot counter's old value). A point without a cell (non-finite or out of
    /// range, counted in the stats) writes `(HASH_REJECTED, HASH_NOT_FOUND)`; one whose probe
    /// sequence is full (an overflow, counted) writes `(HASH_FULL, HASH_NOT_FOUND)`; neither
    /// touches a counter.
    InsertPoints,
    /// `output[i]` = `find` of key `input[i]` through the read-only lookup role: a slot or
    /// [`crate::HASH_NOT_FOUND`].
    FindKeys,
    /// Finds the cell of each point under the table's own params: `output[2i]` = slot (or
    /// [`crate::HASH_NOT_FOUND`] / [`crate::HASH_REJECTED`]), `output[2i + 1]` = items counted
    /// in the slot (0 without a slot).
    FindPoints,
    /// `output[8i..8i + 8]` = the [`crate::HashCell`] of point `input[i]` under the table's
    /// params.
    Cells,
    /// `output[2i]` = pcg(`input[i].x`), `output[2i + 1]` = xxhash32(`input[i].x`) (input is
    /// `vec4<u32>`; the table only provides the bindings).
    HashValues,
    /// Item `i` reads `input[3i]` = position, `input[3i + 1]` = normal, `input[3i + 2]` =
    /// (u.x, u.y, cell_size) as `vec4<f32>`; `output[4i..4i + 3]` = `hash_jitter` of them.
    Jitter,
}

impl BatchKernel {
    /// Every kernel, in pipeline order.
    pub const ALL: [BatchKernel; 7] = [
        BatchKernel::InsertKeys,
        BatchKernel::InsertPoints,
        BatchKernel::FindKeys,
        BatchKernel::FindPoints,
        BatchKernel::Cells,
        BatchKernel::HashValues,
        BatchKernel::Jitter,
    ];

    /// `u32` words written per item.
    pub fn output_words(self) -> u64 {
        match self {
            BatchKernel::InsertKeys | BatchKernel::FindKeys => 1,
            BatchKernel::InsertPoints | BatchKernel::FindPoints | BatchKernel::HashValues => 2,
            BatchKernel::Jitter => 4,
            BatchKernel::Cells => 8,
        }
    }

    /// `vec4`s read per item.
    pub fn input_vec4s(self) -> u64 {
        match self {
            BatchKernel::Jitter => 3,
            _ => 1,
        }
    }

    /// Whether it binds the table role (read-write) rather than the lookup role.
    pub fn writes_table(self) -> bool {
        matches!(self, BatchKernel::InsertKeys | BatchKernel::InsertPoints)
    }

    fn entry_point(self) -> &'static str {
        match self {
            BatchKernel::InsertKeys => "insert_keys",
            BatchKernel::InsertPoints => "insert_points",
            BatchKernel::FindKeys => "find_keys",
            BatchKernel::FindPoints => "find_points",
            BatchKernel::Cells => "cells",
            BatchKernel::HashValues => "hash_values",
            BatchKernel::Jitter => "jitter",
        }
    }
}

/// A batch kernel (or the stats kernel) bound to one table and the caller's buffers: bind
/// groups, parameter block and dispatch size, created once by [`HashBatch::bind`] /
/// [`HashBatch::bind_stats`]. Record it with [`HashBatch::encode`] on the batch that made it.
#[derive(Debug)]
pub struct BatchBinding {
    batch_id: u64,
    kernel: Option<BatchKernel>,
    role: wgpu::BindGroup,
    io: Option<(wgpu::BindGroup, wgpu::Buffer)>,
    dispatch: (u32, u32),
    /// The stats buffer to clear before the stats kernel.
    stats: Option<wgpu::Buffer>,
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

/// The checks of [`HashBatch::bind`] on the caller's buffers that wgpu's validation would
/// otherwise fail on (a panic under the default error handler).
fn check_io(
    table: &HashTable,
    input: &wgpu::Buffer,
    output: &wgpu::Buffer,
) -> Result<(), HashError> {
    for (which, b) in [("input", input), ("output", output)] {
        if !b.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(HashError::MissingStorageUsage { which });
        }
    }
    if input == output {
        return Err(HashError::Aliasing("input", "output"));
    }
    let t = table.buffers();
    for (which, b) in [("input", input), ("output", output)] {
        if [t.params, t.checksums, t.counters, t.stats].contains(&b) {
            return Err(HashError::Aliasing(which, "table"));
        }
    }
    Ok(())
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
        let table_layout = layout("gpu-hash table", &TABLE_AT.layout_entries());
        let lookup_layout = layout("gpu-hash lookup", &LOOKUP_AT.layout_entries());
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
        let pipelines = BatchKernel::ALL
            .iter()
            .map(|k| {
                if k.writes_table() {
                    pipeline(&insert_layout, &insert_module, k.entry_point())
                } else {
                    pipeline(&find_layout, &lookup_module, k.entry_point())
                }
            })
            .collect();
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        Ok(Self {
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            stats: pipeline(&stats_layout, &insert_module, "table_stats"),
            pipelines,
            io_layout,
            table_layout,
            lookup_layout,
        })
    }

    /// Binds `kernel` to `table` and the caller's `input` / `output` for `n` items: checks
    /// that both have `STORAGE` usage ([`HashError::MissingStorageUsage`]), that they are
    /// neither the same buffer nor one of the table's ([`HashError::Aliasing`]), the buffer
    /// sizes, and that the exact ranges the kernel uses (`n * stride` bytes from 0) fit one
    /// storage binding ([`HashError::BindingTooLarge`]), then creates the bind groups and the
    /// parameter block, once.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        kernel: BatchKernel,
        table: &HashTable,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<BatchBinding, HashError> {
        check_io(table, input, output)?;
        let need_in = u64::from(n) * 16 * kernel.input_vec4s();
        let need_out = u64::from(n) * 4 * kernel.output_words();
        let io = [("input", input, need_in), ("output", output, need_out)];
        for (name, buffer, need) in io {
            if buffer.size() < need {
                let have = buffer.size();
                return Err(HashError::BufferTooSmall { name, have, need });
            }
        }
        // Bind exactly the ranges the kernel reads and writes, so a caller's buffer may be
        // larger than one binding; a range that itself exceeds the limit is an error here.
        let limit = device.limits().max_storage_buffer_binding_size;
        for (name, _, bytes) in io {
            if bytes > limit {
                return Err(HashError::BindingTooLarge { name, bytes, limit });
            }
        }
        let role = self.role_group(device, table, kernel.writes_table());
        let io = (n > 0).then(|| {
            let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("gpu-hash batch params"),
                contents: bytemuck::cast_slice(&[n, 0, 0, 0]),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let range = |buffer, size| {
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(size),
                })
            };
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("gpu-hash batch io"),
                layout: &self.io_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: range(input, need_in),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: range(output, need_out),
                    },
                ],
            });
            (group, params)
        });
        Ok(BatchBinding {
            batch_id: self.id,
            kernel: Some(kernel),
            role,
            io,
            dispatch: dispatch_2d(n.div_ceil(WORKGROUP_SIZE), device),
            stats: None,
        })
    }

    /// Binds the stats kernel to `table`: recomputes `used_slots`, `max_bucket_fill` and
    /// `full_buckets` of its stats from its checksums (the insert-time counters are kept).
    pub fn bind_stats(&self, device: &wgpu::Device, table: &HashTable) -> BatchBinding {
        BatchBinding {
            batch_id: self.id,
            kernel: None,
            role: self.role_group(device, table, true),
            io: None,
            dispatch: dispatch_2d(table.config().num_buckets.div_ceil(WORKGROUP_SIZE), device),
            stats: Some(table.stats().clone()),
        }
    }

    fn role_group(&self, device: &wgpu::Device, table: &HashTable, write: bool) -> wgpu::BindGroup {
        let (at, layout) = if write {
            (TABLE_AT, &self.table_layout)
        } else {
            (LOOKUP_AT, &self.lookup_layout)
        };
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gpu-hash table"),
            layout,
            entries: &at.bind_group_entries(&table.buffers()),
        })
    }

    /// Records a bound kernel: one compute pass (the stats kernel also clears the fields it
    /// recomputes). Allocates nothing; `n = 0` records nothing.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        binding: &BatchBinding,
    ) -> Result<(), HashError> {
        self.encode_timed(encoder, binding, &mut |_| None)
    }

    /// [`HashBatch::encode`] with a named timestamp span hook: `span` is called with the pass
    /// name (`"gpu-hash <entry point>"`, e.g. `"gpu-hash insert_points"`, or
    /// `"gpu-hash table_stats"`) and may return the timestamp writes for it.
    pub fn encode_timed<'q>(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        binding: &BatchBinding,
        span: &mut dyn FnMut(&'static str) -> Option<wgpu::ComputePassTimestampWrites<'q>>,
    ) -> Result<(), HashError> {
        if binding.batch_id != self.id {
            return Err(HashError::ForeignBinding);
        }
        let (pipeline, name) = match binding.kernel {
            Some(k) => {
                if binding.io.is_none() {
                    return Ok(()); // n = 0
                }
                (&self.pipelines[k as usize], pass_name(k))
            }
            None => (&self.stats, "gpu-hash table_stats"),
        };
        if let Some(stats) = &binding.stats {
            encoder.clear_buffer(stats, HashStats::COMPUTED_OFFSET, None);
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(name),
            timestamp_writes: span(name),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &binding.role, &[]);
        if let Some((io, _)) = &binding.io {
            pass.set_bind_group(1, io, &[]);
        }
        pass.dispatch_workgroups(binding.dispatch.0, binding.dispatch.1, 1);
        Ok(())
    }

    /// One-off convenience: [`HashBatch::bind`] then [`HashBatch::encode`] (allocates a bind
    /// group and parameter block on every call).
    #[allow(clippy::too_many_arguments)]
    pub fn bind_and_encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        kernel: BatchKernel,
        table: &HashTable,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
    ) -> Result<(), HashError> {
        let binding = self.bind(device, kernel, table, input, output, n)?;
        self.encode(encoder, &binding)
    }

    /// Test and tool convenience: computes and reads back `table`'s stats. It **submits its own
    /// command buffer and blocks** until the GPU is done; in a frame loop, record
    /// [`HashBatch::bind_stats`] with [`HashBatch::encode`] and copy [`HashTable::stats`] to
    /// your own readback buffer instead.
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
        self.encode(&mut encoder, &self.bind_stats(device, table))?;
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

fn pass_name(kernel: BatchKernel) -> &'static str {
    match kernel {
        BatchKernel::InsertKeys => "gpu-hash insert_keys",
        BatchKernel::InsertPoints => "gpu-hash insert_points",
        BatchKernel::FindKeys => "gpu-hash find_keys",
        BatchKernel::FindPoints => "gpu-hash find_points",
        BatchKernel::Cells => "gpu-hash cells",
        BatchKernel::HashValues => "gpu-hash hash_values",
        BatchKernel::Jitter => "gpu-hash jitter",
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
