// Pass "shade": one shadow ray for each vertex's selected sample; radiance leaving the
// secondary vertex towards the primary = f(y) W (the pixel's path sample, PathLight), indirect
// at the primary = primary albedo x that radiance (the cosine pdf of the GI ray cancels the
// primary's cosine and 1/pi; render_throughput). A secondary vertex the reuse does not take
// (wr_reuses: glossy) gets the renderer's own light estimate (render_indirect_pixel).

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_shade(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var light = PathLight(vec3<f32>(0.0), vec3<f32>(0.0));
    var e = 0.0;
    if wr_reuses(i) {
        let res = wr_final[i];
        e = wr_estimate[i];
        let f = render_stored_light(render_reused_vertex(render_unpack_vertex(render_secondary[i])), res, e);
        let g = render_primary_vertex(i);
        let t = render_throughput(g, render_secondary_vertex(i, g));
        light = PathLight(render_shade_stored(f, res, t), render_shade_stored(f, res, vec3<f32>(1.0)));
    } else if wr_has_vertex(i) {
        light = render_indirect_pixel(i);
    }
    render_store_path_light(i, light, e);
}

// Pass "shade_direct" of the unified cache: direct light at pixel i's primary vertex = its
// emission + f(y) W of its final reservoir (item pixel_count + i) with one shadow ray; replaces
// the renderer's RIS (render_shade_direct), which a glossy primary vertex keeps
// (render_direct_pixel).
@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_shade_direct(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let item = render_params.pixel_count + i;
    if wr_has_vertex(item) && !wr_reuses(item) {
        render_direct_frame[i] = vec4<f32>(render_direct_pixel(i), 1.0);
        return;
    }
    let c = render_direct_from_stored(render_reused_vertex(render_unpack_vertex(render_gbuffer[i])), wr_final[item], render_unpack_vertex(render_secondary[i]),
                                      wr_estimate[item]);
    render_direct_frame[i] = vec4<f32>(c, 1.0);
}
