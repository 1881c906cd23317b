//! Textures of glTF materials: base colour, emission, metallic-roughness and normals, as the
//! renderers sample them.
//!
//! A [`Texture`] keeps the file's 8-bit texels (RGBA, row-major from the top row); a
//! [`TextureRef`] is one material's use of it: the wrap mode of each axis, the
//! `KHR_texture_transform` affine map of the texture coordinates, and how its texels are
//! read (sRGB-encoded colour, or linear data: metallic-roughness and normal textures).
//! Sampling ([`TextureRef::sample`], twin of WGSL `render_texture`) is bilinear over texel
//! centres on decoded (linear) texels, at texture coordinates (s, t) = transform (u, v, 1); no
//! mipmaps. The material's factor multiplies the result (the loader keeps it in `Material`).

use glam::Vec2;

/// How texture coordinates outside [0, 1] wrap (glTF sampler `wrapS`/`wrapT`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    Repeat = 0,
    MirroredRepeat = 1,
    ClampToEdge = 2,
}

/// An image of 8-bit RGBA texels, row-major from the top row (sRGB-encoded colour or linear
/// data: its [`TextureRef`]s say which).
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// The image's name or file, for messages.
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[u8; 4]>,
}

/// A material's use of a texture: which one, how it wraps, the affine map
/// (s, t) = (row0 . (u, v, 1), row1 . (u, v, 1)) of `KHR_texture_transform` (identity without
/// it), and whether its texels are linear data (glTF's metallic-roughness and normal textures)
/// rather than sRGB-encoded colour (base colour, emission).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextureRef {
    /// Index into `Scene::textures`.
    pub texture: u32,
    pub wrap: [Wrap; 2],
    pub row0: [f32; 3],
    pub row1: [f32; 3],
    /// Texels read as value / 255 (linear data), not sRGB-decoded.
    pub linear: bool,
}

/// Largest side of a texture in texels.
pub const MAX_TEXTURE_SIDE: u32 = 16_384;

/// Most bytes all of a scene's texels may take (4 a texel): the renderers keep them in one
/// storage binding, and 128 MiB is lavapipe's limit and WebGPU's default. The loader halves the
/// largest textures until a scene fits ([`fit`]).
pub const MAX_TEXEL_BYTES: u64 = 128 << 20;

/// sRGB encoding of a linear value in [0, 1] to 8 bits (inverse of [`srgb_to_linear`]).
pub fn linear_to_srgb(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

impl Texture {
    /// The texture at half the size (rounded up) a side, each texel the mean of its 2 x 2
    /// block in linear light (alpha averaged as is). A texture of linear data (metallic-roughness,
    /// normals) is averaged through the same sRGB decoding: exact where its 2 x 2 blocks are
    /// flat, a small bias at its edges, and only for scenes whose textures exceed
    /// [`MAX_TEXEL_BYTES`].
    pub fn halved(&self) -> Texture {
        let (w, h) = (self.width.div_ceil(2), self.height.div_ceil(2));
        let mut texels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0f32; 4];
                let mut n = 0.0;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (2 * x + dx, 2 * y + dy);
                    if sx < self.width && sy < self.height {
                        let p = self.texels[(sy * self.width + sx) as usize];
                        for c in 0..3 {
                            sum[c] += srgb_to_linear(p[c]);
                        }
                        sum[3] += f32::from(p[3]);
                        n += 1.0;
                    }
                }
                texels.push([
                    linear_to_srgb(sum[0] / n),
                    linear_to_srgb(sum[1] / n),
                    linear_to_srgb(sum[2] / n),
                    (sum[3] / n).round() as u8,
                ]);
            }
        }
        Texture {
            name: self.name.clone(),
            width: w,
            height: h,
            texels,
        }
    }
}

/// Halves the largest textures until all texels take at most `budget` bytes; returns how many
/// halvings it made (0: they fitted).
pub fn fit(textures: &mut [Texture], budget: u64) -> usize {
    let bytes = |t: &[Texture]| t.iter().map(|t| 4 * t.texels.len() as u64).sum::<u64>();
    let mut halvings = 0;
    while bytes(textures) > budget {
        let Some(largest) = (0..textures.len())
            .filter(|&i| textures[i].texels.len() > 1)
            .max_by_key(|&i| textures[i].texels.len())
        else {
            break;
        };
        textures[largest] = textures[largest].halved();
        halvings += 1;
    }
    halvings
}

/// sRGB transfer function decoded to linear (IEC 61966-2-1), for one 8-bit channel (a
/// table of the 256 values: halving a large texture calls it for every texel).
pub fn srgb_to_linear(c: u8) -> f32 {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_decode(i as u8)))[usize::from(c)]
}

fn srgb_decode(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// An integer texel coordinate wrapped into 0..n (twin of `render_wrap`).
pub fn wrap(i: i32, n: i32, mode: Wrap) -> i32 {
    match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let p = i.rem_euclid(2 * n);
            if p >= n { 2 * n - 1 - p } else { p }
        }
    }
}

impl TextureRef {
    /// Identity transform, repeat wrapping.
    pub fn plain(texture: u32) -> Self {
        Self {
            texture,
            wrap: [Wrap::Repeat; 2],
            row0: [1.0, 0.0, 0.0],
            row1: [0.0, 1.0, 0.0],
            linear: false,
        }
    }

    /// The same use with its texels read as linear data (value / 255).
    pub fn linear(self) -> Self {
        Self {
            linear: true,
            ..self
        }
    }

    /// `KHR_texture_transform`: translation x rotation x scale, as the extension defines it.
    pub fn with_transform(mut self, offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Self {
        let (s, c) = rotation.sin_cos();
        self.row0 = [c * scale[0], s * scale[1], offset[0]];
        self.row1 = [-s * scale[0], c * scale[1], offset[1]];
        self
    }

    /// The texture coordinates (s, t) of the vertex coordinates uv, clamped to +-1e6 (so that
    /// texel indices stay in range).
    pub fn transform(&self, uv: Vec2) -> Vec2 {
        let (r0, r1) = (self.row0, self.row1);
        Vec2::new(
            r0[0] * uv.x + r0[1] * uv.y + r0[2],
            r1[0] * uv.x + r1[1] * uv.y + r1[2],
        )
        .clamp(Vec2::splat(-1e6), Vec2::splat(1e6))
    }

    /// Bilinear linear-RGB sample at vertex coordinates uv (twin of `render_texture`): texels
    /// sRGB-decoded, or value / 255 for a linear use.
    pub fn sample(&self, textures: &[Texture], uv: Vec2) -> [f32; 3] {
        let t = &textures[self.texture as usize];
        let st = self.transform(uv);
        let (w, h) = (t.width as i32, t.height as i32);
        let x = st.x * w as f32 - 0.5;
        let y = st.y * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i32, y0 as i32);
        let texel = |i: i32, j: i32| -> [f32; 3] {
            let (i, j) = (wrap(i, w, self.wrap[0]), wrap(j, h, self.wrap[1]));
            let p = t.texels[(j * w + i) as usize];
            let decode = |c: u8| match self.linear {
                true => f32::from(c) / 255.0,
                false => srgb_to_linear(c),
            };
            [decode(p[0]), decode(p[1]), decode(p[2])]
        };
        let (a, b) = (texel(x0, y0), texel(x0 + 1, y0));
        let (c, d) = (texel(x0, y0 + 1), texel(x0 + 1, y0 + 1));
        [0, 1, 2].map(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

/// Most bytes one texture may take decoded (RGBA, 4 a texel): a 16384 x 16384 image. The
/// size is read from the file's header and checked before anything is decoded.
pub const MAX_DECODED_TEXTURE_BYTES: u64 = 1 << 30;

/// Decodes an image file's bytes (PNG or JPEG) into a texture; an error with the decoder's
/// message when it cannot be read, is of another format (HDR, EXR, ... would be clamped to 8
/// bits and taken as sRGB), or is larger than [`MAX_TEXTURE_SIDE`] a side or
/// [`MAX_DECODED_TEXTURE_BYTES`] decoded (both checked from the header, before decoding).
pub fn decode(name: &str, bytes: &[u8]) -> Result<Texture, String> {
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| e.to_string())
    };
    let format = reader()?.format();
    match format {
        Some(image::ImageFormat::Png | image::ImageFormat::Jpeg) => {}
        Some(f) => {
            return Err(format!(
                "it is {f:?}; only PNG and JPEG textures are read (8-bit sRGB)"
            ));
        }
        None => return Err("not an image format this loader knows (PNG or JPEG)".into()),
    }
    let (w, h) = reader()?.into_dimensions().map_err(|e| e.to_string())?;
    let decoded = 4 * u64::from(w) * u64::from(h);
    if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE || w == 0 || h == 0 {
        return Err(format!(
            "{w}x{h} texels is outside 1..={MAX_TEXTURE_SIDE} a side"
        ));
    }
    if decoded > MAX_DECODED_TEXTURE_BYTES {
        return Err(format!(
            "{w}x{h} texels take {decoded} bytes decoded, above the limit of \
             {MAX_DECODED_TEXTURE_BYTES}"
        ));
    }
    let mut reader = reader()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    limits.max_alloc = Some(2 * MAX_DECODED_TEXTURE_BYTES);
    reader.limits(limits);
    let rgba = reader.decode().map_err(|e| e.to_string())?.into_rgba8();
    Ok(Texture {
        name: name.to_owned(),
        width: rgba.width(),
        height: rgba.height(),
        texels: rgba.pixels().map(|p| p.0).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_modes() {
        assert_eq!(
            [-1, 0, 3, 4, 5].map(|i| wrap(i, 4, Wrap::Repeat)),
            [3, 0, 3, 0, 1]
        );
        assert_eq!(
            [-1, 0, 3, 4, 9].map(|i| wrap(i, 4, Wrap::ClampToEdge)),
            [0, 0, 3, 3, 3]
        );
        assert_eq!(
            [-1, 0, 3, 4, 5, 8].map(|i| wrap(i, 4, Wrap::MirroredRepeat)),
            [0, 0, 3, 3, 2, 0]
        );
    }

    #[test]
    fn bilinear_between_texel_centres_in_linear() {
        let t = Texture {
            name: "t".into(),
            width: 2,
            height: 1,
            texels: vec![[0, 0, 0, 255], [255, 255, 255, 255]],
        };
        let r = TextureRef {
            wrap: [Wrap::ClampToEdge; 2],
            ..TextureRef::plain(0)
        };
        let at = |u: f32| r.sample(std::slice::from_ref(&t), Vec2::new(u, 0.5))[0];
        assert_eq!(at(0.25), 0.0);
        assert_eq!(at(0.75), 1.0);
        assert!((at(0.5) - 0.5).abs() < 1e-6);
        assert!((srgb_to_linear(188) - 0.5).abs() < 0.003);
        // KHR_texture_transform: offset 0.5 moves the white texel to u = 0.25.
        let moved = r.with_transform([0.5, 0.0], 0.0, [1.0, 1.0]);
        assert_eq!(
            moved.sample(std::slice::from_ref(&t), Vec2::new(0.25, 0.5))[0],
            1.0
        );
    }

    #[test]
    fn textures_are_halved_until_they_fit() {
        let t = |w: u32, h: u32, v: u8| Texture {
            name: "t".into(),
            width: w,
            height: h,
            texels: vec![[v, v, v, 255]; (w * h) as usize],
        };
        let mut ts = vec![t(64, 64, 188), t(16, 8, 10), t(3, 3, 0)];
        // 64x64 -> 32x32 -> 16x16: 4 x (256 + 128 + 9) bytes fit in 1600.
        assert_eq!(fit(&mut ts, 1600), 2);
        assert_eq!((ts[0].width, ts[0].height), (16, 16));
        assert_eq!(
            ts[0].texels[5],
            [188, 188, 188, 255],
            "a flat texture stays flat"
        );
        assert_eq!(fit(&mut ts, 1 << 20), 0);
        let odd = t(3, 3, 0).halved();
        assert_eq!((odd.width, odd.height), (2, 2));
        // Black and white average to linear 0.5 (sRGB 188), not to sRGB 128.
        let bw = Texture {
            texels: vec![[0, 0, 0, 255], [255, 255, 255, 255]],
            ..t(2, 1, 0)
        };
        assert_eq!(bw.halved().texels[0][0], 188);
        for v in [0u8, 1, 50, 128, 188, 254, 255] {
            assert_eq!(linear_to_srgb(srgb_to_linear(v)), v);
        }
    }

    #[test]
    fn undecodable_bytes_are_an_error() {
        assert!(decode("x.png", b"not a png").is_err());
        // A Radiance HDR decodes, but not as an 8-bit sRGB texture (issue 27, 20).
        let mut hdr = std::io::Cursor::new(Vec::new());
        image::Rgb32FImage::from_pixel(2, 2, image::Rgb([2.0, 1.0, 0.5]))
            .write_to(&mut hdr, image::ImageFormat::Hdr)
            .unwrap();
        let e = decode("x.hdr", hdr.get_ref()).unwrap_err();
        assert!(e.contains("only PNG and JPEG"), "{e}");
    }

    #[test]
    fn png_and_jpeg_decode() {
        let img = image::RgbImage::from_pixel(8, 4, image::Rgb([200, 100, 50]));
        for format in [image::ImageFormat::Png, image::ImageFormat::Jpeg] {
            let mut bytes = std::io::Cursor::new(Vec::new());
            img.write_to(&mut bytes, format).unwrap();
            let t = decode("t", bytes.get_ref()).unwrap();
            assert_eq!((t.width, t.height), (8, 4));
            let p = t.texels[9];
            assert!(
                (i32::from(p[0]) - 200).abs() <= 3 && (i32::from(p[2]) - 50).abs() <= 3,
                "{format:?}: {p:?}"
            );
            assert_eq!(p[3], 255);
        }
    }
}
