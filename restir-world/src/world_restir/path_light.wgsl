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
// that the cell visit (rng_cell, at most max_count) finds at vertices facing as w does, by the
// one merge loop (reuse_merge) with the combination knob (pairwise MIS: unbiased, a
// neighbour's weight 0 where its vertex could not have drawn y, e.g. a light behind it), then
// one shadow ray for the selected sample, MIS-weighted against the ray leaving w with w's
// estimate e as every light sample is (render_light_mis_at). The cell's reservoirs are
// independent of this path (other pixels' vertices, numbers of their own), and so is e of the
// sample drawn here.
fn wr_path_reservoir_light(w: GVertex, e: f32, rng: ptr<function, u32>,
                           rng_cell: ptr<function, u32>) -> vec3<f32> {
    let ris = render_ris_lights(w, render_params.candidates, rng);
    let cell = grid_visit(w.position, w.normal, wr_params.knobs.max_count, rng_cell);
    var r = ReuseReceiver(w, ris.light, cell);
    let conf = reuse_confidence(&r);
    var c = reuse_begin(wr_params.knobs.combine, reservoir_pack(ris.reservoir), ris.p_hat, conf.k,
                        conf.m_sum, rng_next_f32(rng_cell));
    let chosen = reuse_merge(&c, &r, rng_cell);
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

// The receiver (reuse-merge's hooks): path vertex w, its own RIS sample and the visit of its
// cell in this frame's grid.
struct ReuseReceiver {
    w: GVertex,
    own_sample: LightSample,
    cell: GridVisit,
}

fn reuse_visit_count(r: ptr<function, ReuseReceiver>) -> u32 {
    return grid_visited_count((*r).cell);
}

fn reuse_visited(r: ptr<function, ReuseReceiver>, n: u32) -> ReuseNeighbour {
    let j = grid_visited((*r).cell, n * (*r).cell.increment);
    return ReuseNeighbour(j, wr_path_merged_m(j, (*r).w));
}

fn reuse_merge_one(c: ptr<function, Reuse>, n: u32, r: ptr<function, ReuseReceiver>,
                   nb: ReuseNeighbour, u: f32) -> bool {
    return render_reuse_light(c, n, wr_final[nb.j], nb.m, (*r).w, render_reused_vertex(wr_vertex(nb.j)),
                              (*r).own_sample, u);
}

fn reuse_z_target(r: ptr<function, ReuseReceiver>, nb: ReuseNeighbour, chosen: u32) -> f32 {
    var y = (*r).own_sample;
    if chosen != REUSE_NO_NEIGHBOUR {
        y = render_stored_sample(wr_final[chosen]);
    }
    return render_light_target(render_reused_vertex(wr_vertex(nb.j)), y);
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

// The sample combination c selected: the canonical `own`, or reservoir `chosen`'s
// (REUSE_NO_NEIGHBOUR: none).
fn wr_path_selected(c: Reuse, own: LightSample, chosen: u32) -> LightSample {
    if reuse_selected(c) == REUSE_CANONICAL || chosen >= wr_params.items {
        return own;
    }
    return render_stored_sample(wr_final[chosen]);
}
