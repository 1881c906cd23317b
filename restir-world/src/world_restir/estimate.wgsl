// The MIS estimate of a vertex from the world-space grid (kernels that look this frame's grid
// up): e, its unshadowed cosine-weighted mean incident luminance, the normaliser of the MIS
// density that follows the resampled distribution (render_light_density).

// The mean of the generate pass's estimates (wr_estimate_raw) of item `own` (none when it is
// >= wr_params.items) and of the items of v's cell in this frame's grid whose vertex faces as
// v does (normal_threshold); 0 where there are none. Those estimates come from light samples no
// reservoir sees, and the visit draws from `rng`, numbers of the caller's own: e is independent
// of the light sample and of the ray that both MIS strategies weigh with it.
fn wr_cell_estimate(v: GVertex, own: u32, rng: ptr<function, u32>) -> f32 {
    let cell = grid_visit(v.position, v.normal, wr_params.knobs.max_count, rng);
    var sum = 0.0;
    var n = 0u;
    if own < wr_params.items {
        sum = wr_estimate_raw[own];
        n = 1u;
    }
    for (var k = 0u; k < cell.count; k += cell.increment) {
        let j = grid_visited(cell, k);
        if j != own && dot(wr_vertex(j).shading, v.shading) >= wr_params.knobs.normal_threshold {
            sum += wr_estimate_raw[j];
            n += 1u;
        }
    }
    return select(0.0, sum / f32(max(n, 1u)), n > 0u);
}
