// The radiance cache's passes: update (a share of the pixels trace a short path and keep what
// each vertex reflects), accumulate (those samples into their cells: the update reads the
// cells, so it must not see this frame's sums half added), resolve (one invocation per bucket: cap the history, age,
// evict and compact), path (the render's path, ending in the cache) and the debug view.

// Update path k of the frame (update_paths of them, one per stratum of the pixels: k's pixel is
// drawn at random from its stratum, so the invocations that trace are contiguous and a SIMD
// group runs full): from the pixel's secondary vertex, up to
// update_depth vertices, each with a light estimate (demodulated: a white surface's) and a
// cosine bounce; the radiance the vertex after the last reflects is that of the path going on
// from it (cache_tail). Then, from the last vertex back, each vertex's
// reflected radiance (white surface) = light estimate + MIS-weighted emission its bounce found
// + the radiance the next vertex reflects, is one sample of its cell (its slot is claimed now,
// the sample kept in cache_update_samples for cache_accumulate). Only diffuse vertices have
// cells (render_reuses): the path ends its samples at a glossy one, whose radiance is its tail.
@compute @workgroup_size(WORKGROUP_SIZE)
fn cache_update(id: Invocation) {
    let k = item_index(id);
    if k >= cache_params.update_paths { return; }
    var rng = render_rng_salted(k, STREAM_PATH, SALT_CACHE_UPDATE);
    let stratum = f32(render_params.pixel_count) / f32(cache_params.update_paths);
    let i = min(u32((f32(k) + rng_next_f32(&rng)) * stratum), render_params.pixel_count - 1u);
    // From the pixel's secondary vertex, not its primary: the paths read the cache at
    // vertices a diffuse bounce reached, and a cell's mean is the mean over where its samples
    // fell (from the camera, a lamp hides the bright wall behind it; from a bounce, it does not).
    var v = render_unpack_vertex(render_secondary[i]);
    if render_gbuffer[i].prim == BVH_NO_HIT || v.prim == BVH_NO_HIT || !render_reuses(v) {
        for (var j = 0u; j < CACHE_MAX_UPDATE_DEPTH; j++) {
            cache_update_samples[k * CACHE_MAX_UPDATE_DEPTH + j] = CacheSample(vec3<f32>(0.0), HASH_REJECTED);
        }
        return;
    }
    var slots: array<u32, CACHE_MAX_UPDATE_DEPTH>;
    var light: array<vec3<f32>, CACHE_MAX_UPDATE_DEPTH>;
    var albedo: array<vec3<f32>, CACHE_MAX_UPDATE_DEPTH>;
    var n = 0u;
    var tail = vec3<f32>(0.0);
    let depth = min(cache_params.knobs.update_depth, CACHE_MAX_UPDATE_DEPTH);
    for (var j = 0u; j < depth; j++) {
        if !render_reuses(v) {
            // A glossy vertex has no cell: the path goes on from it as the render's do.
            tail = cache_tail(v, j + 2u, &rng);
            break;
        }
        var white = v;
        white.albedo = vec3<f32>(1.0);
        slots[j] = cache_insert(v);
        light[j] = render_nee(white, &rng);
        albedo[j] = v.albedo;
        n = j + 1u;
        let w = render_path_step(v, &rng);
        light[j] += render_hit_emission(v, w);
        if w.prim == BVH_NO_HIT {
            break;
        }
        if j + 1u == depth {
            tail = cache_tail(w, j + 3u, &rng);
            break;
        }
        v = w;
    }
    var l = tail;
    let first = k * CACHE_MAX_UPDATE_DEPTH;
    for (var j = CACHE_MAX_UPDATE_DEPTH; j > 0u; j--) {
        var s = CacheSample(vec3<f32>(0.0), HASH_REJECTED);
        if j <= n {
            s = CacheSample(light[j - 1u] + l, slots[j - 1u]);
            l = albedo[j - 1u] * s.value;
        }
        cache_update_samples[first + j - 1u] = s;
    }
}

// The radiance path vertex w, reached by bounce `bounce` from the primary vertex, reflects
// towards the vertex before it: with `feedback`, what the cache holds (its light estimate alone
// where its cell has no sample yet); by default the path going on from w as the render's paths
// do (a light estimate at each vertex, Russian roulette from roulette_from, at most
// MAX_BOUNCES in all), so that every sample is unbiased from the first frame on.
fn cache_tail(w: GVertex, bounce: u32, rng: ptr<function, u32>) -> vec3<f32> {
    if render_planted(PLANTED_CACHE_UPDATE_WITHOUT_TAIL) {
        return vec3<f32>(0.0);
    }
    if cache_params.knobs.feedback != 0u {
        let cached = cache_radiance(w);
        return select(render_nee(w, rng), cached.xyz, cached.w > 0.0);
    }
    var v = w;
    var throughput = vec3<f32>(1.0);
    var l = vec3<f32>(0.0);
    for (var b = bounce; b <= CACHE_MAX_BOUNCES; b++) {
        l += throughput * render_nee(v, rng);
        if render_params.roulette_from != 0u && b >= render_params.roulette_from {
            let q = render_roulette_survival(v);
            if !(rng_next_f32(rng) < q) {
                break;
            }
            throughput /= render_roulette_divisor(q);
        }
        let next = render_path_step(v, rng);
        throughput *= render_throughput(v, next);
        l += throughput * render_hit_emission(v, next);
        if next.prim == BVH_NO_HIT {
            break;
        }
        v = next;
    }
    return l;
}

// Sample item of the frame's update paths into its cell.
@compute @workgroup_size(WORKGROUP_SIZE)
fn cache_accumulate(id: Invocation) {
    let item = item_index(id);
    if item >= cache_params.update_paths * CACHE_MAX_UPDATE_DEPTH { return; }
    var rng = render_rng_salted(item, STREAM_PATH, SALT_CACHE_ACCUMULATE);
    let s = cache_update_samples[item];
    cache_add(s.slot, s.value, &rng);
}

// find_or_insert of v's cell: a slot, HASH_FULL (counted as an overflow) or HASH_REJECTED
// (counted by kind).
fn cache_insert(v: GVertex) -> u32 {
    return hash_insert_cell(cache_cell(v));
}

// Adds sample e to the cell in `slot` (none when the slot is a sentinel or the sample is not
// finite; the first CACHE_MAX_NEW of a frame count, later ones only raise the slot counter).
fn cache_add(slot: u32, e: vec3<f32>, rng: ptr<function, u32>) {
    if !hash_is_slot(slot) {
        return;
    }
    if !(hash_is_finite(e.x) && hash_is_finite(e.y) && hash_is_finite(e.z)) {
        atomicAdd(&hash_stats.rejected_nonfinite, 1u);
        return;
    }
    if hash_slot_append(slot) >= CACHE_MAX_NEW {
        return;
    }
    let q = cache_fixed(clamp(e / cache_params.unit, vec3<f32>(0.0), vec3<f32>(CACHE_MAX_VALUE)), rng);
    atomicAdd(&cache_cells[slot].r, q.x);
    atomicAdd(&cache_cells[slot].g, q.y);
    atomicAdd(&cache_cells[slot].b, q.z);
}

// x (>= 0) in CACHE_SCALE units, rounded up or down at random: exact in expectation.
fn cache_fixed(x: vec3<f32>, rng: ptr<function, u32>) -> vec3<u32> {
    let u = vec3<f32>(rng_next_f32(rng), rng_next_f32(rng), rng_next_f32(rng));
    return vec3<u32>(floor(x * CACHE_SCALE + u));
}

// Bucket b: each cell takes the frame's samples into its history (at most `history` samples:
// beyond, the sums are scaled down to that many, keeping the mean), ages when it got none,
// and is evicted after evict_after frames without one. The cells kept move to the front of
// the bucket in order, so gpu-hash's find (which stops at the first empty slot) still finds
// every one; the slot counters start the next frame at 0. Counts the cells kept and the full
// buckets in hash_stats.
@compute @workgroup_size(WORKGROUP_SIZE)
fn cache_resolve(id: Invocation) {
    let b = item_index(id);
    if b >= hash_params.num_buckets { return; }
    var rng = render_rng_salted(b, STREAM_PATH, SALT_CACHE_RESOLVE);
    let spb = hash_params.slots_per_bucket;
    let base = b * spb;
    var kept = 0u;
    var s = 0u;
    for (; s < spb; s++) {
        let slot = base + s;
        let checksum = atomicLoad(&hash_checksums[slot]);
        if checksum == 0u {
            break;
        }
        let fresh = min(atomicLoad(&hash_counters[slot]), CACHE_MAX_NEW);
        let c = &cache_cells[slot];
        let info = atomicLoad(&(*c).info);
        var q = vec3<u32>(atomicLoad(&(*c).r), atomicLoad(&(*c).g), atomicLoad(&(*c).b));
        var count = cache_samples(info) + fresh;
        let age = select(cache_age(info) + 1u, 0u, fresh > 0u);
        if age > cache_params.knobs.evict_after {
            continue;
        }
        let cap = cache_params.knobs.history;
        if count > cap {
            q = cache_fixed(vec3<f32>(q) * (f32(cap) / f32(count)) / CACHE_SCALE, &rng);
            count = cap;
        }
        let to = base + kept;
        atomicStore(&hash_checksums[to], checksum);
        atomicStore(&hash_counters[to], 0u);
        let d = &cache_cells[to];
        atomicStore(&(*d).r, q.x);
        atomicStore(&(*d).g, q.y);
        atomicStore(&(*d).b, q.z);
        atomicStore(&(*d).info, count | (age << 16u));
        kept += 1u;
    }
    // Empty the slots behind the kept cells, up to the last one that was in use.
    for (var e = kept; e < s; e++) {
        let slot = base + e;
        atomicStore(&hash_checksums[slot], 0u);
        atomicStore(&hash_counters[slot], 0u);
        let d = &cache_cells[slot];
        atomicStore(&(*d).r, 0u);
        atomicStore(&(*d).g, 0u);
        atomicStore(&(*d).b, 0u);
        atomicStore(&(*d).info, 0u);
    }
    atomicAdd(&hash_stats.used_slots, kept);
    atomicMax(&hash_stats.max_bucket_fill, kept);
    if kept == spb {
        atomicAdd(&hash_stats.full_buckets, 1u);
    }
}

// The render's path beyond the secondary vertex, ending in the cache (render/path.wgsl).
@compute @workgroup_size(WORKGROUP_SIZE)
fn cache_path(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    render_path_pixel(i);
}

// The cell of each pixel's primary vertex: its demodulated radiance (x / (1 + x) per channel),
// its age (heat, 0 .. evict_after frames) or its samples (heat of log2, 1 .. history); black
// where the vertex has no cell with samples.
@compute @workgroup_size(WORKGROUP_SIZE)
fn cache_debug(id: Invocation) {
    let i = item_index(id);
    if i >= render_params.pixel_count { return; }
    var c = vec3<f32>(0.0);
    let g = render_unpack_vertex(render_gbuffer[i]);
    if g.prim != BVH_NO_HIT {
        let slot = cache_find(g);
        if hash_is_slot(slot) {
            let m = cache_mean(slot);
            let info = atomicLoad(&cache_cells[slot].info);
            if m.w > 0.0 {
                switch cache_params.debug_view {
                    case CACHE_VIEW_AGE: {
                        c = render_heat(f32(cache_age(info)) / f32(max(cache_params.knobs.evict_after, 1u)));
                    }
                    case CACHE_VIEW_SAMPLES: {
                        c = render_heat(log2(m.w) / max(log2(f32(cache_params.knobs.history)), 1.0));
                    }
                    default: {
                        c = m.xyz / (vec3<f32>(1.0) + m.xyz);
                    }
                }
            }
        }
    }
    cache_debug_image[i] = vec4<f32>(c, 1.0);
}
