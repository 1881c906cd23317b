// Passes "gi-temporal" and "gi-spatial" (the entry point screen_reuse): each pixel (the
// canonical reservoir, reuse_self) merges the reservoirs of the neighbours screen_neighbours
// finds (last frame's pixel through last frame's camera, or spatial_k pixels in a disc).
// A neighbour's sample is shifted to the receiver by reconnection (gi_jacobian). With
// `visibility=on`, targets include visibility: one ray from the receiver's x1 to the
// neighbour's x2 (an occluded sample has target 0 here), and for the MIS weights one from the
// neighbour's x1 to the receiver's own x2 (gi_shifted_target: a pixel only ever holds samples
// visible from its x1, so the neighbour could not have produced an occluded one; leaving that
// ray out darkened cornell's indirect image by 5-6%). With `selected` the first ray is traced
// for the selected sample only (gi_finish; occluded, pairwise falls back to the
// receiver's own sample), `final` traces only that one. Combination
// (knobs.combine): the reservoir crate's reuse_* with the shift's Jacobian kept apart
// (reuse_neighbour_shifted). Adds the merged neighbours and the rejected
// reconnections (shift or visibility failed) to gi_debug.

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
        let pair = gi_pair(g, own, has_own && combine == REUSE_PAIRWISE, q, src);
        rejected += select(0u, 1u, gi_has_sample(src) && pair.p_target == 0.0);
        let packed = PackedReservoir(src.ucw, render_planted_m(nb.ms[n]));
        if reuse_neighbour_shifted(&c, n, packed, pair.p_target, pair.jacobian, pair.p_n_y,
                                   pair.p_n_own, u_merge) {
            out = src;
        }
    }
    if combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // Z: the receiver and every merged pixel whose own vertex could have produced y.
        let y = gi_sample(out);
        for (var n = 0u; n < nb.k; n++) {
            let q = screen_source_vertex(nb.idx[n], temporal);
            reuse_count_z(&c, nb.ms[n], gi_shifted_target(q, reuse_src[nb.idx[n]], y, g.position));
        }
    }
    let end = gi_finish(&c, g, own, gi_sample(out));
    if end.canonical {
        out = own;
    }
    rejected += select(0u, 1u, end.occluded);
    gi_debug[i] += nb.k | (rejected << 8u);
    return gi_reweighted(out, end.stored);
}
