//! The default framing of a scene without a camera: look at the bounding box from the side
//! that shows the most of the scene's inside.
//!
//! Candidate views look at the box's centre from outside its bounding sphere (45 degrees
//! vertical field of view, y up): from the four sides and the four diagonals raised by 25
//! degrees, and from above (60 degrees, slightly penalised). A scene that is (nearly) planar is
//! looked at across its plane, never edge-on. Each candidate casts a small grid of rays
//! through the CPU BVH and scores the hits by how deep into the bounding box they land: a box
//! open on one side (the usual Cornell box files) scores highest from its open side, where the
//! rays reach the back wall, and lowest from behind, where they stop at the outside of the back
//! wall. Ties keep the earlier candidate (+z first: glTF's "front").

use glam::Vec3;

use crate::scene::{Camera, Scene};
use crate::trace::{Bvh, Ray};

impl Scene {
    /// The scene's camera, or a default framing at `width` x `height`: the whole bounding
    /// sphere in a 45 degree vertical field of view, y up, from the side that shows the most of
    /// the scene's inside (an open box from its open side; a planar scene across its plane,
    /// never edge-on). See [`crate::framing`].
    pub fn camera_or_default(&self, width: u32, height: u32) -> Camera {
        if let Some(c) = self.camera {
            return Camera { width, height, ..c };
        }
        default_camera(self, width, height)
    }
}

/// Vertical field of view of the default framing, degrees.
pub const DEFAULT_VFOV_DEG: f32 = 45.0;

/// Rays per side of the grid each candidate view casts.
const GRID: u32 = 24;

/// A scene whose thinnest bounding-box side is below this fraction of its largest is planar.
const PLANAR: f32 = 0.02;

/// The candidate directions from the centre towards the eye, each with its score weight.
fn candidates(lo: Vec3, hi: Vec3) -> Vec<(Vec3, f32)> {
    let ext = hi - lo;
    let max = ext.max_element();
    let thin = (0..3)
        .min_by(|&a, &b| ext[a].total_cmp(&ext[b]))
        .unwrap_or(1);
    if max > 0.0 && ext[thin] < PLANAR * max {
        // Across the plane, tilted by 20 degrees (towards +z, or +y when the plane is
        // vertical) so that an axis-aligned layout still shows some depth.
        let n = Vec3::AXES[thin];
        let tilt = if thin == 1 { Vec3::Z } else { Vec3::Y };
        let t = 20f32.to_radians().tan();
        return vec![
            ((n + t * tilt).normalize(), 1.0),
            ((-n + t * tilt).normalize(), 1.0),
        ];
    }
    let (s, c) = 25f32.to_radians().sin_cos();
    let mut v: Vec<(Vec3, f32)> = [
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::X,
        Vec3::NEG_X,
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, -1.0),
    ]
    .into_iter()
    .map(|h| ((h.normalize() * c + Vec3::Y * s).normalize(), 1.0))
    .collect();
    let (s, c) = 60f32.to_radians().sin_cos();
    v.push(((Vec3::Z * c + Vec3::Y * s).normalize(), 0.9));
    v
}

/// Where a ray enters and leaves the box, `(t_in, t_out)`, or `None` when it misses.
fn slab(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let inv = dir.recip();
    let a = (lo - origin) * inv;
    let b = (hi - origin) * inv;
    let t_in = a.min(b).max_element().max(0.0);
    let t_out = a.max(b).min_element();
    (t_in <= t_out).then_some((t_in, t_out))
}

/// A camera at `eye` looking at `target`, y up (z up when looking along y).
fn look(eye: Vec3, target: Vec3, width: u32, height: u32) -> Camera {
    let fwd = (target - eye).normalize_or_zero();
    let up = if fwd.cross(Vec3::Y).length() < 1e-3 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    Camera {
        eye,
        target,
        up,
        vfov_deg: DEFAULT_VFOV_DEG,
        width,
        height,
    }
}

/// How much of the scene's inside the view shows: per ray, 0 for a miss, else 0.5 plus the
/// fraction of the box's depth along the ray at which the first hit lies.
fn score(bvh: &Bvh, cam: &Camera, lo: Vec3, hi: Vec3) -> f32 {
    let fwd = (cam.target - cam.eye).normalize();
    let right = fwd.cross(cam.up).normalize();
    let up = right.cross(fwd);
    let half = (0.5 * cam.vfov_deg.to_radians()).tan();
    let diag = (hi - lo).length();
    let mut sum = 0.0;
    for j in 0..GRID {
        for i in 0..GRID {
            let x = ((i as f32 + 0.5) / GRID as f32 * 2.0 - 1.0) * half;
            let y = ((j as f32 + 0.5) / GRID as f32 * 2.0 - 1.0) * half;
            let dir = (fwd + x * right + y * up).normalize();
            let hit = bvh.closest_hit(&Ray::new(cam.eye, dir, 0.0, f32::INFINITY));
            if !hit.is_hit() {
                continue;
            }
            let depth = match slab(cam.eye, dir, lo, hi) {
                Some((t_in, t_out)) if t_out - t_in > 1e-3 * diag => {
                    ((hit.t - t_in) / (t_out - t_in)).clamp(0.0, 1.0)
                }
                _ => 0.0,
            };
            sum += 0.5 + depth;
        }
    }
    sum / (GRID * GRID) as f32
}

/// The default framing of `scene` at `width` x `height` (see the module documentation).
///
/// A scene in very small or very large units is framed as its copy scaled by a power of two
/// (exact) into an extent of [1, 2), the camera scaled back: obvhs's CPU node test clamps t
/// to an absolute 1e-4, so in a scene of 2e-6 units every scoring ray missed, every view
/// tied, and an open scene was looked at from behind its back wall (issue 60).
pub fn default_camera(scene: &Scene, width: u32, height: u32) -> Camera {
    let extent = scene
        .bounds()
        .map_or(1.0, |(lo, hi)| (hi - lo).max_element());
    if extent.is_finite() && extent > 0.0 && !(1.0 / 1024.0..=1024.0).contains(&extent) {
        let k = crate::scene::unit_extent_scale(extent);
        return framed(&scene.scaled(k), width, height).scaled(1.0 / k);
    }
    framed(scene, width, height)
}

/// [`default_camera`] in the scene's own units.
fn framed(scene: &Scene, width: u32, height: u32) -> Camera {
    let (lo, hi) = scene
        .bounds()
        .filter(|(lo, hi)| lo.is_finite() && hi.is_finite())
        .unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let center = 0.5 * (lo + hi);
    let r = 0.5 * (hi - lo).length();
    let radius = if r > 0.0 && r.is_finite() { r } else { 1.0 };
    let dist = radius / (0.5 * DEFAULT_VFOV_DEG.to_radians()).sin();
    let views: Vec<(Camera, f32)> = candidates(lo, hi)
        .into_iter()
        .map(|(d, w)| (look(center + d * dist, center, width, height), w))
        .collect();
    let Ok(bvh) = Bvh::build(scene) else {
        return views[0].0;
    };
    let mut best = (views[0].0, f32::NEG_INFINITY);
    for (cam, w) in views {
        let s = w * score(&bvh, &cam, lo, hi);
        // A later candidate must be clearly better (ties keep the earlier one).
        if s > best.1 * 1.01 + 1e-6 {
            best = (cam, s);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Material;

    /// A box open on the +z side (five walls), with a ceiling light inside.
    fn open_box(open_towards_minus_z: bool) -> Scene {
        let mut s = Scene::default();
        let m = s.add_material(Material::new([0.7; 3], [0.0; 3]));
        let mut full = Scene::default();
        full.push_box(Vec3::ZERO, Vec3::ONE, m);
        // push_box order: bottom, top, z = lo, z = hi, x = lo, x = hi (two triangles each).
        let skip = if open_towards_minus_z { 2 } else { 3 };
        for (i, t) in full.triangles.iter().enumerate() {
            if i / 2 != skip {
                s.triangles.push(*t);
            }
        }
        s
    }

    #[test]
    fn an_open_box_is_framed_from_its_open_side() {
        for (minus, sign) in [(false, 1.0), (true, -1.0)] {
            let s = open_box(minus);
            let c = default_camera(&s, 32, 32);
            c.validate().unwrap();
            let dir = (c.eye - Vec3::splat(0.5)).normalize();
            assert!(
                dir.z * sign > 0.5,
                "open towards {}z: eye direction {dir}",
                if minus { "-" } else { "+" }
            );
        }
        // Control: the old framing (from -z, at the back of a box open towards +z) scores
        // far lower than the open side.
        let s = open_box(false);
        let bvh = Bvh::build(&s).unwrap();
        let (lo, hi) = s.bounds().unwrap();
        let c = Vec3::splat(0.5);
        let front = score(&bvh, &look(c + Vec3::Z * 3.0, c, 8, 8), lo, hi);
        let back = score(&bvh, &look(c - Vec3::Z * 3.0, c, 8, 8), lo, hi);
        assert!(front > 1.5 * back, "front {front} back {back}");
        // A closed box is framed from some side, validly.
        let mut s = Scene::default();
        s.push_box(Vec3::ZERO, Vec3::ONE, 0);
        default_camera(&s, 32, 32).validate().unwrap();
    }

    #[test]
    fn a_planar_scene_is_never_seen_edge_on() {
        for n in [Vec3::X, Vec3::Y, Vec3::Z] {
            let (a, b) = (
                n.any_orthonormal_vector(),
                n.cross(n.any_orthonormal_vector()),
            );
            let mut s = Scene::default();
            s.push_quad(
                [-a - b, a - b, a + b, -a + b].map(|p| p * 3.0 + Vec3::ONE),
                0,
            );
            let c = default_camera(&s, 16, 16);
            c.validate().unwrap();
            let fwd = (c.target - c.eye).normalize();
            assert!(fwd.dot(n).abs() > 0.8, "plane normal {n}: view {fwd}");
        }
    }

    #[test]
    fn tiny_and_huge_scenes_are_framed_at_their_scale() {
        for (scale, minus) in [(1e-9f32, false), (1e-9, true), (1e8, false), (1e8, true)] {
            let s = open_box(minus);
            let mut t = s.clone();
            for tri in &mut t.triangles {
                tri.v = tri.v.map(|v| v * scale);
            }
            let c = default_camera(&t, 8, 8);
            c.validate().unwrap();
            let d = (c.eye - c.target).length() / scale;
            assert!((1.0..10.0).contains(&d), "scale {scale}: distance {d}");
            // From the open side, as at scale 1 (at 1e-9 every scoring ray missed before
            // the framing scaled the scene: the views tied, and +z, the first, won).
            let dir = (c.eye / scale - Vec3::splat(0.5)).normalize();
            let sign = if minus { -1.0 } else { 1.0 };
            assert!(dir.z * sign > 0.5, "scale {scale}: eye direction {dir}");
        }
    }
}
