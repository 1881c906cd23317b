// Passes "gi-temporal" and "gi-spatial": each pixel (the canonical reservoir, reuse_self)
// merges reservoirs of other pixels (reuse_src) that pass the similarity test gi_similar
// (depth within depth_threshold, shading normals within normal_threshold):
// - temporal: the one pixel of last frame's image that sees the receiver's primary hit through
//   last frame's camera (render_project), tested against last frame's G-buffer from last
//   frame's eye; its M capped at temporal_m_cap. A disocclusion, a camera cut or the first
//   frame (history = 0) merges nothing.
// - spatial: spatial_k pixels drawn uniformly in a disc of spatial_radius pixels around the
//   receiver (this frame's temporal output), each M capped at temporal_m_cap.
// A neighbour's sample is shifted to the receiver by reconnection (gi_jacobian). With
// `visibility` on, targets include visibility: one ray from the receiver's x1 to the
// neighbour's x2 (an occluded sample has target 0 here), and for the MIS weights one from the
// neighbour's x1 to the receiver's own x2 (gi_shifted_target: a pixel only ever holds samples
// visible from its x1, so the neighbour could not have produced an occluded one; leaving that
// ray out darkened cornell's indirect image by 5-6%). Combination
// (knobs.combine): the reservoir crate's reuse_* with the shift's Jacobian kept apart
// (reuse_neighbour_shifted). Writes reuse_out; adds the merged neighbours and the rejected
// reconnections (shift or visibility failed) to gi_debug.

// Neighbour q's target at the receiver's sample y shifted to it from the receiver's x1 (at
// x1_own), times that shift's Jacobian, with visibility from q when `visibility` is on.
fn gi_shifted_target(q: GVertex, y: GiSample, x1_own: vec3<f32>) -> f32 {
    let j = gi_jacobian(y, x1_own, q.position);
    if j == 0.0 {
        return 0.0;
    }
    let p = gi_target(q, y) * j;
    if p > 0.0 && gi_params.knobs.visibility != 0u && !render_visible(q.position, q.normal, y.position) {
        return 0.0;
    }
    return p;
}

// The primary vertex that produced source reservoir j (last frame's in the temporal pass).
fn gi_source_vertex(j: u32, temporal: bool) -> GVertex {
    if temporal {
        return gi_prev_gbuffer[j];
    }
    return render_gbuffer[j];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gi_reuse(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let own = reuse_self[i];
    let g = render_gbuffer[i];
    if g.prim == BVH_NO_HIT || gi_m(own) == 0u {
        reuse_out[i] = own;
        return;
    }
    let temporal = reuse_pass.temporal != 0u;
    var rng = render_rng(i, select(STREAM_GI_SPATIAL, STREAM_GI_TEMPORAL, temporal));
    let cap = max(gi_params.knobs.temporal_m_cap, 1u);

    // The merged neighbours and their capped M.
    var idx: array<u32, GI_MAX_NEIGHBOURS>;
    var ms: array<u32, GI_MAX_NEIGHBOURS>;
    var k = 0u;
    if temporal {
        if gi_params.history != 0u {
            let j = render_project(gi_params.prev_camera, g.position);
            if j != RENDER_NO_PIXEL {
                let m = gi_m(reuse_src[j]);
                if m > 0u && gi_similar(g, gi_prev_gbuffer[j], gi_params.prev_camera.eye) {
                    idx[0] = j;
                    ms[0] = reuse_cap_m(m, cap);
                    k = 1u;
                }
            }
        }
    } else {
        let count = min(gi_params.knobs.spatial_k, GI_MAX_NEIGHBOURS);
        for (var n = 0u; n < count; n++) {
            let j = render_disc_neighbour(i, gi_params.knobs.spatial_radius, &rng);
            if j == RENDER_NO_PIXEL {
                continue;
            }
            let m = gi_m(reuse_src[j]);
            if j == i || m == 0u || !gi_similar(g, render_gbuffer[j], render_params.camera.eye) {
                continue;
            }
            idx[k] = j;
            ms[k] = reuse_cap_m(m, cap);
            k += 1u;
        }
    }

    let u_own = rng_next_f32(&rng);
    let has_own = gi_has_sample(own);
    let own_sample = gi_sample(own);
    var p_own = 0.0;
    if has_own {
        p_own = gi_target(g, own_sample);
    }
    var m_neighbours = 0u;
    for (var n = 0u; n < k; n++) {
        m_neighbours = reservoir_add_m(m_neighbours, ms[n]);
    }
    let combine = gi_params.knobs.combine;
    var c = reuse_begin(combine, PackedReservoir(own.ucw, gi_m(own)), p_own, k, m_neighbours, u_own);
    var out = own;
    var rejected = 0u;
    for (var n = 0u; n < k; n++) {
        let u_merge = rng_next_f32(&rng);
        let src = reuse_src[idx[n]];
        let q = gi_source_vertex(idx[n], temporal);
        let y = gi_sample(src);
        var p_target = 0.0;
        var jacobian = 0.0;
        var p_n_y = 0.0;
        if gi_has_sample(src) {
            jacobian = gi_jacobian(y, q.position, g.position);
            if jacobian > 0.0 {
                p_target = gi_target(g, y);
            }
            if p_target > 0.0 && gi_params.knobs.visibility != 0u
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
        let packed = PackedReservoir(src.ucw, render_planted_m(ms[n]));
        if reuse_neighbour_shifted(&c, n, packed, p_target, jacobian, p_n_y, p_n_own, u_merge) {
            out = src;
        }
    }
    if combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // Z: the receiver and every merged pixel whose own vertex could have produced y.
        let y = gi_sample(out);
        for (var n = 0u; n < k; n++) {
            let q = gi_source_vertex(idx[n], temporal);
            reuse_count_z(&c, ms[n], gi_shifted_target(q, y, g.position));
        }
    }
    let stored = reuse_finish(&c);
    if reuse_selected(c) == REUSE_CANONICAL {
        out = own;
    }
    reuse_out[i] = gi_reweighted(out, stored);
    gi_debug[i] += k | (rejected << 16u);
}
