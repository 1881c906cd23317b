// Sampling helpers shared by the passes: orthonormal basis, cosine-weighted hemisphere, uniform
// triangle, and camera rays with a sub-pixel jitter. Functions and structs only, no bindings.
// Twin: restir_world::sampling (same formulas in the same order; results agree to a few ulp,
// since the GPU may fuse multiply-adds and its sqrt/sin/cos/division are not correctly rounded).

const SAMPLING_PI: f32 = 3.14159265358979323846;
const SAMPLING_INV_PI: f32 = 0.31830988618379067154;

// Orthonormal basis around the unit vector n (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited"): columns (tangent, bitangent, n), right-handed.
fn sampling_onb(n: vec3<f32>) -> mat3x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// Cosine-weighted direction on the hemisphere around +z (Malley's method) from u in [0,1)^2.
// pdf (solid angle) = z / pi.
fn sampling_cosine_local(u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = 2.0 * SAMPLING_PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}

// Cosine-weighted direction on the hemisphere around the unit normal n; pdf = dot(n, d) / pi.
fn sampling_cosine_hemisphere(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    return sampling_onb(n) * sampling_cosine_local(u);
}

// Uniformly distributed barycentrics (b1, b2) of vertices 1 and 2 from u in [0,1)^2: the point
// is p0 + b1 * (p1 - p0) + b2 * (p2 - p0). pdf (area) = 1 / area.
fn sampling_triangle_uniform(u: vec2<f32>) -> vec2<f32> {
    let su = sqrt(u.x);
    return vec2<f32>(su * (1.0 - u.y), su * u.y);
}

// Octahedral coordinates in [-1, 1]^2 of the unit vector d (Cigolle et al. 2014), and back.
fn sampling_oct_encode(d: vec3<f32>) -> vec2<f32> {
    let p = d.xy / (abs(d.x) + abs(d.y) + abs(d.z));
    if d.z >= 0.0 {
        return p;
    }
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    return (vec2<f32>(1.0) - abs(p.yx)) * s;
}

fn sampling_oct_decode(e: vec2<f32>) -> vec3<f32> {
    var d = vec3<f32>(e, 1.0 - abs(e.x) - abs(e.y));
    if d.z < 0.0 {
        let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), d.xy >= vec2<f32>(0.0));
        d = vec3<f32>((vec2<f32>(1.0) - abs(d.yx)) * s, d.z);
    }
    return normalize(d);
}

// A pinhole camera as the GPU sees it. `right` and `up` are pre-scaled so that the image plane
// at distance 1 along `forward` spans [-1, 1] in both: |up| = tan(vfov / 2), |right| = |up| *
// width / height. Rust: restir_world::sampling::CameraGpu::new.
struct CameraGpu {
    eye: vec3<f32>,
    width: u32,
    forward: vec3<f32>,
    height: u32,
    right: vec3<f32>,
    _pad0: u32,
    up: vec3<f32>,
    _pad1: u32,
}

// Unit direction of the primary ray through pixel `pixel` (x to the right, y down, (0, 0) the
// top-left pixel) at the sub-pixel offset `jitter` in [0,1)^2 ((0.5, 0.5) is the pixel centre;
// uniform jitter = box filter). The ray starts at cam.eye.
fn camera_ray_dir(cam: CameraGpu, pixel: vec2<u32>, jitter: vec2<f32>) -> vec3<f32> {
    let sx = 2.0 * (f32(pixel.x) + jitter.x) / f32(cam.width) - 1.0;
    let sy = 1.0 - 2.0 * (f32(pixel.y) + jitter.y) / f32(cam.height);
    return normalize(cam.forward + sx * cam.right + sy * cam.up);
}
