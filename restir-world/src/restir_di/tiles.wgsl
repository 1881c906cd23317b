// Pass "di-tiles": di_params.tiles tiles of di_params.tile_size light samples each, drawn by
// power from the light table (render_light_sample, the distribution RIS draws from). Pixels
// then draw their candidates from one tile per 8x8 block: the tiles reorder the draws (each
// entry is distributed by the power pdf, stored in its pdf_area), so the RIS weight stays
// p_hat / pdf.

@compute @workgroup_size(WORKGROUP_SIZE)
fn di_fill_tiles(id: Invocation) {
    let i = item_index(id);
    if i >= di_params.tiles * di_params.tile_size { return; }
    var rng = di_rng(i, DI_PASS_TILES);
    light_tiles[i] = render_light_sample(render_rand4(&rng), &rng);
}
