// The neighbours one screen-space reuse pass merges into a receiver (the canonical reservoir,
// reuse_self), among the pixels whose reservoirs are reuse_src, each passing screen_similar
// (depth within depth_threshold, shading normals within normal_threshold):
// - temporal: the one pixel of last frame's image that sees the receiver's primary hit through
//   last frame's camera (render_project), tested against last frame's G-buffer
//   (screen_prev_gbuffer) from last frame's eye. A disocclusion, a camera cut or the first frame
//   (history = 0) gives none.
// - spatial: spatial_k pixels drawn uniformly in a disc of spatial_radius pixels around the
//   receiver (this frame's temporal output); the receiver itself and empty pixels are skipped.
// Each neighbour's M is capped at temporal_m_cap.
//
// The entry point screen_reuse is the pass: a receiver with no primary hit or no reservoir
// (M = 0) keeps its own; any other merges its neighbours by the stage's screen_merge (the
// stage's target and shift) and writes reuse_out. The stage supplies:
// - `fn screen_m(r: R) -> u32`: the confidence M of a reservoir R of its own type;
// - `fn screen_merge(i: u32, own: R, g: GVertex, temporal: bool, nb: ScreenNeighbours,
//   rng: ptr<function, u32>) -> R`: receiver i's reservoir after merging nb;
// - `const SCREEN_STREAM_TEMPORAL` and `SCREEN_STREAM_SPATIAL`: the random streams of its
//   passes.

struct ScreenNeighbours {
    // The merged pixels and their capped M; the first k are set.
    idx: array<u32, SCREEN_MAX_NEIGHBOURS>,
    ms: array<u32, SCREEN_MAX_NEIGHBOURS>,
    k: u32,
    // The sum of the k capped M (saturating, as reservoir_add_m).
    m_sum: u32,
}

// The primary vertex that produced source reservoir j (last frame's in the temporal pass).
fn screen_source_vertex(j: u32, temporal: bool) -> GVertex {
    if temporal {
        return screen_prev_gbuffer[j];
    }
    return render_gbuffer[j];
}

// The neighbours of receiver i (primary vertex g) in this pass; the spatial pass draws its
// pixels from rng.
fn screen_neighbours(i: u32, g: GVertex, temporal: bool, rng: ptr<function, u32>) -> ScreenNeighbours {
    var n: ScreenNeighbours;
    let cap = max(screen_params.knobs.temporal_m_cap, 1u);
    if temporal {
        if screen_params.history != 0u {
            let j = render_project(screen_params.prev_camera, g.position);
            if j != RENDER_NO_PIXEL {
                let m = screen_m(reuse_src[j]);
                if m > 0u && screen_similar(g, screen_prev_gbuffer[j], screen_params.prev_camera.eye) {
                    n.idx[0] = j;
                    n.ms[0] = reuse_cap_m(m, cap);
                    n.k = 1u;
                }
            }
        }
    } else {
        let count = min(screen_params.knobs.spatial_k, SCREEN_MAX_NEIGHBOURS);
        for (var s = 0u; s < count; s++) {
            let j = render_disc_neighbour(i, screen_params.knobs.spatial_radius, rng);
            if j == RENDER_NO_PIXEL {
                continue;
            }
            let m = screen_m(reuse_src[j]);
            if j == i || m == 0u || !screen_similar(g, render_gbuffer[j], render_params.camera.eye) {
                continue;
            }
            n.idx[n.k] = j;
            n.ms[n.k] = reuse_cap_m(m, cap);
            n.k += 1u;
        }
    }
    for (var s = 0u; s < n.k; s++) {
        n.m_sum = reservoir_add_m(n.m_sum, n.ms[s]);
    }
    return n;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_reuse(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let own = reuse_self[i];
    let g = render_gbuffer[i];
    if g.prim == BVH_NO_HIT || screen_m(own) == 0u {
        reuse_out[i] = own;
        return;
    }
    let temporal = reuse_pass.temporal != 0u;
    var rng = render_rng(i, select(SCREEN_STREAM_SPATIAL, SCREEN_STREAM_TEMPORAL, temporal));
    let nb = screen_neighbours(i, g, temporal, &rng);
    reuse_out[i] = screen_merge(i, own, g, temporal, nb, &rng);
}
