// Pass "gi-shade": indirect light at the primary vertex = f(Y) W of the final reservoir's path
// sample -> render_indirect_frame (replacing the radiance the renderer's passes left there).
// With `visibility` on, `selected` or `final`, every sample a pixel holds with weight is
// unoccluded from its x1 (its own, or one whose reconnection ray was traced), so no ray is
// traced; off (the paper's biased mode), none was, and none is. Where the reuse does not take a
// vertex (gi_reuses, gi_takes_x2), the pixel's own path stands for it: at such an x1, all of
// its indirect light (its GI ray's weight x the radiance its path found leaving x2); at an x1
// whose x2 it does not take (no sample, gi-initial), the light through that x2.

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_shade(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_primary_vertex(i);
    let r = screen_final[i];
    var c = vec3<f32>(0.0);
    if g.prim != BVH_NO_HIT {
        let x2 = render_secondary_vertex(i, g);
        let own = x2.prim != BVH_NO_HIT && (!gi_reuses(g) || !gi_takes_x2(x2));
        if own {
            c = render_throughput(g, x2) * render_path_radiance[i].xyz;
        }
        if gi_reuses(g) && gi_has_sample(r) {
            c += gi_contribution(g, gi_sample(r)) * r.ucw;
        }
    }
    render_indirect_frame[i] = vec4<f32>(c, 1.0);
}
