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
// (reuse_neighbour_shifted), by the one merge loop (reuse_merge). Adds the merged neighbours and the rejected
// reconnections (shift or visibility failed) to gi_debug, and flags why (GI_REFUSED_*).

const SCREEN_STREAM_TEMPORAL: u32 = STREAM_GI_TEMPORAL;
const SCREEN_STREAM_SPATIAL: u32 = STREAM_GI_SPATIAL;

fn screen_m(r: GiReservoir) -> u32 {
    return gi_m(r);
}

// The receiver (reuse-merge's hooks): its vertex (x1 in the reuse passes, x2 in the sub-path
// pass), its reservoir as held and its own sample, whether pairwise MIS evaluates the
// neighbours at that sample, and its neighbours: reservoirs of reuse_src (the reuse passes) or
// each candidate pixel's own path sample (the sub-path pass, gi_subpath_source).
struct ReuseReceiver {
    g: GVertex,
    own: GiReservoir,
    own_sample: GiSample,
    pairwise: bool,
    temporal: bool,
    subpath: bool,
    nb: ScreenNeighbours,
    // Merged neighbours whose shift or visibility failed (for gi_debug).
    rejected: u32,
}

fn reuse_visit_count(r: ptr<function, ReuseReceiver>) -> u32 {
    return (*r).nb.k;
}

fn reuse_visited(r: ptr<function, ReuseReceiver>, n: u32) -> ReuseNeighbour {
    return ReuseNeighbour((*r).nb.idx[n], (*r).nb.ms[n]);
}

// Neighbour j's reservoir and the vertex it was drawn at (x1 of its pixel).
fn gi_source(r: ptr<function, ReuseReceiver>, j: u32) -> GiReservoir {
    if (*r).subpath {
        return gi_subpath_source(j);
    }
    return reuse_src[j];
}

fn gi_source_vertex(r: ptr<function, ReuseReceiver>, j: u32) -> GVertex {
    if (*r).subpath {
        return render_unpack_vertex(render_gbuffer[j]);
    }
    return screen_source_vertex(j, (*r).temporal);
}

// Pixel j's own path sample as its initial pass would hold it, for the sub-path pass: its x2
// and the radiance leaving it one vertex short (W = pi / cos, 0: none; M = 1); no sample where
// j's ray escaped or its x2 is glossy.
fn gi_subpath_source(j: u32) -> GiReservoir {
    let y2 = render_unpack_vertex(render_secondary[j]);
    if y2.prim == BVH_NO_HIT || !render_reuses(y2) {
        return GiReservoir();
    }
    let split = render_load_path_split(j);
    var radiance = split.one_short;
    if render_planted(PLANTED_SUBPATH_FULL_DEPTH) {
        // The defect: j's radiance at its full depth (one vertex too deep here).
        radiance = split.direct + y2.albedo * split.beyond;
    }
    let y = gi_diffuse_sample(y2.position, y2.normal, radiance);
    let q = render_unpack_vertex(render_gbuffer[j]);
    return gi_store(y, PackedReservoir(gi_own_ucw(q, y), 1u));
}

fn reuse_merge_one(c: ptr<function, Reuse>, n: u32, r: ptr<function, ReuseReceiver>,
                   nb: ReuseNeighbour, u: f32) -> bool {
    let src = gi_source(r, nb.j);
    let pair = gi_pair((*r).g, (*r).own, (*r).pairwise, gi_source_vertex(r, nb.j), src);
    (*r).rejected += select(0u, 1u, gi_has_sample(src) && pair.p_target == 0.0);
    let packed = PackedReservoir(src.ucw, render_planted_m(nb.m));
    return reuse_neighbour_shifted(c, n, packed, pair.p_target, pair.jacobian, pair.p_n_y,
                                   pair.p_n_own, u);
}

fn reuse_z_target(r: ptr<function, ReuseReceiver>, nb: ReuseNeighbour, chosen: u32) -> f32 {
    var y = (*r).own_sample;
    if chosen != REUSE_NO_NEIGHBOUR {
        y = gi_sample(gi_source(r, chosen));
    }
    // The sub-path pass's candidates hold no reservoir of their own at their x1.
    var holds = GiReservoir();
    if !(*r).subpath {
        holds = reuse_src[nb.j];
    }
    return gi_shifted_target(gi_source_vertex(r, nb.j), holds, y, (*r).g.position);
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
    let pairwise = has_own && combine == REUSE_PAIRWISE;
    var r = ReuseReceiver(g, own, own_sample, pairwise, temporal, false, nb, 0u);
    let chosen = reuse_merge(&c, &r, rng);
    var out = own;
    if chosen != REUSE_NO_NEIGHBOUR {
        out = reuse_src[chosen];
    }
    let end = gi_finish(&c, g, own, gi_sample(out));
    if end.canonical {
        out = own;
    }
    let rejected = r.rejected + select(0u, 1u, end.occluded);
    gi_debug[i] += nb.k | (rejected << 8u);
    gi_debug[i] |= select(0u, GI_REFUSED_SHIFT, r.rejected > 0u)
        | select(0u, GI_REFUSED_OCCLUDED, end.occluded);
    return gi_reweighted(out, end.stored);
}
