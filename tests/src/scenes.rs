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
