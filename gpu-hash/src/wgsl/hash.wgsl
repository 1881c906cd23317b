// gpu-hash core (no bindings): hashes (Jarzynski & Olano 2020), adaptive cell keys (Boisse 2021,
// Algorithm 4), bucket and checksum of a key, tangent-plane jitter.
// Needs the generated constants header `gpu_hash::constants_wgsl()`.
// Rust twins: gpu_hash::hash (pcg, xxhash32) and gpu_hash::cell (HashGridParams::cell, jitter).

// Per-table parameters, computed by `gpu_hash::HashGridParams::new` (Rust owns the math:
// level_scale = tan(projected_size * fov_y * max(1/height, height/width^2)) / min_cell_size).
struct HashGridParams {
    eye: vec3<f32>,
    level_scale: f32,
    min_cell_size: f32,
    inv_min_cell_size: f32,
    max_level: u32,
    num_buckets: u32,
    slots_per_bucket: u32,
    probe_buckets: u32,
}

// A grid cell: integer coordinates at a level (cell size = min_cell_size * 2^level).
struct HashKey {
    coords: vec3<i32>,
    level: u32,
}

// A position's cell. `status` is HASH_STATUS_OK, HASH_STATUS_NONFINITE or
// HASH_STATUS_OUT_OF_RANGE; the other fields are 0 unless it is HASH_STATUS_OK.
struct HashCell {
    coords: vec3<i32>,
    level: u32,
    bucket: u32,
    checksum: u32,
    cell_size: f32,
    status: u32,
}

// pcg_hash: one LCG step and an RXS-M-XS output permutation.
fn hash_pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// xxhash32 of one 32-bit word as in Jarzynski & Olano 2020 (the XXH32 tail round and avalanche).
fn hash_xxhash32(p: u32) -> u32 {
    var h = p + 374761393u;
    h = 668265263u * ((h << 17u) | (h >> 15u));
    h = 2246822519u * (h ^ (h >> 15u));
    h = 3266489917u * (h ^ (h >> 13u));
    return h ^ (h >> 16u);
}

// Bucket of a key: h1 = pcg chained over x, y, z, level (paper Algorithm 5), mod num_buckets.
fn hash_bucket_of(key: HashKey, num_buckets: u32) -> u32 {
    let c = bitcast<vec3<u32>>(key.coords);
    let h = hash_pcg(key.level + hash_pcg(c.z + hash_pcg(c.y + hash_pcg(c.x))));
    return h % num_buckets;
}

// Checksum of a key: h2 = xxhash32 chained the same way, never 0 (0 marks an empty slot).
fn hash_checksum_of(key: HashKey) -> u32 {
    let c = bitcast<vec3<u32>>(key.coords);
    let h = hash_xxhash32(key.level + hash_xxhash32(c.z + hash_xxhash32(c.y + hash_xxhash32(c.x))));
    return max(h, 1u);
}

// Bit test, immune to fast-math assumptions about NaN and infinity.
fn hash_is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// 2^e exactly, for e in [-126, 127].
fn hash_pow2(e: i32) -> f32 {
    return bitcast<f32>(u32(e + 127) << 23u);
}

// Level of the adaptive cell at `pos` (Algorithm 4): floor(log2(distance * level_scale)),
// clamped to [0, max_level]. Read from the float's exponent bits, so it is exact given the
// distance: distance 0 (and anything below one minimum cell) is level 0.
fn hash_cell_level(params: HashGridParams, pos: vec3<f32>) -> u32 {
    let d = pos - params.eye;
    let dist = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    let ratio = dist * params.level_scale;
    let e = i32((bitcast<u32>(ratio) >> 23u) & 0xffu) - 127;
    return u32(clamp(e, 0, i32(params.max_level)));
}

// Cell size at a level: min_cell_size * 2^level (exact).
fn hash_cell_size_at(params: HashGridParams, level: u32) -> f32 {
    return params.min_cell_size * hash_pow2(i32(level));
}

// Cell size at `pos` (use it to scale the jitter before inserting or looking up).
fn hash_cell_size(params: HashGridParams, pos: vec3<f32>) -> f32 {
    return hash_cell_size_at(params, hash_cell_level(params, pos));
}

// The cell of `pos`: level, integer coordinates floor(pos / cell_size), bucket and checksum.
// Non-finite positions and coordinates outside (-2^31, 2^31) are reported in `status`, never
// wrapped.
fn hash_cell(params: HashGridParams, pos: vec3<f32>) -> HashCell {
    var cell: HashCell;
    if !(hash_is_finite(pos.x) && hash_is_finite(pos.y) && hash_is_finite(pos.z)) {
        cell.status = HASH_STATUS_NONFINITE;
        return cell;
    }
    let level = hash_cell_level(params, pos);
    let q = pos * (params.inv_min_cell_size * hash_pow2(-i32(level)));
    // |q| < 2^31 (0x4f000000), tested on the bits: infinity fails too.
    let mag = bitcast<vec3<u32>>(q) & vec3<u32>(0x7fffffffu);
    if any(mag >= vec3<u32>(0x4f000000u)) {
        cell.status = HASH_STATUS_OUT_OF_RANGE;
        return cell;
    }
    let key = HashKey(vec3<i32>(floor(q)), level);
    cell.coords = key.coords;
    cell.level = level;
    cell.bucket = hash_bucket_of(key, params.num_buckets);
    cell.checksum = hash_checksum_of(key);
    cell.cell_size = hash_cell_size_at(params, level);
    cell.status = HASH_STATUS_OK;
    return cell;
}

// Tangent-plane jitter (Binder et al. 2018, as used by Boisse 2021): moves `pos` by
// cell_size * ((u.x - 0.5) t + (u.y - 0.5) b), where (t, b) span the plane orthogonal to
// `normal` (unit length expected; Duff et al. 2017 basis). `u` holds two numbers in [0, 1).
fn hash_jitter(pos: vec3<f32>, normal: vec3<f32>, u: vec2<f32>, cell_size: f32) -> vec3<f32> {
    let s = select(-1.0, 1.0, normal.z >= 0.0);
    let a = -1.0 / (s + normal.z);
    let b = normal.x * normal.y * a;
    let t = vec3<f32>(1.0 + s * normal.x * normal.x * a, s * b, -s * normal.x);
    let bt = vec3<f32>(b, s + normal.y * normal.y * a, -normal.y);
    return pos + (t * (u.x - 0.5) + bt * (u.y - 0.5)) * cell_size;
}
