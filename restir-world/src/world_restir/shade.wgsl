// Pass "shade": one shadow ray for each vertex's selected sample; radiance leaving the
// secondary vertex towards the primary = f(y) W (the pixel's path sample, PathLight), indirect
// at the primary = primary albedo x that radiance (the cosine pdf of the GI ray cancels the
// primary's cosine and 1/pi).

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_shade(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var light = PathLight(vec3<f32>(0.0), vec3<f32>(0.0));
    var e = 0.0;
    if wr_has_vertex(i) {
        let res = wr_final[i];
        e = wr_estimate[i];
        let f = render_stored_light(render_unpack_vertex(render_secondary[i]), res, e);
        light = PathLight(render_shade_stored(f, res, render_unpack_vertex(render_gbuffer[i]).albedo),
                          render_shade_stored(f, res, vec3<f32>(1.0)));
    }
    render_store_path_light(i, light, e);
}

// Pass "shade_direct" of the unified cache: direct light at pixel i's primary vertex = its
// emission + f(y) W of its final reservoir (item pixel_count + i) with one shadow ray; replaces
// the renderer's RIS (render_shade_direct).
@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_shade_direct(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let item = render_params.pixel_count + i;
    let c = render_direct_from_stored(render_unpack_vertex(render_gbuffer[i]), wr_final[item], render_unpack_vertex(render_secondary[i]),
                                      wr_estimate[item]);
    render_direct_frame[i] = vec4<f32>(c, 1.0);
}
