// The path's MIS estimate at vertex w (render/path.wgsl's "path-light"): its cell's, numbers
// drawn apart from the path's; 0 (the light table's density) with mis_candidates = 0 or without
// MIS, or at a vertex the reuse does not take (render_reuses).
fn path_light_estimate(i: u32, w: GVertex, bounce: u32) -> f32 {
    if wr_params.knobs.mis_candidates == 0u || render_params.mis == 0u || !render_reuses(w) {
        return 0.0;
    }
    var rng = render_rng_salted(i, STREAM_PATH, SALT_WR_PATH_ESTIMATE + bounce);
    return wr_cell_estimate(w, wr_params.items, &rng);
}

// The light reflected at the path's vertex w (render/path.wgsl's "path-light"): with
// path_reservoirs, the renderer's RIS reservoir at w merged with a reservoir of w's cell
// (wr_path_reservoir_light); else, and at a vertex the reuse does not take, the renderer's light
// sample.
fn path_light_nee(i: u32, w: GVertex, bounce: u32, e: f32, rng: ptr<function, u32>) -> vec3<f32> {
    if wr_params.knobs.path_reservoirs == 0u || lights_info.count == 0u || !render_reuses(w) {
        return render_nee_at(w, rng, e);
    }
    var rng_cell = render_rng_salted(i, STREAM_PATH, SALT_WR_PATH_RESERVOIR + bounce);
    return wr_path_reservoir_light(render_reused_vertex(w), e, rng, &rng_cell);
}

// World-space reservoirs at a path vertex w past the secondary one: w's own RIS reservoir
// (render_params.candidates light samples of the table, the canonical one, which covers every
// light w can see) merged with the final reservoirs (wr_final) of w's cell in this frame's grid
// that the cell visit (rng_cell, at most max_count) finds at vertices facing as w does, the
// merge of the reuse passes with the combination knob (pairwise MIS: unbiased, a neighbour's
// weight 0 where its vertex could not have drawn y, e.g. a light behind it), then one shadow
// ray for the selected sample, MIS-weighted against the ray leaving w with w's estimate e as
// every light sample is (render_light_mis_at). The cell's reservoirs are independent of this
// path (other pixels' vertices, numbers of their own), and so is e of the sample drawn here.
fn wr_path_reservoir_light(w: GVertex, e: f32, rng: ptr<function, u32>,
                           rng_cell: ptr<function, u32>) -> vec3<f32> {
    let ris = render_ris_lights(w, render_params.candidates, rng);
    let cell = grid_visit(w.position, w.normal, wr_params.knobs.max_count, rng_cell);
    // k merged neighbours and their total confidence.
    var k = 0u;
    var m_neighbours = 0u;
    for (var n = 0u; n < cell.count; n += cell.increment) {
        let m = wr_path_merged_m(grid_visited(cell, n), w);
        k += select(0u, 1u, m > 0u);
        m_neighbours = reservoir_add_m(m_neighbours, m);
    }
    var c = reuse_begin(wr_params.knobs.combine, reservoir_pack(ris.reservoir), ris.p_hat, k,
                        m_neighbours, rng_next_f32(rng_cell));
    var chosen = wr_params.items;
    for (var n = 0u; n < cell.count; n += cell.increment) {
        let j = grid_visited(cell, n);
        let u = rng_next_f32(rng_cell);
        let m = wr_path_merged_m(j, w);
        if m > 0u && render_reuse_light(&c, j, wr_final[j], m, w, wr_vertex(j), ris.light, u) {
            chosen = j;
        }
    }
    if wr_params.knobs.combine == REUSE_ONE_OVER_Z && c.p_hat > 0.0 {
        // 1/M and 1/Z merged the canonical reservoir first: the selection is final here.
        let y = wr_path_selected(c, ris.light, chosen);
        for (var n = 0u; n < cell.count; n += cell.increment) {
            let j = grid_visited(cell, n);
            let m = wr_path_merged_m(j, w);
            if m > 0u {
                reuse_count_z(&c, m, render_light_target(render_reused_vertex(wr_vertex(j)), y));
            }
        }
    }
    let stored = reuse_finish(&c);
    let y = wr_path_selected(c, ris.light, chosen);
    if !(stored.ucw > 0.0) || !render_visible_sample(w.position, w.normal, y) {
        return vec3<f32>(0.0);
    }
    var f = render_vertex_light(w, y);
    if render_params.mis != 0u {
        f *= render_light_mis_at(w, y, e);
    }
    return f * stored.ucw;
}

// M of final reservoir j as merged at path vertex w: 0 when it has none or its vertex faces
// otherwise (normal_threshold).
fn wr_path_merged_m(j: u32, w: GVertex) -> u32 {
    let m = wr_final[j].m;
    if m == 0u || dot(wr_vertex(j).shading, w.shading) < wr_params.knobs.normal_threshold {
        return 0u;
    }
    return m;
}

// The sample combination c selected: the canonical `own`, or reservoir `chosen`'s.
fn wr_path_selected(c: Reuse, own: LightSample, chosen: u32) -> LightSample {
    if reuse_selected(c) == REUSE_CANONICAL || chosen >= wr_params.items {
        return own;
    }
    return render_stored_sample(wr_final[chosen]);
}
