//! Scene files: glTF 2.0 (.gltf/.glb) and OBJ+MTL.

use std::path::Path;

use super::{SanitizeReport, Scene, SceneError};

/// Loads a scene file by extension (.gltf, .glb, .obj) and sanitizes it. Returns the scene and
/// what sanitizing dropped or repaired (print it as a warning when not clean).
pub fn load(path: &Path) -> Result<(Scene, SanitizeReport), SceneError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut scene = match ext.as_deref() {
        Some("gltf" | "glb") => load_gltf(path)?,
        Some("obj") => load_obj(path)?,
        _ => {
            return Err(SceneError::UnsupportedFormat {
                path: path.to_owned(),
            });
        }
    };
    let report = scene.sanitize(&path.display().to_string())?;
    Ok((scene, report))
}

/// Loads a glTF 2.0 file without sanitizing it.
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError::Parse {
        path: path.to_owned(),
        message: "glTF loading is not implemented yet".into(),
    })
}

/// Loads an OBJ file (with its MTL libraries) without sanitizing it.
pub fn load_obj(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError::Parse {
        path: path.to_owned(),
        message: "OBJ loading is not implemented yet".into(),
    })
}
