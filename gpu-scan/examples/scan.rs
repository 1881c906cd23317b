//! A standalone use of gpu-scan: create a device, upload numbers, scan them, read them back.
//!
//! `cargo run -p gpu-scan --example scan`

use gpu_scan::{Scan, ScanDescriptor, ScanKind};
use wgpu::util::DeviceExt;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    pollster::block_on(run())
}

/// The default adapter and a device with subgroups when the adapter has them (the scan uses
/// them if present).
async fn device() -> Result<(wgpu::Adapter, wgpu::Device, wgpu::Queue), Box<dyn std::error::Error>>
{
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = instance
        .request_adapter(&wgpu::RequestAdapterOptions::default())
        .await
        .map_err(|e| {
            format!("no GPU adapter ({e}); on a machine without a GPU install lavapipe")
        })?;
    // Ask for subgroups when the adapter has them: the scan uses them if present.
    let features = adapter.features() & wgpu::Features::SUBGROUP;
    let (device, queue) = adapter
        .request_device(&wgpu::DeviceDescriptor {
            label: Some("gpu-scan example"),
            required_features: features,
            ..Default::default()
        })
        .await?;
    Ok((adapter, device, queue))
}

async fn run() -> Result<(), Box<dyn std::error::Error>> {
    let (adapter, device, queue) = device().await?;
    let input: Vec<u32> = (1..=10_000).collect();
    let n = input.len() as u32;
    let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
    let input_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("input"),
        contents: bytemuck::cast_slice(&input),
        usage,
    });
    let output_buf = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("output"),
        size: u64::from(n) * 4,
        usage,
        mapped_at_creation: false,
    });
    let total_buf = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("total"),
        size: 4,
        usage,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(n) * 4 + 4,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });

    let scan = Scan::new(&device, &ScanDescriptor::for_device(&device, n))?;
    let mut encoder = device.create_command_encoder(&Default::default());
    // Bind once to the buffers; encode (here once) with no allocation.
    let binding = scan.bind(
        &device,
        &input_buf,
        &output_buf,
        n,
        ScanKind::Exclusive,
        Some(&total_buf),
    )?;
    scan.encode(&mut encoder, &binding)?;
    encoder.copy_buffer_to_buffer(&output_buf, 0, &readback, 0, u64::from(n) * 4);
    encoder.copy_buffer_to_buffer(&total_buf, 0, &readback, u64::from(n) * 4, 4);
    queue.submit([encoder.finish()]);

    let slice = readback.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    rx.recv()??;
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&slice.get_mapped_range()?);
    let (out, total) = words.split_at(n as usize);

    assert_eq!(out, gpu_scan::cpu::scan(&input, ScanKind::Exclusive));
    println!(
        "exclusive scan of 1..=10000 on {:?} (subgroups: {}): out[0..4] = {:?}, out[9999] = {}, total = {}",
        adapter.get_info().name,
        scan.config().subgroups,
        &out[..4],
        out[9999],
        total[0]
    );
    Ok(())
}
