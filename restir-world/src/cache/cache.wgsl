// The world-space radiance cache's library: its parameters, the cell record, a vertex's cell
// (the world-space grid's, restir_world::grid: gpu-hash's adaptive cell with the normal folded
// into the key), the cached radiance, and
// `path_cache_radiance`, through which the shared path (render/path.wgsl) ends in the cache.
// Needs the render library, the grid library (grid::WGSL), gpu-hash's table role (hash_params, hash_checksums,
// hash_counters, hash_stats) and the bindings header (cache_params, cache_cells, cache_debug).
// Rust twin of the layout and the key: restir_world::cache.

struct CacheParams {
    knobs: CacheKnobs,
    debug_view: u32,
    // Update paths per frame: ceil(pixels x update_fraction).
    update_paths: u32,
    // The unit of the cells' radiance (cache::radiance_unit): they hold radiance / unit.
    unit: f32,
    _pad2: u32,
}

// One cell's radiance, 16 bytes: the sums of its samples in fixed point (CACHE_SCALE units,
// stochastically rounded), and info = samples in the sums (low 16 bits) | frames since its
// last sample << 16. The sample count of the frame in progress is gpu-hash's slot counter.
struct CacheCell {
    r: atomic<u32>,
    g: atomic<u32>,
    b: atomic<u32>,
    info: atomic<u32>,
}

// One sample of an update path's vertex, kept between the update and accumulate passes:
// slot = HASH_REJECTED for none.
struct CacheSample {
    value: vec3<f32>,
    slot: u32,
}

// The cell of a surface vertex: the world-space grid's cell of its position with the normal's
// axis folded into the key (grid_cell), so that the faces of a corner or of a thin wall never
// share a cell.
fn cache_cell(v: GVertex) -> HashCell {
    return grid_cell(hash_params, v.position, v.normal, true);
}

// The slot of v's cell, or a sentinel (not found, rejected).
fn cache_find(v: GVertex) -> u32 {
    let c = cache_cell(v);
    if c.status != HASH_STATUS_OK {
        return HASH_REJECTED;
    }
    return hash_find(c.bucket, c.checksum);
}

fn cache_samples(info: u32) -> u32 {
    return info & 0xffffu;
}

fn cache_age(info: u32) -> u32 {
    return info >> 16u;
}

// The mean of a cell's samples (radiance reflected by a white surface: the cache stores it
// demodulated by albedo), .w = its sample count (0: nothing cached).
fn cache_mean(slot: u32) -> vec4<f32> {
    let n = cache_samples(atomicLoad(&cache_cells[slot].info));
    if n == 0u {
        return vec4<f32>(0.0);
    }
    let c = &cache_cells[slot];
    let sum = vec3<f32>(f32(atomicLoad(&(*c).r)), f32(atomicLoad(&(*c).g)), f32(atomicLoad(&(*c).b)));
    return vec4<f32>(sum * (cache_params.unit / (f32(n) * CACHE_SCALE)), f32(n));
}

// The radiance v reflects as the cache has it (v's albedo x its cell's mean), .w = 1, or
// .w = 0 when its cell has no sample.
fn cache_radiance(v: GVertex) -> vec4<f32> {
    if !render_reuses(v) {
        // A glossy vertex's radiance depends on the direction it is seen from: never cached.
        return vec4<f32>(0.0);
    }
    let slot = cache_find(v);
    if !hash_is_slot(slot) {
        return vec4<f32>(0.0);
    }
    let m = cache_mean(slot);
    if m.w == 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(v.albedo * m.xyz, 1.0);
}

// The shared path's hook: from bounce `after` on, a vertex with a cached radiance ends it,
// once the path's footprint there covers the cell (with `footprint` on): a path that arrives
// from close by (a corner, a lamp over a wall) still resolves what a cell's mean would blur.
fn path_cache_radiance(w: GVertex, bounce: u32, footprint: f32) -> vec4<f32> {
    if bounce < cache_params.knobs.after {
        return vec4<f32>(0.0);
    }
    if cache_params.knobs.footprint != 0u && footprint < hash_cell_size(hash_params, w.position) {
        return vec4<f32>(0.0);
    }
    return cache_radiance(w);
}
