// The salt of the path's draws for the estimates' cell visits (render_rng_salted, STREAM_PATH,
// + the bounce): apart from the path's own (salted by the bounce alone).
const WR_PATH_ESTIMATE_SALT: u32 = 0x800u;

// The path's MIS estimate at vertex w (render/path.wgsl's "path-light"): its cell's, numbers
// drawn apart from the path's; 0 (the light table's density) with mis_candidates = 0 or without
// MIS.
fn path_light_estimate(i: u32, w: GVertex, bounce: u32) -> f32 {
    if wr_params.knobs.mis_candidates == 0u || render_params.mis == 0u {
        return 0.0;
    }
    var rng = render_rng_salted(i, STREAM_PATH, WR_PATH_ESTIMATE_SALT + bounce);
    return wr_cell_estimate(w, wr_params.items, &rng);
}
