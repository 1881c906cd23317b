// Ray tracing through the adapter's acceleration structures (WGSL ray queries): the same
// interface as trace.wgsl (`trace_closest`, `trace_any`, `bvh_traverse`), on `bvh_accel` (one
// instance of one BLAS whose triangle i is `bvh_triangles[i]`) from
// `trace::bindings(Tracer::RayQuery)`. Every triangle is opaque and two-sided.
enable wgpu_ray_query;

// `any_hit` stops at the first hit in [tmin, tmax] (shadow rays).
fn bvh_traverse(ray: Ray, any_hit: bool) -> Hit {
    var flags = RAY_FLAG_FORCE_OPAQUE;
    if any_hit {
        flags |= RAY_FLAG_TERMINATE_ON_FIRST_HIT;
    }
    var rq: ray_query;
    rayQueryInitialize(&rq, bvh_accel,
                       RayDesc(flags, 0xffu, ray.tmin, ray.tmax, ray.origin, ray.dir));
    while rayQueryProceed(&rq) {}
    let x = rayQueryGetCommittedIntersection(&rq);
    var hit: Hit;
    hit.t = ray.tmax;
    hit.prim = BVH_NO_HIT;
    hit.b1 = 0.0;
    hit.b2 = 0.0;
    if x.kind == RAY_QUERY_INTERSECTION_TRIANGLE {
        hit.t = x.t;
        hit.prim = x.primitive_index;
        hit.b1 = x.barycentrics.x;
        hit.b2 = x.barycentrics.y;
    }
    return hit;
}

fn trace_closest(ray: Ray) -> Hit {
    return bvh_traverse(ray, false);
}

// True when anything blocks the ray within [tmin, tmax].
fn trace_any(ray: Ray) -> bool {
    return bvh_traverse(ray, true).prim != BVH_NO_HIT;
}
