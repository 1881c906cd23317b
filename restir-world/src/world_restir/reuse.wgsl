// Passes "temporal" and "spatial" (paper Algorithm 3): each vertex merges its own reservoir
// (wr_self) and a stochastic subset of up to max_count reservoirs (wr_src) of the cell it falls
// in, looked up (jittered) in a grid bound in gpu-hash's lookup role with its compact cell
// storage (wr_lookup_offsets, wr_lookup_cells): last frame's grid, eye and reservoirs for the
// temporal pass (at most temporal_m_cap of M taken from last frame in total), this frame's for
// the spatial passes (ping-pong wr_self -> wr_out). Reservoirs whose generating normal differs
// from the receiver's beyond normal_threshold (cosine) are skipped. Writes wr_out.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_reuse(@builtin(global_invocation_id) gid: vec3<u32>,
            @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * WORKGROUP_SIZE;
    if i >= render_params.pixel_count {
        return;
    }
    let own = wr_self[i];
    if !wr_has_vertex(i) {
        wr_out[i] = own;
        return;
    }
    let v = render_secondary[i];
    let temporal = wr_pass.temporal != 0u;
    var rng = wr_rng(i, select(WR_PASS_SPATIAL, WR_PASS_TEMPORAL, temporal), wr_pass.pass_index);
    var r = reservoir_empty();
    var chosen = own;
    var chosen_p_hat = 0.0;
    if own.m > 0u {
        let p_hat = wr_target(v, wr_light_sample(own));
        reservoir_merge(&r, reservoir_unpack(PackedReservoir(own.ucw, own.m), i), p_hat,
                        rng_next_f32(&rng));
        chosen_p_hat = p_hat;
    }
    var pos = v.position;
    let u = vec2<f32>(rng_next_f32(&rng), rng_next_f32(&rng));
    if wr_params.jitter != 0u {
        pos = hash_jitter(pos, v.normal, u, hash_cell_size(hash_lookup_params, pos));
    }
    let slot = hash_lookup_position(pos);
    if hash_lookup_is_slot(slot) {
        let count = hash_lookup_slot_count(slot);
        let start = wr_lookup_offsets[slot];
        let max_count = max(wr_params.max_count, 1u);
        let increment = max((count + max_count - 1u) / max_count, 1u);
        let offset = rng_next_u32(&rng) % increment;
        // Temporal: the M taken from last frame is capped at temporal_m_cap in total, split
        // over the (at most max_count) reservoirs this lookup visits.
        let visited = (count + increment - 1u) / increment;
        let cap = max(wr_params.temporal_m_cap / max(visited, 1u), 1u);
        for (var k = 0u; k < count; k += increment) {
            let j = wr_lookup_cells[start + (k + offset) % count];
            let u_merge = rng_next_f32(&rng);
            if !temporal && j == i {
                continue; // the vertex's own reservoir is already in
            }
            let n = wr_src[j];
            if n.m == 0u || dot(n.vertex_normal, v.normal) < wr_params.normal_threshold {
                continue;
            }
            var other = reservoir_unpack(PackedReservoir(n.ucw, n.m), j);
            if temporal {
                reservoir_cap_m(&other, cap);
            }
            let p_hat = wr_target(v, wr_light_sample(n));
            if reservoir_merge(&r, other, p_hat, u_merge) {
                chosen = n;
                chosen_p_hat = p_hat;
            }
        }
    }
    reservoir_finalize(&r, chosen_p_hat);
    var out = chosen;
    let packed = reservoir_pack(r);
    out.ucw = packed.ucw;
    out.m = packed.m;
    out.vertex_normal = v.normal;
    wr_out[i] = out;
}
