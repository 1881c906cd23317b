// The renderer's passes, one entry point each, all over one pixel per invocation:
// render_primary -> render_gi -> [world-space ReSTIR passes go here] -> render_shade_direct,
// render_shade_indirect -> render_accumulate.

// Camera ray with a uniform sub-pixel jitter (box filter) -> G-buffer.
@compute @workgroup_size(WORKGROUP_SIZE)
fn render_primary(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var rng = render_rng(i, STREAM_PRIMARY);
    let w = render_params.camera.width;
    let jitter = vec2<f32>(rng_next_f32(&rng), rng_next_f32(&rng));
    var ray: Ray;
    ray.origin = render_params.camera.eye;
    ray.tmin = 0.0;
    ray.dir = camera_ray_dir(render_params.camera, vec2<u32>(i % w, i / w), jitter);
    ray.tmax = RENDER_T_MAX;
    render_gbuffer[i] = render_pack_vertex(render_surface(ray.dir, trace_closest(ray)));
}

// One GI ray from each primary hit, drawn by its path step (render_path_step: cosine-weighted
// about the shading normal where diffuse) -> secondary vertex (none when the direction is
// below the geometric surface).
@compute @workgroup_size(WORKGROUP_SIZE)
fn render_gi(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    let g = render_primary_vertex(i);
    if g.prim == BVH_NO_HIT {
        var none: GVertex;
        none.prim = BVH_NO_HIT;
        render_secondary[i] = render_pack_vertex(none);
        return;
    }
    var rng = render_rng(i, STREAM_GI);
    render_secondary[i] = render_pack_vertex(render_path_step(g, &rng));
}

// Direct light at the primary vertex (render_direct_pixel).
@compute @workgroup_size(WORKGROUP_SIZE)
fn render_shade_direct(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    render_direct_frame[i] = vec4<f32>(render_direct_pixel(i), 1.0);
}

// One-bounce indirect light (render_indirect_pixel): the radiance leaving the secondary vertex
// and what the primary reflects of it.
@compute @workgroup_size(WORKGROUP_SIZE)
fn render_shade_indirect(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    render_store_path_light(i, render_indirect_pixel(i), 0.0);
}

// Bounces 2..=render_params.bounces of the path beyond the secondary vertex (render_path_pixel,
// path.wgsl), with no radiance cache.
@compute @workgroup_size(WORKGROUP_SIZE)
fn render_path(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    render_path_pixel(i);
}

// Adds this frame's direct and indirect estimates to the running sums (both scaled only in
// tests' negative controls, the frame's own images too); advances the frame.
@compute @workgroup_size(WORKGROUP_SIZE)
fn render_accumulate(id: Invocation) {
    let i = item_index(id);
    if i == 0u {
        render_state.frame += 1u;
    }
    if i >= render_params.pixel_count {
        return;
    }
    let direct = render_direct_frame[i] * select(1.0, render_params.planted_direct_scale, RENDER_PLANTED);
    let indirect = render_indirect_frame[i] * select(1.0, render_params.planted_indirect_scale, RENDER_PLANTED);
    render_direct_frame[i] = direct;
    render_indirect_frame[i] = indirect;
    render_accum_direct[i] += direct;
    render_accum_indirect[i] += indirect;
}
