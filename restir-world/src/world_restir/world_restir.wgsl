// World-space ReSTIR GI library (Boisse 2021): the knobs, the target function and the shared
// helpers of the world-space passes (reservoirs are the render library's StoredReservoir).
// Structs and functions only. Needs the render library (render::library: render_* bindings,
// lights, trace, rng), reservoir::wgsl() and the constants header
// world_restir::constants_wgsl().

// Knobs (WrKnobs, generated from world_restir::WorldRestirConfig) and the frame's layout
// (Rust twin: world_restir::WrParams). items: grid items; tiles, tile_size: the light tiles
// the generate pass draws from (0: the light table).
struct WrParams {
    knobs: WrKnobs,
    debug_view: u32,
    items: u32,
    tiles: u32,
    tile_size: u32,
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

// Whether item i has a vertex the reuse takes (render_reuses: a diffuse one): only those
// generate reservoirs, enter the grid and merge; the shade passes give the others the renderer's
// own light estimates.
fn wr_reuses(i: u32) -> bool {
    return wr_has_vertex(i) && render_reuses(wr_vertex(i));
}

// The vertex of item i.
fn wr_vertex(i: u32) -> GVertex {
    let n = render_params.pixel_count;
    if i >= n {
        return render_unpack_vertex(render_gbuffer[i - n]);
    }
    return render_unpack_vertex(render_secondary[i]);
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

