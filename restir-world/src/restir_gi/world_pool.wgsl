// World-space ReSTIR GI's pool (restir_gi::world): one record per cell of this frame's grid,
// kept for the next frames' temporal passes, so that a surface the camera left and comes back to
// still finds its path samples. Run after the frame's reuse and persist copies, when the
// temporal pass's sources (wgi_history_*: last frame's history buffers, now this frame's) hold
// the pixels' final reservoirs and vertices (records 0..pixels) and the pool the grid was built
// with (records pixels..items, their ages in wgi_history_age).
// - the flags (world_pool_cells.wgsl, in the grid's sort pass, when the frame's grid is built):
//   an item of this frame's grid is kept when it is the first of its cell's list (lists are
//   ordered by item index: a pixel of the cell when it has one, else the oldest pool record)
//   and its age (0 for a pixel, its record's + 1 for a pool record) is at most max_age: a cell
//   the camera sees keeps a fresh record, one it does not see keeps its old one, which ages
//   out after max_age frames.
// - gpu-scan: the kept items' positions (exclusive scan of the flags), in item order, so that
//   the pool's order, and the next grid's lists, do not depend on the order threads ran in.
// - wgi_pool_scatter: each kept record to its position (those past the capacity are dropped);
//   the last item writes the count kept and the count wanted; every item clears its flag for
//   the next frame's grid, which sets only the kept items'.
// Records are copied as raw words (a reservoir of reservoir_words u32, a vertex of 16); the
// history's vertices are in two buffers, the pixels' (wgi_history_vertices) and the pool's
// (wgi_history_pool_vertices), so that each fits one storage binding at 1920x1080.

const WGI_VERTEX_WORDS: u32 = 16u;

fn wgi_record_age(i: u32) -> u32 {
    if i < wgi_pool_params.pixels {
        return 0u;
    }
    return wgi_history_age[i - wgi_pool_params.pixels] + 1u;
}
