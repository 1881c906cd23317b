// The world-space grid's build, after grid_scatter (restir_world::grid): grid_sort_cells orders
// each cell's run by item index, then hands the sorted run to the stage's module "grid-cells"
// (fn grid_cell_sorted(start: u32, count: u32)), which may act on each cell once its list is
// final without a pass of its own (world-restir-gi's pool keeps each cell's first item).

// One invocation per inserted item whose index in its slot is 0: insertion sort of that
// cell's list (cells hold a few hundred items at most at the default projected size).
@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_sort_cells(id: Invocation) {
    let i = item_index(id);
    if i >= grid_params.items { return; }
    let e = grid_item_slot[i];
    if e.x >= GRID_FIRST_SENTINEL || e.y != 0u {
        return;
    }
    let start = grid_offsets[e.x];
    let count = grid_counters[e.x];
    for (var a = 1u; a < count; a++) {
        let key = grid_cells[start + a];
        var b = a;
        loop {
            if b == 0u {
                break;
            }
            let prev = grid_cells[start + b - 1u];
            if prev <= key {
                break;
            }
            grid_cells[start + b] = prev;
            b -= 1u;
        }
        grid_cells[start + b] = key;
    }
    grid_cell_sorted(start, count);
}
