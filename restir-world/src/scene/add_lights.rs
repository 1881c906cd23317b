//! [`add_lights`]: turns any scene into a many-light scene by placing small emissive quads on
//! its own surfaces.

use glam::Vec3;
use reservoir::rng::Rng;

use super::{MAX_EMISSION, Material, Scene, SceneError};

/// Smallest light size relative to the scene's largest coordinate (or extent).
pub const MIN_RELATIVE_SIZE: f32 = 1e-5;

/// Most lights [`add_lights`] places in one call.
pub const MAX_ADDED_LIGHTS: u32 = 1_000_000;

/// What [`add_lights`] places.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AddLights {
    /// Number of lights (square quads, two triangles each); at most [`MAX_ADDED_LIGHTS`].
    pub count: u32,
    /// Power of each light (W, both sides together, grey): its radiance is
    /// `power / (2 pi size^2)`. `None`: the lights together emit `pi / 4` per unit of the
    /// scene's surface area (so a white surface looks about 0.25 before tone mapping,
    /// whatever the scene's units).
    pub power: Option<f32>,
    /// Side length of each quad in scene units. `None`: 0.5% of the bounding box's diagonal.
    pub size: Option<f32>,
    /// Seed of the placement.
    pub seed: u32,
}

/// Where [`add_lights`] put the lights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AddedLights {
    /// Index of the lights' (shared) material.
    pub material: u32,
    /// Index of the first added triangle; the lights are the triangles from there to the end.
    pub first_triangle: usize,
    /// Side length and power of each light.
    pub size: f32,
    pub power: f32,
}

/// Places `opts.count` small square emissive quads on the scene's non-emissive surfaces:
/// triangles picked with probability proportional to their area, a uniform point on the
/// triangle, the quad parallel to the triangle at half its side above it, facing away from it.
/// The side above is the one the triangle's shading normals point to (else its winding's),
/// flipped when that side leaves the scene's bounding box while the other stays inside (so
/// lights on the walls of a room face into it). Deterministic in `opts.seed`; the scene's
/// triangles before the call are unchanged. `count == 0` adds nothing.
pub fn add_lights(scene: &mut Scene, opts: &AddLights) -> Result<AddedLights, SceneError> {
    if opts.count > MAX_ADDED_LIGHTS {
        return bad(format!(
            "{} lights is above the limit of {MAX_ADDED_LIGHTS}",
            opts.count
        ));
    }
    for (what, v) in [("power", opts.power), ("size", opts.size)] {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return bad(format!("{what} {v} must be a finite number above 0"));
        }
    }
    let Some((lo, hi)) = scene.bounds() else {
        return bad("the scene has no triangles to place lights on".into());
    };
    let size = opts.size.unwrap_or(0.005 * (hi - lo).length());
    check_size(size, lo, hi)?;
    let (cdf, which, total) = area_cdf(scene);
    if which.is_empty() {
        return bad("the scene has no non-emissive surface to place lights on".into());
    }
    let area = size * size;
    let power = opts
        .power
        .unwrap_or((std::f64::consts::PI / 4.0 * total / f64::from(opts.count.max(1))) as f32);
    let radiance = power / (2.0 * std::f32::consts::PI * area);
    if !(radiance.is_finite() && radiance > 0.0 && radiance <= MAX_EMISSION) {
        return bad(format!(
            "power {power:e} over a {size:e} x {size:e} quad is a radiance of {radiance:e}, \
             outside (0, {MAX_EMISSION:e}]: change the power or the size"
        ));
    }
    let material = scene.add_material(Material::new([0.8; 3], [radiance; 3]));
    let first_triangle = scene.triangles.len();
    scene.triangles.reserve(2 * opts.count as usize);
    let inside = |p: Vec3| p.cmpge(lo).all() && p.cmple(hi).all();
    let mut rng = Rng::seed(0xadd11, opts.seed, 2);
    for _ in 0..opts.count {
        let u = f64::from(rng.next_f32()) * total;
        let k = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
        let t = scene.triangles[which[k]];
        // Uniform point on the triangle.
        let (r1, r2) = (rng.next_f32().sqrt(), rng.next_f32());
        let p = t.v[0] * (1.0 - r1) + t.v[1] * (r1 * (1.0 - r2)) + t.v[2] * (r1 * r2);
        let mut n = t.cross().normalize_or_zero();
        if let Some(sn) = t.n
            && (sn[0] + sn[1] + sn[2]).dot(n) < 0.0
        {
            n = -n;
        }
        let reach = 1.5 * size;
        if !inside(p + n * reach) && inside(p - n * reach) {
            n = -n;
        }
        let center = p + n * (0.5 * size);
        let (a, b) = n.any_orthonormal_pair();
        let (a, b) = (a * (0.5 * size), b * (0.5 * size));
        // Counter-clockwise seen from the side n points to: the winding faces away too.
        scene.push_quad(
            [
                center - a - b,
                center + a - b,
                center + a + b,
                center - a + b,
            ],
            material,
        );
    }
    check_added(scene, first_triangle, size)?;
    Ok(AddedLights {
        material,
        first_triangle,
        size,
        power,
    })
}

/// Area-proportional choice over the non-emissive triangles: cumulative areas (f64), the
/// triangles they belong to, and the total.
fn area_cdf(scene: &Scene) -> (Vec<f64>, Vec<usize>, f64) {
    let emissive = |m: u32| {
        scene
            .materials
            .get(m as usize)
            .is_some_and(Material::is_emissive)
    };
    let mut cdf = Vec::with_capacity(scene.triangles.len());
    let mut which = Vec::with_capacity(scene.triangles.len());
    let mut total = 0.0f64;
    for (i, t) in scene.triangles.iter().enumerate() {
        let a = f64::from(t.area());
        if emissive(t.material) || !(a.is_finite() && a > 0.0) {
            continue;
        }
        total += a;
        cdf.push(total);
        which.push(i);
    }
    (cdf, which, total)
}

fn bad<T>(m: String) -> Result<T, SceneError> {
    Err(SceneError::BadOption(format!("add-lights: {m}")))
}

/// A quad must be representable next to the scene's coordinates (smaller ones collapse to a
/// point in 32-bit floats) and no larger than the scene (larger ones overflow their area, and
/// the scene's extent).
fn check_size(size: f32, lo: Vec3, hi: Vec3) -> Result<(), SceneError> {
    if !(size.is_finite() && size > 0.0) {
        return bad(format!("the light size {size} is not a positive number"));
    }
    let extent = (hi - lo).max_element();
    let magnitude = lo.abs().max(hi.abs()).max_element().max(extent);
    let (min_size, max_size) = (MIN_RELATIVE_SIZE * magnitude, extent);
    if !(min_size..=max_size).contains(&size) {
        return bad(format!(
            "size {size:e} is outside [{min_size:e}, {max_size:e}] for this scene (from \
             {MIN_RELATIVE_SIZE:e} times its coordinates, where 32-bit floats still resolve a \
             quad, to its extent)"
        ));
    }
    Ok(())
}

/// Every added quad has a finite, non-zero area (else the light table would leave it out) and
/// the scene with them stays within [`super::SCENE_EXTENT_RANGE`].
fn check_added(scene: &Scene, first_triangle: usize, size: f32) -> Result<(), SceneError> {
    let added = &scene.triangles[first_triangle..];
    if let Some(t) = added
        .iter()
        .find(|t| !(t.area().is_finite() && t.area() > 0.0))
    {
        return bad(format!(
            "a {size:e} x {size:e} quad has an area of {:e} in 32-bit floats: change the size",
            t.area()
        ));
    }
    if let Some((lo, hi)) = scene.bounds() {
        let extent = (hi - lo).max_element();
        if !(super::SCENE_EXTENT_RANGE.0..=super::SCENE_EXTENT_RANGE.1).contains(&extent) {
            return Err(SceneError::Scale {
                what: "the scene with the added lights".into(),
                extent,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::Lights;

    /// A closed 10 m room with a 2 m crate on its floor.
    fn room() -> Scene {
        let mut s = Scene::default();
        let m = s.add_material(Material::new([0.7; 3], [0.0; 3]));
        s.push_box(Vec3::ZERO, Vec3::splat(10.0), m);
        s.push_box(Vec3::new(4.0, 0.0, 4.0), Vec3::new(6.0, 2.0, 6.0), m);
        s
    }

    fn opts(count: u32, seed: u32) -> AddLights {
        AddLights {
            count,
            power: Some(3.0),
            size: Some(0.1),
            seed,
        }
    }

    #[test]
    fn adds_count_quads_deterministically() {
        let mut a = room();
        let before = a.clone();
        let r = add_lights(&mut a, &opts(500, 7)).unwrap();
        assert_eq!(a.triangles.len(), before.triangles.len() + 1000);
        assert_eq!(a.emissive_triangles(), 1000);
        assert_eq!(a.triangles[..before.triangles.len()], before.triangles[..]);
        assert_eq!(r.first_triangle, before.triangles.len());
        let mut b = room();
        add_lights(&mut b, &opts(500, 7)).unwrap();
        assert_eq!(a, b, "same seed, same scene");
        let mut c = room();
        add_lights(&mut c, &opts(500, 8)).unwrap();
        assert_ne!(a, c, "another seed places them elsewhere");
        a.sanitize("lights").unwrap();
        assert_eq!(a.emissive_triangles(), 1000, "no light quad is degenerate");
        let mut d = room();
        add_lights(&mut d, &opts(0, 7)).unwrap();
        assert_eq!(d.emissive_triangles(), 0);
    }

    #[test]
    fn quads_sit_inside_facing_away_from_their_surface() {
        let mut s = room();
        let r = add_lights(&mut s, &opts(2000, 3)).unwrap();
        let (lo, hi) = (Vec3::ZERO, Vec3::splat(10.0));
        let crate_lo = Vec3::new(4.0, 0.0, 4.0);
        let crate_hi = Vec3::new(6.0, 2.0, 6.0);
        let mut on_crate = 0;
        for q in s.triangles[r.first_triangle..].chunks_exact(2) {
            let c = 0.5 * (q[0].v[0] + q[0].v[2]);
            let n = q[0].cross().normalize();
            assert!(
                c.cmpge(lo).all() && c.cmple(hi).all(),
                "{c} outside the room"
            );
            // The quad is parallel to an axis-aligned surface (a wall or a crate face), half
            // its side away from it, and faces away from it (n points from the plane to c).
            let a = n.abs().max_position();
            assert!(n[a].abs() > 0.9999, "{c}: normal {n} not along an axis");
            let planes = [lo[a], hi[a], crate_lo[a], crate_hi[a]];
            let (k, plane) = planes
                .iter()
                .enumerate()
                .min_by(|x, y| (c[a] - x.1).abs().total_cmp(&(c[a] - y.1).abs()))
                .unwrap();
            assert!(
                ((c[a] - plane).abs() - 0.05).abs() < 1e-4,
                "{c}: {plane} on axis {a}"
            );
            assert!(
                (c[a] - plane) * n[a] > 0.0,
                "{c}: normal {n} faces its surface"
            );
            on_crate += usize::from(k >= 2);
        }
        // The crate's area is 20 of 620 m^2: about 3% of the lights.
        assert!(
            (30..=110).contains(&on_crate),
            "{on_crate} lights on the crate"
        );
    }

    #[test]
    fn power_is_each_lights_and_the_default_scales_with_the_scene() {
        let mut s = room();
        add_lights(&mut s, &opts(100, 1)).unwrap();
        // Lights' sampling power is area x luminance: 100 x 2 triangles x (P / 2 pi).
        let p = Lights::build(&s).total_power;
        let want = 100.0 * 3.0 / std::f64::consts::TAU;
        assert!((p / want - 1.0).abs() < 1e-4, "{p} vs {want}");
        // Default power: pi/4 per unit area of the scene, independent of the count.
        for scale in [1.0f32, 1000.0] {
            let mut s = room();
            for t in &mut s.triangles {
                t.v = t.v.map(|v| v * scale);
            }
            let area: f32 = s.triangles.iter().map(|t| t.area()).sum();
            let r = add_lights(
                &mut s,
                &AddLights {
                    power: None,
                    size: None,
                    ..opts(64, 1)
                },
            )
            .unwrap();
            let total = 64.0 * r.power;
            assert!((total / (std::f32::consts::FRAC_PI_4 * area) - 1.0).abs() < 1e-3);
            assert!((r.size / (scale * 0.005 * 300f32.sqrt()) - 1.0).abs() < 1e-4);
        }
    }

    #[test]
    fn bad_options_are_refused_by_name() {
        for (o, needle) in [
            (opts(MAX_ADDED_LIGHTS + 1, 1), "limit"),
            (
                AddLights {
                    power: Some(f32::NAN),
                    ..opts(1, 1)
                },
                "power",
            ),
            (
                AddLights {
                    size: Some(-1.0),
                    ..opts(1, 1)
                },
                "size",
            ),
            (
                AddLights {
                    power: Some(1e30),
                    ..opts(1, 1)
                },
                "radiance",
            ),
        ] {
            let e = add_lights(&mut room(), &o).unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains("add-lights"), "{e}");
        }
        let mut lit = Scene::default();
        let m = lit.add_material(Material::new([0.5; 3], [1.0; 3]));
        lit.push_box(Vec3::ZERO, Vec3::ONE, m);
        let e = add_lights(&mut lit, &opts(1, 1)).unwrap_err().to_string();
        assert!(e.contains("no non-emissive surface"), "{e}");
    }
}
