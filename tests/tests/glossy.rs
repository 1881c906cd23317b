//! Glossy materials (glTF 2.0 metallic-roughness) in the paths: the closed furnace with
//! energy-conserving glossy walls against its analytic radiance, and the GPU baselines against
//! the CPU reference on the glossy Cornell box. Each check has a control that runs the
//! estimator with a defect planted near its bound (`Planted::GlossyEnergyLoss`: the glossy
//! BRDF losing 1% of its energy) and must fail it.

use restir_world::plant::Planted;
use restir_world::reference::{ReferenceOptions, ReferenceRenderer};
use restir_world::render::Paths;
use restir_world::sampling::Estimator;
use restir_world::scene::{Camera, Material, Scene, furnace_sphere};
use tests::bias::channel_means;
use tests::gpu;
use tests::scenes::builtin_square;

const SIDE: u32 = 24;
/// The furnace's bound: 1% on the direct and the indirect image's channel means.
const FURNACE_BOUND: f64 = 0.01;

/// The closed icosphere furnace with every surface the glossy material (base white, `metallic`,
/// `roughness`) emitting Le = 1: energy compensation makes its directional albedo 1, so
/// direct = Le (1 + 1) and indirect(N) = Le N (every bounce returns all of the light).
fn glossy_furnace(metallic: f32, roughness: f32) -> (Scene, Camera) {
    let mut s = furnace_sphere(0.5, 1.0, SIDE, SIDE).expect("furnace");
    s.materials[0] = Material {
        emission: [1.0; 3],
        ..Material::metal_roughness([1.0; 3], metallic, roughness)
    };
    let cam = s.camera_or_default(SIDE, SIDE);
    (s, cam)
}

/// The largest relative error of the (direct, indirect) channel means against 2 and N.
fn furnace_error(direct: &[[f32; 3]], indirect: &[[f32; 3]], bounces: u32) -> f64 {
    let e = |img: &[[f32; 3]], want: f64| {
        channel_means(img)
            .iter()
            .map(|m| (m / want - 1.0).abs())
            .fold(0.0, f64::max)
    };
    e(direct, 2.0).max(e(indirect, f64::from(bounces)))
}

/// `spec`'s accumulated (direct, indirect) after `frames` frames.
fn gpu_images(
    spec: &str,
    s: &Scene,
    cam: &Camera,
    frames: u32,
    planted: Planted,
) -> [Vec<[f32; 3]>; 2] {
    let mut m = gpu::build(spec, s, cam, gpu::planted(1, planted));
    gpu::render(&mut m, frames);
    let img = gpu::images(&m);
    [img.direct, img.indirect]
}

/// The CPU reference's (direct, indirect) at the default paths.
fn cpu_images(s: &Scene, cam: &Camera, method: Estimator, spp: u32) -> [Vec<[f32; 3]>; 2] {
    let o = ReferenceOptions {
        method,
        spp,
        seed: 3,
        ..Default::default()
    };
    let out = ReferenceRenderer::new(s)
        .expect("reference")
        .render(cam, &o, None)
        .expect("render");
    [out.direct.pixels, out.indirect.pixels]
}

/// Guards the glossy BRDF in every part of the paths at once (light samples, path steps and
/// their weights, MIS between them, roulette by the BRDF's albedo): white glossy walls emitting
/// everywhere must give the furnace's analytic radiance, within 1% on the channel means (24x24,
/// 64 frames on the GPU, 16 spp on the CPU), for smooth, medium and rough metal (roughness
/// 0.1, 0.5, 1) and a rough dielectric, nee and ris on the GPU, nee on the CPU. Measured: 0.1%
/// (smooth metal, dielectric), 0.5-0.7% (metal at 0.5 and 1, where the compensation tables are
/// within 0.15% of 1 a bounce and the indirect image's seed-to-seed scatter is 0.4%: three
/// seeds at 128 frames averaged +0.3%); so a bias of 1.5% fails 90% of the time. Control: the
/// BRDF losing 1% of its energy (Planted::GlossyEnergyLoss) reads -2.4% (2.4x the bound) and
/// must fail.
#[test]
fn glossy_furnace_is_analytic_in_every_estimator() {
    let bounces = Paths::default().bounces;
    for (metallic, roughness) in [(1.0, 0.1), (1.0, 0.5), (1.0, 1.0), (0.0, 0.5)] {
        let (s, cam) = glossy_furnace(metallic, roughness);
        for spec in ["nee", "ris"] {
            let [d, i] = gpu_images(spec, &s, &cam, 64, Planted::None);
            let err = furnace_error(&d, &i, bounces);
            println!(
                "{spec} metallic {metallic} roughness {roughness}: error {err:.4} (direct \
                 {:.4?}, indirect {:.4?})",
                channel_means(&d),
                channel_means(&i)
            );
            assert!(
                err < FURNACE_BOUND,
                "{spec}, metallic {metallic}, roughness {roughness}: furnace error {err:.4} \
                 above {FURNACE_BOUND}"
            );
        }
        let [d, i] = cpu_images(&s, &cam, Estimator::Nee, 16);
        let err = furnace_error(&d, &i, bounces);
        println!("cpu nee metallic {metallic} roughness {roughness}: error {err:.4}");
        assert!(err < FURNACE_BOUND, "CPU reference: furnace error {err:.4}");
    }
    let (s, cam) = glossy_furnace(1.0, 0.5);
    let [d, i] = gpu_images("nee", &s, &cam, 64, Planted::GlossyEnergyLoss);
    let err = furnace_error(&d, &i, bounces);
    println!("control (1% energy loss): error {err:.4}");
    assert!(
        err > FURNACE_BOUND,
        "control: a BRDF losing 1% of its energy passed the furnace ({err:.4})"
    );
}

/// The relative differences of two images' channel means over the pixels `keep`.
fn relative_means(got: &[[f32; 3]], want: &[[f32; 3]], keep: &[bool]) -> [f64; 3] {
    let mean = |img: &[[f32; 3]]| -> [f64; 3] {
        let kept: Vec<[f32; 3]> = img
            .iter()
            .zip(keep)
            .filter(|(_, k)| **k)
            .map(|(p, _)| *p)
            .collect();
        channel_means(&kept)
    };
    let (g, w) = (mean(got), mean(want));
    [0, 1, 2].map(|c| g[c] / w[c] - 1.0)
}

/// The pixels that do not see the light (the direct image's red at most 1 in `img`, and in
/// their 8 neighbours): where the light is seen, the pixels' sub-pixel jitter decides how much
/// of it each sees, and at 32x32 its few edge pixels scatter the direct image's mean by about
/// 0.6% (the same seed's primary rays in both methods: render.rs measured the light's
/// seed-to-seed spread at 2.5%).
fn unlit_pixels(img: &[[f32; 3]], side: u32) -> Vec<bool> {
    let n = side as i32;
    let lit = |x: i32, y: i32| {
        (0..n).contains(&x) && (0..n).contains(&y) && img[(y * n + x) as usize][0] > 1.0
    };
    (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            !(-1..=1).any(|dy| (-1..=1).any(|dx| lit(x + dx, y + dy)))
        })
        .collect()
}

/// Guards the GPU's glossy paths against the CPU reference's (written apart: per-vertex steps
/// in f32 with the f64 BRDF twin, MIS only at glossy vertices) where the two can differ, on
/// the glossy Cornell box with its tall block at roughness 0.3 (a polished floor, a rough gold
/// and a glossy metal block; at the shipped 0.1 the image mean's seed-to-seed scatter is 2-3%
/// at 256 frames): the mean of six GPU runs (seeds 1-6, nee and ris alternating, 512 frames,
/// 32x32) within 2% of the CPU reference's (nee, seeds 3-8, 1024 spp) on each channel of the
/// direct image where the light is not seen ([`unlit_pixels`]) and of the indirect image.
/// Measured scatter: GPU seeds 1% (indirect, 512 frames), the CPU's mean 0.25%: the
/// difference's sigma is 0.5%, so a bias of 2.6% fails 90% of the time. Measured: indirect
/// +0.9%, +0.6%, +1.1% (about 2 sigma: not resolved here). Power check (not a defect of the
/// estimator): the GPU's indirect frames scaled to 96% must fail.
#[test]
fn glossy_cornell_gpu_matches_the_cpu_reference() {
    let side = 32;
    let (mut s, cam) = builtin_square("cornell-glossy", side, Default::default());
    for m in &mut s.materials {
        if m.metallic == 1.0 && m.roughness == 0.1 {
            m.roughness = 0.3;
        }
    }
    let mut want = [vec![[0.0f32; 3]; 1024], vec![[0.0f32; 3]; 1024]];
    for seed in 3..=8 {
        let o = ReferenceOptions {
            method: Estimator::Nee,
            spp: 1024,
            seed,
            ..Default::default()
        };
        let out = ReferenceRenderer::new(&s)
            .expect("reference")
            .render(&cam, &o, None)
            .expect("render");
        add_scaled(&mut want[0], &out.direct.pixels, 1.0 / 6.0);
        add_scaled(&mut want[1], &out.indirect.pixels, 1.0 / 6.0);
    }
    let unlit = unlit_pixels(&want[0], side);
    let all = vec![true; unlit.len()];
    let bound = 0.02;
    let worst = |planted: Planted| -> f64 {
        let mut got = [vec![[0.0f32; 3]; 1024], vec![[0.0f32; 3]; 1024]];
        for seed in 1..=6 {
            let spec = if seed % 2 == 1 { "nee" } else { "ris" };
            let mut m = gpu::build(spec, &s, &cam, gpu::planted(seed, planted));
            gpu::render(&mut m, 512);
            let img = gpu::images(&m);
            add_scaled(&mut got[0], &img.direct, 1.0 / 6.0);
            add_scaled(&mut got[1], &img.indirect, 1.0 / 6.0);
        }
        let (d, i) = (
            relative_means(&got[0], &want[0], &unlit),
            relative_means(&got[1], &want[1], &all),
        );
        println!("{planted:?}: direct {d:+.4?} indirect {i:+.4?}");
        d.iter().chain(&i).map(|x| x.abs()).fold(0.0, f64::max)
    };
    let w = worst(Planted::None);
    assert!(w < bound, "{w:.4} from the CPU reference");
    let w = worst(Planted::indirect_scaled(96));
    assert!(w > bound, "power check passed: {w:.4}");
}

/// Adds `img` x `k` to `sum`, pixel by pixel.
fn add_scaled(sum: &mut [[f32; 3]], img: &[[f32; 3]], k: f32) {
    for (s, p) in sum.iter_mut().zip(img) {
        for c in 0..3 {
            s[c] += p[c] * k;
        }
    }
}
