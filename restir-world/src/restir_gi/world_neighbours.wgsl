// World-space ReSTIR GI's neighbour choice (module screen-neighbours of world-restir-gi): the
// path samples of the receiver's cell in the world-space grid of the pixels' primary vertices
// (grid-lookup; the cells are restir_gi::world's).
// - temporal: up to temporal_k of the items of the cell of the receiver's x1 in last frame's
//   grid: last frame's pixels and the pool's records (the temporal pass looks that grid up; its
//   sources are last frame's final reservoirs and G-buffer, then the pool's reservoirs and
//   vertices). The cell is where the surface is, whatever the camera did; the first frame
//   (history = 0) has none. With `reproject` on, the first of them is last frame's pixel that
//   saw x1 (screen_reprojected) where there is one: with a still camera that is the receiver's
//   own pixel, whose x1 is the receiver's, where a random item of the cell is another point
//   whose shift fails more often; the cell is left for disocclusions and cuts.
// - spatial: up to spatial_k items of the receiver's cell in this frame's grid (the receiver
//   itself skipped), the lookup jittered in the tangent plane by up to one cell, so that a
//   neighbouring cell is visited at times.
// A cell's items are visited every increment-th from a random offset (grid_visit); each must
// pass screen_similar (depth and normal thresholds) and hold a reservoir, its M capped at
// temporal_m_cap. The temporal pass notes where its first neighbour came from in gi_debug
// (bits 16-17: WGI_FROM_*), the debug view History, and how old its sample is (bits 18-27:
// frames since a pixel resampled it, 1 for last frame's pixels, a pooled record's age + 2; the
// history's ages are wgi_history_age), the debug view HistoryAge.

const WGI_FROM_REPROJECTED: u32 = 1u;
const WGI_FROM_CELL_PIXEL: u32 = 2u;
const WGI_FROM_POOL: u32 = 3u;

fn wgi_note_origin(i: u32, n: ScreenNeighbours, reprojected: u32) {
    if n.k == 0u {
        return;
    }
    var origin = WGI_FROM_CELL_PIXEL;
    var age = 1u;
    if n.idx[0] == reprojected {
        origin = WGI_FROM_REPROJECTED;
    } else if n.idx[0] >= render_params.pixel_count {
        origin = WGI_FROM_POOL;
        age = wgi_history_age[n.idx[0] - render_params.pixel_count] + 2u;
    }
    gi_debug[i] |= (origin << 16u) | (min(age, 1023u) << 18u);
}

fn screen_neighbours(i: u32, g: GVertex, temporal: bool, rng: ptr<function, u32>) -> ScreenNeighbours {
    var n: ScreenNeighbours;
    if temporal && screen_params.history == 0u {
        return n;
    }
    let cap = max(screen_params.knobs.temporal_m_cap, 1u);
    let wanted = min(select(screen_params.knobs.spatial_k, screen_params.knobs.temporal_k, temporal),
                     SCREEN_MAX_NEIGHBOURS);
    var reprojected = RENDER_NO_PIXEL;
    if temporal && screen_params.knobs.reproject != 0u {
        reprojected = screen_reprojected(g);
        if reprojected != RENDER_NO_PIXEL {
            n.idx[0] = reprojected;
            n.ms[0] = reuse_cap_m(screen_m(reuse_src[reprojected]), cap);
            n.k = 1u;
        }
        if n.k >= wanted {
            wgi_note_origin(i, n, reprojected);
            return n;
        }
    }
    // This frame's cell holds the receiver too: visit one more.
    let visit = grid_visit(g.position, g.normal, wanted + select(1u, 0u, temporal), rng);
    let eye = select(render_params.camera.eye, screen_params.prev_camera.eye, temporal);
    for (var k = 0u; k < visit.count && n.k < wanted; k += visit.increment) {
        let j = grid_visited(visit, k);
        // This frame's grid also holds the pool's records, which only the temporal pass reads.
        if (!temporal && (j == i || j >= render_params.pixel_count)) || j == reprojected {
            continue;
        }
        let m = screen_m(reuse_src[j]);
        if m == 0u || !screen_similar(g, screen_source_vertex(j, temporal), eye) {
            continue;
        }
        n.idx[n.k] = j;
        let pooled = temporal && j >= render_params.pixel_count;
        n.ms[n.k] = reuse_cap_m(m, select(cap, min(cap, screen_params.knobs.pool_m_cap), pooled));
        n.k += 1u;
    }
    if temporal {
        wgi_note_origin(i, n, reprojected);
    }
    return n;
}
