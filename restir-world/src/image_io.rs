//! Linear f32 RGB images: write as OpenEXR (linear) and as tone-mapped sRGB PNG, each written
//! whole or not at all (temporary file in the same directory + rename); read EXR back (for
//! reference images).

use std::path::{Path, PathBuf};

/// A linear HDR RGB image, rows top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

/// What can go wrong reading or writing an image.
#[derive(Debug, thiserror::Error)]
pub enum ImageIoError {
    #[error("{path}: file system error")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: image encoding or decoding failed")]
    Codec {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("image of {width}x{height} needs {} pixels, has {len}", *width as u64 * *height as u64)]
    Size { width: u32, height: u32, len: usize },
    #[error(
        "{path}: is {format}, not OpenEXR: only a linear EXR holds radiance (an 8-bit sRGB \
         image is tone-mapped and clipped)"
    )]
    NotExr { path: PathBuf, format: String },
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// An image from pixels (row-major, top row first); errors if the count is wrong.
    pub fn from_pixels(
        width: u32,
        height: u32,
        pixels: Vec<[f32; 3]>,
    ) -> Result<Self, ImageIoError> {
        if pixels.len() as u64 != u64::from(width) * u64::from(height) {
            return Err(ImageIoError::Size {
                width,
                height,
                len: pixels.len(),
            });
        }
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// The pixel at (x, y).
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Mean of each channel (f64).
    pub fn mean(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        for p in &self.pixels {
            for c in 0..3 {
                s[c] += f64::from(p[c]);
            }
        }
        let n = self.pixels.len().max(1) as f64;
        s.map(|x| x / n)
    }

    /// Whether every value is finite.
    pub fn is_finite(&self) -> bool {
        self.pixels.iter().flatten().all(|v| v.is_finite())
    }

    fn to_rgb32f(&self) -> Result<image::Rgb32FImage, ImageIoError> {
        let size_err = || ImageIoError::Size {
            width: self.width,
            height: self.height,
            len: self.pixels.len(),
        };
        if self.pixels.len() as u64 != u64::from(self.width) * u64::from(self.height) {
            return Err(size_err());
        }
        let flat: Vec<f32> = self.pixels.iter().flatten().copied().collect();
        image::Rgb32FImage::from_raw(self.width, self.height, flat).ok_or_else(size_err)
    }
}

/// The sRGB transfer function of a linear value in [0, 1].
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Tone mapping for PNGs: multiply by `exposure`, clamp to [0, 1] (NaN -> 0), sRGB-encode,
/// round to 8 bits. Deliberately simple and monotonic: the PNGs are for looking at; numbers
/// come from the EXRs.
pub fn tone_map(p: [f32; 3], exposure: f32) -> [u8; 3] {
    p.map(|v| {
        let v = v * exposure;
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        (srgb_encode(v) * 255.0 + 0.5) as u8
    })
}

/// Writes `img` as a linear 32-bit float RGB OpenEXR file, whole or not at all.
pub fn write_exr(path: &Path, img: &Image) -> Result<(), ImageIoError> {
    let buf = img.to_rgb32f()?;
    write_atomically(
        path,
        &encode(path, &buf.into(), image::ImageFormat::OpenExr)?,
    )
}

/// Writes `img` tone-mapped ([`tone_map`] with `exposure`) as an 8-bit sRGB PNG, whole or not
/// at all.
pub fn write_png(path: &Path, img: &Image, exposure: f32) -> Result<(), ImageIoError> {
    img.to_rgb32f()?; // size check
    let bytes: Vec<u8> = img
        .pixels
        .iter()
        .flat_map(|&p| tone_map(p, exposure))
        .collect();
    let buf =
        image::RgbImage::from_raw(img.width, img.height, bytes).ok_or(ImageIoError::Size {
            width: img.width,
            height: img.height,
            len: img.pixels.len(),
        })?;
    write_atomically(path, &encode(path, &buf.into(), image::ImageFormat::Png)?)
}

/// Writes an 8-bit image (already tone-mapped) as a PNG, whole or not at all.
pub fn write_png8(path: &Path, img: impl Into<image::DynamicImage>) -> Result<(), ImageIoError> {
    write_atomically(path, &encode(path, &img.into(), image::ImageFormat::Png)?)
}

/// Writes `img` as a JPEG of `quality` (1-100), whole or not at all: for large previews that
/// need not be exact.
pub fn write_jpeg(path: &Path, img: &image::RgbImage, quality: u8) -> Result<(), ImageIoError> {
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality)
        .encode_image(img)
        .map_err(|source| ImageIoError::Codec {
            path: path.to_owned(),
            source,
        })?;
    write_atomically(path, &bytes)
}

/// Writes `bytes` to `path`, whole or not at all (reports, plots).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), ImageIoError> {
    write_atomically(path, bytes)
}

/// The file bytes of `img` in `format` (encoded in memory: the file is then written through
/// [`write_atomically`]).
fn encode(
    path: &Path,
    img: &image::DynamicImage,
    format: image::ImageFormat,
) -> Result<Vec<u8>, ImageIoError> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, format)
        .map_err(|source| ImageIoError::Codec {
            path: path.to_owned(),
            source,
        })?;
    Ok(out.into_inner())
}

/// Reads an OpenEXR file as linear RGB (alpha dropped).
pub fn read_exr(path: &Path) -> Result<Image, ImageIoError> {
    let codec = |source| ImageIoError::Codec {
        path: path.to_owned(),
        source,
    };
    let reader = image::ImageReader::open(path).map_err(|source| ImageIoError::Io {
        path: path.to_owned(),
        source,
    })?;
    let reader = reader
        .with_guessed_format()
        .map_err(|source| ImageIoError::Io {
            path: path.to_owned(),
            source,
        })?;
    if reader.format() != Some(image::ImageFormat::OpenExr) {
        return Err(ImageIoError::NotExr {
            path: path.to_owned(),
            format: reader
                .format()
                .map_or("an unknown format".into(), |f| format!("{f:?}")),
        });
    }
    let img = reader.decode().map_err(codec)?.into_rgb32f();
    let (width, height) = img.dimensions();
    let pixels = img
        .into_raw()
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    Image::from_pixels(width, height, pixels)
}

/// A name no one can have planted: the process id, a counter and the clock's nanoseconds,
/// mixed (the file is then created with create-new semantics, so a guess only fails it).
pub fn unique_suffix() -> String {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for x in [u64::from(std::process::id()), n, nanos] {
        for b in x.to_le_bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{}-{h:016x}", std::process::id())
}

/// Creates a new file at `path`; fails if anything (a file, a link, even a dangling one)
/// is there, so that no existing path is followed or truncated.
pub fn create_new(path: &Path) -> std::io::Result<std::fs::File> {
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
}

/// Writes `bytes` through a new temporary file beside `path` (a random name, created with
/// create-new semantics: a link planted there is never followed) and renames it into place
/// (which replaces a link at `path` itself, never its target); removes the temporary file on
/// failure.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), ImageIoError> {
    use std::io::Write;
    let io = |source| ImageIoError::Io {
        path: path.to_owned(),
        source,
    };
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("out");
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Keep the real extension last: tools like to see it.
    let tmp = path.with_file_name(format!(".{name}.tmp{}.{ext}", unique_suffix()));
    let mut file = create_new(&tmp).map_err(io)?;
    let result = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(io);
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("restir-image-io-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn exr_round_trips_exactly_and_png_is_written() {
        let d = temp_dir("rt");
        let mut img = Image::new(5, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = [i as f32 * 0.37, 1e-3 / (i as f32 + 1.0), 123.5];
        }
        let exr = d.join("a.exr");
        write_exr(&exr, &img).unwrap();
        assert_eq!(read_exr(&exr).unwrap(), img);
        let png = d.join("a.png");
        write_png(&png, &img, 1.0).unwrap();
        let back = image::open(&png).unwrap().into_rgb8();
        assert_eq!(back.dimensions(), (5, 3));
        assert_eq!(back.get_pixel(0, 0).0, [0, 3, 255]);
        // No temporary files left behind.
        let names: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().collect();
        assert_eq!(names.len(), 2);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn failed_writes_leave_nothing_and_name_the_file() {
        let d = temp_dir("fail");
        let path = d.join("missing-dir").join("x.exr");
        let e = write_exr(&path, &Image::new(2, 2)).unwrap_err();
        assert!(e.to_string().contains("x.exr"), "{e}");
        let bad = Image {
            width: 3,
            height: 3,
            pixels: vec![[0.0; 3]; 2],
        };
        assert!(matches!(
            write_png(&d.join("b.png"), &bad, 1.0),
            Err(ImageIoError::Size { .. })
        ));
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
        let junk = d.join("junk.exr");
        std::fs::write(&junk, b"not an exr").unwrap();
        assert!(
            read_exr(&junk)
                .unwrap_err()
                .to_string()
                .contains("junk.exr")
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    /// Issue 27, 2: a link at the output path is replaced, never written through; a link at
    /// a name `create_new` is asked for fails it.
    #[cfg(unix)]
    #[test]
    fn links_are_never_written_through() {
        let d = temp_dir("links");
        let victim = d.join("victim");
        std::fs::write(&victim, b"keep").unwrap();
        let out = d.join("out.bin");
        std::os::unix::fs::symlink(&victim, &out).unwrap();
        write_bytes(&out, b"new").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        assert!(!std::fs::symlink_metadata(&out).unwrap().is_symlink());
        assert_eq!(std::fs::read(&out).unwrap(), b"new");
        let planted = d.join("planted");
        std::os::unix::fs::symlink(&victim, &planted).unwrap();
        assert!(create_new(&planted).is_err());
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
        assert_ne!(unique_suffix(), unique_suffix());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn tone_map_is_monotonic_and_safe() {
        assert_eq!(tone_map([0.0, 1.0, 2.0], 1.0), [0, 255, 255]);
        assert_eq!(tone_map([f32::NAN, -1.0, f32::INFINITY], 1.0), [0, 0, 255]);
        let mut last = 0;
        for i in 0..=100 {
            let v = tone_map([i as f32 / 100.0; 3], 1.0)[0];
            assert!(v >= last);
            last = v;
        }
    }
}
