// Pass "gi-initial": each pixel's own path sample from this frame: x2 = its secondary vertex, L
// = the radiance leaving it that the indirect passes recorded (render_path_radiance). The GI
// ray was drawn by x1's path step (the cosine density about the primary's shading normal, or
// its BRDF's), so W = 1 / pdf (one RIS candidate). M = 1; a GI ray that escaped or found no
// light gives W = 0. Writes screen_out; clears gi_debug but for its refusal flags
// (GI_REFUSED_X1, GI_REFUSED_X2). An x1 the reuse does not take
// (gi_reuses: glossy below min-roughness) holds no reservoir (M = 0: no neighbour merges it,
// and gi-shade gives it the pixel's own path); an x2 it does not take (gi_takes_x2: glossy
// below x2-min-roughness) is no sample (W = 0, M = 1, as an escaped ray), and gi-shade adds
// that pixel's own path instead. A glossy x2's sample is its glossy record (gi_glossy_sample).

@compute @workgroup_size(WORKGROUP_SIZE)
fn screen_initial(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    gi_debug[i] = 0u;
    let g = render_primary_vertex(i);
    var out: GiReservoir;
    if g.prim == BVH_NO_HIT || !gi_reuses(g) {
        if g.prim != BVH_NO_HIT {
            gi_debug[i] = GI_REFUSED_X1;
        }
        screen_out[i] = out;
        return;
    }
    let x2 = render_unpack_vertex(render_secondary[i]);
    if x2.prim != BVH_NO_HIT && !gi_takes_x2(x2) {
        gi_debug[i] = GI_REFUSED_X2;
    }
    var sample: GiSample;
    var packed = PackedReservoir(0.0, 1u);
    if x2.prim != BVH_NO_HIT && gi_takes_x2(x2) {
        sample = gi_diffuse_sample(x2.position, x2.normal, render_path_radiance[i].xyz);
        if RENDER_GLOSSY && x2.material != 0u {
            sample = gi_glossy_sample(x2, render_load_glossy_x2(i));
        }
        packed.ucw = gi_own_ucw(g, sample);
    }
    screen_out[i] = gi_store(sample, packed);
}
