// Passes "di-temporal" and "di-spatial": each pixel (the canonical reservoir, reuse_self) merges
// reservoirs of other pixels (reuse_src) that pass the similarity test di_similar (depth within
// depth_threshold, shading normals within normal_threshold):
// - temporal: the one pixel of last frame's image that sees the receiver's primary hit
//   through last frame's camera (render_project), tested against last frame's G-buffer
//   (di_prev_gbuffer) from last frame's eye; its M capped at temporal_m_cap. A disocclusion, a
//   camera cut or the first frame (history = 0) merges nothing.
// - spatial: spatial_k pixels drawn uniformly in a disc of spatial_radius pixels around the
//   receiver (this frame's temporal output), each M capped at temporal_m_cap.
// Writes reuse_out; the stored M is the sum of the merged (capped) M.
//
// Combination (di_params.knobs.combine): the reservoir crate's reuse_* (1/M, 1/Z or pairwise
// MIS); light samples need no shift, so every Jacobian is 1. The target is render_light_target.

// The vertex that produced source reservoir j (last frame's in the temporal pass).
fn di_source_vertex(j: u32, temporal: bool) -> GVertex {
    if temporal {
        return di_prev_gbuffer[j];
    }
    return render_gbuffer[j];
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn di_reuse(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let own = reuse_self[i];
    let g = render_gbuffer[i];
    if g.prim == BVH_NO_HIT || own.m == 0u {
        reuse_out[i] = own;
        return;
    }
    let temporal = reuse_pass.temporal != 0u;
    var rng = render_rng(i, select(STREAM_DI_SPATIAL, STREAM_DI_TEMPORAL, temporal));
    let cap = max(di_params.knobs.temporal_m_cap, 1u);

    // The merged neighbours and their capped M.
    var idx: array<u32, DI_MAX_NEIGHBOURS>;
    var ms: array<u32, DI_MAX_NEIGHBOURS>;
    var k = 0u;
    if temporal {
        if di_params.history != 0u {
            let j = render_project(di_params.prev_camera, g.position);
            if j != RENDER_NO_PIXEL {
                let m = reuse_src[j].m;
                if m > 0u && di_similar(g, di_prev_gbuffer[j], di_params.prev_camera.eye) {
                    idx[0] = j;
                    ms[0] = reuse_cap_m(m, cap);
                    k = 1u;
                }
            }
        }
    } else {
        let count = min(di_params.knobs.spatial_k, DI_MAX_NEIGHBOURS);
        for (var n = 0u; n < count; n++) {
            let j = render_disc_neighbour(i, di_params.knobs.spatial_radius, &rng);
            if j == RENDER_NO_PIXEL {
                continue;
            }
            let m = reuse_src[j].m;
            if j == i || m == 0u || !di_similar(g, render_gbuffer[j], render_params.camera.eye) {
                continue;
            }
            idx[k] = j;
            ms[k] = reuse_cap_m(m, cap);
            k += 1u;
        }
    }

    let u_own = rng_next_f32(&rng);
    let own_sample = render_stored_sample(own);
    var m_neighbours = 0u;
    for (var n = 0u; n < k; n++) {
        m_neighbours = reservoir_add_m(m_neighbours, ms[n]);
    }
    var c = reuse_begin(di_params.knobs.combine, PackedReservoir(own.ucw, own.m),
                        render_light_target(g, own_sample), k, m_neighbours, u_own);
    var out = own;
    for (var n = 0u; n < k; n++) {
        let u_merge = rng_next_f32(&rng);
        let src = reuse_src[idx[n]];
        let q = di_source_vertex(idx[n], temporal);
        if render_reuse_light(&c, n, src, ms[n], g, q, own_sample, u_merge) {
            out = src;
        }
    }
    if di_params.knobs.combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // Z: the receiver and every merged pixel whose own vertex could have produced y.
        let y = render_stored_sample(out);
        for (var n = 0u; n < k; n++) {
            reuse_count_z(&c, ms[n], render_light_target(di_source_vertex(idx[n], temporal), y));
        }
    }
    reuse_out[i] = render_reuse_store(&c, own, out);
}
