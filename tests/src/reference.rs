//! Converged references, rendered once per key and kept on disk for every later test binary and
//! run.
//!
//! A reference is a list of numbers (a channel mean, an image) that a test renders with a
//! baseline estimator at many frames. Its key is the test's own description of it (scene, size,
//! estimator, seed, frames, paths) hashed with the source of the renderer: every `.rs` and
//! `.wgsl` file of `restir-world`, `reservoir`, `gpu-hash` and `gpu-scan`, so any change of the
//! code that renders it renders it again. Entries live in the user's cache directory
//! (`$XDG_CACHE_HOME` or `~/.cache`, then `restir-world/test-references/`; or
//! `$RESTIR_TEST_REFERENCES`), so that every checkout, clean clones and CI on the same machine
//! included, renders a reference once; they are written whole (a temporary file renamed into
//! place) and checked when read (key, count, finite values); a damaged entry is rendered
//! again. Within a test binary, tests that need the same reference wait for one render.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

use restir_world::gpu_reference::Fnv64;

/// The directory of the cached references.
pub fn dir() -> PathBuf {
    let var = |v: &str| {
        std::env::var_os(v)
            .filter(|x| !x.is_empty())
            .map(PathBuf::from)
    };
    if let Some(d) = var("RESTIR_TEST_REFERENCES") {
        return d;
    }
    let cache = var("XDG_CACHE_HOME").or_else(|| var("HOME").map(|h| h.join(".cache")));
    match cache {
        Some(c) => c.join("restir-world/test-references"),
        None => crate::wgsl::workspace_root().join("target/test-references"),
    }
}

/// A hash of the renderer's source (the crates it is made of), computed once.
fn source_hash() -> u64 {
    static HASH: OnceLock<u64> = OnceLock::new();
    *HASH.get_or_init(|| {
        let root = crate::wgsl::workspace_root();
        let mut files = Vec::new();
        for krate in ["restir-world", "reservoir", "gpu-hash", "gpu-scan"] {
            collect_sources(&root.join(krate).join("src"), &mut files);
        }
        files.sort();
        let mut h = Fnv64::default();
        for f in files {
            // The path within the workspace: clones elsewhere share the key.
            let name = f.strip_prefix(&root).unwrap_or(&f);
            h.bytes(name.to_string_lossy().as_bytes());
            h.bytes(&std::fs::read(&f).unwrap_or_default());
        }
        h.finish()
    })
}

fn collect_sources(dir: &std::path::Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect_sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs" || x == "wgsl") {
            out.push(p);
        }
    }
}

/// The file of `key`.
fn path_of(key: &str) -> PathBuf {
    let mut h = Fnv64::default();
    h.bytes(key.as_bytes()).bytes(&source_hash().to_le_bytes());
    dir().join(format!("{:016x}.txt", h.finish()))
}

/// `len` finite numbers from `path`, or `None` (absent, damaged or of another length).
fn read(path: &std::path::Path, key: &str, len: usize) -> Option<Vec<f64>> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines();
    if lines.next()? != key {
        return None;
    }
    let values: Vec<f64> = lines
        .map(|l| l.parse::<f64>())
        .collect::<Result<_, _>>()
        .ok()?;
    (values.len() == len && values.iter().all(|v| v.is_finite())).then_some(values)
}

/// Writes `values` under `key`, whole or not at all (a failure only costs a later render).
fn write(path: &std::path::Path, key: &str, values: &[f64]) {
    let Some(parent) = path.parent() else { return };
    if std::fs::create_dir_all(parent).is_err() {
        return;
    }
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    let mut text = format!("{key}\n");
    for v in values {
        text += &format!("{v:e}\n");
    }
    if std::fs::write(&tmp, text).is_ok() && std::fs::rename(&tmp, path).is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
}

/// The `len` numbers of the reference `key`: from the cache, else from `render` (then
/// cached). `key` must name everything the numbers depend on besides the renderer's source.
pub fn cached(key: &str, len: usize, render: impl FnOnce() -> Vec<f64>) -> Vec<f64> {
    // One lock per key: tests of one binary needing the same reference wait for one render.
    static LOCKS: Mutex<Option<HashMap<String, std::sync::Arc<Mutex<()>>>>> = Mutex::new(None);
    let lock = {
        let mut locks = LOCKS.lock().unwrap_or_else(|e| e.into_inner());
        locks
            .get_or_insert_with(HashMap::new)
            .entry(key.to_owned())
            .or_default()
            .clone()
    };
    let _held = lock.lock().unwrap_or_else(|e| e.into_inner());
    let path = path_of(key);
    if let Some(v) = read(&path, key, len) {
        return v;
    }
    let values = render();
    assert_eq!(
        values.len(),
        len,
        "reference {key}: rendered {} values",
        values.len()
    );
    write(&path, key, &values);
    values
}

/// [`cached`] for three channel means.
pub fn cached_means(key: &str, render: impl FnOnce() -> [f64; 3]) -> [f64; 3] {
    let v = cached(key, 3, || render().to_vec());
    [v[0], v[1], v[2]]
}

/// [`cached`] for an RGB image of `pixels` pixels.
pub fn cached_image(
    key: &str,
    pixels: usize,
    render: impl FnOnce() -> Vec<[f32; 3]>,
) -> Vec<[f32; 3]> {
    let v = cached(key, pixels * 3, || {
        render().iter().flat_map(|p| p.map(f64::from)).collect()
    });
    v.chunks_exact(3)
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_damage() {
        let d = std::env::temp_dir().join(format!("refs-{}", std::process::id()));
        let p = d.join("x.txt");
        write(&p, "k", &[1.5, -2.0, 3e-9]);
        assert_eq!(read(&p, "k", 3), Some(vec![1.5, -2.0, 3e-9]));
        assert_eq!(read(&p, "other key", 3), None);
        assert_eq!(read(&p, "k", 4), None);
        std::fs::write(&p, "k\n1\nNaN\n3\n").unwrap();
        assert_eq!(read(&p, "k", 3), None);
        let _ = std::fs::remove_dir_all(d);
    }
}
