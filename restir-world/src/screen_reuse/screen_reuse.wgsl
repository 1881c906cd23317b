// Screen-space reuse, the part every stage that resamples between pixels and frames shares
// (restir-di, restir-gi): the frame's parameters and the similarity test of two pixels' primary
// vertices. Structs and functions only; the reuse pass's neighbours are neighbours.wgsl.
//
// The stage supplies `struct ScreenKnobs` (generated from its knobs) with at least
// temporal_m_cap: u32, spatial_k: u32, spatial_radius: f32, depth_threshold: f32 and
// normal_threshold: f32, and binds `screen_params` in each of its kernels.

// The stage's knobs and the frame's history (Rust twin: screen_reuse::params_words), uploaded
// every frame. prev_camera: last frame's camera; history = 1 when last frame's G-buffer and
// reservoirs exist.
struct ScreenParams {
    knobs: ScreenKnobs,
    prev_camera: CameraGpu,
    history: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Geometric similarity of a reused pixel's vertex q to the receiver g, both seen from eye
// (render_similar with the knobs' thresholds).
fn screen_similar(g: GVertex, q: GVertex, eye: vec3<f32>) -> bool {
    return render_similar(g, q, eye, screen_params.knobs.depth_threshold,
                          screen_params.knobs.normal_threshold);
}
