// Ray tracing against an obvhs compressed wide BVH8 (Ylitie et al. 2017), uploaded as-is, and
// full-precision triangles stored in BVH primitive order. Library file: structs and functions
// only. Buffers come from `trace::bindings(Tracer::Bvh)` (`bvh_nodes`, `bvh_triangles`);
// constants from `trace::constants_wgsl` (`BVH_STACK_SIZE`, `BVH_NO_HIT`, `BVH_NODE_TMIN`);
// `Ray`, `Hit` and `BvhTriangle` from trace_types.wgsl. trace_rq.wgsl has the same interface
// (`trace_closest`, `trace_any`, `bvh_traverse`) on the adapter's ray queries.
// CPU twin: restir_world::trace::Bvh::{closest_hit, any_hit} (obvhs's CPU traversal + the same
// watertight triangle test).

// One CwBvhNode, byte for byte (80 bytes). `e_imask` holds the three extent exponents in its low
// bytes and the internal-child mask in its high byte; the vec2<u32> fields hold 8 bytes, one per
// child slot, little-endian.
struct BvhNode {
    p: vec3<f32>,
    e_imask: u32,
    child_base_idx: u32,
    primitive_base_idx: u32,
    child_meta: vec2<u32>,
    child_min_x: vec2<u32>,
    child_max_x: vec2<u32>,
    child_min_y: vec2<u32>,
    child_max_y: vec2<u32>,
    child_min_z: vec2<u32>,
    child_max_z: vec2<u32>,
}

// Per-ray constants of the watertight test (Woop, Benthin, Wald 2013).
struct WatertightRay {
    k: vec3<u32>,
    s: vec3<f32>,
}

fn bvh_byte(v: vec2<u32>, i: u32) -> u32 {
    return (v[i >> 2u] >> ((i & 3u) * 8u)) & 0xffu;
}

fn bvh_safe_inverse(x: f32) -> f32 {
    let eps = 1.1920929e-7;
    if abs(x) <= eps {
        return select(1.0, -1.0, x < 0.0) / eps;
    }
    return 1.0 / x;
}

fn bvh_watertight_setup(dir: vec3<f32>) -> WatertightRay {
    let a = abs(dir);
    var kz = 0u;
    if a.y > a.x && a.y >= a.z {
        kz = 1u;
    } else if a.z > a.x && a.z > a.y {
        kz = 2u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if dir[kz] < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    var w: WatertightRay;
    w.k = vec3<u32>(kx, ky, kz);
    w.s = vec3<f32>(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
    return w;
}

// Watertight ray/triangle test. Returns (t, b1, b2) with t = -1 on a miss or outside
// [tmin, tmax].
fn bvh_intersect_triangle(w: WatertightRay, origin: vec3<f32>, tmin: f32, tmax: f32,
                          v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> vec3<f32> {
    let a = v0 - origin;
    let b = v1 - origin;
    let c = v2 - origin;
    let ax = a[w.k.x] - w.s.x * a[w.k.z];
    let ay = a[w.k.y] - w.s.y * a[w.k.z];
    let bx = b[w.k.x] - w.s.x * b[w.k.z];
    let by = b[w.k.y] - w.s.y * b[w.k.z];
    let cx = c[w.k.x] - w.s.x * c[w.k.z];
    let cy = c[w.k.y] - w.s.y * c[w.k.z];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let ww = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || ww < 0.0) && (u > 0.0 || v > 0.0 || ww > 0.0) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let det = u + v + ww;
    if det == 0.0 {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    let az = w.s.z * a[w.k.z];
    let bz = w.s.z * b[w.k.z];
    let cz = w.s.z * c[w.k.z];
    let tt = u * az + v * bz + ww * cz;
    let rcp = 1.0 / det;
    let t = tt * rcp;
    if !(t >= tmin && t <= tmax) {
        return vec3<f32>(-1.0, 0.0, 0.0);
    }
    return vec3<f32>(t, v * rcp, ww * rcp);
}

// Hit mask of one node, in the layout obvhs's traversal uses: internal children in the high
// byte (bit 24 + slot ^ octant), leaf primitives in the low 24 bits.
fn bvh_intersect_node(node: BvhNode, origin: vec3<f32>, inv_dir: vec3<f32>, neg: vec3<bool>,
                      tmin: f32, tmax: f32, oct_inv: u32) -> u32 {
    let e = vec3<f32>(
        bitcast<f32>((node.e_imask & 0xffu) << 23u),
        bitcast<f32>(((node.e_imask >> 8u) & 0xffu) << 23u),
        bitcast<f32>(((node.e_imask >> 16u) & 0xffu) << 23u),
    );
    let adj_dir_inv = e * inv_dir;
    let adj_origin = (node.p - origin) * inv_dir;
    var hit_mask = 0u;
    for (var child = 0u; child < 8u; child++) {
        let cmeta = bvh_byte(node.child_meta, child);
        if cmeta == 0u {
            continue;
        }
        let lo = vec3<f32>(f32(bvh_byte(node.child_min_x, child)),
                           f32(bvh_byte(node.child_min_y, child)),
                           f32(bvh_byte(node.child_min_z, child)));
        let hi = vec3<f32>(f32(bvh_byte(node.child_max_x, child)),
                           f32(bvh_byte(node.child_max_y, child)),
                           f32(bvh_byte(node.child_max_z, child)));
        let near = select(lo, hi, neg);
        let far = select(hi, lo, neg);
        let tn = near * adj_dir_inv + adj_origin;
        let tf = far * adj_dir_inv + adj_origin;
        let t0 = max(max(max(tn.x, tn.y), tn.z), tmin);
        let t1 = min(min(min(tf.x, tf.y), tf.z), tmax);
        if t0 <= t1 {
            let is_inner = ((cmeta & (cmeta << 1u)) & 0x10u) != 0u;
            let bit_index = (cmeta ^ select(0u, oct_inv, is_inner)) & 0x1fu;
            let child_bits = (cmeta >> 5u) & 7u;
            hit_mask |= child_bits << bit_index;
        }
    }
    return hit_mask;
}

// The nodes (x) and triangles (y) the invocation's traversals tested, for `trace_rays_counted`
// (a kernel that never reads it pays nothing: the driver drops the stores).
var<private> bvh_visits: vec2<u32>;

// Traverses the BVH. `any_hit` stops at the first hit in [tmin, tmax] (shadow rays).
fn bvh_traverse(ray: Ray, any_hit: bool) -> Hit {
    var hit: Hit;
    hit.t = ray.tmax;
    hit.prim = BVH_NO_HIT;
    hit.b1 = 0.0;
    hit.b2 = 0.0;
    let inv_dir = vec3<f32>(bvh_safe_inverse(ray.dir.x), bvh_safe_inverse(ray.dir.y),
                            bvh_safe_inverse(ray.dir.z));
    let neg = ray.dir < vec3<f32>(0.0);
    let oct_inv = select(4u, 0u, neg.x) | select(2u, 0u, neg.y) | select(1u, 0u, neg.z);
    let wt = bvh_watertight_setup(ray.dir);
    let tmin = max(ray.tmin, BVH_NODE_TMIN);

    var stack: array<vec2<u32>, BVH_STACK_SIZE>;
    var sp = 0u;
    var current = vec2<u32>(0u, 0x80000000u);
    var prims = vec2<u32>(0u, 0u);
    loop {
        while prims.y != 0u {
            let local = firstLeadingBit(prims.y);
            prims.y &= ~(1u << local);
            let id = prims.x + local;
            let tri = bvh_triangles[id];
            bvh_visits.y += 1u;
            let r = bvh_intersect_triangle(wt, ray.origin, ray.tmin, hit.t, tri.v0, tri.v1, tri.v2);
            if r.x >= 0.0 && r.x < hit.t {
                hit.t = r.x;
                hit.prim = id;
                hit.b1 = r.y;
                hit.b2 = r.z;
                if any_hit {
                    return hit;
                }
            }
        }
        if (current.y & 0xff000000u) != 0u {
            let hits_imask = current.y;
            let child_offset = firstLeadingBit(hits_imask);
            let base = current.x;
            current.y &= ~(1u << child_offset);
            if (current.y & 0xff000000u) != 0u {
                if sp < BVH_STACK_SIZE {
                    stack[sp] = current;
                    sp += 1u;
                }
            }
            let slot = (child_offset - 24u) ^ oct_inv;
            let relative = countOneBits(hits_imask & ~(0xffffffffu << slot));
            let node = bvh_nodes[base + relative];
            bvh_visits.x += 1u;
            let mask = bvh_intersect_node(node, ray.origin, inv_dir, neg, tmin, hit.t, oct_inv);
            current = vec2<u32>(node.child_base_idx, (mask & 0xff000000u) | (node.e_imask >> 24u));
            prims = vec2<u32>(node.primitive_base_idx, mask & 0x00ffffffu);
        } else {
            current = vec2<u32>(0u, 0u);
        }
        if prims.y == 0u && (current.y & 0xff000000u) == 0u {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            current = stack[sp];
        }
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
