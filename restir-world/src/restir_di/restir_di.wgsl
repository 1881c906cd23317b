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

// Geometric similarity of a reused pixel's vertex q to the receiver g, both seen from eye
// (render_similar with the knobs' thresholds).
fn di_similar(g: GVertex, q: GVertex, eye: vec3<f32>) -> bool {
    return render_similar(g, q, eye, di_params.knobs.depth_threshold,
                          di_params.knobs.normal_threshold);
}
