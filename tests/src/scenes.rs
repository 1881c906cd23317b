//! Small scenes the GPU tests share.

use glam::Vec3;
use restir_world::scene::{BuiltinOptions, Camera, Material, Scene, builtin};

/// The built-in scene `name` at `side` x `side` (the rest of `opts` as given) and its default
/// camera at that size.
pub fn builtin_square(name: &str, side: u32, opts: BuiltinOptions) -> (Scene, Camera) {
    let opts = BuiltinOptions {
        width: side,
        height: side,
        ..opts
    };
    let s = builtin(name, &opts).expect("scene");
    let cam = s.camera_or_default(side, side);
    (s, cam)
}

/// Lights of the many-lights hall in the tests (the scene's default is 10,000; 2,000 keeps its
/// BVH build and the runs short).
pub const MANY_LIGHTS: u32 = 2000;

/// The built-in scene `name` at `side` x `side` (many-lights with [`MANY_LIGHTS`]) and its
/// default camera.
pub fn test_scene(name: &str, side: u32) -> (Scene, Camera) {
    let opts = BuiltinOptions {
        lights: MANY_LIGHTS,
        ..Default::default()
    };
    builtin_square(name, side, opts)
}

/// A 4 x 4 slab of albedo 0.6 with a 1 x 1 x 1 block on it and a 0.3 x 0.3 emissive quad of
/// radiance `lamp` above one corner: shadows from every light a test adds.
pub fn lit_slab(lamp: [f32; 3]) -> Scene {
    let mut s = Scene::default();
    let m = s.add_material(Material::new([0.6; 3], [0.0; 3]));
    let lamp = s.add_material(Material::new([0.0; 3], lamp));
    s.push_box(Vec3::new(-2.0, -1.0, -2.0), Vec3::new(2.0, -0.8, 2.0), m);
    s.push_box(Vec3::new(-0.5, -0.8, -0.5), Vec3::new(0.5, 0.2, 0.5), m);
    s.push_quad(
        [
            Vec3::new(1.5, 0.5, -1.5),
            Vec3::new(1.8, 0.5, -1.5),
            Vec3::new(1.8, 0.5, -1.2),
            Vec3::new(1.5, 0.5, -1.2),
        ],
        lamp,
    );
    s
}

/// The indirect radiance of a closed furnace of albedo `rho` per unit of the radiance its walls
/// send out first (Le, or the light a point source makes them reflect, over rho), at paths of
/// `bounces`: bounce k adds rho^(k+1), so rho^2 + ... + rho^(bounces+1).
pub fn furnace_indirect(rho: f64, bounces: u32) -> f64 {
    (2..=bounces as i32 + 1).map(|k| rho.powi(k)).sum()
}

/// The last frame of [`orbit_then_cut`]'s camera motion: frames 0..CUT_FRAME move or hold, the
/// rest look away.
pub const CUT_FRAME: u32 = 250;

/// The camera of `frame` in the motion the reuse stages' finiteness tests drive (500 frames):
/// orbiting `base`'s target (a full turn every 100 frames) for frames 0-239, still at `base`
/// for 10 frames, then cut at [`CUT_FRAME`]: turned round on the spot to look away from all it
/// saw (the reprojection then finds nothing), and still again.
pub fn orbit_then_cut(base: &Camera, frame: u32) -> Camera {
    let orbit = restir_world::scene::CameraPath::Orbit {
        frames: 100,
        degrees: 360.0,
    };
    match frame {
        0..240 => orbit.camera(base, frame),
        240..CUT_FRAME => *base,
        _ => Camera {
            target: base.eye + (base.eye - base.target),
            ..*base
        },
    }
}

/// The frames of [`orbit_then_cut`]'s 500 at which the finiteness tests read images back:
/// every 50th, the frames around the cut and the last (the frames between render in batches).
pub fn cut_checkpoints() -> Vec<u32> {
    let mut f: Vec<u32> = (0..500).step_by(50).collect();
    f.extend([CUT_FRAME - 1, CUT_FRAME, CUT_FRAME + 1, 499]);
    f.sort_unstable();
    f.dedup();
    f
}

/// Standard base64 with padding (glTF data URIs the loader tests write).
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A closed glTF box 2 x 2 x 2 about the origin, its faces albedo 0.7, a 0.6 x 0.6 lamp face
/// (radiance 10) 0.02 under the ceiling facing down, and its own camera inside at z = 0.8
/// looking along -z (yfov 0.9): every coordinate times `scale` (issue 60's scale sweep).
pub fn box_gltf(scale: f32) -> String {
    let (h, l, y) = (1.0f32, 0.3f32, 0.98f32);
    let quads: [([[f32; 3]; 4], u32); 7] = [
        ([[-h, -h, -h], [h, -h, -h], [h, -h, h], [-h, -h, h]], 0),
        ([[-h, h, -h], [-h, h, h], [h, h, h], [h, h, -h]], 0),
        ([[-h, -h, -h], [-h, h, -h], [h, h, -h], [h, -h, -h]], 0),
        ([[-h, -h, h], [h, -h, h], [h, h, h], [-h, h, h]], 0),
        ([[-h, -h, -h], [-h, -h, h], [-h, h, h], [-h, h, -h]], 0),
        ([[h, -h, -h], [h, h, -h], [h, h, h], [h, -h, h]], 0),
        ([[-l, y, -l], [-l, y, l], [l, y, l], [l, y, -l]], 1),
    ];
    let mut bin = Vec::new();
    for (q, _) in &quads {
        for p in q {
            for c in p {
                bin.extend_from_slice(&(c * scale).to_le_bytes());
            }
        }
    }
    let positions = bin.len();
    for (k, _) in quads.iter().enumerate() {
        for i in [0u16, 1, 2, 0, 2, 3] {
            bin.extend_from_slice(&(4 * k as u16 + i).to_le_bytes());
        }
    }
    let (lo, hi) = (-h * scale, h * scale);
    let prims: Vec<String> = quads
        .iter()
        .enumerate()
        .map(|(k, (_, m))| {
            format!(
                r#"{{"attributes": {{"POSITION": 0}}, "indices": {}, "material": {m}}}"#,
                k + 1
            )
        })
        .collect();
    let views: Vec<String> = (0..quads.len())
        .map(|k| {
            format!(
                r#"{{"buffer": 0, "byteOffset": {}, "byteLength": 12}}"#,
                positions + 12 * k
            )
        })
        .collect();
    let accessors: Vec<String> = (0..quads.len())
        .map(|k| {
            format!(
                r#"{{"bufferView": {}, "componentType": 5123, "count": 6, "type": "SCALAR"}}"#,
                k + 1
            )
        })
        .collect();
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0, 0, {cz:e}]}}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.9, "znear": 0.01, "aspectRatio": 1.0}}}}],
  "meshes": [{{"primitives": [{prims}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0}}}},
    {{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0}}, "emissiveFactor": [1, 1, 1],
      "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 10}}}}}}],
  "extensionsUsed": ["KHR_materials_emissive_strength"],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {positions}}}, {views}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 28, "type": "VEC3", "min": [{lo:e}, {lo:e}, {lo:e}], "max": [{hi:e}, {hi:e}, {hi:e}]}}, {accessors}]}}"#,
        cz = 0.8 * scale,
        prims = prims.join(", "),
        len = bin.len(),
        b64 = base64(&bin),
        views = views.join(", "),
        accessors = accessors.join(", "),
    )
}
