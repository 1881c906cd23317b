//! Scene files: glTF 2.0 (.gltf/.glb, via the `gltf` crate) and OBJ+MTL (via `tobj`).
//!
//! glTF: meshes (triangle primitives) under the default scene's node hierarchy with their
//! transforms, the first perspective camera met, baseColorFactor as albedo, emissiveFactor x
//! KHR_materials_emissive_strength as emission. Buffers: the GLB binary chunk, base64 data
//! URIs and files relative to the .gltf. OBJ: Kd as albedo, Ke as emission, polygons
//! triangulated. Textures are not modelled: their factors are used and [`Loaded::warnings`]
//! says so once per file.

use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec3};

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
    let report = scene.sanitize(&path.display().to_string())?;
    Ok(Loaded {
        scene,
        report,
        warnings,
    })
}

fn parse_err(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Parse {
        path: path.to_owned(),
        message: message.into(),
    }
}

fn read(path: &Path) -> Result<Vec<u8>, SceneError> {
    std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_owned(),
        source,
    })
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

/// Loads a glTF 2.0 file (.gltf or .glb) without sanitizing it.
pub fn load_gltf(path: &Path, warnings: &mut Vec<String>) -> Result<Scene, SceneError> {
    let bytes = read(path)?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| parse_err(path, format!("glTF: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("."));
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
                    let file: PathBuf = dir.join(uri);
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

    let mut scene = Scene::default();
    let mut material_of = std::collections::HashMap::new();
    let mut textured = 0usize;
    let scene_def = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or_else(|| parse_err(path, "glTF: no scene"))?;
    let mut stack: Vec<(gltf::Node, Mat4, u32)> =
        scene_def.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(parse_err(
                path,
                "glTF: node hierarchy deeper than 256 (a cycle?)",
            ));
        }
        let m = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        for child in node.children() {
            stack.push((child, m, depth + 1));
        }
        if let Some(cam) = node.camera()
            && scene.camera.is_none()
            && let gltf::camera::Projection::Perspective(p) = cam.projection()
        {
            let eye = m.transform_point3(Vec3::ZERO);
            let fwd = m.transform_vector3(-Vec3::Z);
            let up = m.transform_vector3(Vec3::Y);
            let aspect = p.aspect_ratio().filter(|a| *a > 0.0).unwrap_or(1.0);
            scene.camera = Some(Camera {
                eye,
                target: eye + fwd,
                up,
                vfov_deg: p.yfov().to_degrees(),
                width: (256.0 * aspect).round().clamp(1.0, 16384.0) as u32,
                height: 256,
            });
        }
        let Some(mesh) = node.mesh() else { continue };
        let normal_m = Mat3::from_mat4(m).inverse().transpose();
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                warnings.push(format!(
                    "{}: mesh {} has a {:?} primitive: skipped (only triangles are supported)",
                    path.display(),
                    mesh.index(),
                    prim.mode()
                ));
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| {
                    parse_err(
                        path,
                        format!("glTF: mesh {} has no readable POSITION data", mesh.index()),
                    )
                })?
                .map(|p| m.transform_point3(Vec3::from(p)))
                .collect();
            let normals: Option<Vec<Vec3>> = reader.read_normals().map(|it| {
                it.map(|n| (normal_m * Vec3::from(n)).normalize_or_zero())
                    .collect()
            });
            let indices: Vec<u32> = match reader.read_indices() {
                Some(it) => it.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(i) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(parse_err(
                    path,
                    format!(
                        "glTF: mesh {} index {i} is out of range ({} vertices)",
                        mesh.index(),
                        positions.len()
                    ),
                ));
            }
            let normals = normals.filter(|n| n.len() == positions.len());
            let mat = prim.material();
            let key = mat.index();
            let material = match material_of.get(&key) {
                Some(&id) => id,
                None => {
                    let pbr = mat.pbr_metallic_roughness();
                    if pbr.base_color_texture().is_some() || mat.emissive_texture().is_some() {
                        textured += 1;
                    }
                    let base = pbr.base_color_factor();
                    let strength = mat.emissive_strength().unwrap_or(1.0);
                    let e = mat.emissive_factor().map(|x| x * strength);
                    let albedo = if key.is_none() {
                        DEFAULT_ALBEDO
                    } else {
                        [base[0], base[1], base[2]]
                    };
                    let id = scene.add_material(Material::new(albedo, e));
                    material_of.insert(key, id);
                    id
                }
            };
            for tri in indices.chunks_exact(3) {
                let idx = [tri[0], tri[1], tri[2]].map(|i| i as usize);
                scene.triangles.push(Triangle {
                    v: idx.map(|i| positions[i]),
                    n: normals.as_ref().map(|n| idx.map(|i| n[i])),
                    material,
                });
            }
        }
    }
    if textured > 0 {
        warnings.push(format!(
            "{}: {textured} materials have textures, which are not modelled: their factors are used",
            path.display()
        ));
    }
    Ok(scene)
}

/// Loads an OBJ file (with its MTL libraries, relative to the file) without sanitizing it.
pub fn load_obj(path: &Path, warnings: &mut Vec<String>) -> Result<Scene, SceneError> {
    let bytes = read(path)?;
    let dir = path.parent().unwrap_or(Path::new(".")).to_owned();
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, materials) = tobj::load_obj_buf(&mut bytes.as_slice(), &opts, |mtl| {
        tobj::load_mtl(dir.join(mtl))
    })
    .map_err(|e| parse_err(path, format!("OBJ: {e}")))?;
    let materials = materials.unwrap_or_else(|e| {
        warnings.push(format!(
            "{}: material library: {e}; using grey {DEFAULT_ALBEDO:?}",
            path.display()
        ));
        Vec::new()
    });
    let mut scene = Scene::default();
    let mut textured = 0usize;
    for m in &materials {
        if m.diffuse_texture.is_some() || m.unknown_param.contains_key("map_Ke") {
            textured += 1;
        }
        let ke = match m.emissive {
            Some(e) => e,
            None => match m.unknown_param.get("Ke") {
                Some(s) => {
                    let v: Vec<f32> = s
                        .split_whitespace()
                        .map(str::parse)
                        .collect::<Result<_, _>>()
                        .map_err(|_| {
                            parse_err(path, format!("MTL: material {:?}: bad Ke {s:?}", m.name))
                        })?;
                    match v[..] {
                        [r, g, b] => [r, g, b],
                        [x] => [x; 3],
                        _ => {
                            return Err(parse_err(
                                path,
                                format!("MTL: material {:?}: bad Ke {s:?}", m.name),
                            ));
                        }
                    }
                }
                None => [0.0; 3],
            },
        };
        scene.add_material(Material::new(m.diffuse.unwrap_or(DEFAULT_ALBEDO), ke));
    }
    let default = scene.add_material(Material::new(DEFAULT_ALBEDO, [0.0; 3]));
    for model in &models {
        let mesh = &model.mesh;
        let material = mesh
            .material_id
            .filter(|&i| i < materials.len())
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
                material,
            });
        }
    }
    if textured > 0 {
        warnings.push(format!(
            "{}: {textured} materials have textures, which are not modelled: their factors are used",
            path.display()
        ));
    }
    Ok(scene)
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
}
