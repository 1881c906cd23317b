// Passes "di-temporal" and "di-spatial" (the entry point screen_reuse): each pixel (the
// canonical reservoir, reuse_self) merges the reservoirs of the neighbours screen_neighbours
// finds (last frame's pixel through last frame's camera, or spatial_k pixels in a disc) by the
// one merge loop (reuse_merge); the stored M is the sum of the merged (capped) M.
//
// Combination (knobs.combine): the reservoir crate's reuse_* (1/M, 1/Z or pairwise MIS); light
// samples need no shift, so every Jacobian is 1. The target is render_light_target.

const SCREEN_STREAM_TEMPORAL: u32 = STREAM_DI_TEMPORAL;
const SCREEN_STREAM_SPATIAL: u32 = STREAM_DI_SPATIAL;

fn screen_m(r: StoredReservoir) -> u32 {
    return r.m;
}

// The receiver (reuse-merge's hooks): a pixel's primary vertex, its own reservoir and sample,
// and the screen neighbours found for it.
struct ReuseReceiver {
    g: GVertex,
    own: StoredReservoir,
    own_sample: LightSample,
    temporal: bool,
    nb: ScreenNeighbours,
}

fn reuse_visit_count(r: ptr<function, ReuseReceiver>) -> u32 {
    return (*r).nb.k;
}

fn reuse_visited(r: ptr<function, ReuseReceiver>, n: u32) -> ReuseNeighbour {
    return ReuseNeighbour((*r).nb.idx[n], (*r).nb.ms[n]);
}

fn reuse_merge_one(c: ptr<function, Reuse>, n: u32, r: ptr<function, ReuseReceiver>,
                   nb: ReuseNeighbour, u: f32) -> bool {
    let q = screen_source_vertex(nb.j, (*r).temporal);
    return render_reuse_light(c, n, reuse_src[nb.j], nb.m, (*r).g, q, (*r).own_sample, u);
}

fn reuse_z_target(r: ptr<function, ReuseReceiver>, nb: ReuseNeighbour, chosen: u32) -> f32 {
    var y = (*r).own_sample;
    if chosen != REUSE_NO_NEIGHBOUR {
        y = render_stored_sample(reuse_src[chosen]);
    }
    let q = screen_source_vertex(nb.j, (*r).temporal);
    return render_light_target(q, y);
}

fn screen_merge(i: u32, own: StoredReservoir, g: GVertex, temporal: bool,
                nb: ScreenNeighbours, rng: ptr<function, u32>) -> StoredReservoir {
    let u_own = rng_next_f32(rng);
    let own_sample = render_stored_sample(own);
    var c = reuse_begin(screen_params.knobs.combine, PackedReservoir(own.ucw, own.m),
                        render_light_target(g, own_sample), nb.k, nb.m_sum, u_own);
    var r = ReuseReceiver(g, own, own_sample, temporal, nb);
    let chosen = reuse_merge(&c, &r, rng);
    var out = own;
    if chosen != REUSE_NO_NEIGHBOUR {
        out = reuse_src[chosen];
    }
    return render_reuse_store(&c, own, out);
}
