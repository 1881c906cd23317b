// Presampled light tiles (Wyman & Panteleev 2021) as the passes that draw RIS candidates from
// them read them: restir-di's di-initial, and world-restir's generate when the tiles feed it
// too. light_tiles (bound by the kernel) holds tiles x tile_size light samples drawn by power,
// each keeping its power pdf (the light-tiles pass fills them once per frame). Needs the
// render library.

// The first entry of the tile that pixel's 8x8 block uses this frame: one random tile per
// block per frame (coherent memory), the same for every pass that reads the tiles.
fn light_tiles_first(pixel: u32, tiles: u32, tile_size: u32) -> u32 {
    let w = render_params.camera.width;
    let blocks_x = (w + 7u) / 8u;
    let block = ((pixel / w) / 8u) * blocks_x + (pixel % w) / 8u;
    var rng = render_rng(block, STREAM_LIGHT_TILE_PICK);
    return (rng_next_u32(&rng) % tiles) * tile_size;
}

// render_ris_lights with the candidates drawn uniformly from the tile of tile_size entries at
// `first` instead of from the light table: each entry is a draw of the power pdf, so the RIS
// weight stays p_hat / pdf.
fn light_tiles_ris(v: GVertex, first: u32, tile_size: u32, candidates: u32,
                   rng: ptr<function, u32>) -> RisLightSample {
    var r = reservoir_empty();
    var out: RisLightSample;
    out.p_hat = 0.0;
    for (var k = 0u; k < candidates; k++) {
        let s = light_tiles[first + rng_next_u32(rng) % tile_size];
        render_ris_candidate(&r, &out, v, s, rng_next_f32(rng));
    }
    reservoir_finalize(&r, out.p_hat);
    out.reservoir = r;
    return out;
}
