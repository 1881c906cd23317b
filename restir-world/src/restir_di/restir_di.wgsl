// ReSTIR DI's functions shared by its kernels (the stage's library).

// Whether restir-di reuses light at primary vertex g: a diffuse one, or a glossy one at
// knobs.min_roughness or rougher; any other holds no reservoir and is shaded by the renderer's
// own estimator.
fn di_reuses(g: GVertex) -> bool {
    return !RENDER_GLOSSY || g.material == 0u
        // Half the packed roughness' step below: a material at the knob's value is reused.
        || render_vertex_brdf(g).roughness >= screen_params.knobs.min_roughness - 0.5 / 65535.0;
}
