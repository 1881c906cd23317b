// Passes "temporal" and "spatial" (paper Algorithm 3): each vertex (the canonical reservoir,
// wr_self) merges a stochastic subset of up to max_count reservoirs (wr_src) of the cell it
// falls in, looked up (jittered) in a grid bound in gpu-hash's lookup role with its compact cell
// storage (wr_lookup_offsets, wr_lookup_cells): last frame's grid, eye, reservoirs and vertices
// (wr_prev_vertices) for the temporal pass (at most temporal_m_cap of M taken from last frame in
// total), this frame's for the spatial passes (ping-pong wr_self -> wr_out). Reservoirs whose
// generating normal differs from the receiver's beyond normal_threshold (cosine) are skipped.
// Writes wr_out; the stored M is always the sum of the merged (capped) M.
//
// Combination weights (wr_params.combine):
// - WR_COMBINE_BIASED, the paper's: W = w_sum / (M p_hat(y)). A neighbour whose own target is 0
//   at a sample the receiver can use (a light behind its tangent plane) could never have
//   produced it, so 1/M darkens, and chained passes with temporal feedback compound it.
// - WR_COMBINE_ONE_OVER_Z (Bitterli et al. 2020): W = w_sum / (Z p_hat(y)), Z = the M of the
//   merged reservoirs whose own vertex has a non-zero target at the selected y. Unbiased, but a
//   neighbour's sample whose target is far larger here than where it was drawn (1/d^2 next to
//   a small light) keeps a large weight: rare, persistent fireflies.
// - WR_COMBINE_PAIRWISE (pairwise MIS with confidence weights, Bitterli 2022 / Wyman et al.
//   2023): each merged neighbour i shares a fraction s_i = (M_i + M_c/k) / T of the unit MIS
//   mass with the canonical reservoir c by a two-strategy balance heuristic with confidences
//   M_i and M_c/k (k neighbours, T = M_c + sum M_i). The weights sum to 1 everywhere the
//   canonical's target is non-zero: unbiased, and a neighbour's sample is weighted by how well
//   it could have been drawn there. W = w_sum / p_hat(y).

// The vertex that generated source reservoir j (last frame's for the temporal pass).
fn wr_source_vertex(j: u32, temporal: bool) -> GVertex {
    if temporal {
        return wr_prev_vertices[j];
    }
    return wr_vertex(j);
}

// The cell's visited subset: `count` reservoirs from `start`, every `increment`-th from
// `offset`, and the temporal M cap of each.
struct WrVisit {
    count: u32,
    start: u32,
    increment: u32,
    offset: u32,
    cap: u32,
}

fn wr_visit(v: GVertex, rng: ptr<function, u32>) -> WrVisit {
    var s = WrVisit(0u, 0u, 1u, 0u, 0u);
    var pos = v.position;
    let u = vec2<f32>(rng_next_f32(rng), rng_next_f32(rng));
    if wr_params.jitter != 0u {
        pos = hash_jitter(pos, v.normal, u, hash_cell_size(hash_lookup_params, pos));
    }
    let slot = hash_lookup_position(pos);
    if hash_lookup_is_slot(slot) {
        s.count = hash_lookup_slot_count(slot);
        s.start = wr_lookup_offsets[slot];
        let max_count = max(wr_params.max_count, 1u);
        s.increment = max((s.count + max_count - 1u) / max_count, 1u);
        s.offset = rng_next_u32(rng) % s.increment;
        // Temporal: the M taken from last frame is capped at temporal_m_cap in total, split
        // over the (at most max_count) reservoirs this lookup visits.
        let visited = (s.count + s.increment - 1u) / s.increment;
        s.cap = max(wr_params.temporal_m_cap / max(visited, 1u), 1u);
    }
    return s;
}

// The index of the n-th visited reservoir.
fn wr_visited(s: WrVisit, k: u32) -> u32 {
    return wr_lookup_cells[s.start + (k + s.offset) % s.count];
}

// M of source reservoir j as merged at receiver i, 0 when it is not merged (no vertex, the
// receiver itself in a spatial pass, or a normal too different).
fn wr_merged_m(i: u32, j: u32, v: GVertex, temporal: bool, cap: u32) -> u32 {
    let m = wr_src[j].m;
    if (!temporal && j == i) || m == 0u
        || dot(wr_source_vertex(j, temporal).shading, v.shading) < wr_params.normal_threshold {
        return 0u;
    }
    return select(m, min(m, cap), temporal);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_reuse(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    let own = wr_self[i];
    if !wr_has_vertex(i) {
        wr_out[i] = own;
        return;
    }
    let v = wr_vertex(i);
    let temporal = wr_pass.temporal != 0u;
    var rng = wr_rng(i, select(WR_PASS_SPATIAL, WR_PASS_TEMPORAL, temporal), wr_pass.pass_index);
    let u_own = rng_next_f32(&rng);
    let own_sample = render_stored_sample(own);
    let p_own = select(0.0, wr_target(v, own_sample), own.m > 0u);
    let visit = wr_visit(v, &rng);

    // k merged neighbours and their total confidence.
    var k = 0u;
    var m_neighbours = 0u;
    for (var n = 0u; n < visit.count; n += visit.increment) {
        let m = wr_merged_m(i, wr_visited(visit, n), v, temporal, visit.cap);
        k += select(0u, 1u, m > 0u);
        m_neighbours = reservoir_add_m(m_neighbours, m);
    }
    let m_total = reservoir_add_m(own.m, m_neighbours);

    var r = reservoir_empty();
    var chosen = own;
    var chosen_p_hat = 0.0;
    let pairwise = wr_params.combine == WR_COMBINE_PAIRWISE;
    if pairwise {
        let total = f32(m_total);
        let m_c = f32(own.m) / f32(max(k, 1u));
        var canonical = select(0.0, 1.0, k == 0u);
        for (var n = 0u; n < visit.count; n += visit.increment) {
            let j = wr_visited(visit, n);
            let u_merge = rng_next_f32(&rng);
            let m = wr_merged_m(i, j, v, temporal, visit.cap);
            if m == 0u {
                continue;
            }
            let src = wr_src[j];
            let vj = wr_source_vertex(j, temporal);
            let y = render_stored_sample(src);
            let p_here = wr_target(v, y);
            let w = render_pairwise_mis(f32(m), m_c, total, wr_target(vj, y), p_here,
                                        wr_target(vj, own_sample), p_own);
            canonical += w.y;
            if reservoir_update(&r, w.x * p_here * src.ucw, u_merge) {
                chosen = src;
                chosen_p_hat = p_here;
            }
        }
        if reservoir_update(&r, canonical * p_own * own.ucw, u_own) {
            chosen = own;
            chosen_p_hat = p_own;
        }
        r.m = 1u;
    } else {
        if own.m > 0u {
            reservoir_merge(&r, reservoir_unpack(PackedReservoir(own.ucw, own.m), i), p_own, u_own);
            chosen_p_hat = p_own;
        }
        for (var n = 0u; n < visit.count; n += visit.increment) {
            let j = wr_visited(visit, n);
            let u_merge = rng_next_f32(&rng);
            let m = wr_merged_m(i, j, v, temporal, visit.cap);
            if m == 0u {
                continue;
            }
            let src = wr_src[j];
            let p_here = wr_target(v, render_stored_sample(src));
            var other = reservoir_unpack(PackedReservoir(src.ucw, src.m), j);
            other.m = m;
            if reservoir_merge(&r, other, p_here, u_merge) {
                chosen = src;
                chosen_p_hat = p_here;
            }
        }
        if wr_params.combine == WR_COMBINE_ONE_OVER_Z && chosen_p_hat > 0.0 {
            // Z: the receiver (its target at y is chosen_p_hat > 0) and every merged
            // reservoir whose own vertex could have produced y.
            let y = render_stored_sample(chosen);
            var z = own.m;
            for (var n = 0u; n < visit.count; n += visit.increment) {
                let j = wr_visited(visit, n);
                let m = wr_merged_m(i, j, v, temporal, visit.cap);
                if m > 0u && wr_target(wr_source_vertex(j, temporal), y) > 0.0 {
                    z = reservoir_add_m(z, m);
                }
            }
            r.m = z;
        }
    }
    reservoir_finalize(&r, chosen_p_hat);
    var out = chosen;
    out.ucw = reservoir_pack(r).ucw;
    out.m = m_total;
    wr_out[i] = out;
}
