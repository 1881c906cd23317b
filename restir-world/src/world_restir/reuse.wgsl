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
// Combination (wr_params.knobs.combine): the reservoir crate's reuse_* (1/M, 1/Z or pairwise MIS);
// light samples need no shift, so every Jacobian is 1. The target is render_light_target.

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
    let visit = wr_visit(v, &rng);

    // k merged neighbours and their total confidence.
    var k = 0u;
    var m_neighbours = 0u;
    for (var n = 0u; n < visit.cell.count; n += visit.cell.increment) {
        let m = wr_merged_m(i, grid_visited(visit.cell, n), v, temporal, visit.cap);
        k += select(0u, 1u, m > 0u);
        m_neighbours = reservoir_add_m(m_neighbours, m);
    }

    var c = reuse_begin(wr_params.knobs.combine, PackedReservoir(own.ucw, own.m), p_own, k,
                        m_neighbours, u_own);
    var out = own;
    for (var n = 0u; n < visit.cell.count; n += visit.cell.increment) {
        let j = grid_visited(visit.cell, n);
        let u_merge = rng_next_f32(&rng);
        let m = wr_merged_m(i, j, v, temporal, visit.cap);
        if m == 0u {
            continue;
        }
        let src = reuse_src[j];
        if render_reuse_light(&c, j, src, m, v, wr_source_vertex(j, temporal), own_sample, u_merge) {
            out = src;
        }
    }
    if wr_params.knobs.combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // Z: the receiver and every merged reservoir whose own vertex could have produced y.
        let y = render_stored_sample(out);
        for (var n = 0u; n < visit.cell.count; n += visit.cell.increment) {
            let j = grid_visited(visit.cell, n);
            let m = wr_merged_m(i, j, v, temporal, visit.cap);
            if m > 0u {
                let q = render_reused_vertex(wr_source_vertex(j, temporal));
                reuse_count_z(&c, m, render_light_target(q, y));
            }
        }
    }
    reuse_out[i] = render_reuse_store(&c, own, out);
}
