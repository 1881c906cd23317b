//! The glTF 2.0 metal-roughness BRDF (Appendix B) with energy compensation, on the GPU
//! ([`WGSL`]) and as its f64 twin ([`Brdf`]), and the compensation tables both read
//! ([`BrdfTables`]).
//!
//! # The model
//!
//! A [`BrdfSurface`] is a base colour, a metallic and a perceptual roughness, or the plain
//! Lambertian surface the renderer had before (`diffuse`: f = base / pi, exactly the product
//! `base * SAMPLING_INV_PI`, sampled by the cosine lobe). Otherwise, in the local frame of the
//! unit shading normal n (f = 0 where n.wo <= 0 or n.wi <= 0):
//!
//! - D: Trowbridge-Reitz (GGX) with alpha = r^2; V = G2 / (4 |n.wi| |n.wo|) with the
//!   height-correlated Smith G2, as glTF writes it; F: Schlick with F90 = 1 at |wo.h|.
//! - metal = F(base) D V + f_ms(base); dielectric = F(0.04) D V + f_ms(0.04) + diffuse;
//!   f = mix(dielectric, metal, metallic).
//! - f_ms(F0) is the multiple-scattering lobe of Kulla & Conty 2017, (1 - E(mu_o)) (1 -
//!   E(mu_i)) / (pi (1 - E_avg)) F_ms(F0), F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)),
//!   F_avg = F0 + (1 - F0) / 21, with E(mu) the directional albedo of D V cos (F = 1) and
//!   E_avg = 2 int E mu dmu: a white metal reflects E + (1 - E) = 1 at every angle.
//! - The diffuse part is base / pi (1 - E_s(mu_o)) (1 - E_s(mu_i)) / (1 - E_s,avg), E_s the
//!   directional albedo of the dielectric's specular part (with its f_ms): a white dielectric
//!   reflects E_s + (1 - E_s) = 1. This replaces glTF's weight 1 - F(0.04, |v.h|) per
//!   microfacet, which the specification itself says does not conserve energy (it points to
//!   Kulla-Conty). That weight depends on the half vector only, so it dims the diffuse part
//!   near the mirror direction at grazing angles and nowhere else, and Appendix B's white
//!   dielectric gains or loses light (at roughness 1: 1-3% lost, 1% gained at 89 degrees, as
//!   the furnace test prints); the new weight dims it towards grazing view and grazing light
//!   alike (reciprocal), by exactly what the specular part reflects at that view.
//!
//! Roughness is clamped to [[`MIN_ROUGHNESS`], 1]: there is no delta lobe to special-case,
//! and D = 1 / (pi alpha^2) at its peak stays finite in f32 (alpha^2 >= 1.6e-7, its square in
//! D's denominator 2.6e-14, far from f32's underflow). A NaN metallic counts as 0 and a NaN
//! roughness as 1: `min(max(m, 0), 1)` and `max(min(r, 1), MIN_ROUGHNESS)`, whose `f64::min`
//! and `max` return the number where one operand is NaN (WGSL leaves min and max of NaN to the
//! implementation, so the GPU follows only where its min and max do the same); a NaN base
//! channel counts as 1.
//!
//! # Sampling
//!
//! The specular lobe by its distribution of visible normals, drawn as a spherical cap
//! (Dupuy & Benyoub 2023), density G1(wo) D(h) / (4 n.wo); the diffuse and the
//! multiple-scattering lobes by the cosine lobe (`sampling::cosine_local`). The lobe is
//! chosen with probability proportional to the luminance of each side's directional albedo
//! from the tables at mu_o ([`Brdf::specular_probability`]), clamped into [0.05, 0.95] unless
//! a side reflects nothing; the pdf is the mixture. Random numbers: u.x chooses the lobe, u.yz
//! the direction.
//!
//! # The tables
//!
//! E (as the loss 1 - E) and E_s (as 1 - E_s) at 32 x 32 nodes and their averages, computed
//! at start by a fixed quadrature ([`BrdfTables::compute`]); see there for the axes.

use glam::{DVec2, DVec3, Vec2};

use crate::sampling;

#[cfg(test)]
mod tests;

/// WGSL source: structs `BrdfSurface`, `BrdfSample`, functions `brdf_eval`, `brdf_pdf`,
/// `brdf_sample`, `brdf_specular_probability`, `brdf_albedo`. Needs `sampling::WGSL`,
/// [`constants_wgsl`] and the including module's hook `fn brdf_table(index: u32) -> f32`
/// (element `index` of [`BrdfTables::as_f32`]).
pub const WGSL: &str = include_str!("brdf.wgsl");

/// The smallest perceptual roughness (alpha = 4e-4): no delta lobe, a finite D in f32.
pub const MIN_ROUGHNESS: f32 = 0.02;

/// Nodes of each table axis (mu = n.wo and roughness). 64, not 32: between rows uniform in
/// ln alpha, linear interpolation of E was off by up to 0.3% at 32 (a white metal's furnace
/// at roughness 0.5 then gained 0.3% a bounce), 0.15% at 64.
pub const TABLE_SIZE: usize = 64;
/// Offset of the loss 1 - E(mu, r) (TABLE_SIZE rows of roughness, TABLE_SIZE columns of mu).
pub const TABLE_LOSS: usize = 0;
/// Offset of the dielectric specular loss 1 - E_s(mu, r), laid out as [`TABLE_LOSS`].
pub const TABLE_SPEC_LOSS: usize = TABLE_SIZE * TABLE_SIZE;
/// Offset of 1 - E_avg per roughness row.
pub const TABLE_LOSS_AVG: usize = 2 * TABLE_SIZE * TABLE_SIZE;
/// Offset of 1 - E_s,avg per roughness row.
pub const TABLE_SPEC_LOSS_AVG: usize = TABLE_LOSS_AVG + TABLE_SIZE;
/// Offset of each row's 1 / eps (its mu axis: see [`BrdfTables::compute`]).
pub const TABLE_ROW_INV_EPS: usize = TABLE_SPEC_LOSS_AVG + TABLE_SIZE;
/// Offset of each row's 1 / ln(1 + 1 / eps).
pub const TABLE_ROW_INV_LOG: usize = TABLE_ROW_INV_EPS + TABLE_SIZE;
/// Length of [`BrdfTables::as_f32`].
pub const TABLE_LEN: usize = TABLE_ROW_INV_LOG + TABLE_SIZE;

/// Share of the mu axis that is linear in mu (the rest is logarithmic near 0).
const MU_WARP_LINEAR: f64 = 0.3;
/// A row's logarithmic mu axis bends at eps = this x its alpha.
const MU_WARP_SCALE: f64 = 0.5;
/// F0 of the dielectric (index of refraction 1.5).
const DIELECTRIC_F0: f64 = 0.04;
/// The least probability of either lobe when both reflect something.
const LOBE_MIN: f64 = 0.05;
/// Gauss-Legendre nodes along the spherical cap's height in the tables' quadrature.
const QUAD_HEIGHT: usize = 96;
/// Midpoint nodes in azimuth over the half cap (the integrand is even in azimuth).
const QUAD_AZIMUTH: usize = 24;

/// The WGSL constants [`WGSL`] reads: the table's size and offsets and [`MIN_ROUGHNESS`].
pub fn constants_wgsl() -> String {
    let u = |name: &str, v: usize| format!("const BRDF_{name}: u32 = {v}u;\n");
    let f = |name: &str, v: f64| format!("const BRDF_{name}: f32 = {:?};\n", v as f32);
    [
        f("MIN_ROUGHNESS", f64::from(MIN_ROUGHNESS)),
        u("TABLE_SIZE", TABLE_SIZE),
        u("TABLE_LOSS", TABLE_LOSS),
        u("TABLE_SPEC_LOSS", TABLE_SPEC_LOSS),
        u("TABLE_LOSS_AVG", TABLE_LOSS_AVG),
        u("TABLE_SPEC_LOSS_AVG", TABLE_SPEC_LOSS_AVG),
        u("TABLE_ROW_INV_EPS", TABLE_ROW_INV_EPS),
        u("TABLE_ROW_INV_LOG", TABLE_ROW_INV_LOG),
        u("TABLE_LEN", TABLE_LEN),
        f("MU_WARP_LINEAR", MU_WARP_LINEAR),
        f("DIELECTRIC_F0", DIELECTRIC_F0),
        f("LOBE_MIN", LOBE_MIN),
    ]
    .concat()
}

/// The library composed with a `brdf_table` hook over `brdf_table_data: array<f32>` at
/// `@group(0) @binding(0)`: a whole module for naga to validate, and the shape of a user.
pub fn wgsl_with_table_buffer() -> String {
    format!(
        "{}\n{}\n@group(0) @binding(0) var<storage, read> brdf_table_data: array<f32>;\n\
         fn brdf_table(index: u32) -> f32 {{ return brdf_table_data[index]; }}\n{WGSL}",
        sampling::WGSL,
        constants_wgsl()
    )
}

/// The tables, computed once per process (by the first glossy scene's renderer, the CPU
/// reference or a test) and shared by all.
pub fn tables() -> &'static BrdfTables {
    static TABLES: std::sync::OnceLock<BrdfTables> = std::sync::OnceLock::new();
    TABLES.get_or_init(BrdfTables::compute)
}

/// A surface's BRDF inputs (WGSL `BrdfSurface`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrdfSurface {
    /// Base colour, linear, 0..1.
    pub base: DVec3,
    /// 0 (dielectric) ..1 (metal).
    pub metallic: f64,
    /// Perceptual roughness 0..1 (alpha = roughness^2), clamped to [`MIN_ROUGHNESS`]..1.
    pub roughness: f64,
    /// The plain Lambertian surface: f = base / pi; metallic and roughness unused.
    pub diffuse: bool,
}

/// One drawn direction (WGSL `BrdfSample`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrdfSample {
    /// The direction towards the light (unit; may lie below the surface, then pdf = 0).
    pub wi: DVec3,
    /// The BRDF at wi (without the cosine).
    pub f: DVec3,
    /// The density of wi (solid angle), [`Brdf::pdf`].
    pub pdf: f64,
    /// f cos / pdf, or 0 where pdf = 0 or wi is below the surface.
    pub weight: DVec3,
}

/// The inputs clamped and derived once (WGSL `BrdfParams`).
#[derive(Debug, Clone, Copy)]
struct Params {
    base: DVec3,
    metallic: f64,
    roughness: f64,
    alpha: f64,
}

/// The clamped inputs of `s` (NaN metallic -> 0, NaN roughness -> 1, NaN base -> 1).
// min/max, not clamp: clamp keeps a NaN, min/max give the bound (brdf_params writes the same).
#[allow(clippy::manual_clamp)]
fn params(s: &BrdfSurface) -> Params {
    let roughness = s.roughness.min(1.0).max(f64::from(MIN_ROUGHNESS));
    Params {
        base: s.base.min(DVec3::ONE).max(DVec3::ZERO),
        metallic: s.metallic.max(0.0).min(1.0),
        roughness,
        alpha: roughness * roughness,
    }
}

/// The 1 / pi the renderer's Lambertian surface uses (WGSL `SAMPLING_INV_PI`, an f32).
const INV_PI: f64 = std::f32::consts::FRAC_1_PI as f64;
const PI: f64 = std::f64::consts::PI;

/// x > 0, false for NaN: a cosine above the surface, a weight that counts.
fn above(x: f64) -> bool {
    x > 0.0
}

/// Rec. 709 luminance.
fn luminance(c: DVec3) -> f64 {
    c.dot(DVec3::new(0.2126, 0.7152, 0.0722))
}

/// sqrt(cos^2 (1 - a^2) + a^2) = cos (1 + 2 Lambda): the Smith term of one direction.
fn smith_term(cos: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    (cos * cos * (1.0 - a2) + a2).sqrt()
}

/// glTF's V = G2 / (4 cos_i cos_o), height-correlated Smith.
fn visibility(alpha: f64, cos_o: f64, cos_i: f64) -> f64 {
    0.5 / (cos_i * smith_term(cos_o, alpha) + cos_o * smith_term(cos_i, alpha))
}

/// GGX D at the half vector of the unnormalised sum `hs` = wo + wi: 1 - (n.h)^2 comes from
/// |n x hs|^2, not from 1 - (n.h)^2, so that a lobe as narrow as alpha = 4e-4 keeps its
/// precision in f32.
fn ggx_d(alpha: f64, n: DVec3, hs: DVec3) -> f64 {
    let a2 = alpha * alpha;
    let c = n.dot(hs);
    let sv = n.cross(hs);
    let d = (a2 * (c * c) + sv.dot(sv)) / hs.dot(hs);
    a2 * INV_PI / (d * d)
}

/// Schlick's weight (1 - vh)^5, vh clamped into [0, 1].
fn schlick_weight(vh: f64) -> f64 {
    let x = (1.0 - vh).clamp(0.0, 1.0);
    let x2 = x * x;
    x2 * x2 * x
}

/// Kulla-Conty's F_ms per channel from F0 and the loss 1 - E_avg.
fn ms_fresnel(f0: DVec3, loss_avg: f64) -> DVec3 {
    let f_avg = f0 + (DVec3::ONE - f0) / 21.0;
    f_avg * f_avg * (1.0 - loss_avg) / (DVec3::ONE - f_avg * loss_avg)
}

/// (1 - E_o) (1 - E_i) / (1 - E_avg) from the losses (pi times the shape of the
/// multiple-scattering and the diffuse lobes); 0 where the average loss is 0.
fn loss_product(loss_o: f64, loss_i: f64, loss_avg: f64) -> f64 {
    if loss_avg > 0.0 {
        loss_o * loss_i / loss_avg
    } else {
        0.0
    }
}

/// The visible-normal density of wi (solid angle): G1(wo) D(h) / (4 cos_o) = D / (2 (cos_o +
/// cos_o (1 + 2 Lambda(wo)))).
fn vndf_pdf(alpha: f64, cos_o: f64, d: f64) -> f64 {
    d / (2.0 * (cos_o + smith_term(cos_o, alpha)))
}

/// A visible normal (local frame, z up) of the GGX surface seen from `wo` (local, z > 0),
/// from the point (cos phi, sin phi) of azimuth and `u` in [0, 1) along the spherical cap
/// (Dupuy & Benyoub 2023): in the configuration stretched to alpha = 1 the visible normals
/// are the half vectors between wo and a direction uniform on the cap z >= -wo.z of the unit
/// sphere; un-stretching gives GGX's. Returns +z where the normal degenerates.
fn vndf_normal(wo: DVec3, alpha: f64, azimuth: DVec2, u: f64) -> DVec3 {
    let v = DVec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let z = (1.0 - u) * (1.0 + v.z) - v.z;
    let sin_t = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
    let m = DVec3::new(sin_t * azimuth.x, sin_t * azimuth.y, z) + v;
    let h = DVec3::new(alpha * m.x, alpha * m.y, m.z.max(0.0));
    let l2 = h.dot(h);
    if l2 > 0.0 { h / l2.sqrt() } else { DVec3::Z }
}

/// The bilinear position of (mu, roughness) in the tables (WGSL `BrdfTableCoord`): two rows
/// and the column of mu in each row's own axis.
#[derive(Debug, Clone, Copy)]
struct TableCoord {
    row: usize,
    t: f64,
    col: [usize; 2],
    s: [f64; 2],
}

/// Precomputed directional albedos: see [`BrdfTables::compute`].
#[derive(Debug, Clone, PartialEq)]
pub struct BrdfTables {
    data: Vec<f32>,
}

impl BrdfTables {
    /// Computes the tables (deterministic; about 8.8 M evaluations of the integrand).
    ///
    /// Axes: row k (of [`TABLE_SIZE`]) holds alpha_k = MIN_ROUGHNESS^(2 (1 - k / 63)),
    /// uniform in ln alpha, since E near grazing depends on mu / alpha (a dip of 11% at mu ~
    /// alpha, with E = 1 at mu = 0 for the height-correlated G2); column j sits where the
    /// row's axis x(mu) = 0.3 mu + 0.7 ln(1 + mu / eps_k) / ln(1 + 1 / eps_k), eps_k = alpha_k
    /// / 2, equals j / 63: the nodes are the axes' endpoints and every node between. A lookup
    /// is linear in x within each of the two nearest rows, then linear in ln alpha between
    /// them, clamped at the ends. The averages are the exact mu-integrals of each row's
    /// interpolant, so that the multiple-scattering lobe's albedo is exactly 1 - E as
    /// interpolated. The losses 1 - E are stored, not E, to keep their precision in f32 when
    /// E is close to 1.
    ///
    /// Quadrature: per node, the visible-normal sampling map with 96 Gauss-Legendre nodes
    /// along the cap and 24 midpoint azimuths over the half cap; E(mu) = the mean of
    /// G2 / G1(wo) where wi is above the surface (the weight of visible-normal sampling).
    pub fn compute() -> Self {
        let mut data = vec![0.0f32; TABLE_LEN];
        for k in 0..TABLE_SIZE {
            let eps = MU_WARP_SCALE * row_alpha(k);
            data[TABLE_ROW_INV_EPS + k] = (1.0 / eps) as f32;
            data[TABLE_ROW_INV_LOG + k] = (1.0 / (1.0 + 1.0 / eps).ln()) as f32;
        }
        let mut tables = Self { data };
        let quad = CapQuadrature::new(QUAD_HEIGHT, QUAD_AZIMUTH);
        let mut single = vec![0.0; TABLE_SIZE * TABLE_SIZE];
        for k in 0..TABLE_SIZE {
            for j in 0..TABLE_SIZE {
                let (e, e04) = quad.albedos(tables.node_mu(k, j), row_alpha(k));
                tables.data[TABLE_LOSS + k * TABLE_SIZE + j] = (1.0 - e).max(0.0) as f32;
                single[k * TABLE_SIZE + j] = e04;
            }
        }
        for k in 0..TABLE_SIZE {
            tables.data[TABLE_LOSS_AVG + k] = tables.row_average(TABLE_LOSS, k) as f32;
        }
        for k in 0..TABLE_SIZE {
            let loss_avg = f64::from(tables.data[TABLE_LOSS_AVG + k]);
            let f_ms = ms_fresnel(DVec3::splat(DIELECTRIC_F0), loss_avg).x;
            for j in 0..TABLE_SIZE {
                let i = k * TABLE_SIZE + j;
                let loss = f64::from(tables.data[TABLE_LOSS + i]);
                let e_spec = single[i] + loss * f_ms;
                tables.data[TABLE_SPEC_LOSS + i] = (1.0 - e_spec).max(0.0) as f32;
            }
        }
        for k in 0..TABLE_SIZE {
            tables.data[TABLE_SPEC_LOSS_AVG + k] = tables.row_average(TABLE_SPEC_LOSS, k) as f32;
        }
        tables
    }

    /// The tables as the GPU reads them (`brdf_table(i)` = element i), [`TABLE_LEN`] long.
    pub fn as_f32(&self) -> &[f32] {
        &self.data
    }

    /// 1 - E(mu, roughness): the energy the single-scattering lobe with F = 1 loses.
    pub fn loss(&self, mu: f64, roughness: f64) -> f64 {
        let c = self.coord(mu, clamp_roughness(roughness));
        self.lookup(&c, TABLE_LOSS)
    }

    /// 1 - E_s(mu, roughness): the energy the dielectric's specular part does not reflect.
    pub fn spec_loss(&self, mu: f64, roughness: f64) -> f64 {
        let c = self.coord(mu, clamp_roughness(roughness));
        self.lookup(&c, TABLE_SPEC_LOSS)
    }

    /// 1 - E_avg(roughness).
    pub fn loss_avg(&self, roughness: f64) -> f64 {
        let c = self.coord(0.0, clamp_roughness(roughness));
        self.average(&c, TABLE_LOSS_AVG)
    }

    /// 1 - E_s,avg(roughness).
    pub fn spec_loss_avg(&self, roughness: f64) -> f64 {
        let c = self.coord(0.0, clamp_roughness(roughness));
        self.average(&c, TABLE_SPEC_LOSS_AVG)
    }

    fn at(&self, i: usize) -> f64 {
        f64::from(self.data[i])
    }

    /// Row k's axis coordinate of mu, in nodes: x(mu) (TABLE_SIZE - 1).
    fn row_x(&self, k: usize, mu: f64) -> f64 {
        let inv_eps = self.at(TABLE_ROW_INV_EPS + k);
        let inv_log = self.at(TABLE_ROW_INV_LOG + k);
        let x =
            MU_WARP_LINEAR * mu + (1.0 - MU_WARP_LINEAR) * ((1.0 + mu * inv_eps).ln() * inv_log);
        x * (TABLE_SIZE - 1) as f64
    }

    /// The mu of node (k, j): x(mu) = j by bisection (x is increasing), the ends exact.
    fn node_mu(&self, k: usize, j: usize) -> f64 {
        if j == 0 || j == TABLE_SIZE - 1 {
            return if j == 0 { 0.0 } else { 1.0 };
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..64 {
            let mid = 0.5 * (lo + hi);
            if self.row_x(k, mid) < j as f64 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// Twin of `brdf_table_coord`: mu clamped into [0, 1] (NaN -> 0, hence min/max), roughness
    /// already clamped.
    #[allow(clippy::manual_clamp)]
    fn coord(&self, mu: f64, roughness: f64) -> TableCoord {
        let last = (TABLE_SIZE - 1) as f64;
        let mu = mu.max(0.0).min(1.0);
        let min_r = f64::from(MIN_ROUGHNESS);
        let y = ((roughness / min_r).ln() / (1.0 / min_r).ln() * last).clamp(0.0, last);
        let row = (y.floor() as usize).min(TABLE_SIZE - 2);
        let col_of = |k: usize| {
            let x = self.row_x(k, mu).clamp(0.0, last);
            let j = (x.floor() as usize).min(TABLE_SIZE - 2);
            (j, x - j as f64)
        };
        let (c0, s0) = col_of(row);
        let (c1, s1) = col_of(row + 1);
        TableCoord {
            row,
            t: y - row as f64,
            col: [c0, c1],
            s: [s0, s1],
        }
    }

    /// Twin of `brdf_table_lookup`: the 2-D table at `offset` at `c`.
    fn lookup(&self, c: &TableCoord, offset: usize) -> f64 {
        let in_row = |r: usize| {
            let i = offset + (c.row + r) * TABLE_SIZE + c.col[r];
            self.at(i) * (1.0 - c.s[r]) + self.at(i + 1) * c.s[r]
        };
        in_row(0) * (1.0 - c.t) + in_row(1) * c.t
    }

    /// Twin of `brdf_table_average`: the per-row table at `offset` at `c`'s roughness.
    fn average(&self, c: &TableCoord, offset: usize) -> f64 {
        self.at(offset + c.row) * (1.0 - c.t) + self.at(offset + c.row + 1) * c.t
    }

    /// 2 int_0^1 L(mu) mu dmu of row k's interpolant of the table at `offset`: 8-point
    /// Gauss-Legendre on each interval between the row's nodes (the interpolant is smooth
    /// there, linear in the row's x).
    fn row_average(&self, offset: usize, k: usize) -> f64 {
        let gl = gauss_legendre(8);
        let mut sum = 0.0;
        for j in 0..TABLE_SIZE - 1 {
            let (a, b) = (self.node_mu(k, j), self.node_mu(k, j + 1));
            for &(x, w) in &gl {
                let mu = a + (b - a) * x;
                let xk = self.row_x(k, mu).clamp(0.0, (TABLE_SIZE - 1) as f64);
                let col = (xk.floor() as usize).min(TABLE_SIZE - 2);
                let s = xk - col as f64;
                let i = offset + k * TABLE_SIZE + col;
                let v = self.at(i) * (1.0 - s) + self.at(i + 1) * s;
                sum += w * (b - a) * v * mu;
            }
        }
        2.0 * sum
    }
}

/// Row k's alpha (uniform in ln alpha from MIN_ROUGHNESS^2 to 1).
fn row_alpha(k: usize) -> f64 {
    let t = k as f64 / (TABLE_SIZE - 1) as f64;
    f64::from(MIN_ROUGHNESS).powf(2.0 * (1.0 - t))
}

fn clamp_roughness(r: f64) -> f64 {
    r.min(1.0).max(f64::from(MIN_ROUGHNESS))
}

/// Gauss-Legendre nodes and weights on [0, 1] (Newton's method on P_n; weights sum to 1).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p1, mut p2) = (1.0, 0.0);
                for j in 0..n {
                    let p3 = p2;
                    p2 = p1;
                    p1 = ((2 * j + 1) as f64 * z * p2 - j as f64 * p3) / (j + 1) as f64;
                }
                dp = n as f64 * (z * p1 - p2) / (z * z - 1.0);
                let step = p1 / dp;
                z -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            (0.5 * (1.0 - z), 1.0 / ((1.0 - z * z) * dp * dp))
        })
        .collect()
}

/// The tables' fixed quadrature over the visible-normal sampling map (Gauss-Legendre along
/// the cap, midpoint azimuths over the half cap).
struct CapQuadrature {
    height: Vec<(f64, f64)>,
    azimuth: Vec<DVec2>,
}

impl CapQuadrature {
    fn new(height: usize, azimuth: usize) -> Self {
        let azimuth = (0..azimuth)
            .map(|i| {
                let phi = PI * (i as f64 + 0.5) / azimuth as f64;
                DVec2::new(phi.cos(), phi.sin())
            })
            .collect();
        Self {
            height: gauss_legendre(height),
            azimuth,
        }
    }

    /// (E, the single-scattering albedo with Schlick F at F0 = 0.04) at (mu, alpha).
    fn albedos(&self, mu: f64, alpha: f64) -> (f64, f64) {
        let wo = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
        let so = smith_term(mu, alpha);
        let (mut e, mut e04) = (0.0, 0.0);
        for &azimuth in &self.azimuth {
            for &(u, w) in &self.height {
                let h = vndf_normal(wo, alpha, azimuth, u);
                let vh = wo.dot(h);
                let cos_i = 2.0 * vh * h.z - wo.z;
                if cos_i > 0.0 {
                    // G2 / G1(wo) = f cos_i / pdf_vndf.
                    let g = 2.0 * visibility(alpha, mu, cos_i) * cos_i * (mu + so);
                    e += w * g;
                    e04 += w * g * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * schlick_weight(vh));
                }
            }
        }
        let n = self.azimuth.len() as f64;
        (e / n, e04 / n)
    }
}

/// The directional albedos of the two sampled sides at wo (WGSL `BrdfLobeAlbedos`).
#[derive(Debug, Clone, Copy)]
struct LobeAlbedos {
    /// The single-scattering specular lobes (sampled by visible normals).
    specular: DVec3,
    /// The diffuse and multiple-scattering lobes (sampled by the cosine lobe).
    rest: DVec3,
}

/// The f64 twin of brdf.wgsl: the same formulas in the same order.
#[derive(Debug, Clone, Copy)]
pub struct Brdf<'a> {
    /// The compensation tables (shared with the GPU).
    pub tables: &'a BrdfTables,
    /// Energy compensation (the GPU's is always on); off: Appendix B's single-scattering
    /// model, the dielectric's diffuse part weighted by 1 - F(0.04, v.h). Sampling is the same.
    pub compensation: bool,
}

impl<'a> Brdf<'a> {
    /// The BRDF as the GPU evaluates it (compensation on).
    pub fn new(tables: &'a BrdfTables) -> Self {
        Self {
            tables,
            compensation: true,
        }
    }

    /// f(wo, wi) without the cosine (twin of `brdf_eval`); n the unit shading normal, wo and
    /// wi unit, away from the surface.
    pub fn eval(&self, s: &BrdfSurface, n: DVec3, wo: DVec3, wi: DVec3) -> DVec3 {
        let cos_o = n.dot(wo);
        let cos_i = n.dot(wi);
        if !(above(cos_o) && above(cos_i)) {
            return DVec3::ZERO;
        }
        if s.diffuse {
            return s.base * INV_PI;
        }
        self.eval_glossy(&params(s), n, wo, wi, cos_o, cos_i)
    }

    /// Twin of `brdf_eval_glossy`.
    fn eval_glossy(
        &self,
        p: &Params,
        n: DVec3,
        wo: DVec3,
        wi: DVec3,
        cos_o: f64,
        cos_i: f64,
    ) -> DVec3 {
        let hs = wo + wi;
        let vh = 0.5 * hs.length();
        let dv = ggx_d(p.alpha, n, hs) * visibility(p.alpha, cos_o, cos_i);
        let w = schlick_weight(vh);
        let f04 = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w;
        let f_metal = p.base + (DVec3::ONE - p.base) * w;
        if !self.compensation {
            let dielectric = p.base * (INV_PI * (1.0 - f04)) + DVec3::splat(f04 * dv);
            return dielectric * (1.0 - p.metallic) + f_metal * dv * p.metallic;
        }
        let t = self.tables;
        let co = t.coord(cos_o, p.roughness);
        let ci = t.coord(cos_i, p.roughness);
        let loss_avg = t.average(&co, TABLE_LOSS_AVG);
        let ms = INV_PI
            * loss_product(
                t.lookup(&co, TABLE_LOSS),
                t.lookup(&ci, TABLE_LOSS),
                loss_avg,
            );
        let metal = f_metal * dv + ms_fresnel(p.base, loss_avg) * ms;
        let spec = f04 * dv + ms_fresnel(DVec3::splat(DIELECTRIC_F0), loss_avg).x * ms;
        let spec_avg = t.average(&co, TABLE_SPEC_LOSS_AVG);
        let diffuse = INV_PI
            * loss_product(
                t.lookup(&co, TABLE_SPEC_LOSS),
                t.lookup(&ci, TABLE_SPEC_LOSS),
                spec_avg,
            );
        let dielectric = p.base * diffuse + DVec3::splat(spec);
        dielectric * (1.0 - p.metallic) + metal * p.metallic
    }

    /// Twin of `brdf_lobe_albedos`: each sampled side's directional albedo at cos_o, from the
    /// tables. The single-scattering albedo with Schlick F at any F0 is F0 E + (1 - F0) S,
    /// S the albedo of (1 - v.h)^5 D V cos, found from the dielectric's.
    fn lobe_albedos(&self, p: &Params, cos_o: f64) -> LobeAlbedos {
        let t = self.tables;
        let c = t.coord(cos_o, p.roughness);
        let loss = t.lookup(&c, TABLE_LOSS);
        let spec_loss = t.lookup(&c, TABLE_SPEC_LOSS);
        let loss_avg = t.average(&c, TABLE_LOSS_AVG);
        let ms04 = loss * ms_fresnel(DVec3::splat(DIELECTRIC_F0), loss_avg).x;
        let single04 = (1.0 - spec_loss - ms04).max(0.0);
        let schlick = ((single04 - DIELECTRIC_F0 * (1.0 - loss)) / (1.0 - DIELECTRIC_F0)).max(0.0);
        let metal_single = p.base * (1.0 - loss) + (DVec3::ONE - p.base) * schlick;
        let metal_ms = ms_fresnel(p.base, loss_avg) * loss;
        let m = p.metallic;
        LobeAlbedos {
            specular: metal_single * m + DVec3::splat(single04 * (1.0 - m)),
            rest: (p.base * spec_loss + DVec3::splat(ms04)) * (1.0 - m) + metal_ms * m,
        }
    }

    /// The directional albedo at wo, from the tables (twin of `brdf_albedo`): the compensated
    /// model's, whatever `compensation` says; base for a diffuse surface; 0 where wo is below
    /// the surface.
    pub fn albedo(&self, s: &BrdfSurface, n: DVec3, wo: DVec3) -> DVec3 {
        let cos_o = n.dot(wo);
        if !above(cos_o) {
            return DVec3::ZERO;
        }
        if s.diffuse {
            return s.base;
        }
        let a = self.lobe_albedos(&params(s), cos_o);
        a.specular + a.rest
    }

    /// The probability of drawing the specular lobe at wo (twin of
    /// `brdf_specular_probability`): the luminance share of its albedo, in [0.05, 0.95]
    /// unless a side reflects nothing (a diffuse surface: 0; a metal whose lobe loses no
    /// energy at wo, 1 - E = 0: 1; a white metal draws its multiple-scattering lobe with
    /// probability 1 - E(mu_o), at least 0.05).
    pub fn specular_probability(&self, s: &BrdfSurface, n: DVec3, wo: DVec3) -> f64 {
        if s.diffuse {
            return 0.0;
        }
        let a = self.lobe_albedos(&params(s), n.dot(wo));
        let ws = luminance(a.specular);
        let wr = luminance(a.rest);
        match (above(ws), above(wr)) {
            (_, false) => 1.0,
            (false, true) => 0.0,
            (true, true) => (ws / (ws + wr)).clamp(LOBE_MIN, 1.0 - LOBE_MIN),
        }
    }

    /// The density (solid angle) with which [`Brdf::sample`] draws wi (twin of `brdf_pdf`):
    /// 0 where wo or wi is below the surface.
    pub fn pdf(&self, s: &BrdfSurface, n: DVec3, wo: DVec3, wi: DVec3) -> f64 {
        let cos_o = n.dot(wo);
        let cos_i = n.dot(wi);
        if !(above(cos_o) && above(cos_i)) {
            return 0.0;
        }
        if s.diffuse {
            return cos_i * INV_PI;
        }
        let p = params(s);
        let p_spec = self.specular_probability(s, n, wo);
        let spec = vndf_pdf(p.alpha, cos_o, ggx_d(p.alpha, n, wo + wi));
        p_spec * spec + (1.0 - p_spec) * (cos_i * INV_PI)
    }

    /// A direction drawn from u in [0, 1)^3 (twin of `brdf_sample`): u.x chooses the lobe,
    /// u.yz the direction. Where wo is below the surface: wi = n, f = 0, pdf = 0.
    pub fn sample(&self, s: &BrdfSurface, n: DVec3, wo: DVec3, u: DVec3) -> BrdfSample {
        let cos_o = n.dot(wo);
        if !above(cos_o) {
            return BrdfSample {
                wi: n,
                f: DVec3::ZERO,
                pdf: 0.0,
                weight: DVec3::ZERO,
            };
        }
        let (t, b) = sampling::onb(n.as_vec3());
        let (t, b) = (t.as_dvec3(), b.as_dvec3());
        let local = if u.x < self.specular_probability(s, n, wo) {
            let wo_l = DVec3::new(t.dot(wo), b.dot(wo), cos_o);
            let phi = 2.0 * PI * u.y;
            let h = vndf_normal(wo_l, params(s).alpha, DVec2::new(phi.cos(), phi.sin()), u.z);
            h * (2.0 * wo_l.dot(h)) - wo_l
        } else {
            sampling::cosine_local(Vec2::new(u.y as f32, u.z as f32)).as_dvec3()
        };
        let wi = t * local.x + b * local.y + n * local.z;
        let f = self.eval(s, n, wo, wi);
        let pdf = self.pdf(s, n, wo, wi);
        let cos_i = n.dot(wi);
        let weight = if pdf > 0.0 && cos_i > 0.0 {
            f * (cos_i / pdf)
        } else {
            DVec3::ZERO
        };
        BrdfSample { wi, f, pdf, weight }
    }
}
