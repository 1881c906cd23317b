// Pass "generate" (paper Algorithm 1): RIS over wr_params.knobs.candidates light samples (from
// the light table, or from the presampled light tiles when a method shares them) at each grid
// item's vertex, target = luminance of the unshadowed reflected radiance. Writes wr_out.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_generate(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    if !wr_has_vertex(i) || !wr_is_active(i, wr_params.knobs.gi_stride) || lights_info.count == 0u {
        wr_out[i] = StoredReservoir();
        return;
    }
    let v = wr_vertex(i);
    var rng = render_rng_salted(i, STREAM_WR_GENERATE, 0u);
    var ris: RisLightSample;
    if wr_params.tiles > 0u {
        // Candidates from the light tile of the pixel's block (shared with restir-di).
        let first = light_tiles_first(i % render_params.pixel_count, wr_params.tiles, wr_params.tile_size);
        ris = light_tiles_ris(v.position, v.normal, v.shading, v.albedo, first, wr_params.tile_size,
                              wr_params.knobs.candidates, &rng);
    } else {
        ris = render_ris_lights(v.position, v.normal, v.shading, v.albedo, wr_params.knobs.candidates, &rng);
    }
    wr_out[i] = render_store_reservoir(ris.light, reservoir_pack(ris.reservoir));
}
