//! What the CLI tests share.

/// `restir-demo render` of `scene` by the CPU reference at 4x4, one frame, one thread: no GPU
/// needed.
pub fn cpu(scene: &str) -> Vec<String> {
    [
        "render",
        "--scene",
        scene,
        "--method",
        "cpu-reference",
        "--size",
        "4x4",
        "--frames",
        "1",
        "--threads",
        "1",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// Says that a case did not run, and why: on stderr and as a line of the file
/// `$RESTIR_TEST_SKIPS` names (`cargo xtask test` counts them; the `tests` crate's `skip`).
#[allow(dead_code)] // not every binary that shares this module skips
pub fn skip(why: &str) {
    eprintln!("skipped: {why}");
    if let Some(path) = std::env::var_os("RESTIR_TEST_SKIPS") {
        use std::io::Write;
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path);
        if let Ok(mut f) = file {
            // libtest names each test's thread after the test.
            let test = std::thread::current().name().unwrap_or("?").to_owned();
            let _ = f.write_all(format!("{test}: {why}\n").as_bytes());
        }
    }
}
