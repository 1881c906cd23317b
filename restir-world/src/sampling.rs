//! Sampling helpers and the GPU camera: orthonormal basis, cosine-weighted hemisphere, uniform
//! triangle, camera rays with a sub-pixel jitter. [`WGSL`] is the GPU side (functions and
//! structs, no bindings); the functions here are its twins, with the same formulas in the same
//! order (results agree to a few ulp: the GPU may fuse multiply-adds, and its sqrt, sin, cos
//! and division are not correctly rounded).

use glam::{Vec2, Vec3};

use crate::scene::Camera;

/// WGSL source: `sampling_onb`, `sampling_cosine_local`, `sampling_cosine_hemisphere`,
/// `sampling_triangle_uniform`, struct `CameraGpu`, `camera_ray_dir`, constants `SAMPLING_PI`,
/// `SAMPLING_INV_PI`.
pub const WGSL: &str = include_str!("sampling.wgsl");

/// Orthonormal basis around the unit vector `n` (Duff et al. 2017): `(tangent, bitangent)`,
/// with (tangent, bitangent, n) right-handed. Twin of `sampling_onb`.
pub fn onb(n: Vec3) -> (Vec3, Vec3) {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction around +z from `u` in [0,1)^2; pdf = z / pi. Twin of
/// `sampling_cosine_local`.
pub fn cosine_local(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// Cosine-weighted direction around the unit normal `n`; pdf = dot(n, d) / pi. Twin of
/// `sampling_cosine_hemisphere`.
pub fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let (t, b) = onb(n);
    let l = cosine_local(u);
    t * l.x + b * l.y + n * l.z
}

/// Uniform barycentrics (b1, b2) of vertices 1 and 2; the point is p0 + b1 e1 + b2 e2.
/// Twin of `sampling_triangle_uniform`.
pub fn triangle_uniform(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(su * (1.0 - u.y), su * u.y)
}

/// The iteration cap GPU drivers put on an invocation's loops (llvmpipe: 65,535): a loop bound
/// a user sets (RIS candidates, bounces x candidates) is validated against it.
pub const MAX_LOOP_ITERATIONS: u32 = 65_535;

/// Most bounces of indirect light a render takes ([`Paths::bounces`]).
pub const MAX_BOUNCES: u32 = 64;

/// Default bounces of indirect light ([`Paths::bounces`]). Measured with `ris` at 128x128
/// against 16-bounce renders: 3 bounces carry 97% of the converged image on cornell and 87% on
/// many-lights (1 bounce: 88% and 71%) for about twice the GPU time of one; each further
/// bounce adds less light for the same cost (docs/results.md).
pub const DEFAULT_BOUNCES: u32 = 3;

/// Multiple importance sampling of emission hits by default ([`Paths::mis`]). Measured with
/// `nee` and `ris` at one bounce, 3 seeds x 128 frames, on many-lights and on Sponza with 300
/// small added lights: the combined image's relMSE per GPU ms is 3-600x better (fireflies of
/// rare light samples next to small lights are gone; Sponza's direct mean no longer varies
/// -11..+20% between seeds) for 20-40% more GPU time; with the 0.1% worst pixels left out it
/// is 0.5-2.4x (docs/results.md).
pub const DEFAULT_MIS: bool = true;

/// Default bounce at which Russian roulette starts ([`Paths::roulette_from`]).
pub const DEFAULT_ROULETTE_FROM: u32 = 3;

/// The depth of the indirect paths, shared by the GPU renderer and the CPU reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Paths {
    /// Bounces of indirect light: the indirect image holds bounces 1..=bounces (1: light
    /// estimated at the secondary vertex only). Beyond the secondary vertex the path continues
    /// by cosine sampling with a light estimate (the method's estimator) at every vertex.
    /// 1..=[`MAX_BOUNCES`].
    pub bounces: u32,
    /// Russian roulette from this bounce on (0: never): the path survives each further bounce
    /// with the probability of the largest albedo component of the vertex it leaves, and its
    /// throughput is divided by that probability (unbiased). 0 or at least 2.
    pub roulette_from: u32,
    /// Multiple importance sampling of the light reached both ways (GPU renderer; default
    /// on, [`DEFAULT_MIS`]): every light sample is weighted by the power heuristic against the cosine density
    /// of its direction, and the emission a cosine-sampled ray finds (an emitter, or the
    /// environment where it escapes) is added with the complementary weight, instead of being
    /// left to next-event estimation alone. The expectation is the same; rare samples of small
    /// bright lights near a surface lose most of their weight. (The CPU reference estimates the
    /// same images without it.)
    pub mis: bool,
}

impl Default for Paths {
    fn default() -> Self {
        Self {
            bounces: DEFAULT_BOUNCES,
            roulette_from: DEFAULT_ROULETTE_FROM,
            mis: DEFAULT_MIS,
        }
    }
}

impl Paths {
    /// Whether the paths go on beyond the secondary vertex (a second bounce, or MIS's ray from
    /// it), i.e. whether a frame has a path pass: the one place that decides it (the frame
    /// plan's step and the passes that run it ask here).
    pub fn beyond_secondary(&self) -> bool {
        self.bounces > 1 || self.mis
    }

    /// `bounces` with the default roulette.
    pub fn bounces(bounces: u32) -> Self {
        Self {
            bounces,
            ..Self::default()
        }
    }

    /// Checks the depth against [`MAX_BOUNCES`] and, for a light estimator of `candidates` per
    /// vertex (one estimate per bounce), their loops together against [`MAX_LOOP_ITERATIONS`].
    pub fn check(&self, candidates: u32) -> Result<(), String> {
        if !(1..=MAX_BOUNCES).contains(&self.bounces) {
            return Err(format!(
                "bounces {} must be in 1..={MAX_BOUNCES}",
                self.bounces
            ));
        }
        if self.bounces.saturating_mul(candidates.max(1)) > MAX_LOOP_ITERATIONS {
            return Err(format!(
                "bounces x candidates = {} x {candidates} must be at most {MAX_LOOP_ITERATIONS} \
                 (GPU drivers cap shader loop iterations)",
                self.bounces
            ));
        }
        if self.roulette_from == 1 {
            return Err("roulette-from must be 0 (never) or at least 2".into());
        }
        Ok(())
    }
}

/// The light estimator at each shading point, shared by the GPU renderer and the CPU
/// reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimator {
    /// One light sample + shadow ray.
    Nee,
    /// `candidates` light samples resampled by RIS + one shadow ray (default 16).
    Ris { candidates: u32 },
}

/// The camera as the GPU sees it (WGSL struct `CameraGpu`): `right` and `up` are pre-scaled so
/// the image plane at distance 1 spans [-1, 1]: |up| = tan(vfov/2), |right| = |up| * w / h.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CameraGpu {
    pub eye: [f32; 3],
    pub width: u32,
    pub forward: [f32; 3],
    pub height: u32,
    pub right: [f32; 3],
    pub _pad0: u32,
    pub up: [f32; 3],
    pub _pad1: u32,
}

impl CameraGpu {
    /// The GPU camera of `c` (validate `c` first: a degenerate camera gives NaN directions).
    pub fn new(c: &Camera) -> Self {
        let forward = (c.target - c.eye).normalize();
        let right = forward.cross(c.up).normalize();
        let up = right.cross(forward);
        let th = (0.5 * c.vfov_deg.to_radians()).tan();
        let aspect = c.width as f32 / c.height as f32;
        Self {
            eye: c.eye.to_array(),
            width: c.width,
            forward: forward.to_array(),
            height: c.height,
            right: (right * th * aspect).to_array(),
            _pad0: 0,
            up: (up * th).to_array(),
            _pad1: 0,
        }
    }

    /// Unit direction through pixel `(x, y)` (y down, (0, 0) top-left) at sub-pixel offset
    /// `jitter` in [0,1)^2. Twin of `camera_ray_dir`.
    pub fn ray_dir(&self, pixel: [u32; 2], jitter: Vec2) -> Vec3 {
        let sx = 2.0 * (pixel[0] as f32 + jitter.x) / self.width as f32 - 1.0;
        let sy = 1.0 - 2.0 * (pixel[1] as f32 + jitter.y) / self.height as f32;
        (Vec3::from(self.forward) + sx * Vec3::from(self.right) + sy * Vec3::from(self.up))
            .normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use reservoir::rng::Rng;

    #[test]
    fn onb_is_orthonormal_everywhere() {
        let mut rng = Rng::seed(1, 2, 3);
        for i in 0..10_000 {
            let n = if i < 4 {
                [Vec3::Z, -Vec3::Z, Vec3::new(1e-4, 0.0, -1.0), Vec3::X][i]
            } else {
                cosine_local(Vec2::new(rng.next_f32(), rng.next_f32()))
                    * if i % 2 == 0 { 1.0 } else { -1.0 }
            }
            .normalize();
            let (t, b) = onb(n);
            for (x, y) in [(t, b), (t, n), (b, n)] {
                assert!(x.dot(y).abs() < 1e-5, "{n}");
            }
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!((t.cross(b) - n).length() < 1e-5, "right-handed at {n}");
        }
    }

    #[test]
    fn cosine_sampling_has_the_right_moments() {
        // E[cos] = 2/3 and E[cos^2] = 1/2 under the pdf cos/pi.
        let mut rng = Rng::seed(9, 0, 0);
        let n = Vec3::new(1.0, 2.0, -3.0).normalize();
        let m = 200_000;
        let (mut c1, mut c2) = (0.0f64, 0.0f64);
        for _ in 0..m {
            let d = cosine_hemisphere(n, Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = f64::from(d.dot(n));
            assert!(c >= -1e-6);
            c1 += c;
            c2 += c * c;
        }
        // sd of cos is sqrt(1/2 - 4/9) = 0.236: 5 sd / sqrt(m) = 0.0026.
        assert!((c1 / f64::from(m) - 2.0 / 3.0).abs() < 0.0026);
        assert!((c2 / f64::from(m) - 0.5).abs() < 0.0026);
    }

    #[test]
    fn triangle_sampling_is_uniform() {
        // Mean barycentrics of a uniform point are (1/3, 1/3); b1, b2 >= 0, b1 + b2 <= 1.
        let mut rng = Rng::seed(4, 0, 0);
        let m = 100_000;
        let mut s = glam::DVec2::ZERO;
        for _ in 0..m {
            let b = triangle_uniform(Vec2::new(rng.next_f32(), rng.next_f32()));
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            s += b.as_dvec2();
        }
        // sd of a barycentric is sqrt(1/18) = 0.236: 5 sd / sqrt(m) = 0.0037.
        let mean = s / f64::from(m);
        assert!((mean.x - 1.0 / 3.0).abs() < 0.0037 && (mean.y - 1.0 / 3.0).abs() < 0.0037);
    }

    #[test]
    fn camera_centre_ray_looks_at_the_target_and_corners_match_fov() {
        let cam = Camera {
            eye: Vec3::new(1.0, 2.0, 3.0),
            target: Vec3::new(1.0, 2.0, 10.0),
            up: Vec3::Y,
            vfov_deg: 90.0,
            width: 200,
            height: 100,
        };
        let g = CameraGpu::new(&cam);
        let c = g.ray_dir([100, 50], Vec2::ZERO);
        assert!((c - Vec3::Z).length() < 1e-6);
        // Top edge of the image: 45 degrees up. Left edge: right is -x (looking along +z with
        // y up, x points left), aspect 2 -> tan = 2.
        let top = g.ray_dir([100, 0], Vec2::ZERO);
        assert!((top.y / top.z - 1.0).abs() < 1e-5, "{top}");
        let left = g.ray_dir([0, 50], Vec2::ZERO);
        assert!((left.x / left.z - 2.0).abs() < 1e-5, "{left}");
    }
}
