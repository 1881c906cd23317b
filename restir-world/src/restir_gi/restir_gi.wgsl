// Screen-space ReSTIR GI library (Ouyang et al. 2021): the path sample, its target, the
// reconnection shift's Jacobian, and the knobs of the restir-gi passes. Structs and functions
// only. Needs the render library (render::library), reservoir::wgsl() and the constants header
// restir_gi::constants_wgsl(), and the screen-reuse library
// (screen_reuse::WGSL: ScreenParams, the knobs in screen_params.knobs).
//
// A sample is the secondary vertex x2 of a pixel's path (position, the normal on the side its
// primary saw it from) and the radiance leaving it towards that primary, L (the pixel's path
// sample as the indirect passes record it, PathLight: x2's light estimate and the path beyond
// it). Samples live in the solid angle at the primary vertex x1: a pixel's own sample has
// the GI ray's density; a neighbour's is shifted to the receiver by reconnection (the
// receiver's x1 joins the neighbour's x2). At a diffuse x2 L is kept (the same towards any
// x1); at a glossy x2 (x2-min-roughness or rougher) the sample keeps x2's BRDF and its glossy
// record (RenderGlossyX2: its light sample's and its continuation's directions and weights),
// and L towards each x1 is f(x2; wo, wl) a_l + f(x2; wo, wi) a_i, wo towards that x1: the
// reconnection shift of a path whose vertices beyond x2 stay, its Jacobian the same.

// A pixel's reservoir as stored, 48 bytes (Rust twin: restir_gi::GiReservoir; 48 so that
// world-restir-gi's reservoirs, the pixels' and the pool's, fit one 128 MiB binding at
// 1920x1080): its sample's x2, W, `radiance` (a diffuse x2's L as f32 bits; a glossy x2's a_i
// as shared-exponent RGB and the directions wl and wi, octahedral snorm16 x2), normal_m = x2's
// normal (octahedral, two 11-bit snorm) | M << 22 (M saturates at GI_MAX_M; M = 0: no primary
// vertex); at a glossy x2 (material != 0) its material word, base colour (unorm10 x3), shading
// normal (octahedral snorm16 x2) and a_l (shared-exponent RGB).
struct GiReservoir {
    position: vec3<f32>,
    ucw: f32,
    radiance: vec3<u32>,
    normal_m: u32,
    material: u32,
    base: u32,
    shading: u32,
    light: u32,
}

// A path sample (GiReservoir's): at a diffuse x2 (material 0) its position, normal and L; at a
// glossy one also its BRDF (base colour, shading normal, material word) and its glossy record
// (radiance = a_i, light = a_l).
struct GiSample {
    position: vec3<f32>,
    normal: vec3<f32>,
    radiance: vec3<f32>,
    material: u32,
    base: vec3<f32>,
    shading: vec3<f32>,
    light: vec3<f32>,
    wl: vec3<f32>,
    wi: vec3<f32>,
}

// A sample at a diffuse x2: L leaving it.
fn gi_diffuse_sample(position: vec3<f32>, normal: vec3<f32>, radiance: vec3<f32>) -> GiSample {
    var s: GiSample;
    s.position = position;
    s.normal = normal;
    s.radiance = radiance;
    return s;
}

// A sample at glossy x2 with its record r.
fn gi_glossy_sample(x2: GVertex, r: RenderGlossyX2) -> GiSample {
    return GiSample(x2.position, x2.normal, r.a_i, x2.material, x2.albedo, x2.shading, r.a_l,
                    r.wl, r.wi);
}

fn gi_pack_direction(d: vec3<f32>) -> u32 {
    return pack2x16snorm(sampling_oct_encode(d));
}

fn gi_unpack_direction(b: u32) -> vec3<f32> {
    return sampling_oct_decode(unpack2x16snorm(b));
}

fn gi_pack_unorm10(c: vec3<f32>) -> u32 {
    let q = vec3<u32>(round(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)) * 1023.0));
    return q.x | (q.y << 10u) | (q.z << 20u);
}

fn gi_unpack_unorm10(b: u32) -> vec3<f32> {
    return vec3<f32>(vec3<u32>(b, b >> 10u, b >> 20u) & vec3<u32>(1023u)) / 1023.0;
}

// Non-negative RGB in 32 bits: three 9-bit mantissas and a shared 5-bit exponent (as
// EXT_texture_shared_exponent's, its bias moved to cover 2^-21 .. 5.2e5, a glossy record's
// weights: relative error at most 1/1024 of the largest channel; larger values clamp).
const GI_RGB9E5_BIAS: i32 = 21;

fn gi_pack_rgb9e5(c: vec3<f32>) -> u32 {
    let top = 511.0 * exp2(f32(31 - GI_RGB9E5_BIAS));
    let v = clamp(c, vec3<f32>(0.0), vec3<f32>(top));
    let most = max(v.x, max(v.y, v.z));
    if !(most > 0.0) {
        return 0u;
    }
    var e = clamp(i32(floor(log2(most))) + 1 + GI_RGB9E5_BIAS - 9, 0, 31);
    if round(most * exp2(f32(GI_RGB9E5_BIAS - e))) > 511.0 && e < 31 {
        e += 1;
    }
    let q = vec3<u32>(min(round(v * exp2(f32(GI_RGB9E5_BIAS - e))), vec3<f32>(511.0)));
    return q.x | (q.y << 9u) | (q.z << 18u) | (u32(e) << 27u);
}

fn gi_unpack_rgb9e5(b: u32) -> vec3<f32> {
    let q = vec3<u32>(b, b >> 9u, b >> 18u) & vec3<u32>(511u);
    return vec3<f32>(q) * exp2(f32(i32(b >> 27u) - GI_RGB9E5_BIAS));
}

fn gi_snorm11(x: f32) -> u32 {
    return u32(round((clamp(x, -1.0, 1.0) * 0.5 + 0.5) * 2047.0));
}

fn gi_unsnorm11(b: u32) -> f32 {
    return f32(b & 2047u) / 2047.0 * 2.0 - 1.0;
}

// Octahedral encoding of a unit vector in 22 bits.
fn gi_encode_normal(n: vec3<f32>) -> u32 {
    var p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if n.z < 0.0 {
        p = (1.0 - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    }
    return gi_snorm11(p.x) | (gi_snorm11(p.y) << 11u);
}

fn gi_decode_normal(bits: u32) -> vec3<f32> {
    let p = vec2<f32>(gi_unsnorm11(bits), gi_unsnorm11(bits >> 11u));
    var n = vec3<f32>(p, 1.0 - abs(p.x) - abs(p.y));
    if n.z < 0.0 {
        n = vec3<f32>((1.0 - abs(n.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), n.xy >= vec2<f32>(0.0)), n.z);
    }
    return normalize(n);
}

fn gi_m(r: GiReservoir) -> u32 {
    return r.normal_m >> 22u;
}

fn gi_store(s: GiSample, packed: PackedReservoir) -> GiReservoir {
    let m = min(packed.m, GI_MAX_M);
    var r = GiReservoir(s.position, packed.ucw, bitcast<vec3<u32>>(s.radiance),
                        gi_encode_normal(s.normal) | (m << 22u), 0u, 0u, 0u, 0u);
    if RENDER_GLOSSY && s.material != 0u {
        r.radiance = vec3<u32>(gi_pack_rgb9e5(s.radiance), gi_pack_direction(s.wl),
                               gi_pack_direction(s.wi));
        r.material = s.material;
        r.base = gi_pack_unorm10(s.base);
        r.shading = gi_pack_direction(s.shading);
        r.light = gi_pack_rgb9e5(s.light);
    }
    return r;
}

// Reservoir r with the W and M of `packed` (its sample's bits kept as they are).
fn gi_reweighted(r: GiReservoir, packed: PackedReservoir) -> GiReservoir {
    var out = r;
    out.ucw = packed.ucw;
    out.normal_m = (r.normal_m & 0x3fffffu) | (min(packed.m, GI_MAX_M) << 22u);
    return out;
}

fn gi_sample(r: GiReservoir) -> GiSample {
    var s = gi_diffuse_sample(r.position, gi_decode_normal(r.normal_m), bitcast<vec3<f32>>(r.radiance));
    if RENDER_GLOSSY && r.material != 0u {
        s.radiance = gi_unpack_rgb9e5(r.radiance.x);
        s.wl = gi_unpack_direction(r.radiance.y);
        s.wi = gi_unpack_direction(r.radiance.z);
        s.material = r.material;
        s.base = gi_unpack_unorm10(r.base);
        s.shading = gi_unpack_direction(r.shading);
        s.light = gi_unpack_rgb9e5(r.light);
    }
    return s;
}

// Whether the reservoir holds a sample with weight (an escaped GI ray, a black one: none).
fn gi_has_sample(r: GiReservoir) -> bool {
    return gi_m(r) > 0u && r.ucw > 0.0;
}

// gi_debug's refusal flags (DebugView::Refused; bits 0-15 count the merged neighbours and the
// rejected reconnections, 16-27 world-restir-gi's temporal origin and age): the pixel's x1 is
// too smooth to take part (min-roughness), its own x2 too smooth to reconnect to
// (x2-min-roughness), a neighbour's shift was refused (Jacobian out of range, x2 facing away;
// with visibility=on also occluded), the selected sample was occluded (selected, final).
const GI_REFUSED_X1: u32 = 0x10000000u;
const GI_REFUSED_X2: u32 = 0x20000000u;
const GI_REFUSED_SHIFT: u32 = 0x40000000u;
const GI_REFUSED_OCCLUDED: u32 = 0x80000000u;

// Whether the reuse takes primary vertex g as an x1 (holds a path sample there): a diffuse one,
// or a glossy one at knobs.min_roughness or rougher (half the packed roughness' step below: a
// material at the knob's value is taken). Its x2 is one gi_takes_x2 takes.
fn gi_reuses(g: GVertex) -> bool {
    return render_reuses(g)
        || render_vertex_brdf(g).roughness >= screen_params.knobs.min_roughness - 0.5 / 65535.0;
}

// Whether the reuse takes x2 (the secondary vertex of a path from a primary vertex it takes) as
// a sample's reconnection vertex: a diffuse one, or a glossy one whose glossy record the passes
// keep (render_records_glossy: x2-min-roughness or rougher). Other x2 are no sample
// (gi-initial), their light the pixel's own path's (gi-shade).
fn gi_takes_x2(x2: GVertex) -> bool {
    return render_reuses(x2) || render_records_glossy(x2);
}

// The radiance sample s's x2 sends towards primary vertex g: L at a diffuse x2; at a glossy
// one its record reflected by x2's BRDF towards g (wo from g's ray origin, as the path's own
// x2 saw it: render_secondary_vertex).
fn gi_radiance(g: GVertex, s: GiSample) -> vec3<f32> {
    if !RENDER_GLOSSY || s.material == 0u {
        return s.radiance;
    }
    var x2: GVertex;
    x2.position = s.position;
    x2.normal = s.normal;
    x2.albedo = s.base;
    x2.shading = s.shading;
    x2.material = s.material;
    x2.wo = normalize(render_offset(g.position, g.normal) - s.position);
    var l = vec3<f32>(0.0);
    if any(s.light > vec3<f32>(0.0)) {
        l += render_brdf(x2, s.wl) * s.light;
    }
    if any(s.radiance > vec3<f32>(0.0)) {
        l += render_brdf(x2, s.wi) * s.radiance;
    }
    return l;
}

// The sample's contribution at primary vertex g: f(x1) L cos (albedo / pi * L * cos at a
// diffuse x1, the BRDF towards g's camera at a glossy one; L towards g, gi_radiance), 0 where
// the direction to x2 is below g's surface or x2 faces away from g (its L is for the other side).
fn gi_contribution(g: GVertex, s: GiSample) -> vec3<f32> {
    let d = s.position - g.position;
    let d2 = dot(d, d);
    if !(d2 > 0.0) {
        return vec3<f32>(0.0);
    }
    let dir = d * inverseSqrt(d2);
    let cos_x1 = dot(g.shading, dir);
    if cos_x1 <= 0.0 || dot(g.normal, dir) <= 0.0 || dot(s.normal, dir) >= 0.0 {
        return vec3<f32>(0.0);
    }
    let l = gi_radiance(g, s);
    if RENDER_GLOSSY && g.material != 0u {
        return render_brdf(g, dir) * l * cos_x1;
    }
    return g.albedo * SAMPLING_INV_PI * l * cos_x1;
}

// The target p_hat at g: luminance of the sample's contribution.
fn gi_target(g: GVertex, s: GiSample) -> f32 {
    return render_luminance(gi_contribution(g, s));
}

// W of a vertex's own sample s, drawn by its path step (the cosine density about g's shading
// normal at a diffuse g, the BRDF's at a glossy one): 1 / pdf (one RIS candidate); 0 where the
// pdf or the target is 0.
fn gi_own_ucw(g: GVertex, s: GiSample) -> f32 {
    var dir = normalize(s.position - g.position);
    if RENDER_GLOSSY && g.material != 0u {
        // The direction the ray took, from its origin (a narrow lobe's density differs).
        dir = normalize(s.position - render_offset(g.position, g.normal));
    }
    let pdf = render_brdf_pdf(g, dir);
    if pdf > 0.0 && gi_target(g, s) > 0.0 {
        return 1.0 / pdf;
    }
    return 0.0;
}

// |J| of the reconnection shift of sample s from primary vertex x1_from to primary vertex x1_to
// (Ouyang et al. 2021, Eq. 11): |cos phi_to| / |cos phi_from| * |from - x2|^2 / |to - x2|^2,
// phi the angle at x2 between its normal and the direction to each primary. 0 (no shift)
// where x2 faces away from either, or where |J| leaves [1 / max_jacobian, max_jacobian]: the
// same pairs either way, so the shift stays a bijection between the domains it keeps.
fn gi_jacobian(s: GiSample, x1_from: vec3<f32>, x1_to: vec3<f32>) -> f32 {
    let a = x1_from - s.position;
    let b = x1_to - s.position;
    let da = dot(a, a);
    let db = dot(b, b);
    let cos_a = dot(s.normal, a) * inverseSqrt(da);
    let cos_b = dot(s.normal, b) * inverseSqrt(db);
    if !(cos_a > 0.0 && cos_b > 0.0) {
        return 0.0;
    }
    var j = cos_b / cos_a * (da / db);
    if render_planted(PLANTED_JACOBIAN_WITHOUT_DISTANCE) {
        j = cos_b / cos_a;
    }
    let t = screen_params.knobs.max_jacobian;
    if !(j <= t && j * t >= 1.0) {
        return 0.0;
    }
    return j;
}

// The visibility modes (restir_gi::Visibility): whether each neighbour's sample is tested from
// the receiver (the forward ray), whether the receiver's own sample is tested from each
// neighbour (the back ray), whether the sample a merge selects is tested after it.
fn gi_forward_rays() -> bool {
    return screen_params.knobs.visibility == GI_VISIBILITY_ON
        && !render_planted(PLANTED_FORWARD_UNTESTED);
}

fn gi_back_rays() -> bool {
    let v = screen_params.knobs.visibility;
    return v == GI_VISIBILITY_ON || v == GI_VISIBILITY_SELECTED;
}

fn gi_tests_selected() -> bool {
    let v = screen_params.knobs.visibility;
    return v == GI_VISIBILITY_SELECTED || v == GI_VISIBILITY_FINAL;
}

// Whether a vertex that holds reservoir `held` sees point x2 without a ray: a reservoir's
// sample is visible from its own primary vertex (it was traced from there or tested there, in
// every mode that traces rays; the scenes are static), and reuse copies samples, so a receiver
// and its neighbours often hold the very same x2.
fn gi_holds(held: GiReservoir, x2: vec3<f32>) -> bool {
    return gi_has_sample(held) && all(held.position == x2);
}

// Whether sample y, which a merge at g (holding `own`) selected from a neighbour, may light g:
// false where the visibility mode tests the selected sample and the ray from g finds it
// occluded. Unbiased with `selected`: the targets leave visibility out, the integrand keeps it.
fn gi_selected_visible(g: GVertex, own: GiReservoir, y: GiSample) -> bool {
    return !gi_tests_selected() || render_planted(PLANTED_FORWARD_UNTESTED)
        || gi_holds(own, y.position) || render_visible(g.position, g.normal, y.position);
}

// How a merge ended (gi_finish): the reservoir to store, whether the receiver's own sample is
// the selection, and whether a selected neighbour's sample was found occluded.
struct GiFinished {
    stored: PackedReservoir,
    canonical: bool,
    occluded: bool,
}

// Ends a merge at g (holding `own`, reuse_finish) whose selected neighbour's sample, if one is
// selected, is y. With `selected` and `final` y is tested now; occluded, it counts as 0:
// pairwise drops the neighbours' part (reuse_drop_neighbours) and the receiver keeps its own
// sample, the other combinations store W = 0.
fn gi_finish(c: ptr<function, Reuse>, g: GVertex, own: GiReservoir, y: GiSample) -> GiFinished {
    var occluded = false;
    if reuse_selected(*c) != REUSE_CANONICAL && !gi_selected_visible(g, own, y) {
        occluded = true;
        if (*c).mode == REUSE_PAIRWISE {
            reuse_drop_neighbours(c);
        }
    }
    var stored = reuse_finish(c);
    let canonical = reuse_selected(*c) == REUSE_CANONICAL;
    if !canonical && occluded {
        stored.ucw = 0.0;
    }
    return GiFinished(stored, canonical, occluded);
}

// Neighbour q's target at the receiver's sample y shifted to it from the receiver's x1 (at
// x1_own), times that shift's Jacobian, with visibility from q where the mode traces back rays
// (no ray where q holds y's x2 in `q_holds`, gi_holds).
fn gi_shifted_target(q: GVertex, q_holds: GiReservoir, y: GiSample, x1_own: vec3<f32>) -> f32 {
    let j = gi_jacobian(y, x1_own, q.position);
    if j == 0.0 {
        return 0.0;
    }
    let p = gi_target(q, y) * j;
    if p > 0.0 && gi_back_rays() && !gi_holds(q_holds, y.position)
        && !render_visible(q.position, q.normal, y.position) {
        return 0.0;
    }
    return p;
}

// What a receiver (primary vertex g, own reservoir own) needs of neighbour q's reservoir
// src to merge it (reuse_neighbour_shifted): src's sample's target at g with its reconnection's
// Jacobian (0 where the shift or, with `visibility=on`, the ray from g fails), its target at q, and
// (`pairwise`) the receiver's own sample's shifted to q.
struct GiPair {
    p_target: f32,
    jacobian: f32,
    p_n_y: f32,
    p_n_own: f32,
}

fn gi_pair(g: GVertex, own: GiReservoir, pairwise: bool, q: GVertex, src: GiReservoir) -> GiPair {
    var pair = GiPair(0.0, 0.0, 0.0, 0.0);
    if gi_has_sample(src) {
        let y = gi_sample(src);
        pair.jacobian = gi_jacobian(y, q.position, g.position);
        if pair.jacobian > 0.0 {
            pair.p_target = gi_target(g, y);
        }
        if pair.p_target > 0.0 && gi_forward_rays() && !gi_holds(own, y.position)
            && !render_visible(g.position, g.normal, y.position) {
            pair.p_target = 0.0;
        }
        pair.p_n_y = gi_target(q, y);
    }
    if pairwise {
        pair.p_n_own = gi_shifted_target(q, src, gi_sample(own), g.position);
    }
    return pair;
}
