// Pass "di-shade": direct light at the primary vertex = emission seen + f(y) W for the final
// reservoir's sample y with one shadow ray -> render_direct_frame (what the renderer's
// render_shade_direct writes otherwise).

@compute @workgroup_size(WORKGROUP_SIZE)
fn di_shade(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_gbuffer[i];
    var c = g.emission;
    if g.prim != BVH_NO_HIT {
        let res = di_final[i];
        if res.m > 0u && res.ucw > 0.0 {
            let y = render_stored_sample(res);
            let f = di_contribution(g, y);
            if any(f > vec3<f32>(0.0)) && render_visible_sample(g.position, g.normal, y) {
                c += f * res.ucw;
            }
        }
    }
    render_direct_frame[i] = vec4<f32>(c, 1.0);
}
