//! # gpu-scan
//!
//! Single-pass prefix sums of `u32` on the GPU: chained scan with decoupled look-back
//! (Merrill & Garland 2016) made portable by a bounded spin and a fallback (Smith, Levien &
//! Owens, "Decoupled Fallback", SPAA 2025). Encodes into the caller's command encoder over
//! caller-owned buffers.
//!
//! ```no_run
//! # fn demo(device: &wgpu::Device, queue: &wgpu::Queue, input: &wgpu::Buffer,
//! #         output: &wgpu::Buffer) -> Result<(), gpu_scan::ScanError> {
//! use gpu_scan::{Scan, ScanDescriptor, ScanKind};
//! // Create with the device (limits checked), bind once to your buffers...
//! let scan = Scan::new(device, &ScanDescriptor::for_device(device, 1 << 20))?;
//! let binding = scan.bind(device, input, output, 1000, ScanKind::Exclusive, None)?;
//! // ...and encode as often as needed into your encoder, with no allocation.
//! let mut encoder = device.create_command_encoder(&Default::default());
//! scan.encode(&mut encoder, &binding)?;
//! queue.submit([encoder.finish()]);
//! # Ok(()) }
//! ```
//!
//! See [`Scan`] for the contract, `examples/scan.rs` for a complete program, and the
//! workspace's `tests` crate for the GPU tests and the benchmark.

pub mod cpu;
pub mod shaders;
pub mod state;

use wgpu::util::DeviceExt;

pub use shaders::KernelConfig;

/// Default failed polls of one predecessor before a workgroup takes the fallback.
pub const DEFAULT_SPIN_LIMIT: u32 = 256;

/// Default elements per invocation on GPUs (see [`ScanDescriptor::items_per_thread`]).
pub const DEFAULT_ITEMS_PER_THREAD: u32 = 16;

/// Default invocations per workgroup on GPUs (see [`ScanDescriptor::workgroup_size`]).
pub const DEFAULT_WORKGROUP_SIZE: u32 = 256;

/// Default elements per invocation on CPU adapters (llvmpipe / lavapipe, SwiftShader).
pub const CPU_ITEMS_PER_THREAD: u32 = 1024;

/// Default invocations per workgroup on CPU adapters.
pub const CPU_WORKGROUP_SIZE: u32 = 32;

/// The default `(workgroup_size, items_per_thread)` for an adapter.
///
/// GPUs get 256 x 16 (tiles of 4096: enough invocations to hide memory latency). CPU adapters
/// (`DeviceType::Cpu`) get 32 x 1024 (tiles of 32768): there every workgroup runs as a few
/// SIMD lanes on one core, and the per-tile costs (barriers, which llvmpipe implements as
/// coroutine switches, the ticket, the look-back) dominate unless each invocation scans a long
/// run. On llvmpipe this takes a 2^25 scan from ~0.2 to ~1.0 times the speed of a plain copy.
pub fn default_shape(info: &wgpu::AdapterInfo) -> (u32, u32) {
    if info.device_type == wgpu::DeviceType::Cpu {
        (CPU_WORKGROUP_SIZE, CPU_ITEMS_PER_THREAD)
    } else {
        (DEFAULT_WORKGROUP_SIZE, DEFAULT_ITEMS_PER_THREAD)
    }
}

/// Which prefix sum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScanKind {
    /// `out[i] = in[0] + ... + in[i-1]` (`out[0] = 0`).
    Exclusive,
    /// `out[i] = in[0] + ... + in[i]`.
    Inclusive,
}

/// How to build a [`Scan`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanDescriptor {
    /// Largest number of elements one scan may cover. Must fit one storage binding on the device.
    pub max_len: u32,
    /// Use subgroup operations for the workgroup scan. Needs `Features::SUBGROUP` on the device
    /// (an error otherwise); [`ScanDescriptor::for_device`] turns it on when available.
    pub use_subgroups: bool,
    /// Failed polls of one not-yet-published predecessor before the waiting workgroup reduces
    /// that predecessor's input itself. Default [`DEFAULT_SPIN_LIMIT`].
    ///
    /// **Testing knob:** `0` forces the fallback: every tile reduces its immediate predecessor
    /// itself without polling, and falls back at once on any later predecessor that is not
    /// ready. Results stay exact; the scan then reads its input about twice.
    pub spin_limit: u32,
    /// Count tiles, look-back steps, failed polls and fallbacks into a debug buffer
    /// ([`Scan::counters_buffer`]). Costs a few atomics per tile; for benchmarks and tests.
    pub debug_counters: bool,
    /// Elements per thread (tile = workgroup size x this), a non-zero multiple of 4: each
    /// invocation scans a run of this many consecutive elements serially in registers. `None`
    /// picks [`DEFAULT_ITEMS_PER_THREAD`].
    pub items_per_thread: Option<u32>,
    /// Invocations per workgroup, a power of two >= 32 within the device's limits. `None`
    /// picks [`DEFAULT_WORKGROUP_SIZE`] (or the device's largest power of two below it).
    pub workgroup_size: Option<u32>,
}

impl ScanDescriptor {
    /// Defaults for `max_len` elements: no subgroups, default spin limit, no counters.
    pub fn new(max_len: u32) -> Self {
        Self {
            max_len,
            use_subgroups: false,
            spin_limit: DEFAULT_SPIN_LIMIT,
            debug_counters: false,
            items_per_thread: None,
            workgroup_size: None,
        }
    }

    /// Like [`ScanDescriptor::new`], with subgroups when `device` has `Features::SUBGROUP`.
    pub fn for_device(device: &wgpu::Device, max_len: u32) -> Self {
        Self {
            use_subgroups: device.features().contains(wgpu::Features::SUBGROUP),
            ..Self::new(max_len)
        }
    }
}

/// Errors of [`Scan`]: all are returned before anything is created or encoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScanError {
    /// `max_len` does not fit one storage binding on this device.
    #[error("max_len {max_len} exceeds the device's storage binding limit of {limit} u32s")]
    MaxLenAboveBindingLimit { max_len: u32, limit: u64 },
    /// Subgroups were requested on a device without `Features::SUBGROUP`.
    #[error("use_subgroups was requested but the device lacks Features::SUBGROUP")]
    SubgroupsUnavailable,
    /// The device's compute limits cannot hold the kernel's workgroup.
    #[error("the device's compute limits cannot run the scan kernel: {0}")]
    UnsupportedLimits(String),
    /// A device limit is below what the scan kernel needs (see the crate README's device
    /// requirements table).
    #[error("the scan needs {limit} >= {needed}, the device has {available}")]
    DeviceLimit {
        /// The field of [`wgpu::Limits`].
        limit: &'static str,
        needed: u64,
        available: u64,
    },
    /// `workgroup_size` is not a power of two in `32..=max`.
    #[error("workgroup_size {size} is not a power of two in 32..={max}")]
    InvalidWorkgroupSize { size: u32, max: u32 },
    /// `items_per_thread` is not one of the supported values.
    #[error(
        "items_per_thread {0} is not supported (use 4, 8, 12, 16, ...: a non-zero multiple of 4)"
    )]
    InvalidItemsPerThread(u32),
    /// `n` is larger than the scan's `max_len` (which never exceeds the binding limit).
    #[error("n = {n} exceeds this scan's max_len of {max_len} elements")]
    TooLong { n: u32, max_len: u32 },
    /// A buffer is smaller than the scan needs.
    #[error("the {which} buffer holds {size} bytes, fewer than the {needed} this scan needs")]
    BufferTooSmall {
        which: &'static str,
        size: u64,
        needed: u64,
    },
    /// A buffer lacks a usage the scan needs.
    #[error("the {which} buffer lacks BufferUsages::STORAGE")]
    MissingStorageUsage { which: &'static str },
    /// Two buffers that must differ are the same buffer.
    #[error("the {0} and {1} buffers must not alias")]
    Aliasing(&'static str, &'static str),
    /// A [`ScanBinding`] made by another [`Scan`] was passed to [`Scan::encode`].
    #[error("the binding was made by another Scan")]
    ForeignBinding,
    /// The indirect length's offset is not a multiple of 4.
    #[error("the length offset {0} is not a multiple of 4")]
    UnalignedLenOffset(u64),
}

/// Per-binding parameters of the kernel (the WGSL struct `ScanParams`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScanParams {
    /// Number of elements (the indirect pre-pass overwrites it).
    pub n: u32,
    /// 1 for an inclusive scan.
    pub inclusive: u32,
    /// 1 to write the total.
    pub write_total: u32,
    /// Indirect: word index of n in the length buffer.
    pub len_index: u32,
}

/// The debug counters (see [`ScanDescriptor::debug_counters`]), accumulated over every scan
/// encoded since the last [`Scan::clear_counters`].
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScanCounters {
    /// Tiles scanned.
    pub tiles: u32,
    /// Predecessor states consumed by look-backs (aggregates and inclusive prefixes).
    pub lookback_steps: u32,
    /// Polls that found a predecessor not ready.
    pub failed_polls: u32,
    /// Predecessor tiles reduced by a waiting workgroup.
    pub fallbacks: u32,
}

/// A reusable prefix-sum operator: pipelines plus scratch (tile states, ticket counter).
///
/// # Contract
/// - Results are modulo 2^32 (wrapping adds), bit-exact against [`cpu::scan`].
/// - One dispatch per scan (plus a one-thread pre-pass for [`Scan::bind_indirect`] and a
///   `clear_buffer` of the scratch). Everything is recorded into the caller's encoder; the
///   scratch reset is part of the recorded work, so any number of scans may be encoded in one
///   submit, on the same or different buffers.
/// - `n = 0` records nothing, unless a total is requested: then 0 is written to it.
/// - `input` and `output` must not alias (nor either of them alias `total`); `input` must hold
///   at least `n` u32s, `output` at least `n`, `total` at least one; all need `STORAGE` usage.
/// - `n` above the scan's `max_len` (which [`Scan::new`] checks against the device's storage
///   binding limit) is an error returned before anything is encoded.
/// - A scan sharing one `Scan` with another scan must not run concurrently with it (they share
///   the scratch); scans recorded in one encoder or in successive submits never do.
///
/// # Forward progress
/// Tiles are ranked by an atomic ticket, so a workgroup only ever waits for tiles whose
/// workgroups started before it. A workgroup that has polled a predecessor
/// [`ScanDescriptor::spin_limit`] times without result reduces that predecessor's input itself,
/// so the scan completes even where a waiting workgroup could starve the one it waits for.
#[derive(Debug)]
pub struct Scan {
    /// Identifies the bindings this scan made ([`ScanBinding`]).
    id: u64,
    config: KernelConfig,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    prepare_layout: wgpu::BindGroupLayout,
    prepare_pipeline: wgpu::ComputePipeline,
    scratch: wgpu::Buffer,
    dispatch: wgpu::Buffer,
    counters: wgpu::Buffer,
    dummy_in: wgpu::Buffer,
    dummy_out: wgpu::Buffer,
    dummy_in4: wgpu::Buffer,
    dummy_out4: wgpu::Buffer,
    binding_limit: u64,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn buffer_entry(
    binding: u32,
    buffer: &wgpu::Buffer,
    size: Option<u64>,
) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer,
            offset: 0,
            size: size.and_then(wgpu::BufferSize::new),
        }),
    }
}

/// Splits `groups` into an (x, y) dispatch with x <= `max_x`.
fn split_groups(groups: u32, max_x: u32) -> (u32, u32) {
    let x = groups.min(max_x).max(1);
    (x, groups.div_ceil(x).max(1))
}

/// The kernel's configuration for `desc` on `device`, after every check of the descriptor
/// against the device: the configuration, the tiles of a scan of `max_len` and the binding
/// limit in elements.
fn checked_config(
    device: &wgpu::Device,
    desc: &ScanDescriptor,
) -> Result<(KernelConfig, u32, u64), ScanError> {
    let limits = device.limits();
    let binding_limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
        / 4;
    if u64::from(desc.max_len) > binding_limit {
        return Err(ScanError::MaxLenAboveBindingLimit {
            max_len: desc.max_len,
            limit: binding_limit,
        });
    }
    if desc.use_subgroups && !device.features().contains(wgpu::Features::SUBGROUP) {
        return Err(ScanError::SubgroupsUnavailable);
    }
    check_device_limits(&limits)?;
    if let Some(items) = desc.items_per_thread {
        if items == 0 || items % 4 != 0 {
            return Err(ScanError::InvalidItemsPerThread(items));
        }
    }
    let (default_wg, default_items) = default_shape(&device.adapter_info());
    let config = KernelConfig {
        workgroup_size: workgroup_size(desc, &limits, default_wg)?,
        items_per_thread: desc.items_per_thread.unwrap_or(default_items),
        spin_limit: desc.spin_limit,
        counters: desc.debug_counters,
        max_len: desc.max_len,
        max_groups_x: limits.max_compute_workgroups_per_dimension,
        subgroups: desc.use_subgroups,
    };
    if config.workgroup_bytes() > limits.max_compute_workgroup_storage_size {
        return Err(ScanError::DeviceLimit {
            limit: "max_compute_workgroup_storage_size",
            needed: u64::from(config.workgroup_bytes()),
            available: u64::from(limits.max_compute_workgroup_storage_size),
        });
    }
    if u64::from(config.tile_len()) > u64::from(u32::MAX / 2) {
        return Err(ScanError::InvalidItemsPerThread(config.items_per_thread));
    }
    let tiles = desc.max_len.div_ceil(config.tile_len()).max(1);
    let groups = split_groups(tiles, config.max_groups_x);
    if groups.1 > limits.max_compute_workgroups_per_dimension {
        return Err(ScanError::UnsupportedLimits(format!(
            "{tiles} tiles exceed the dispatch limits"
        )));
    }
    Ok((config, tiles, binding_limit))
}

/// The workgroup size: the descriptor's (a power of two from 32 to the device's limit, at most
/// 256) or the adapter's default shape's.
fn workgroup_size(
    desc: &ScanDescriptor,
    limits: &wgpu::Limits,
    default_wg: u32,
) -> Result<u32, ScanError> {
    let max_threads = limits
        .max_compute_invocations_per_workgroup
        .min(limits.max_compute_workgroup_size_x)
        .min(256);
    if max_threads < 32 {
        return Err(ScanError::UnsupportedLimits(format!(
            "{max_threads} invocations per workgroup (need 32)"
        )));
    }
    match desc.workgroup_size {
        None => Ok(1 << max_threads.min(default_wg).ilog2()),
        Some(w) if w.is_power_of_two() && w >= 32 && w <= max_threads => Ok(w),
        Some(w) => Err(ScanError::InvalidWorkgroupSize {
            size: w,
            max: 1 << max_threads.ilog2(),
        }),
    }
}

/// A layout of storage buffers at bindings 0.. (`read_only[i]`: binding i is read-only).
fn bind_group_layout(
    device: &wgpu::Device,
    label: &str,
    read_only: &[bool],
) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = (0u32..)
        .zip(read_only)
        .map(|(i, &ro)| storage_entry(i, ro))
        .collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// The compute pipeline of `entry` in `source` over the one group `layout`.
fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    source: String,
    layout: &wgpu::BindGroupLayout,
    entry: &str,
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

impl Scan {
    /// Builds the pipelines and scratch for scans of up to `desc.max_len` elements.
    pub fn new(device: &wgpu::Device, desc: &ScanDescriptor) -> Result<Self, ScanError> {
        let (config, tiles, binding_limit) = checked_config(device, desc)?;
        let layout = bind_group_layout(
            device,
            "gpu-scan",
            &[true, false, false, false, true, false, true, false],
        );
        let prepare_layout = bind_group_layout(device, "gpu-scan prepare", &[true, false, false]);
        let pipeline = compute_pipeline(
            device,
            "gpu-scan",
            config.scan_source(),
            &layout,
            "scan_main",
        );
        let prepare_pipeline = compute_pipeline(
            device,
            "gpu-scan prepare",
            config.prepare_source(),
            &prepare_layout,
            "scan_prepare",
        );
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        Ok(Self {
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            config,
            layout,
            pipeline,
            prepare_layout,
            prepare_pipeline,
            scratch: buffer(
                "gpu-scan scratch",
                (1 + 2 * u64::from(tiles)) * 4,
                U::STORAGE | U::COPY_DST,
            ),
            dispatch: buffer("gpu-scan dispatch", 16, U::STORAGE | U::INDIRECT),
            counters: buffer(
                "gpu-scan counters",
                16,
                U::STORAGE | U::COPY_SRC | U::COPY_DST,
            ),
            dummy_in: buffer("gpu-scan empty input", 16, U::STORAGE),
            dummy_out: buffer("gpu-scan empty output", 16, U::STORAGE),
            dummy_in4: buffer("gpu-scan empty vec4 input", 16, U::STORAGE),
            dummy_out4: buffer("gpu-scan empty vec4 output", 16, U::STORAGE),
            binding_limit,
        })
    }

    /// The compiled kernel's configuration (tile size, workgroup size, ...).
    pub fn config(&self) -> &KernelConfig {
        &self.config
    }

    /// Elements per tile (one workgroup's share).
    pub fn tile_len(&self) -> u32 {
        self.config.tile_len()
    }

    /// Largest `n` this scan accepts.
    pub fn max_len(&self) -> u32 {
        self.config.max_len
    }

    /// The debug counters buffer (a [`ScanCounters`]) when
    /// [`ScanDescriptor::debug_counters`] is set. It has `COPY_SRC` usage for readback.
    pub fn counters_buffer(&self) -> Option<&wgpu::Buffer> {
        self.config.counters.then_some(&self.counters)
    }

    /// Records a reset of the debug counters.
    pub fn clear_counters(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.counters, 0, None);
    }

    fn check_total(
        &self,
        total: Option<&wgpu::Buffer>,
        others: [&wgpu::Buffer; 2],
    ) -> Result<(), ScanError> {
        if let Some(t) = total {
            check_storage("total", t)?;
            if t.size() < 4 {
                return Err(ScanError::BufferTooSmall {
                    which: "total",
                    size: t.size(),
                    needed: 4,
                });
            }
            if t == others[0] {
                return Err(ScanError::Aliasing("input", "total"));
            }
            if t == others[1] {
                return Err(ScanError::Aliasing("output", "total"));
            }
        }
        Ok(())
    }

    /// Binds this scan to the caller's buffers: a scan of the first `n` elements of `input`
    /// into the first `n` of `output`; with `total`, the sum of the `n` inputs is also written
    /// to its first word. Every check of the [contract](Scan#contract) happens here, and the
    /// per-binding parameter block and bind group are created here, once: record the scan with
    /// [`Scan::encode`] as many times as needed, without any allocation.
    #[allow(clippy::too_many_arguments)]
    pub fn bind(
        &self,
        device: &wgpu::Device,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
        kind: ScanKind,
        total: Option<&wgpu::Buffer>,
    ) -> Result<ScanBinding, ScanError> {
        if n > self.config.max_len {
            return Err(ScanError::TooLong {
                n,
                max_len: self.config.max_len,
            });
        }
        if input == output {
            return Err(ScanError::Aliasing("input", "output"));
        }
        check_storage("input", input)?;
        check_storage("output", output)?;
        let bytes = u64::from(n) * 4;
        for (which, b) in [("input", input), ("output", output)] {
            if b.size() < bytes {
                return Err(ScanError::BufferTooSmall {
                    which,
                    size: b.size(),
                    needed: bytes,
                });
            }
        }
        self.check_total(total, [input, output])?;
        if n == 0 && total.is_none() {
            return Ok(ScanBinding {
                scan_id: self.id,
                work: None,
            });
        }
        let views = if n == 0 {
            Views {
                input: (&self.dummy_in, None),
                output: (&self.dummy_out, None),
                input4: (&self.dummy_in4, None),
                output4: (&self.dummy_out4, None),
            }
        } else {
            let bytes4 = bytes / 16 * 16;
            let (input4, output4) = if bytes4 == 0 {
                ((&self.dummy_in4, None), (&self.dummy_out4, None))
            } else {
                ((input, Some(bytes4)), (output, Some(bytes4)))
            };
            Views {
                input: (input, Some(bytes)),
                output: (output, Some(bytes)),
                input4,
                output4,
            }
        };
        let params = self.params(device, n, kind, total.is_some(), 0);
        let bind_group = self.bind_group(device, &views, total, &params);
        let tiles = n.div_ceil(self.config.tile_len()).max(1);
        Ok(ScanBinding {
            scan_id: self.id,
            work: Some(Work {
                bind_group,
                _params: params,
                clear_bytes: Some((1 + 2 * u64::from(tiles)) * 4),
                dispatch: Dispatch::Direct(split_groups(tiles, self.config.max_groups_x)),
            }),
        })
    }

    /// Every check of [`Scan::bind_indirect`]'s buffers: returns the length's word index.
    fn check_indirect(
        &self,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        len: &wgpu::Buffer,
        len_offset: u64,
        total: Option<&wgpu::Buffer>,
    ) -> Result<u32, ScanError> {
        if input == output {
            return Err(ScanError::Aliasing("input", "output"));
        }
        if len == output {
            return Err(ScanError::Aliasing("length", "output"));
        }
        check_storage("input", input)?;
        check_storage("output", output)?;
        check_storage("length", len)?;
        if !len_offset.is_multiple_of(4) {
            return Err(ScanError::UnalignedLenOffset(len_offset));
        }
        if len.size() < len_offset + 4 {
            return Err(ScanError::BufferTooSmall {
                which: "length",
                size: len.size(),
                needed: len_offset + 4,
            });
        }
        for (which, b) in [("input", input), ("output", output)] {
            if b.size() < 4 {
                return Err(ScanError::BufferTooSmall {
                    which,
                    size: b.size(),
                    needed: 4,
                });
            }
        }
        self.check_total(total, [input, output])?;
        if let Some(t) = total {
            if t == len {
                return Err(ScanError::Aliasing("length", "total"));
            }
        }
        u32::try_from(len_offset / 4).map_err(|_| ScanError::BufferTooSmall {
            which: "length (offset beyond u32 words)",
            size: len.size(),
            needed: len_offset + 4,
        })
    }

    /// Like [`Scan::bind`], but `n` is the `u32` at byte `len_offset` of `len`, read on the GPU
    /// each time the scan runs. A one-thread pre-pass clamps it to `max_len` and writes the
    /// scan's own indirect dispatch arguments; the kernel further clamps `n` to the `input` and
    /// `output` bindings (each bound whole, up to the device's binding limit). `n = 0` writes
    /// only the total (0), if requested.
    #[allow(clippy::too_many_arguments)]
    pub fn bind_indirect(
        &self,
        device: &wgpu::Device,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        len: &wgpu::Buffer,
        len_offset: u64,
        kind: ScanKind,
        total: Option<&wgpu::Buffer>,
    ) -> Result<ScanBinding, ScanError> {
        let len_index = self.check_indirect(input, output, len, len_offset, total)?;
        let params = self.params(device, 0, kind, total.is_some(), len_index);
        let prepare_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gpu-scan prepare"),
            layout: &self.prepare_layout,
            entries: &[
                buffer_entry(0, len, None),
                buffer_entry(1, &params, None),
                buffer_entry(2, &self.dispatch, Some(12)),
            ],
        });
        let whole =
            |b: &wgpu::Buffer, align: u64| b.size().min(self.binding_limit * 4) / align * align;
        let view4 = |b, dummy| match whole(b, 16) {
            0 => (dummy, None),
            size => (b, Some(size)),
        };
        let views = Views {
            input: (input, Some(whole(input, 4))),
            output: (output, Some(whole(output, 4))),
            input4: view4(input, &self.dummy_in4),
            output4: view4(output, &self.dummy_out4),
        };
        let bind_group = self.bind_group(device, &views, total, &params);
        Ok(ScanBinding {
            scan_id: self.id,
            work: Some(Work {
                bind_group,
                _params: params,
                clear_bytes: None,
                dispatch: Dispatch::Indirect(prepare_group),
            }),
        })
    }

    /// Records the bound scan into the caller's encoder: a `clear_buffer` of the scratch and
    /// one compute pass (the pre-pass and the scan for an indirect binding). Allocates nothing;
    /// may be called any number of times, in one encoder or many.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        binding: &ScanBinding,
    ) -> Result<(), ScanError> {
        self.encode_timed(encoder, binding, &mut |_| None)
    }

    /// [`Scan::encode`] with a named timestamp span hook: `span` is called with the pass name
    /// (`"gpu-scan"` or `"gpu-scan indirect"`) and may return the timestamp writes for it.
    pub fn encode_timed<'q>(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        binding: &ScanBinding,
        span: &mut dyn FnMut(&'static str) -> Option<wgpu::ComputePassTimestampWrites<'q>>,
    ) -> Result<(), ScanError> {
        if binding.scan_id != self.id {
            return Err(ScanError::ForeignBinding);
        }
        let Some(work) = &binding.work else {
            return Ok(());
        };
        encoder.clear_buffer(&self.scratch, 0, work.clear_bytes);
        let name = match work.dispatch {
            Dispatch::Direct(_) => "gpu-scan",
            Dispatch::Indirect(_) => "gpu-scan indirect",
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(name),
            timestamp_writes: span(name),
        });
        match &work.dispatch {
            Dispatch::Direct((x, y)) => {
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &work.bind_group, &[]);
                pass.dispatch_workgroups(*x, *y, 1);
            }
            Dispatch::Indirect(prepare_group) => {
                pass.set_pipeline(&self.prepare_pipeline);
                pass.set_bind_group(0, prepare_group, &[]);
                pass.dispatch_workgroups(1, 1, 1);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &work.bind_group, &[]);
                pass.dispatch_workgroups_indirect(&self.dispatch, 0);
            }
        }
        Ok(())
    }

    /// One-off convenience: [`Scan::bind`] then [`Scan::encode`]. It allocates a parameter
    /// block and a bind group on every call; bind once and encode many times instead when the
    /// same scan runs every frame.
    #[allow(clippy::too_many_arguments)]
    pub fn bind_and_encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        n: u32,
        kind: ScanKind,
        total: Option<&wgpu::Buffer>,
    ) -> Result<(), ScanError> {
        let binding = self.bind(device, input, output, n, kind, total)?;
        self.encode(encoder, &binding)
    }

    fn params(
        &self,
        device: &wgpu::Device,
        n: u32,
        kind: ScanKind,
        write_total: bool,
        len_index: u32,
    ) -> wgpu::Buffer {
        let params = ScanParams {
            n,
            inclusive: u32::from(kind == ScanKind::Inclusive),
            write_total: u32::from(write_total),
            len_index,
        };
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("gpu-scan params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::STORAGE,
        })
    }

    fn bind_group(
        &self,
        device: &wgpu::Device,
        views: &Views<'_>,
        total: Option<&wgpu::Buffer>,
        params: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gpu-scan"),
            layout: &self.layout,
            entries: &[
                buffer_entry(0, views.input.0, views.input.1),
                buffer_entry(1, views.output.0, views.output.1),
                buffer_entry(6, views.input4.0, views.input4.1),
                buffer_entry(7, views.output4.0, views.output4.1),
                buffer_entry(2, &self.scratch, None),
                buffer_entry(3, total.unwrap_or(&self.dummy_out), Some(4)),
                buffer_entry(4, params, None),
                buffer_entry(5, &self.counters, None),
            ],
        })
    }
}

/// A [`Scan`] bound to the caller's buffers (see [`Scan::bind`] and [`Scan::bind_indirect`]):
/// the bind group and parameter block, created once. It keeps the buffers alive; record it with
/// [`Scan::encode`] on the `Scan` that made it.
#[derive(Debug)]
pub struct ScanBinding {
    scan_id: u64,
    work: Option<Work>,
}

impl ScanBinding {
    /// The compute dispatches one [`Scan::encode`] of this binding records: 0 for an empty
    /// scan, 1 for a direct one, 2 for an indirect one (its pre-pass and the scan).
    pub fn dispatches(&self) -> u32 {
        match self.work.as_ref().map(|w| &w.dispatch) {
            None => 0,
            Some(Dispatch::Direct(_)) => 1,
            Some(Dispatch::Indirect(_)) => 2,
        }
    }
}

#[derive(Debug)]
struct Work {
    bind_group: wgpu::BindGroup,
    _params: wgpu::Buffer,
    /// Bytes of scratch to clear (`None`: all of it, for indirect scans).
    clear_bytes: Option<u64>,
    dispatch: Dispatch,
}

#[derive(Debug)]
enum Dispatch {
    Direct((u32, u32)),
    /// The pre-pass's bind group; the scan dispatch reads the arguments it writes.
    Indirect(wgpu::BindGroup),
}

/// The four views of input and output the kernel binds: (buffer, binding size).
struct Views<'a> {
    input: (&'a wgpu::Buffer, Option<u64>),
    output: (&'a wgpu::Buffer, Option<u64>),
    input4: (&'a wgpu::Buffer, Option<u64>),
    output4: (&'a wgpu::Buffer, Option<u64>),
}

/// Storage buffers the scan kernel binds in its one compute stage.
pub const STORAGE_BUFFERS_PER_STAGE: u32 = 8;

/// The device limits every scan needs, whatever its descriptor (the README's device
/// requirements table): checked by [`Scan::new`] before anything is created, so a device that
/// falls short gets a [`ScanError::DeviceLimit`] instead of a wgpu validation error.
pub fn check_device_limits(limits: &wgpu::Limits) -> Result<(), ScanError> {
    let checks = [
        (
            "max_storage_buffers_per_shader_stage",
            STORAGE_BUFFERS_PER_STAGE,
            limits.max_storage_buffers_per_shader_stage,
        ),
        ("max_bind_groups", 1, limits.max_bind_groups),
        (
            "max_bindings_per_bind_group",
            STORAGE_BUFFERS_PER_STAGE,
            limits.max_bindings_per_bind_group,
        ),
        (
            "max_compute_invocations_per_workgroup",
            32,
            limits.max_compute_invocations_per_workgroup,
        ),
        (
            "max_compute_workgroup_size_x",
            32,
            limits.max_compute_workgroup_size_x,
        ),
    ];
    for (limit, needed, available) in checks {
        if available < needed {
            return Err(ScanError::DeviceLimit {
                limit,
                needed: u64::from(needed),
                available: u64::from(available),
            });
        }
    }
    Ok(())
}

fn check_storage(which: &'static str, buffer: &wgpu::Buffer) -> Result<(), ScanError> {
    if buffer.usage().contains(wgpu::BufferUsages::STORAGE) {
        Ok(())
    } else {
        Err(ScanError::MissingStorageUsage { which })
    }
}

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them. The kernel is listed with and without
/// subgroups, with debug counters, and in the forced-fallback testing mode.
pub fn wgsl_modules() -> Vec<(String, String)> {
    let base = KernelConfig {
        workgroup_size: 256,
        items_per_thread: 16,
        spin_limit: DEFAULT_SPIN_LIMIT,
        counters: false,
        max_len: 1 << 25,
        max_groups_x: 65535,
        subgroups: false,
    };
    let subgroups = KernelConfig {
        subgroups: true,
        ..base
    };
    let testing = KernelConfig {
        spin_limit: 0,
        counters: true,
        ..base
    };
    let testing_subgroups = KernelConfig {
        subgroups: true,
        ..testing
    };
    let cpu_shape = KernelConfig {
        workgroup_size: CPU_WORKGROUP_SIZE,
        items_per_thread: CPU_ITEMS_PER_THREAD,
        subgroups: true,
        ..base
    };
    vec![
        ("gpu-scan/scan (no subgroups)".into(), base.scan_source()),
        (
            "gpu-scan/scan (CPU-adapter shape 32 x 1024, subgroups)".into(),
            cpu_shape.scan_source(),
        ),
        ("gpu-scan/scan (subgroups)".into(), subgroups.scan_source()),
        (
            "gpu-scan/scan (no subgroups, forced fallback, counters)".into(),
            testing.scan_source(),
        ),
        (
            "gpu-scan/scan (subgroups, forced fallback, counters)".into(),
            testing_subgroups.scan_source(),
        ),
        ("gpu-scan/prepare".into(), base.prepare_source()),
    ]
}
