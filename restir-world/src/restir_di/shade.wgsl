// Pass "di-shade": direct light at the primary vertex = emission seen + f(y) W for the final
// reservoir's sample y with one shadow ray -> render_direct_frame (what the renderer's
// render_shade_direct writes otherwise); the light sample and the GI ray's emission weighed with
// the pixel's estimate (di_estimate, render_light_density). A primary vertex restir-di does not
// reuse (di_reuses) gets the renderer's own (render_direct_pixel).

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_shade(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_primary_vertex(i);
    if !di_reuses(g) {
        render_direct_frame[i] = vec4<f32>(render_direct_pixel(i), 1.0);
        return;
    }
    let c = render_direct_from_stored(g, screen_final[i], render_secondary_vertex(i, g), di_estimate[i]);
    render_direct_frame[i] = vec4<f32>(c, 1.0);
}
