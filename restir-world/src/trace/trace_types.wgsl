// The types every tracing backend shares (trace.wgsl: the software CWBVH; trace_rq.wgsl: ray
// queries).

// A triangle in BVH primitive order: full f32 vertices, its material, and its index in the
// scene's triangle list.
struct BvhTriangle {
    v0: vec3<f32>,
    material: u32,
    v1: vec3<f32>,
    index: u32,
    v2: vec3<f32>,
    flags: u32,
}

struct Ray {
    origin: vec3<f32>,
    tmin: f32,
    dir: vec3<f32>,
    tmax: f32,
}

// Closest hit: `prim` indexes `bvh_triangles` (BVH_NO_HIT on a miss); (b1, b2) are the
// barycentric weights of v1 and v2.
struct Hit {
    t: f32,
    prim: u32,
    b1: f32,
    b2: f32,
}
