//! Scene files: glTF 2.0 (.gltf/.glb, via the `gltf` crate) and OBJ+MTL (via `tobj`).
//!
//! glTF: meshes (triangle primitives) under the default scene's node hierarchy with their
//! transforms, the first perspective camera met, baseColorFactor as albedo, emissiveFactor x
//! KHR_materials_emissive_strength as emission. Buffers: the GLB binary chunk, base64 data
//! URIs and files relative to the .gltf; metallicFactor, roughnessFactor and the
//! metallic-roughness texture (glTF's core material: [`super::MaterialModel`]). OBJ: Kd as
//! albedo, Ke as emission, the PBR extension's Pm and Pr (else Ns) as metallic and roughness,
//! polygons triangulated. glTF base colour and emissive textures (PNG, JPEG) are read into
//! `Scene::textures`/`texture_refs` with their sampler's wrap modes and `KHR_texture_transform`;
//! a texture without a `source` (DDS only), a missing image file, an undecodable image or one
//! of another format, a data: uri, a `TEXCOORD_1` texture, unusable `TEXCOORD_0` data or a
//! non-finite transform keeps its material's factor with a warning, never an error. Every file
//! is opened through [`super::files`] (regular files only, capped, confined to the scene's
//! directory). Accessors are checked (type, component type, stride, count, bounds) before the
//! `gltf` crate reads them. Normal maps (`normalTexture` with its `scale`, on `TEXCOORD_0`) are
//! read with the primitives' `TANGENT`s, or MikkTSpace tangents generated where a primitive has
//! none ([`super::tangents`]); triangles whose tangents are unusable, and materials whose normal
//! texture is, shade with their interpolated normals, with a warning naming the material. Alpha
//! MASK/BLEND is not modelled (one warning per file). `extensionsRequired` follows
//! [`extension_policy`]: supported extensions are used, ones that change only what the renderer
//! does not model warn once each, ones that change the geometry (Draco, meshopt, quantization, GPU
//! instancing) are an error naming the extension and the file.

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec3};

use super::files::{self, MAX_SCENE_FILE_BYTES, MAX_TEXTURE_FILE_BYTES, confined};
use super::texture::{self, TextureRef, Wrap};
use super::{Camera, Material, SanitizeReport, Scene, SceneError, Triangle};

/// Albedo of surfaces without a material.
pub const DEFAULT_ALBEDO: [f32; 3] = [0.8; 3];

/// A loaded, sanitized scene with what loading had to say about it.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    pub scene: Scene,
    /// What sanitizing dropped or repaired (warn when not clean).
    pub report: SanitizeReport,
    /// Other things worth a warning (ignored textures, missing material libraries, ...).
    pub warnings: Vec<String>,
}

/// The error and its sources, joined by ": ".
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut src = e.source();
    while let Some(x) = src {
        s.push_str(&format!(": {x}"));
        src = x.source();
    }
    s
}

/// Loads a scene file by extension (.gltf, .glb, .obj) and sanitizes it.
pub fn load(path: &Path) -> Result<Loaded, SceneError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut warnings = Vec::new();
    let mut scene = match ext.as_deref() {
        Some("gltf" | "glb") => load_gltf(path, &mut warnings)?,
        Some("obj") => load_obj(path, &mut warnings)?,
        _ => {
            return Err(SceneError::UnsupportedFormat {
                path: path.to_owned(),
            });
        }
    };
    let halvings = texture::fit(&mut scene.textures, texture::MAX_TEXEL_BYTES);
    warn_halvings(path, halvings, &mut warnings);
    let report = scene.sanitize(&path.display().to_string())?;
    Ok(Loaded {
        scene,
        report,
        warnings,
    })
}

fn warn_halvings(path: &Path, halvings: usize, warnings: &mut Vec<String>) {
    if halvings > 0 {
        warnings.push(format!(
            "{}: the textures need more than {} MiB (the renderers keep them in one storage \
             binding): the largest were halved {halvings} times to fit",
            path.display(),
            texture::MAX_TEXEL_BYTES >> 20
        ));
    }
}

fn parse_err(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Parse {
        path: path.to_owned(),
        message: message.into(),
    }
}

/// Reads a scene file (OBJ, MTL, glTF, GLB, glTF buffer) through the shared opening path.
fn read(path: &Path) -> Result<Vec<u8>, SceneError> {
    files::read_capped(path, MAX_SCENE_FILE_BYTES)
}

/// What a mesh attribute or index accessor must be.
#[derive(Clone, Copy, PartialEq)]
enum AccessorRole {
    Position,
    Normal,
    Tangent,
    TexCoord,
    Index,
}

impl AccessorRole {
    fn name(self) -> &'static str {
        match self {
            AccessorRole::Position => "POSITION",
            AccessorRole::Normal => "NORMAL",
            AccessorRole::Tangent => "TANGENT",
            AccessorRole::TexCoord => "TEXCOORD_0",
            AccessorRole::Index => "index",
        }
    }
}

fn component_name(t: gltf::accessor::DataType) -> &'static str {
    use gltf::accessor::DataType::*;
    match t {
        I8 => "BYTE",
        U8 => "UNSIGNED_BYTE",
        I16 => "SHORT",
        U16 => "UNSIGNED_SHORT",
        U32 => "UNSIGNED_INT",
        F32 => "FLOAT",
    }
}

/// Checks what the `gltf` crate's reader assumes of an accessor before it reads it (it panics
/// otherwise): the type and component type of its role, a stride of at least one element,
/// and (non-sparse) that its `count` elements lie inside its buffer view and the view inside
/// its buffer (the reader silently yields nothing otherwise). The message says what is wrong.
fn accessor_problem(
    acc: &gltf::Accessor,
    role: AccessorRole,
    buffers: &[Vec<u8>],
) -> Option<String> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    if acc.count() == 0 {
        return Some("has no elements".into());
    }
    let (dims, types): (D, &[T]) = match role {
        AccessorRole::Position | AccessorRole::Normal => (D::Vec3, &[T::F32]),
        AccessorRole::Tangent => (D::Vec4, &[T::F32]),
        AccessorRole::TexCoord => (D::Vec2, &[T::F32, T::U8, T::U16]),
        AccessorRole::Index => (D::Scalar, &[T::U8, T::U16, T::U32]),
    };
    if acc.dimensions() != dims {
        return Some(format!("is {:?}, not {dims:?}", acc.dimensions()));
    }
    if !types.contains(&acc.data_type()) {
        let allowed: Vec<&str> = match types {
            [T::F32] => vec!["32-bit float (FLOAT)"],
            _ => types.iter().map(|t| component_name(*t)).collect(),
        };
        return Some(format!(
            "has {} components, not {} (quantized vertex data, KHR_mesh_quantization, is not \
             read)",
            component_name(acc.data_type()),
            allowed.join(" or ")
        ));
    }
    if acc.sparse().is_some() {
        return None;
    }
    let Some(view) = acc.view() else {
        return Some("has no buffer view".into());
    };
    let size = acc.size();
    if let Some(stride) = view.stride()
        && (stride < size || !stride.is_multiple_of(acc.data_type().size()))
    {
        return Some(format!(
            "has a byteStride {stride} below its element size {size} (or not a multiple of its \
             component size)"
        ));
    }
    let stride = view.stride().unwrap_or(size);
    let end = stride
        .checked_mul(acc.count() - 1)
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(acc.offset()));
    let view_end = view.offset().checked_add(view.length());
    let held = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    match (end, view_end) {
        (Some(end), Some(view_end)) if end <= view.length() && view_end <= held => None,
        _ => Some(format!(
            "declares {} elements, which do not fit its buffer view ({} bytes at offset {} of \
             buffer {}, which holds {held} bytes)",
            acc.count(),
            view.length(),
            view.offset(),
            view.buffer().index()
        )),
    }
}

/// [`accessor_problem`] as an error naming the mesh and the accessor.
fn check_accessor(
    path: &Path,
    mesh: usize,
    role: AccessorRole,
    acc: &gltf::Accessor,
    buffers: &[Vec<u8>],
) -> Result<(), SceneError> {
    match accessor_problem(acc, role, buffers) {
        None => Ok(()),
        Some(msg) => Err(parse_err(
            path,
            format!(
                "glTF: mesh {mesh}: {} accessor {}: {msg}",
                role.name(),
                acc.index()
            ),
        )),
    }
}

/// Decodes standard base64 (with or without padding); `None` on any invalid character.
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in s.bytes().filter(|c| !c.is_ascii_whitespace()) {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

/// What the glTF loader does with an extension a file lists in `extensionsRequired`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExtensionPolicy {
    /// Read and used.
    Supported,
    /// Changes only what the renderer does not model (the text says what): the file loads
    /// with one warning.
    Ignored(&'static str),
    /// Changes the geometry, which this loader cannot decode (the text says how): the file is
    /// refused.
    Refused(&'static str),
    /// Not known to this loader: the file loads with one warning that it may be incomplete.
    Unknown,
}

/// The policy for a required glTF extension by name (see [`ExtensionPolicy`]).
pub fn extension_policy(name: &str) -> ExtensionPolicy {
    use ExtensionPolicy::*;
    match name {
        "KHR_materials_emissive_strength" | "KHR_lights_punctual" | "KHR_texture_transform" => {
            Supported
        }
        "KHR_draco_mesh_compression" => Refused("Draco-compressed meshes"),
        "EXT_meshopt_compression" => Refused("meshoptimizer-compressed buffers"),
        "KHR_mesh_quantization" => Refused("quantized (integer) vertex attributes"),
        "EXT_mesh_gpu_instancing" => Refused("GPU-instanced meshes"),
        "AMD_split_roughnessMetallic" => Ignored("split roughness/metallic textures"),
        "MSFT_texture_dds" | "KHR_texture_basisu" | "EXT_texture_webp" | "EXT_texture_avif" => {
            Ignored(
                "alternative texture image formats (only PNG and JPEG are read: the factors are used)",
            )
        }
        "KHR_materials_variants" => Ignored("material variants (the default is used)"),
        "KHR_materials_unlit" => Ignored("unlit materials (shaded as lit)"),
        "EXT_lights_image_based" => Ignored("image-based (environment) lighting"),
        "KHR_xmp_json_ld" => Ignored("metadata"),
        "KHR_animation_pointer" => Ignored("animation"),
        n if n.starts_with("KHR_materials_") => {
            Ignored("a material model beyond glTF's core metallic-roughness and emission")
        }
        n if n.starts_with("KHR_texture_") || n.starts_with("EXT_texture_") => {
            Ignored("textures (not modelled)")
        }
        _ => Unknown,
    }
}

/// Parses a .gltf/.glb, applies [`extension_policy`] to its `extensionsRequired` (one warning
/// per ignored or unknown extension, an error naming a refused one), then validates the rest
/// with the `gltf` crate (which would refuse every required extension it does not implement).
fn parse_gltf(
    path: &Path,
    bytes: &[u8],
    warnings: &mut Vec<String>,
) -> Result<gltf::Gltf, SceneError> {
    let err = |e: gltf::Error| parse_err(path, format!("glTF: {e}"));
    let raw = gltf::Gltf::from_slice_without_validation(bytes).map_err(err)?;
    let blob = raw.blob;
    let mut root = raw.document.into_json();
    let mut seen = std::collections::HashSet::new();
    for ext in &root.extensions_required {
        if !seen.insert(ext.clone()) {
            continue;
        }
        match extension_policy(ext) {
            ExtensionPolicy::Supported => {}
            ExtensionPolicy::Ignored(what) => warnings.push(format!(
                "{}: glTF requires extension {ext}, which only affects {what}; the renderer \
                 does not model it: ignored",
                path.display()
            )),
            ExtensionPolicy::Refused(what) => {
                return Err(parse_err(
                    path,
                    format!(
                        "glTF: requires extension {ext} ({what}), which this loader cannot \
                         decode: export the scene without it"
                    ),
                ));
            }
            ExtensionPolicy::Unknown => warnings.push(format!(
                "{}: glTF requires extension {ext}, unknown to this loader: ignored (the scene \
                 may load incomplete or look different)",
                path.display()
            )),
        }
    }
    root.extensions_required.clear();
    let document = gltf::Document::from_json(root).map_err(err)?;
    Ok(gltf::Gltf { document, blob })
}

/// What reading a material's texture needs.
struct TextureContext<'a> {
    path: &'a Path,
    dir: &'a Path,
    buffers: &'a [Vec<u8>],
    scene: &'a mut Scene,
    warnings: &'a mut Vec<String>,
}

/// Where an image's bytes are: its file (resolved) or its buffer view.
#[derive(Clone, PartialEq, Eq, Hash)]
enum ImageSource {
    File(PathBuf),
    View(usize),
}

/// The textures of a glTF file read so far: each image decoded once (or found unusable once),
/// also when several image entries name the same file or view.
#[derive(Default)]
struct GltfTextures {
    /// glTF image index -> index in `Scene::textures` (None: unusable, warned).
    images: HashMap<usize, Option<u32>>,
    /// The same by where the bytes are.
    sources: HashMap<ImageSource, Option<u32>>,
    /// Halvings made so far to keep the texels within [`texture::MAX_TEXEL_BYTES`].
    halvings: usize,
    alpha_cutouts: usize,
}

/// A material's use of a texture: the texture, its `texCoord` set and its
/// `KHR_texture_transform` (offset, rotation, scale).
struct TextureUse<'a> {
    texture: gltf::Texture<'a>,
    set: u32,
    transform: Option<([f32; 2], f32, [f32; 2])>,
}

impl<'a> TextureUse<'a> {
    fn of_info(info: &gltf::texture::Info<'a>) -> Self {
        let transform = info.texture_transform();
        Self {
            texture: info.texture(),
            set: transform
                .as_ref()
                .and_then(|t| t.tex_coord())
                .unwrap_or(info.tex_coord()),
            transform: transform.map(|t| (t.offset(), t.rotation(), t.scale())),
        }
    }

    /// A normal texture's use (the `gltf` crate gives its `KHR_texture_transform` only as
    /// JSON: the extension's defaults where a member is absent or not a number).
    fn of_normal(info: &gltf::material::NormalTexture<'a>) -> Self {
        let ext = info.extension_value("KHR_texture_transform");
        let num = |v: Option<&gltf::json::Value>| v.and_then(gltf::json::Value::as_f64);
        let pair = |key: &str, default: [f32; 2]| {
            ext.and_then(|e| e.get(key))
                .and_then(|v| v.as_array())
                .map_or(default, |a| {
                    [0, 1].map(|i| num(a.get(i)).map_or(default[i], |x| x as f32))
                })
        };
        let transform = ext.map(|e| {
            (
                pair("offset", [0.0, 0.0]),
                num(e.get("rotation")).map_or(0.0, |x| x as f32),
                pair("scale", [1.0, 1.0]),
            )
        });
        let set = ext
            .and_then(|e| e.get("texCoord"))
            .and_then(gltf::json::Value::as_u64)
            .map_or(info.tex_coord(), |s| s as u32);
        Self {
            texture: info.texture(),
            set,
            transform,
        }
    }
}

fn wrap_of(m: gltf::texture::WrappingMode) -> Wrap {
    match m {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

impl GltfTextures {
    /// The texture ref (1 + index into `Scene::texture_refs`) of a material's texture, or 0
    /// with a warning when it cannot be used (its factor is then used alone).
    /// `linear`: the texels are data (metallic-roughness), not sRGB-encoded colour.
    fn reference(&mut self, c: &mut TextureContext, info: &TextureUse, linear: bool) -> u32 {
        let tex = &info.texture;
        let set = info.set;
        let warn = |c: &mut TextureContext, why: String| {
            c.warnings.push(format!(
                "{}: texture {} {why}: its material keeps the factor",
                c.path.display(),
                tex.index()
            ));
        };
        if set != 0 {
            warn(c, format!("uses TEXCOORD_{set}; only TEXCOORD_0 is read"));
            return 0;
        }
        let sampler = tex.sampler();
        let mut r = TextureRef {
            wrap: [wrap_of(sampler.wrap_s()), wrap_of(sampler.wrap_t())],
            linear,
            ..TextureRef::plain(0)
        };
        if let Some((offset, rotation, scale)) = info.transform {
            r = r.with_transform(offset, rotation, scale);
            if !r.row0.iter().chain(&r.row1).all(|x| x.is_finite()) {
                warn(
                    c,
                    format!(
                        "has a KHR_texture_transform that is not finite (offset {offset:?}, \
                         rotation {rotation}, scale {scale:?})"
                    ),
                );
                return 0;
            }
        }
        // A texture without a source (DDS only) is warned about with the extensions.
        let Some(image) = tex.source() else { return 0 };
        let index = match self.images.get(&image.index()) {
            Some(&i) => i,
            None => {
                let i = self.load_image(c, &image);
                self.images.insert(image.index(), i);
                i
            }
        };
        let Some(texture) = index else { return 0 };
        r.texture = texture;
        c.scene.texture_refs.push(r);
        c.scene.texture_refs.len() as u32
    }

    /// Decodes glTF image `image` (embedded in a buffer view or a file next to the scene) into
    /// `Scene::textures`, once per file or view; None with a warning when it is missing,
    /// unreadable or cannot be decoded. The textures kept are halved as they come to stay
    /// within [`texture::MAX_TEXEL_BYTES`] (so that memory holds at most one full-size
    /// decoded image more).
    fn load_image(&mut self, c: &mut TextureContext, image: &gltf::image::Image) -> Option<u32> {
        let name = image
            .name()
            .map_or_else(|| format!("image {}", image.index()), str::to_owned);
        let warn = |c: &mut TextureContext, why: String| {
            c.warnings.push(format!(
                "{}: {name} {why}: its materials keep their factors",
                c.path.display()
            ));
            None
        };
        let source = match image.source() {
            gltf::image::Source::View { view, .. } => ImageSource::View(view.index()),
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                return warn(c, "is a data: uri, which is not read".into());
            }
            gltf::image::Source::Uri { uri, .. } => {
                // Missing files were warned about together (and links leading out refused).
                let file = confined(c.path, c.dir, uri, false).ok()?;
                if !file.exists() {
                    return None;
                }
                match confined(c.path, c.dir, uri, true) {
                    Ok(f) => ImageSource::File(f),
                    Err(e) => return warn(c, error_chain(&e)),
                }
            }
        };
        if let Some(&known) = self.sources.get(&source) {
            return known;
        }
        let loaded = match image_bytes(c, image, &source) {
            Ok(bytes) => {
                texture::decode(&name, &bytes).map_err(|e| format!("cannot be decoded ({e})"))
            }
            Err(e) => Err(e),
        };
        let index = match loaded {
            Ok(t) => {
                c.scene.textures.push(t);
                self.halvings += texture::fit(&mut c.scene.textures, texture::MAX_TEXEL_BYTES);
                Some(c.scene.textures.len() as u32 - 1)
            }
            Err(e) => warn(c, e),
        };
        self.sources.insert(source, index);
        index
    }
}

/// The bytes of an image: its buffer view's (which must lie inside its buffer) or its file's
/// (through the shared opening path).
fn image_bytes(
    c: &TextureContext,
    image: &gltf::image::Image,
    source: &ImageSource,
) -> Result<Vec<u8>, String> {
    match (source, image.source()) {
        (ImageSource::File(f), _) => files::read_capped(f, MAX_TEXTURE_FILE_BYTES)
            .map_err(|e| format!("cannot be read ({})", error_chain(&e))),
        (_, gltf::image::Source::View { view, .. }) => {
            let b = c.buffers.get(view.buffer().index()).map_or(&[][..], |b| b);
            let range = view.offset()..view.offset().saturating_add(view.length());
            b.get(range.clone()).map(<[u8]>::to_vec).ok_or_else(|| {
                format!(
                    "is in buffer view {} (bytes {range:?}), which lies outside its buffer ({} \
                     bytes)",
                    view.index(),
                    b.len()
                )
            })
        }
        _ => Err("has no bytes".into()),
    }
}

/// Loads a glTF 2.0 file (.gltf or .glb) without sanitizing it.
pub fn load_gltf(path: &Path, warnings: &mut Vec<String>) -> Result<Scene, SceneError> {
    let bytes = read(path)?;
    let gltf = parse_gltf(path, &bytes, warnings)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let buffers = read_buffers(path, dir, &gltf)?;
    check_image_files(path, dir, &gltf, warnings)?;
    let mut g = GltfScene {
        path,
        dir,
        buffers: &buffers,
        scene: Scene::default(),
        materials: HashMap::new(),
        material_names: HashMap::new(),
        textures: GltfTextures::default(),
        warnings,
    };
    let scene_def = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or_else(|| parse_err(path, "glTF: no scene"))?;
    // Depth-first in file order (children pushed in reverse), so that cameras are listed in
    // the order the file gives them.
    let mut stack: Vec<(gltf::Node, Mat4, u32)> =
        scene_def.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    stack.reverse();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(parse_err(
                path,
                "glTF: node hierarchy deeper than 256 (a cycle?)",
            ));
        }
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, m, depth + 1));
        }
        if let Some(cam) = node.camera() {
            g.add_camera(&node, &cam, &m);
        }
        if let Some(light) = node.light() {
            parse_light(
                path,
                &gltf,
                &node,
                light.index(),
                &m,
                &mut g.scene,
                g.warnings,
            );
        }
        if let Some(mesh) = node.mesh() {
            g.add_mesh(&mesh, &m)?;
        }
    }
    Ok(g.finish())
}

/// The buffers of a glTF: the GLB binary chunk, base64 data uris, files next to the scene.
fn read_buffers(path: &Path, dir: &Path, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut buffers = Vec::new();
    for b in gltf.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                parse_err(path, "glTF: buffer refers to a missing GLB binary chunk")
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let (_, payload) = rest
                        .split_once(";base64,")
                        .ok_or_else(|| parse_err(path, "glTF: data URI is not base64"))?;
                    base64_decode(payload)
                        .ok_or_else(|| parse_err(path, "glTF: invalid base64 in a data URI"))?
                } else {
                    let file = confined(path, dir, uri, true)?;
                    read(&file)
                        .map_err(|e| parse_err(path, format!("glTF: buffer {uri:?}: {e}")))?
                }
            }
        };
        if data.len() < b.length() {
            return Err(parse_err(
                path,
                format!(
                    "glTF: buffer {} is truncated: {} bytes, {} declared",
                    b.index(),
                    data.len(),
                    b.length()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Refuses a scene naming image files outside its directory (also through a link: the base
/// colour and emissive textures are read later, the others never) and warns about missing ones
/// together.
fn check_image_files(
    path: &Path,
    dir: &Path,
    gltf: &gltf::Gltf,
    warnings: &mut Vec<String>,
) -> Result<(), SceneError> {
    let mut missing_images = Vec::new();
    for img in gltf.images() {
        if let gltf::image::Source::Uri { uri, .. } = img.source()
            && !uri.starts_with("data:")
        {
            let file = confined(path, dir, uri, false)?;
            if file.exists() {
                confined(path, dir, uri, true)?;
            } else {
                missing_images.push(uri);
            }
        }
    }
    if let Some(first) = missing_images.first() {
        warnings.push(format!(
            "{}: {} image files are missing (the first: {first:?}); the materials using them \
             keep their factors",
            path.display(),
            missing_images.len()
        ));
    }
    Ok(())
}

/// A glTF scene being built from its nodes.
struct GltfScene<'a> {
    path: &'a Path,
    dir: &'a Path,
    buffers: &'a [Vec<u8>],
    scene: Scene,
    /// glTF material index (None: the default material) -> scene material.
    materials: HashMap<Option<usize>, u32>,
    /// Scene material -> its glTF material's name for messages ([`material_name`]).
    material_names: HashMap<u32, String>,
    textures: GltfTextures,
    warnings: &'a mut Vec<String>,
}

/// A glTF camera's target lies at least this fraction of its eye's largest coordinate ahead
/// (2^-12: the view direction then rounds by at most about 2^-12 radians).
const TARGET_PRECISION: f32 = 1.0 / 4096.0;

impl GltfScene<'_> {
    /// The warnings of the whole file, and the first camera as the one renders use.
    fn finish(mut self) -> Scene {
        let path = self.path.display();
        if self.textures.alpha_cutouts > 0 {
            self.warnings.push(format!(
                "{path}: {} materials use alpha MASK or BLEND, which is not modelled yet: they \
                 render opaque",
                self.textures.alpha_cutouts
            ));
        }
        warn_halvings(self.path, self.textures.halvings, self.warnings);
        self.scene.camera = self.scene.cameras.first().map(|c| c.camera);
        self.scene
    }

    /// Adds the perspective camera of `node` (world transform `m`), or warns and skips it.
    fn add_camera(&mut self, node: &gltf::Node, cam: &gltf::Camera, m: &Mat4) {
        let name = node.name().or(cam.name()).map_or_else(
            || format!("camera {}", self.scene.cameras.len()),
            str::to_owned,
        );
        let p = match cam.projection() {
            gltf::camera::Projection::Perspective(p) => p,
            gltf::camera::Projection::Orthographic(_) => {
                self.warnings.push(format!(
                    "{}: camera {name:?} is orthographic: skipped (only perspective cameras \
                     are supported)",
                    self.path.display()
                ));
                return;
            }
        };
        let eye = m.transform_point3(Vec3::ZERO);
        let fwd = m.transform_vector3(-Vec3::Z).normalize_or_zero();
        let up = m.transform_vector3(Vec3::Y).normalize_or_zero();
        let aspect = p.aspect_ratio().filter(|a| *a > 0.0).unwrap_or(1.0);
        // glTF gives a direction, not a target: one unit ahead, or further where the eye's
        // coordinates are so large that one unit is lost in their rounding (an eye at 8e8
        // has a spacing of 64: its target one unit ahead was the eye itself).
        let ahead = (eye.abs().max_element() * TARGET_PRECISION).max(1.0);
        let camera = Camera {
            eye,
            target: eye + fwd * ahead,
            up,
            vfov_deg: p.yfov().to_degrees(),
            width: (256.0 * aspect).round().clamp(1.0, 16384.0) as u32,
            height: 256,
        };
        match camera.validate() {
            Ok(()) => self.scene.cameras.push(super::NamedCamera { name, camera }),
            Err(e) => self.warnings.push(format!(
                "{}: camera {name:?} skipped: {e}",
                self.path.display()
            )),
        }
    }

    /// Adds the triangle primitives of `mesh` (world transform `m`).
    fn add_mesh(&mut self, mesh: &gltf::Mesh, m: &Mat4) -> Result<(), SceneError> {
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                self.warnings.push(format!(
                    "{}: mesh {} has a {:?} primitive: skipped (only triangles are supported)",
                    self.path.display(),
                    mesh.index(),
                    prim.mode()
                ));
                continue;
            }
            self.add_primitive(mesh.index(), &prim, m)?;
        }
        Ok(())
    }

    fn add_primitive(
        &mut self,
        mesh: usize,
        prim: &gltf::Primitive,
        m: &Mat4,
    ) -> Result<(), SceneError> {
        let (path, buffers) = (self.path, self.buffers);
        for (role, acc) in [
            (AccessorRole::Position, prim.get(&gltf::Semantic::Positions)),
            (AccessorRole::Normal, prim.get(&gltf::Semantic::Normals)),
            (AccessorRole::Index, prim.indices()),
        ] {
            if let Some(acc) = acc {
                check_accessor(path, mesh, role, &acc, buffers)?;
            }
        }
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let local: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| {
                parse_err(
                    path,
                    format!("glTF: mesh {mesh} has no readable POSITION data"),
                )
            })?
            .map(Vec3::from)
            .collect();
        let positions: Vec<Vec3> = local.iter().map(|&p| m.transform_point3(p)).collect();
        let normal_m = Mat3::from_mat4(*m).inverse().transpose();
        let local_normals: Option<Vec<Vec3>> = reader
            .read_normals()
            .map(|it| it.map(Vec3::from).collect())
            .filter(|n: &Vec<Vec3>| n.len() == positions.len());
        let normals: Option<Vec<Vec3>> = local_normals.as_ref().map(|n| {
            n.iter()
                .map(|&n| (normal_m * n).normalize_or_zero())
                .collect()
        });
        let indices = read_indices(path, mesh, prim, &reader, positions.len())?;
        let material = self.material(&prim.material());
        let uvs = self.tex_coords(mesh, prim, &reader, positions.len(), material);
        let first = self.scene.triangles.len();
        for tri in indices.chunks_exact(3) {
            let idx = [tri[0], tri[1], tri[2]].map(|i| i as usize);
            self.scene.triangles.push(Triangle {
                v: idx.map(|i| positions[i]),
                n: normals.as_ref().map(|n| idx.map(|i| n[i])),
                uv: uvs.as_ref().map(|uv| idx.map(|i| uv[i])),
                t: None,
                material,
            });
        }
        if self.scene.materials[material as usize].normal_texture != 0 {
            let local_tris: Vec<Triangle> = indices
                .chunks_exact(3)
                .map(|tri| {
                    let idx = [tri[0], tri[1], tri[2]].map(|i| i as usize);
                    Triangle {
                        v: idx.map(|i| local[i]),
                        n: local_normals.as_ref().map(|n| idx.map(|i| n[i])),
                        uv: uvs.as_ref().map(|uv| idx.map(|i| uv[i])),
                        t: None,
                        material,
                    }
                })
                .collect();
            let file = self.file_tangents(mesh, prim, &reader, positions.len());
            self.add_tangents(mesh, first, &local_tris, &indices, file, m);
        }
        Ok(())
    }

    /// The primitive's `TANGENT`s (local space), when it has usable ones; a warning when it
    /// has unusable ones (they are then generated).
    fn file_tangents<'a, 's, F>(
        &mut self,
        mesh: usize,
        prim: &gltf::Primitive,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        vertices: usize,
    ) -> Option<Vec<glam::Vec4>>
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let acc = prim.get(&gltf::Semantic::Tangents)?;
        let problem = accessor_problem(&acc, AccessorRole::Tangent, self.buffers).or_else(|| {
            (acc.count() != vertices)
                .then(|| format!("has {} elements for {vertices} vertices", acc.count()))
        });
        let tangents: Option<Vec<glam::Vec4>> = match problem {
            None => reader
                .read_tangents()
                .map(|it| it.map(glam::Vec4::from).collect())
                .filter(|t: &Vec<glam::Vec4>| t.len() == vertices),
            Some(_) => None,
        };
        if tangents.is_none() {
            self.warnings.push(format!(
                "{}: mesh {mesh}: TANGENT accessor {} {}: MikkTSpace tangents are generated \
                 instead",
                self.path.display(),
                acc.index(),
                problem.unwrap_or_else(|| "is unreadable".into())
            ));
        }
        tangents
    }

    /// Gives the normal-mapped triangles `first..` of the scene (the primitive's, `local` in
    /// its mesh's space, with their vertex `indices`) their tangents: the file's (per vertex),
    /// else MikkTSpace's generated over `local`; transformed by the node's `m` (the handedness
    /// flipped where it mirrors).
    /// A primitive without vertex normals gets its flat normal at each corner (transformed as
    /// a normal: the one its tangents were made with). Triangles whose tangents are unusable
    /// ([`super::tangents::usable`]) keep none; a warning names their material.
    fn add_tangents(
        &mut self,
        mesh: usize,
        first: usize,
        local: &[Triangle],
        indices: &[u32],
        file: Option<Vec<glam::Vec4>>,
        m: &Mat4,
    ) {
        let normal_m = Mat3::from_mat4(*m).inverse().transpose();
        let Some(&Triangle { material, .. }) = local.first() else {
            return;
        };
        let name = self
            .material_names
            .get(&material)
            .cloned()
            .unwrap_or_default();
        if local[0].uv.is_none() {
            self.warnings.push(format!(
                "{}: material {name}: mesh {mesh} has no usable TEXCOORD_0: its normal map is \
                 not applied there",
                self.path.display()
            ));
            return;
        }
        let tangents: Vec<[glam::Vec4; 3]> = match &file {
            Some(per_vertex) => indices
                .chunks_exact(3)
                .map(|tri| [0, 1, 2].map(|c| per_vertex[tri[c] as usize]))
                .collect(),
            None => super::tangents::generate(local),
        };
        let m3 = Mat3::from_mat4(*m);
        let mirror = if m3.determinant() < 0.0 { -1.0 } else { 1.0 };
        let mut bad = 0usize;
        for (k, (tri, tan)) in local.iter().zip(&tangents).enumerate() {
            let t = &mut self.scene.triangles[first + k];
            if t.n.is_none() {
                t.n = Some([(normal_m * tri.cross()).normalize_or_zero(); 3]);
            }
            t.t = Some(tan.map(|q| (m3 * q.truncate()).normalize_or_zero().extend(q.w * mirror)));
            if !super::tangents::usable(t) {
                t.t = None;
                bad += 1;
            }
        }
        if bad > 0 {
            self.warnings.push(format!(
                "{}: material {name}: {bad} of the {} triangles of mesh {mesh} have unusable \
                 {} tangents (zero, NaN, parallel to the normal, or zero-area texture \
                 coordinates): they shade with their interpolated normals, without the normal \
                 map",
                self.path.display(),
                local.len(),
                if file.is_some() {
                    "TANGENT"
                } else {
                    "generated"
                }
            ));
        }
    }

    /// The primitive's `TEXCOORD_0`, when it is usable; a warning when it is not and its
    /// material has a texture (which then is not applied to it).
    fn tex_coords<'a, 's, F>(
        &mut self,
        mesh: usize,
        prim: &gltf::Primitive,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        vertices: usize,
        material: u32,
    ) -> Option<Vec<glam::Vec2>>
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let acc = prim.get(&gltf::Semantic::TexCoords(0))?;
        let problem = accessor_problem(&acc, AccessorRole::TexCoord, self.buffers).or_else(|| {
            (acc.count() != vertices)
                .then(|| format!("has {} elements for {vertices} vertices", acc.count()))
        });
        let Some(problem) = problem else {
            let uvs: Vec<glam::Vec2> = reader
                .read_tex_coords(0)?
                .into_f32()
                .map(glam::Vec2::from)
                .collect();
            return (uvs.len() == vertices).then_some(uvs);
        };
        let m = self.scene.materials.get(material as usize);
        if m.is_some_and(|m| {
            m.base_color_texture != 0
                || m.emissive_texture != 0
                || m.metallic_roughness_texture != 0
        }) {
            self.warnings.push(format!(
                "{}: mesh {mesh}: TEXCOORD_0 accessor {} {problem}: its textures are not \
                 applied (the material's factors are)",
                self.path.display(),
                acc.index()
            ));
        }
        None
    }

    /// The scene material of a glTF material (created with its textures the first time).
    fn material(&mut self, mat: &gltf::Material) -> u32 {
        let key = mat.index();
        if let Some(&id) = self.materials.get(&key) {
            return id;
        }
        let pbr = mat.pbr_metallic_roughness();
        let base = pbr.base_color_factor();
        let strength = mat.emissive_strength().unwrap_or(1.0);
        let e = mat.emissive_factor().map(|x| x * strength);
        // A primitive without a material gets a diffuse grey (glTF's default material is a
        // rough white metal, which no exporter means).
        let mut material = match key {
            None => Material::new(DEFAULT_ALBEDO, e),
            Some(_) => Material {
                emission: e,
                ..Material::metal_roughness(
                    [base[0], base[1], base[2]],
                    pbr.metallic_factor(),
                    pbr.roughness_factor(),
                )
            },
        };
        self.warn_out_of_range(mat, &material);
        let mut ctx = TextureContext {
            path: self.path,
            dir: self.dir,
            buffers: self.buffers,
            scene: &mut self.scene,
            warnings: self.warnings,
        };
        if let Some(info) = pbr.base_color_texture() {
            let info = TextureUse::of_info(&info);
            material.base_color_texture = self.textures.reference(&mut ctx, &info, false);
        }
        if let Some(info) = mat.emissive_texture() {
            let info = TextureUse::of_info(&info);
            material.emissive_texture = self.textures.reference(&mut ctx, &info, false);
        }
        if let Some(info) = pbr.metallic_roughness_texture() {
            let info = TextureUse::of_info(&info);
            material.metallic_roughness_texture = self.textures.reference(&mut ctx, &info, true);
        }
        if let Some(info) = mat.normal_texture() {
            let r = self
                .textures
                .reference(&mut ctx, &TextureUse::of_normal(&info), true);
            material.normal_texture = self.normal_texture(mat, &info, r);
            // A non-finite scale was warned about with the texture (which is then not used).
            material.normal_scale = Some(info.scale()).filter(|s| s.is_finite()).unwrap_or(1.0);
        }
        self.textures.alpha_cutouts +=
            usize::from(mat.alpha_mode() != gltf::material::AlphaMode::Opaque);
        let id = self.scene.add_material(material);
        self.materials.insert(key, id);
        self.material_names.insert(id, material_name(mat));
        id
    }

    /// The normal texture ref `r` of `mat` (0: it could not be read) if it is usable as a
    /// tangent-space normal map, else 0 with a warning naming the material (but for a missing
    /// image file, warned about with the others): a non-finite `scale`, or texels that are
    /// not a normal map's (all grey, r = g = b: a height or bump map; or a blue channel, the
    /// normals' z, below 0.5 on average: the normals point into the surface).
    fn normal_texture(
        &mut self,
        mat: &gltf::Material,
        info: &gltf::material::NormalTexture,
        r: u32,
    ) -> u32 {
        let problem = if r == 0 {
            let missing = match info.texture().source().map(|i| i.source()) {
                Some(gltf::image::Source::Uri { uri, .. }) if !uri.starts_with("data:") => {
                    confined(self.path, self.dir, uri, false).is_ok_and(|f| !f.exists())
                }
                _ => false,
            };
            if missing {
                return 0;
            }
            Some("cannot be read (above)".to_owned())
        } else if !info.scale().is_finite() {
            Some(format!("has a scale {} that is not finite", info.scale()))
        } else {
            let t = &self.scene.textures[self.scene.texture_refs[r as usize - 1].texture as usize];
            let grey = t.texels.iter().all(|p| p[0] == p[1] && p[1] == p[2]);
            let blue = t.texels.iter().map(|p| f64::from(p[2])).sum::<f64>()
                / (255.0 * t.texels.len().max(1) as f64);
            if grey {
                Some(format!(
                    "{:?} is grey (r = g = b: a height or bump map?), not a tangent-space \
                     normal map",
                    t.name
                ))
            } else if blue < 0.5 {
                Some(format!(
                    "{:?} has a blue channel (the normals' z) of {blue:.2} on average, below \
                     0.5: not a tangent-space normal map",
                    t.name
                ))
            } else {
                None
            }
        };
        match problem {
            None => r,
            Some(why) => {
                self.warnings.push(format!(
                    "{}: material {}: its normal texture {why}: ignored (the interpolated \
                     vertex normals shade)",
                    self.path.display(),
                    material_name(mat)
                ));
                0
            }
        }
    }
}

impl GltfScene<'_> {
    /// Warns, naming the material, about metallic or roughness factors outside [0, 1] or NaN
    /// (`Scene::sanitize` clamps them).
    fn warn_out_of_range(&mut self, mat: &gltf::Material, m: &Material) {
        let bad: Vec<String> = [
            ("metallicFactor", m.metallic),
            ("roughnessFactor", m.roughness),
        ]
        .into_iter()
        .filter(|(_, x)| !(0.0..=1.0).contains(x))
        .map(|(name, x)| format!("{name} {x}"))
        .collect();
        if !bad.is_empty() {
            self.warnings.push(format!(
                "{}: material {}: {} outside [0, 1]: clamped (NaN: 1)",
                self.path.display(),
                material_name(mat),
                bad.join(", ")
            ));
        }
    }
}

/// A glTF material's name for messages: its name, else its index.
fn material_name(mat: &gltf::Material) -> String {
    match (mat.name(), mat.index()) {
        (Some(name), _) => format!("{name:?}"),
        (None, Some(i)) => i.to_string(),
        (None, None) => "(default)".into(),
    }
}

/// The primitive's vertex indices (0..vertices without an index accessor), checked: all of
/// them read, a multiple of 3, in range.
fn read_indices<'a, 's, F>(
    path: &Path,
    mesh: usize,
    prim: &gltf::Primitive,
    reader: &gltf::mesh::Reader<'a, 's, F>,
    vertices: usize,
) -> Result<Vec<u32>, SceneError>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let indices: Vec<u32> = match (prim.indices(), reader.read_indices()) {
        (Some(acc), Some(it)) => {
            let v: Vec<u32> = it.into_u32().collect();
            if v.len() != acc.count() {
                return Err(parse_err(
                    path,
                    format!(
                        "glTF: mesh {mesh}: index accessor {} declares {} indices, its buffer \
                         holds {}",
                        acc.index(),
                        acc.count(),
                        v.len()
                    ),
                ));
            }
            v
        }
        (Some(acc), None) => {
            return Err(parse_err(
                path,
                format!(
                    "glTF: mesh {mesh}: index accessor {} is unreadable",
                    acc.index()
                ),
            ));
        }
        (None, _) => (0..vertices as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(parse_err(
            path,
            format!(
                "glTF: mesh {mesh}: {} {} is not a multiple of 3 (triangles)",
                indices.len(),
                if prim.indices().is_some() {
                    "indices"
                } else {
                    "vertices"
                }
            ),
        ));
    }
    if let Some(i) = indices.iter().find(|&&i| i as usize >= vertices) {
        return Err(parse_err(
            path,
            format!("glTF: mesh {mesh} index {i} is out of range ({vertices} vertices)"),
        ));
    }
    Ok(indices)
}

/// Adds the `KHR_lights_punctual` light `index` of `node` (world transform `m`) to the scene,
/// or warns and skips it when it is invalid.
fn parse_light(
    path: &Path,
    gltf: &gltf::Gltf,
    node: &gltf::Node,
    index: usize,
    m: &Mat4,
    scene: &mut Scene,
    warnings: &mut Vec<String>,
) {
    use gltf::json::extensions::scene::khr_lights_punctual::Type;
    use gltf::json::validation::Checked;
    let lights: &[gltf::json::extensions::scene::khr_lights_punctual::Light] =
        gltf.as_json().as_ref();
    let Some(json) = lights.get(index) else {
        warnings.push(format!(
            "{}: node {} refers to punctual light {index}, which does not exist: skipped",
            path.display(),
            node.index()
        ));
        return;
    };
    let name = node
        .name()
        .or(json.name.as_deref())
        .map_or_else(|| format!("light {}", scene.lights.len()), str::to_owned);
    let kind = match (&json.type_, &json.spot) {
        (Checked::Valid(Type::Point), _) => Ok(super::PunctualKind::Point),
        (Checked::Valid(Type::Directional), _) => Ok(super::PunctualKind::Directional),
        (Checked::Valid(Type::Spot), Some(spot)) => Ok(super::PunctualKind::Spot {
            inner_cone: spot.inner_cone_angle,
            outer_cone: spot.outer_cone_angle,
        }),
        (Checked::Valid(Type::Spot), None) => Err("a spot light without its \"spot\" cone".into()),
        (Checked::Invalid, _) => Err("an unknown light type".to_owned()),
    };
    // Above the cap, an intensity is clamped (as emission is): accumulating it would
    // overflow 32-bit floats into infinite pixels.
    let intensity = if json.intensity.is_finite() && json.intensity > super::MAX_PUNCTUAL_INTENSITY
    {
        warnings.push(format!(
            "{}: punctual light {name:?}: intensity {:e} clamped to {:e}",
            path.display(),
            json.intensity,
            super::MAX_PUNCTUAL_INTENSITY
        ));
        super::MAX_PUNCTUAL_INTENSITY
    } else {
        json.intensity
    };
    let light = kind.and_then(|kind| {
        let l = super::PunctualLight {
            name: name.clone(),
            kind,
            position: m.transform_point3(Vec3::ZERO),
            direction: m.transform_vector3(-Vec3::Z).normalize_or_zero(),
            color: json.color,
            intensity,
            range: json.range,
        };
        l.validate().map(|()| l)
    });
    match light {
        Ok(l) => scene.lights.push(l),
        Err(e) => warnings.push(format!(
            "{}: punctual light {name:?} skipped: {e}",
            path.display()
        )),
    }
}

/// Checks an MTL file's numeric lines (tobj rejects the whole library on one bad number, and
/// panics on a colour with two numbers) and expands one-number colours to three. Errors name
/// the line.
fn clean_mtl(file: &Path, text: &str) -> Result<String, SceneError> {
    let mut out = String::with_capacity(text.len());
    for (n, line) in text.lines().enumerate() {
        // A `#` starts a comment, also after values ("Ka 0.63 0.065 0.05 # Red").
        let data = line.split_once('#').map_or(line, |(d, _)| d);
        let mut words = data.split_whitespace();
        let key = words.next().unwrap_or("");
        let values: Vec<&str> = words.collect();
        let numbers = || {
            values
                .iter()
                .map(|v| v.parse::<f32>())
                .collect::<Result<Vec<_>, _>>()
        };
        let bad = |want: &str| {
            parse_err(
                file,
                format!(
                    "MTL line {}: {key} expects {want}, got {:?}",
                    n + 1,
                    values.join(" ")
                ),
            )
        };
        match key {
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => match numbers().as_deref() {
                Ok([r, g, b]) => out.push_str(&format!("{key} {r} {g} {b}")),
                Ok([x]) => out.push_str(&format!("{key} {x} {x} {x}")),
                _ => return Err(bad("1 or 3 numbers")),
            },
            "Ns" | "Ni" | "d" | "Tr" | "Pm" | "Pr" => match numbers().as_deref() {
                Ok([_]) => out.push_str(data.trim_end()),
                _ => return Err(bad("one number")),
            },
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

/// Loads an OBJ file (with its MTL libraries, relative to the file) without sanitizing it.
pub fn load_obj(path: &Path, warnings: &mut Vec<String>) -> Result<Scene, SceneError> {
    let bytes = read(path)?;
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        parse_err(
            path,
            format!(
                "OBJ: not UTF-8 text (invalid byte at offset {}): not an OBJ file?",
                e.valid_up_to()
            ),
        )
    })?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_owned();
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // What went wrong with each material library, by cause (tobj only keeps a code).
    let mtl_warnings: RefCell<Vec<String>> = RefCell::new(Vec::new());
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let (models, materials) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |mtl| {
        let file = dir.join(mtl);
        let bytes = match read(&file) {
            Ok(b) => b,
            Err(e) => {
                mtl_warnings.borrow_mut().push(format!(
                    "{}: material library {}; its materials are grey {DEFAULT_ALBEDO:?}",
                    path.display(),
                    error_chain(&e)
                ));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        let cleaned = std::str::from_utf8(&bytes)
            .map_err(|_| parse_err(&file, "MTL: not UTF-8 text"))
            .and_then(|t| clean_mtl(&file, t));
        match cleaned {
            Ok(t) => tobj::load_mtl_buf(&mut t.as_bytes()).inspect_err(|e| {
                mtl_error
                    .borrow_mut()
                    .get_or_insert(parse_err(&file, format!("MTL: {e}")));
            }),
            Err(e) => {
                mtl_error.borrow_mut().get_or_insert(e);
                Err(tobj::LoadError::MaterialParseError)
            }
        }
    })
    .map_err(|e| parse_err(path, format!("OBJ: {e}")))?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let mtl_warnings = mtl_warnings.into_inner();
    let libraries_ok = mtl_warnings.is_empty();
    warnings.extend(mtl_warnings);
    let materials = materials.unwrap_or_default();
    if libraries_ok {
        warn_unknown_usemtl(path, text, &materials, warnings);
    }
    let mut scene = Scene::default();
    let textured = obj_materials(path, &materials, &mut scene)?;
    obj_triangles(path, &models, materials.len(), &mut scene)?;
    if textured > 0 {
        warnings.push(format!(
            "{}: {textured} materials have textures, which are not modelled: their factors are used",
            path.display()
        ));
    }
    Ok(scene)
}

/// MTL texture statements of the PBR extension and of emission (tobj keeps them as unknown
/// parameters); textures of OBJ scenes are not read.
const MTL_TEXTURE_KEYS: [&str; 5] = ["map_Ke", "map_Pm", "map_Pr", "norm", "map_Kn"];

/// Adds the MTL materials (Kd as albedo, Ke as emission; with the PBR extension's `Pm` or `Pr`
/// a metallic-roughness material, see [`obj_metal_roughness`]) to `scene`; returns how many
/// have textures (not modelled).
fn obj_materials(
    path: &Path,
    materials: &[tobj::Material],
    scene: &mut Scene,
) -> Result<usize, SceneError> {
    let mut textured = 0usize;
    for m in materials {
        let has_texture = MTL_TEXTURE_KEYS
            .iter()
            .any(|k| m.unknown_param.contains_key(*k));
        if m.diffuse_texture.is_some() || m.normal_texture.is_some() || has_texture {
            textured += 1;
        }
        let bad_ke = |s: &str| parse_err(path, format!("MTL: material {:?}: bad Ke {s:?}", m.name));
        let ke = match (m.emissive, m.unknown_param.get("Ke")) {
            (Some(e), _) => e,
            (None, Some(s)) => {
                let v: Vec<f32> = s
                    .split_whitespace()
                    .map(str::parse)
                    .collect::<Result<_, _>>()
                    .map_err(|_| bad_ke(s))?;
                match v[..] {
                    [r, g, b] => [r, g, b],
                    [x] => [x; 3],
                    _ => return Err(bad_ke(s)),
                }
            }
            (None, None) => [0.0; 3],
        };
        let kd = m.diffuse.unwrap_or(DEFAULT_ALBEDO);
        let material = match obj_metal_roughness(m) {
            Some((metallic, roughness)) => Material {
                emission: ke,
                ..Material::metal_roughness(kd, metallic, roughness)
            },
            None => Material::new(kd, ke),
        };
        scene.add_material(material);
    }
    Ok(textured)
}

/// The metallic and roughness of an MTL material with the PBR extension (`Pm`, `Pr`, mapped
/// as glTF's factors, Kd the base colour), or None for a material without them (diffuse, as
/// before the extension). Without `Pr` the roughness comes from the Phong exponent `Ns`:
/// GGX alpha = sqrt(2 / (Ns + 2)) (Walter et al. 2007's Phong-Beckmann correspondence), so
/// roughness = alpha^(1/2); without either, 1. Without `Pm`, metallic 0.
fn obj_metal_roughness(m: &tobj::Material) -> Option<(f32, f32)> {
    // `clean_mtl` checked both as one number.
    let number = |k: &str| {
        m.unknown_param
            .get(k)
            .and_then(|v| v.trim().parse::<f32>().ok())
    };
    let (pm, pr) = (number("Pm"), number("Pr"));
    if pm.is_none() && pr.is_none() {
        return None;
    }
    let from_ns = |ns: f32| (2.0 / (ns.max(0.0) + 2.0)).sqrt().sqrt();
    let roughness = pr.or(m.shininess.map(from_ns)).unwrap_or(1.0);
    Some((pm.unwrap_or(0.0), roughness))
}

/// Adds the triangles of the OBJ models to `scene` (faces without a known material get a
/// default grey one).
fn obj_triangles(
    path: &Path,
    models: &[tobj::Model],
    n_materials: usize,
    scene: &mut Scene,
) -> Result<(), SceneError> {
    let default = scene.add_material(Material::new(DEFAULT_ALBEDO, [0.0; 3]));
    for model in models {
        let mesh = &model.mesh;
        let material = mesh
            .material_id
            .filter(|&i| i < n_materials)
            .map_or(default, |i| i as u32);
        let pos = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            Some(Vec3::from_slice(mesh.positions.get(i..i + 3)?))
        };
        let nrm = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            Some(Vec3::from_slice(mesh.normals.get(i..i + 3)?))
        };
        for tri in mesh.indices.chunks_exact(3) {
            let v = [pos(tri[0]), pos(tri[1]), pos(tri[2])];
            let [Some(a), Some(b), Some(c)] = v else {
                return Err(parse_err(
                    path,
                    format!("OBJ: object {:?} has a face index out of range", model.name),
                ));
            };
            let n = match [nrm(tri[0]), nrm(tri[1]), nrm(tri[2])] {
                [Some(x), Some(y), Some(z)] => Some([x, y, z]),
                _ => None,
            };
            scene.triangles.push(Triangle {
                v: [a, b, c],
                n,
                uv: None,
                t: None,
                material,
            });
        }
    }
    Ok(())
}

/// `usemtl` of a material no library defines: tobj falls back to no material (a missing
/// library has already been warned about).
fn warn_unknown_usemtl(
    path: &Path,
    text: &str,
    materials: &[tobj::Material],
    warnings: &mut Vec<String>,
) {
    for (n, line) in text.lines().enumerate() {
        if let Some(name) = line.trim_start().strip_prefix("usemtl ").map(str::trim)
            && !materials.iter().any(|m| m.name == name)
        {
            warnings.push(format!(
                "{} line {}: usemtl {name:?} names no material of the libraries: its faces \
                 are grey {DEFAULT_ALBEDO:?}",
                path.display(),
                n + 1
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_standard_text() {
        assert_eq!(base64_decode("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(base64_decode("aGVsbG8gd29ybGQ").unwrap(), b"hello world");
        assert!(base64_decode("a*b").is_none());
    }

    #[test]
    fn mtl_lines_are_checked_and_one_number_colours_expanded() {
        let f = Path::new("m.mtl");
        let t = clean_mtl(f, "newmtl a\nKd 0.5\nKe 1 2 3\nNs 10\n").unwrap();
        assert_eq!(t, "newmtl a\nKd 0.5 0.5 0.5\nKe 1 2 3\nNs 10\n");
        // Trailing comments (McGuire's Cornell box: "Ka 0.63 0.065 0.05 # Red").
        let t = clean_mtl(f, "newmtl a\nKa 0.63 0.065 0.05 # Red\nNs 10.0 # shiny\n").unwrap();
        assert_eq!(t, "newmtl a\nKa 0.63 0.065 0.05\nNs 10.0\n");
        for bad in ["Ke abc def", "Kd 1 2", "Ns", "Ni x"] {
            let e = clean_mtl(f, &format!("newmtl a\n{bad}\n")).unwrap_err();
            assert!(e.to_string().contains("m.mtl: MTL line 2"), "{e}");
        }
    }
}
