//! Lights, sampling and camera WGSL: layouts against naga, GPU vs Rust twin on the same random
//! numbers, and a chi-square test of the GPU's light selection against power (with negative
//! controls).

use glam::{Vec2, Vec3};
use restir_world::gpu::{Access, Kernel, Resource, WgslModule};
use restir_world::lights::{self, AliasEntry, GpuLights, LightTriangle, Lights, LightsInfo};
use restir_world::sampling::{self, CameraGpu};
use restir_world::scene::{self, Material, Scene, Triangle};
use tests::{buffers, gpu};

#[test]
fn gpu_structs_match_naga_layouts() {
    let src = restir_world::gpu::compose(&lights::modules(0)).expect("compose");
    tests::assert_wgsl_layout!(
        LightTriangle,
        src,
        "LightTriangle",
        [p0, area, e1, prob, e2, triangle, emission, kind]
    );
    tests::assert_wgsl_layout!(AliasEntry, src, "AliasEntry", [prob, alias_index]);
    tests::assert_wgsl_layout!(
        LightsInfo,
        src,
        "LightsInfo",
        [
            count,
            env_width,
            total_power,
            env_height,
            env_light,
            _pad0,
            _pad1,
            _pad2
        ]
    );
    tests::assert_wgsl_layout!(
        CameraGpu,
        sampling::WGSL,
        "CameraGpu",
        [eye, width, forward, height, right, _pad0, up, _pad1]
    );
}

/// Per invocation i: 4 uniforms from rng_seed(i, 7, 3); a light sample; an ONB, a cosine
/// direction and a camera ray derived from them. 6 vec4 per invocation.
const KERNEL: &str = r#"
@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i >= arrayLength(&out) / 6u { return; }
    var st = rng_seed(i, 7u, 3u);
    let u = vec4<f32>(rng_next_f32(&st), rng_next_f32(&st), rng_next_f32(&st), rng_next_f32(&st));
    let s = lights_sample(u, &st);
    out[i * 6u] = vec4<f32>(s.position, s.pdf_area);
    out[i * 6u + 1u] = vec4<f32>(s.normal, bitcast<f32>(s.light));
    let n = normalize(vec3<f32>(u.x - 0.5, u.y - 0.5, u.z - 0.4));
    let b = sampling_onb(n);
    out[i * 6u + 2u] = vec4<f32>(b[0], bitcast<f32>(s.triangle));
    out[i * 6u + 3u] = vec4<f32>(b[1], 0.0);
    out[i * 6u + 4u] = vec4<f32>(sampling_cosine_hemisphere(n, u.zw), 0.0);
    let px = vec2<u32>(i % cam.width, (i / cam.width) % cam.height);
    out[i * 6u + 5u] = vec4<f32>(camera_ray_dir(cam, px, u.xy), 0.0);
}
"#;

/// Runs KERNEL over `n` invocations with `lights` and `cam`; returns the raw vec4s.
fn run_kernel(l: &Lights, cam: &CameraGpu, n: u32) -> Vec<[f32; 4]> {
    let ctx = gpu::context();
    let device = &ctx.device;
    let set = lights::bindings()
        .buffer("out", "array<vec4<f32>>", Access::ReadWrite)
        .buffer("cam", "CameraGpu", Access::Uniform);
    // The lights' bindings header becomes the whole set's (lights + out + cam).
    let mut modules = lights::modules(0);
    for m in &mut modules {
        if m.name == "lights-bindings" {
            m.source = set.wgsl(0);
        }
    }
    modules.extend([
        WgslModule::new("workgroup", &[], restir_world::gpu::workgroup_size_wgsl()),
        WgslModule::new("kernel", &["rng", "lights", "workgroup"], KERNEL),
    ]);
    let layout = set.layout(device);
    let src = restir_world::gpu::compose(&modules).expect("compose");
    let kernel = Kernel::new(device, "lights test", &src, &[&layout], &["main"]);
    let gl = GpuLights::new(device, l).unwrap();
    let out = buffers::storage_zeroed(device, "out", u64::from(n) * 6 * 16);
    let cam_buf = buffers::with_usage(device, "cam", &[*cam], wgpu::BufferUsages::UNIFORM);
    let mut res: Vec<(&str, Resource)> = gl.resources().into();
    res.extend([("out", (&out).into()), ("cam", (&cam_buf).into())]);
    let group = layout.bind(device, res).expect("bind");
    let pass = kernel.pass(device, "main", &[&group], n);
    gpu::run(ctx, |enc| pass.record(enc));
    buffers::read(ctx, &out).unwrap()
}

fn test_camera() -> CameraGpu {
    CameraGpu::new(&scene::Camera {
        eye: Vec3::new(0.3, 1.0, -2.0),
        target: Vec3::new(0.1, 0.8, 1.0),
        up: Vec3::Y,
        vfov_deg: 50.0,
        width: 37,
        height: 23,
    })
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol * (1.0 + b.abs().max_element())
}

#[test]
fn gpu_sampling_matches_the_rust_twin() {
    let scene = scene::many_lights(1000, 5, 8, 8).unwrap();
    let l = Lights::build(&scene);
    let cam = test_camera();
    let n = 20_000u32;
    let out = run_kernel(&l, &cam, n);
    let v = |i: usize| Vec3::new(out[i][0], out[i][1], out[i][2]);
    let mut worst = 0.0f32;
    for i in 0..n {
        let mut rng = reservoir::rng::Rng::seed(i, 7, 3);
        let u = [0; 4].map(|_| rng.next_f32());
        let s = l.sample(u, &mut rng).unwrap();
        let k = i as usize * 6;
        // The picked light is exactly the twin's: same f32 product, same truncation.
        assert_eq!(out[k + 1][3].to_bits(), s.light, "invocation {i}");
        assert_eq!(out[k + 2][3].to_bits(), s.triangle, "invocation {i}");
        assert!(
            close(v(k), s.position, 1e-5),
            "{i}: {} vs {}",
            v(k),
            s.position
        );
        // A quotient: WGSL allows 2.5 ulp (exact on lavapipe, 1 ulp off on an NVIDIA H200).
        let pdf = out[k][3];
        assert!(
            (pdf - s.pdf_area).abs() <= 1e-6 * s.pdf_area.abs(),
            "{i}: pdf {pdf} vs {}",
            s.pdf_area
        );
        assert!(close(v(k + 1), s.normal, 1e-5), "{i}: normal");
        let nrm = Vec3::new(u[0] - 0.5, u[1] - 0.5, u[2] - 0.4).normalize();
        let (t, b) = sampling::onb(nrm);
        assert!(
            close(v(k + 2), t, 1e-5) && close(v(k + 3), b, 1e-5),
            "{i}: onb"
        );
        let d = sampling::cosine_hemisphere(nrm, Vec2::new(u[2], u[3]));
        assert!(close(v(k + 4), d, 1e-4), "{i}: cosine {} vs {d}", v(k + 4));
        let px = [i % cam.width, (i / cam.width) % cam.height];
        let r = cam.ray_dir(px, Vec2::new(u[0], u[1]));
        assert!(close(v(k + 5), r, 1e-5), "{i}: camera");
        worst = worst.max((v(k) - s.position).abs().max_element());
    }
    eprintln!("largest position difference GPU vs twin: {worst:e}");
}

#[test]
fn gpu_without_lights_returns_zero_pdf() {
    let mut s = Scene::default();
    let m = s.add_material(Material::new([0.5; 3], [0.0; 3]));
    s.push_box(Vec3::ZERO, Vec3::ONE, m);
    let l = Lights::build(&s);
    let out = run_kernel(&l, &test_camera(), 64);
    for i in 0..64 {
        assert_eq!(out[i * 6][3], 0.0);
        assert_eq!(out[i * 6 + 1][3].to_bits(), u32::MAX);
    }
}

/// Chi-square statistic of `counts` against probabilities `p` (bins with expectation < 5 are
/// merged into one).
fn chi_square(counts: &[u64], p: &[f64]) -> (f64, usize) {
    let total: u64 = counts.iter().sum();
    let (mut chi, mut dof) = (0.0, 0usize);
    let (mut rest_o, mut rest_e) = (0.0, 0.0);
    for (&c, &p) in counts.iter().zip(p) {
        let e = p * total as f64;
        if e < 5.0 {
            rest_o += c as f64;
            rest_e += e;
        } else {
            chi += (c as f64 - e).powi(2) / e;
            dof += 1;
        }
    }
    if rest_e > 0.0 {
        chi += (rest_o - rest_e).powi(2) / rest_e.max(1e-9);
        dof += 1;
    }
    (chi, dof.saturating_sub(1))
}

/// Upper quantile of chi-square with `dof` degrees of freedom at z standard deviations
/// (Wilson-Hilferty).
fn chi_square_threshold(dof: usize, z: f64) -> f64 {
    let k = dof as f64;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

#[test]
fn gpu_light_selection_follows_power_chi_square() {
    // 64 emissive triangles of random area and emission (over three decades) plus dark ones.
    let mut s = Scene::default();
    let dark = s.add_material(Material::new([0.5; 3], [0.0; 3]));
    let mut rng = reservoir::rng::Rng::seed(11, 0, 0);
    for i in 0..96u32 {
        let e = 10f32.powf(3.0 * rng.next_f32());
        let m = if i % 3 == 2 {
            dark
        } else {
            s.add_material(Material::new([0.5; 3], [e, 0.5 * e, 0.1 * e]))
        };
        let a = 0.1 + rng.next_f32();
        let z = i as f32;
        s.triangles.push(Triangle::new(
            [
                Vec3::new(0.0, 0.0, z),
                Vec3::new(a, 0.0, z),
                Vec3::new(0.0, 1.0, z),
            ],
            m,
        ));
    }
    let l = Lights::build(&s);
    assert_eq!(l.len(), 64);
    let n = 1u32 << 18;
    let out = run_kernel(&l, &test_camera(), n);
    let mut counts = vec![0u64; l.len()];
    for i in 0..n as usize {
        counts[out[i * 6 + 1][3].to_bits() as usize] += 1;
    }
    let p: Vec<f64> = (0..l.len())
        .map(|i| {
            let t = &l.triangles[i];
            lights::power(t.area, t.emission) / l.total_power
        })
        .collect();
    let (chi, dof) = chi_square(&counts, &p);
    // z = 4.3: false-alarm probability ~1e-5 for this fixed seed anyway.
    let limit = chi_square_threshold(dof, 4.3);
    eprintln!("chi-square {chi:.1} with {dof} dof (limit {limit:.1})");
    assert!(
        chi < limit,
        "selection does not follow power: chi^2 {chi} > {limit}"
    );

    // Negative controls: the same counts against planted errors must fail.
    // (1) One light's power off by 10%.
    let mut biased = p.clone();
    let big = (0..p.len()).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap();
    biased[big] *= 1.1;
    let norm: f64 = biased.iter().sum();
    biased.iter_mut().for_each(|x| *x /= norm);
    let (chi_b, _) = chi_square(&counts, &biased);
    assert!(
        chi_b > limit,
        "planted 10% bias not detected: {chi_b} <= {limit}"
    );
    // (2) Area-proportional selection instead of power.
    let area: f64 = l.triangles.iter().map(|t| f64::from(t.area)).sum();
    let by_area: Vec<f64> = l
        .triangles
        .iter()
        .map(|t| f64::from(t.area) / area)
        .collect();
    let (chi_a, _) = chi_square(&counts, &by_area);
    assert!(chi_a > limit, "area-proportional not told apart: {chi_a}");
}
