//! The glossy BRDF (glTF 2.0 metal-roughness with Kulla-Conty energy compensation,
//! `restir_world::brdf`) in the renderer's paths against an independent renderer: Mitsuba 3's
//! `path` integrator on `cornell-glossy` with the BRDF written again as a Mitsuba plugin
//! (`scripts/mitsuba/gltf_bsdf.py`, its compensation tables from its own quadrature; images in
//! `tests/data/mitsuba`, made by `scripts/mitsuba/render_reference.py`).
//!
//! What it guards that no other test does: tests/glossy checks the GPU against the CPU
//! reference, which evaluates the same f64 twin of the BRDF with the same tables, and the
//! glossy furnace checks energy only; the BRDF's unit tests check the WGSL against its twin.
//! A wrong formula written into both (a Fresnel term, the dielectric's diffuse weighting, the
//! masking-shadowing, a compensation lobe of the right energy but the wrong shape) passes all
//! of those; here it meets the model written apart, region by region of the image (the glossy
//! surfaces' pixels, the floor's, the gold block's), in the direct image of both renderers and
//! in the CPU reference's indirect images up to four bounces.

use glam::{Vec2, Vec3};
use restir_world::image_io::read_exr;
use restir_world::plant::Planted;
use restir_world::render::{Paths, RenderOptions};
use restir_world::sampling::{CameraGpu, Estimator};
use restir_world::scene::{Camera, MaterialModel, Scene, builtin};
use tests::gpu;

const SIDE: u32 = 64;
/// The bound on every compared mean, per channel.
const BOUND: f64 = 0.02;
/// Samples per pixel of the CPU reference's renders, and their seed.
const SPP: u32 = 2048;
const CPU_SEED: u32 = 3;
/// Frames of the GPU's render (its direct image), and its seed.
const FRAMES: u32 = 512;
const GPU_SEED: u32 = 7;

/// The pixels a mean is taken over.
struct Region {
    name: &'static str,
    keep: Vec<bool>,
}

/// cornell-glossy's regions: the whole image, the pixels whose centre sees a glossy surface,
/// and those that see the floor (the polished dielectric) and the short block (the rough
/// gold). The tall block (a near-mirror metal, roughness 0.1) is in `glossy` but not compared
/// alone: see [`glossy_cornell_matches_mitsuba`].
fn regions(s: &Scene, cam: &Camera) -> Vec<Region> {
    let seen = seen_materials(s, cam);
    // cornell's triangle order: the floor first, the short block from triangle 18.
    let (floor, gold) = (s.triangles[0].material, s.triangles[18].material);
    let glossy = |m: u32| s.materials[m as usize].model() == MaterialModel::MetalRoughness;
    let region = |name, f: &dyn Fn(u32) -> bool| Region {
        name,
        keep: seen.iter().map(|m| m.is_some_and(f)).collect(),
    };
    vec![
        Region {
            name: "image",
            keep: vec![true; seen.len()],
        },
        region("glossy", &|m| glossy(m)),
        region("floor", &|m| m == floor),
        region("gold", &|m| m == gold),
    ]
}

/// The material each pixel's centre sees (None: nothing), by brute force over the triangles.
fn seen_materials(s: &Scene, cam: &Camera) -> Vec<Option<u32>> {
    let g = CameraGpu::new(cam);
    let eye = cam.eye;
    let hit = |d: Vec3| {
        let mut best = (f32::INFINITY, None);
        for t in &s.triangles {
            let (e1, e2) = (t.v[1] - t.v[0], t.v[2] - t.v[0]);
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 {
                continue;
            }
            let o = eye - t.v[0];
            let (a, q) = (o.dot(p) / det, o.cross(e1));
            let (b, dist) = (d.dot(q) / det, e2.dot(q) / det);
            if a >= 0.0 && b >= 0.0 && a + b <= 1.0 && dist > 0.0 && dist < best.0 {
                best = (dist, Some(t.material));
            }
        }
        best.1
    };
    (0..cam.height)
        .flat_map(|y| (0..cam.width).map(move |x| [x, y]))
        .map(|p| hit(g.ray_dir(p, Vec2::splat(0.5))))
        .collect()
}

/// Per channel: the mean of `img` over the region.
fn mean(img: &[[f32; 3]], r: &Region) -> [f64; 3] {
    let n = r.keep.iter().filter(|k| **k).count() as f64;
    [0, 1, 2].map(|c| {
        img.iter()
            .zip(&r.keep)
            .filter(|(_, k)| **k)
            .map(|(p, _)| f64::from(p[c]))
            .sum::<f64>()
            / n
    })
}

/// Per channel `got / want - 1` over the region.
fn deviation(got: &[[f32; 3]], want: &[[f32; 3]], r: &Region) -> [f64; 3] {
    let (g, w) = (mean(got, r), mean(want, r));
    [0, 1, 2].map(|c| g[c] / w[c] - 1.0)
}

/// Mitsuba's images of cornell-glossy at 64x64 (`tests/data/mitsuba`, BSDF variant `variant`
/// of the plugin: "" for the model itself): its direct image (max_depth = 2) and its indirect
/// image at N bounces (max_depth = N + 2 minus the direct one).
struct Mitsuba {
    variant: &'static str,
    direct: Vec<[f32; 3]>,
}

impl Mitsuba {
    fn image(variant: &str, bounces: u32) -> Vec<[f32; 3]> {
        let path = tests::wgsl::workspace_root().join(format!(
            "tests/data/mitsuba/cornell-glossy-64x64{variant}-bounces-{bounces}.exr"
        ));
        let img = read_exr(&path).expect("a committed Mitsuba reference");
        assert_eq!((img.width, img.height), (SIDE, SIDE), "{}", path.display());
        img.pixels
    }

    fn load(variant: &'static str) -> Self {
        Self {
            variant,
            direct: Self::image(variant, 0),
        }
    }

    fn indirect(&self, bounces: u32) -> Vec<[f32; 3]> {
        let all = Self::image(self.variant, bounces);
        all.iter()
            .zip(&self.direct)
            .map(|(a, d)| [0, 1, 2].map(|c| a[c] - d[c]))
            .collect()
    }
}

/// The CPU reference's (direct, indirect) images of `s` (`nee`, the shipped paths but for
/// the depth: MIS at glossy vertices, Russian roulette from bounce 3).
fn cpu(s: &Scene, cam: &Camera, bounces: u32) -> [Vec<[f32; 3]>; 2] {
    let paths = Paths {
        bounces,
        ..Paths::default()
    };
    let out = tests::cpu::reference_at(s, cam, Estimator::Nee, SPP, CPU_SEED, paths);
    [out.direct.pixels, out.indirect.pixels]
}

/// The GPU renderer's accumulated direct image of `s` (`nee`, the shipped paths).
fn gpu_direct(s: &Scene, cam: &Camera) -> Vec<[f32; 3]> {
    let options = RenderOptions {
        seed: GPU_SEED,
        paths: Paths {
            bounces: 1,
            ..Paths::default()
        },
        planted: Planted::None,
        ..Default::default()
    };
    let mut m = gpu::build("nee", s, cam, options);
    gpu::render(&mut m, FRAMES);
    gpu::images(&m).direct
}

/// Guards the glossy BRDF's formulas in the paths, against Mitsuba 3 (65536 spp as 64
/// passes, seed 1; box filter, two-sided surfaces and emitters, no Russian roulette) on
/// cornell-glossy at 64x64, each mean per channel within 2%:
///
/// - the CPU reference (the BRDF's f64 twin; `nee`, the shipped paths but for the depth, 2048
///   spp, seed 3): its direct image over the whole image, the glossy pixels, the floor's and
///   the gold block's; its indirect image at N = 1..4 over the whole image, and at N = 1 over
///   the glossy pixels too;
/// - the GPU renderer (its WGSL BRDF; `nee`, 512 frames, seed 7): its direct image over the
///   same four regions. (Its indirect images at this noise would take minutes on lavapipe;
///   tests/glossy checks them against the CPU reference's.)
///
/// Noise, standard errors: Mitsuba's means 0.02-0.03% (direct), 0.04-0.11% (indirect, whole
/// image), 0.1-0.2% (indirect, glossy pixels). Ours seed to seed (CPU seeds 3-6, GPU seeds 1-4
/// and 7): the direct means 0.1-0.3% (the gold block's 0.5% on the GPU), the indirect whole
/// image 0.3-0.6% and the glossy pixels' at N = 1 0.2-0.4% (the near-mirror block's and the
/// polished floor's caustics of the small light, heavy-tailed; the glossy pixels' scatter 1%
/// in blue at N = 4, so deeper they are not compared). 2% is 3.5 standard errors of the
/// noisiest difference. The CPU reference's images are deterministic (per-pixel streams).
///
/// Measured: seed 3 as the output prints (direct within -0.26%, indirect whole image -0.2% to
/// -0.7%, glossy pixels at N = 1 -0.2%; the GPU's direct within +0.3%); seeds 3-6: direct
/// within 0.26%, indirect whole image -1.3% to +0.2% (its mean over the seeds -0.4/-0.5/-0.6%
/// at N = 1), glossy pixels at N = 1 -0.2% to +0.75%.
///
/// Not compared alone: the tall block's pixels (393; the glossy pixels include them). Its
/// direct image is the near-mirror's lobe tail and multiple-scattering lobe towards the light,
/// and ours reads 1.2% (CPU, seeds 3-6) to 2.4% (GPU, seeds 1-4) darker there, of which 1.7%
/// is our compensation tables' loss 1 - E at roughness 0.1 (about 70% of the true 2.6e-4 at
/// mu = 0.5, 0 instead of 1e-4 at mu = 1: Mitsuba rendered with our tables in place of its
/// own reads 1.7% darker there, the same paths otherwise). Its indirect image reads -0.3% on
/// the CPU but +1.2/+1.6/+2.0% at N = 1 on the GPU (four seeds of 512 frames), which the
/// whole image's means do not resolve.
///
/// Controls: the same images of ours against Mitsuba's with glTF Appendix B's model instead
/// (no energy compensation, the diffuse weighted by 1 - F(v.h)) and with Schlick's Fresnel
/// term dropped (F = F0 everywhere; both 16384 spp): each must be beyond the bound in some
/// compared mean. Measured: Appendix B -10/-11/-13% (direct, glossy pixels), -15% (floor),
/// +16/+12/+5% (gold), -0.7/-1.2/-2.5% (indirect at N = 4, whole image); no Fresnel
/// -12/-13/-14% (glossy pixels), -15% (floor), -0.6/-0.5/-0.6% (indirect at N = 4).
#[test]
fn glossy_cornell_matches_mitsuba() {
    let s = builtin("cornell-glossy", &Default::default()).expect("cornell-glossy");
    let cam = s.camera_or_default(SIDE, SIDE);
    let regions = regions(&s, &cam);
    let full = Mitsuba::load("");
    // The check resolves each depth: one bounce less is beyond the bound (whole image).
    for bounces in 2..=4 {
        let d = deviation(
            &full.indirect(bounces - 1),
            &full.indirect(bounces),
            &regions[0],
        );
        assert!(
            d.iter().all(|x| x.abs() > 2.0 * BOUND),
            "{bounces}: {d:+.4?}"
        );
    }
    let mut failed = Vec::new();
    // The indirect images over the whole image at every depth, and over the glossy pixels at
    // one bounce: deeper, their caustics scatter them by 1% a seed in blue (the floor's and
    // the gold block's alone by 1-3% at every depth).
    let indirect_regions = |bounces: u32| &regions[..if bounces == 1 { 2 } else { 1 }];
    let mut check = |what: String, d: [f64; 3]| {
        println!("{what}: {d:+.4?}");
        if !d.iter().all(|x| x.abs() < BOUND) {
            failed.push(format!("{what}: {d:+.4?}"));
        }
    };
    let mut direct = Vec::new();
    let mut deepest = Vec::new();
    for bounces in 1..=4 {
        let [d, i] = cpu(&s, &cam, bounces);
        if bounces == 1 {
            for r in &regions {
                check(
                    format!("cpu direct, {}", r.name),
                    deviation(&d, &full.direct, r),
                );
            }
            direct = d;
        }
        let want = full.indirect(bounces);
        for r in indirect_regions(bounces) {
            check(
                format!("cpu {bounces} bounces, indirect, {}", r.name),
                deviation(&i, &want, r),
            );
        }
        deepest = i;
    }
    let gpu = gpu_direct(&s, &cam);
    for r in &regions {
        check(
            format!("gpu direct, {}", r.name),
            deviation(&gpu, &full.direct, r),
        );
    }
    assert!(failed.is_empty(), "{failed:?}");
    for variant in ["-no-compensation", "-no-fresnel"] {
        let control = Mitsuba::load(variant);
        let want = control.indirect(4);
        let mut worst = 0.0f64;
        for (k, r) in regions.iter().enumerate() {
            let dd = deviation(&direct, &control.direct, r);
            let di = deviation(&deepest, &want, r);
            println!(
                "control {variant}: {}: direct {dd:+.4?}, indirect at 4 {di:+.4?}",
                r.name
            );
            worst = dd.iter().fold(worst, |w, x| w.max(x.abs()));
            if k < indirect_regions(4).len() {
                worst = di.iter().fold(worst, |w, x| w.max(x.abs()));
            }
        }
        assert!(
            worst > BOUND,
            "control: Mitsuba's {variant} images passed ({worst:.4})"
        );
    }
}
