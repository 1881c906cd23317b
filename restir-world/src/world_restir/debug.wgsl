// Debug views of the last frame into wr_debug (RGBA per pixel): WR_VIEW_CELLS colours each
// vertex by its grid slot, WR_VIEW_M is a heat map of log2(M) of the final reservoir (blue
// M = 1 .. red M = 2^16), WR_VIEW_OVERFLOW is red where the vertex found its bucket full
// (and kept its own reservoir), grey where it entered the grid.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_debug_view(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var c = vec3<f32>(0.0);
    let e = wr_item_slot[i];
    if wr_has_vertex(i) {
        if wr_params.debug_view == WR_VIEW_CELLS {
            if e.x < WR_FIRST_SENTINEL {
                let h = rng_pcg(e.x);
                c = vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
            }
        } else if wr_params.debug_view == WR_VIEW_M {
            let m = wr_final[i].m;
            if m > 0u {
                c = render_heat(log2(f32(m)) / 16.0);
            }
        } else {
            c = select(vec3<f32>(0.25), vec3<f32>(1.0, 0.0, 0.0), e.x == WR_FULL);
        }
    }
    wr_debug[i] = vec4<f32>(c, 1.0);
}
