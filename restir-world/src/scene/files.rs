//! The one way scene inputs are opened: scene files (OBJ, MTL, glTF, GLB), glTF buffers and
//! images, environment maps. Each is a regular file (a device such as /dev/zero, a pipe or a
//! directory is refused before it is opened: opening a pipe blocks until a writer comes), no
//! larger than a cap given by its kind, and read through a bound (a file that grows while it is
//! read is cut off and refused). Files a glTF names ([`confined`]) must stay in the scene
//! file's directory, links resolved.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use super::SceneError;

/// Largest file (OBJ, MTL, glTF, GLB, glTF buffer, environment map) the loaders read.
pub const MAX_SCENE_FILE_BYTES: u64 = 1 << 30;

/// Largest texture image file (PNG, JPEG) the glTF loader reads.
pub const MAX_TEXTURE_FILE_BYTES: u64 = 256 << 20;

fn parse_err(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::Parse {
        path: path.to_owned(),
        message: message.into(),
    }
}

/// Opens a regular file of at most `cap` bytes; the handle reads at most `cap + 1` bytes.
pub fn open_regular(path: &Path, cap: u64) -> Result<std::io::Take<std::fs::File>, SceneError> {
    let io = |source| SceneError::Io {
        path: path.to_owned(),
        source,
    };
    // Before opening: opening a FIFO for reading would block.
    let meta = std::fs::metadata(path).map_err(io)?;
    let check = |meta: &std::fs::Metadata| {
        if !meta.is_file() {
            return Err(parse_err(
                path,
                "not a regular file (a directory, device or pipe): refusing to read it",
            ));
        }
        if meta.len() > cap {
            return Err(too_big(path, meta.len(), cap));
        }
        Ok(())
    };
    check(&meta)?;
    let file = std::fs::File::open(path).map_err(io)?;
    // And the file opened (a swap in between).
    check(&file.metadata().map_err(io)?)?;
    Ok(file.take(cap + 1))
}

fn too_big(path: &Path, n: u64, cap: u64) -> SceneError {
    parse_err(
        path,
        format!("is {n} bytes or more, above the limit of {cap} bytes"),
    )
}

/// Reads a whole regular file of at most `cap` bytes ([`open_regular`]).
pub fn read_capped(path: &Path, cap: u64) -> Result<Vec<u8>, SceneError> {
    let mut bytes = Vec::new();
    open_regular(path, cap)?
        .read_to_end(&mut bytes)
        .map_err(|source| SceneError::Io {
            path: path.to_owned(),
            source,
        })?;
    if bytes.len() as u64 > cap {
        return Err(too_big(path, bytes.len() as u64, cap));
    }
    Ok(bytes)
}

/// The file a glTF uri names, confined to the scene file's directory `dir`: no scheme, no
/// absolute path, no `..`, and (when `resolve`) no link that leads outside (`resolve` needs the
/// file to exist).
pub fn confined(path: &Path, dir: &Path, uri: &str, resolve: bool) -> Result<PathBuf, SceneError> {
    let bad = |why: &str| {
        parse_err(
            path,
            format!(
                "glTF: uri {uri:?} {why}; uris must name files in the scene file's directory \
                 or below"
            ),
        )
    };
    if uri.contains(':') || uri.starts_with(['/', '\\']) {
        return Err(bad("is absolute or has a scheme"));
    }
    let rel = Path::new(uri);
    if rel
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(bad("leaves the scene file's directory"));
    }
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let file = dir.join(rel);
    if resolve {
        let canon = |p: &Path| {
            p.canonicalize().map_err(|e| {
                parse_err(
                    path,
                    format!("glTF: uri {uri:?}: cannot open {}: {e}", p.display()),
                )
            })
        };
        let resolved = canon(&file)?;
        if !resolved.starts_with(canon(dir)?) {
            return Err(bad(
                "leads (through a link) outside the scene file's directory",
            ));
        }
        return Ok(resolved);
    }
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gltf_uris_stay_in_the_scene_directory() {
        let p = Path::new("d/s.gltf");
        let dir = Path::new("d");
        assert_eq!(
            confined(p, dir, "sub/b.bin", false).unwrap(),
            Path::new("d/sub/b.bin")
        );
        for bad in [
            "/dev/zero",
            "../../etc/passwd",
            "a/../../b",
            "file:///etc/passwd",
            "C:\\x",
        ] {
            assert!(confined(p, dir, bad, false).is_err(), "{bad}");
        }
    }

    #[test]
    fn devices_and_large_files_are_refused() {
        let e = read_capped(Path::new("/dev/zero"), 10).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
        let d = std::env::temp_dir().join(format!("restir-files-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("eleven");
        std::fs::write(&f, [0u8; 11]).unwrap();
        let e = read_capped(&f, 10).unwrap_err();
        assert!(e.to_string().contains("above the limit of 10 bytes"), "{e}");
        assert_eq!(read_capped(&f, 11).unwrap().len(), 11);
        std::fs::remove_dir_all(&d).ok();
    }
}
