// Passes "temporal" and "spatial" (paper Algorithm 3): each vertex (the canonical reservoir,
// reuse_self) merges a stochastic subset of up to max_count reservoirs (reuse_src) of the cell it
// falls in, looked up (jittered) in the world-space grid (grid_visit, restir_world::grid): last
// frame's grid, eye, reservoirs and vertices
// (wr_prev_vertices, and when unified wr_prev_primary: apart, so that each fits one storage
// binding at 1920x1080) for the temporal pass (at most temporal_m_cap of M taken from last frame in
// total), this frame's for the spatial passes (ping-pong reuse_self -> reuse_out). Reservoirs whose
// generating normal differs from the receiver's beyond normal_threshold (cosine) are skipped.
// Writes reuse_out; the stored M is always the sum of the merged (capped) M.
//
// Combination (wr_params.knobs.combine): the reservoir crate's reuse_* (1/M, 1/Z or pairwise MIS),
// by the one merge loop (reuse_merge); light samples need no shift, so every Jacobian is 1. The
// target is render_light_target.

// The vertex that generated source reservoir j (last frame's for the temporal pass).
fn wr_source_vertex(j: u32, temporal: bool) -> GVertex {
    if temporal {
        let n = render_params.pixel_count;
        if j >= n {
            return render_unpack_vertex(wr_prev_primary[j - n]);
        }
        return render_unpack_vertex(wr_prev_vertices[j]);
    }
    return wr_vertex(j);
}

// The cell's visited subset (the grid's, restir_world::grid) and the temporal M cap of each
// visited reservoir.
struct WrVisit {
    cell: GridVisit,
    cap: u32,
}

fn wr_visit(v: GVertex, rng: ptr<function, u32>) -> WrVisit {
    let cell = grid_visit(v.position, v.normal, wr_params.knobs.max_count, rng);
    // Temporal: the M taken from last frame is capped at temporal_m_cap in total, split over
    // the (at most max_count) reservoirs this lookup visits.
    let cap = wr_params.knobs.temporal_m_cap * wr_params.knobs.candidates;
    return WrVisit(cell, max(cap / max(grid_visited_count(cell), 1u), 1u));
}

// M of source reservoir j as merged at receiver i, 0 when it is not merged (no vertex, the
// receiver itself in a spatial pass, or a normal too different).
fn wr_merged_m(i: u32, j: u32, v: GVertex, temporal: bool, cap: u32) -> u32 {
    let m = reuse_src[j].m;
    if (!temporal && j == i) || m == 0u
        || dot(wr_source_vertex(j, temporal).shading, v.shading) < wr_params.knobs.normal_threshold {
        return 0u;
    }
    return select(m, reuse_cap_m(m, cap), temporal);
}

// The receiver (reuse-merge's hooks): vertex i, its own reservoir and sample, and the grid
// cell's visit it merges from (last frame's grid in the temporal pass).
struct ReuseReceiver {
    i: u32,
    v: GVertex,
    own_sample: LightSample,
    temporal: bool,
    visit: WrVisit,
}

fn reuse_visit_count(r: ptr<function, ReuseReceiver>) -> u32 {
    return grid_visited_count((*r).visit.cell);
}

fn reuse_visited(r: ptr<function, ReuseReceiver>, n: u32) -> ReuseNeighbour {
    let cell = (*r).visit.cell;
    let j = grid_visited(cell, n * cell.increment);
    return ReuseNeighbour(j, wr_merged_m((*r).i, j, (*r).v, (*r).temporal, (*r).visit.cap));
}

fn reuse_merge_one(c: ptr<function, Reuse>, n: u32, r: ptr<function, ReuseReceiver>,
                   nb: ReuseNeighbour, u: f32) -> bool {
    let q = render_reused_vertex(wr_source_vertex(nb.j, (*r).temporal));
    return render_reuse_light(c, n, reuse_src[nb.j], nb.m, (*r).v, q, (*r).own_sample, u);
}

fn reuse_z_target(r: ptr<function, ReuseReceiver>, nb: ReuseNeighbour, chosen: u32) -> f32 {
    var y = (*r).own_sample;
    if chosen != REUSE_NO_NEIGHBOUR {
        y = render_stored_sample(reuse_src[chosen]);
    }
    return render_light_target(render_reused_vertex(wr_source_vertex(nb.j, (*r).temporal)), y);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_reuse(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    let own = reuse_self[i];
    let temporal = reuse_pass.temporal != 0u;
    if !wr_reuses(i) {
        reuse_out[i] = own;
        return;
    }
    let v = render_reused_vertex(wr_vertex(i));
    if !temporal && reuse_pass.pass_index == 0u && wr_params.knobs.mis_candidates > 0u
        && render_params.mis != 0u {
        var rng_e = render_rng_salted(i, STREAM_WR_SPATIAL, SALT_WR_SPATIAL_ESTIMATE);
        wr_estimate[i] = wr_cell_estimate(v, i, &rng_e);
    }
    var rng = render_rng_salted(i, select(STREAM_WR_SPATIAL, STREAM_WR_TEMPORAL, temporal),
                                SALT_WR_REUSE_PASS + reuse_pass.pass_index);
    let u_own = rng_next_f32(&rng);
    let own_sample = render_stored_sample(own);
    let p_own = select(0.0, render_light_target(v, own_sample), own.m > 0u);
    var r = ReuseReceiver(i, v, own_sample, temporal, wr_visit(v, &rng));
    let conf = reuse_confidence(&r);
    var c = reuse_begin(wr_params.knobs.combine, PackedReservoir(own.ucw, own.m), p_own, conf.k,
                        conf.m_sum, u_own);
    let chosen = reuse_merge(&c, &r, &rng);
    var out = own;
    if chosen != REUSE_NO_NEIGHBOUR {
        out = reuse_src[chosen];
    }
    reuse_out[i] = render_reuse_store(&c, own, out);
}
