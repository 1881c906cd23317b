// The world-space grid's library (restir_world::grid): its parameters, the item contract, a
// point's cell (gpu-hash's adaptive cell, the normal optionally folded into the key). Structs
// and functions only; needs gpu-hash's hash.wgsl and the constants header
// grid::constants_wgsl(). Rust twin: restir_world::grid.

// The grid's parameters (Rust twin: grid::GridParams). items: how many items may enter it;
// jitter: 1 = positions are moved in the tangent plane by up to one cell before insertion and
// lookup; fold_normal: 1 = the key holds the axis the normal points along most.
struct GridParams {
    items: u32,
    jitter: u32,
    fold_normal: u32,
    _pad: u32,
}

// What a stage's module "grid-items" answers for item i (fn grid_item(i: u32) -> GridItem):
// whether it enters the grid this frame, and where.
struct GridItem {
    present: bool,
    position: vec3<f32>,
    normal: vec3<f32>,
}

// 0..5: the axis the normal points along most, and its sign.
fn grid_normal_axis(n: vec3<f32>) -> u32 {
    let a = abs(n);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, n.x >= 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, n.y >= 0.0);
    }
    return select(5u, 4u, n.z >= 0.0);
}

// The cell of a surface point under `params`: gpu-hash's adaptive cell of its position, with
// `fold` its level moved to one of six level ranges by the normal's axis, so that the faces of
// a corner or of a thin wall never share a cell.
fn grid_cell(params: HashGridParams, position: vec3<f32>, normal: vec3<f32>, fold: bool) -> HashCell {
    var c = hash_cell(params, position);
    if !fold || c.status != HASH_STATUS_OK {
        return c;
    }
    let key = HashKey(c.coords, c.level + (params.max_level + 1u) * grid_normal_axis(normal));
    c.bucket = hash_bucket_of(key, params.num_buckets);
    c.checksum = hash_checksum_of(key);
    return c;
}

// A point moved by the grid's tangent-plane jitter (up to one cell of `params` at the point)
// when `jitter`; u: two numbers in [0, 1), drawn whether or not it is on.
fn grid_jittered(params: HashGridParams, position: vec3<f32>, normal: vec3<f32>, u: vec2<f32>,
                 jitter: bool) -> vec3<f32> {
    if !jitter {
        return position;
    }
    return hash_jitter(position, normal, u, hash_cell_size(params, position));
}
