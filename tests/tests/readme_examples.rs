//! The user-shader examples of the gpu-hash and reservoir READMEs, taken verbatim out of the
//! README files (the ```wgsl block after `<!-- user-shader example -->`), composed as the
//! README says, compiled and run on the shared test device, and checked against the Rust twins.

use glam::Vec3;
use gpu_hash::{CellSizing, GridBinding, HASH_NOT_FOUND, HashGridParams, HashTable, TableConfig};
use rand::{Rng, SeedableRng, rngs::StdRng};
use reservoir::reuse::{CANONICAL, Combination, Reuse, cap_m};
use reservoir::{PackedReservoir, Reservoir};
use tests::{buffers, gpu};

/// The WGSL block that follows the `<!-- user-shader example -->` marker in `readme`.
fn example_block(readme: &str, which: &str) -> String {
    let after = readme
        .split_once("<!-- user-shader example -->")
        .unwrap_or_else(|| panic!("{which}: no user-shader example marker"))
        .1;
    let body = after
        .split_once("```wgsl\n")
        .unwrap_or_else(|| panic!("{which}: no wgsl block after the marker"))
        .1;
    body.split_once("```")
        .unwrap_or_else(|| panic!("{which}: unterminated wgsl block"))
        .0
        .to_owned()
}

/// A pipeline for `entry` of `source` with explicit group layouts.
fn pipeline(
    device: &wgpu::Device,
    source: &str,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
) -> wgpu::ComputePipeline {
    if let Err(e) = tests::wgsl::validate(entry, source) {
        panic!("{e}");
    }
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(entry),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(entry),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

fn storage_group(
    device: &wgpu::Device,
    buffers: &[&wgpu::Buffer],
) -> (wgpu::BindGroupLayout, wgpu::BindGroup) {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = (0..buffers.len() as u32)
        .map(|b| buffers::storage_entry(b, b == 0))
        .collect();
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("user buffers"),
        entries: &entries,
    });
    let group_entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("user buffers"),
        layout: &layout,
        entries: &group_entries,
    });
    (layout, group)
}

/// The README shader's output against the twins: each point's jitter, the bucket of its slot,
/// and every slot's indices 0..count. Returns the cells used.
fn check_inserts(
    params: &HashGridParams,
    points: &[[f32; 4]],
    jittered: &[[f32; 4]],
    out: &[[u32; 2]],
    counters: &[u32],
) -> usize {
    let mut members: std::collections::HashMap<u32, Vec<u32>> = Default::default();
    for i in 0..points.len() {
        let p = Vec3::from_slice(&points[i][..3]);
        let q = Vec3::from_slice(&jittered[i][..3]);
        // The jitter against its twin (same u as the shader: the library hashes of i).
        let u = [
            (gpu_hash::hash::pcg(i as u32) >> 8) as f32 / 16_777_216.0,
            (gpu_hash::hash::xxhash32(i as u32) >> 8) as f32 / 16_777_216.0,
        ];
        let twin = gpu_hash::jitter(p, Vec3::Y, u, params.cell_size(p));
        assert!(
            (q - twin).length() <= 1e-5 * (1.0 + p.length()),
            "point {i}: jitter {q} vs twin {twin}"
        );
        // The slot is in the twin's bucket of the jittered position.
        let [slot, index] = out[i];
        assert_ne!(index, HASH_NOT_FOUND, "point {i}: not inserted");
        assert_eq!(slot / params.slots_per_bucket, params.cell(q).bucket);
        members.entry(slot).or_default().push(index);
    }
    for (slot, idx) in &mut members {
        idx.sort_unstable();
        assert!(idx.iter().enumerate().all(|(k, &v)| v == k as u32));
        assert_eq!(counters[*slot as usize] as usize, idx.len());
    }
    members.len()
}

#[test]
fn gpu_hash_readme_user_shader_runs_and_matches_the_twins() {
    let user = example_block(include_str!("../../gpu-hash/README.md"), "gpu-hash");
    let ctx = gpu::context();
    let device = &ctx.device;
    let config = TableConfig {
        num_buckets: 4096,
        ..TableConfig::default()
    };
    let params =
        HashGridParams::new(&config, &CellSizing::default(), Vec3::new(0.0, 1.0, -4.0)).unwrap();
    let table = HashTable::new(device, &ctx.queue, &params).unwrap();

    // The README's host side: one GridBinding places the table.
    let grid = GridBinding::table(0, 0);
    let source = format!("{}\n{user}", gpu_hash::compose_grid(&[grid]));
    let table_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &grid.layout_entries(),
    });
    let table_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &table_layout,
        entries: &grid.bind_group_entries(&table.buffers()),
    });

    let n = 20_000usize;
    let mut rng = StdRng::seed_from_u64(21);
    let points: Vec<[f32; 4]> = (0..n)
        .map(|_| {
            [
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                1.0,
            ]
        })
        .collect();
    let points_buf = buffers::storage_from(device, "points", &points);
    let jittered_buf = buffers::storage_zeroed(device, "jittered", n as u64 * 16);
    let out_buf = buffers::storage_zeroed(device, "out", n as u64 * 8);
    let (user_layout, user_group) = storage_group(device, &[&points_buf, &jittered_buf, &out_buf]);
    let pipeline = pipeline(
        device,
        &source,
        "insert_jittered",
        &[&table_layout, &user_layout],
    );
    gpu::run(ctx, |enc| {
        table.encode_clear(enc);
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &table_group, &[]);
        pass.set_bind_group(1, &user_group, &[]);
        pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
    });
    let jittered: Vec<[f32; 4]> = buffers::read(ctx, &jittered_buf).unwrap();
    let out: Vec<[u32; 2]> = buffers::read(ctx, &out_buf).unwrap();
    let counters: Vec<u32> = buffers::read(ctx, table.counters()).unwrap();

    let cells = check_inserts(&params, &points, &jittered, &out, &counters);
    eprintln!("gpu-hash README example: {n} points in {cells} cells");
}

/// The twin's `Stored` (x, W, M).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Stored {
    x: f32,
    ucw: f32,
    m: u32,
}

/// The twin of the README's `temporal` pass at pixel `i`.
fn twin_temporal(i: u32, frame: u32, previous: &[Stored]) -> Stored {
    let target = |x: f32| x * x;
    let mut rng = reservoir::rng::Rng::seed(i, frame, 0);
    let mut r = Reservoir::empty();
    let mut y = 0.0;
    for _ in 0..8 {
        let x = rng.next_f32();
        if r.update(target(x), rng.next_f32()) {
            y = x;
        }
    }
    r.finalize(target(y));
    let prev = previous[i as usize];
    let m_prev = cap_m(prev.m, 20);
    let mut c = Reuse::begin(
        Combination::Pairwise,
        r.pack(),
        target(y),
        1,
        m_prev,
        rng.next_f32(),
    );
    let mut x = y;
    let other = PackedReservoir {
        ucw: prev.ucw,
        m: m_prev,
    };
    if c.neighbour(
        0,
        other,
        target(prev.x),
        target(prev.x),
        target(y),
        rng.next_f32(),
    ) {
        x = prev.x;
    }
    let w = c.finish();
    if c.selected() == CANONICAL {
        x = y;
    }
    Stored {
        x,
        ucw: w.ucw,
        m: w.m,
    }
}

/// The twin of the README's `spatial` pass at pixel `i`.
fn twin_spatial(i: u32, frame: u32, current: &[Stored]) -> Stored {
    let target = |x: f32| x * x;
    let n = current.len() as u32;
    let mut rng = reservoir::rng::Rng::seed(i, frame, 1);
    let own = current[i as usize];
    let left = current[((i + n - 1) % n) as usize];
    let right = current[((i + 1) % n) as usize];
    let packed = PackedReservoir {
        ucw: own.ucw,
        m: own.m,
    };
    let m_n = left.m.saturating_add(right.m);
    let mut c = Reuse::begin(
        Combination::Pairwise,
        packed,
        target(own.x),
        2,
        m_n,
        rng.next_f32(),
    );
    let mut x = own.x;
    for (j, q) in [left, right].iter().enumerate() {
        let other = PackedReservoir { ucw: q.ucw, m: q.m };
        if c.neighbour(
            j as u32,
            other,
            target(q.x),
            target(q.x),
            target(own.x),
            rng.next_f32(),
        ) {
            x = q.x;
        }
    }
    let w = c.finish();
    if c.selected() == CANONICAL {
        x = own.x;
    }
    Stored {
        x,
        ucw: w.ucw,
        m: w.m,
    }
}

/// One frame of the README shader against the twin, pass by pass from the GPU's own inputs
/// (`previous`: last frame's final reservoirs; `current`, `fin`: this frame's temporal and
/// final ones).
fn check_frame(frame: u32, previous: &[Stored], current: &[Stored], fin: &[Stored]) {
    let mut mismatches = 0;
    for i in 0..current.len() {
        for (got, want) in [
            (current[i], twin_temporal(i as u32, frame, previous)),
            (fin[i], twin_spatial(i as u32, frame, current)),
        ] {
            assert_eq!(got.m, want.m, "frame {frame} pixel {i}: M");
            // A WGSL division may differ by a few ulp (2.5 allowed), which can flip a
            // selection only at a near tie.
            if got.x != want.x {
                mismatches += 1;
                continue;
            }
            let ulps = got.ucw.to_bits().abs_diff(want.ucw.to_bits());
            assert!(
                ulps <= 16,
                "frame {frame} pixel {i}: W {} vs {}",
                got.ucw,
                want.ucw
            );
        }
    }
    assert!(
        mismatches <= current.len() / 1000,
        "frame {frame}: {mismatches} selections differ"
    );
}

#[test]
fn reservoir_readme_user_shader_runs_and_matches_the_twin() {
    let user = example_block(include_str!("../../reservoir/README.md"), "reservoir");
    let ctx = gpu::context();
    let device = &ctx.device;
    let source = format!("{}\n{}\n{user}", reservoir::wgsl(), reservoir::rng::WGSL);
    let n = 1usize << 14;
    let bytes = (n * size_of::<Stored>()) as u64;
    let bufs: Vec<wgpu::Buffer> = ["previous", "current", "final_out"]
        .iter()
        .map(|label| buffers::storage_zeroed(device, label, bytes))
        .collect();
    let frame_buf = buffers::storage_zeroed(device, "frame", 4);
    let entries: Vec<_> = (0..4).map(|b| buffers::storage_entry(b, false)).collect();
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &entries,
    });
    let all = [&bufs[0], &bufs[1], &bufs[2], &frame_buf];
    let group_entries: Vec<_> = all
        .iter()
        .enumerate()
        .map(|(b, buf)| wgpu::BindGroupEntry {
            binding: b as u32,
            resource: buf.as_entire_binding(),
        })
        .collect();
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &group_entries,
    });
    let passes = ["temporal", "spatial"].map(|e| pipeline(device, &source, e, &[&layout]));
    let (mut previous, mut fin) = (vec![Stored::default(); n], Vec::new());
    for frame in 0..2u32 {
        ctx.queue
            .write_buffer(&frame_buf, 0, bytemuck::bytes_of(&frame));
        gpu::run(ctx, |enc| {
            for p in &passes {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_pipeline(p);
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups((n as u32).div_ceil(64), 1, 1);
            }
            enc.copy_buffer_to_buffer(&bufs[2], 0, &bufs[0], 0, bytes);
        });
        // The twin from the GPU's own inputs of this frame, pass by pass.
        let current: Vec<Stored> = buffers::read(ctx, &bufs[1]).unwrap();
        fin = buffers::read(ctx, &bufs[2]).unwrap();
        check_frame(frame, &previous, &current, &fin);
        previous = fin.clone();
    }
    // f(x) = x over [0, 1): integral 1/2; the mean of 16384 estimates is within 0.01 with
    // overwhelming probability (each has a variance well below 0.1).
    let mean = fin.iter().map(|s| f64::from(s.x * s.ucw)).sum::<f64>() / n as f64;
    assert!((mean - 0.5).abs() < 0.01, "reuse estimate {mean}");
    assert!(fin.iter().all(|s| s.m > 8), "spatial reuse merged nothing");
    eprintln!("reservoir README example: mean estimate {mean:.4} (exact 0.5) after two frames");
}
