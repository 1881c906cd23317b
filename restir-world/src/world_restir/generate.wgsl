// Pass "generate" (paper Algorithm 1): RIS over wr_params.knobs.candidates light samples (from
// the light table, or from the presampled light tiles when a method shares them) at each grid
// item's vertex, target = luminance of the unshadowed reflected radiance. Writes wr_out, and the
// vertex's MIS estimate (render_light_estimate) to wr_estimate_raw and wr_estimate (the first spatial
// pass replaces the latter by its cell's mean).

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_generate(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    wr_estimate[i] = 0.0;
    wr_estimate_raw[i] = 0.0;
    if !wr_reuses(i) || !wr_is_active(i, wr_params.knobs.gi_stride) || lights_info.count == 0u {
        wr_out[i] = StoredReservoir();
        return;
    }
    let v = render_reused_vertex(wr_vertex(i));
    var rng_e = render_rng_salted(i, STREAM_WR_GENERATE, SALT_ESTIMATE);
    let e = render_light_estimate(v, wr_params.knobs.mis_candidates, &rng_e);
    wr_estimate[i] = e;
    wr_estimate_raw[i] = e;
    var rng = render_rng_salted(i, STREAM_WR_GENERATE, SALT_CANDIDATES);
    var ris: RisLightSample;
    if wr_params.tiles > 0u {
        // Candidates from the light tile of the pixel's block (shared with restir-di).
        let first = light_tiles_first(i % render_params.pixel_count, wr_params.tiles, wr_params.tile_size);
        ris = light_tiles_ris(v, first, wr_params.tile_size, wr_params.knobs.candidates, &rng);
    } else {
        ris = render_ris_lights(v, wr_params.knobs.candidates, &rng);
    }
    wr_out[i] = render_store_reservoir(ris.light, reservoir_pack(ris.reservoir));
}
