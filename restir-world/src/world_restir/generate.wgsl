// Pass "generate" (paper Algorithm 1): RIS over wr_params.candidates light samples at each
// grid item's vertex, target = luminance of the unshadowed reflected radiance. Writes wr_out.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_generate(id: Invocation) {
    let i = item_index(id);
    if i >= wr_params.items { return; }
    if !wr_has_vertex(i) || !wr_is_active(i, wr_params.gi_stride) || lights_info.count == 0u {
        wr_out[i] = StoredReservoir();
        return;
    }
    let v = wr_vertex(i);
    var rng = wr_rng(i, WR_PASS_GENERATE, 0u);
    let ris = render_ris_lights(v.position, v.normal, v.shading, v.albedo, wr_params.candidates, &rng);
    wr_out[i] = render_store_reservoir(ris.light, reservoir_pack(ris.reservoir));
}
