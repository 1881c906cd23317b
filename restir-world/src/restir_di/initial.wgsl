// Pass "di-initial": RIS over di_params.candidates light samples at each primary vertex, drawn
// uniformly from the tile its 8x8 pixel block picked this frame (one random tile per block per
// frame: coherent memory), target = luminance of the unshadowed reflected radiance. The stored
// confidence is 1 (one frame of candidates), as RTXDI's. Writes di_out.

@compute @workgroup_size(WORKGROUP_SIZE)
fn di_initial(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var out: StoredReservoir;
    let g = render_gbuffer[i];
    if g.prim == BVH_NO_HIT {
        di_out[i] = out;
        return;
    }
    out.m = 1u;
    if lights_info.count == 0u {
        di_out[i] = out;
        return;
    }
    let w = render_params.camera.width;
    let blocks_x = (w + 7u) / 8u;
    let block = ((i / w) / 8u) * blocks_x + (i % w) / 8u;
    var block_rng = di_rng(block, DI_PASS_TILE_PICK);
    let tile = (rng_next_u32(&block_rng) % di_params.tiles) * di_params.tile_size;
    var rng = di_rng(i, DI_PASS_INITIAL);
    var r = reservoir_empty();
    var chosen: LightSample;
    var chosen_p_hat = 0.0;
    for (var k = 0u; k < di_params.candidates; k++) {
        let s = di_tiles[tile + rng_next_u32(&rng) % di_params.tile_size];
        let u = rng_next_f32(&rng);
        var weight = 0.0;
        var p_hat = 0.0;
        if s.pdf_area > 0.0 {
            p_hat = di_target(g, s);
            weight = p_hat / s.pdf_area;
        }
        if reservoir_update(&r, weight, u) {
            chosen = s;
            chosen_p_hat = p_hat;
        }
    }
    reservoir_finalize(&r, chosen_p_hat);
    out = render_store_reservoir(chosen, PackedReservoir(r.ucw, 1u));
    di_out[i] = out;
}
