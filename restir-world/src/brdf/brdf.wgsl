// The glTF 2.0 metal-roughness BRDF (Appendix B) with Kulla-Conty energy compensation: eval,
// pdf, sampling and the directional albedo. Functions and structs only, no bindings.
// Twin: restir_world::brdf::Brdf (f64, the same formulas in the same order; the model, the
// clamps and the tables' axes are documented there).
//
// Needs sampling.wgsl, the constants of restir_world::brdf::constants_wgsl() (BRDF_*), and a
// hook the including module defines:
//     fn brdf_table(index: u32) -> f32
// element `index` of restir_world::brdf::BrdfTables::as_f32() (BRDF_TABLE_LEN floats, e.g. a
// read-only storage buffer: restir_world::brdf::wgsl_with_table_buffer() shows one).
//
// Conventions: n is the unit shading normal, wo (towards the viewer) and wi (towards the
// light) are unit; f is 0 where n.wo <= 0 or n.wi <= 0. Random numbers u in [0,1)^3: u.x
// chooses the lobe, u.yz the direction.

// A surface's BRDF inputs. diffuse: the plain Lambertian surface, f = base / pi (metallic and
// roughness unused). Otherwise base colour (linear, 0..1), metallic 0..1 and perceptual
// roughness (alpha = roughness^2), clamped to [BRDF_MIN_ROUGHNESS, 1].
struct BrdfSurface {
    base: vec3<f32>,
    metallic: f32,
    roughness: f32,
    diffuse: bool,
}

// A drawn direction wi (may lie below the surface: then f = 0, pdf = 0), the BRDF there, its
// density (solid angle) and weight = f cos / pdf (0 where pdf = 0).
struct BrdfSample {
    wi: vec3<f32>,
    pdf: f32,
    f: vec3<f32>,
    weight: vec3<f32>,
}

// The clamped inputs: NaN metallic -> 0, NaN roughness -> 1, NaN base -> 1 where min and max
// return the number, as the twin's do (WGSL leaves min and max of NaN to the implementation).
struct BrdfParams {
    base: vec3<f32>,
    metallic: f32,
    roughness: f32,
    alpha: f32,
}

fn brdf_params(s: BrdfSurface) -> BrdfParams {
    let roughness = max(min(s.roughness, 1.0), BRDF_MIN_ROUGHNESS);
    return BrdfParams(max(min(s.base, vec3<f32>(1.0)), vec3<f32>(0.0)),
                      min(max(s.metallic, 0.0), 1.0), roughness, roughness * roughness);
}

fn brdf_luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// sqrt(cos^2 (1 - a^2) + a^2) = cos (1 + 2 Lambda): the Smith term of one direction.
fn brdf_smith_term(cos: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    return sqrt(cos * cos * (1.0 - a2) + a2);
}

// glTF's V = G2 / (4 cos_i cos_o), height-correlated Smith.
fn brdf_visibility(alpha: f32, cos_o: f32, cos_i: f32) -> f32 {
    return 0.5 / (cos_i * brdf_smith_term(cos_o, alpha) + cos_o * brdf_smith_term(cos_i, alpha));
}

// GGX D at the half vector of hs = wo + wi (unnormalised): 1 - (n.h)^2 from |n x hs|^2, which
// keeps its precision in f32 for lobes as narrow as alpha = 4e-4.
fn brdf_ggx_d(alpha: f32, n: vec3<f32>, hs: vec3<f32>) -> f32 {
    let a2 = alpha * alpha;
    let c = dot(n, hs);
    let sv = cross(n, hs);
    let d = (a2 * (c * c) + dot(sv, sv)) / dot(hs, hs);
    return a2 * SAMPLING_INV_PI / (d * d);
}

// Schlick's weight (1 - vh)^5, vh clamped into [0, 1].
fn brdf_schlick_weight(vh: f32) -> f32 {
    let x = clamp(1.0 - vh, 0.0, 1.0);
    let x2 = x * x;
    return x2 * x2 * x;
}

// Kulla-Conty's F_ms per channel from F0 and the loss 1 - E_avg.
fn brdf_ms_fresnel(f0: vec3<f32>, loss_avg: f32) -> vec3<f32> {
    let f_avg = f0 + (vec3<f32>(1.0) - f0) / 21.0;
    return f_avg * f_avg * (1.0 - loss_avg) / (vec3<f32>(1.0) - f_avg * loss_avg);
}

// (1 - E_o) (1 - E_i) / (1 - E_avg) from the losses; 0 where the average loss is 0.
fn brdf_loss_product(loss_o: f32, loss_i: f32, loss_avg: f32) -> f32 {
    if loss_avg > 0.0 {
        return loss_o * loss_i / loss_avg;
    }
    return 0.0;
}

// The visible-normal density of wi: G1(wo) D / (4 cos_o) = D / (2 (cos_o + smith term)).
fn brdf_vndf_pdf(alpha: f32, cos_o: f32, d: f32) -> f32 {
    return d / (2.0 * (cos_o + brdf_smith_term(cos_o, alpha)));
}

// A visible normal (local frame, z up) of the GGX surface seen from wo (local, z > 0), from the
// azimuth's (cos, sin) and u along the spherical cap (Dupuy & Benyoub 2023): stretched to
// alpha = 1, the visible normals are the half vectors between wo and a direction uniform on the
// cap z >= -wo.z of the unit sphere; un-stretching gives GGX's. +z where it degenerates.
fn brdf_vndf_normal(wo: vec3<f32>, alpha: f32, azimuth: vec2<f32>, u: f32) -> vec3<f32> {
    let v = normalize(vec3<f32>(alpha * wo.x, alpha * wo.y, wo.z));
    let z = (1.0 - u) * (1.0 + v.z) - v.z;
    let sin_t = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    let m = vec3<f32>(sin_t * azimuth.x, sin_t * azimuth.y, z) + v;
    let h = vec3<f32>(alpha * m.x, alpha * m.y, max(m.z, 0.0));
    let l2 = dot(h, h);
    if l2 > 0.0 {
        return h / sqrt(l2);
    }
    return vec3<f32>(0.0, 0.0, 1.0);
}

// The position of (mu, roughness) in the tables: rows `row` and `row + 1` (uniform in
// ln alpha) with weight t on the second, and mu's column in each row's own axis x(mu) with
// weights s0, s1 on the next column.
struct BrdfTableCoord {
    row: u32,
    t: f32,
    col0: u32,
    s0: f32,
    col1: u32,
    s1: f32,
}

// Row k's axis coordinate of mu, in nodes (clamped): x(mu) (BRDF_TABLE_SIZE - 1).
fn brdf_row_x(k: u32, mu: f32) -> f32 {
    let inv_eps = brdf_table(BRDF_TABLE_ROW_INV_EPS + k);
    let inv_log = brdf_table(BRDF_TABLE_ROW_INV_LOG + k);
    let x = BRDF_MU_WARP_LINEAR * mu + (1.0 - BRDF_MU_WARP_LINEAR) * (log(1.0 + mu * inv_eps) * inv_log);
    return clamp(x * f32(BRDF_TABLE_SIZE - 1u), 0.0, f32(BRDF_TABLE_SIZE - 1u));
}

// mu clamped into [0, 1]; roughness already clamped (BrdfParams).
fn brdf_table_coord(mu_in: f32, roughness: f32) -> BrdfTableCoord {
    let last = f32(BRDF_TABLE_SIZE - 1u);
    let mu = min(max(mu_in, 0.0), 1.0);
    let y = clamp(log(roughness / BRDF_MIN_ROUGHNESS) / log(1.0 / BRDF_MIN_ROUGHNESS) * last, 0.0, last);
    let row = min(u32(floor(y)), BRDF_TABLE_SIZE - 2u);
    let x0 = brdf_row_x(row, mu);
    let x1 = brdf_row_x(row + 1u, mu);
    let c0 = min(u32(floor(x0)), BRDF_TABLE_SIZE - 2u);
    let c1 = min(u32(floor(x1)), BRDF_TABLE_SIZE - 2u);
    return BrdfTableCoord(row, y - f32(row), c0, x0 - f32(c0), c1, x1 - f32(c1));
}

// The 2-D table at `offset` (BRDF_TABLE_LOSS or BRDF_TABLE_SPEC_LOSS) at c.
fn brdf_table_lookup(c: BrdfTableCoord, offset: u32) -> f32 {
    let i0 = offset + c.row * BRDF_TABLE_SIZE + c.col0;
    let i1 = offset + (c.row + 1u) * BRDF_TABLE_SIZE + c.col1;
    let v0 = brdf_table(i0) * (1.0 - c.s0) + brdf_table(i0 + 1u) * c.s0;
    let v1 = brdf_table(i1) * (1.0 - c.s1) + brdf_table(i1 + 1u) * c.s1;
    return v0 * (1.0 - c.t) + v1 * c.t;
}

// The per-row table at `offset` (BRDF_TABLE_LOSS_AVG or BRDF_TABLE_SPEC_LOSS_AVG) at c.
fn brdf_table_average(c: BrdfTableCoord, offset: u32) -> f32 {
    return brdf_table(offset + c.row) * (1.0 - c.t) + brdf_table(offset + c.row + 1u) * c.t;
}

// f of the glossy model at cos_o, cos_i > 0.
fn brdf_eval_glossy(p: BrdfParams, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, cos_o: f32,
                    cos_i: f32) -> vec3<f32> {
    let hs = wo + wi;
    let vh = 0.5 * length(hs);
    let dv = brdf_ggx_d(p.alpha, n, hs) * brdf_visibility(p.alpha, cos_o, cos_i);
    let w = brdf_schlick_weight(vh);
    let f04 = BRDF_DIELECTRIC_F0 + (1.0 - BRDF_DIELECTRIC_F0) * w;
    let f_metal = p.base + (vec3<f32>(1.0) - p.base) * w;
    let co = brdf_table_coord(cos_o, p.roughness);
    let ci = brdf_table_coord(cos_i, p.roughness);
    let loss_avg = brdf_table_average(co, BRDF_TABLE_LOSS_AVG);
    let ms = SAMPLING_INV_PI * brdf_loss_product(brdf_table_lookup(co, BRDF_TABLE_LOSS),
                                                 brdf_table_lookup(ci, BRDF_TABLE_LOSS), loss_avg);
    let metal = f_metal * dv + brdf_ms_fresnel(p.base, loss_avg) * ms;
    let spec = f04 * dv + brdf_ms_fresnel(vec3<f32>(BRDF_DIELECTRIC_F0), loss_avg).x * ms;
    let spec_avg = brdf_table_average(co, BRDF_TABLE_SPEC_LOSS_AVG);
    let diffuse = SAMPLING_INV_PI * brdf_loss_product(brdf_table_lookup(co, BRDF_TABLE_SPEC_LOSS),
                                                      brdf_table_lookup(ci, BRDF_TABLE_SPEC_LOSS),
                                                      spec_avg);
    let dielectric = p.base * diffuse + vec3<f32>(spec);
    return dielectric * (1.0 - p.metallic) + metal * p.metallic;
}

// f(wo, wi) without the cosine.
fn brdf_eval(s: BrdfSurface, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let cos_o = dot(n, wo);
    let cos_i = dot(n, wi);
    if !(cos_o > 0.0 && cos_i > 0.0) {
        return vec3<f32>(0.0);
    }
    if s.diffuse {
        return s.base * SAMPLING_INV_PI;
    }
    return brdf_eval_glossy(brdf_params(s), n, wo, wi, cos_o, cos_i);
}

// The directional albedos at cos_o of the lobes drawn by visible normals (specular) and by the
// cosine lobe (rest: diffuse and multiple scattering), from the tables. The single-scattering
// albedo with Schlick F at any F0 is F0 E + (1 - F0) S, S found from the dielectric's.
struct BrdfLobeAlbedos {
    specular: vec3<f32>,
    rest: vec3<f32>,
}

fn brdf_lobe_albedos(p: BrdfParams, cos_o: f32) -> BrdfLobeAlbedos {
    let c = brdf_table_coord(cos_o, p.roughness);
    let loss = brdf_table_lookup(c, BRDF_TABLE_LOSS);
    let spec_loss = brdf_table_lookup(c, BRDF_TABLE_SPEC_LOSS);
    let loss_avg = brdf_table_average(c, BRDF_TABLE_LOSS_AVG);
    let ms04 = loss * brdf_ms_fresnel(vec3<f32>(BRDF_DIELECTRIC_F0), loss_avg).x;
    let single04 = max(1.0 - spec_loss - ms04, 0.0);
    let schlick = max((single04 - BRDF_DIELECTRIC_F0 * (1.0 - loss)) / (1.0 - BRDF_DIELECTRIC_F0), 0.0);
    let metal_single = p.base * (1.0 - loss) + (vec3<f32>(1.0) - p.base) * schlick;
    let metal_ms = brdf_ms_fresnel(p.base, loss_avg) * loss;
    let m = p.metallic;
    return BrdfLobeAlbedos(metal_single * m + vec3<f32>(single04 * (1.0 - m)),
                           (p.base * spec_loss + vec3<f32>(ms04)) * (1.0 - m) + metal_ms * m);
}

// The directional albedo at wo from the tables: base for a diffuse surface, 0 below.
fn brdf_albedo(s: BrdfSurface, n: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let cos_o = dot(n, wo);
    if !(cos_o > 0.0) {
        return vec3<f32>(0.0);
    }
    if s.diffuse {
        return s.base;
    }
    let a = brdf_lobe_albedos(brdf_params(s), cos_o);
    return a.specular + a.rest;
}

// The probability of drawing the specular lobe at wo: the luminance share of its albedo, in
// [BRDF_LOBE_MIN, 1 - BRDF_LOBE_MIN] unless a side reflects nothing (diffuse surface: 0).
fn brdf_specular_probability(s: BrdfSurface, n: vec3<f32>, wo: vec3<f32>) -> f32 {
    if s.diffuse {
        return 0.0;
    }
    let a = brdf_lobe_albedos(brdf_params(s), dot(n, wo));
    let ws = brdf_luminance(a.specular);
    let wr = brdf_luminance(a.rest);
    if !(wr > 0.0) {
        return 1.0;
    }
    if !(ws > 0.0) {
        return 0.0;
    }
    return clamp(ws / (ws + wr), BRDF_LOBE_MIN, 1.0 - BRDF_LOBE_MIN);
}

// The density (solid angle) with which brdf_sample draws wi; 0 where wo or wi is below.
fn brdf_pdf(s: BrdfSurface, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let cos_o = dot(n, wo);
    let cos_i = dot(n, wi);
    if !(cos_o > 0.0 && cos_i > 0.0) {
        return 0.0;
    }
    if s.diffuse {
        return cos_i * SAMPLING_INV_PI;
    }
    let p = brdf_params(s);
    let p_spec = brdf_specular_probability(s, n, wo);
    let spec = brdf_vndf_pdf(p.alpha, cos_o, brdf_ggx_d(p.alpha, n, wo + wi));
    return p_spec * spec + (1.0 - p_spec) * (cos_i * SAMPLING_INV_PI);
}

// A direction drawn from u: u.x < brdf_specular_probability draws a visible normal and
// reflects wo, otherwise the cosine lobe. Where wo is below the surface: wi = n, pdf = 0.
fn brdf_sample(s: BrdfSurface, n: vec3<f32>, wo: vec3<f32>, u: vec3<f32>) -> BrdfSample {
    let cos_o = dot(n, wo);
    if !(cos_o > 0.0) {
        return BrdfSample(n, 0.0, vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let frame = sampling_onb(n);
    var local: vec3<f32>;
    if u.x < brdf_specular_probability(s, n, wo) {
        let wo_l = vec3<f32>(dot(frame[0], wo), dot(frame[1], wo), cos_o);
        let phi = 2.0 * SAMPLING_PI * u.y;
        let h = brdf_vndf_normal(wo_l, brdf_params(s).alpha, vec2<f32>(cos(phi), sin(phi)), u.z);
        local = h * (2.0 * dot(wo_l, h)) - wo_l;
    } else {
        local = sampling_cosine_local(u.yz);
    }
    let wi = frame[0] * local.x + frame[1] * local.y + n * local.z;
    let f = brdf_eval(s, n, wo, wi);
    let pdf = brdf_pdf(s, n, wo, wi);
    let cos_i = dot(n, wi);
    var weight = vec3<f32>(0.0);
    if pdf > 0.0 && cos_i > 0.0 {
        weight = f * (cos_i / pdf);
    }
    return BrdfSample(wi, pdf, f, weight);
}
