// Pass "wgi-subpath" (the entry point screen_subpath; world-restir-gi with subpath-k > 0, before
// the initial pass): sub-path reuse (Zhang & Wang 2023), the secondary vertex as a receiver.
// Each pixel's x2 resamples the light arriving at it from the path samples that this frame's
// pixels left in x2's cell of this frame's grid (cells of primary vertices: x2 finds those
// whose x1 lies where it does): up to subpath_k of them, each pixel j's x2 and the radiance
// leaving it one vertex short (RenderPathSplit.one_short: a path from x2 through it has the depth
// of the pixel's own), shifted to x2 by reconnection as restir-gi's temporal and spatial
// passes shift to x1, by the same merge (reuse_merge with restir-gi's hooks: gi_pair's target,
// Jacobian, visibility and pairwise MIS, with x2 as the receiver and j's x1 as the neighbour's
// vertex; gi_subpath_source is j's sample). The canonical sample is x2's own: x3 and
// the radiance it sends (RenderPathSplit.beyond), drawn with the cosine density at x2. The
// pixel's path sample's radiance becomes x2's own light (RenderPathSplit.direct) plus the
// resampled light reflected at x2 (render_path_radiance, which the initial pass reads).
// Candidates whose x1's shading normal is below normal_threshold against x2's are skipped;
// one whose GI ray escaped is merged with no sample (skipping it would bias the others up).
// Only diffuse vertices are reconnected (render_reuses): a glossy x2 keeps its own path; a
// candidate whose x2 is glossy is merged with no sample, as an escaped one; a glossy x3 is no
// canonical sample, and the light it sends is added as the path found it.

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_subpath(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let x2 = render_unpack_vertex(render_secondary[i]);
    if render_unpack_vertex(render_gbuffer[i]).prim == BVH_NO_HIT || x2.prim == BVH_NO_HIT
        || !render_reuses(x2) {
        return;
    }
    let split = render_load_path_split(i);
    var rng = render_rng_salted(i, STREAM_GI_TEMPORAL, SALT_GI_SUBPATH);
    let own_sample = gi_diffuse_sample(split.x3, split.x3_normal, split.beyond);
    var own = PackedReservoir(0.0, 1u);
    if split.x3_hit && !split.x3_glossy {
        own.ucw = gi_own_ucw(x2, own_sample);
    }
    let has_own = own.ucw > 0.0;
    let own_held = gi_store(own_sample, own);
    var p_own = 0.0;
    if has_own {
        p_own = gi_target(x2, own_sample);
    }
    // The candidates: pixels of x2's cell with a secondary vertex and a similar normal.
    let wanted = min(screen_params.knobs.subpath_k, SCREEN_MAX_NEIGHBOURS);
    var nb: ScreenNeighbours;
    let visit = grid_visit(x2.position, x2.normal, wanted + 1u, &rng);
    for (var n = 0u; n < visit.count && nb.k < wanted; n += visit.increment) {
        let j = grid_visited(visit, n);
        // A candidate whose GI ray escaped stays one (with no sample): leaving it out would
        // make the others' weights depend on its sample, and bias them up.
        if j == i || j >= render_params.pixel_count || (render_planted(PLANTED_SUBPATH_SKIPS_ESCAPED)
            && render_secondary[j].prim == BVH_NO_HIT) {
            continue;
        }
        let q = render_unpack_vertex(render_gbuffer[j]);
        if dot(q.shading, x2.shading) < screen_params.knobs.normal_threshold {
            continue;
        }
        nb.idx[nb.k] = j;
        nb.ms[nb.k] = 1u;
        nb.k += 1u;
    }
    let combine = screen_params.knobs.combine;
    let u_own = rng_next_f32(&rng);
    var c = reuse_begin(combine, own, p_own, nb.k, nb.k, u_own);
    let pairwise = has_own && combine == REUSE_PAIRWISE;
    var r = ReuseReceiver(x2, own_held, own_sample, pairwise, false, true, nb, 0u);
    let selected = reuse_merge(&c, &r, &rng);
    var chosen = own_sample;
    if selected != REUSE_NO_NEIGHBOUR {
        chosen = gi_sample(gi_subpath_source(selected));
    }
    let end = gi_finish(&c, x2, own_held, chosen);
    if end.canonical {
        chosen = own_sample;
    }
    var reflected = vec3<f32>(0.0);
    if split.x3_glossy {
        // x3's light as the path found it: x2 (diffuse) reflects it with its albedo.
        reflected = x2.albedo * split.beyond;
    }
    if end.stored.ucw > 0.0 {
        reflected += gi_contribution(x2, chosen) * end.stored.ucw;
    }
    render_path_radiance[i] = vec4<f32>(split.direct + reflected, render_path_radiance[i].w);
}
