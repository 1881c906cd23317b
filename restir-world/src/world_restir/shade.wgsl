// Pass "shade": one shadow ray for each vertex's selected sample; radiance leaving the
// secondary vertex towards the primary = f(y) W; indirect at the primary = primary albedo x
// that radiance (the cosine pdf of the GI ray cancels the primary's cosine and 1/pi).

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_shade(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var c = vec3<f32>(0.0);
    if wr_has_vertex(i) {
        let res = wr_final[i];
        if res.m > 0u && res.ucw > 0.0 {
            let v = render_secondary[i];
            let y = render_stored_sample(res);
            let f = wr_contribution(v, y);
            if any(f > vec3<f32>(0.0)) && render_visible_sample(v.position, v.normal, y) {
                c = render_gbuffer[i].albedo * f * res.ucw;
            }
        }
    }
    render_indirect_frame[i] = vec4<f32>(c, 1.0);
}

// Pass "shade_direct" of the unified cache: direct light at pixel i's primary vertex = its
// emission + f(y) W of its final reservoir (item pixel_count + i) with one shadow ray; replaces
// the renderer's RIS (render_shade_direct).
@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_shade_direct(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_gbuffer[i];
    var c = g.emission;
    let res = wr_final[render_params.pixel_count + i];
    if g.prim != BVH_NO_HIT && res.m > 0u && res.ucw > 0.0 {
        let y = render_stored_sample(res);
        let f = wr_contribution(g, y);
        if any(f > vec3<f32>(0.0)) && render_visible_sample(g.position, g.normal, y) {
            c += f * res.ucw;
        }
    }
    render_direct_frame[i] = vec4<f32>(c, 1.0);
}
