//! The scene model: triangles, a material each (diffuse, or glTF's metallic-roughness), and a
//! camera. Nothing else until a scene needs it.
//!
//! Conventions every consumer (GPU renderer, CPU reference) follows:
//! - Surfaces are **two-sided**: both the reflection and the emission act on either side
//!   of a triangle; a renderer flips the geometric normal to face the incoming ray. Loaders
//!   disagree about winding, and two-sided surfaces make that harmless.
//! - Units are whatever the scene uses; the built-in scenes are in metres.
//!
//! Entry points: [`builtin()`] (procedural scenes by name), [`load`] (glTF 2.0 / OBJ+MTL files),
//! [`Scene::sanitize`] (drops NaN/Inf and degenerate triangles, counts them in a
//! [`SanitizeReport`]).

mod add_lights;
pub mod builtin;
pub mod environment;
mod files;
mod loaders;
pub mod tangents;
pub mod texture;

pub use add_lights::{AddLights, AddedLights, MAX_ADDED_LIGHTS, add_lights};
pub use builtin::{
    BUILTIN_NAMES, BuiltinOptions, builtin, colonnade, cornell, furnace, furnace_sphere,
    many_lights,
};
pub use environment::Environment;
pub use files::{MAX_SCENE_FILE_BYTES, MAX_TEXTURE_FILE_BYTES};
pub use loaders::{
    DEFAULT_ALBEDO, ExtensionPolicy, Loaded, extension_policy, load, load_gltf, load_obj,
};
pub use texture::{Texture, TextureRef, Wrap};

use std::path::PathBuf;

use glam::Vec3;

/// The Rec. 709 luminance weights of linear RGB (the WGSL `render_luminance` is generated
/// from them).
pub const LUMINANCE: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Rec. 709 luminance of a linear RGB triple.
pub fn luminance(c: [f32; 3]) -> f32 {
    LUMINANCE[0] * c[0] + LUMINANCE[1] * c[1] + LUMINANCE[2] * c[2]
}
/// What can go wrong when building, loading or checking a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read the file")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: unsupported scene format (expected .gltf, .glb or .obj)")]
    UnsupportedFormat { path: PathBuf },
    #[error("unknown built-in scene {name:?} (expected one of {})", BUILTIN_NAMES.join(", "))]
    UnknownBuiltin { name: String },
    #[error("bad scene option: {0}")]
    BadOption(String),
    #[error("{what}: the scene has no valid triangles{}", .report.map(|r| format!(" ({r})")).unwrap_or_default())]
    Empty {
        what: String,
        report: Option<SanitizeReport>,
    },
    #[error(
        "{what}: the scene is {extent:e} units across, outside [{:e}, {:e}]: 32-bit light \
         densities and distances lose their precision there; rescale the scene",
        SCENE_EXTENT_RANGE.0,
        SCENE_EXTENT_RANGE.1
    )]
    Scale { what: String, extent: f32 },
    #[error("no camera {wanted:?} in the scene (expected a name or an index: {available})")]
    UnknownCamera { wanted: String, available: String },
}

/// The sizes (largest side of the bounding box) a scene may have. Renders are the same at every
/// scale inside (tested from 5.6e-11 to 1.7e9 across); at 5.6e-16 and at 5.6e11 the direct light
/// was 33% low.
pub const SCENE_EXTENT_RANGE: (f32, f32) = (5e-11, 5e9);

/// How a material reflects light ([`Material::model`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum MaterialModel {
    /// Lambertian: albedo / pi (the built-in scenes, OBJ materials without the PBR extension).
    Diffuse = 0,
    /// glTF 2.0's core metallic-roughness model (its Appendix B): a GGX specular lobe over a
    /// diffuse base for dielectrics, a coloured GGX lobe for metals, mixed by `metallic`.
    MetalRoughness = 1,
}

/// A material: base colour (reflectance), emitted radiance, and for
/// [`MaterialModel::MetalRoughness`] the metallic and roughness factors; linear RGB, each
/// factor optionally multiplied by a texture (`Scene::texture_refs[index - 1]`; 0: none); and
/// a tangent-space normal map with its scale. The GPU's `Material` has this layout (64 bytes:
/// the normal map's two words made it 56, and WGSL rounds a struct holding a `vec3` up to a
/// multiple of 16, so the last two words are padding).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Material {
    /// Base colour in [0, 1] per channel (glTF's base colour factor; the diffuse albedo of a
    /// diffuse material, the specular colour of a metal).
    pub albedo: [f32; 3],
    /// Base colour texture: 1 + its index in `Scene::texture_refs`, 0 for none.
    pub base_color_texture: u32,
    /// Emitted radiance (W sr^-1 m^-2 per channel); zero for non-emitters. Two-sided. The
    /// emissive factor (x strength) with a texture.
    pub emission: [f32; 3],
    /// Emissive texture: 1 + its index in `Scene::texture_refs`, 0 for none.
    pub emissive_texture: u32,
    /// A [`MaterialModel`] as its `u32` (Pod); read it with [`Material::model`].
    pub model: u32,
    /// Metallic factor in [0, 1] (glTF `metallicFactor`).
    pub metallic: f32,
    /// Perceptual roughness factor in [0, 1] (glTF `roughnessFactor`; GGX alpha = roughness^2).
    pub roughness: f32,
    /// glTF metallic-roughness texture (linear; blue = metallic, green = roughness, each
    /// multiplying its factor): 1 + its texture ref index, 0 for none.
    pub metallic_roughness_texture: u32,
    /// glTF `normalTexture` (linear, tangent space: n = 2 texel - 1, +x along the tangent, +y
    /// along the bitangent, +z along the normal): 1 + its texture ref index, 0 for none. It
    /// perturbs the shading normal of the triangles that have tangents
    /// ([`Triangle::t`]); the others shade with their interpolated normals.
    pub normal_texture: u32,
    /// glTF `normalTexture.scale`: the sampled normal's x and y are multiplied by it (1: as
    /// stored) before it is normalized.
    pub normal_scale: f32,
    pub _pad: [u32; 2],
}

impl Material {
    /// A diffuse material.
    pub const fn new(albedo: [f32; 3], emission: [f32; 3]) -> Self {
        Self {
            albedo,
            base_color_texture: 0,
            emission,
            emissive_texture: 0,
            model: MaterialModel::Diffuse as u32,
            metallic: 0.0,
            roughness: 1.0,
            metallic_roughness_texture: 0,
            normal_texture: 0,
            normal_scale: 1.0,
            _pad: [0; 2],
        }
    }

    /// A glTF metallic-roughness material without textures.
    pub const fn metal_roughness(base: [f32; 3], metallic: f32, roughness: f32) -> Self {
        Self {
            model: MaterialModel::MetalRoughness as u32,
            metallic,
            roughness,
            ..Self::new(base, [0.0; 3])
        }
    }

    /// This material's model (an unknown value reads as diffuse; `Scene::sanitize` resets it).
    pub fn model(&self) -> MaterialModel {
        match self.model {
            1 => MaterialModel::MetalRoughness,
            _ => MaterialModel::Diffuse,
        }
    }

    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.iter().any(|&e| e > 0.0)
    }

    /// The texture refs this material uses (1-based, 0: none): base colour, emission,
    /// metallic-roughness, normals.
    pub fn textures_mut(&mut self) -> [&mut u32; 4] {
        [
            &mut self.base_color_texture,
            &mut self.emissive_texture,
            &mut self.metallic_roughness_texture,
            &mut self.normal_texture,
        ]
    }
}

/// One triangle: positions, optional per-vertex shading normals, texture coordinates and
/// tangents, and its material index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    pub v: [Vec3; 3],
    /// Per-vertex normals (any length but 0; the renderers interpolate and normalize them for
    /// shading).
    pub n: Option<[Vec3; 3]>,
    /// Per-vertex texture coordinates (glTF `TEXCOORD_0`).
    pub uv: Option<[glam::Vec2; 3]>,
    /// Per-vertex tangents of a normal-mapped triangle (glTF `TANGENT`, or generated by
    /// MikkTSpace: [`tangents`]): xyz the unit tangent (along increasing u), w = +-1 the
    /// handedness, bitangent = w cross(normal, tangent) (towards the image's top, glTF's +y).
    /// Only used with texture coordinates and a material with a normal texture;
    /// [`Scene::sanitize`] removes unusable ones (the triangle then shades with its
    /// interpolated normals).
    pub t: Option<[glam::Vec4; 3]>,
    pub material: u32,
}

impl Triangle {
    /// A triangle without shading normals.
    pub const fn new(v: [Vec3; 3], material: u32) -> Self {
        Self {
            v,
            n: None,
            uv: None,
            t: None,
            material,
        }
    }
    /// Geometric normal (unnormalized: its length is twice the area).
    pub fn cross(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
    /// Area of the triangle.
    pub fn area(&self) -> f32 {
        0.5 * self.cross().length()
    }
    /// Area in f64 (no underflow nor overflow of the cross product).
    pub fn area_f64(&self) -> f64 {
        let v = self.v.map(|p| p.as_dvec3());
        0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length()
    }

    /// Whether the triangle has (numerically) no area: a zero or non-finite cross product, or
    /// edges so close to collinear that the sine of their angle is below 1e-7.
    /// Computed in f64, so that the test depends on the triangle's shape, not on its units (in
    /// f32 the cross product's length overflows near 3e9 and underflows near 1e-15).
    pub fn is_degenerate(&self) -> bool {
        let v = self.v.map(|p| p.as_dvec3());
        let c = (v[1] - v[0]).cross(v[2] - v[0]);
        let len = c.length();
        let e = [
            (v[1] - v[0]).length_squared(),
            (v[2] - v[1]).length_squared(),
            (v[0] - v[2]).length_squared(),
        ];
        let longest = e[0].max(e[1]).max(e[2]);
        !len.is_finite() || len == 0.0 || len <= 1e-7 * longest
    }
}

/// Smallest triangle area, in the GPU's units ([`Scene::gpu_units`]), a scene keeps: twice
/// the area is the length of the edges' cross product, whose square must stay a normal
/// 32-bit float (above 1.2e-38) for the normal to be computed (a lamp of area 1e-20 in a
/// scene of 2 units rendered NaN pixels).
pub const MIN_GPU_AREA: f32 = 1e-18;

/// Largest emitted radiance per channel a scene may hold: accumulating many samples of a
/// larger one overflows 32-bit floats (infinite pixels). [`Scene::sanitize`] clamps to it.
pub const MAX_EMISSION: f32 = 1e10;

/// Largest intensity (candela, or lux for directional lights) a punctual light may have, for
/// the same reason: the loader clamps a file's lights to it, and a scaled one above it is
/// refused.
pub const MAX_PUNCTUAL_INTENSITY: f32 = 1e10;

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// This camera in units `k` times smaller (eye and target times `k`).
    pub fn scaled(&self, k: f32) -> Camera {
        Camera {
            eye: self.eye * k,
            target: self.target * k,
            ..*self
        }
    }

    /// Checks that the camera can produce rays: finite vectors, eye != target, up not parallel
    /// to the view direction, 0 < fov < 180, non-zero size.
    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |m: &str| Err(SceneError::BadOption(format!("camera: {m}")));
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return bad("eye, target and up must be finite");
        }
        let fwd = self.target - self.eye;
        if !fwd.is_finite() || !fwd.length_squared().is_finite() {
            return bad("eye and target are too far apart: their distance overflows 32-bit floats");
        }
        if fwd.length_squared() == 0.0 {
            return bad("eye and target coincide");
        }
        if fwd.normalize().cross(self.up.normalize_or_zero()).length() < 1e-6 {
            return bad("up is zero or parallel to the view direction");
        }
        if !(self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return bad("vertical field of view must be in (0, 180) degrees");
        }
        if self.width == 0 || self.height == 0 {
            return bad("image size must be at least 1x1");
        }
        Ok(())
    }
}

/// A camera animation over `frames` frames (then it repeats).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraPath {
    Static,
    /// Orbit around the target by `degrees` about the up axis over `frames` frames.
    Orbit {
        frames: u32,
        degrees: f32,
    },
    /// Move towards the target by `fraction` of the eye-target distance over `frames` frames.
    Dolly {
        frames: u32,
        fraction: f32,
    },
}

impl CameraPath {
    /// The camera of frame `frame` of the path starting at `base`.
    pub fn camera(&self, base: &Camera, frame: u32) -> Camera {
        match *self {
            CameraPath::Static => *base,
            CameraPath::Orbit { frames, degrees } => {
                let t = (frame % frames.max(1)) as f32 / frames.max(1) as f32;
                let rot =
                    glam::Quat::from_axis_angle(base.up.normalize(), (degrees * t).to_radians());
                Camera {
                    eye: base.target + rot * (base.eye - base.target),
                    ..*base
                }
            }
            CameraPath::Dolly { frames, fraction } => {
                let t = (frame % frames.max(1)) as f32 / frames.max(1) as f32;
                Camera {
                    eye: base.eye + (base.target - base.eye) * (fraction * t),
                    ..*base
                }
            }
        }
    }
}

/// A camera of a scene file with its name (the node's, else the camera's, else `camera N`).
#[derive(Debug, Clone, PartialEq)]
pub struct NamedCamera {
    pub name: String,
    pub camera: Camera,
}

/// What kind of punctual light (glTF `KHR_lights_punctual`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PunctualKind {
    /// Emits in all directions from `position`; intensity in candela.
    Point,
    /// Emits along `direction` inside a cone (angles from the axis, radians,
    /// `0 <= inner < outer <= pi/2`); intensity in candela.
    Spot { inner_cone: f32, outer_cone: f32 },
    /// Infinitely far away, emits along `direction`; intensity (illuminance) in lux.
    Directional,
}

/// A punctual light from a scene file (glTF `KHR_lights_punctual`), in world space, parsed and
/// validated; every renderer samples it (`lights`: one entry of the power-proportional table).
#[derive(Debug, Clone, PartialEq)]
pub struct PunctualLight {
    /// The node's name, else the light's, else `light N`.
    pub name: String,
    pub kind: PunctualKind,
    /// World position (ignored for directional lights).
    pub position: Vec3,
    /// Unit direction the light travels (the node's -z; ignored for point lights).
    pub direction: Vec3,
    /// Linear RGB colour, each channel in [0, 1].
    pub color: [f32; 3],
    /// Candela (point, spot) or lux (directional), finite and >= 0.
    pub intensity: f32,
    /// Distance beyond which the light is cut off (`None`: infinite), > 0.
    pub range: Option<f32>,
}

impl PunctualLight {
    /// Checks the values the glTF specification allows; the message names what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.position.is_finite() && self.direction.is_finite()) {
            return Err("position and direction must be finite".into());
        }
        if (self.direction.length() - 1.0).abs() > 1e-3 {
            return Err("its node's transform has no usable -z direction".into());
        }
        if !self.color.iter().all(|c| (0.0..=1.0).contains(c)) {
            return Err(format!("color {:?} must be in [0, 1]", self.color));
        }
        if !(self.intensity.is_finite() && (0.0..=MAX_PUNCTUAL_INTENSITY).contains(&self.intensity))
        {
            return Err(format!(
                "intensity {:e} must be finite and in [0, {MAX_PUNCTUAL_INTENSITY:e}]",
                self.intensity
            ));
        }
        if let Some(r) = self.range
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("range {r} must be finite and > 0"));
        }
        if let PunctualKind::Spot {
            inner_cone,
            outer_cone,
        } = self.kind
            && !(0.0 <= inner_cone
                && inner_cone < outer_cone
                && outer_cone <= std::f32::consts::FRAC_PI_2)
        {
            return Err(format!(
                "spot cone angles {inner_cone} and {outer_cone} must satisfy \
                 0 <= inner < outer <= pi/2"
            ));
        }
        Ok(())
    }
}

/// Scenes whose extent is below this are rendered scaled by a power of two
/// ([`Scene::gpu_units`]): 2^-10, about a millimetre in metres.
pub const SMALLEST_GPU_EXTENT: f32 = 1.0 / 1024.0;

/// The power of two that brings a finite, positive `extent` into [1, 2) (exact: scaling by
/// it changes no mantissa): with extent = m 2^e, m in [1, 2), it is 2^-e (within 2^+-126).
pub fn unit_extent_scale(extent: f32) -> f32 {
    let e = extent.log2().floor().clamp(-126.0, 126.0) as i32;
    2f32.powi(-e)
}

/// A scene ready to render: triangles with materials, and an optional camera from the file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    /// The camera renders use (a file's first camera, or the one [`Scene::select_camera`]
    /// chose); `None`: `Scene::camera_or_default` (in [`crate::framing`]) frames the scene.
    pub camera: Option<Camera>,
    /// All cameras of a scene file, in file order (depth-first over the default scene's
    /// nodes); empty for the built-in scenes.
    pub cameras: Vec<NamedCamera>,
    /// Punctual lights of a scene file, sampled by every renderer with the emissive triangles
    /// (see `lights`).
    pub lights: Vec<PunctualLight>,
    /// Light from infinity seen by rays that miss the scene (`None`: black).
    pub environment: Option<Environment>,
    /// Texture images (8-bit) of the materials.
    pub textures: Vec<Texture>,
    /// The materials' uses of the textures (`Material`'s texture fields index them from 1).
    pub texture_refs: Vec<TextureRef>,
}

/// Clamps a material's model fields into range: an unknown model becomes diffuse, metallic and
/// roughness into [0, 1] (NaN: glTF's default 1). Returns whether anything changed.
fn sanitize_metal_roughness(m: &mut Material) -> bool {
    let before = *m;
    m.model = m.model() as u32;
    for x in [&mut m.metallic, &mut m.roughness] {
        *x = if x.is_nan() { 1.0 } else { x.clamp(0.0, 1.0) };
    }
    // Bitwise: a NaN factor counts as changed.
    bytemuck::bytes_of(&before) != bytemuck::bytes_of(m)
}

/// What [`Scene::sanitize`] dropped or repaired. All counts are zero for a clean scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SanitizeReport {
    /// Triangles dropped because a vertex had a NaN or infinite coordinate.
    pub non_finite: usize,
    /// Triangles dropped because they had no area.
    pub degenerate: usize,
    /// Triangles dropped because their area, in the GPU's units ([`Scene::gpu_units`]), is
    /// below [`MIN_GPU_AREA`]: their normals' squared lengths underflow 32-bit floats (NaN
    /// pixels), and they reflect or emit nothing a 32-bit image holds.
    pub too_small: usize,
    /// Triangles dropped because their material index was out of range.
    pub bad_material: usize,
    /// Triangles whose shading normals were non-finite or zero and were removed (the geometric
    /// normal is used instead).
    pub bad_normals: usize,
    /// Triangles whose texture coordinates were non-finite and were removed (their textures
    /// are not applied: the material's factors are).
    pub bad_uvs: usize,
    /// Triangles whose tangents were unusable ([`tangents::usable`]: zero, non-finite,
    /// parallel to the normal, zero-area texture coordinates, or no texture coordinates) and
    /// were removed (their normal map is not applied: the interpolated normals shade). The
    /// loaders remove theirs first, with a warning naming the material.
    pub bad_tangents: usize,
    /// Materials whose albedo or emission was non-finite, negative, (albedo) above 1 or
    /// (emission) above [`MAX_EMISSION`], and was clamped into range (non-finite values
    /// become 0); or whose metallic or roughness was outside [0, 1] or NaN, model unknown,
    /// or a texture unusable.
    pub clamped_materials: usize,
}

impl SanitizeReport {
    /// Whether nothing was dropped or repaired.
    pub fn is_clean(&self) -> bool {
        *self == Self::default()
    }
    /// Number of triangles dropped.
    pub fn dropped(&self) -> usize {
        self.non_finite + self.degenerate + self.too_small + self.bad_material
    }
}

impl std::fmt::Display for SanitizeReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "dropped {} triangles ({} with NaN/Inf vertices, {} degenerate, {} of an area below \
             {MIN_GPU_AREA:e} in the GPU's units, {} with a bad material index); removed bad shading normals on {}; removed bad texture coordinates on {}; \
             removed unusable tangents on {}; clamped {} materials (albedo, metallic and \
             roughness into [0, 1], emission into [0, {MAX_EMISSION:e}])",
            self.dropped(),
            self.non_finite,
            self.degenerate,
            self.too_small,
            self.bad_material,
            self.bad_normals,
            self.bad_uvs,
            self.bad_tangents,
            self.clamped_materials
        )
    }
}

impl Scene {
    /// Drops triangles with NaN/Inf vertices, degenerate triangles and triangles with an
    /// out-of-range material; removes unusable shading normals; clamps materials into range.
    /// Returns what it did. A scene left with no triangle is an error ([`SceneError::Empty`]);
    /// a scene without emitters is fine (it renders black).
    pub fn sanitize(&mut self, what: &str) -> Result<SanitizeReport, SceneError> {
        let mut report = SanitizeReport::default();
        for m in &mut self.materials {
            let mut changed = false;
            for a in &mut m.albedo {
                let c = if a.is_finite() {
                    a.clamp(0.0, 1.0)
                } else {
                    0.0
                };
                changed |= c != *a || a.is_nan();
                *a = c;
            }
            for e in &mut m.emission {
                let c = if e.is_finite() {
                    e.clamp(0.0, MAX_EMISSION)
                } else {
                    0.0
                };
                changed |= c != *e || e.is_nan();
                *e = c;
            }
            changed |= sanitize_metal_roughness(m);
            if !m.normal_scale.is_finite() {
                m.normal_scale = 1.0;
                changed = true;
            }
            let refs = self.texture_refs.len() as u32;
            for tex in m.textures_mut() {
                if *tex > refs {
                    *tex = 0;
                    changed = true;
                }
            }
            report.clamped_materials += usize::from(changed);
        }
        self.sanitize_texture_refs(&mut report);
        let n_materials = self.materials.len();
        self.triangles.retain_mut(|t| {
            if !t.v.iter().all(|v| v.is_finite()) {
                report.non_finite += 1;
                return false;
            }
            if t.is_degenerate() {
                report.degenerate += 1;
                return false;
            }
            if t.material as usize >= n_materials {
                report.bad_material += 1;
                return false;
            }
            if let Some(n) = &t.n
                && !n.iter().all(|n| n.is_finite() && n.length_squared() > 0.0)
            {
                t.n = None;
                report.bad_normals += 1;
            }
            if let Some(uv) = &t.uv
                && !uv.iter().all(|uv| uv.is_finite())
            {
                t.uv = None;
                report.bad_uvs += 1;
            }
            if t.t.is_some() && !tangents::usable(t) {
                t.t = None;
                report.bad_tangents += 1;
            }
            true
        });
        if self.triangles.is_empty() {
            return Err(SceneError::Empty {
                what: what.to_owned(),
                report: Some(report),
            });
        }
        if let Some((lo, hi)) = self.bounds() {
            let extent = (hi - lo).max_element();
            if !(SCENE_EXTENT_RANGE.0..=SCENE_EXTENT_RANGE.1).contains(&extent) {
                return Err(SceneError::Scale {
                    what: what.to_owned(),
                    extent,
                });
            }
        }
        // After the extent check: gpu_units is that of the scene the GPU receives.
        let area_units = f64::from(self.gpu_units()).powi(2);
        self.triangles.retain(|t| {
            let small = t.area_f64() * area_units < f64::from(MIN_GPU_AREA);
            report.too_small += usize::from(small);
            !small
        });
        if self.triangles.is_empty() {
            return Err(SceneError::Empty {
                what: what.to_owned(),
                report: Some(report),
            });
        }
        Ok(report)
    }

    /// Unlinks the materials from texture refs that are unusable (a missing or malformed
    /// texture, a non-finite transform; only a hand-built scene can have one): those materials
    /// keep their factors and are counted as clamped; the other textures stay.
    fn sanitize_texture_refs(&mut self, report: &mut SanitizeReport) {
        let textures = &self.textures;
        let valid = |r: &TextureRef| {
            textures.get(r.texture as usize).is_some_and(|t| {
                t.width > 0 && t.texels.len() as u64 == u64::from(t.width) * u64::from(t.height)
            }) && r.row0.iter().chain(&r.row1).all(|x| x.is_finite())
        };
        let ok: Vec<bool> = self.texture_refs.iter().map(valid).collect();
        for m in &mut self.materials {
            let mut changed = false;
            for tex in m.textures_mut() {
                if *tex > 0 && !ok.get(*tex as usize - 1).copied().unwrap_or(false) {
                    *tex = 0;
                    changed = true;
                }
            }
            report.clamped_materials += usize::from(changed);
        }
    }

    /// How many materials are glossy ([`MaterialModel::MetalRoughness`]) and used by a
    /// triangle: what the renderer specializes its kernels for.
    pub fn glossy_materials(&self) -> usize {
        let mut used = vec![false; self.materials.len()];
        for t in &self.triangles {
            if let Some(u) = used.get_mut(t.material as usize) {
                *u = true;
            }
        }
        self.materials
            .iter()
            .zip(used)
            .filter(|(m, u)| *u && m.model() == MaterialModel::MetalRoughness)
            .count()
    }

    /// This scene with every material diffuse (its base colour as the albedo; metallic,
    /// roughness and their texture dropped; the normal map kept): `--materials diffuse`, the
    /// matte rendering of before glossy materials.
    pub fn with_diffuse_materials(mut self) -> Scene {
        for m in &mut self.materials {
            *m = Material {
                base_color_texture: m.base_color_texture,
                emissive_texture: m.emissive_texture,
                normal_texture: m.normal_texture,
                normal_scale: m.normal_scale,
                ..Material::new(m.albedo, m.emission)
            };
        }
        self
    }

    /// The scene with every material glTF metallic-roughness at `metallic` and `roughness`
    /// (their textures dropped), keeping its base colour, emission and normal map: the same
    /// scene as glossy as asked, for measuring a method against the lobe's width.
    pub fn with_uniform_gloss(mut self, metallic: f32, roughness: f32) -> Scene {
        for m in &mut self.materials {
            *m = Material {
                base_color_texture: m.base_color_texture,
                emissive_texture: m.emissive_texture,
                normal_texture: m.normal_texture,
                normal_scale: m.normal_scale,
                ..Material {
                    emission: m.emission,
                    ..Material::metal_roughness(m.albedo, metallic, roughness)
                }
            };
        }
        self
    }

    /// Axis-aligned bounds of all vertices, `(min, max)`; `None` for an empty scene.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.triangles.iter().flat_map(|t| t.v);
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v))))
    }

    /// The largest radiance any channel of the scene emits: its materials' emission and its
    /// environment's pixels (punctual lights have no radiance).
    pub fn brightest_emission(&self) -> f32 {
        let brightest = |c: [f32; 3]| c.into_iter().fold(0.0f32, f32::max);
        let emitted = self.materials.iter().map(|m| brightest(m.emission));
        let sky = self
            .environment
            .iter()
            .flat_map(|e| e.pixels.iter().map(|p| brightest(*p)));
        emitted.chain(sky).fold(0.0f32, f32::max)
    }

    /// The power of two the GPU renderer scales this scene by ([`crate::render::Renderer`]):
    /// 1 unless its extent (largest side of its bounding box) is below [`SMALLEST_GPU_EXTENT`],
    /// else the one that brings the extent into [1, 2). Products of two areas of a scene of
    /// 1e-10 units are below f32's smallest normal number, and GPUs that flush subnormals to 0
    /// (an NVIDIA H200 does; lavapipe does not) rendered NaN there; a power of two scales
    /// exactly, so the image is the same.
    pub fn gpu_units(&self) -> f32 {
        let extent = self
            .bounds()
            .map_or(1.0, |(lo, hi)| (hi - lo).max_element());
        if !(extent.is_finite() && extent > 0.0) || extent >= SMALLEST_GPU_EXTENT {
            return 1.0;
        }
        unit_extent_scale(extent)
    }

    /// This scene in units `k` times smaller (every position times `k`, a punctual light's
    /// range too and its candela times `k^2`, so that it lights the scaled surfaces as
    /// before); its cameras too.
    pub fn scaled(&self, k: f32) -> Scene {
        let mut s = self.clone();
        for t in &mut s.triangles {
            t.v = t.v.map(|v| v * k);
        }
        for l in &mut s.lights {
            l.position *= k;
            l.range = l.range.map(|r| r * k);
            if l.kind != PunctualKind::Directional {
                l.intensity *= k * k;
            }
        }
        s.camera = s.camera.map(|c| c.scaled(k));
        for c in &mut s.cameras {
            c.camera = c.camera.scaled(k);
        }
        s
    }

    /// Makes the file camera `wanted` (an index into [`Scene::cameras`] or a name) the one
    /// renders use. An unknown one is an error listing the cameras there are.
    /// A scene without named cameras but with a camera (the built-in scenes) offers that one
    /// as `0` / `default`.
    pub fn select_camera(&mut self, wanted: &str) -> Result<(), SceneError> {
        let implicit;
        let cameras = match (&self.cameras[..], self.camera) {
            ([], Some(camera)) => {
                implicit = [NamedCamera {
                    name: "default".into(),
                    camera,
                }];
                &implicit[..]
            }
            (named, _) => named,
        };
        let found = match wanted.trim().parse::<usize>() {
            Ok(i) => cameras.get(i),
            Err(_) => cameras.iter().find(|c| c.name == wanted),
        };
        match found {
            Some(c) => {
                self.camera = Some(c.camera);
                Ok(())
            }
            None => Err(SceneError::UnknownCamera {
                wanted: wanted.to_owned(),
                available: if cameras.is_empty() {
                    "the scene has no cameras".into()
                } else {
                    let list: Vec<String> = cameras
                        .iter()
                        .enumerate()
                        .map(|(i, c)| format!("{i} {:?}", c.name))
                        .collect();
                    format!("the scene has {}", list.join(", "))
                },
            }),
        }
    }

    /// Number of triangles whose material emits.
    pub fn emissive_triangles(&self) -> usize {
        self.triangles
            .iter()
            .filter(|t| {
                self.materials
                    .get(t.material as usize)
                    .is_some_and(Material::is_emissive)
            })
            .count()
    }

    /// Appends the two triangles (a, b, c) and (a, c, d) of the planar quad a-b-c-d.
    pub fn push_quad(&mut self, q: [Vec3; 4], material: u32) {
        self.triangles
            .push(Triangle::new([q[0], q[1], q[2]], material));
        self.triangles
            .push(Triangle::new([q[0], q[2], q[3]], material));
    }

    /// Appends the 12 triangles of the box with corners `lo` and `hi`.
    pub fn push_box(&mut self, lo: Vec3, hi: Vec3, material: u32) {
        let c = |x: bool, y: bool, z: bool| {
            Vec3::new(
                if x { hi.x } else { lo.x },
                if y { hi.y } else { lo.y },
                if z { hi.z } else { lo.z },
            )
        };
        let (f, t) = (false, true);
        for q in [
            [c(f, f, f), c(t, f, f), c(t, f, t), c(f, f, t)], // bottom
            [c(f, t, f), c(f, t, t), c(t, t, t), c(t, t, f)], // top
            [c(f, f, f), c(f, t, f), c(t, t, f), c(t, f, f)], // z = lo
            [c(f, f, t), c(t, f, t), c(t, t, t), c(f, t, t)], // z = hi
            [c(f, f, f), c(f, f, t), c(f, t, t), c(f, t, f)], // x = lo
            [c(t, f, f), c(t, t, f), c(t, t, t), c(t, f, t)], // x = hi
        ] {
            self.push_quad(q, material);
        }
    }

    /// Adds a material and returns its index.
    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene below the smallest extent is rendered scaled by the power of two that brings
    /// its extent into [1, 2); others are not scaled. Scaling moves every position and keeps
    /// what a punctual light delivers to the scaled surfaces (candela times k^2).
    #[test]
    fn tiny_scenes_are_scaled_by_a_power_of_two() {
        let mut s = builtin::cornell(8, 8);
        assert_eq!(s.gpu_units(), 1.0);
        s.lights.push(PunctualLight {
            name: "lamp".into(),
            kind: PunctualKind::Point,
            position: Vec3::ONE,
            direction: Vec3::NEG_Y,
            color: [1.0; 3],
            intensity: 8.0,
            range: Some(4.0),
        });
        let extent = |s: &Scene| s.bounds().map(|(lo, hi)| (hi - lo).max_element()).unwrap();
        for k in [1e-3, 1e-10, 3e-30] {
            let tiny = s.scaled(k);
            let units = tiny.gpu_units();
            assert_eq!(units.log2().fract(), 0.0, "{units}");
            let e = extent(&tiny) * units;
            assert!((1.0..2.0).contains(&e), "{k}: extent {e}");
        }
        let half = s.scaled(0.5);
        assert_eq!(half.lights[0].position, Vec3::splat(0.5));
        assert_eq!(half.lights[0].intensity, 2.0);
        assert_eq!(half.lights[0].range, Some(2.0));
        assert_eq!(half.triangles[3].v[1], s.triangles[3].v[1] * 0.5);
        let cam = s.camera.unwrap();
        assert_eq!(half.camera.unwrap().eye, cam.eye * 0.5);
    }

    #[test]
    fn orbit_keeps_the_distance_to_the_target() {
        let base = Camera {
            eye: glam::Vec3::new(0.0, 1.0, -5.0),
            target: glam::Vec3::ZERO,
            up: glam::Vec3::Y,
            vfov_deg: 40.0,
            width: 8,
            height: 8,
        };
        let path = CameraPath::Orbit {
            frames: 10,
            degrees: 90.0,
        };
        for f in 0..10 {
            let c = path.camera(&base, f);
            assert!(((c.eye - c.target).length() - (base.eye - base.target).length()).abs() < 1e-4);
        }
    }

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Triangle {
        Triangle::new([a.into(), b.into(), c.into()], 0)
    }

    #[test]
    fn sanitize_drops_and_counts_bad_triangles() {
        let mut s = Scene {
            triangles: vec![
                tri([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                tri([f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                tri([0.0; 3], [f32::INFINITY, 0.0, 0.0], [0.0, 1.0, 0.0]),
                tri([0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]),
                tri([0.0; 3], [0.0; 3], [0.0, 1.0, 0.0]),
                Triangle {
                    material: 7,
                    ..tri([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
                },
                Triangle {
                    n: Some([Vec3::Z, Vec3::ZERO, Vec3::Z]),
                    ..tri([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
                },
            ],
            materials: vec![Material::new([2.0, f32::NAN, 0.5], [-1.0, 0.0, 0.0])],
            ..Default::default()
        };
        let r = s.sanitize("test").unwrap();
        assert_eq!(
            r,
            SanitizeReport {
                non_finite: 2,
                degenerate: 2,
                too_small: 0,
                bad_material: 1,
                bad_normals: 1,
                bad_uvs: 0,
                bad_tangents: 0,
                clamped_materials: 1
            }
        );
        assert_eq!(s.triangles.len(), 2);
        assert_eq!(s.materials[0], Material::new([1.0, 0.0, 0.5], [0.0; 3]));
        assert!(s.triangles[1].n.is_none());
        assert!(!r.is_clean());
        assert!(r.to_string().contains("dropped 5 triangles"));
    }

    #[test]
    fn sanitize_rejects_a_scene_left_empty() {
        let mut s = Scene {
            triangles: vec![tri([0.0; 3], [0.0; 3], [0.0; 3])],
            materials: vec![Material::new([0.5; 3], [0.0; 3])],
            ..Default::default()
        };
        let e = s.sanitize("x.obj").unwrap_err();
        assert!(matches!(e, SceneError::Empty { .. }), "{e}");
        assert!(e.to_string().contains("x.obj"));
        let mut empty = Scene::default();
        assert!(empty.sanitize("e").is_err());
    }

    #[test]
    fn default_camera_sees_the_bounds_and_validates() {
        let mut s = Scene::default();
        let m = s.add_material(Material::new([0.5; 3], [0.0; 3]));
        s.push_box(Vec3::splat(-2.0), Vec3::splat(3.0), m);
        let c = s.camera_or_default(64, 32);
        c.validate().unwrap();
        assert_eq!((c.width, c.height), (64, 32));
        assert!(
            c.eye.z > 3.0,
            "a closed box is framed from the front (+z): {}",
            c.eye
        );
        let bad = Camera { vfov_deg: 0.0, ..c };
        assert!(bad.validate().is_err());
        let bad = Camera {
            up: c.target - c.eye,
            ..c
        };
        assert!(bad.validate().is_err());
        // Finite ends whose distance overflows f32 (issue 14): refused, not a black image.
        let far = Camera {
            eye: Vec3::new(0.0, 1.0, 3e38),
            target: Vec3::new(0.0, 1.0, -3e38),
            ..c
        };
        let e = far.validate().unwrap_err();
        assert!(e.to_string().contains("too far apart"), "{e}");
    }

    #[test]
    fn cameras_are_selected_by_index_or_name() {
        let cam = |z: f32| Camera {
            eye: Vec3::new(0.0, 0.0, z),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 40.0,
            width: 8,
            height: 8,
        };
        let mut s = Scene {
            camera: Some(cam(1.0)),
            cameras: ["Main", "Side"]
                .iter()
                .zip([1.0, 2.0])
                .map(|(n, z)| NamedCamera {
                    name: (*n).into(),
                    camera: cam(z),
                })
                .collect(),
            ..Default::default()
        };
        s.select_camera("Side").unwrap();
        assert_eq!(s.camera, Some(cam(2.0)));
        s.select_camera("0").unwrap();
        assert_eq!(s.camera, Some(cam(1.0)));
        for bad in ["2", "side", ""] {
            let e = s.select_camera(bad).unwrap_err().to_string();
            assert!(e.contains("0 \"Main\", 1 \"Side\""), "{e}");
            assert!(e.contains(&format!("{bad:?}")), "{e}");
        }
        // A built-in scene's one camera is `0` / `default`; no camera at all is said so.
        let mut b = Scene {
            camera: Some(cam(3.0)),
            ..Default::default()
        };
        b.select_camera("default").unwrap();
        b.select_camera("0").unwrap();
        assert!(
            b.select_camera("1")
                .unwrap_err()
                .to_string()
                .contains("0 \"default\"")
        );
        let e = Scene::default().select_camera("0").unwrap_err().to_string();
        assert!(e.contains("has no cameras"), "{e}");
    }

    #[test]
    fn sanitize_clamps_emission_that_would_overflow() {
        let mut s = Scene::default();
        let m = s.add_material(Material::new([0.5; 3], [3.4e38, 1.0, 0.0]));
        s.push_box(Vec3::ZERO, Vec3::ONE, m);
        let r = s.sanitize("huge").unwrap();
        assert_eq!(r.clamped_materials, 1);
        assert_eq!(s.materials[0].emission, [MAX_EMISSION, 1.0, 0.0]);
        assert!(r.to_string().contains("emission into [0, 1e10]"), "{r}");
    }

    #[test]
    fn box_is_closed_with_the_right_area() {
        let mut s = Scene::default();
        s.push_box(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), 0);
        assert_eq!(s.triangles.len(), 12);
        let area: f32 = s.triangles.iter().map(Triangle::area).sum();
        assert!((area - 2.0 * (2.0 + 3.0 + 6.0)).abs() < 1e-5);
    }
}
