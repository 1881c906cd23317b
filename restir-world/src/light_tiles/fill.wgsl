// Pass "light-tiles": light_tiles_params.tiles tiles of light_tiles_params.tile_size light
// samples each, drawn by power from the light table (render_light_sample, the distribution RIS
// draws from). Pixels then draw their candidates from one tile per 8x8 block: the tiles
// reorder the draws (each entry is distributed by the power pdf, stored in its pdf_area), so
// the RIS weight stays p_hat / pdf.

// Rust twin: light_tiles::LightTilesParams.
struct LightTilesParams {
    tiles: u32,
    tile_size: u32,
    _pad0: u32,
    _pad1: u32,
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn light_tiles_fill(id: Invocation) {
    let i = item_index(id);
    if i >= light_tiles_params.tiles * light_tiles_params.tile_size { return; }
    var rng = render_rng(i, STREAM_LIGHT_TILES);
    light_tiles[i] = render_light_sample(render_rand4(&rng), &rng);
}
