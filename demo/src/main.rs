//! `restir-demo`: render, compare and inspect world-space ReSTIR GI.

mod compare;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use restir_world::{GpuContext, GpuTimer, gpu::buffers};

mod render_cmd;

#[derive(Parser, Debug)]
#[command(name = "restir-demo", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the adapter, its optional features and its limits.
    Info,
    /// Render a built-in scene with nee, ris or world-restir (every knob a flag), static or
    /// with a camera animation; writes PNG + EXR images and prints per-pass GPU times.
    Render(render_cmd::RenderArgs),
    /// The default job: prove the device works by running a compute shader and writing its
    /// image as a PNG.
    Smoke {
        /// Output directory.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Image size, WxH.
        #[arg(long, default_value = "256x256", value_parser = parse_size)]
        size: (u32, u32),
    },
    /// Speed against error: run methods over the same frames and camera, measure per-stage
    /// GPU time and the error against a converged reference, compare at equal time, and write
    /// report.md, report.json, error_vs_time.svg and strip.png into --out.
    Compare(CompareArgs),
}

#[derive(clap::Args, Debug)]
struct CompareArgs {
    /// Scenes, comma-separated: built-in names (cornell, many-lights, furnace, furnace-sphere)
    /// or scene files (.gltf, .glb, .obj).
    #[arg(long, default_value = "many-lights", value_delimiter = ',')]
    scene: Vec<String>,
    /// Methods of the registry, comma-separated, each `name` or `name:variant`; default: every
    /// registered method.
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
    /// Frames per method.
    #[arg(long, default_value_t = 16)]
    frames: u32,
    /// Image size, WxH.
    #[arg(long, default_value = "128x128", value_parser = parse_size)]
    size: (u32, u32),
    /// Output directory.
    #[arg(long, default_value = "out/compare")]
    out: PathBuf,
    /// Camera motion over the frames.
    #[arg(long, value_enum, default_value_t = compare::CameraMode::Static)]
    camera: compare::CameraMode,
    /// An external reference (combined image, linear EXR) instead of the GPU reference mode.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// The external reference's indirect image (linear EXR); without it indirect errors are
    /// not reported.
    #[arg(long, requires = "reference")]
    reference_indirect: Option<PathBuf>,
    /// Samples per pixel of the GPU reference.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Reference cache directory.
    #[arg(long, default_value = "out/cache")]
    cache: PathBuf,
    /// Do not read or write the reference cache.
    #[arg(long)]
    no_cache: bool,
    /// many-lights: number of lights.
    #[arg(long, default_value_t = 10_000)]
    lights: u32,
    /// Seed of the methods' random numbers.
    #[arg(long, default_value_t = 1)]
    seed: u32,
    /// Frames of each equal-time run (capped at --frames).
    #[arg(long, default_value_t = 8)]
    equal_time_frames: u32,
    /// The method others are compared against at equal time (default: world-restir when
    /// listed, else the slowest method).
    #[arg(long)]
    equal_time_to: Option<String>,
    /// Moving camera: evaluate the error every N frames (and at the last), each against its
    /// own reference.
    #[arg(long, default_value_t = 8)]
    eval_every: u32,
    /// Negative control for tests: METHOD=FACTOR multiplies that method's indirect image.
    #[arg(long, hide = true, value_parser = parse_bias)]
    plant_bias: Vec<(String, f32)>,
    /// Do not write the reference EXRs into --out.
    #[arg(long)]
    no_exr: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

fn parse_bias(s: &str) -> Result<(String, f32), String> {
    let (m, f) = s
        .split_once('=')
        .ok_or_else(|| format!("expected METHOD=FACTOR, got {s:?}"))?;
    let f: f32 = f.parse().map_err(|_| format!("bad factor in {s:?}"))?;
    Ok((m.to_owned(), f))
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WxH, got {s:?}"))?;
    let w: u32 = w.parse().map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h.parse().map_err(|_| format!("bad height in {s:?}"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s:?} must be between 1x1 and 16384x16384"));
    }
    Ok((w, h))
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command.unwrap_or(Command::Smoke {
        out: "out".into(),
        size: (256, 256),
    }) {
        Command::Info => info(),
        Command::Render(args) => render_cmd::render(&args),
        Command::Smoke { out, size } => smoke(&out, size),
        Command::Compare(args) => compare_cmd(args),
    }
}

fn compare_cmd(a: CompareArgs) -> Result<()> {
    let ctx = GpuContext::new()?;
    eprintln!("{}", ctx.describe());
    let methods = if a.methods.is_empty() {
        restir_world::render::registry()
            .iter()
            .map(|e| e.name.to_owned())
            .collect()
    } else {
        a.methods
    };
    let opts = compare::CompareOptions {
        scenes: a.scene,
        methods,
        frames: a.frames,
        size: a.size,
        out: a.out,
        camera: a.camera,
        reference: a.reference,
        reference_indirect: a.reference_indirect,
        reference_spp: a.reference_spp,
        cache: (!a.no_cache).then_some(a.cache),
        lights: a.lights,
        seed: a.seed,
        equal_time_frames: a.equal_time_frames,
        equal_time_to: a.equal_time_to,
        eval_every: a.eval_every,
        plant_bias: a.plant_bias,
        write_exr: !a.no_exr,
        progress: !a.quiet,
    };
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let report = compare::run(&ctx, &opts, command)?;
    for sc in &report.scenes {
        for m in &sc.methods {
            println!(
                "{:>12} {:>14}: {} ms/frame, frame relMSE indirect {} combined {}",
                sc.scene,
                m.method,
                m.ms_per_frame.map_or("-".into(), |v| format!("{v:.3}")),
                m.frame_indirect
                    .map_or("-".into(), |e| format!("{:.4e}", e.rel_mse)),
                m.frame_combined
                    .map_or("-".into(), |e| format!("{:.4e}", e.rel_mse)),
            );
        }
    }
    println!("report: {}", opts.out.join("report.md").display());
    Ok(())
}

fn info() -> Result<()> {
    let ctx = GpuContext::new()?;
    println!("{}", ctx.describe());
    let l = ctx.limits();
    println!(
        "limits: max_storage_buffer_binding_size={} max_buffer_size={} \
         max_compute_workgroup_storage_size={} max_compute_invocations_per_workgroup={} \
         max_compute_workgroups_per_dimension={} max_storage_buffers_per_shader_stage={}",
        l.max_storage_buffer_binding_size,
        l.max_buffer_size,
        l.max_compute_workgroup_storage_size,
        l.max_compute_invocations_per_workgroup,
        l.max_compute_workgroups_per_dimension,
        l.max_storage_buffers_per_shader_stage,
    );
    let sg = ctx.adapter.get_info();
    println!(
        "subgroup sizes: {}..{}",
        sg.subgroup_min_size, sg.subgroup_max_size
    );
    Ok(())
}

const SMOKE_WGSL: &str = r#"
struct Params { width: u32, height: u32 }
@group(0) @binding(0) var<storage, read_write> pixels: array<u32>;
@group(0) @binding(1) var<uniform> params: Params;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height { return; }
    let uv = vec2<f32>(id.xy) / vec2<f32>(f32(params.width), f32(params.height));
    let checker = f32(((id.x / 32u) + (id.y / 32u)) % 2u);
    let rgb = vec3<f32>(uv.x, uv.y, 0.25 + 0.5 * checker);
    pixels[id.y * params.width + id.x] = pack4x8unorm(vec4<f32>(rgb, 1.0));
}
"#;

fn smoke(out: &Path, (width, height): (u32, u32)) -> Result<()> {
    let ctx = GpuContext::new()?;
    println!("{}", ctx.describe());
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("smoke"),
        source: wgpu::ShaderSource::Wgsl(SMOKE_WGSL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("smoke"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let pixels = buffers::storage_zeroed(device, "pixels", u64::from(width * height) * 4);
    let params = buffers::with_usage(
        device,
        "params",
        &[width, height, 0, 0],
        wgpu::BufferUsages::UNIFORM,
    );
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("smoke"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: pixels.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: params.as_entire_binding(),
            },
        ],
    });
    let mut timer = GpuTimer::new(&ctx, 1);
    let mut encoder = device.create_command_encoder(&Default::default());
    timer.span(&mut encoder, "smoke", |enc| {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    });
    timer.resolve(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    let words: Vec<u32> = buffers::read(&ctx, &pixels)?;
    match timer.read(&ctx) {
        Ok(t) => println!("GPU time: {t}"),
        Err(e) => println!("GPU time: {e}"),
    }
    let bytes: Vec<u8> = bytemuck::cast_slice(&words[..(width * height) as usize]).to_vec();
    let img = image::RgbaImage::from_raw(width, height, bytes).context("image size")?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join("smoke.png");
    write_atomically(&path, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(anyhow::Error::from)
    })?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Writes through a temporary file in the same directory and renames it into place, so the
/// output is written whole or not at all.
fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = path.with_extension(format!(
        "tmp{}.{}",
        std::process::id(),
        path.extension().and_then(|e| e.to_str()).unwrap_or("out")
    ));
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).with_context(|| format!("renaming into {}", path.display()))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.with_context(|| format!("writing {}", path.display()))
}
