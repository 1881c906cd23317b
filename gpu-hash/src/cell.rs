//! Adaptive cell keys (Boissé 2021, Algorithm 4) and tangent-plane jitter: the parameters the
//! GPU reads ([`HashGridParams`]) and the Rust twins of `hash_cell` and `hash_jitter`.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::{HashError, TableConfig, hash};

/// `HashCell::status`: the cell is valid.
pub const STATUS_OK: u32 = 0;
/// `HashCell::status`: the position has a NaN or infinite coordinate.
pub const STATUS_NONFINITE: u32 = 1;
/// `HashCell::status`: a cell coordinate would fall outside (-2^31, 2^31).
pub const STATUS_OUT_OF_RANGE: u32 = 2;

/// How cell sizes adapt to the distance from the eye (paper Algorithm 4).
///
/// The cell size at distance `d` is `min_cell_size * 2^level` with
/// `level = clamp(floor(log2(d * tan(projected_size * fov_y * max(1/height, height/width^2))
/// / min_cell_size)), 0, max_level)`: cells project to roughly `projected_size` pixels, never
/// smaller than `min_cell_size`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellSizing {
    /// Smallest cell edge in world units (default 0.01).
    pub min_cell_size: f32,
    /// Target projected cell size in pixels (default 16).
    pub projected_size: f32,
    /// Vertical field of view in radians (default 60 degrees).
    pub fov_y: f32,
    /// Sensor width in pixels (default 1920).
    pub width: u32,
    /// Sensor height in pixels (default 1080).
    pub height: u32,
    /// Coarsest level (default 24): cells are at most `min_cell_size * 2^max_level`.
    pub max_level: u32,
}

impl Default for CellSizing {
    fn default() -> Self {
        Self {
            min_cell_size: 0.01,
            projected_size: 16.0,
            fov_y: 60f32.to_radians(),
            width: 1920,
            height: 1080,
            max_level: 24,
        }
    }
}

/// The per-table uniform the WGSL library reads (`HashGridParams` in `hash.wgsl`): one eye and
/// cell sizing, and the table's dimensions. Build it with [`HashGridParams::new`]; every
/// derived value is computed here once, so the GPU and the twin use the same bits.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct HashGridParams {
    /// Eye position the cell size is measured from.
    pub eye: [f32; 3],
    /// `tan(projected_size * fov_y * max(1/height, height/width^2)) / min_cell_size`.
    pub level_scale: f32,
    pub min_cell_size: f32,
    /// `1 / min_cell_size` rounded to f32: cell coordinates are
    /// `floor(pos * inv_min_cell_size * 2^-level)`.
    pub inv_min_cell_size: f32,
    pub max_level: u32,
    pub num_buckets: u32,
    pub slots_per_bucket: u32,
    pub probe_buckets: u32,
    pub _pad: [u32; 2],
}

/// A grid cell: integer coordinates at a level (`HashKey` in `hash.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Pod, Zeroable)]
pub struct HashKey {
    pub coords: [i32; 3],
    pub level: u32,
}

impl HashKey {
    /// Bucket `h1(level + h1(z + h1(y + h1(x)))) % num_buckets` with `h1` = [`hash::pcg`].
    pub fn bucket(&self, num_buckets: u32) -> u32 {
        let [x, y, z] = self.coords.map(|c| c as u32);
        let h = hash::pcg(self.level.wrapping_add(hash::pcg(
            z.wrapping_add(hash::pcg(y.wrapping_add(hash::pcg(x)))),
        )));
        h % num_buckets
    }

    /// Checksum `max(h2(level + h2(z + h2(y + h2(x)))), 1)` with `h2` = [`hash::xxhash32`].
    pub fn checksum(&self) -> u32 {
        let [x, y, z] = self.coords.map(|c| c as u32);
        let h2 = hash::xxhash32;
        h2(self
            .level
            .wrapping_add(h2(z.wrapping_add(h2(y.wrapping_add(h2(x)))))))
        .max(1)
    }
}

/// The cell of a position (`HashCell` in `hash.wgsl`, the 8 words the `cells` batch kernel
/// writes). Unless `status == STATUS_OK` every other field is 0.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct HashCell {
    pub coords: [i32; 3],
    pub level: u32,
    pub bucket: u32,
    pub checksum: u32,
    pub cell_size: f32,
    pub status: u32,
}

impl HashCell {
    pub fn key(&self) -> HashKey {
        HashKey {
            coords: self.coords,
            level: self.level,
        }
    }

    pub fn is_ok(&self) -> bool {
        self.status == STATUS_OK
    }
}

/// Exact 2^e for e in [-126, 127].
fn pow2(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

fn is_finite_bits(x: f32) -> bool {
    x.to_bits() & 0x7f80_0000 != 0x7f80_0000
}

impl HashGridParams {
    /// Parameters for a table of `table`'s size whose cells are sized by `sizing` around `eye`.
    pub fn new(table: &TableConfig, sizing: &CellSizing, eye: Vec3) -> Result<Self, HashError> {
        table.validate()?;
        let bad = |why: String| Err(HashError::InvalidSizing(why));
        let s = sizing;
        if !(s.min_cell_size.is_normal() && s.min_cell_size > 0.0) {
            return bad(format!(
                "min_cell_size {} must be a normal f32 > 0",
                s.min_cell_size
            ));
        }
        if !(s.projected_size.is_finite() && s.projected_size > 0.0) {
            return bad(format!(
                "projected_size {} must be finite and > 0",
                s.projected_size
            ));
        }
        if !(s.fov_y > 0.0 && s.fov_y < std::f32::consts::PI) {
            return bad(format!("fov_y {} must be in (0, pi) radians", s.fov_y));
        }
        if s.width == 0 || s.height == 0 {
            return bad(format!(
                "resolution {}x{} must be non-zero",
                s.width, s.height
            ));
        }
        if !eye.is_finite() {
            return bad(format!("eye {eye} must be finite"));
        }
        let (w, h) = (f64::from(s.width), f64::from(s.height));
        let angle = f64::from(s.projected_size) * f64::from(s.fov_y) * (1.0 / h).max(h / (w * w));
        if angle >= std::f64::consts::FRAC_PI_2 {
            return bad(format!(
                "projected_size * fov_y * max(1/height, height/width^2) = {angle} rad must be \
                 below pi/2"
            ));
        }
        let min = f64::from(s.min_cell_size);
        let inv_min = (1.0 / min) as f32;
        let level_scale = (angle.tan() / min) as f32;
        // Every cell size and coordinate scale must be a normal f32, so the GPU (which may
        // flush subnormals) and the twin agree.
        let coarsest = min * 2f64.powi(s.max_level as i32);
        let finest_scale = f64::from(inv_min) * 2f64.powi(-(s.max_level as i32));
        if s.max_level > 100
            || coarsest >= f64::from(f32::MAX)
            || finest_scale < f64::from(f32::MIN_POSITIVE)
            || !inv_min.is_normal()
            || !level_scale.is_normal()
        {
            return bad(format!(
                "min_cell_size {} with max_level {} leaves the range of normal f32 values",
                s.min_cell_size, s.max_level
            ));
        }
        Ok(Self {
            eye: eye.to_array(),
            level_scale,
            min_cell_size: s.min_cell_size,
            inv_min_cell_size: inv_min,
            max_level: s.max_level,
            num_buckets: table.num_buckets,
            slots_per_bucket: table.slots_per_bucket,
            probe_buckets: table.probe_buckets,
            _pad: [0; 2],
        })
    }

    /// The same parameters seen from another eye (e.g. this frame's camera).
    pub fn with_eye(mut self, eye: Vec3) -> Result<Self, HashError> {
        if !eye.is_finite() {
            return Err(HashError::InvalidSizing(format!(
                "eye {eye} must be finite"
            )));
        }
        self.eye = eye.to_array();
        Ok(self)
    }

    /// Twin of `hash_cell_level`.
    pub fn cell_level(&self, pos: Vec3) -> u32 {
        let eye = Vec3::from_array(self.eye);
        let d = pos - eye;
        let dist = (d.x * d.x + d.y * d.y + d.z * d.z).sqrt();
        let ratio = dist * self.level_scale;
        let e = ((ratio.to_bits() >> 23) & 0xff) as i32 - 127;
        e.clamp(0, self.max_level as i32) as u32
    }

    /// Twin of `hash_cell_size_at`.
    pub fn cell_size_at(&self, level: u32) -> f32 {
        self.min_cell_size * pow2(level as i32)
    }

    /// Twin of `hash_cell_size`.
    pub fn cell_size(&self, pos: Vec3) -> f32 {
        self.cell_size_at(self.cell_level(pos))
    }

    /// Twin of `hash_cell`: the same level, coordinates, bucket, checksum and status.
    pub fn cell(&self, pos: Vec3) -> HashCell {
        let mut cell = HashCell::zeroed();
        if !(is_finite_bits(pos.x) && is_finite_bits(pos.y) && is_finite_bits(pos.z)) {
            cell.status = STATUS_NONFINITE;
            return cell;
        }
        let level = self.cell_level(pos);
        let q = pos * (self.inv_min_cell_size * pow2(-(level as i32)));
        if q.to_array()
            .iter()
            .any(|v| v.to_bits() & 0x7fff_ffff >= 0x4f00_0000)
        {
            cell.status = STATUS_OUT_OF_RANGE;
            return cell;
        }
        let key = HashKey {
            coords: q.to_array().map(|v| v.floor() as i32),
            level,
        };
        HashCell {
            coords: key.coords,
            level,
            bucket: key.bucket(self.num_buckets),
            checksum: key.checksum(),
            cell_size: self.cell_size_at(level),
            status: STATUS_OK,
        }
    }
}

/// Twin of `hash_jitter`: `pos + cell_size * ((u.x - 0.5) t + (u.y - 0.5) b)` with (t, b) an
/// orthonormal basis of the plane orthogonal to the unit `normal` (Duff et al. 2017). The GPU
/// divides with the precision WGSL allows (2.5 ulp), so compare with a tolerance.
pub fn jitter(pos: Vec3, normal: Vec3, u: [f32; 2], cell_size: f32) -> Vec3 {
    let (t, b) = tangent_basis(normal);
    pos + (t * (u[0] - 0.5) + b * (u[1] - 0.5)) * cell_size
}

/// The tangent basis `hash_jitter` uses.
pub fn tangent_basis(n: Vec3) -> (Vec3, Vec3) {
    let s = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> HashGridParams {
        HashGridParams::new(&TableConfig::default(), &CellSizing::default(), Vec3::ZERO).unwrap()
    }

    #[test]
    fn distance_zero_is_level_zero_and_min_size() {
        let p = params();
        let c = p.cell(Vec3::ZERO);
        assert!(c.is_ok());
        assert_eq!((c.level, c.coords), (0, [0, 0, 0]));
        assert_eq!(c.cell_size, 0.01);
    }

    #[test]
    fn levels_follow_algorithm_4() {
        let s = CellSizing::default();
        let p = params();
        let angle = f64::from(s.projected_size)
            * f64::from(s.fov_y)
            * (1.0 / 1080f64).max(1080.0 / (1920.0f64 * 1920.0));
        for d in [0.5f64, 1.0, 3.0, 10.0, 100.0, 1000.0, 1e4] {
            let step = d * angle.tan();
            let want = (step / 0.01).log2().floor().clamp(0.0, 24.0) as u32;
            let got = p.cell_level(Vec3::new(0.0, 0.0, d as f32));
            assert_eq!(got, want, "distance {d}");
            let size = p.cell_size(Vec3::new(0.0, 0.0, d as f32));
            assert_eq!(f64::from(size), 0.01f32 as f64 * 2f64.powi(want as i32));
        }
        // Monotone in distance, capped at max_level.
        let mut last = 0;
        for i in 0..200 {
            let l = p.cell_level(Vec3::new(1.1f32.powi(i), 0.0, 0.0));
            assert!(l >= last && l <= 24);
            last = l;
        }
        assert_eq!(p.cell_level(Vec3::new(1e30, 0.0, 0.0)), 24);
    }

    #[test]
    fn nonfinite_and_far_positions_are_rejected() {
        let p = params();
        for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for axis in 0..3 {
                let mut a = [1.0f32; 3];
                a[axis] = v;
                assert_eq!(p.cell(Vec3::from_array(a)).status, STATUS_NONFINITE);
            }
        }
        // Level 24 cells are 167772.16 wide: 1e20 is ~6e14 cells out, beyond i32.
        assert_eq!(
            p.cell(Vec3::new(1e20, 0.0, 0.0)).status,
            STATUS_OUT_OF_RANGE
        );
        assert_eq!(
            p.cell(Vec3::new(0.0, -3e38, 0.0)).status,
            STATUS_OUT_OF_RANGE
        );
        assert_eq!(p.cell(Vec3::MAX).status, STATUS_OUT_OF_RANGE);
        // Just inside and just outside 2^31 cells at the coarsest level.
        let size = f64::from(p.cell_size_at(24));
        let inside = (2f64.powi(31) * size * 0.999) as f32;
        let outside = (2f64.powi(31) * size * 1.001) as f32;
        assert!(p.cell(Vec3::new(inside, 0.0, 0.0)).is_ok());
        assert_eq!(
            p.cell(Vec3::new(outside, 0.0, 0.0)).status,
            STATUS_OUT_OF_RANGE
        );
        let c = p.cell(Vec3::new(-inside, 0.0, 0.0));
        assert!(c.is_ok() && c.coords[0] < -2_000_000_000);
    }

    #[test]
    fn level_goes_into_bucket_and_checksum() {
        let a = HashKey {
            coords: [3, -4, 5],
            level: 2,
        };
        let b = HashKey { level: 3, ..a };
        assert_ne!(a.checksum(), b.checksum());
        assert_ne!(a.bucket(1 << 30), b.bucket(1 << 30));
    }

    #[test]
    fn invalid_sizing_is_an_error() {
        let t = TableConfig::default();
        let ok = CellSizing::default();
        for s in [
            CellSizing {
                min_cell_size: 0.0,
                ..ok
            },
            CellSizing {
                min_cell_size: f32::NAN,
                ..ok
            },
            CellSizing { fov_y: 0.0, ..ok },
            CellSizing { fov_y: 4.0, ..ok },
            CellSizing { height: 0, ..ok },
            CellSizing {
                projected_size: -1.0,
                ..ok
            },
            CellSizing {
                projected_size: 1e6,
                ..ok
            },
            CellSizing {
                min_cell_size: 1e30,
                max_level: 40,
                ..ok
            },
            CellSizing {
                min_cell_size: 1e-39,
                max_level: 0,
                ..ok
            },
            CellSizing {
                min_cell_size: 1e-30,
                max_level: 127,
                ..ok
            },
        ] {
            assert!(HashGridParams::new(&t, &s, Vec3::ZERO).is_err(), "{s:?}");
        }
        assert!(HashGridParams::new(&t, &ok, Vec3::NAN).is_err());
    }

    #[test]
    fn jitter_stays_in_the_tangent_plane() {
        let mut x = 1u32;
        let mut next = || {
            x = hash::pcg(x);
            (x >> 8) as f32 / 16_777_216.0
        };
        for _ in 0..10_000 {
            let n = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::Z);
            let u = [next(), next()];
            let p = Vec3::new(1.0, 2.0, 3.0);
            let j = jitter(p, n, u, 0.5);
            let off = j - p;
            assert!(off.dot(n).abs() < 1e-5, "{n} {off}");
            assert!(off.length() <= 0.5 * std::f32::consts::SQRT_2 * 0.5 + 1e-5);
        }
        // Poles and the zero normal stay finite.
        for n in [Vec3::Z, -Vec3::Z, Vec3::ZERO, Vec3::new(0.0, 0.0, -0.0)] {
            assert!(jitter(Vec3::ONE, n, [0.9, 0.1], 1.0).is_finite(), "{n}");
        }
    }
}
