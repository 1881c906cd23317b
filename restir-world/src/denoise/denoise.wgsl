// The denoiser (SVGF, Schied et al. HPG 2017) after any method: composed after the render
// library, its buffers at group 3 (denoise::BINDINGS). Per pixel, two signals are filtered
// apart: the direct and the indirect light, each demodulated by the primary vertex's albedo
// (illumination = (frame - emission) / albedo) and remodulated at the end, so that texture
// detail never enters the filter. At a glossy vertex (dn_glossy) the albedo is its BRDF's
// directional albedo towards the eye, the spatial filter stays within the lobe's footprint on
// the screen and does not mix surfaces of different roughness, so that a reflection keeps
// the sharpness its lobe gives it.
//
// Passes (denoise::Denoiser records them under one span, `denoise`):
// - denoise_temporal: demodulates this frame, reprojects the pixel's primary hit through last
//   frame's camera (bilinear over the four pixels around it, each kept only where last frame's
//   surface there is the same: plane distance and normal), clamps that history to this
//   frame's neighbourhood and blends: colour and luminance moments, and the history length.
//   -> dn_dst (the integrated colour), dn_state (this frame's surface, moments, length).
// - denoise_variance: each signal's luminance variance: from the moments, or (history shorter
//   than 4 frames) from the moments of a 7x7 neighbourhood on the same surface.
// - denoise_atrous (x iterations, step 1, 2, 4, ...): the edge-aware a-trous wavelet filter,
//   3x3 B-spline taps per level (9 taps where SVGF's 5x5 has 25: the per-tap cost is what a
//   CPU Vulkan pays for), weights stopped by plane distance, normals and luminance against the
//   prefiltered variance; the variance filtered with the squared weights. The first iteration's
//   output is next frame's colour history (dn_history).
// - denoise_modulate: albedo x illumination + emission -> dn_out (direct, indirect).

// Per pixel: a signal pair, each rgb and its luminance variance (w).
struct DnPair {
    direct: vec4<f32>,
    indirect: vec4<f32>,
}

// Per pixel and frame: the surface (position, oct-packed shading normal or DN_NO_SURFACE), the
// luminance moments (direct: x, y = mean, mean of squares; indirect: z, w) and the history
// length in frames.
struct DnState {
    position: vec3<f32>,
    normal: u32,
    moments: vec4<f32>,
    length: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// The knobs and the frame's history (Rust twin: denoise::params_words). prev_camera: last
// frame's; history = 1 when last frame's state exists.
struct DenoiseParams {
    knobs: DenoiseKnobs,
    prev_camera: CameraGpu,
    history: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Per a-trous pass: its step in pixels and whether it is the first (which prefilters the
// variance and writes the colour history).
struct DenoisePass {
    step: u32,
    first: u32,
    _pad0: u32,
    _pad1: u32,
}

// pack2x16snorm never writes -32768 (0x8000): no oct-packed normal equals this.
const DN_NO_SURFACE: u32 = 0x80008000u;
// History length saturates here (frames); alpha sets the blend long before.
const DN_MAX_LENGTH: f32 = 255.0;
// A demodulating albedo channel below this is taken as black (illumination 0 there).
const DN_MIN_ALBEDO: f32 = 1e-3;
const DN_LOG2E: f32 = 1.4426950408889634;

fn dn_demodulate(c: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let ok = albedo > vec3<f32>(DN_MIN_ALBEDO);
    return select(vec3<f32>(0.0), c / max(albedo, vec3<f32>(DN_MIN_ALBEDO)), ok);
}

// The remodulating albedo: 0 where demodulation took the channel as black.
fn dn_albedo(albedo: vec3<f32>) -> vec3<f32> {
    return select(vec3<f32>(0.0), albedo, albedo > vec3<f32>(DN_MIN_ALBEDO));
}

// Whether primary vertex g is glossy (never without glossy materials: RENDER_GLOSSY false).
fn dn_glossy(g: GVertex) -> bool {
    return RENDER_GLOSSY && g.material != 0u;
}

// The albedo pixel g's light is demodulated by: its base colour where diffuse; where glossy,
// its BRDF's directional albedo towards the eye (specular and diffuse lobes, from the
// compensation tables), so that the filter sees the light the lobe averages, not the lobe's
// Fresnel and energy (its base colour where the shading normal faces away from the eye).
fn dn_demodulating_albedo(g: GVertex) -> vec3<f32> {
    if !dn_glossy(g) {
        return g.albedo;
    }
    let wo = normalize(render_params.camera.eye - g.position);
    if !(dot(g.shading, wo) > 0.0) {
        return g.albedo;
    }
    return brdf_albedo(render_vertex_brdf(g), g.shading, wo);
}

// Perceptual roughness of primary vertex g for the filter's roughness stop: 1 where diffuse.
fn dn_roughness(g: GVertex) -> f32 {
    return select(1.0, render_vertex_brdf(g).roughness, dn_glossy(g));
}

// The screen radius in pixels of glossy vertex g's lobe: its width alpha = roughness^2 in
// radians, seen from the eye with the reflected surface as far from g as the eye is (a
// pixel spans 2 |up| / height radians), times the knob lobe_scale; a diffuse vertex's is
// unbounded (and every vertex's where lobe_scale is 0). The a-trous levels whose step
// exceeds it leave g's pixel as it is.
fn dn_lobe_pixels(g: GVertex) -> f32 {
    let scale = denoise_params.knobs.lobe_scale;
    if !dn_glossy(g) || scale == 0.0 {
        return 3.0e38;
    }
    let r = max(render_vertex_brdf(g).roughness, BRDF_MIN_ROUGHNESS);
    let cam = render_params.camera;
    return scale * r * r * f32(cam.height) / (2.0 * length(cam.up));
}

// How fast the a-trous weight falls with the roughness difference of two pixels (log2 per
// unit): 0.1 apart keeps a third, 0.5 apart 1/256 (a mirror beside a rough wall).
const DN_ROUGHNESS_STOP: f32 = 16.0;

fn dn_pack_normal(n: vec3<f32>) -> u32 {
    return pack2x16snorm(sampling_oct_encode(n));
}

fn dn_unpack_normal(p: u32) -> vec3<f32> {
    return sampling_oct_decode(unpack2x16snorm(p));
}

// This frame's demodulated (direct, indirect) illumination of pixel i (g its primary vertex).
// (Its albedo and emission, not the whole vertex: the clamp reads nine.)
fn dn_input(i: u32, albedo: vec3<f32>, emission: vec3<f32>) -> array<vec3<f32>, 2> {
    let direct = render_direct_frame[i].xyz - emission;
    return array<vec3<f32>, 2>(dn_demodulate(direct, albedo),
                               dn_demodulate(render_indirect_frame[i].xyz, albedo));
}

// Whether last frame's surface s is the receiver g's: within depth_threshold x the distance to
// the eye of g's plane, shading normals within normal_threshold.
fn dn_same_surface(g: GVertex, s: DnState, eye: vec3<f32>) -> bool {
    if s.normal == DN_NO_SURFACE {
        return false;
    }
    if render_planted(PLANTED_DENOISE_NO_DISOCCLUSION) {
        return true;
    }
    let plane = abs(dot(g.normal, s.position - g.position));
    let near = plane <= denoise_params.knobs.depth_threshold * distance(g.position, eye);
    return near && dot(g.shading, dn_unpack_normal(s.normal)) >= denoise_params.knobs.normal_threshold;
}

// Pixel (x, y) of this frame's image, or RENDER_NO_PIXEL outside it.
fn dn_pixel_at(x: i32, y: i32) -> u32 {
    let cam = render_params.camera;
    if x < 0 || y < 0 || x >= i32(cam.width) || y >= i32(cam.height) {
        return RENDER_NO_PIXEL;
    }
    return u32(y) * cam.width + u32(x);
}

// Last frame's history at g: the bilinear blend of the (up to) four pixels around g's
// projection through last frame's camera that saw the same surface. w: the weight found (0:
// none, a disocclusion or no history).
struct DnHistory {
    colour: DnPair,
    moments: vec4<f32>,
    length: f32,
    w: f32,
}

fn dn_reproject(i: u32, g: GVertex) -> DnHistory {
    var h: DnHistory;
    if denoise_params.history == 0u {
        return h;
    }
    let cam = denoise_params.prev_camera;
    // The motion of the surface point from this frame's image to last frame's, applied to the
    // pixel's centre: the sub-pixel jitter of the hit drops out, so a still camera reads each
    // pixel's own history (a jittered point's bilinear taps would blur it every frame).
    let now = render_params.camera;
    let centre = vec2<f32>(f32(i % now.width), f32(i / now.width)) + vec2<f32>(0.5);
    let before = render_project_xy(cam, g.position);
    // Also rejects NaN and points behind last frame's camera (-1, -1) or outside its image.
    if !(before.x >= 0.0 && before.y >= 0.0 && before.x <= f32(cam.width)
         && before.y <= f32(cam.height)) {
        return h;
    }
    let xy = centre + before - render_project_xy(now, g.position) - vec2<f32>(0.5);
    let base = floor(xy);
    let f = xy - base;
    for (var t = 0u; t < 4u; t++) {
        let o = vec2<f32>(f32(t & 1u), f32(t >> 1u));
        let q = base + o;
        if q.x < 0.0 || q.y < 0.0 || q.x >= f32(cam.width) || q.y >= f32(cam.height) {
            continue;
        }
        let j = u32(q.y) * cam.width + u32(q.x);
        let s = dn_state_prev[j];
        if !dn_same_surface(g, s, cam.eye) {
            continue;
        }
        let b = mix(1.0 - f, f, o);
        let w = b.x * b.y;
        h.colour.direct += w * dn_history[j].direct;
        h.colour.indirect += w * dn_history[j].indirect;
        h.moments += w * s.moments;
        h.length += w * s.length;
        h.w += w;
    }
    if h.w > 1e-3 {
        let n = 1.0 / h.w;
        h.colour.direct *= n;
        h.colour.indirect *= n;
        h.moments *= n;
        h.length *= n;
    } else {
        h = DnHistory();
    }
    return h;
}

// History h (both signals) clamped to the box of this frame's 3x3 neighbourhood around pixel
// (x, y): mean -/+ clamp_sigma standard deviations, per channel, over the pixels that hit.
fn dn_clamp(x: i32, y: i32, h: DnPair) -> DnPair {
    var m1 = array<vec3<f32>, 2>();
    var m2 = array<vec3<f32>, 2>();
    var n = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let j = dn_pixel_at(x + dx, y + dy);
            if j == RENDER_NO_PIXEL {
                continue;
            }
            if render_gbuffer[j].prim == BVH_NO_HIT {
                continue;
            }
            let q = render_unpack_vertex(render_gbuffer[j]);
            let c = dn_input(j, dn_demodulating_albedo(q), q.emission);
            m1[0] += c[0];
            m2[0] += c[0] * c[0];
            m1[1] += c[1];
            m2[1] += c[1] * c[1];
            n += 1.0;
        }
    }
    let k = denoise_params.knobs.clamp_sigma;
    var out = h;
    let mean_d = m1[0] / n;
    let sd_d = sqrt(max(m2[0] / n - mean_d * mean_d, vec3<f32>(0.0)));
    out.direct = vec4<f32>(clamp(h.direct.xyz, mean_d - k * sd_d, mean_d + k * sd_d), 0.0);
    let mean_i = m1[1] / n;
    let sd_i = sqrt(max(m2[1] / n - mean_i * mean_i, vec3<f32>(0.0)));
    out.indirect = vec4<f32>(clamp(h.indirect.xyz, mean_i - k * sd_i, mean_i + k * sd_i), 0.0);
    return out;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_temporal(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_unpack_vertex(render_gbuffer[i]);
    var state: DnState;
    if g.prim == BVH_NO_HIT {
        state.normal = DN_NO_SURFACE;
        dn_state[i] = state;
        dn_dst[i] = DnPair();
        return;
    }
    let cur = dn_input(i, dn_demodulating_albedo(g), g.emission);
    let lum = vec2<f32>(render_luminance(cur[0]), render_luminance(cur[1]));
    let m = vec4<f32>(lum.x, lum.x * lum.x, lum.y, lum.y * lum.y);
    var h = dn_reproject(i, g);
    let length = min(h.length + 1.0, DN_MAX_LENGTH);
    let knobs = denoise_params.knobs;
    if h.w > 0.0 && knobs.clamp_sigma > 0.0 {
        let w = render_params.camera.width;
        let x = i32(i % w);
        let y = i32(i / w);
        h.colour = dn_clamp(x, y, h.colour);
    }
    // A new surface (no history) takes this frame whole.
    let alpha = select(1.0, max(1.0 / length, knobs.alpha), h.w > 0.0);
    let alpha_m = select(1.0, max(1.0 / length, knobs.moments_alpha), h.w > 0.0);
    var keep = 1.0 - alpha;
    if render_planted(PLANTED_DENOISE_HISTORY_WEIGHT) {
        keep *= 0.9;
    }
    var out: DnPair;
    out.direct = vec4<f32>(keep * h.colour.direct.xyz + alpha * cur[0], 0.0);
    out.indirect = vec4<f32>(keep * h.colour.indirect.xyz + alpha * cur[1], 0.0);
    dn_dst[i] = out;
    state.position = g.position;
    state.normal = dn_pack_normal(g.shading);
    state.moments = mix(h.moments, m, alpha_m);
    state.length = length;
    dn_state[i] = state;
}

// The a-trous weights' geometry: the edge-stopping weight of pixel j (this frame's surface)
// for the receiver at p with shading normal n and the plane normal gn, `pixel` the receiver's
// pixel footprint at its distance, `d` the neighbour's distance in pixels.
fn dn_geometry_weight(p: vec3<f32>, gn: vec3<f32>, n: vec3<f32>, j: u32, pixel: f32,
                      d: f32) -> f32 {
    let packed = dn_state[j].normal;
    if packed == DN_NO_SURFACE {
        return 0.0;
    }
    let knobs = denoise_params.knobs;
    let w_n = pow(max(dot(n, dn_unpack_normal(packed)), 0.0), knobs.phi_normal);
    let plane = abs(dot(gn, dn_state[j].position - p));
    let w_z = exp(-plane / (knobs.phi_depth * pixel * max(d, 1.0) + 1e-20));
    return w_n * w_z;
}

// The size of a pixel at distance `depth` along the camera's forward axis.
fn dn_pixel_size(depth: f32) -> f32 {
    let cam = render_params.camera;
    return 2.0 * length(cam.up) * depth / f32(cam.height);
}

// The 3-tap B-spline (1/4, 1/2, 1/4) of each a-trous level, by |offset|.
const DN_SPLINE = array<f32, 2>(0.5, 0.25);

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_variance(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let s = dn_state[i];
    var out = dn_src[i];
    if s.normal == DN_NO_SURFACE {
        dn_dst[i] = out;
        return;
    }
    var m = s.moments;
    if s.length < 4.0 {
        // Too short a history for its own moments: those of the same surface around it.
        let g = render_unpack_vertex(render_gbuffer[i]);
        let cam = render_params.camera;
        let pixel = dn_pixel_size(dot(g.position - cam.eye, cam.forward));
        let x = i32(i % cam.width);
        let y = i32(i / cam.width);
        var sum = vec4<f32>(0.0);
        var wsum = 0.0;
        for (var dy = -3; dy <= 3; dy++) {
            for (var dx = -3; dx <= 3; dx++) {
                let j = dn_pixel_at(x + dx, y + dy);
                if j == RENDER_NO_PIXEL {
                    continue;
                }
                let d = length(vec2<f32>(f32(dx), f32(dy)));
                let w = dn_geometry_weight(g.position, g.normal, g.shading, j, pixel, d);
                sum += w * dn_state[j].moments;
                wsum += w;
            }
        }
        m = sum / max(wsum, 1e-20);
        // A short history's variance is underestimated: raised as SVGF does.
        m = vec4<f32>(m.x, m.x * m.x + (m.y - m.x * m.x) * 4.0 / s.length,
                      m.z, m.z * m.z + (m.w - m.z * m.z) * 4.0 / s.length);
    }
    out.direct.w = max(m.y - m.x * m.x, 0.0);
    out.indirect.w = max(m.w - m.z * m.z, 0.0);
    dn_dst[i] = out;
}

// The 3x3 Gaussian of the variance of both signals around (x, y): the luminance weight's scale.
fn dn_prefiltered_variance(x: i32, y: i32) -> vec2<f32> {
    var v = vec2<f32>(0.0);
    var wsum = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let j = dn_pixel_at(x + dx, y + dy);
            if j == RENDER_NO_PIXEL {
                continue;
            }
            let c = dn_src[j];
            let w = select(0.5, 1.0, dx == 0) * select(0.5, 1.0, dy == 0);
            v += w * vec2<f32>(c.direct.w, c.indirect.w);
            wsum += w;
        }
    }
    return v / wsum;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_atrous(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let c = dn_src[i];
    let s = dn_state[i];
    var out = c;
    let g = render_unpack_vertex(render_gbuffer[i]);
    if s.normal != DN_NO_SURFACE && f32(dn_pass.step) <= dn_lobe_pixels(g) {
        let cam = render_params.camera;
        let pixel = dn_pixel_size(dot(g.position - cam.eye, cam.forward));
        let x = i32(i % cam.width);
        let y = i32(i / cam.width);
        let step = i32(dn_pass.step);
        // Later levels' variance has been filtered by the ones before.
        var var_p = vec2<f32>(c.direct.w, c.indirect.w);
        if dn_pass.first != 0u {
            var_p = dn_prefiltered_variance(x, y);
        }
        let knobs = denoise_params.knobs;
        // Every weight is one power of 2 per signal: exp2 of the sum of the edge-stopping
        // exponents (normal, plane distance, luminance).
        var stop = vec2<f32>(DN_LOG2E / knobs.phi_luminance);
        if render_planted(PLANTED_DENOISE_NO_LUMINANCE_STOP) {
            stop = vec2<f32>(0.0);
        }
        let inv_z = DN_LOG2E / (knobs.phi_depth * pixel * f32(step) + 1e-20);
        let l_p = vec2<f32>(render_luminance(c.direct.xyz), render_luminance(c.indirect.xyz));
        let r_p = dn_roughness(g);
        var sum_d = vec4<f32>(0.0);
        var sum_i = vec4<f32>(0.0);
        var w_d = 0.0;
        var w_i = 0.0;
        for (var dy = -1; dy <= 1; dy++) {
            for (var dx = -1; dx <= 1; dx++) {
                let j = dn_pixel_at(x + dx * step, y + dy * step);
                if j == RENDER_NO_PIXEL {
                    continue;
                }
                var e_geometry = 0.0;
                if j != i {
                    let packed = dn_state[j].normal;
                    let cos_n = select(0.0, dot(g.shading, dn_unpack_normal(packed)),
                                       packed != DN_NO_SURFACE);
                    if cos_n <= 0.0 {
                        continue;
                    }
                    let plane = abs(dot(g.normal, dn_state[j].position - g.position));
                    // Per pixel of offset: a diagonal neighbour is sqrt(2) steps away.
                    let per = select(1.0, 0.70710678, dx != 0 && dy != 0);
                    e_geometry = knobs.phi_normal * log2(cos_n) - plane * inv_z * per;
                    if RENDER_GLOSSY {
                        let r_q = dn_roughness(render_unpack_vertex(render_gbuffer[j]));
                        e_geometry -= DN_ROUGHNESS_STOP * abs(r_p - r_q);
                    }
                }
                let q = dn_src[j];
                let l_q = vec2<f32>(render_luminance(q.direct.xyz), render_luminance(q.indirect.xyz));
                let h = DN_SPLINE[abs(dx)] * DN_SPLINE[abs(dy)];
                // Symmetric in p and q (the geometric mean of their deviations): a bright
                // outlier's energy is shared with noisy neighbours that would otherwise refuse
                // it, not lost, while a noise-free pixel (deviation 0) still refuses it.
                let var_q = max(vec2<f32>(q.direct.w, q.indirect.w), vec2<f32>(0.0));
                let sigma = sqrt(sqrt(max(var_p, vec2<f32>(0.0)) * var_q)) + 1e-10;
                let w = h * exp2(vec2<f32>(e_geometry) - abs(l_p - l_q) * stop / sigma);
                sum_d += vec4<f32>(w.x * q.direct.xyz, w.x * w.x * q.direct.w);
                sum_i += vec4<f32>(w.y * q.indirect.xyz, w.y * w.y * q.indirect.w);
                w_d += w.x;
                w_i += w.y;
            }
        }
        out.direct = vec4<f32>(sum_d.xyz / w_d, sum_d.w / (w_d * w_d));
        out.indirect = vec4<f32>(sum_i.xyz / w_i, sum_i.w / (w_i * w_i));
    }
    dn_dst[i] = out;
    if dn_pass.first != 0u {
        dn_history[i] = out;
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn denoise_modulate(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_unpack_vertex(render_gbuffer[i]);
    var out: DnPair;
    if g.prim == BVH_NO_HIT {
        // What the camera ray saw (the environment): nothing to filter.
        out.direct = render_direct_frame[i];
    } else {
        let c = dn_src[i];
        let a = dn_albedo(dn_demodulating_albedo(g));
        out.direct = vec4<f32>(g.emission + a * c.direct.xyz, 0.0);
        out.indirect = vec4<f32>(a * c.indirect.xyz, 0.0);
    }
    dn_out[i] = out;
}
