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
