// Pass "generate" (paper Algorithm 1): RIS over wr_params.candidates light samples at each
// secondary vertex, target = luminance of the unshadowed reflected radiance; optionally one
// shadow ray for the selected candidate (W = 0 when occluded). Writes wr_out.

@compute @workgroup_size(WORKGROUP_SIZE)
fn wr_generate(@builtin(global_invocation_id) gid: vec3<u32>,
               @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * WORKGROUP_SIZE;
    if i >= render_params.pixel_count {
        return;
    }
    var out = wr_empty_stored();
    if !wr_has_vertex(i) || !wr_is_active(i, wr_params.gi_stride) || lights_info.count == 0u {
        wr_out[i] = out;
        return;
    }
    let v = render_secondary[i];
    out.vertex_normal = v.normal;
    var rng = wr_rng(i, WR_PASS_GENERATE, 0u);
    var r = reservoir_empty();
    var chosen: LightSample;
    var chosen_p_hat = 0.0;
    for (var k = 0u; k < wr_params.candidates; k++) {
        let s = lights_sample(render_rand4(&rng));
        let u = rng_next_f32(&rng);
        var w = 0.0;
        var p_hat = 0.0;
        if s.pdf_area > 0.0 {
            p_hat = wr_target(v, s);
            w = p_hat / s.pdf_area;
        }
        if reservoir_update(&r, w, u) {
            chosen = s;
            chosen_p_hat = p_hat;
        }
    }
    reservoir_finalize(&r, chosen_p_hat);
    if wr_params.visibility != 0u && r.ucw > 0.0
        && !render_visible(v.position, v.normal, chosen.position) {
        r.ucw = 0.0;
    }
    let packed = reservoir_pack(r);
    out.ucw = packed.ucw;
    out.m = packed.m;
    out.light_position = chosen.position;
    out.light_normal = chosen.normal;
    out.light_emission = chosen.emission;
    wr_out[i] = out;
}
