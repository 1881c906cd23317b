// Screen-space ReSTIR DI library (Bitterli et al. 2020; Wyman & Panteleev 2021): the stored
// reservoir, the knobs, the target function and the screen-space helpers (reprojection,
// similarity tests) of the restir-di passes. Structs and functions only. Needs the render
// library (render::library: render_* bindings, lights, trace, rng), reservoir::wgsl() and the
// constants header restir_di::constants_wgsl().

// One pixel's reservoir as stored between passes (Rust twin: restir_di::DiReservoir). The
// selected light sample is the payload, one representation for every light kind (as
// world-restir's WrReservoir): light_position is the point on the light or, for the kinds at
// infinity, the unit direction towards it; light_kind = LIGHTS_KIND_* in the low 2 bits and the
// light table index above. (ucw, m) is reservoir's PackedReservoir; m = 0: no reservoir.
struct DiReservoir {
    light_position: vec3<f32>,
    ucw: f32,
    light_normal: vec3<f32>,
    m: u32,
    light_emission: vec3<f32>,
    light_kind: u32,
}

// Knobs and the frame's history (Rust twin: restir_di::DiParams), uploaded every frame.
// prev_camera: last frame's camera; history = 1 when last frame's G-buffer and reservoirs
// exist.
struct DiParams {
    prev_camera: CameraGpu,
    tiles: u32,
    tile_size: u32,
    candidates: u32,
    history: u32,
    temporal_m_cap: u32,
    spatial_k: u32,
    spatial_radius: f32,
    combine: u32,
    depth_threshold: f32,
    normal_threshold: f32,
    _pad0: u32,
    _pad1: u32,
}

// Per reuse pass (Rust twin: restir_di::DiPass): temporal = 1 for the pass that reads last
// frame's reservoirs through the reprojection.
struct DiPass {
    temporal: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

fn di_store(s: LightSample, ucw: f32, m: u32) -> DiReservoir {
    return DiReservoir(s.position, ucw, s.normal, m, s.emission, s.kind | (s.light << 2u));
}

fn di_light_sample(r: DiReservoir) -> LightSample {
    var s: LightSample;
    s.position = r.light_position;
    s.normal = r.light_normal;
    s.emission = r.light_emission;
    s.kind = r.light_kind & 3u;
    s.light = r.light_kind >> 2u;
    s.pdf_area = 1.0;
    return s;
}

// Unshadowed reflected radiance of light sample s at the primary vertex g.
fn di_contribution(g: GVertex, s: LightSample) -> vec3<f32> {
    return render_light_contribution(g.position, g.normal, g.shading, g.albedo, s);
}

// The target p_hat: luminance of the unshadowed reflected radiance (the `ris` baseline's).
fn di_target(g: GVertex, s: LightSample) -> f32 {
    return render_luminance(di_contribution(g, s));
}

fn di_rng(i: u32, pass_id: u32) -> u32 {
    return rng_seed(i, render_state.frame, render_params.seed * RENDER_PASS_COUNT + pass_id);
}

// The pixel whose camera ray through `cam` sees the point p, or DI_NO_PIXEL when p is behind
// the camera or outside the image.
fn di_project(cam: CameraGpu, p: vec3<f32>) -> u32 {
    let d = p - cam.eye;
    let z = dot(d, cam.forward);
    if !(z > 1e-6) {
        return DI_NO_PIXEL;
    }
    let sx = dot(d, cam.right) / (z * dot(cam.right, cam.right));
    let sy = dot(d, cam.up) / (z * dot(cam.up, cam.up));
    let x = (sx + 1.0) * 0.5 * f32(cam.width);
    let y = (1.0 - sy) * 0.5 * f32(cam.height);
    // Also rejects NaN.
    if !(x >= 0.0 && x < f32(cam.width) && y >= 0.0 && y < f32(cam.height)) {
        return DI_NO_PIXEL;
    }
    return min(u32(y), cam.height - 1u) * cam.width + min(u32(x), cam.width - 1u);
}

// Geometric similarity of a reused pixel's vertex q to the receiver g, both seen from eye: both
// hit, depths within depth_threshold (relative), shading normals within normal_threshold
// (cosine).
fn di_similar(g: GVertex, q: GVertex, eye: vec3<f32>) -> bool {
    if q.prim == BVH_NO_HIT {
        return false;
    }
    let dg = distance(g.position, eye);
    let dq = distance(q.position, eye);
    return abs(dq - dg) <= di_params.depth_threshold * dg
        && dot(g.shading, q.shading) >= di_params.normal_threshold;
}
