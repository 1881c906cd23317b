// The pool's flag pass (world_pool.wgsl).

@compute @workgroup_size(WORKGROUP_SIZE)
fn wgi_pool_flag(id: Invocation) {
    let i = item_index(id);
    if i >= wgi_pool_params.items {
        return;
    }
    var keep = 0u;
    let slot = grid_item_slot[i].x;
    if slot < GRID_FIRST_SENTINEL && grid_cells[grid_offsets[slot]] == i
        && wgi_record_age(i) <= wgi_pool_params.max_age {
        keep = 1u;
    }
    wgi_flags[i] = keep;
}
