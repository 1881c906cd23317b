// The screen-space neighbour choice (module screen-neighbours of restir-di and restir-gi):
// the neighbours one reuse pass merges into a receiver (the canonical reservoir, reuse_self),
// among the pixels whose reservoirs are reuse_src, each passing screen_similar (depth within
// depth_threshold, shading normals within normal_threshold):
// - temporal: the one pixel of last frame's image that sees the receiver's primary hit through
//   last frame's camera (screen_reprojected). A disocclusion, a camera cut or the first frame
//   (history = 0) gives none.
// - spatial: spatial_k pixels drawn uniformly in a disc of spatial_radius pixels around the
//   receiver (this frame's temporal output); the receiver itself and empty pixels are skipped.
// Each neighbour's M is capped at temporal_m_cap.

// The neighbours of receiver i (primary vertex g) in this pass; the spatial pass draws its
// pixels from rng.
fn screen_neighbours(i: u32, g: GVertex, temporal: bool, rng: ptr<function, u32>) -> ScreenNeighbours {
    var n: ScreenNeighbours;
    let cap = max(screen_params.knobs.temporal_m_cap, 1u);
    if temporal {
        let j = screen_reprojected(g);
        if j != RENDER_NO_PIXEL {
            n.idx[0] = j;
            n.ms[0] = reuse_cap_m(screen_m(reuse_src[j]), cap);
            n.k = 1u;
        }
    } else {
        let count = min(screen_params.knobs.spatial_k, SCREEN_MAX_NEIGHBOURS);
        for (var s = 0u; s < count; s++) {
            let j = render_disc_neighbour(i, screen_params.knobs.spatial_radius, rng);
            if j == RENDER_NO_PIXEL {
                continue;
            }
            let m = screen_m(reuse_src[j]);
            if j == i || m == 0u || !screen_similar(g, render_unpack_vertex(render_gbuffer[j]), render_params.camera.eye) {
                continue;
            }
            n.idx[n.k] = j;
            n.ms[n.k] = reuse_cap_m(m, cap);
            n.k += 1u;
        }
    }
    return n;
}

