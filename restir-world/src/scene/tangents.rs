//! Tangent frames for normal maps: MikkTSpace tangents (the `mikktspace` crate, a port of
//! Mikkelsen's reference implementation, which glTF names for files without `TANGENT`) and
//! the checks that decide whether a triangle's tangents can carry its normal map.
//!
//! Conventions (glTF 2.0's): a tangent's xyz is the unit direction of increasing u, its w = +-1
//! the handedness, and the bitangent `w cross(n, t)` points towards the top of the image
//! (decreasing v: glTF's texture coordinates start at the image's top-left corner; a normal
//! texture's +y is "up"). MikkTSpace's own bitangent runs along increasing v, so it is given
//! (u, 1 - v): the same tangents, the handedness of glTF's convention (what exporters that
//! flip v on export write).

use glam::{Vec2, Vec3, Vec4};

use super::Triangle;

/// Smallest sine of the angle between a tangent and its normal: below it the tangent is
/// taken as parallel to the normal (no frame).
pub const MIN_TANGENT_SINE: f32 = 1e-3;

/// The unit normal a triangle's corner shades with: its vertex normal, else the geometric one
/// (the winding's, `Triangle::cross`); zero where neither has a length.
pub fn corner_normal(t: &Triangle, corner: usize) -> Vec3 {
    match t.n {
        Some(n) => n[corner].normalize_or_zero(),
        None => t.cross().normalize_or_zero(),
    }
}

/// Whether the triangle's texture coordinates span an area: not collinear (the sine of their
/// angle above 1e-7, as `Triangle::is_degenerate` for positions), finite. False without them.
pub fn uv_area_ok(t: &Triangle) -> bool {
    let Some(uv) = t.uv else { return false };
    let uv = uv.map(|p| p.as_dvec2());
    let (a, b) = (uv[1] - uv[0], uv[2] - uv[0]);
    let area = a.perp_dot(b).abs();
    let longest = a
        .length_squared()
        .max(b.length_squared())
        .max((uv[2] - uv[1]).length_squared());
    area.is_finite() && area > 0.0 && area > 1e-7 * longest
}

/// Whether one corner's tangent gives a frame with its normal: finite, w nonzero, a length,
/// not parallel to the normal (sine above [`MIN_TANGENT_SINE`]).
pub fn corner_usable(n: Vec3, t: Vec4) -> bool {
    let xyz = t.truncate();
    if !(t.is_finite() && t.w != 0.0 && xyz.length_squared() > 1e-12) || n == Vec3::ZERO {
        return false;
    }
    n.cross(xyz.normalize()).length() > MIN_TANGENT_SINE
}

/// Whether a triangle's tangents ([`Triangle::t`]) can carry a normal map: present, texture
/// coordinates that span an area, and every corner [`corner_usable`].
pub fn usable(t: &Triangle) -> bool {
    let Some(tan) = t.t else { return false };
    uv_area_ok(t) && (0..3).all(|c| corner_usable(corner_normal(t, c), tan[c]))
}

/// The triangles as MikkTSpace sees them (each corner its own vertex: the algorithm welds
/// corners with equal position, normal and texture coordinates itself).
struct Faces<'a> {
    tris: &'a [Triangle],
    out: Vec<[Vec4; 3]>,
}

impl mikktspace::Geometry for Faces<'_> {
    fn num_faces(&self) -> usize {
        self.tris.len()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.tris[face].v[vert].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        corner_normal(&self.tris[face], vert).to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        let uv = self.tris[face].uv.map_or(Vec2::ZERO, |uv| uv[vert]);
        [uv.x, 1.0 - uv.y]
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.out[face][vert] = Vec4::from_array(tangent);
    }
}

/// MikkTSpace tangents of `tris` (one mesh: the corners they share are welded), per corner in
/// glTF's convention (see the module). Triangles without texture coordinates get zero
/// tangents, as do all when the algorithm refuses the mesh; [`usable`] tells which to keep.
pub fn generate(tris: &[Triangle]) -> Vec<[Vec4; 3]> {
    let mut faces = Faces {
        tris,
        out: vec![[Vec4::ZERO; 3]; tris.len()],
    };
    if tris.is_empty() || !mikktspace::generate_tangents(&mut faces) {
        return vec![[Vec4::ZERO; 3]; tris.len()];
    }
    for (t, out) in tris.iter().zip(&mut faces.out) {
        if t.uv.is_none() {
            *out = [Vec4::ZERO; 3];
        }
    }
    faces.out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(uv_flip_u: bool) -> Vec<Triangle> {
        let p = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]].map(|[x, y]| Vec3::new(x, y, 0.0));
        // glTF: v = 0 at the image's top, so the quad's top (+y) has v = 0.
        let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]]
            .map(|[u, v]| Vec2::new(if uv_flip_u { 1.0 - u } else { u }, v));
        [[0, 1, 2], [0, 2, 3]]
            .map(|[a, b, c]| Triangle {
                n: Some([Vec3::Z; 3]),
                uv: Some([uv[a], uv[b], uv[c]]),
                ..Triangle::new([p[a], p[b], p[c]], 0)
            })
            .to_vec()
    }

    /// A quad facing +z, u along +x and the image's top at +y: tangent +x, bitangent
    /// w cross(z, x) = +y with w = 1; with u mirrored, tangent -x and w = -1 (the same +y).
    #[test]
    fn generated_tangents_follow_gltf_convention() {
        for (flip, want) in [
            (false, Vec4::new(1.0, 0.0, 0.0, 1.0)),
            (true, Vec4::new(-1.0, 0.0, 0.0, -1.0)),
        ] {
            let tris = quad(flip);
            let t = generate(&tris);
            for (tri, tan) in tris.iter().zip(&t) {
                for c in tan {
                    assert!((*c - want).length() < 1e-5, "flip {flip}: {c}");
                    let b = c.w * Vec3::Z.cross(c.truncate());
                    assert!((b - Vec3::Y).length() < 1e-5);
                }
                let mut tri = *tri;
                tri.t = Some(*tan);
                assert!(usable(&tri));
            }
        }
    }

    #[test]
    fn degenerate_tangents_are_refused() {
        let mut t = quad(false)[0];
        t.t = Some([Vec4::new(1.0, 0.0, 0.0, 1.0); 3]);
        assert!(usable(&t));
        for bad in [
            Vec4::ZERO,
            Vec4::new(f32::NAN, 0.0, 0.0, 1.0),
            Vec4::new(0.0, 0.0, 1.0, 1.0),
            Vec4::new(1.0, 0.0, 0.0, 0.0),
        ] {
            let mut b = t;
            b.t = Some([
                Vec4::new(1.0, 0.0, 0.0, 1.0),
                bad,
                Vec4::new(1.0, 0.0, 0.0, 1.0),
            ]);
            assert!(!usable(&b), "{bad}");
        }
        let mut flat_uv = t;
        flat_uv.uv = Some([Vec2::ZERO, Vec2::X, Vec2::new(2.0, 0.0)]);
        assert!(!usable(&flat_uv));
        let mut no_uv = t;
        no_uv.uv = None;
        assert!(!usable(&no_uv));
    }
}
