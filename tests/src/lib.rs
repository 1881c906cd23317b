//! # tests
//!
//! The shared test harness of the workspace, plus (under `tests/` and `benches/`) every GPU
//! test, the cross-crate integration tests and the per-primitive microbenchmarks.
//!
//! - [`wgsl`]: naga parsing/validation of every WGSL module and Rust/WGSL layout checks
//!   (no adapter needed).
//! - [`gpu`]: the one shared [`GpuContext`] for a test binary; tests fail loudly when there is no
//!   adapter and skip, with a printed reason, only for missing optional features.
//! - [`bias`]: bias and equivalence checks with negative controls that can fail.
//! - [`scenes`](mod@scenes): small scenes the GPU tests share; [`cpu`]: the CPU reference as
//!   tests call it.
//! - [`reference`](mod@reference): converged references rendered once per key (the renderer's
//!   source and the settings) and kept on disk for later binaries and runs.
//! - [`floors`]: same-harness floor kernels (vec4 copy) that benchmarks compare against.
//! - [`bench`](mod@bench): GPU-timestamp timing for criterion's `iter_custom` and the `RESULT` line.
//!
//! Buffer upload and readback live in [`restir_world::gpu::buffers`] (re-exported as
//! [`buffers`]).

pub mod bench;
pub mod bias;
pub mod cpu;
pub mod floors;
pub mod gpu;
pub mod reference;
pub mod scenes;
pub mod wgsl;

pub use restir_world::GpuContext;
pub use restir_world::gpu::buffers;

/// Says that a check did not run, and why: on stderr (shown with `--nocapture` or a failure)
/// and as a line of the file `$RESTIR_TEST_SKIPS` names, which `cargo xtask test` sets and
/// counts in its summary, so that a skip is never silent (the demo's tests use it too).
pub fn skip(why: &str) {
    eprintln!("skipped: {why}");
    if let Some(path) = std::env::var_os(SKIPS_ENV) {
        use std::io::Write;
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path);
        if let Ok(mut f) = file {
            // One write per line: parallel tests' lines stay whole.
            // libtest names each test's thread after the test.
            let test = std::thread::current().name().unwrap_or("?").to_owned();
            let _ = f.write_all(format!("{test}: {why}\n").as_bytes());
        }
    }
}

/// The environment variable naming the file [`skip`] appends to.
pub const SKIPS_ENV: &str = "RESTIR_TEST_SKIPS";

/// The public test scenes (`$RESTIR_SCENES_DIR`, else `shared/scenes` next to the workspace),
/// or `None` with the reason said ([`skip`]): tests that use them then pass without them.
pub fn scenes_dir() -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("RESTIR_SCENES_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| wgsl::workspace_root().join("../shared/scenes"));
    if dir.is_dir() {
        Some(dir)
    } else {
        skip(&format!(
            "the public scenes are not at {} (set RESTIR_SCENES_DIR)",
            dir.display()
        ));
        None
    }
}
