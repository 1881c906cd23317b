// Pass "build" step 1 (paper Algorithm 2): find_or_insert the cell of each active secondary
// vertex (adaptive size, tangent jitter) in this frame's table, count it in its slot and keep
// (slot, index in slot) per vertex in wr_vertex_slot. A full bucket leaves the vertex out of the
// grid (slot = HASH_FULL, counted by gpu-hash): it keeps its own reservoir.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_insert(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    var entry = vec2<u32>(WR_NO_SLOT, 0u);
    if wr_has_vertex(i) && wr_is_active(i, wr_params.knobs.gi_stride) {
        let v = wr_vertex(i);
        var pos = v.position;
        if wr_params.knobs.jitter != 0u {
            var rng = render_rng_salted(i, STREAM_WR_BUILD, 0u);
            let u = vec2<f32>(rng_next_f32(&rng), rng_next_f32(&rng));
            pos = hash_jitter(pos, v.normal, u, hash_cell_size(hash_params, pos));
        }
        let slot = hash_insert_position(pos);
        if hash_is_slot(slot) {
            entry = vec2<u32>(slot, hash_slot_append(slot));
        } else {
            entry = vec2<u32>(slot, 0u);
        }
    }
    wr_vertex_slot[i] = entry;
}
