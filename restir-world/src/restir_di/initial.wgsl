// Pass "di-initial": RIS over screen_params.knobs.candidates light samples at each primary vertex,
// drawn uniformly from the tile its 8x8 pixel block picked this frame (one random tile per
// block per frame: coherent memory), target = luminance of the unshadowed reflected radiance. The stored
// confidence is 1 (one frame of candidates), as RTXDI's. Writes screen_out, and the pixel's MIS
// estimate (render_light_estimate, from light samples of its own) to di_estimate. At a glossy
// vertex the target is its BRDF's towards the camera (light samples need no shift, so glossy
// vertices are reused as diffuse ones are; each receiver evaluates a neighbour's sample with its
// own BRDF and view direction). A glossy vertex below knobs.min_roughness holds no reservoir
// (M = 0: no neighbour merges it) and di-shade gives it the renderer's own direct light.

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_initial(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var out: StoredReservoir;
    let g = render_primary_vertex(i);
    di_estimate[i] = 0.0;
    if g.prim == BVH_NO_HIT || !di_reuses(g) {
        screen_out[i] = out;
        return;
    }
    out.m = 1u;
    if lights_info.count == 0u {
        screen_out[i] = out;
        return;
    }
    let first = light_tiles_first(i, screen_params.knobs.tiles, screen_params.knobs.tile_size);
    var rng = render_rng_salted(i, STREAM_DI_INITIAL, SALT_CANDIDATES);
    let ris = light_tiles_ris(g, first, screen_params.knobs.tile_size, screen_params.knobs.candidates,
                              &rng);
    out = render_store_reservoir(ris.light, PackedReservoir(ris.reservoir.ucw, 1u));
    screen_out[i] = out;
    var rng_e = render_rng_salted(i, STREAM_DI_INITIAL, SALT_ESTIMATE);
    di_estimate[i] = render_light_estimate(g, screen_params.knobs.mis_candidates, &rng_e);
}
