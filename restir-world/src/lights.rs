//! Light sampling over the emissive triangles: a power-proportional alias table built on the
//! CPU in O(n) (Vose 1991), uniform area sampling on the chosen triangle, pdfs in area and solid
//! angle. Emitters are two-sided (see [`crate::scene`]).
//!
//! GPU side: [`WGSL`] (structs `LightTriangle`, `AliasEntry`, `LightsInfo`, `LightSample`;
//! functions `lights_pick`, `lights_sample`, `lights_pdf_area`, `lights_pdf_solid_angle`), which
//! a consumer composes from [`modules`] with the [`bindings`] at a group of its choice. Upload
//! with [`GpuLights::new`] and bind [`GpuLights::resources`].
//!
//! [`Lights::pick`] and [`Lights::sample`] are the twins of `lights_pick` and `lights_sample`:
//! the same arithmetic on the same random numbers (the picked index is identical; positions
//! agree to a few ulp).

use glam::{Vec2, Vec3};

use crate::gpu::{Access, BindingSet, Resource, WgslModule};
use crate::sampling;
use crate::scene::{Scene, builtin::luminance};

/// WGSL source of the light sampling functions (no bindings; see [`bindings`]).
pub const WGSL: &str = include_str!("lights.wgsl");

/// One emissive triangle on the GPU (WGSL `LightTriangle`).
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
    /// Index of the triangle in `Scene::triangles`.
    pub triangle: u32,
    pub emission: [f32; 3],
    pub _pad: u32,
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

/// Light count and total power (WGSL `LightsInfo`, a uniform).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightsInfo {
    pub count: u32,
    pub _pad0: u32,
    pub total_power: f32,
    pub _pad1: u32,
}

/// A point on a light (twin of WGSL `LightSample`; not uploaded).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    pub position: Vec3,
    /// Density per unit area of having sampled this point.
    pub pdf_area: f32,
    /// Unit geometric normal of the light triangle.
    pub normal: Vec3,
    /// Index into [`Lights::triangles`].
    pub light: u32,
    pub emission: Vec3,
    /// Index into `Scene::triangles`.
    pub triangle: u32,
}

/// The lights of a scene: its emissive triangles with their alias table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lights {
    pub triangles: Vec<LightTriangle>,
    pub alias: Vec<AliasEntry>,
    /// Sum over lights of area x luminance(emission).
    pub total_power: f64,
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

impl Lights {
    /// Collects the emissive triangles of `scene` (material emission > 0, area > 0) and builds
    /// the alias table over their power. A scene without emitters gives empty lights.
    pub fn build(scene: &Scene) -> Self {
        let mut triangles = Vec::new();
        let mut weights = Vec::new();
        for (i, t) in scene.triangles.iter().enumerate() {
            let Some(m) = scene.materials.get(t.material as usize) else {
                continue;
            };
            let area = t.area();
            let w = power(area, m.emission);
            if !(w > 0.0 && w.is_finite()) {
                continue;
            }
            weights.push(w);
            triangles.push(LightTriangle {
                p0: t.v[0].to_array(),
                area,
                e1: (t.v[1] - t.v[0]).to_array(),
                prob: 0.0,
                e2: (t.v[2] - t.v[0]).to_array(),
                triangle: i as u32,
                emission: m.emission,
                _pad: 0,
            });
        }
        let total_power: f64 = weights.iter().sum();
        for (t, w) in triangles.iter_mut().zip(&weights) {
            t.prob = (w / total_power) as f32;
        }
        let alias = build_alias(&weights);
        Self {
            triangles,
            alias,
            total_power,
        }
    }

    /// Number of emissive triangles.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// Whether there is nothing to sample.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The uniform block.
    pub fn info(&self) -> LightsInfo {
        LightsInfo {
            count: self.triangles.len() as u32,
            _pad0: 0,
            total_power: self.total_power as f32,
            _pad1: 0,
        }
    }

    /// Twin of `lights_pick`: a light index from two uniforms in [0, 1). Panics if empty.
    pub fn pick(&self, u0: f32, u1: f32) -> u32 {
        let n = self.triangles.len() as u32;
        let column = ((u0 * n as f32) as u32).min(n - 1);
        let e = self.alias[column as usize];
        if u1 < e.prob { column } else { e.alias_index }
    }

    /// Area density of points on light `light` (twin of `lights_pdf_area`).
    pub fn pdf_area(&self, light: u32) -> f32 {
        let t = &self.triangles[light as usize];
        t.prob / t.area
    }

    /// Twin of `lights_sample`: `None` when there are no lights.
    pub fn sample(&self, u: [f32; 4]) -> Option<LightSample> {
        if self.is_empty() {
            return None;
        }
        let i = self.pick(u[0], u[1]);
        let t = &self.triangles[i as usize];
        let b = sampling::triangle_uniform(Vec2::new(u[2], u[3]));
        let (p0, e1, e2) = (Vec3::from(t.p0), Vec3::from(t.e1), Vec3::from(t.e2));
        Some(LightSample {
            position: p0 + b.x * e1 + b.y * e2,
            pdf_area: t.prob / t.area,
            normal: e1.cross(e2).normalize(),
            light: i,
            emission: Vec3::from(t.emission),
            triangle: t.triangle,
        })
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
        .buffer("lights_info", "LightsInfo", Access::Uniform)
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
    pub info: wgpu::Buffer,
    pub count: u32,
}

impl GpuLights {
    /// Uploads `lights`; errors before allocating if they exceed the device's storage binding
    /// size.
    pub fn new(device: &wgpu::Device, lights: &Lights) -> Result<Self, LightsError> {
        check_fits(
            lights.len(),
            device.limits().max_storage_buffer_binding_size,
        )?;
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
        use crate::gpu::buffers;
        Ok(Self {
            triangles: buffers::storage_from(device, "lights_triangles", t),
            alias: buffers::storage_from(device, "lights_alias", a),
            info: buffers::with_usage(
                device,
                "lights_info",
                &[lights.info()],
                wgpu::BufferUsages::UNIFORM,
            ),
            count: lights.len() as u32,
        })
    }

    /// The buffers of [`bindings`], by name.
    pub fn resources(&self) -> [(&'static str, Resource<'_>); 3] {
        [
            ("lights_triangles", (&self.triangles).into()),
            ("lights_alias", (&self.alias).into()),
            ("lights_info", (&self.info).into()),
        ]
    }
}

/// The lights' WGSL modules with their bindings at `group`: `sampling`, `lights-bindings` and
/// `lights` (the light sampling functions).
pub fn modules(group: u32) -> Vec<WgslModule> {
    vec![
        WgslModule::new("sampling", &[], sampling::WGSL),
        WgslModule::new("lights-bindings", &[], bindings().wgsl(group)),
        WgslModule::new("lights", &["sampling", "lights-bindings"], WGSL),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Material, Triangle};
    use reservoir::rng::Rng;

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
            let smp = l.sample(u).unwrap();
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
        assert!(l.is_empty() && l.sample([0.5; 4]).is_none());
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
