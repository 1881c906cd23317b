// World-space ReSTIR GI library (Boisse 2021): the stored reservoir, the target function and the
// shared helpers of the world-space passes. Structs and functions only. Needs the render
// library (render::library: render_* bindings, lights, trace, rng), reservoir::wgsl() and the
// constants header world_restir::constants_wgsl().

// One vertex's reservoir as stored between passes (Rust twin: world_restir::WrReservoir), 16
// bytes. The selected light sample is stored as the light and where on it, one representation
// for every light kind: light_kind = the sample's LIGHTS_KIND_* in the low 2 bits and its index
// in the light table above; coords = LightSample.coords packed: a triangle point's
// barycentrics as two unorm16 (pack2x16unorm), an environment direction's octahedral
// coordinates as two snorm16 (pack2x16snorm), 0 for punctual lights. wr_light_sample decodes
// it (position, normal, textured emission) from the light table. (ucw, m) is reservoir's
// PackedReservoir. The normal of the vertex that generated the reservoir (the paper's
// bias-reduction test) is that vertex's own shading normal in the G-buffer.
struct WrReservoir {
    light_kind: u32,
    coords: u32,
    ucw: f32,
    m: u32,
}

// Knobs of a world-space ReSTIR renderer (Rust twin: world_restir::WrParams).
struct WrParams {
    candidates: u32,
    max_count: u32,
    normal_threshold: f32,
    temporal_m_cap: u32,
    jitter: u32,
    combine: u32,
    gi_stride: u32,
    debug_view: u32,
    items: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Per reuse pass: `pass_index` mixes into the random stream, `temporal` = 1 for the pass that
// reads last frame's grid (Rust twin: world_restir::WrPass).
struct WrPass {
    pass_index: u32,
    temporal: u32,
    _pad0: u32,
    _pad1: u32,
}

fn wr_empty_stored() -> WrReservoir {
    var r: WrReservoir;
    return r;
}

// Grid items: item i < pixel_count is pixel i's secondary vertex; with the unified cache,
// item pixel_count + i is pixel i's primary vertex (wr_params.items in all).

// Whether item i has a vertex (a secondary one needs a primary hit and a GI hit).
fn wr_has_vertex(i: u32) -> bool {
    let n = render_params.pixel_count;
    if i >= n {
        return render_gbuffer[i - n].prim != BVH_NO_HIT;
    }
    return render_gbuffer[i].prim != BVH_NO_HIT && render_secondary[i].prim != BVH_NO_HIT;
}

// The vertex of item i.
fn wr_vertex(i: u32) -> GVertex {
    let n = render_params.pixel_count;
    if i >= n {
        return render_gbuffer[i - n];
    }
    return render_secondary[i];
}

// Whether item i generates a reservoir and enters the grid this frame: with gi_stride s, one
// secondary vertex of each s x s block of pixels, rotating over frames (GI resolution scale
// 1/s); every primary vertex.
fn wr_is_active(i: u32, stride: u32) -> bool {
    if stride <= 1u || i >= render_params.pixel_count {
        return true;
    }
    let w = render_params.camera.width;
    let phase = render_state.frame % (stride * stride);
    return (i % w) % stride == phase % stride && (i / w) % stride == phase / stride;
}

// The stored sample of r, decoded (see WrReservoir).
fn wr_light_sample(r: WrReservoir) -> LightSample {
    let kind = r.light_kind & 3u;
    var coords = unpack2x16unorm(r.coords);
    if kind == LIGHTS_KIND_ENV {
        coords = unpack2x16snorm(r.coords);
    } else if coords.x + coords.y > 1.0 {
        // Rounding can leave the triangle by half a step: back onto its edge.
        coords /= coords.x + coords.y;
    }
    var s = render_light_sample_at(r.light_kind >> 2u, coords);
    s.pdf_area = 1.0;
    return s;
}

// The reservoir storing light sample s with the packed (W, M) of a reservoir.
fn wr_store(s: LightSample, packed: PackedReservoir) -> WrReservoir {
    var coords = 0u;
    if s.kind == LIGHTS_KIND_TRIANGLE {
        coords = pack2x16unorm(s.coords);
    } else if s.kind == LIGHTS_KIND_ENV {
        coords = pack2x16snorm(s.coords);
    }
    return WrReservoir(s.kind | (s.light << 2u), coords, packed.ucw, packed.m);
}

// Unshadowed reflected radiance of the light sample at vertex v (the target's integrand).
fn wr_contribution(v: GVertex, s: LightSample) -> vec3<f32> {
    return render_light_contribution(v.position, v.normal, v.shading, v.albedo, s);
}

// Target function p_hat: luminance of the unshadowed reflected radiance.
fn wr_target(v: GVertex, s: LightSample) -> f32 {
    return render_luminance(wr_contribution(v, s));
}

fn wr_rng(i: u32, pass_id: u32, salt: u32) -> u32 {
    return rng_seed(i, render_state.frame, (render_params.seed * RENDER_PASS_COUNT + pass_id) ^ (salt << 20u));
}
