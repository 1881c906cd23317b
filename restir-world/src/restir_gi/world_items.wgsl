// World-space ReSTIR GI's grid items (grid-items, restir_gi::world): items 0..pixels are the
// pixels, each at its primary vertex x1 where it has one that the reuse takes (render_reuses;
// its record: its path-sample reservoir); items pixels.. are the pool's records
// (world_pool.wgsl), the first wgi_pool_count[0] of them, each at the primary vertex it was
// resampled for.

fn grid_item(i: u32) -> GridItem {
    var item: GridItem;
    var v: GVertex;
    let pixels = render_params.pixel_count;
    if i < pixels {
        v = render_unpack_vertex(render_gbuffer[i]);
        item.present = v.prim != BVH_NO_HIT && render_reuses(v);
    } else {
        item.present = i - pixels < wgi_pool_count[0];
        if item.present {
            v = render_unpack_vertex(wgi_pool_vertices[i - pixels]);
        }
    }
    if item.present {
        item.position = v.position;
        item.normal = v.normal;
    }
    return item;
}
