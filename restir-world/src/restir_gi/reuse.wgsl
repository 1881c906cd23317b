// Passes "gi-temporal" and "gi-spatial" (the entry point screen_reuse): each pixel (the
// canonical reservoir, reuse_self) merges the reservoirs of the neighbours screen_neighbours
// finds (last frame's pixel through last frame's camera, or spatial_k pixels in a disc).
// A neighbour's sample is shifted to the receiver by reconnection (gi_jacobian). With
// `visibility` on, targets include visibility: one ray from the receiver's x1 to the
// neighbour's x2 (an occluded sample has target 0 here), and for the MIS weights one from the
// neighbour's x1 to the receiver's own x2 (gi_shifted_target: a pixel only ever holds samples
// visible from its x1, so the neighbour could not have produced an occluded one; leaving that
// ray out darkened cornell's indirect image by 5-6%). Combination
// (knobs.combine): the reservoir crate's reuse_* with the shift's Jacobian kept apart
// (reuse_neighbour_shifted). Adds the merged neighbours and the rejected
// reconnections (shift or visibility failed) to gi_debug.

// Neighbour q's target at the receiver's sample y shifted to it from the receiver's x1 (at
// x1_own), times that shift's Jacobian, with visibility from q when `visibility` is on.
fn gi_shifted_target(q: GVertex, y: GiSample, x1_own: vec3<f32>) -> f32 {
    let j = gi_jacobian(y, x1_own, q.position);
    if j == 0.0 {
        return 0.0;
    }
    let p = gi_target(q, y) * j;
    if p > 0.0 && screen_params.knobs.visibility != 0u && !render_visible(q.position, q.normal, y.position) {
        return 0.0;
    }
    return p;
}

const SCREEN_STREAM_TEMPORAL: u32 = STREAM_GI_TEMPORAL;
const SCREEN_STREAM_SPATIAL: u32 = STREAM_GI_SPATIAL;

fn screen_m(r: GiReservoir) -> u32 {
    return gi_m(r);
}

fn screen_merge(i: u32, own: GiReservoir, g: GVertex, temporal: bool, nb: ScreenNeighbours,
                rng: ptr<function, u32>) -> GiReservoir {
    let u_own = rng_next_f32(rng);
    let has_own = gi_has_sample(own);
    let own_sample = gi_sample(own);
    var p_own = 0.0;
    if has_own {
        p_own = gi_target(g, own_sample);
    }
    let combine = screen_params.knobs.combine;
    var c = reuse_begin(combine, PackedReservoir(own.ucw, gi_m(own)), p_own, nb.k, nb.m_sum, u_own);
    var out = own;
    var rejected = 0u;
    for (var n = 0u; n < nb.k; n++) {
        let u_merge = rng_next_f32(rng);
        let src = reuse_src[nb.idx[n]];
        let q = screen_source_vertex(nb.idx[n], temporal);
        let y = gi_sample(src);
        var p_target = 0.0;
        var jacobian = 0.0;
        var p_n_y = 0.0;
        if gi_has_sample(src) {
            jacobian = gi_jacobian(y, q.position, g.position);
            if jacobian > 0.0 {
                p_target = gi_target(g, y);
            }
            if p_target > 0.0 && screen_params.knobs.visibility != 0u
                && !render_visible(g.position, g.normal, y.position) {
                p_target = 0.0;
            }
            rejected += select(0u, 1u, p_target == 0.0);
            p_n_y = gi_target(q, y);
        }
        var p_n_own = 0.0;
        if has_own && combine == REUSE_PAIRWISE {
            p_n_own = gi_shifted_target(q, own_sample, g.position);
        }
        let packed = PackedReservoir(src.ucw, render_planted_m(nb.ms[n]));
        if reuse_neighbour_shifted(&c, n, packed, p_target, jacobian, p_n_y, p_n_own, u_merge) {
            out = src;
        }
    }
    if combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // Z: the receiver and every merged pixel whose own vertex could have produced y.
        let y = gi_sample(out);
        for (var n = 0u; n < nb.k; n++) {
            let q = screen_source_vertex(nb.idx[n], temporal);
            reuse_count_z(&c, nb.ms[n], gi_shifted_target(q, y, g.position));
        }
    }
    let stored = reuse_finish(&c);
    if reuse_selected(c) == REUSE_CANONICAL {
        out = own;
    }
    gi_debug[i] += nb.k | (rejected << 16u);
    return gi_reweighted(out, stored);
}
