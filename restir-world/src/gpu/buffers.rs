//! Buffer upload and readback: the one place tests, benches and the demo get them from.

use wgpu::util::DeviceExt;

use super::{GpuContext, GpuError};

/// Usage for buffers that kernels read and write and tests upload to and read back.
pub const STORAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

/// Smallest buffer we create: bindings of size 0 are invalid, so empty data gets 16 bytes.
const MIN_SIZE: u64 = 16;

/// A storage buffer holding `data` (padded to 16 bytes when smaller).
pub fn storage_from<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    data: &[T],
) -> wgpu::Buffer {
    with_usage(device, label, data, STORAGE)
}

/// A buffer with `usage` holding `data` (padded to 16 bytes when smaller).
pub fn with_usage<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    data: &[T],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let bytes: &[u8] = bytemuck::cast_slice(data);
    if (bytes.len() as u64) < MIN_SIZE {
        let mut padded = bytes.to_vec();
        padded.resize(MIN_SIZE as usize, 0);
        return device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &padded,
            usage,
        });
    }
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage,
    })
}

/// A zero-filled storage buffer of `size` bytes (at least 16).
pub fn storage_zeroed(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(MIN_SIZE).next_multiple_of(4),
        usage: STORAGE,
        mapped_at_creation: false,
    })
}

/// Reads a whole buffer back as `T`s (blocks until the GPU is done).
pub fn read<T: bytemuck::Pod>(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<T>, GpuError> {
    read_range(ctx, buffer, 0, buffer.size())
}

/// Reads `size` bytes at `offset` back as `T`s (blocks until the GPU is done).
pub fn read_range<T: bytemuck::Pod>(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<T>, GpuError> {
    if size == 0 {
        return Ok(Vec::new());
    }
    let padded = size.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback staging"),
        size: padded,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("readback"),
        });
    encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, padded);
    ctx.queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Map(e.to_string()))?
        .map_err(|e| GpuError::Map(e.to_string()))?;
    let view = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Map(e.to_string()))?;
    let bytes = &view[..size as usize];
    // `pod_collect_to_vec` copes with any alignment of the mapped bytes.
    let out = bytemuck::pod_collect_to_vec(&bytes[..bytes.len() / size_of::<T>() * size_of::<T>()]);
    drop(view);
    staging.unmap();
    Ok(out)
}

/// A compute-stage bind group layout entry for a whole buffer of type `ty`: the one place
/// that spells this struct out for the renderer, the tests and the benches.
pub fn layout_entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// [`layout_entry`] for a storage buffer.
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    layout_entry(binding, wgpu::BufferBindingType::Storage { read_only })
}
