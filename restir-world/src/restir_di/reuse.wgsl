// Passes "di-temporal" and "di-spatial" (the entry point screen_reuse): each pixel (the
// canonical reservoir, reuse_self) merges the reservoirs of the neighbours screen_neighbours
// finds (last frame's pixel through last frame's camera, or spatial_k pixels in a disc); the
// stored M is the sum of the merged (capped) M.
//
// Combination (knobs.combine): the reservoir crate's reuse_* (1/M, 1/Z or pairwise MIS); light
// samples need no shift, so every Jacobian is 1. The target is render_light_target.

const SCREEN_STREAM_TEMPORAL: u32 = STREAM_DI_TEMPORAL;
const SCREEN_STREAM_SPATIAL: u32 = STREAM_DI_SPATIAL;

fn screen_m(r: StoredReservoir) -> u32 {
    return r.m;
}

fn screen_merge(i: u32, own: StoredReservoir, receiver: GVertex, temporal: bool,
                nb: ScreenNeighbours, rng: ptr<function, u32>) -> StoredReservoir {
    let g = render_reused_vertex(receiver);
    let u_own = rng_next_f32(rng);
    let own_sample = render_stored_sample(own);
    var c = reuse_begin(screen_params.knobs.combine, PackedReservoir(own.ucw, own.m),
                        render_light_target(g, own_sample), nb.k, nb.m_sum, u_own);
    var out = own;
    for (var n = 0u; n < nb.k; n++) {
        let u_merge = rng_next_f32(rng);
        let src = reuse_src[nb.idx[n]];
        let q = screen_source_vertex(nb.idx[n], temporal);
        if render_reuse_light(&c, n, src, nb.ms[n], g, q, own_sample, u_merge) {
            out = src;
        }
    }
    if screen_params.knobs.combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // Z: the receiver and every merged pixel whose own vertex could have produced y.
        let y = render_stored_sample(out);
        for (var n = 0u; n < nb.k; n++) {
            let q = render_reused_vertex(screen_source_vertex(nb.idx[n], temporal));
            reuse_count_z(&c, nb.ms[n], render_light_target(q, y));
        }
    }
    return render_reuse_store(&c, own, out);
}
