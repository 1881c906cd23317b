// Pass "path": the renderer's path beyond the secondary vertex (render/path.wgsl), each vertex's
// light sample and the ray leaving it MIS-weighted with the vertex's estimate from this frame's
// grid (wr_cell_estimate; the module "path-light"), not the light table's density, and with
// path_reservoirs each vertex's light sample resampled with one of its cell's final reservoirs.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_path(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    render_path_pixel(i);
}
