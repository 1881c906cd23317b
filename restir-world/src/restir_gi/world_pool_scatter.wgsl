// The pool's scatter pass (world_pool.wgsl).

@compute @workgroup_size(WORKGROUP_SIZE)
fn wgi_pool_scatter(id: Invocation) {
    let i = item_index(id);
    let p = wgi_pool_params;
    if i >= p.items {
        return;
    }
    if i == p.items - 1u {
        let wanted = wgi_positions[i] + wgi_flags[i];
        wgi_pool_count[0] = min(wanted, p.capacity);
        wgi_pool_count[1] = wanted;
    }
    let k = wgi_positions[i];
    let kept = wgi_flags[i] != 0u;
    wgi_flags[i] = 0u;
    if !kept || k >= p.capacity {
        return;
    }
    for (var w = 0u; w < p.reservoir_words; w++) {
        wgi_pool_reservoirs[k * p.reservoir_words + w] = wgi_history_reservoirs[i * p.reservoir_words + w];
    }
    for (var w = 0u; w < WGI_VERTEX_WORDS; w++) {
        var word: u32;
        if i < p.pixels {
            word = wgi_history_vertices[i * WGI_VERTEX_WORDS + w];
        } else {
            word = wgi_history_pool_vertices[(i - p.pixels) * WGI_VERTEX_WORDS + w];
        }
        wgi_pool_vertices[k * WGI_VERTEX_WORDS + w] = word;
    }
    wgi_pool_age[k] = wgi_record_age(i);
}
