// The world-space grid's build, after the insert and gpu-scan's offsets (restir_world::grid):
// grid_scatter writes each inserted item's index into the compact cell storage at
// offsets[slot] + index in slot (grid_sort_cells, sort.wgsl, then orders each cell's run).

@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_scatter(id: Invocation) {
    let i = item_index(id);
    if i >= grid_params.items { return; }
    let e = grid_item_slot[i];
    if e.x < GRID_FIRST_SENTINEL {
        grid_cells[grid_offsets[e.x] + e.y] = i;
    }
}
