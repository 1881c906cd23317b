//! The GPU reference mode: the same estimator as the baselines (RIS by default) accumulated to
//! convergence on the GPU, as two independent half renders (different seeds) whose average is
//! the reference and whose difference estimates the reference's own relMSE
//! ([`crate::metrics::rel_mse_of_average`]). Results can be cached on disk under a key of
//! scene contents + camera + settings + crate version.

use std::path::{Path, PathBuf};

use crate::GpuContext;
use crate::image_io::{self, Image, ImageIoError};
use crate::methods::{FrameLoop, MethodError, Readback, run_frames};
use crate::metrics::{self, MetricsError};
use crate::render::{RenderError, RenderOptions, Renderer};
use crate::sampling::{Estimator, Paths};
use crate::scene::{Camera, Scene};

/// Frames recorded per submission while rendering a reference.
const FRAMES_PER_SUBMIT: u32 = 8;

/// Most samples per pixel a reference takes (`ReferenceSettings::spp`): 2^20, a thousand
/// times the default, days of lavapipe at 256x256; more is a mistaken flag, refused.
pub const MAX_SPP: u32 = 1 << 20;

/// How a reference is rendered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceSettings {
    /// Samples per pixel in total (split over the two halves; rounded up to even).
    pub spp: u32,
    /// The estimator accumulated.
    pub method: Estimator,
    /// Seed of the first half (the second uses a derived seed).
    pub seed: u32,
    /// The depth of the paths (bounces, Russian roulette): the reference's indirect image holds
    /// the same bounces as the methods compared with it.
    pub paths: Paths,
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self {
            spp: 1024,
            method: Estimator::Ris {
                candidates: crate::render::DEFAULT_CANDIDATES,
            },
            seed: 0x5eed_0001,
            paths: Paths::default(),
        }
    }
}

/// A converged (or supplied) reference.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuReference {
    pub width: u32,
    pub height: u32,
    /// Linear HDR, combined (direct + indirect).
    pub combined: Vec<[f32; 3]>,
    /// Linear HDR indirect (bounces 1..N); `None` for an external reference given without one.
    pub indirect: Option<Vec<[f32; 3]>>,
    /// Samples per pixel (0 when unknown: external).
    pub samples: u32,
    /// Estimated relMSE of the reference itself (combined, indirect), from the two halves.
    pub self_rel_mse: Option<(f64, f64)>,
    /// The cache key (empty for an external reference).
    pub key: String,
    /// Whether it was read from the cache rather than rendered.
    pub from_cache: bool,
    /// Why the cache entry under its key was not used although it was there (damaged: it was
    /// dropped and the reference rendered again); `None` otherwise.
    pub cache_note: Option<String>,
}

impl GpuReference {
    /// The direct image: combined minus indirect (clamped at 0 against rounding); `None`
    /// without an indirect image.
    pub fn direct(&self) -> Option<Vec<[f32; 3]>> {
        let indirect = self.indirect.as_ref()?;
        Some(
            self.combined
                .iter()
                .zip(indirect)
                .map(|(c, i)| [0, 1, 2].map(|k| (c[k] - i[k]).max(0.0)))
                .collect(),
        )
    }
}

/// What can go wrong making a reference.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error(transparent)]
    Method(#[from] MethodError),
    #[error(transparent)]
    Image(#[from] ImageIoError),
    #[error(transparent)]
    Metrics(#[from] MetricsError),
    #[error("reference {path}: {msg}")]
    Bad { path: PathBuf, msg: String },
    #[error("a reference of {0} samples per pixel: at most {MAX_SPP}")]
    Spp(u32),
    /// Every pixel of the rendered reference is 0: a relative error against it is undefined.
    #[error(
        "the camera at {eye} looking at {target} sees no light: its reference is black everywhere \
         (is the eye outside the scene's lit space, or inside an object?)"
    )]
    Black { eye: glam::Vec3, target: glam::Vec3 },
}

/// 64-bit FNV-1a, a stable hash for cache keys (std's hasher may change between releases).
#[derive(Debug, Clone, Copy)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        for &x in b {
            self.0 ^= u64::from(x);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self
    }
    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        for x in v {
            self.bytes(&x.to_le_bytes());
        }
        self
    }
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// Hashes what of `scene` changes its images: geometry (with normals and texture coordinates),
/// materials, textures, the environment and the punctual lights.
fn hash_scene(h: &mut Fnv64, scene: &Scene) {
    for t in &scene.triangles {
        for v in t.v {
            h.f32s(&v.to_array());
        }
        h.bytes(&t.material.to_le_bytes());
        // Shading normals and texture coordinates change the image: hashed where present (a
        // scene without them keeps its former key).
        if let Some(n) = t.n {
            h.bytes(b"n");
            for v in n {
                h.f32s(&v.to_array());
            }
        }
        if let Some(uv) = t.uv {
            h.bytes(b"uv");
            for v in uv {
                h.f32s(&v.to_array());
            }
        }
    }
    for m in &scene.materials {
        h.f32s(&m.albedo).f32s(&m.emission);
        if m.base_color_texture != 0 || m.emissive_texture != 0 {
            h.bytes(&m.base_color_texture.to_le_bytes())
                .bytes(&m.emissive_texture.to_le_bytes());
        }
    }
    for t in &scene.textures {
        h.bytes(b"texture")
            .bytes(&t.width.to_le_bytes())
            .bytes(&t.height.to_le_bytes());
        for p in &t.texels {
            h.bytes(p);
        }
    }
    for r in &scene.texture_refs {
        h.bytes(&r.texture.to_le_bytes())
            .bytes(&[r.wrap[0] as u8, r.wrap[1] as u8])
            .f32s(&r.row0)
            .f32s(&r.row1);
    }
    if let Some(env) = &scene.environment {
        h.bytes(b"environment")
            .bytes(&env.width.to_le_bytes())
            .bytes(&env.height.to_le_bytes());
        for p in &env.pixels {
            h.f32s(p);
        }
    }
    for l in &scene.lights {
        h.bytes(format!("{:?}", l.kind).as_bytes())
            .f32s(&l.position.to_array())
            .f32s(&l.direction.to_array())
            .f32s(&l.color)
            .f32s(&[l.intensity, l.range.unwrap_or(0.0)]);
    }
}

/// The cache key of a reference: a hash of the scene's triangles (with their normals and
/// texture coordinates), materials, textures, environment and punctual lights, the camera,
/// the settings, this crate's version and the renderer's composed WGSL (so a change of the
/// estimator's code invalidates old references even within one version; the software
/// tracer's composition: both tracers estimate the same image).
pub fn cache_key(scene: &Scene, camera: &Camera, settings: &ReferenceSettings) -> String {
    let mut h = Fnv64::default();
    h.bytes(env!("CARGO_PKG_VERSION").as_bytes());
    h.bytes(crate::render::passes_source(crate::gpu::Tracer::Bvh).as_bytes());
    hash_scene(&mut h, scene);
    h.f32s(&camera.eye.to_array())
        .f32s(&camera.target.to_array())
        .f32s(&camera.up.to_array())
        .f32s(&[camera.vfov_deg])
        .bytes(&camera.width.to_le_bytes())
        .bytes(&camera.height.to_le_bytes());
    let (m, k) = match settings.method {
        Estimator::Nee => (0u32, 1u32),
        Estimator::Ris { candidates } => (1, candidates),
    };
    // Wrapping: a count above MAX_SPP is refused by `render`, not here.
    for x in [
        settings.spp.div_ceil(2).wrapping_mul(2),
        m,
        k,
        settings.seed,
    ] {
        h.bytes(&x.to_le_bytes());
    }
    // Paths change the image: hashed unless one bounce without MIS (which keeps the key it had
    // before paths had a depth, whatever the default depth).
    let p = settings.paths;
    if p.bounces != 1 || p.mis {
        h.bytes(b"paths")
            .bytes(&p.bounces.to_le_bytes())
            .bytes(&p.roulette_from.to_le_bytes())
            .bytes(&[u8::from(p.mis)]);
    }
    format!("{:016x}", h.finish())
}

fn half(
    ctx: &GpuContext,
    (scene, camera): (&Scene, &Camera),
    settings: &ReferenceSettings,
    seed: u32,
    frames: u32,
    progress: &mut dyn FnMut(u32),
) -> Result<crate::reference::Rendered, MethodError> {
    let options = RenderOptions {
        seed,
        paths: settings.paths,
        ..Default::default()
    };
    let mut r = Renderer::with_options(ctx, scene, camera, settings.method, &options)?;
    let l = FrameLoop {
        samples: frames,
        records: 1,
        timed: false,
        batch: FRAMES_PER_SUBMIT,
        ..FrameLoop::frames(1)
    };
    run_frames(ctx, &mut r, &l, |_, s| {
        progress(s.frames);
        Ok::<(), MethodError>(())
    })?;
    let images = r.read(ctx, Readback::Accumulated)?;
    Ok(images
        .into_rendered()
        .map_err(|e| RenderError::Settings(e.to_string()))?)
}

/// Renders a reference (two halves of `spp / 2` samples each); `progress` gets the number of
/// frames just finished (of `spp` in all).
pub fn render(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    settings: &ReferenceSettings,
    mut progress: impl FnMut(u32),
) -> Result<GpuReference, ReferenceError> {
    if settings.spp > MAX_SPP {
        return Err(ReferenceError::Spp(settings.spp));
    }
    let frames = settings.spp.div_ceil(2).max(1);
    let seed_b = settings.seed ^ 0x9e37_79b9;
    let view = (scene, camera);
    let a = half(ctx, view, settings, settings.seed, frames, &mut progress)?;
    let b = half(ctx, view, settings, seed_b, frames, &mut progress)?;
    let avg = |x: &[[f32; 3]], y: &[[f32; 3]]| -> Vec<[f32; 3]> {
        x.iter()
            .zip(y)
            .map(|(p, q)| [0, 1, 2].map(|c| 0.5 * (p[c] + q[c])))
            .collect()
    };
    let combined = avg(&a.combined.pixels, &b.combined.pixels);
    let indirect = avg(&a.indirect.pixels, &b.indirect.pixels);
    let self_rel_mse = (
        metrics::rel_mse_of_average(&a.combined.pixels, &b.combined.pixels)?,
        metrics::rel_mse_of_average(&a.indirect.pixels, &b.indirect.pixels)?,
    );
    Ok(GpuReference {
        width: camera.width,
        height: camera.height,
        combined,
        indirect: Some(indirect),
        samples: frames * 2,
        self_rel_mse: Some(self_rel_mse),
        key: cache_key(scene, camera, settings),
        from_cache: false,
        cache_note: None,
    })
}

fn cache_paths(dir: &Path, key: &str) -> [PathBuf; 3] {
    [
        dir.join(format!("ref-{key}.combined.exr")),
        dir.join(format!("ref-{key}.indirect.exr")),
        dir.join(format!("ref-{key}.txt")),
    ]
}

/// The most bytes a cache entry's text file may hold (it holds four short lines).
const MAX_CACHE_TEXT_BYTES: u64 = 4096;

/// The most bytes a cache entry's EXR for `camera` may hold: its pixels as uncompressed f32
/// RGBA, and 1 MiB of header and offset tables.
fn max_cache_exr_bytes(camera: &Camera) -> u64 {
    u64::from(camera.width) * u64::from(camera.height) * 16 + (1 << 20)
}

/// Checks a cache entry's file before it is opened: a regular file (not a link, a FIFO or a
/// device: opening a FIFO blocks, a link may point anywhere) of at most `max` bytes.
fn check_cache_file(p: &Path, max: u64) -> Result<(), String> {
    let meta = std::fs::symlink_metadata(p).map_err(|e| format!("{}: {e}", p.display()))?;
    if !meta.file_type().is_file() {
        return Err(format!("{}: not a regular file", p.display()));
    }
    if meta.len() > max {
        return Err(format!(
            "{}: {} bytes, more than the {max} an entry of this size holds",
            p.display(),
            meta.len()
        ));
    }
    Ok(())
}

/// The cache entry under `key`: `Ok(None)` when there is none, an error saying what is wrong
/// when it is damaged (not a regular file, larger than an entry of `camera`'s size, unreadable,
/// a missing or bad line, images of another size than `camera`'s, NaN, infinite or negative
/// values, a combined image of zeros): cache entries are checked like `--reference` files, and
/// each file's kind and size before it is opened.
fn read_cached(dir: &Path, key: &str, camera: &Camera) -> Result<Option<GpuReference>, String> {
    let [c, i, t] = cache_paths(dir, key);
    let present = |p: &&PathBuf| std::fs::symlink_metadata(p).is_ok();
    if ![&c, &i, &t].iter().any(present) {
        return Ok(None);
    }
    check_cache_file(&t, MAX_CACHE_TEXT_BYTES)?;
    for p in [&c, &i] {
        check_cache_file(p, max_cache_exr_bytes(camera))?;
    }
    let text = std::fs::read_to_string(&t).map_err(|e| format!("{}: {e}", t.display()))?;
    let mut samples = None;
    let (mut rc, mut ri) = (None, None);
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match (it.next(), it.next()) {
            (Some("samples"), Some(v)) => samples = v.parse::<u32>().ok(),
            (Some("rel_mse_combined"), Some(v)) => rc = v.parse::<f64>().ok(),
            (Some("rel_mse_indirect"), Some(v)) => ri = v.parse::<f64>().ok(),
            _ => {}
        }
    }
    let (Some(samples), Some(rc), Some(ri)) = (samples, rc, ri) else {
        return Err(format!("{}: a line is missing or bad", t.display()));
    };
    let read = |p: &Path, combined: bool| -> Result<Image, String> {
        let img = image_io::read_exr(p).map_err(|e| e.to_string())?;
        if (img.width, img.height) != (camera.width, camera.height) {
            return Err(format!(
                "{}: is {}x{}, the render is {}x{}",
                p.display(),
                img.width,
                img.height,
                camera.width,
                camera.height
            ));
        }
        check_values(&img, p, combined).map_err(|e| e.to_string())?;
        Ok(img)
    };
    let combined = read(&c, true)?;
    let indirect = read(&i, false)?;
    Ok(Some(GpuReference {
        width: combined.width,
        height: combined.height,
        combined: combined.pixels,
        indirect: Some(indirect.pixels),
        samples,
        self_rel_mse: Some((rc, ri)),
        key: key.to_owned(),
        from_cache: true,
        cache_note: None,
    }))
}

/// Writes a rendered reference into the cache directory `dir` (created if needed).
pub fn write_cache(dir: &Path, r: &GpuReference) -> Result<(), ReferenceError> {
    std::fs::create_dir_all(dir).map_err(|e| ReferenceError::Bad {
        path: dir.to_owned(),
        msg: e.to_string(),
    })?;
    let [c, i, t] = cache_paths(dir, &r.key);
    image_io::write_exr(
        &c,
        &Image::from_pixels(r.width, r.height, r.combined.clone())?,
    )?;
    if let Some(ind) = &r.indirect {
        image_io::write_exr(&i, &Image::from_pixels(r.width, r.height, ind.clone())?)?;
    }
    let (rc, ri) = r.self_rel_mse.unwrap_or((f64::NAN, f64::NAN));
    let text = format!(
        "samples {}\nrel_mse_combined {rc:e}\nrel_mse_indirect {ri:e}\nversion {}\n",
        r.samples,
        env!("CARGO_PKG_VERSION")
    );
    image_io::write_bytes(&t, text.as_bytes())?;
    Ok(())
}

/// The reference of `scene` seen by `camera`: from the cache directory when it holds one under
/// the same key, else rendered (and then cached when `cache_dir` is given).
pub fn load_or_render(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    settings: &ReferenceSettings,
    cache_dir: Option<&Path>,
    progress: impl FnMut(u32),
) -> Result<GpuReference, ReferenceError> {
    let key = cache_key(scene, camera, settings);
    let mut note = None;
    if let Some(dir) = cache_dir {
        match read_cached(dir, &key, camera) {
            Ok(Some(r)) => return Ok(r),
            Ok(None) => {}
            Err(why) => {
                // Dropped: rendered again below and written over it.
                for p in cache_paths(dir, &key) {
                    let _ = std::fs::remove_file(p);
                }
                note = Some(format!(
                    "the reference cache entry {key} in {} was damaged ({why}): dropped and \
                     rendered again",
                    dir.display()
                ));
            }
        }
    }
    let mut r = render(ctx, scene, camera, settings, progress)?;
    if r.combined.iter().all(|p| p.iter().all(|&v| v == 0.0)) {
        return Err(ReferenceError::Black {
            eye: camera.eye,
            target: camera.target,
        });
    }
    if let Some(dir) = cache_dir {
        write_cache(dir, &r)?;
    }
    r.cache_note = note;
    Ok(r)
}

/// A reference image must hold finite, non-negative radiance; a combined reference must not
/// be black everywhere (every relative error would divide by it).
fn check_values(img: &Image, path: &Path, combined: bool) -> Result<(), ReferenceError> {
    let bad = |msg: String| ReferenceError::Bad {
        path: path.to_owned(),
        msg,
    };
    for (i, p) in img.pixels.iter().enumerate() {
        let (x, y) = (i % img.width as usize, i / img.width as usize);
        if !p.iter().all(|v| v.is_finite()) {
            return Err(bad(format!(
                "has a NaN or infinite value at pixel ({x}, {y}): {p:?}"
            )));
        }
        if p.iter().any(|&v| v < 0.0) {
            return Err(bad(format!(
                "has a negative value at pixel ({x}, {y}): {p:?}"
            )));
        }
    }
    if combined && img.pixels.iter().all(|p| p.iter().all(|&v| v == 0.0)) {
        return Err(bad(
            "is black everywhere (all zeros): not a reference".into()
        ));
    }
    Ok(())
}

/// An external reference: `combined` from an EXR file, and the indirect image from a second
/// one when given. Its convergence is unknown.
/// The images must hold finite, non-negative radiance, and the combined one must not be all
/// zeros.
pub fn external(
    combined: &Path,
    indirect: Option<&Path>,
    camera: &Camera,
) -> Result<GpuReference, ReferenceError> {
    let c = image_io::read_exr(combined)?;
    let check = |img: &Image, path: &Path| {
        if (img.width, img.height) == (camera.width, camera.height) {
            Ok(())
        } else {
            Err(ReferenceError::Bad {
                path: path.to_owned(),
                msg: format!(
                    "is {}x{}, the render is {}x{}",
                    img.width, img.height, camera.width, camera.height
                ),
            })
        }
    };
    check(&c, combined)?;
    check_values(&c, combined, true)?;
    let ind = match indirect {
        Some(p) => {
            let i = image_io::read_exr(p)?;
            check(&i, p)?;
            check_values(&i, p, false)?;
            Some(i.pixels)
        }
        None => None,
    };
    Ok(GpuReference {
        width: c.width,
        height: c.height,
        combined: c.pixels,
        indirect: ind,
        samples: 0,
        self_rel_mse: None,
        key: String::new(),
        from_cache: false,
        cache_note: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin;

    #[test]
    fn key_changes_with_scene_camera_and_settings() {
        let scene = builtin("cornell", &Default::default()).unwrap();
        let cam = scene.camera_or_default(32, 32);
        let s = ReferenceSettings::default();
        let k = cache_key(&scene, &cam, &s);
        assert_eq!(k, cache_key(&scene, &cam, &s));
        let mut cam2 = cam;
        cam2.eye.x += 0.01;
        assert_ne!(k, cache_key(&scene, &cam2, &s));
        let s2 = ReferenceSettings { spp: 2048, ..s };
        assert_ne!(k, cache_key(&scene, &cam, &s2));
        let mut scene2 = scene.clone();
        scene2.materials[0].albedo[0] += 0.1;
        assert_ne!(k, cache_key(&scene2, &cam, &s));
    }

    #[test]
    fn fnv_matches_published_vector() {
        // FNV-1a 64 of "a" is 0xaf63dc4c8601ec8c (Fowler/Noll/Vo test vectors).
        assert_eq!(Fnv64::default().bytes(b"a").finish(), 0xaf63_dc4c_8601_ec8c);
    }
}
