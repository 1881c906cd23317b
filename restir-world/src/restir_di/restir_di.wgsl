// Screen-space ReSTIR DI library (Bitterli et al. 2020; Wyman & Panteleev 2021): the knobs,
// the target function and the screen-space helpers (reprojection, similarity tests) of the
// restir-di passes; reservoirs are the render library's StoredReservoir. Structs and functions
// only. Needs the render library (render::library: render_* bindings, lights, trace, rng),
// reservoir::wgsl() and the constants header restir_di::constants_wgsl().

// Knobs (DiKnobs, generated from restir_di::RestirDiConfig) and the frame's history (Rust
// twin: restir_di::DiParams), uploaded every frame. prev_camera: last frame's camera; history
// = 1 when last frame's G-buffer and reservoirs exist.
struct DiParams {
    knobs: DiKnobs,
    prev_camera: CameraGpu,
    history: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
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
    return abs(dq - dg) <= di_params.knobs.depth_threshold * dg
        && dot(g.shading, q.shading) >= di_params.knobs.normal_threshold;
}
