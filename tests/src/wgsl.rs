//! WGSL checks that need no adapter: naga parse + validate, and Rust/WGSL struct layouts.

use std::path::{Path, PathBuf};

/// Parses and validates `source` with naga (all capabilities, so subgroup shaders pass).
/// The error names the module and carries naga's own diagnostic.
pub fn validate(name: &str, source: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("{name}: parse error:\n{}", e.emit_to_string(source)))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| format!("{name}: validation error:\n{}", e.emit_to_string(source)))?;
    Ok(module)
}

/// Every composed WGSL module of the workspace, as `(name, source)`. Each crate owns its list.
pub fn all_modules() -> Vec<(String, String)> {
    let mut all = Vec::new();
    all.extend(gpu_scan::wgsl_modules());
    all.extend(gpu_hash::wgsl_modules());
    all.extend(reservoir::wgsl_modules());
    all.extend(restir_world::wgsl_modules());
    all.extend(crate::floors::wgsl_modules());
    all
}

/// Every `.wgsl` file under the workspace root (skipping `target/`).
pub fn wgsl_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name();
            if path.is_dir() {
                if name != "target" && !name.to_string_lossy().starts_with('.') {
                    walk(&path, out);
                }
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(&workspace_root(), &mut out);
    out.sort();
    out
}

/// The workspace root (parent of this crate's directory).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests crate sits in the workspace root")
        .to_path_buf()
}

/// Compares a Rust `#[repr(C)]` struct with the WGSL struct of the same shape as naga lays it
/// out: total size and each field's name and offset, in order.
///
/// Use through [`assert_wgsl_layout!`](crate::assert_wgsl_layout), which takes the offsets with `offset_of!`.
pub fn check_layout(
    source: &str,
    wgsl_struct: &str,
    rust_size: usize,
    rust_fields: &[(&str, usize)],
) -> Result<(), String> {
    let module = validate(wgsl_struct, source)?;
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| format!("naga layouter: {e}"))?;
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(wgsl_struct))
        .ok_or_else(|| format!("no WGSL struct named {wgsl_struct}"))?;
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        return Err(format!("{wgsl_struct} is not a struct"));
    };
    let wgsl_size = layouter[handle].size as usize;
    let mut problems = Vec::new();
    if wgsl_size != rust_size {
        problems.push(format!("size: WGSL {wgsl_size}, Rust {rust_size}"));
    }
    let wgsl_fields: Vec<(String, usize)> = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
        .collect();
    let rust: Vec<(String, usize)> = rust_fields
        .iter()
        .map(|(n, o)| ((*n).to_owned(), *o))
        .collect();
    if wgsl_fields != rust {
        problems.push(format!("fields: WGSL {wgsl_fields:?}, Rust {rust:?}"));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{wgsl_struct} layout differs: {}",
            problems.join("; ")
        ))
    }
}

/// `assert_wgsl_layout!(RustType, wgsl_source, "WgslName", [field_a, field_b, ...])` panics
/// unless size and every field offset match what naga computes for the WGSL struct.
#[macro_export]
macro_rules! assert_wgsl_layout {
    ($ty:ty, $source:expr, $wgsl_name:expr, [$($field:ident),* $(,)?]) => {
        if let Err(e) = $crate::wgsl::check_layout(
            &$source,
            $wgsl_name,
            ::std::mem::size_of::<$ty>(),
            &[$((stringify!($field), ::std::mem::offset_of!($ty, $field))),*],
        ) {
            panic!("{e}");
        }
    };
}

/// Asserts that the WGSL struct `$wgsl_name` in `$source` is the knob table `$config`'s GPU
/// words: its `[gpu]` knobs as consecutive 4-byte fields, then `_padN` fields up to `GPU_WORDS`.
#[macro_export]
macro_rules! assert_knobs_layout {
    ($config:ty, $source:expr, $wgsl_name:expr) => {
        let pads: Vec<String> = (<$config>::GPU_KNOBS..<$config>::GPU_WORDS)
            .map(|p| format!("_pad{p}"))
            .collect();
        let fields: Vec<(&str, usize)> = <$config>::GPU_FIELDS
            .iter()
            .copied()
            .chain(pads.iter().map(String::as_str))
            .enumerate()
            .map(|(i, f)| (f, 4 * i))
            .collect();
        if let Err(e) =
            $crate::wgsl::check_layout(&$source, $wgsl_name, 4 * <$config>::GPU_WORDS, &fields)
        {
            panic!("{e}");
        }
    };
}

/// Checks WGSL `ScreenParams` in `source` (a screen-space stage's kernel) against the words
/// `screen_reuse::params_words` uploads for knobs of `knob_words` words.
pub fn assert_screen_params_layout(source: &str, knob_words: usize) {
    let (size, fields) = restir_world::screen_reuse::params_layout(knob_words);
    if let Err(e) = check_layout(source, "ScreenParams", size, &fields) {
        panic!("{e}");
    }
}
