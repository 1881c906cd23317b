// The world-space grid's lookup: a stage's kernel finds the items of the cell a point falls in,
// in a grid it binds in the lookup role (grid::LOOKUP: grid_params, grid_lookup_offsets,
// grid_lookup_cells, then gpu-hash's lookup block) and nobody writes during the dispatch (this
// frame's after its build, or last frame's with last frame's eye).

// A cell's visited subset: `count` items from `start`, every `increment`-th from `offset`.
struct GridVisit {
    count: u32,
    start: u32,
    increment: u32,
    offset: u32,
}

// The items of the cell of the point (position, normal), jittered as the build was (two numbers
// drawn from rng whether or not jitter is on), of which at most `max_count` are visited: every
// increment-th from a random offset (one more number drawn where the cell exists). count = 0:
// no cell.
fn grid_visit(position: vec3<f32>, normal: vec3<f32>, max_count: u32, rng: ptr<function, u32>) -> GridVisit {
    var s = GridVisit(0u, 0u, 1u, 0u);
    let u = vec2<f32>(rng_next_f32(rng), rng_next_f32(rng));
    let pos = grid_jittered(hash_lookup_params, position, normal, u, grid_params.jitter != 0u);
    let cell = grid_cell(hash_lookup_params, pos, normal, grid_params.fold_normal != 0u);
    if cell.status != HASH_STATUS_OK {
        return s;
    }
    let slot = hash_lookup_find(cell.bucket, cell.checksum);
    if hash_lookup_is_slot(slot) {
        s.count = hash_lookup_slot_count(slot);
        s.start = grid_lookup_offsets[slot];
        s.increment = max((s.count + max(max_count, 1u) - 1u) / max(max_count, 1u), 1u);
        s.offset = rng_next_u32(rng) % s.increment;
    }
    return s;
}

// How many items the visit takes.
fn grid_visited_count(s: GridVisit) -> u32 {
    return (s.count + s.increment - 1u) / s.increment;
}

// The item index of the k-th item of the cell's list from the visit's offset (k = 0,
// increment, 2 increment, ... < count are the visited ones).
fn grid_visited(s: GridVisit, k: u32) -> u32 {
    return grid_lookup_cells[s.start + (k + s.offset) % s.count];
}
