// The reuse pass every screen-space stage shares (the entry point screen_reuse): a receiver
// with no primary hit or no reservoir (M = 0) keeps its own; any other merges the neighbours
// its stage's neighbour choice (`fn screen_neighbours`, module screen-neighbours: the pixels of a
// disc and last frame's reprojected pixel, neighbours.wgsl, or a stage's own) finds, by the
// stage's screen_merge (its target and shift), and writes reuse_out. The stage supplies:
// - `fn screen_m(r: R) -> u32`: the confidence M of a reservoir R of its own type;
// - `fn screen_merge(i: u32, own: R, g: GVertex, temporal: bool, nb: ScreenNeighbours,
//   rng: ptr<function, u32>) -> R`: receiver i's reservoir after merging nb;
// - `const SCREEN_STREAM_TEMPORAL` and `SCREEN_STREAM_SPATIAL`: the random streams of its
//   passes.
// In the temporal pass the sources (reuse_src) are last frame's final reservoirs, and a
// source's vertex is last frame's G-buffer's (screen_prev_gbuffer), or past the pixels a stage's
// pool's record's (screen_prev_pool).

struct ScreenNeighbours {
    // The merged pixels and their capped M; the first k are set.
    idx: array<u32, SCREEN_MAX_NEIGHBOURS>,
    ms: array<u32, SCREEN_MAX_NEIGHBOURS>,
    k: u32,
    // The sum of the k capped M (saturating, as reservoir_add_m; the pass adds them up).
    m_sum: u32,
}

// The primary vertex that produced source reservoir j (last frame's in the temporal pass), seen
// from the camera that saw it (a glossy vertex's target depends on its view direction).
fn screen_source_vertex(j: u32, temporal: bool) -> GVertex {
    if temporal {
        let n = render_params.pixel_count;
        var q: GVertex;
        if j >= n {
            q = render_unpack_vertex(screen_prev_pool[j - n]);
        } else {
            q = render_unpack_vertex(screen_prev_gbuffer[j]);
        }
        q.wo = normalize(screen_params.prev_camera.eye - q.position);
        return q;
    }
    return render_primary_vertex(j);
}

// Last frame's pixel that saw receiver vertex g through last frame's camera (render_project),
// when it holds a reservoir and passes screen_similar against last frame's G-buffer from last
// frame's eye; RENDER_NO_PIXEL where there is none (a disocclusion, a cut, the first frame).
fn screen_reprojected(g: GVertex) -> u32 {
    if screen_params.history == 0u {
        return RENDER_NO_PIXEL;
    }
    let j = render_project(screen_params.prev_camera, g.position);
    if j == RENDER_NO_PIXEL || screen_m(reuse_src[j]) == 0u
        || !screen_similar(g, render_unpack_vertex(screen_prev_gbuffer[j]), screen_params.prev_camera.eye) {
        return RENDER_NO_PIXEL;
    }
    return j;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_reuse(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let own = reuse_self[i];
    let g = render_primary_vertex(i);
    if g.prim == BVH_NO_HIT || screen_m(own) == 0u {
        reuse_out[i] = own;
        return;
    }
    let temporal = reuse_pass.temporal != 0u;
    var rng = render_rng(i, select(SCREEN_STREAM_SPATIAL, SCREEN_STREAM_TEMPORAL, temporal));
    var nb = screen_neighbours(i, g, temporal, &rng);
    nb.m_sum = 0u;
    for (var s = 0u; s < nb.k; s++) {
        nb.m_sum = reservoir_add_m(nb.m_sum, nb.ms[s]);
    }
    reuse_out[i] = screen_merge(i, own, g, temporal, nb, &rng);
}
