//! The CPU reference renderer: the same estimators as the GPU renderer, traced with obvhs's CPU
//! traversal of its CWBVH (medium build preset), multi-threaded over rows
//! (`std::thread::scope`), accumulated in f64.
//!
//! Per sample of pixel p (box filter: the sub-pixel position is uniform in the pixel):
//! 1. Primary ray from the eye; a miss sees the environment (black without one) in **direct**
//!    and contributes 0 to **indirect**.
//! 2. At the primary hit x1 (geometric normal n1 flipped towards the eye, albedo a1, emission
//!    Le1): **direct** = Le1 (emission seen) + one light estimate at x1 (reflected direct light).
//! 3. One cosine-weighted GI ray from x1. At its hit x2: **indirect** = a1 x (one light
//!    estimate at x2). The cosine pdf cancels a1 cos / pi. Emission seen at x2 is *not* added
//!    (that light is the direct light at x1, already estimated by NEE), and neither is the
//!    environment seen by a GI ray that escapes (the same light, also estimated by NEE at x1).
//! 4. **combined** = direct + indirect.
//!
//! A "light estimate" at x (normal n, albedo a) is, for method `Nee`, one power-proportional
//! light sample y (see [`crate::lights`]: a triangle point, an environment direction or a
//! punctual light) with a shadow ray: f(y) / pdf(y) V(x, y), for a triangle
//! a/pi Le(y) cos_x cos_y / |x-y|^2 / pdf_area(y); for method `Ris { candidates: K }`,
//! K such samples resampled by RIS with target p̂ = luminance of the unshadowed reflected
//! radiance, then one shadow ray for the chosen one: f(y) V W, W = w_sum / (K p̂(y)).
//!
//! In the furnace (closed box, albedo rho, emission Le everywhere) this gives:
//! direct = Le + rho Le, indirect = rho^2 Le, exactly in expectation.
//!
//! Glossy surfaces (glTF metallic-roughness, [`crate::brdf`]'s f64 twin of the GPU's BRDF)
//! replace the albedo / pi above by their BRDF towards the vertex before, their cosine ray by
//! the BRDF's sampler (three uniforms, weight f cos / pdf), and weigh the light estimate and
//! the emission their ray finds (an emitter, or the environment where it escapes) by the power
//! heuristic of the light table's density against the sampler's; after the last bounce a
//! glossy vertex traces one more ray for that share. Diffuse surfaces are as above, their
//! random numbers unchanged.
//!
//! Surfaces are two-sided (see [`crate::scene`]). Shading uses the interpolated vertex normals
//! where a triangle has them (turned to the side of the geometric normal), perturbed by the
//! material's normal map where it has one and the triangle usable tangents (`normal_mapped`): the
//! cosine of the BRDF and the GI ray's cosine distribution; the geometric normal keeps the ray
//! offsets and which side a light must be on (a light behind the geometric surface contributes
//! nothing; a GI direction below it ends the path). Ray origins are offset along the normal by 1e-5
//! of the scene's extent; shadow rays stop 1e-4 short of the light point (relative).

use std::sync::atomic::{AtomicU32, Ordering};

use glam::{DVec3, Vec2, Vec3, Vec3A, Vec4};
use obvhs::{BvhBuildParams, cwbvh::CwBvh, ray::Ray, ray::RayHit};
use reservoir::rng::Rng;

use crate::brdf::{Brdf, BrdfSurface};
use crate::image_io::Image;
use crate::lights::{self, LightSample, Lights};
use crate::sampling::{self, CameraGpu, Estimator, Paths};
use crate::scene::{Camera, MaterialModel, Scene, SceneError, Triangle, luminance, tangents};

/// Options of [`ReferenceRenderer::render`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceOptions {
    pub method: Estimator,
    /// Samples per pixel.
    pub spp: u32,
    /// Seed of the random streams: pixel p, sample s draws from `Rng::seed(p, s, seed)`.
    pub seed: u32,
    /// Worker threads; 0 = all available cores.
    pub threads: usize,
    /// The depth of the indirect paths, as the GPU renderer's.
    pub paths: Paths,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            method: Estimator::Nee,
            spp: 64,
            seed: 0,
            threads: 0,
            paths: Paths::default(),
        }
    }
}

/// The three outputs, linear HDR, averaged over the samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    pub direct: Image,
    pub indirect: Image,
    pub combined: Image,
}

/// A scene prepared for CPU tracing.
#[derive(Debug)]
pub struct ReferenceRenderer {
    scene: Scene,
    lights: Lights,
    bvh: CwBvh,
    tris: Vec<obvhs::triangle::Triangle>,
    eps: f32,
    /// Scene units to BVH units (1 unless the scene is smaller than 1).
    units: f32,
}

fn u4(rng: &mut Rng) -> [f32; 4] {
    [0; 4].map(|_| rng.next_f32())
}

struct Hit {
    t: f32,
    triangle: usize,
}

/// Barycentric coordinates (of vertices 1 and 2) of the point x on the triangle v.
fn barycentrics(v: [Vec3; 3], x: Vec3) -> Vec2 {
    let (e1, e2, p) = (v[1] - v[0], v[2] - v[0], x - v[0]);
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (p.dot(e1), p.dot(e2));
    let denom = d00 * d11 - d01 * d01;
    Vec2::new(d11 * d20 - d01 * d21, d00 * d21 - d01 * d20) / denom
}

/// A surface point: position, geometric normal facing the incoming ray (offsets, light
/// sidedness), shading normal, albedo (base colour), emission, the direction towards whoever
/// sees it, and its glossy BRDF (None: diffuse).
struct Surface {
    x: Vec3,
    n: Vec3,
    ns: Vec3,
    albedo: Vec3,
    emission: Vec3,
    wo: Vec3,
    glossy: Option<BrdfSurface>,
}

/// One step of a path from a surface: the surface it reaches (None: the path ends), its weight
/// f cos / pdf, and the emission it finds MIS-weighted against the light table (only from a
/// glossy surface: a diffuse one leaves all of that light to next-event estimation).
struct Step {
    next: Option<Surface>,
    weight: Vec3,
    found: Vec3,
}

/// The power heuristic's weight of strategy a against b, as 1 / (1 + (b/a)^2) (twin of
/// `render_power_heuristic`: a^2 overflows f32 above 1.8e19).
fn power_heuristic(a: f32, b: f32) -> f32 {
    if a > 0.0 {
        let r = b / a;
        1.0 / (1.0 + r * r)
    } else {
        0.0
    }
}

/// Twin of `render_shading_normal`: the interpolated vertex normals at barycentrics b,
/// normalized and turned to the side of the geometric normal n (n when they cancel out).
fn shading_normal(vn: [Vec3; 3], b: Vec2, n: Vec3) -> Vec3 {
    let raw = (1.0 - b.x - b.y) * vn[0] + b.x * vn[1] + b.y * vn[2];
    let l2 = raw.length_squared();
    if l2.is_nan() || l2 <= 1e-30 {
        return n;
    }
    let ns = raw / l2.sqrt();
    if ns.dot(n) < 0.0 { -ns } else { ns }
}

/// Twin of `render_normal_mapped`, in f64: the interpolated normal N (the corners' vertex
/// normals, or the geometric normal at each) and tangent T (made orthogonal to N), B = w
/// cross(N, T) (w the sign of the interpolated handedness), the normal texture's texel `at`
/// turned into n = normalize((2 at - 1) * (scale, scale, 1)), and normalize(T n.x + B n.y +
/// N n.z) on the side of the geometric normal n; the interpolated normal (on that side) where
/// the frame degenerates. The GPU keeps the tangents as octahedral snorm16 (about 5e-5
/// radians); these are the scene's.
fn normal_mapped(t: &Triangle, tan: [Vec4; 3], at: Vec3, scale: f32, b: Vec2, n: Vec3) -> Vec3 {
    let w3 = DVec3::new(
        1.0 - f64::from(b.x) - f64::from(b.y),
        f64::from(b.x),
        f64::from(b.y),
    );
    let face = t.cross().normalize();
    let vn = [0, 1, 2].map(|c| t.n.map_or(face, |vn| vn[c]).as_dvec3());
    let raw = w3.x * vn[0] + w3.y * vn[1] + w3.z * vn[2];
    let l2 = raw.length_squared();
    let n = n.as_dvec3();
    if l2.is_nan() || l2 <= 1e-30 {
        return n.as_vec3();
    }
    let nn = raw / l2.sqrt();
    let ns = if nn.dot(n) < 0.0 { -nn } else { nn };
    let tc = tan.map(|t| t.truncate().as_dvec3().normalize());
    let ti = w3.x * tc[0] + w3.y * tc[1] + w3.z * tc[2];
    let tp = ti - nn * nn.dot(ti);
    let tl2 = tp.length_squared();
    let s = f64::from(scale);
    let ts = (at.as_dvec3() * 2.0 - DVec3::ONE) * DVec3::new(s, s, 1.0);
    let frame = tl2 > 1e-8 && ts.length_squared() > 1e-30;
    if !frame {
        return ns.as_vec3();
    }
    let w = w3.dot(DVec3::from(tan.map(|t| if t.w < 0.0 { -1.0 } else { 1.0 })));
    let tu = tp / tl2.sqrt();
    let bu = if w < 0.0 { -1.0 } else { 1.0 } * nn.cross(tu);
    let p = (tu * ts.x + bu * ts.y + nn * ts.z).normalize();
    (if p.dot(n) < 0.0 { -p } else { p }).as_vec3()
}

/// Most memory the CPU reference may use for its images (larger sizes are refused before any
/// work instead of aborting on allocation).
pub const MAX_REFERENCE_BYTES: u64 = 4 << 30;

/// Memory the CPU reference needs for a `width` x `height` image: the f64 row sums (48 bytes a
/// pixel) and the three f32 output images (36), with the images' final copies (36).
pub fn reference_bytes(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * (48 + 36 + 36)
}

impl ReferenceRenderer {
    /// Builds the CWBVH (obvhs medium preset) and the light table. The scene should be
    /// sanitized; an empty scene is an error.
    pub fn new(scene: &Scene) -> Result<Self, SceneError> {
        if scene.triangles.is_empty() {
            return Err(SceneError::Empty {
                what: "reference renderer".into(),
                report: None,
            });
        }
        let (lo, hi) = scene.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
        let extent = (hi - lo).max_element();
        let extent = if extent > 0.0 && extent.is_finite() {
            extent
        } else {
            1.0
        };
        // obvhs enters node boxes at t >= 1e-4 in its own units: a scene smaller than 1 is
        // traced scaled up to extent 1, so that its near hits stay visible.
        let units = 1.0 / extent.min(1.0);
        let tris: Vec<obvhs::triangle::Triangle> = scene
            .triangles
            .iter()
            .map(|t| obvhs::triangle::Triangle {
                v0: (t.v[0] * units).into(),
                v1: (t.v[1] * units).into(),
                v2: (t.v[2] * units).into(),
            })
            .collect();
        let mut build_time = std::time::Duration::ZERO;
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::medium_build(),
            &mut build_time,
        );
        let eps = 1e-5 * extent;
        Ok(Self {
            scene: scene.clone(),
            lights: Lights::build(scene),
            bvh,
            tris,
            eps,
            units,
        })
    }

    /// The light table (same as the GPU's).
    pub fn lights(&self) -> &Lights {
        &self.lights
    }

    fn closest(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let o = origin * self.units;
        let ray = Ray::new(Vec3A::from(o), Vec3A::from(dir), 0.0, f32::INFINITY);
        let mut hit = RayHit::none();
        if self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            self.tris[self.bvh.primitive_indices[id] as usize].intersect(r)
        }) {
            Some(Hit {
                t: hit.t / self.units,
                triangle: self.bvh.primitive_indices[hit.primitive_id as usize] as usize,
            })
        } else {
            None
        }
    }

    fn unoccluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        let o = origin * self.units;
        let ray = Ray::new(Vec3A::from(o), Vec3A::from(dir), 0.0, tmax * self.units);
        self.bvh.ray_traverse_miss(ray, |r, id| {
            self.tris[self.bvh.primitive_indices[id] as usize].intersect(r)
        })
    }

    /// Unshadowed reflected radiance at x (normal n, albedo a) from light sample `u` (and, for
    /// an environment sample, two more uniforms from `rng`), and the sample; None when the
    /// sample cannot contribute.
    fn light_term(&self, v: &Surface, u: [f32; 4], rng: &mut Rng) -> Option<(Vec3, LightSample)> {
        let mut s = self.lights.sample(u, rng)?;
        if s.pdf_area <= 0.0 {
            return None;
        }
        if s.kind == lights::KIND_TRIANGLE {
            // A textured emitter's radiance at the sampled point (twin of render_light_sample).
            let t = &self.scene.triangles[s.triangle as usize];
            let m = self.scene.materials[t.material as usize];
            if let (Some(uv), true) = (t.uv, m.emissive_texture != 0) {
                let b = sampling::triangle_uniform(Vec2::new(u[2], u[3]));
                s.emission *= self.texture(m.emissive_texture, uv, b);
            }
        }
        // A glossy surface's BRDF as the albedo whose / pi it is.
        let a = match v.glossy {
            Some(_) => self.brdf(v, self.light_direction(v.x, &s)) * std::f32::consts::PI,
            None => v.albedo,
        };
        let f = self.lights.contribution(v.x, v.n, v.ns, a, &s);
        (f != Vec3::ZERO).then_some((f, s))
    }

    /// The unit direction from x towards light sample s.
    fn light_direction(&self, x: Vec3, s: &LightSample) -> Vec3 {
        match lights::at_infinity(s.kind) {
            true => s.position,
            false => (s.position - x).normalize_or_zero(),
        }
    }

    /// v's BRDF from direction wi towards v.wo, without the cosine.
    fn brdf(&self, v: &Surface, wi: Vec3) -> Vec3 {
        match &v.glossy {
            Some(g) => {
                let (n, wo) = (v.ns.as_dvec3(), v.wo.as_dvec3());
                Brdf::new(crate::brdf::tables())
                    .eval(g, n, wo, wi.as_dvec3())
                    .as_vec3()
            }
            None => v.albedo * std::f32::consts::FRAC_1_PI,
        }
    }

    /// The density of direction wi from v's step (cosine where diffuse, the BRDF's sampler
    /// where glossy).
    fn step_pdf(&self, v: &Surface, wi: Vec3) -> f32 {
        match &v.glossy {
            Some(g) => {
                let (n, wo) = (v.ns.as_dvec3(), v.wo.as_dvec3());
                Brdf::new(crate::brdf::tables()).pdf(g, n, wo, wi.as_dvec3()) as f32
            }
            None => v.ns.dot(wi).max(0.0) * std::f32::consts::FRAC_1_PI,
        }
    }

    /// The light sample's MIS weight at a glossy surface against its step's density (the
    /// light table's density on the light side, as the GPU's with no estimate); 1 where
    /// diffuse (next-event estimation takes all of the light there) and for punctual lights.
    fn light_mis(&self, v: &Surface, s: &LightSample) -> f32 {
        if v.glossy.is_none() || s.kind == lights::KIND_POINT || s.kind == lights::KIND_DIRECTIONAL
        {
            return 1.0;
        }
        let wi = self.light_direction(v.x, s);
        let p_light = match s.kind {
            lights::KIND_ENV => self.lights.pdf_env(wi),
            _ => lights::pdf_solid_angle(self.lights.pdf_area(s.light), s.position - v.x, s.normal),
        };
        power_heuristic(p_light, self.step_pdf(v, wi))
    }

    /// Whether sample `s` is unoccluded from x (normal n): the segment to its point, or the ray
    /// along its direction for lights at infinity.
    fn visible(&self, x: Vec3, n: Vec3, s: &LightSample) -> bool {
        let o = x + n * self.eps;
        if lights::at_infinity(s.kind) {
            return self.unoccluded(o, s.position, f32::INFINITY);
        }
        let to = s.position - o;
        let d = to.length();
        d > 0.0 && self.unoccluded(o, to / d, d * (1.0 - 1e-4))
    }

    /// One light estimate of the reflected radiance at surface point v.
    fn estimate(&self, method: Estimator, v: &Surface, rng: &mut Rng) -> Vec3 {
        let (x, n) = (v.x, v.n);
        if self.lights.is_empty() {
            return Vec3::ZERO;
        }
        match method {
            Estimator::Nee => {
                let u = u4(rng);
                match self.light_term(v, u, rng) {
                    Some((f, s)) if self.visible(x, n, &s) => {
                        f * self.light_mis(v, &s) / s.pdf_area
                    }
                    _ => Vec3::ZERO,
                }
            }
            Estimator::Ris { candidates } => {
                let k = candidates.max(1);
                let mut w_sum = 0.0f32;
                let mut chosen: Option<(Vec3, LightSample, f32)> = None;
                for _ in 0..k {
                    let u = u4(rng);
                    let term = self.light_term(v, u, rng);
                    let pick = rng.next_f32();
                    if let Some((f, s)) = term {
                        let p_hat = luminance(f.to_array());
                        let w = p_hat / s.pdf_area;
                        if w > 0.0 && w.is_finite() {
                            w_sum += w;
                            if pick * w_sum < w {
                                chosen = Some((f, s, p_hat));
                            }
                        }
                    }
                }
                match chosen {
                    Some((f, s, p_hat)) if self.visible(x, n, &s) => {
                        f * self.light_mis(v, &s) * (w_sum / (k as f32 * p_hat))
                    }
                    _ => Vec3::ZERO,
                }
            }
        }
    }

    /// The surface at a hit of the ray (origin, dir).
    fn surface(&self, origin: Vec3, dir: Vec3, h: &Hit) -> Surface {
        let t = &self.scene.triangles[h.triangle];
        let m = self.scene.materials[t.material as usize];
        let mut n = t.cross().normalize();
        if n.dot(dir) > 0.0 {
            n = -n;
        }
        let x = origin + dir * h.t;
        let b = barycentrics(t.v, x);
        let ns = match t.n {
            Some(vn) => shading_normal(vn, b, n),
            None => n,
        };
        // The GPU's render::ATTR_TANGENTS: a normal texture and usable tangents.
        let ns = match (t.t, t.uv) {
            (Some(tan), Some(uv)) if m.normal_texture != 0 && tangents::usable(t) => {
                let at = self.texture(m.normal_texture, uv, b);
                normal_mapped(t, tan, at, m.normal_scale, b, n)
            }
            _ => ns,
        };
        let (mut albedo, mut emission) = (Vec3::from(m.albedo), Vec3::from(m.emission));
        let (mut metallic, mut roughness) = (m.metallic, m.roughness);
        if let Some(uv) = t.uv {
            if m.base_color_texture != 0 {
                albedo *= self.texture(m.base_color_texture, uv, b);
            }
            if m.emissive_texture != 0 {
                emission *= self.texture(m.emissive_texture, uv, b);
            }
            if m.metallic_roughness_texture != 0 {
                let mr = self.texture(m.metallic_roughness_texture, uv, b);
                (metallic, roughness) = (metallic * mr.z, roughness * mr.y);
            }
        }
        // The GPU keeps metallic in 8 bits and roughness in 16 (render::pack_material).
        let glossy = (m.model() == MaterialModel::MetalRoughness).then(|| BrdfSurface {
            base: albedo.as_dvec3(),
            metallic: f64::from((metallic.clamp(0.0, 1.0) * 255.0).round()) / 255.0,
            roughness: f64::from((roughness.clamp(0.0, 1.0) * 65535.0).round()) / 65535.0,
            diffuse: false,
        });
        Surface {
            x,
            n,
            ns,
            albedo,
            emission,
            wo: -dir,
            glossy,
        }
    }

    /// One step of a path from v ([`Step`]): a cosine-distributed direction about v's shading
    /// normal where diffuse (two uniforms), the BRDF's sample where glossy (three); the path
    /// ends where the direction is below the geometric surface or escapes.
    fn step(&self, v: &Surface, rng: &mut Rng) -> Step {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let (wi, weight) = match &v.glossy {
            None => (sampling::cosine_hemisphere(v.ns, u), v.albedo),
            Some(g) => {
                let u3 =
                    glam::DVec3::new(f64::from(u.x), f64::from(u.y), f64::from(rng.next_f32()));
                let (n, wo) = (v.ns.as_dvec3(), v.wo.as_dvec3());
                let s = Brdf::new(crate::brdf::tables()).sample(g, n, wo, u3);
                (s.wi.as_vec3(), s.weight.as_vec3())
            }
        };
        let ends = match v.glossy {
            Some(_) => wi.dot(v.n) <= 0.0 || weight == Vec3::ZERO,
            // Cosine-distributed about the shading normal but below the surface: no path.
            None => wi.dot(v.n) <= 0.0 && v.ns != v.n,
        };
        let none = Step {
            next: None,
            weight,
            found: Vec3::ZERO,
        };
        if ends {
            return none;
        }
        let o = v.x + v.n * self.eps;
        let Some(h) = self.closest(o, wi) else {
            let found = match v.glossy {
                Some(_) => {
                    let p_light = self.lights.pdf_env(wi);
                    self.lights.env_radiance(wi) * power_heuristic(self.step_pdf(v, wi), p_light)
                }
                None => Vec3::ZERO,
            };
            return Step { found, ..none };
        };
        let w = self.surface(o, wi, &h);
        let mut found = Vec3::ZERO;
        if v.glossy.is_some() && w.emission != Vec3::ZERO {
            let p_light = self.lights.pdf_hit(h.triangle as u32, v.x, w.x, w.n);
            found = w.emission * power_heuristic(self.step_pdf(v, wi), p_light);
        }
        Step {
            next: Some(w),
            weight,
            found,
        }
    }

    /// Texture ref `index - 1` at the texture coordinates of barycentrics b (of vertices 1, 2).
    fn texture(&self, index: u32, uv: [Vec2; 3], b: Vec2) -> Vec3 {
        let at = (1.0 - b.x - b.y) * uv[0] + b.x * uv[1] + b.y * uv[2];
        let r = &self.scene.texture_refs[index as usize - 1];
        Vec3::from(r.sample(&self.scene.textures, at))
    }

    /// (direct, indirect) of one sample.
    fn sample(
        &self,
        cam: &CameraGpu,
        px: [u32; 2],
        opts: &ReferenceOptions,
        rng: &mut Rng,
    ) -> (Vec3, Vec3) {
        let jitter = Vec2::new(rng.next_f32(), rng.next_f32());
        let eye = Vec3::from(cam.eye);
        let dir = cam.ray_dir(px, jitter);
        let Some(h1) = self.closest(eye, dir) else {
            // The camera ray escaped: it sees the environment.
            return (self.lights.env_radiance(dir), Vec3::ZERO);
        };
        let v1 = self.surface(eye, dir, &h1);
        let mut direct = v1.emission + self.estimate(opts.method, &v1, rng);
        let step = self.step(&v1, rng);
        direct += step.weight * step.found;
        let indirect = match step.next {
            Some(v2) => {
                step.weight * (self.estimate(opts.method, &v2, rng) + self.path(opts, v2, rng))
            }
            None => Vec3::ZERO,
        };
        (direct, indirect)
    }

    /// Bounces 2..=opts.paths.bounces beyond the secondary vertex v2: radiance towards x1 from the
    /// light estimates at x3, x4, ... (each vertex's step, throughput = the step weights of
    /// the vertices left behind after x1: their albedos where diffuse), and from glossy
    /// vertices the emission their steps find; Russian roulette as the GPU's `render_path`.
    fn path(&self, opts: &ReferenceOptions, v2: Surface, rng: &mut Rng) -> Vec3 {
        let (mut v, mut throughput, mut l) = (v2, Vec3::ONE, Vec3::ZERO);
        let paths = opts.paths;
        for bounce in 2..=paths.bounces {
            if paths.roulette_from != 0 && bounce >= paths.roulette_from {
                let q = self.survival(&v);
                if rng.next_f32() >= q {
                    return l;
                }
                throughput /= q;
            }
            let step = self.step(&v, rng);
            throughput *= step.weight;
            l += throughput * step.found;
            let Some(w) = step.next else {
                return l;
            };
            v = w;
            l += throughput * self.estimate(opts.method, &v, rng);
        }
        // The last vertex's light estimate is MIS-weighted where it is glossy: its step's
        // share of the emission is part of the last bounce.
        if v.glossy.is_some() {
            let step = self.step(&v, rng);
            l += throughput * step.weight * step.found;
        }
        l
    }

    /// The probability that a path survives Russian roulette at v (twin of
    /// `render_roulette_survival`): the largest channel of v's albedo, or of its BRDF's
    /// directional albedo where glossy; at most 1.
    fn survival(&self, v: &Surface) -> f32 {
        let a = match &v.glossy {
            Some(g) => {
                let (n, wo) = (v.ns.as_dvec3(), v.wo.as_dvec3());
                Brdf::new(crate::brdf::tables()).albedo(g, n, wo).as_vec3()
            }
            None => v.albedo,
        };
        a.max_element().min(1.0)
    }

    /// The radiance a white diffuse surface at `x` with unit normal `n` reflects towards any
    /// direction: the light estimate there plus the light of every bounce `opts.paths` takes
    /// beyond it (the first bounce's vertex lit by `opts.method`, then the path beyond it as
    /// [`ReferenceRenderer::render`]'s), averaged over `opts.spp` samples seeded by `opts.seed`
    /// (one thread). What the radiance cache stores for a cell at `x`.
    pub fn reflected_white(&self, x: Vec3, n: Vec3, opts: &ReferenceOptions) -> Vec3 {
        let v = Surface {
            x,
            n,
            ns: n,
            albedo: Vec3::ONE,
            emission: Vec3::ZERO,
            wo: n,
            glossy: None,
        };
        let mut sum = glam::DVec3::ZERO;
        for s in 0..opts.spp {
            let mut rng = Rng::seed(s, 0, opts.seed);
            let mut l = self.estimate(opts.method, &v, &mut rng);
            let wi = sampling::cosine_hemisphere(n, Vec2::new(rng.next_f32(), rng.next_f32()));
            let o = x + n * self.eps;
            if let Some(h) = self.closest(o, wi) {
                let w = self.surface(o, wi, &h);
                l += self.estimate(opts.method, &w, &mut rng) + self.path(opts, w, &mut rng);
            }
            sum += l.as_dvec3();
        }
        (sum / f64::from(opts.spp.max(1))).as_vec3()
    }

    /// Renders `camera` (its width x height) with `opts`. `progress`, if given, is called with
    /// the number of rows finished so far (from worker threads).
    /// Fails before any work when the image needs more than [`MAX_REFERENCE_BYTES`].
    pub fn render(
        &self,
        camera: &Camera,
        opts: &ReferenceOptions,
        progress: Option<&(dyn Fn(u32) + Sync)>,
    ) -> Result<Rendered, SceneError> {
        camera.validate()?;
        if opts.spp == 0 {
            return Err(SceneError::BadOption("spp must be at least 1".into()));
        }
        opts.paths.check(1).map_err(SceneError::BadOption)?;
        let bytes = reference_bytes(camera.width, camera.height);
        if bytes > MAX_REFERENCE_BYTES {
            return Err(SceneError::BadOption(format!(
                "cpu-reference: a {}x{} image needs about {:.1} GiB of memory, above the limit \
                 of {} GiB: render a smaller size",
                camera.width,
                camera.height,
                bytes as f64 / f64::from(1u32 << 30),
                MAX_REFERENCE_BYTES >> 30
            )));
        }
        let cam = CameraGpu::new(camera);
        let (w, h) = (camera.width, camera.height);
        let threads = if opts.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            opts.threads
        };
        let next_row = AtomicU32::new(0);
        let done = AtomicU32::new(0);
        let worker = || {
            let mut out = Vec::new();
            loop {
                let y = next_row.fetch_add(1, Ordering::Relaxed);
                if y >= h {
                    break;
                }
                out.push((y, self.row(&cam, y, w, opts)));
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                if let Some(p) = progress {
                    p(n);
                }
            }
            out
        };
        let mut rows: Vec<(u32, Vec<[f64; 6]>)> = std::thread::scope(|s| {
            let workers: Vec<_> = (0..threads.min(h as usize).max(1))
                .map(|_| s.spawn(worker))
                .collect();
            workers
                .into_iter()
                .flat_map(|w| w.join().unwrap_or_default())
                .collect()
        });
        if rows.len() != h as usize {
            return Err(SceneError::BadOption(
                "a reference worker thread panicked".into(),
            ));
        }
        rows.sort_by_key(|r| r.0);
        Ok(images(w, h, rows, opts.spp))
    }

    /// Row `y` of `w` pixels: per pixel the sums of (direct, indirect) over `opts.spp` samples.
    fn row(&self, cam: &CameraGpu, y: u32, w: u32, opts: &ReferenceOptions) -> Vec<[f64; 6]> {
        let mut row = vec![[0.0f64; 6]; w as usize];
        for (x, acc) in row.iter_mut().enumerate() {
            let pixel = y * w + x as u32;
            for s in 0..opts.spp {
                let mut rng = Rng::seed(pixel, s, opts.seed);
                let (d, i) = self.sample(cam, [x as u32, y], opts, &mut rng);
                for c in 0..3 {
                    acc[c] += f64::from(d[c]);
                    acc[3 + c] += f64::from(i[c]);
                }
            }
        }
        row
    }
}

/// The three images of `rows` (sorted by y) of sums over `spp` samples.
fn images(w: u32, h: u32, rows: Vec<(u32, Vec<[f64; 6]>)>, spp: u32) -> Rendered {
    let inv = 1.0 / f64::from(spp);
    let mut direct = Image::new(w, h);
    let mut indirect = Image::new(w, h);
    let mut combined = Image::new(w, h);
    for (y, row) in rows {
        for (x, acc) in row.into_iter().enumerate() {
            let i = y as usize * w as usize + x;
            for c in 0..3 {
                direct.pixels[i][c] = (acc[c] * inv) as f32;
                indirect.pixels[i][c] = (acc[3 + c] * inv) as f32;
                combined.pixels[i][c] = ((acc[c] + acc[3 + c]) * inv) as f32;
            }
        }
    }
    Rendered {
        direct,
        indirect,
        combined,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{self, Material};

    /// Renders `s` at one bounce (whose analytic values these tests know) and returns the
    /// channel means of (direct - Le, indirect).
    fn furnace_means(s: &Scene, method: Estimator, spp: u32, seed: u32) -> ([f64; 3], [f64; 3]) {
        let r = ReferenceRenderer::new(s).unwrap();
        let out = r
            .render(
                &s.camera.unwrap(),
                &ReferenceOptions {
                    method,
                    spp,
                    seed,
                    threads: 0,
                    paths: Paths::bounces(1),
                },
                None,
            )
            .unwrap();
        let le = f64::from(s.materials[0].emission[0]);
        let (d, i, c) = (out.direct.mean(), out.indirect.mean(), out.combined.mean());
        for ch in 0..3 {
            assert!((c[ch] - d[ch] - i[ch]).abs() < 1e-5);
        }
        (d.map(|x| x - le), i)
    }

    #[test]
    fn furnace_matches_the_analytic_values() {
        // rho = 0.5, Le = 1: direct = Le + rho Le (reflected part 0.5), indirect = rho^2 Le =
        // 0.25. On the icosphere furnace, 32x32 pixels x 32 spp: across seeds the image means
        // scatter by ~0.15% (reflected direct) and ~0.1% (indirect), so 1% is > 6 sd.
        let s = scene::furnace_sphere(0.5, 1.0, 32, 32).unwrap();
        for method in [Estimator::Nee, Estimator::Ris { candidates: 4 }] {
            let (d, i) = furnace_means(&s, method, 32, 1);
            for ch in 0..3 {
                assert!(
                    (d[ch] - 0.5).abs() < 0.005,
                    "{method:?} reflected direct {d:?}"
                );
                assert!((i[ch] - 0.25).abs() < 0.0025, "{method:?} indirect {i:?}");
            }
        }
    }

    #[test]
    fn box_furnace_is_close_to_the_analytic_values() {
        // The box furnace has edges where cos cos / d^2 is unbounded: the NEE estimator's
        // variance diverges there and fixed-seed means scatter by a few percent (one seed of
        // 32x32x32 gave an indirect 15% high). This is a sanity check at 3% with 128 spp and a
        // fixed seed, not a statistical test; the tight test uses the icosphere.
        let s = scene::furnace(0.5, 1.0, 32, 32).unwrap();
        let (d, i) = furnace_means(&s, Estimator::Nee, 128, 1);
        assert!((d[0] - 0.5).abs() < 0.015, "{d:?}");
        assert!((i[0] - 0.25).abs() < 0.0075, "{i:?}");
    }

    #[test]
    fn furnace_negative_control_catches_a_wrong_albedo() {
        // Planted error: rho = 0.515 (3% more reflected direct light, 6% more indirect) checked
        // against the rho = 0.5 values must fall outside the 1% tolerance.
        let s = scene::furnace_sphere(0.515, 1.0, 32, 32).unwrap();
        let (d, i) = furnace_means(&s, Estimator::Nee, 32, 1);
        assert!((d[0] - 0.5).abs() > 0.005, "{d:?}");
        assert!((i[0] - 0.25).abs() > 0.0025, "{i:?}");
    }

    #[test]
    fn nee_and_ris_agree_in_expectation_on_cornell() {
        // Same estimand, different estimators. 16x16 x 128 spp, fixed seed. Across seeds the
        // image means scatter by ~1% (direct) and ~2% (indirect) at 64 spp; at 128 spp and with
        // common primary rays (same seed) the NEE-RIS differences seen were below 1.5%.
        // Tolerance: 2.5% (direct), 5% (indirect). Negative control: a planted 10% bias in the
        // RIS image must be caught.
        let s = scene::cornell(16, 16);
        let r = ReferenceRenderer::new(&s).unwrap();
        let run = |method| {
            let o = ReferenceOptions {
                method,
                spp: 128,
                seed: 7,
                threads: 0,
                ..Default::default()
            };
            r.render(&s.camera.unwrap(), &o, None).unwrap()
        };
        let nee = run(Estimator::Nee);
        let ris = run(Estimator::Ris { candidates: 8 });
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-12);
        let within = |a: &Image, b: &Image, scale: f64, tol: f64| {
            let (ma, mb) = (a.mean(), b.mean());
            (0..3).all(|c| rel(ma[c] * scale, mb[c]) < tol)
        };
        assert!(
            within(&ris.direct, &nee.direct, 1.0, 0.025),
            "direct {:?} vs {:?}",
            ris.direct.mean(),
            nee.direct.mean()
        );
        assert!(
            within(&ris.indirect, &nee.indirect, 1.0, 0.05),
            "indirect {:?} vs {:?}",
            ris.indirect.mean(),
            nee.indirect.mean()
        );
        assert!(!within(&ris.direct, &nee.direct, 1.1, 0.025));
        assert!(!within(&ris.indirect, &nee.indirect, 1.1, 0.05));
    }

    #[test]
    fn no_emitters_renders_black_without_nan() {
        let mut s = Scene::default();
        let m = s.add_material(Material::new([0.8; 3], [0.0; 3]));
        s.push_box(Vec3::splat(-1.0), Vec3::splat(1.0), m);
        let cam = Camera {
            eye: Vec3::ZERO,
            target: Vec3::Z,
            up: Vec3::Y,
            vfov_deg: 60.0,
            width: 8,
            height: 8,
        };
        let r = ReferenceRenderer::new(&s).unwrap();
        for method in [Estimator::Nee, Estimator::Ris { candidates: 16 }] {
            let out = r
                .render(
                    &cam,
                    &ReferenceOptions {
                        method,
                        spp: 4,
                        ..Default::default()
                    },
                    None,
                )
                .unwrap();
            assert!(out.combined.pixels.iter().flatten().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn deterministic_for_a_seed_and_independent_of_threads() {
        let s = scene::cornell(12, 10);
        let r = ReferenceRenderer::new(&s).unwrap();
        let cam = s.camera.unwrap();
        let o = |seed, threads| ReferenceOptions {
            method: Estimator::Ris { candidates: 4 },
            spp: 2,
            seed,
            threads,
            ..Default::default()
        };
        let a = r.render(&cam, &o(3, 1), None).unwrap();
        let b = r.render(&cam, &o(3, 3), None).unwrap();
        assert_eq!(a, b);
        let c = r.render(&cam, &o(4, 1), None).unwrap();
        assert_ne!(a.combined, c.combined);
        assert!(a.combined.is_finite());
        // The light is visible and bright; the box is lit.
        assert!(a.combined.mean()[0] > 0.05, "{:?}", a.combined.mean());
    }
}
