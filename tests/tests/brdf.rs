//! The BRDF's WGSL (`restir_world::brdf`) against its f64 twin, on the same f32 inputs: eval,
//! pdf, the lobe probability, the albedo and sampling, for thousands of random configurations
//! and a hand-written list of awkward ones; no NaN or Inf anywhere in the GPU's output.

use glam::{DVec3, Vec3};
use restir_world::brdf::{self, Brdf, BrdfSurface, BrdfTables};
use restir_world::gpu::{Access, BindingSet, Kernel, WgslModule};
use tests::{buffers, gpu};

/// One configuration as the kernel reads it (WGSL `BrdfCase`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct Case {
    n: [f32; 3],
    metallic: f32,
    wo: [f32; 3],
    roughness: f32,
    wi: [f32; 3],
    diffuse: u32,
    base: [f32; 3],
    _pad0: f32,
    u: [f32; 3],
    _pad1: f32,
}

/// vec4s the kernel writes per case: (eval, pdf), (sample wi, sample pdf), (sample f,
/// specular probability), (sample weight, 0), (albedo, 0).
const OUT_PER_CASE: usize = 5;

/// The kernel's input struct (Rust: Case).
const CASE_WGSL: &str = r#"
struct BrdfCase {
    n: vec3<f32>,
    metallic: f32,
    wo: vec3<f32>,
    roughness: f32,
    wi: vec3<f32>,
    diffuse: u32,
    base: vec3<f32>,
    _pad0: f32,
    u: vec3<f32>,
    _pad1: f32,
}
"#;

/// Per case i: the BRDF's functions at the case's inputs, OUT_PER_CASE vec4s.
const KERNEL: &str = r#"
@compute @workgroup_size(WORKGROUP_SIZE)
fn main(id: Invocation) {
    let i = item_index(id);
    if i >= arrayLength(&cases) {
        return;
    }
    let c = cases[i];
    var s: BrdfSurface;
    s.base = c.base;
    s.metallic = c.metallic;
    s.roughness = c.roughness;
    s.diffuse = c.diffuse != 0u;
    let x = brdf_sample(s, c.n, c.wo, c.u);
    out[i * 5u] = vec4<f32>(brdf_eval(s, c.n, c.wo, c.wi), brdf_pdf(s, c.n, c.wo, c.wi));
    out[i * 5u + 1u] = vec4<f32>(x.wi, x.pdf);
    out[i * 5u + 2u] = vec4<f32>(x.f, brdf_specular_probability(s, c.n, c.wo));
    out[i * 5u + 3u] = vec4<f32>(x.weight, 0.0);
    out[i * 5u + 4u] = vec4<f32>(brdf_albedo(s, c.n, c.wo), 0.0);
}
"#;

/// The hook brdf.wgsl reads its tables through.
const TABLE_HOOK: &str = "fn brdf_table(index: u32) -> f32 {\n    return brdf_tables[index];\n}\n";

fn bindings() -> BindingSet {
    BindingSet::new("brdf test")
        .buffer("brdf_tables", "array<f32>", Access::Read)
        .buffer("cases", "array<BrdfCase>", Access::Read)
        .buffer("out", "array<vec4<f32>>", Access::ReadWrite)
}

/// The kernel's source: the sampling library, the BRDF's constants, the bindings, the table
/// hook, brdf.wgsl and KERNEL, composed as a renderer pass composes them.
fn kernel_source() -> String {
    let modules = [
        WgslModule::new("sampling", &[], restir_world::sampling::WGSL),
        WgslModule::new("brdf-constants", &[], brdf::constants_wgsl()),
        WgslModule::new("workgroup", &[], restir_world::gpu::workgroup_size_wgsl()),
        WgslModule::new("bindings", &["kernel-types"], bindings().wgsl(0)),
        WgslModule::new("brdf-table", &["bindings"], TABLE_HOOK),
        WgslModule::new(
            "brdf",
            &["sampling", "brdf-constants", "brdf-table"],
            brdf::WGSL,
        ),
        WgslModule::new("kernel-types", &[], CASE_WGSL),
        WgslModule::new("kernel", &["brdf", "workgroup", "kernel-types"], KERNEL),
    ];
    restir_world::gpu::compose(&modules).expect("the test kernel composes")
}

/// Runs the kernel over `cases`; returns its vec4s.
fn run_gpu(tables: &BrdfTables, cases: &[Case]) -> Vec<[f32; 4]> {
    let ctx = gpu::context();
    let device = &ctx.device;
    let source = kernel_source();
    if let Err(e) = tests::wgsl::validate("brdf test kernel", &source) {
        panic!("{e}");
    }
    let set = bindings();
    let layout = set.layout(device);
    let kernel = Kernel::new(device, "brdf test", &source, &[&layout], &["main"]);
    let table_buf = buffers::storage_from(device, "brdf tables", tables.as_f32());
    let case_buf = buffers::storage_from(device, "cases", cases);
    let out = buffers::storage_zeroed(device, "out", (cases.len() * OUT_PER_CASE * 16) as u64);
    let group = layout
        .bind(
            device,
            [
                ("brdf_tables", (&table_buf).into()),
                ("cases", (&case_buf).into()),
                ("out", (&out).into()),
            ],
        )
        .expect("bind");
    let pass = kernel.pass(device, "main", &[&group], cases.len() as u32);
    gpu::run(ctx, |enc| pass.record(enc));
    buffers::read(ctx, &out).expect("readback")
}

/// SplitMix64 for the random configurations (fixed seed).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn direction(&mut self) -> Vec3 {
        let z = 2.0 * self.next() - 1.0;
        let phi = 2.0 * std::f32::consts::PI * self.next();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z).normalize()
    }
}

fn case(n: Vec3, wo: Vec3, wi: Vec3, s: (Vec3, f32, f32, bool), u: Vec3) -> Case {
    Case {
        n: n.to_array(),
        metallic: s.1,
        wo: wo.to_array(),
        roughness: s.2,
        wi: wi.to_array(),
        diffuse: u32::from(s.3),
        base: s.0.to_array(),
        _pad0: 0.0,
        u: u.to_array(),
        _pad1: 0.0,
    }
}

/// Random configurations: normals anywhere; wo mostly above the surface, wi on either side;
/// metallic exactly 0 or 1 a fifth of the time each; a quarter of the roughness below 0.1; a
/// tenth diffuse.
fn random_cases(count: usize) -> Vec<Case> {
    let mut rng = Rng(2024);
    (0..count)
        .map(|_| {
            let n = rng.direction();
            let wo = rng.direction();
            let wo = if rng.next() < 0.95 {
                wo * wo.dot(n).signum()
            } else {
                wo
            };
            let wi = rng.direction();
            let metallic = match rng.next() {
                m if m < 0.2 => 0.0,
                m if m < 0.4 => 1.0,
                _ => rng.next(),
            };
            let roughness = if rng.next() < 0.25 {
                0.1 * rng.next()
            } else {
                rng.next()
            };
            let base = Vec3::new(rng.next(), rng.next(), rng.next());
            let u = Vec3::new(rng.next(), rng.next(), rng.next());
            case(n, wo, wi, (base, metallic, roughness, rng.next() < 0.1), u)
        })
        .collect()
}

/// The awkward configurations: wo == n, grazing at 80 and 89.9 degrees, exactly at 90; wi the
/// mirror direction (the peak of a lobe at roughness 0.02), n, wo, above and below; metallic
/// 0, 0.5 and 1 with base 0 and 1, roughness 0 (clamped), 0.02 and 1, and a diffuse surface.
fn awkward_cases() -> Vec<Case> {
    let surfaces = [
        (Vec3::ZERO, 1.0, 0.02, false),
        (Vec3::ONE, 1.0, 0.02, false),
        (Vec3::ONE, 0.0, 0.02, false),
        (Vec3::ZERO, 0.0, 0.02, false),
        (Vec3::splat(0.5), 0.5, 0.0, false),
        (Vec3::ONE, 0.0, 1.0, false),
        (Vec3::new(0.7, 0.3, 0.1), 0.0, 0.5, true),
    ];
    let mut cases = Vec::new();
    for n in [Vec3::Z, Vec3::new(0.3, -0.5, 0.8).normalize()] {
        let (t, b) = restir_world::sampling::onb(n);
        let at = |deg: f32, phi: f32| {
            let (s, c) = deg.to_radians().sin_cos();
            (t * (s * phi.cos()) + b * (s * phi.sin()) + n * c).normalize()
        };
        for wo in [n, at(45.0, 0.3), at(80.0, 1.0), at(89.9, 2.0)] {
            let mirror = (n * (2.0 * n.dot(wo)) - wo).normalize();
            for wi in [mirror, n, wo, at(30.0, 4.0), at(100.0, 0.5)] {
                for (k, &s) in surfaces.iter().enumerate() {
                    let u = Vec3::new(0.05 + 0.13 * k as f32, 0.37, 0.81);
                    cases.push(case(n, wo, wi, s, u));
                }
            }
        }
    }
    for &s in &surfaces {
        cases.push(case(Vec3::Z, Vec3::X, Vec3::Z, s, Vec3::splat(0.5)));
    }
    cases
}

/// The twin's surface of a case (the f32 inputs, exactly).
fn surface(c: &Case) -> BrdfSurface {
    BrdfSurface {
        base: Vec3::from(c.base).as_dvec3(),
        metallic: f64::from(c.metallic),
        roughness: f64::from(c.roughness),
        diffuse: c.diffuse != 0,
    }
}

fn d3(v: [f32; 3]) -> DVec3 {
    Vec3::from(v).as_dvec3()
}

/// Moves u.x away from the twin's specular probability (by 2e-3 at least) so that the GPU and
/// the twin choose the same lobe: their probabilities differ by f32 rounding.
fn separate_lobe_choice(twin: &Brdf, cases: &mut [Case]) {
    for c in cases {
        let p = twin.specular_probability(&surface(c), d3(c.n), d3(c.wo)) as f32;
        if (c.u[0] - p).abs() < 2e-3 {
            c.u[0] = (c.u[0] + 0.5).fract();
        }
    }
}

/// The relative tolerance at a case. f32 against f64: each operation rounds to 2^-24, and
/// WGSL's sqrt, division and log are not correctly rounded (2.5 ulp; log 2^-21 absolute near
/// 1), over a few dozen operations: 1e-4 keeps a wide margin. Near a narrow lobe the half
/// vector's rounding (a few 2^-24) moves D by up to 2 delta / alpha relative, so the
/// tolerance grows by 8 x 2^-24 / alpha (1.2e-3 at alpha = 4e-4).
fn tolerance(c: &Case) -> f64 {
    let r = f64::from(c.roughness).clamp(f64::from(brdf::MIN_ROUGHNESS), 1.0);
    1e-4 + 8.0 * f64::from(f32::EPSILON) * 0.5 / (r * r)
}

/// |gpu - twin| within tol x (|twin| + floor), channel by channel, and exactly 0 where the
/// twin is exactly 0.
fn close(gpu: DVec3, twin: DVec3, tol: f64, floor: f64) -> bool {
    (0..3).all(|k| {
        if twin[k] == 0.0 {
            gpu[k] == 0.0
        } else {
            (gpu[k] - twin[k]).abs() <= tol * (twin[k].abs() + floor)
        }
    })
}

/// What it guards: brdf.wgsl computes what its twin computes (eval, pdf, the specular
/// probability, the albedo, the sampled direction and its f, pdf and weight) on 4096 random
/// and a few hundred awkward configurations, within `tolerance`; values the twin gives as 0
/// are 0; diffuse surfaces are bit-for-bit base x the f32 1 / pi (the renderer's product);
/// nothing the GPU writes is NaN or Inf. (NaN inputs are the CPU tests' business: WGSL leaves
/// min and max of NaN to the implementation.)
#[test]
fn gpu_brdf_matches_the_twin() {
    let tables = BrdfTables::compute();
    let twin = Brdf::new(&tables);
    let mut cases = random_cases(4096);
    cases.extend(awkward_cases());
    separate_lobe_choice(&twin, &mut cases);
    let out = run_gpu(&tables, &cases);
    assert!(
        out.iter().flatten().all(|x| x.is_finite()),
        "the GPU wrote NaN or Inf"
    );
    let mut worst = Errors::default();
    for (i, c) in cases.iter().enumerate() {
        let o = &out[i * OUT_PER_CASE..(i + 1) * OUT_PER_CASE];
        check_diffuse_exact(c, o);
        let e = check_case(&twin, c, o, &format!("case {i}: {c:?}"));
        worst.pdf = worst.pdf.max(e.pdf);
        worst.sampled_pdf = worst.sampled_pdf.max(e.sampled_pdf);
        worst.direction = worst.direction.max(e.direction);
        worst.near_horizon += e.near_horizon;
    }
    eprintln!(
        "{} cases: largest relative pdf error {:.1e} (at wi), {:.1e} (sampled); largest \
         direction error {:.1e}; {} sampled directions within 1e-5 of the horizon not compared",
        cases.len(),
        worst.pdf,
        worst.sampled_pdf,
        worst.direction,
        worst.near_horizon
    );
}

/// What one case (or all of them) differed by.
#[derive(Debug, Default)]
struct Errors {
    pdf: f64,
    sampled_pdf: f64,
    direction: f64,
    near_horizon: usize,
}

fn relative(gpu: f32, twin: f64) -> f64 {
    if twin == 0.0 {
        0.0
    } else {
        (f64::from(gpu) - twin).abs() / twin.abs()
    }
}

/// Checks the GPU's output `o` for case `c` against the twin (see gpu_brdf_matches_the_twin);
/// `what` names the case in a failure.
fn check_case(twin: &Brdf, c: &Case, o: &[[f32; 4]], what: &str) -> Errors {
    let v = |k: usize| Vec3::new(o[k][0], o[k][1], o[k][2]).as_dvec3();
    let scalar = |x: f64| DVec3::splat(x);
    let s = surface(c);
    let (n, wo, wi) = (d3(c.n), d3(c.wo), d3(c.wi));
    let tol = tolerance(c);
    // The size the lobe would have with F = 1: a floor for values that cancel (base 0).
    let white = BrdfSurface {
        base: DVec3::ONE,
        metallic: 1.0,
        ..s
    };
    let floor = |wi: DVec3| 1e-3 * twin.eval(&white, n, wo, wi).max_element();
    let e = twin.eval(&s, n, wo, wi);
    assert!(
        close(v(0), e, tol, floor(wi)),
        "eval {} vs {e}: {what}",
        v(0)
    );
    let pdf = twin.pdf(&s, n, wo, wi);
    let gpu_pdf = f64::from(o[0][3]);
    assert!(
        close(scalar(gpu_pdf), scalar(pdf), tol, 0.0),
        "pdf {gpu_pdf} vs {pdf}: {what}"
    );
    let p = twin.specular_probability(&s, n, wo);
    let gpu_p = f64::from(o[2][3]);
    assert!(
        (gpu_p - p).abs() <= 1e-5,
        "probability {gpu_p} vs {p}: {what}"
    );
    let albedo = twin.albedo(&s, n, wo);
    assert!(
        close(v(4), albedo, tol, 1e-3),
        "albedo {} vs {albedo}: {what}",
        v(4)
    );
    let x = twin.sample(&s, n, wo, d3(c.u));
    let mut errors = Errors {
        pdf: relative(o[0][3], pdf),
        direction: (v(1) - x.wi).abs().max_element(),
        ..Errors::default()
    };
    assert!(
        errors.direction <= 1e-4,
        "sampled wi {} vs {}: {what}",
        v(1),
        x.wi
    );
    // f, pdf and weight at the GPU's own direction (a narrow lobe would turn the directions'
    // 1e-7 difference into far more than rounding); not within 1e-5 of the horizon, where
    // rounding decides whether the direction is above.
    let g_wi = v(1);
    if n.dot(g_wi).abs() < 1e-5 {
        errors.near_horizon = 1;
        return errors;
    }
    let (f, pdf) = (twin.eval(&s, n, wo, g_wi), twin.pdf(&s, n, wo, g_wi));
    assert!(
        close(v(2), f, tol, floor(g_wi)),
        "sample f {} vs {f}: {what}",
        v(2)
    );
    let gpu_pdf = f64::from(o[1][3]);
    assert!(
        close(scalar(gpu_pdf), scalar(pdf), tol, 0.0),
        "sample pdf {gpu_pdf} vs {pdf}: {what}"
    );
    let weight = if pdf > 0.0 {
        f * (n.dot(g_wi) / pdf)
    } else {
        DVec3::ZERO
    };
    let weight_floor = floor(g_wi) / pdf.max(1e-30);
    assert!(
        close(v(3), weight, 3.0 * tol, weight_floor),
        "weight {} vs {weight}: {what}",
        v(3)
    );
    errors.sampled_pdf = relative(o[1][3], pdf);
    errors
}

/// A diffuse surface's f is exactly the f32 product base x SAMPLING_INV_PI wherever both
/// directions are above the surface (and its sample's f where the sample is).
fn check_diffuse_exact(c: &Case, o: &[[f32; 4]]) {
    if c.diffuse == 0 {
        return;
    }
    let n = Vec3::from(c.n);
    let expect = Vec3::from(c.base) * std::f32::consts::FRAC_1_PI;
    let above = |w: Vec3| n.dot(Vec3::from(c.wo)) > 0.0 && n.dot(w) > 0.0;
    if above(Vec3::from(c.wi)) {
        assert_eq!(
            Vec3::new(o[0][0], o[0][1], o[0][2]),
            expect,
            "diffuse eval: {c:?}"
        );
    }
    let wi = Vec3::new(o[1][0], o[1][1], o[1][2]);
    if above(wi) && o[1][3] > 0.0 {
        assert_eq!(
            Vec3::new(o[2][0], o[2][1], o[2][2]),
            expect,
            "diffuse sample f: {c:?}"
        );
    }
}

/// The kernel's case struct matches its Rust twin (naga's layout).
#[test]
fn case_layout_matches_naga() {
    tests::assert_wgsl_layout!(
        Case,
        kernel_source(),
        "BrdfCase",
        [
            n, metallic, wo, roughness, wi, diffuse, base, _pad0, u, _pad1
        ]
    );
}
