// Pass "build" step 3 (paper Algorithm 2): scatter each inserted vertex's index into the
// compact cell storage at offsets[slot] + index_in_slot (offsets = exclusive scan of the slot
// counters by gpu-scan). wr_sort_cells then orders each cell's list by vertex index, so the
// grid (and the images) do not depend on the order in which the atomics ran.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_scatter(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    let e = wr_vertex_slot[i];
    if e.x < WR_FIRST_SENTINEL {
        wr_cells[wr_offsets[e.x] + e.y] = i;
    }
}

// One invocation per inserted vertex whose index in its slot is 0: insertion sort of that
// cell's list (cells hold a few hundred vertices at most at the default projected size).
@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_sort_cells(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    let e = wr_vertex_slot[i];
    if e.x >= WR_FIRST_SENTINEL || e.y != 0u {
        return;
    }
    let start = wr_offsets[e.x];
    let count = wr_counters[e.x];
    for (var a = 1u; a < count; a++) {
        let key = wr_cells[start + a];
        var b = a;
        loop {
            if b == 0u {
                break;
            }
            let prev = wr_cells[start + b - 1u];
            if prev <= key {
                break;
            }
            wr_cells[start + b] = prev;
            b -= 1u;
        }
        wr_cells[start + b] = key;
    }
}
