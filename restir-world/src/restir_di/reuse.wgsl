// Passes "di-temporal" and "di-spatial": each pixel (the canonical reservoir, di_self) merges
// reservoirs of other pixels (di_src) that pass the similarity test di_similar (depth within
// depth_threshold, shading normals within normal_threshold):
// - temporal: the one pixel of last frame's image that sees the receiver's primary hit
//   through last frame's camera (di_project), tested against last frame's G-buffer
//   (di_prev_gbuffer) from last frame's eye; its M capped at temporal_m_cap. A disocclusion, a
//   camera cut or the first frame (history = 0) merges nothing.
// - spatial: spatial_k pixels drawn uniformly in a disc of spatial_radius pixels around the
//   receiver (this frame's temporal output), each M capped at temporal_m_cap.
// Writes di_out; the stored M is the sum of the merged (capped) M.
//
// Combination weights (di_params.combine), as world-restir's reuse.wgsl:
// - DI_COMBINE_BIASED, the paper's 1/M: W = w_sum / (M p_hat(y)); darkens where a neighbour
//   could not have produced a sample the receiver can use.
// - DI_COMBINE_PAIRWISE, pairwise MIS with confidence weights (Bitterli 2022 / Wyman et al.
//   2023): merged neighbour n shares s_n = (M_n + M_c / k) / T of the unit MIS mass with the
//   canonical reservoir by a two-strategy balance heuristic on confidences M_n and M_c / k
//   (T = M_c + sum M_n). Unbiased. Cost: two more target evaluations per neighbour (the
//   neighbour's target at its own sample and at the canonical sample) than 1/M's one, no ray.


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
    let own = di_self[i];
    let g = render_gbuffer[i];
    if g.prim == BVH_NO_HIT || own.m == 0u {
        di_out[i] = own;
        return;
    }
    let temporal = di_pass.temporal != 0u;
    var rng = di_rng(i, select(DI_PASS_SPATIAL, DI_PASS_TEMPORAL, temporal));
    let cap = max(di_params.temporal_m_cap, 1u);

    // The merged neighbours and their capped M.
    var idx: array<u32, DI_MAX_NEIGHBOURS>;
    var ms: array<u32, DI_MAX_NEIGHBOURS>;
    var k = 0u;
    if temporal {
        if di_params.history != 0u {
            let j = di_project(di_params.prev_camera, g.position);
            if j != DI_NO_PIXEL {
                let m = di_src[j].m;
                if m > 0u && di_similar(g, di_prev_gbuffer[j], di_params.prev_camera.eye) {
                    idx[0] = j;
                    ms[0] = min(m, cap);
                    k = 1u;
                }
            }
        }
    } else {
        let cam = render_params.camera;
        let x = f32(i % cam.width);
        let y = f32(i / cam.width);
        let count = min(di_params.spatial_k, DI_MAX_NEIGHBOURS);
        for (var n = 0u; n < count; n++) {
            let radius = di_params.spatial_radius * sqrt(rng_next_f32(&rng));
            let phi = 6.28318530717959 * rng_next_f32(&rng);
            let nx = floor(x + 0.5 + radius * cos(phi));
            let ny = floor(y + 0.5 + radius * sin(phi));
            if !(nx >= 0.0 && nx < f32(cam.width) && ny >= 0.0 && ny < f32(cam.height)) {
                continue;
            }
            let j = u32(ny) * cam.width + u32(nx);
            let m = di_src[j].m;
            if j == i || m == 0u || !di_similar(g, render_gbuffer[j], cam.eye) {
                continue;
            }
            idx[k] = j;
            ms[k] = min(m, cap);
            k += 1u;
        }
    }

    let u_own = rng_next_f32(&rng);
    let own_sample = render_stored_sample(own);
    let p_own = di_target(g, own_sample);
    var m_total = own.m;
    for (var n = 0u; n < k; n++) {
        m_total = reservoir_add_m(m_total, ms[n]);
    }
    var r = reservoir_empty();
    var chosen = own;
    var chosen_p_hat = 0.0;
    if di_params.combine == DI_COMBINE_PAIRWISE {
        let total = f32(m_total);
        let m_c = f32(own.m) / f32(max(k, 1u));
        var canonical = select(0.0, 1.0, k == 0u);
        for (var n = 0u; n < k; n++) {
            let u_merge = rng_next_f32(&rng);
            let src = di_src[idx[n]];
            let q = di_source_vertex(idx[n], temporal);
            let y = render_stored_sample(src);
            let p_here = di_target(g, y);
            let w = render_pairwise_mis(f32(ms[n]), m_c, total, di_target(q, y), p_here,
                                        di_target(q, own_sample), p_own);
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
        reservoir_merge(&r, reservoir_unpack(PackedReservoir(own.ucw, own.m), i), p_own, u_own);
        chosen_p_hat = p_own;
        for (var n = 0u; n < k; n++) {
            let u_merge = rng_next_f32(&rng);
            let src = di_src[idx[n]];
            let p_here = di_target(g, render_stored_sample(src));
            if reservoir_merge(&r, reservoir_unpack(PackedReservoir(src.ucw, ms[n]), idx[n]), p_here, u_merge) {
                chosen = src;
                chosen_p_hat = p_here;
            }
        }
    }
    reservoir_finalize(&r, chosen_p_hat);
    var out = chosen;
    out.ucw = r.ucw;
    out.m = m_total;
    di_out[i] = out;
}
