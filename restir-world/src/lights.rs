//! Light sampling over every light of a scene in one power-proportional alias table built on
//! the CPU in O(n) (Vose 1991): the emissive triangles (uniform area sampling on the chosen
//! one), the environment (one entry; a pixel of its map is then picked in proportion to
//! luminance x solid angle by a second alias table, and a direction uniformly in that pixel's
//! solid angle) and the punctual lights (point, spot, directional: one entry each). Emitters are
//! two-sided (see [`crate::scene`]).
//!
//! **Measures.** A light sample's density `pdf_area` is in the sample's own measure: area
//! (triangles), solid angle (environment) or a discrete probability (punctual lights, delta
//! lights), and its unshadowed contribution ([`Lights::contribution`], WGSL
//! `render_light_contribution`) is the integrand in the same measure: f / pdf is the estimate
//! for every kind, and RIS weights p_hat / pdf compare samples of different kinds consistently
//! (the kinds are disjoint parts of one sample space). None of these measures depends on the
//! receiver (an area point, a direction at infinity and a delta light are the same sample seen
//! from anywhere), which is why world-space reuse needs no Jacobian.
//!
//! **Selection by power.** The table's weights estimate each light's power divided by 2 pi (the
//! factor common to them, as for two-sided Lambertian triangles: area x luminance of the
//! radiance). A punctual light emits 4 pi I (point) or about 2 pi (1 - cos of the mid cone
//! angle) I (spot); the environment and a directional light are weighted by the flux they send
//! through the scene's bounding sphere (radius r, half the bounding box diagonal): 4 pi^2 r^2
//! L_mean and pi r^2 E. Photometric units of glTF lights (candela, lux) are taken as the
//! radiometric ones, 1:1.
//!
//! GPU side: [`WGSL`] (structs `LightTriangle`, `AliasEntry`, `EnvPixel`, `LightsInfo`,
//! `LightSample`; functions `lights_pick`, `lights_sample`, `lights_pdf_area`,
//! `lights_pdf_solid_angle`, `lights_env_radiance`, `lights_point_falloff`), which a consumer
//! composes from [`modules`] with the [`bindings`] at a group of its choice. Upload with
//! [`GpuLights::new`] and bind [`GpuLights::resources`].
//!
//! [`Lights::pick`] and [`Lights::sample`] are the twins of `lights_pick` and `lights_sample`:
//! the same arithmetic on the same random numbers (the picked index is identical; positions
//! agree to a few ulp; environment directions to the precision of the GPU's sin and cos).

use glam::{Vec2, Vec3};
use reservoir::rng::Rng;

use crate::gpu::{Access, BindingSet, Resource, WgslModule};
use crate::sampling;
use crate::scene::environment::{self, Environment};
use crate::scene::{PunctualKind, PunctualLight, Scene, luminance};

/// WGSL source of the light sampling functions (no bindings; see [`bindings`]).
pub const WGSL: &str = include_str!("lights.wgsl");

/// [`LightTriangle::kind`] of an emissive triangle.
pub const KIND_TRIANGLE: u32 = 0;
/// [`LightTriangle::kind`] of the environment (one entry; samples are directions).
pub const KIND_ENV: u32 = 1;
/// [`LightTriangle::kind`] of a point or spot light.
pub const KIND_POINT: u32 = 2;
/// [`LightTriangle::kind`] of a directional light (samples are its direction).
pub const KIND_DIRECTIONAL: u32 = 3;

/// Whether samples of light kind `kind` are directions (at infinity) rather than points.
pub fn at_infinity(kind: u32) -> bool {
    kind == KIND_ENV || kind == KIND_DIRECTIONAL
}

/// The WGSL constants of the light kinds.
pub fn constants_wgsl() -> String {
    format!(
        "const LIGHTS_KIND_TRIANGLE: u32 = {KIND_TRIANGLE}u;\nconst LIGHTS_KIND_ENV: u32 = {KIND_ENV}u;\n\
         const LIGHTS_KIND_POINT: u32 = {KIND_POINT}u;\nconst LIGHTS_KIND_DIRECTIONAL: u32 = {KIND_DIRECTIONAL}u;\n\
         const LIGHTS_NONE: u32 = {NO_LIGHT}u;\n"
    )
}

/// One light of the selection table on the GPU (WGSL `LightTriangle`); for an emissive triangle
/// (`kind` [`KIND_TRIANGLE`]) the fields are as named. Other kinds (`area` = 1, `triangle` =
/// `u32::MAX`): [`KIND_ENV`] uses no geometry; [`KIND_POINT`] has its position in `p0`, the
/// spot axis (direction of travel; 0 for a point light) in `e1` and `e2` = (cos outer cone,
/// 1 / (cos inner - cos outer) or 0 for a point light, range or 0 for none);
/// [`KIND_DIRECTIONAL`] has the unit direction towards the light in `p0`. `emission` is the
/// radiance (triangles), the intensity (point, spot) or the illuminance (directional), RGB.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightTriangle {
    pub p0: [f32; 3],
    pub area: f32,
    /// p1 - p0.
    pub e1: [f32; 3],
    /// Probability that `lights_pick` returns this light (its share of the total power).
    pub prob: f32,
    /// p2 - p0.
    pub e2: [f32; 3],
    /// Index of the triangle in `Scene::triangles` (`u32::MAX` for other kinds).
    pub triangle: u32,
    pub emission: [f32; 3],
    /// One of the `KIND_*` constants.
    pub kind: u32,
}

/// One column of the alias table (WGSL `AliasEntry`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AliasEntry {
    /// Keep this column with probability `prob`...
    pub prob: f32,
    /// ...else return this one.
    pub alias_index: u32,
}

/// One pixel of the environment map on the GPU (WGSL `EnvPixel`): its radiance, the solid-angle
/// density of directions in it once the environment is the chosen light (its probability /
/// its solid angle), and its column of the pixels' alias table.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EnvPixel {
    pub radiance: [f32; 3],
    pub pdf: f32,
    pub alias_prob: f32,
    pub alias_index: u32,
    pub _pad: [u32; 2],
}

/// Light count, total power and environment size (WGSL `LightsInfo`, a uniform).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightsInfo {
    pub count: u32,
    /// Environment map width in pixels (0: no environment).
    pub env_width: u32,
    pub total_power: f32,
    pub env_height: u32,
    /// The environment's index in the table ([`NO_LIGHT`] without one).
    pub env_light: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// [`Lights::triangle_light`] of a triangle that is not a light (and
/// [`LightsInfo::env_light`] without an environment).
pub const NO_LIGHT: u32 = u32::MAX;

/// A sample of a light (twin of WGSL `LightSample`; not uploaded).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// The point on the light, or the unit direction towards it when
    /// [`at_infinity`]`(kind)`.
    pub position: Vec3,
    /// Density of having sampled it, in the sample's measure (module documentation).
    pub pdf_area: f32,
    /// Unit geometric normal of a light triangle (the direction for lights at infinity, the
    /// spot axis for punctual lights).
    pub normal: Vec3,
    /// Index into [`Lights::triangles`].
    pub light: u32,
    /// Radiance, intensity or illuminance (see [`LightTriangle`]).
    pub emission: Vec3,
    /// Index into `Scene::triangles` (`u32::MAX` for other kinds).
    pub triangle: u32,
    /// The light's `KIND_*`.
    pub kind: u32,
}

/// The lights of a scene: one table over every light (emissive triangles first, then the
/// environment, then the punctual lights in scene order) and the environment's pixel table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lights {
    /// Every light of the selection table (the name is historical: triangles come first).
    pub triangles: Vec<LightTriangle>,
    pub alias: Vec<AliasEntry>,
    /// Sum over lights of their weights (power / 2 pi, module documentation).
    pub total_power: f64,
    /// The environment's pixels (empty without an environment).
    pub env: Vec<EnvPixel>,
    pub env_width: u32,
    pub env_height: u32,
    /// What the environment was made from (`Environment::source`), for messages.
    pub env_source: String,
    /// Per scene triangle, its index in the table ([`NO_LIGHT`] when it does not emit): the
    /// density with which the table samples a point a ray hit (multiple importance sampling).
    pub triangle_light: Vec<u32>,
}

/// The sampling weight of an emitter: area x Rec. 709 luminance of its radiance (proportional
/// to its emitted power; the factor pi or 2 pi is common to all).
pub fn power(area: f32, emission: [f32; 3]) -> f64 {
    f64::from(area) * f64::from(luminance(emission))
}

/// Vose's alias method: O(n) table for sampling index i with probability w_i / sum(w).
/// Weights must be finite and >= 0 with a positive sum; returns an empty table otherwise.
pub fn build_alias(weights: &[f64]) -> Vec<AliasEntry> {
    let n = weights.len();
    let sum: f64 = weights.iter().sum();
    if n == 0 || !(sum > 0.0 && sum.is_finite()) || weights.iter().any(|w| w.is_nan() || *w < 0.0) {
        return Vec::new();
    }
    let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / sum).collect();
    let mut table = vec![
        AliasEntry {
            prob: 1.0,
            alias_index: 0
        };
        n
    ];
    let (mut small, mut large): (Vec<u32>, Vec<u32>) =
        (0..n as u32).partition(|&i| scaled[i as usize] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        table[s as usize] = AliasEntry {
            prob: scaled[s as usize] as f32,
            alias_index: l,
        };
        scaled[l as usize] -= 1.0 - scaled[s as usize];
        if scaled[l as usize] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // Leftovers (numerical round-off) keep their own column with probability 1.
    for i in small.into_iter().chain(large) {
        table[i as usize] = AliasEntry {
            prob: 1.0,
            alias_index: i,
        };
    }
    table
}

/// The weight of a triangle with an emissive texture: area x luminance of the factor times the
/// texture's mean over 16 stratified points of the triangle, at least 1/1000 of the untextured
/// weight (so that no emitting texel is left unreachable by a mean that missed it).
fn textured_power(scene: &Scene, area: f32, factor: [f32; 3], tex: u32, uv: [Vec2; 3]) -> f64 {
    let r = &scene.texture_refs[tex as usize - 1];
    let mut mean = Vec3::ZERO;
    for k in 0..16 {
        let u = Vec2::new((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5) / 4.0;
        let b = sampling::triangle_uniform(u);
        let at = (1.0 - b.x - b.y) * uv[0] + b.x * uv[1] + b.y * uv[2];
        mean += Vec3::from(r.sample(&scene.textures, at)) / 16.0;
    }
    let untextured = power(area, factor);
    power(area, (Vec3::from(factor) * mean).to_array()).max(1e-3 * untextured)
}

/// Radius of the sphere around the scene that lights at infinity are weighted through: half
/// the bounding box diagonal (1 for an empty scene).
pub fn scene_radius(scene: &Scene) -> f64 {
    scene.bounds().map_or(1.0, |(lo, hi)| {
        let r = 0.5 * f64::from((hi - lo).length());
        if r.is_finite() && r > 0.0 { r } else { 1.0 }
    })
}

fn entry(kind: u32, p0: Vec3, e1: Vec3, e2: Vec3, emission: [f32; 3]) -> LightTriangle {
    LightTriangle {
        p0: p0.to_array(),
        area: 1.0,
        e1: e1.to_array(),
        prob: 0.0,
        e2: e2.to_array(),
        triangle: u32::MAX,
        emission,
        kind,
    }
}

/// The environment's pixel table: alias over luminance x solid angle, per-pixel densities.
fn env_table(env: &Environment) -> Vec<EnvPixel> {
    let mut weights = Vec::with_capacity(env.pixels.len());
    let mut omegas = Vec::with_capacity(env.pixels.len());
    for y in 0..env.height {
        let omega = env.row_solid_angle(y);
        for x in 0..env.width {
            let p = env.pixels[(y * env.width + x) as usize];
            weights.push(f64::from(luminance(p)) * omega);
            omegas.push(omega);
        }
    }
    let total: f64 = weights.iter().sum();
    let alias = build_alias(&weights);
    env.pixels
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let a = alias.get(k).copied().unwrap_or(AliasEntry {
                prob: 1.0,
                alias_index: k as u32,
            });
            let pdf = if total > 0.0 && omegas[k] > 0.0 {
                (weights[k] / total / omegas[k]) as f32
            } else {
                0.0
            };
            EnvPixel {
                radiance: *p,
                pdf,
                alias_prob: a.prob,
                alias_index: a.alias_index,
                _pad: [0; 2],
            }
        })
        .collect()
}

/// The table entries (weight, entry) of the scene's emissive triangles: power of the
/// material's emission (its texture's mean where it has one) over the triangle.
fn emissive_triangles(scene: &Scene) -> Vec<(f64, LightTriangle)> {
    let mut out = Vec::new();
    for (i, t) in scene.triangles.iter().enumerate() {
        let Some(m) = scene.materials.get(t.material as usize) else {
            continue;
        };
        let area = t.area();
        let mut w = power(area, m.emission);
        if let (Some(uv), true) = (t.uv, m.emissive_texture != 0 && w > 0.0) {
            w = textured_power(scene, area, m.emission, m.emissive_texture, uv);
        }
        let e = LightTriangle {
            p0: t.v[0].to_array(),
            area,
            e1: (t.v[1] - t.v[0]).to_array(),
            prob: 0.0,
            e2: (t.v[2] - t.v[0]).to_array(),
            triangle: i as u32,
            emission: m.emission,
            kind: KIND_TRIANGLE,
        };
        out.push((w, e));
    }
    out
}

/// The table entry (weight, entry) of a punctual light in a scene of bounding-sphere radius
/// `r` (see the module documentation for the weights).
fn punctual(l: &PunctualLight, r: f64) -> (f64, LightTriangle) {
    let emission = l.color.map(|c| c * l.intensity);
    let lum = f64::from(luminance(emission));
    let range = l.range.unwrap_or(0.0);
    match l.kind {
        PunctualKind::Point => {
            let params = Vec3::new(-2.0, 0.0, range);
            let e = entry(KIND_POINT, l.position, Vec3::ZERO, params, emission);
            (2.0 * lum, e)
        }
        PunctualKind::Spot {
            inner_cone,
            outer_cone,
        } => {
            let (ci, co) = (inner_cone.cos(), outer_cone.cos());
            let mid = f64::from(0.5 * (inner_cone + outer_cone)).cos();
            let scale = 1.0 / (ci - co).max(1e-3);
            let params = Vec3::new(co, scale, range);
            let e = entry(KIND_POINT, l.position, l.direction, params, emission);
            ((1.0 - mid) * lum, e)
        }
        PunctualKind::Directional => {
            let e = entry(
                KIND_DIRECTIONAL,
                -l.direction,
                Vec3::ZERO,
                Vec3::ZERO,
                emission,
            );
            (0.5 * r * r * lum, e)
        }
    }
}

impl Lights {
    /// Collects the lights of `scene`: its emissive triangles (material emission > 0, area >
    /// 0), its environment and its punctual lights, and builds the alias table over their
    /// weights (module documentation). Lights of weight 0 are left out; a scene without any
    /// gives empty lights (the environment's radiance is still seen by rays that miss).
    pub fn build(scene: &Scene) -> Self {
        let mut entries = emissive_triangles(scene);
        let r = scene_radius(scene);
        let (mut env, mut env_width, mut env_height) = (Vec::new(), 0, 0);
        let mut env_source = String::new();
        if let Some(e) = &scene.environment {
            env = env_table(e);
            env_source.clone_from(&e.source);
            (env_width, env_height) = (e.width, e.height);
            let w = 2.0 * std::f64::consts::PI * r * r * e.mean_luminance();
            let zero = Vec3::ZERO;
            entries.push((w, entry(KIND_ENV, zero, zero, zero, [0.0; 3])));
        }
        entries.extend(scene.lights.iter().map(|l| punctual(l, r)));
        entries.retain(|(w, _)| *w > 0.0 && w.is_finite());
        let (weights, mut triangles): (Vec<f64>, Vec<LightTriangle>) = entries.into_iter().unzip();
        let total_power: f64 = weights.iter().sum();
        for (t, w) in triangles.iter_mut().zip(&weights) {
            t.prob = (w / total_power) as f32;
        }
        let alias = build_alias(&weights);
        let mut triangle_light = vec![NO_LIGHT; scene.triangles.len()];
        for (i, t) in triangles.iter().enumerate() {
            if t.kind == KIND_TRIANGLE {
                triangle_light[t.triangle as usize] = i as u32;
            }
        }
        Self {
            triangles,
            alias,
            total_power,
            env,
            env_width,
            env_height,
            env_source,
            triangle_light,
        }
    }

    /// Number of lights in the table.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// Whether there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The uniform block.
    pub fn info(&self) -> LightsInfo {
        let env_light = self.triangles.iter().position(|t| t.kind == KIND_ENV);
        LightsInfo {
            count: self.triangles.len() as u32,
            env_width: self.env_width,
            total_power: self.total_power as f32,
            env_height: self.env_height,
            env_light: env_light.map_or(NO_LIGHT, |i| i as u32),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }

    /// Twin of `lights_pick`: a light index from two uniforms in [0, 1). Panics if empty.
    pub fn pick(&self, u0: f32, u1: f32) -> u32 {
        let n = self.triangles.len() as u32;
        let column = ((u0 * n as f32) as u32).min(n - 1);
        let e = self.alias[column as usize];
        if u1 < e.prob { column } else { e.alias_index }
    }

    /// Area density of points on light `light` (twin of `lights_pdf_area`; the discrete
    /// probability for punctual lights).
    pub fn pdf_area(&self, light: u32) -> f32 {
        let t = &self.triangles[light as usize];
        t.prob / t.area
    }

    /// Twin of `lights_pdf_hit`: the solid-angle density at p with which [`Lights::sample`]
    /// draws the point q (normal nq) of scene triangle `triangle` (0 when it is no light).
    pub fn pdf_hit(&self, triangle: u32, p: Vec3, q: Vec3, nq: Vec3) -> f32 {
        match self.triangle_light.get(triangle as usize) {
            Some(&light) if light != NO_LIGHT => pdf_solid_angle(self.pdf_area(light), q - p, nq),
            _ => 0.0,
        }
    }

    /// Twin of `lights_pdf_env`: the solid-angle density with which [`Lights::sample`] draws
    /// the environment direction `dir` (0 without an environment).
    pub fn pdf_env(&self, dir: Vec3) -> f32 {
        let Some(t) = self.triangles.iter().find(|t| t.kind == KIND_ENV) else {
            return 0.0;
        };
        let k = environment::pixel_of(self.env_width, self.env_height, dir);
        t.prob * self.env[k].pdf
    }

    /// Twin of `lights_env_radiance`: the environment's radiance from unit direction `dir`
    /// (0 without an environment).
    pub fn env_radiance(&self, dir: Vec3) -> Vec3 {
        if self.env_width == 0 {
            return Vec3::ZERO;
        }
        let k = environment::pixel_of(self.env_width, self.env_height, dir);
        Vec3::from(self.env[k].radiance)
    }

    /// Twin of `lights_sample`: `None` when there are no lights. `u` picks the light and the
    /// point on a triangle (or the environment's pixel); an environment sample draws two more
    /// uniforms from `rng` for the direction in its pixel.
    pub fn sample(&self, u: [f32; 4], rng: &mut Rng) -> Option<LightSample> {
        if self.is_empty() {
            return None;
        }
        let i = self.pick(u[0], u[1]);
        let t = &self.triangles[i as usize];
        let (p0, e1, e2) = (Vec3::from(t.p0), Vec3::from(t.e1), Vec3::from(t.e2));
        let mut s = LightSample {
            position: p0,
            pdf_area: t.prob,
            normal: e1,
            light: i,
            emission: Vec3::from(t.emission),
            triangle: t.triangle,
            kind: t.kind,
        };
        match t.kind {
            KIND_TRIANGLE => {
                let b = sampling::triangle_uniform(Vec2::new(u[2], u[3]));
                s.position = p0 + b.x * e1 + b.y * e2;
                s.pdf_area = t.prob / t.area;
                s.normal = e1.cross(e2).normalize();
            }
            KIND_ENV => {
                let n = self.env.len() as u32;
                let column = ((u[2] * n as f32) as u32).min(n - 1);
                let c = self.env[column as usize];
                let k = if u[3] < c.alias_prob {
                    column
                } else {
                    c.alias_index
                };
                let (a, b) = (rng.next_f32(), rng.next_f32());
                let (w, h) = (self.env_width, self.env_height);
                let (x, y) = (k % w, k / w);
                let phi = (x as f32 + a) * (std::f32::consts::TAU / w as f32);
                let (c0, c1) = environment::row_cosines(h, y);
                let px = self.env[k as usize];
                s.position = Environment::direction(phi, c0 + b * (c1 - c0));
                s.normal = s.position;
                s.pdf_area = t.prob * px.pdf;
                s.emission = Vec3::from(px.radiance);
            }
            _ => {
                if t.kind == KIND_DIRECTIONAL {
                    s.normal = p0;
                }
            }
        }
        Some(s)
    }

    /// Twin of `lights_point_falloff`: the spot cone and range attenuation of point light
    /// `light` towards a receiver in unit direction `wo` (from the light) at squared distance
    /// `d2`, as recommended by `KHR_lights_punctual`.
    pub fn point_falloff(&self, light: u32, wo: Vec3, d2: f32) -> f32 {
        let t = &self.triangles[light as usize];
        let (axis, cone) = (Vec3::from(t.e1), Vec3::from(t.e2));
        let mut a = 1.0;
        if cone.y > 0.0 {
            let s = ((axis.dot(wo) - cone.x) * cone.y).clamp(0.0, 1.0);
            a = s * s;
        }
        if cone.z > 0.0 {
            let q = d2 / (cone.z * cone.z);
            a *= (1.0 - q * q).clamp(0.0, 1.0);
        }
        a
    }

    /// Twin of `render_light_contribution`: the unshadowed reflected radiance at x (geometric
    /// normal n: the light must be on its side; shading normal ns: the cosine; albedo a) from
    /// sample `s`, in the sample's measure (no pdf).
    pub fn contribution(&self, x: Vec3, n: Vec3, ns: Vec3, a: Vec3, s: &LightSample) -> Vec3 {
        let brdf = a * std::f32::consts::FRAC_1_PI;
        if at_infinity(s.kind) {
            let cos_x = ns.dot(s.position);
            return if cos_x > 0.0 && n.dot(s.position) > 0.0 {
                brdf * s.emission * cos_x
            } else {
                Vec3::ZERO
            };
        }
        let to = s.position - x;
        let d2 = to.length_squared();
        if d2 <= 0.0 {
            return Vec3::ZERO;
        }
        let d = d2.sqrt();
        let cos_x = ns.dot(to) / d;
        if cos_x <= 0.0 || n.dot(to) <= 0.0 {
            return Vec3::ZERO;
        }
        if s.kind == KIND_POINT {
            let falloff = self.point_falloff(s.light, -to / d, d2);
            return brdf * s.emission * (cos_x * falloff / d2);
        }
        let cos_l = s.normal.dot(to).abs() / d;
        if cos_l <= 0.0 {
            return Vec3::ZERO;
        }
        brdf * s.emission * (cos_x * cos_l / d2)
    }
}

/// Twin of `lights_pdf_solid_angle`: pdf_area d^2 / |cos theta_light|, 0 when edge-on.
pub fn pdf_solid_angle(pdf_area: f32, to_light: Vec3, light_normal: Vec3) -> f32 {
    let d2 = to_light.dot(to_light);
    let cos_l = light_normal.dot(to_light).abs() / d2.max(1e-30).sqrt();
    if cos_l <= 0.0 || d2 <= 0.0 {
        return 0.0;
    }
    pdf_area * d2 / cos_l
}

/// The lights' bindings: `lights_triangles`, `lights_alias` and `lights_info`.
pub fn bindings() -> BindingSet {
    BindingSet::new("lights")
        .buffer("lights_triangles", "array<LightTriangle>", Access::Read)
        .buffer("lights_alias", "array<AliasEntry>", Access::Read)
        .buffer("lights_env", "array<EnvPixel>", Access::Read)
        .buffer("lights_info", "LightsInfo", Access::Uniform)
        .buffer("lights_of_triangle", "array<u32>", Access::Read)
}

/// Errors of [`GpuLights::new`].
#[derive(Debug, thiserror::Error)]
pub enum LightsError {
    #[error(
        "{count} lights need {bytes} bytes in one storage binding, above the adapter's limit of {limit}"
    )]
    TooLarge {
        count: usize,
        bytes: u64,
        limit: u64,
    },
    #[error(
        "{source_name}: the environment map of {size} ({pixels} pixels) needs {bytes} bytes in \
         one storage binding, above the adapter's limit of {limit}: resize it"
    )]
    EnvTooLarge {
        /// What the map was made from (a file, `--env FILE`).
        source_name: String,
        size: String,
        pixels: usize,
        bytes: u64,
        limit: u64,
    },
}

/// Checks that `count` lights fit one storage binding of `limit` bytes (the largest of the
/// light buffers is the `LightTriangle` array).
pub fn check_fits(count: usize, limit: u64) -> Result<(), LightsError> {
    let bytes = (count as u64).saturating_mul(std::mem::size_of::<LightTriangle>() as u64);
    if bytes > limit {
        return Err(LightsError::TooLarge {
            count,
            bytes,
            limit,
        });
    }
    Ok(())
}

/// The lights uploaded to the GPU. Empty lights upload one zeroed dummy per array (bindings
/// must not be empty) and `count = 0`.
#[derive(Debug)]
pub struct GpuLights {
    pub triangles: wgpu::Buffer,
    pub alias: wgpu::Buffer,
    pub env: wgpu::Buffer,
    pub info: wgpu::Buffer,
    pub triangle_light: wgpu::Buffer,
    pub count: u32,
}

impl GpuLights {
    /// Uploads `lights`; errors before allocating if they exceed the device's storage binding
    /// size.
    pub fn new(device: &wgpu::Device, lights: &Lights) -> Result<Self, LightsError> {
        let limit = device.limits().max_storage_buffer_binding_size;
        check_fits(lights.len(), limit)?;
        let env_bytes = (lights.env.len() as u64) * std::mem::size_of::<EnvPixel>() as u64;
        if env_bytes > limit {
            return Err(LightsError::EnvTooLarge {
                source_name: lights.env_source.clone(),
                size: format!("{}x{}", lights.env_width, lights.env_height),
                pixels: lights.env.len(),
                bytes: env_bytes,
                limit,
            });
        }
        let dummy_t = [bytemuck::Zeroable::zeroed()];
        let dummy_a = [AliasEntry {
            prob: 1.0,
            alias_index: 0,
        }];
        let (t, a): (&[LightTriangle], &[AliasEntry]) = if lights.is_empty() {
            (&dummy_t, &dummy_a)
        } else {
            (&lights.triangles, &lights.alias)
        };
        let no_triangles = [NO_LIGHT];
        let triangle_light = match lights.triangle_light.is_empty() {
            true => &no_triangles[..],
            false => &lights.triangle_light,
        };
        let dummy_e = [bytemuck::Zeroable::zeroed()];
        let e: &[EnvPixel] = if lights.env.is_empty() {
            &dummy_e
        } else {
            &lights.env
        };
        use crate::gpu::buffers;
        Ok(Self {
            triangles: buffers::storage_from(device, "lights_triangles", t),
            alias: buffers::storage_from(device, "lights_alias", a),
            env: buffers::storage_from(device, "lights_env", e),
            info: buffers::with_usage(
                device,
                "lights_info",
                &[lights.info()],
                wgpu::BufferUsages::UNIFORM,
            ),
            triangle_light: buffers::storage_from(device, "lights_of_triangle", triangle_light),
            count: lights.len() as u32,
        })
    }

    /// The buffers of [`bindings`], by name.
    pub fn resources(&self) -> [(&'static str, Resource<'_>); 5] {
        [
            ("lights_triangles", (&self.triangles).into()),
            ("lights_alias", (&self.alias).into()),
            ("lights_env", (&self.env).into()),
            ("lights_info", (&self.info).into()),
            ("lights_of_triangle", (&self.triangle_light).into()),
        ]
    }
}

/// The lights' WGSL modules with their bindings at `group`: `rng` (reservoir's random numbers,
/// which environment sampling draws from), `sampling`, `lights-constants`, `lights-bindings`
/// and `lights` (the light sampling functions).
pub fn modules(group: u32) -> Vec<WgslModule> {
    vec![
        WgslModule::new("rng", &[], reservoir::rng::WGSL),
        WgslModule::new("sampling", &[], sampling::WGSL),
        WgslModule::new("lights-constants", &[], constants_wgsl()),
        WgslModule::new("lights-bindings", &[], bindings().wgsl(group)),
        WgslModule::new(
            "lights",
            &["rng", "sampling", "lights-constants", "lights-bindings"],
            WGSL,
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Triangle};

    #[test]
    fn alias_table_reproduces_the_weights_exactly() {
        // The probability of index i is sum over columns of (prob or 1 - prob) / n: compute it
        // from the table and compare with the weights.
        let weights = [1.0, 0.0, 3.0, 0.5, 10.0, 2.5, 0.0, 7.0];
        let t = build_alias(&weights);
        let n = weights.len() as f64;
        let sum: f64 = weights.iter().sum();
        let mut p = vec![0.0f64; weights.len()];
        for (c, e) in t.iter().enumerate() {
            p[c] += f64::from(e.prob) / n;
            p[e.alias_index as usize] += (1.0 - f64::from(e.prob)) / n;
        }
        for (i, w) in weights.iter().enumerate() {
            assert!(
                (p[i] - w / sum).abs() < 1e-6,
                "{i}: {} vs {}",
                p[i],
                w / sum
            );
        }
        assert!(build_alias(&[]).is_empty());
        assert!(build_alias(&[0.0, 0.0]).is_empty());
        assert!(build_alias(&[1.0, f64::NAN]).is_empty());
    }

    #[test]
    fn lights_select_by_power_and_sample_on_the_triangle() {
        let mut s = Scene::default();
        let dim = s.add_material(Material::new([0.5; 3], [1.0; 3]));
        let bright = s.add_material(Material::new([0.5; 3], [3.0; 3]));
        let dark = s.add_material(Material::new([0.5; 3], [0.0; 3]));
        let t = |m, z: f32| {
            Triangle::new(
                [
                    Vec3::new(0.0, 0.0, z),
                    Vec3::new(1.0, 0.0, z),
                    Vec3::new(0.0, 2.0, z),
                ],
                m,
            )
        };
        s.triangles = vec![t(dark, 0.0), t(dim, 1.0), t(bright, 2.0)];
        let l = Lights::build(&s);
        assert_eq!(l.len(), 2);
        assert_eq!(l.triangles[0].triangle, 1);
        assert!((l.triangles[1].prob - 0.75).abs() < 1e-7);
        let mut rng = Rng::seed(0, 0, 0);
        let (mut hits, m) = ([0u32; 2], 40_000);
        for _ in 0..m {
            let u = [0; 4].map(|_| rng.next_f32());
            let smp = l.sample(u, &mut rng).unwrap();
            hits[smp.light as usize] += 1;
            assert_eq!(smp.position.z, [1.0, 2.0][smp.light as usize]);
            assert!(smp.position.x >= 0.0 && smp.position.y >= 0.0);
            assert!(smp.position.x + smp.position.y / 2.0 <= 1.0 + 1e-6);
            assert!((smp.pdf_area - l.pdf_area(smp.light)).abs() == 0.0);
            assert_eq!(smp.normal, Vec3::Z);
        }
        // Binomial sd sqrt(m p q) = 87: 5 sd.
        assert!(
            (f64::from(hits[1]) - 0.75 * f64::from(m)).abs() < 435.0,
            "{hits:?}"
        );
        // pdfs integrate to 1 over all lights: sum prob = 1.
        let total: f32 = l.triangles.iter().map(|t| t.prob).sum();
        assert!((total - 1.0).abs() < 1e-6);
    }

    #[test]
    fn no_emitters_means_no_samples() {
        let mut s = Scene::default();
        let m = s.add_material(Material::new([0.5; 3], [0.0; 3]));
        s.push_box(Vec3::ZERO, Vec3::ONE, m);
        let l = Lights::build(&s);
        assert!(l.is_empty() && l.sample([0.5; 4], &mut Rng::seed(0, 0, 0)).is_none());
        assert_eq!(l.info().count, 0);
    }

    #[test]
    fn too_many_lights_for_the_adapter_is_an_error() {
        // lavapipe's 128 MiB binding holds 2^21 lights of 64 bytes.
        let limit = 128 << 20;
        assert!(check_fits(1 << 21, limit).is_ok());
        let e = check_fits((1 << 21) + 1, limit).unwrap_err();
        assert!(e.to_string().contains("2097153 lights"), "{e}");
    }

    #[test]
    fn solid_angle_pdf() {
        // Light facing the receiver at distance 2: pdf_sa = pdf_area * 4.
        let p = pdf_solid_angle(0.5, Vec3::new(0.0, 0.0, 2.0), -Vec3::Z);
        assert!((p - 2.0).abs() < 1e-6);
        // At 60 degrees: divide by cos = 0.5.
        let d = Vec3::new(3f32.sqrt(), 0.0, 1.0);
        let p = pdf_solid_angle(1.0, d, Vec3::Z);
        assert!((p - 4.0 / 0.5).abs() < 1e-4, "{p}");
        assert_eq!(pdf_solid_angle(1.0, Vec3::X, Vec3::Z), 0.0);
    }
}
