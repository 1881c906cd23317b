// The world-space grid's build (paper Algorithm 2), over grid_params.items items of the stage's
// module "grid-items": grid_insert finds or inserts each present item's cell (jittered with
// grid_params.jitter) in this frame's table, counts it in its slot and keeps (slot, index in
// slot) in grid_item_slot; a full bucket leaves the item out (slot = HASH_FULL, counted by
// gpu-hash). gpu-scan then turns the slot counts into offsets, grid_scatter writes each item's
// index into the compact cell storage at offsets[slot] + index, and grid_sort_cells orders each
// cell's list by item index, so the grid does not depend on the order atomics ran in.

@compute @workgroup_size(WORKGROUP_SIZE)
fn grid_insert(id: Invocation) {
    let i = item_index(id);
    if i >= grid_params.items { return; }
    var entry = vec2<u32>(GRID_NO_SLOT, 0u);
    let item = grid_item(i);
    if item.present {
        var rng = render_rng_salted(i, GRID_STREAM_BUILD, GRID_SALT_BUILD);
        var u = vec2<f32>(0.0);
        if grid_params.jitter != 0u {
            u = vec2<f32>(rng_next_f32(&rng), rng_next_f32(&rng));
        }
        let pos = grid_jittered(hash_params, item.position, item.normal, u, grid_params.jitter != 0u);
        let slot = hash_insert_cell(grid_cell(hash_params, pos, item.normal, grid_params.fold_normal != 0u));
        if hash_is_slot(slot) {
            entry = vec2<u32>(slot, hash_slot_append(slot));
        } else {
            entry = vec2<u32>(slot, 0u);
        }
    }
    grid_item_slot[i] = entry;
}
