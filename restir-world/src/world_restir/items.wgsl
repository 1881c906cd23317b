// The grid's items (grid-items, restir_world::grid): item i enters the grid where it has a
// vertex the reuse takes (wr_reuses) that generates a reservoir this frame (wr_is_active), at that vertex.

fn grid_item(i: u32) -> GridItem {
    var item: GridItem;
    item.present = wr_reuses(i) && wr_is_active(i, wr_params.knobs.gi_stride);
    if item.present {
        let v = wr_vertex(i);
        item.position = v.position;
        item.normal = v.normal;
    }
    return item;
}
