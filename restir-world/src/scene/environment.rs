//! Environment light: radiance arriving from infinitely far away in every direction, a constant
//! sky or an equirectangular (latitude-longitude) map, as seen by rays that miss the scene.
//!
//! Map convention: pixel (x, y) of a `width` x `height` map covers the azimuths
//! phi in [2 pi x / width, 2 pi (x + 1) / width) and the polar angles (from +y, up)
//! theta in [pi y / height, pi (y + 1) / height); the direction of (phi, theta) is
//! (sin theta sin phi, cos theta, -sin theta cos phi): the left edge of the map looks along -z,
//! its middle along +z, its top row straight up. Radiance is piecewise constant over a pixel
//! (no filtering), which is also what the light sampler's density is
//! ([`crate::lights`]: a pixel is picked in proportion to luminance x solid angle, then a
//! direction uniformly in the pixel's solid angle). A constant sky is a 1 x 1 map.

use std::path::Path;

use glam::Vec3;

use super::SceneError;

/// Largest side of an environment map in pixels.
pub const MAX_ENV_SIDE: u32 = 16_384;
/// Most pixels of an environment map (a 4096 x 2048 map; the GPU also checks its own limit).
pub const MAX_ENV_PIXELS: u64 = 1 << 23;
/// Largest radiance an environment pixel may have: the same as a material's emission
/// ([`super::MAX_EMISSION`]). At 1e30 (the limit before) the denoiser's luminance moments,
/// squares of radiance, overflowed 32-bit floats and its frame had NaN pixels (issue 60).
pub const MAX_ENV_RADIANCE: f32 = super::MAX_EMISSION;

/// Light arriving from infinity: see the module documentation for the map convention.
#[derive(Debug, Clone, PartialEq)]
pub struct Environment {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance per pixel, row-major from the top row; finite and >= 0.
    pub pixels: Vec<[f32; 3]>,
    /// What it was made from (`sky r,g,b` or the file), for messages.
    pub source: String,
}

fn bad(what: &str, message: String) -> SceneError {
    SceneError::BadOption(format!("{what}: {message}"))
}

fn check_radiance(what: &str, c: [f32; 3]) -> Result<(), SceneError> {
    if c.iter()
        .all(|v| v.is_finite() && (0.0..=MAX_ENV_RADIANCE).contains(v))
    {
        Ok(())
    } else {
        Err(bad(
            what,
            format!(
                "radiance {c:?} must be finite, >= 0 and at most {MAX_ENV_RADIANCE:e} in every \
                 channel"
            ),
        ))
    }
}

/// Checks an environment intensity scale: finite and >= 0.
pub fn check_intensity(what: &str, k: f32) -> Result<(), SceneError> {
    if k.is_finite() && k >= 0.0 {
        Ok(())
    } else {
        Err(bad(what, format!("intensity {k} must be finite and >= 0")))
    }
}

impl Environment {
    /// A constant sky of radiance `rgb` (finite, >= 0).
    pub fn constant(rgb: [f32; 3]) -> Result<Self, SceneError> {
        check_radiance("sky", rgb)?;
        Ok(Self {
            width: 1,
            height: 1,
            pixels: vec![rgb],
            source: format!("sky {},{},{}", rgb[0], rgb[1], rgb[2]),
        })
    }

    /// A map from pixels (row-major, top row first), validated like a file's.
    pub fn from_pixels(
        source: &str,
        width: u32,
        height: u32,
        pixels: Vec<[f32; 3]>,
    ) -> Result<Self, SceneError> {
        check_size(source, width, height)?;
        if pixels.len() as u64 != u64::from(width) * u64::from(height) {
            return Err(bad(
                source,
                format!(
                    "{width}x{height} needs {} pixels, has {}",
                    width * height,
                    pixels.len()
                ),
            ));
        }
        for (i, p) in pixels.iter().enumerate() {
            check_radiance(
                &format!(
                    "{source}: pixel ({}, {})",
                    i as u32 % width,
                    i as u32 / width
                ),
                *p,
            )?;
        }
        Ok(Self {
            width,
            height,
            pixels,
            source: source.to_owned(),
        })
    }

    /// Reads an equirectangular Radiance HDR (`.hdr`) or OpenEXR (`.exr`) map and scales it by
    /// `intensity`. The size is checked from the header before decoding; NaN, infinite or
    /// negative pixels are an error naming the file and the pixel.
    pub fn load(path: &Path, intensity: f32) -> Result<Self, SceneError> {
        let shown = path.display().to_string();
        check_intensity(&shown, intensity)?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let format = match ext.as_deref() {
            Some("hdr") => image::ImageFormat::Hdr,
            Some("exr") => image::ImageFormat::OpenExr,
            _ => {
                return Err(bad(
                    &shown,
                    "an environment map must be a .hdr or .exr file (linear radiance)".into(),
                ));
            }
        };
        // The one file-opening path of the loaders: a regular file, capped, read bounded.
        let open = || {
            super::files::open_regular(path, super::files::MAX_SCENE_FILE_BYTES)
                .map(std::io::BufReader::new)
        };
        if format == image::ImageFormat::Hdr {
            check_hdr_header(&shown, open()?)?;
        }
        let reader = image::ImageReader::with_format(open()?, format);
        let decode = |e: image::ImageError| bad(&shown, format!("cannot decode the image: {e}"));
        let (width, height) = reader.into_dimensions().map_err(decode)?;
        check_size(&shown, width, height)?;
        let img = image::ImageReader::with_format(open()?, format)
            .decode()
            .map_err(decode)?
            .into_rgb32f();
        let pixels = img
            .pixels()
            .map(|p| [p[0] * intensity, p[1] * intensity, p[2] * intensity])
            .collect();
        Self::from_pixels(&shown, width, height, pixels)
    }

    /// Multiplies every pixel by `k` (finite, >= 0).
    pub fn scale(&mut self, k: f32) -> Result<(), SceneError> {
        check_intensity(&self.source, k)?;
        for p in &mut self.pixels {
            *p = p.map(|c| c * k);
        }
        for p in &self.pixels {
            check_radiance(&self.source, *p)?;
        }
        Ok(())
    }

    /// The unit direction of azimuth `phi` and polar cosine `cos_theta`.
    pub fn direction(phi: f32, cos_theta: f32) -> Vec3 {
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        Vec3::new(sin_theta * phi.sin(), cos_theta, -sin_theta * phi.cos())
    }

    /// The pixel a unit direction falls in.
    pub fn pixel_of(&self, dir: Vec3) -> usize {
        pixel_of(self.width, self.height, dir)
    }

    /// Radiance arriving from the unit direction `dir`.
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        Vec3::from(self.pixels[self.pixel_of(dir)])
    }

    /// Solid angle of the pixels of row `y`: (2 pi / width) (cos theta0 - cos theta1).
    pub fn row_solid_angle(&self, y: u32) -> f64 {
        let (c0, c1) = row_cosines(self.height, y);
        2.0 * std::f64::consts::PI / f64::from(self.width) * (f64::from(c0) - f64::from(c1))
    }

    /// Mean luminance over the sphere (solid-angle weighted).
    pub fn mean_luminance(&self) -> f64 {
        let mut sum = 0.0;
        for y in 0..self.height {
            let omega = self.row_solid_angle(y);
            let row = &self.pixels[(y * self.width) as usize..((y + 1) * self.width) as usize];
            sum += omega
                * row
                    .iter()
                    .map(|p| f64::from(super::luminance(*p)))
                    .sum::<f64>();
        }
        sum / (4.0 * std::f64::consts::PI)
    }
}

/// cos theta at the top and bottom edges of row `y` of a map `height` rows high (the top
/// one is the larger). Shared with the GPU twin (`lights_env_row_cosines`).
pub fn row_cosines(height: u32, y: u32) -> (f32, f32) {
    let step = std::f32::consts::PI / height as f32;
    ((y as f32 * step).cos(), ((y + 1) as f32 * step).cos())
}

/// The pixel of a `width` x `height` map a unit direction falls in (twin of
/// `lights_env_pixel`).
pub fn pixel_of(width: u32, height: u32, dir: Vec3) -> usize {
    let tau = std::f32::consts::TAU;
    let mut phi = dir.x.atan2(-dir.z);
    if phi < 0.0 {
        phi += tau;
    }
    let theta = dir.y.clamp(-1.0, 1.0).acos();
    let x = ((phi / tau * width as f32) as u32).min(width - 1);
    let y = ((theta / std::f32::consts::PI * height as f32) as u32).min(height - 1);
    (y * width + x) as usize
}

/// Longest Radiance header (its lines up to and with the resolution line) read: the decoder
/// reads a header line whole, however long.
pub const MAX_HDR_HEADER_BYTES: u64 = 64 << 10;

/// Checks that a Radiance file's header ends (blank line, then the resolution line) within
/// [`MAX_HDR_HEADER_BYTES`].
fn check_hdr_header(what: &str, file: impl std::io::Read) -> Result<(), SceneError> {
    use std::io::Read;
    let mut head = Vec::new();
    file.take(MAX_HDR_HEADER_BYTES)
        .read_to_end(&mut head)
        .map_err(|e| bad(what, format!("cannot read the header: {e}")))?;
    let ends = head
        .windows(2)
        .position(|w| w == b"\n\n")
        .is_some_and(|blank| head[blank + 2..].contains(&b'\n'));
    if ends {
        Ok(())
    } else {
        Err(bad(
            what,
            format!(
                "cannot decode the image: its Radiance header does not end within the first \
                 {MAX_HDR_HEADER_BYTES} bytes (a header line without end?)"
            ),
        ))
    }
}

fn check_size(what: &str, width: u32, height: u32) -> Result<(), SceneError> {
    let pixels = u64::from(width) * u64::from(height);
    if width == 0
        || height == 0
        || width > MAX_ENV_SIDE
        || height > MAX_ENV_SIDE
        || pixels > MAX_ENV_PIXELS
    {
        return Err(bad(
            what,
            format!(
                "an environment map of {width}x{height} pixels is outside the supported sizes \
                 (1 to {MAX_ENV_SIDE} a side, at most {MAX_ENV_PIXELS} pixels): resize it"
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_and_pixels_round_trip() {
        let env = Environment::from_pixels("t", 8, 4, vec![[1.0; 3]; 32]).unwrap();
        for y in 0..4u32 {
            for x in 0..8u32 {
                let phi = (x as f32 + 0.5) / 8.0 * std::f32::consts::TAU;
                let (c0, c1) = row_cosines(4, y);
                let d = Environment::direction(phi, 0.5 * (c0 + c1));
                assert!((d.length() - 1.0).abs() < 1e-6);
                assert_eq!(env.pixel_of(d), (y * 8 + x) as usize, "({x}, {y})");
            }
        }
        assert_eq!(
            env.pixel_of(Vec3::Y) / 8,
            0,
            "straight up is in the top row"
        );
        assert_eq!(env.pixel_of(Vec3::NEG_Y) / 8, 3);
        assert_eq!(Environment::direction(0.0, 0.0), Vec3::new(0.0, 0.0, -1.0));
        let total: f64 = (0..4).map(|y| 8.0 * env.row_solid_angle(y)).sum();
        assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-5);
        assert!((env.mean_luminance() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn bad_skies_and_maps_are_refused() {
        for rgb in [[-1.0, 0.0, 0.0], [f32::NAN, 1.0, 1.0], [f32::INFINITY; 3]] {
            let e = Environment::constant(rgb).unwrap_err().to_string();
            assert!(e.contains("sky") && e.contains("finite"), "{e}");
        }
        let e = Environment::from_pixels("m.hdr", 0, 4, vec![])
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.hdr") && e.contains("0x4"), "{e}");
        let e = Environment::from_pixels("m.hdr", 100_000, 2, vec![]).unwrap_err();
        assert!(e.to_string().contains("resize"), "{e}");
        let e = Environment::from_pixels("m.hdr", 2, 1, vec![[1.0; 3], [0.0, -2.0, 0.0]])
            .unwrap_err()
            .to_string();
        assert!(e.contains("m.hdr: pixel (1, 0)"), "{e}");
        let e = Environment::load(Path::new("/nonexistent/sky.hdr"), 1.0).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/sky.hdr"), "{e}");
        let e = Environment::load(Path::new("sky.png"), 1.0).unwrap_err();
        assert!(e.to_string().contains(".hdr or .exr"), "{e}");
        let e = Environment::load(Path::new("sky.hdr"), f32::NAN).unwrap_err();
        assert!(e.to_string().contains("intensity"), "{e}");
    }

    #[test]
    fn a_corrupt_file_is_an_error_naming_it() {
        let dir = std::env::temp_dir().join(format!("restir-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("corrupt.hdr");
        std::fs::write(&p, b"#?RADIANCE\nthis is not a map").unwrap();
        let e = Environment::load(&p, 1.0).unwrap_err().to_string();
        assert!(e.contains("corrupt.hdr") && e.contains("decode"), "{e}");
        // A real map written by the image crate reads back, scaled.
        let q = dir.join("ok.exr");
        let img = image::Rgb32FImage::from_fn(4, 2, |x, _| image::Rgb([x as f32, 1.0, 2.0]));
        img.save(&q).unwrap();
        let env = Environment::load(&q, 2.0).unwrap();
        assert_eq!((env.width, env.height), (4, 2));
        assert_eq!(env.pixels[3], [6.0, 2.0, 4.0]);
        // And a Radiance HDR (RGBE: 8-bit mantissas, so values like these are exact).
        let h = dir.join("ok.hdr");
        img.save(&h).unwrap();
        let env = Environment::load(&h, 1.0).unwrap();
        assert_eq!((env.width, env.height), (4, 2));
        assert_eq!(env.pixels[3], [3.0, 1.0, 2.0]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
