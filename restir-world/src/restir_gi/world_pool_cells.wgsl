// World-space ReSTIR GI's pool flags (world_pool.wgsl), set by the grid's sort pass as each
// cell's list becomes final (grid::CellHook): the cell's first item is kept when its age is at
// most max_age. The ages are the pool's own (wgi_pool_age), which the pool's step copies into
// the history's after this build; the flags of every other item are 0 (the pool's scatter
// clears them after reading).

fn grid_cell_sorted(start: u32, count: u32) {
    let first = grid_cells[start];
    let p = wgi_pool_params;
    var age = 0u;
    if first >= p.pixels {
        age = wgi_pool_age[first - p.pixels] + 1u;
    }
    if age <= p.max_age {
        wgi_flags[first] = 1u;
    }
}
