//! Layer 1 and 2 of the testing plan: every WGSL module parses and validates with naga, and
//! every `.wgsl` file in the workspace is part of some validated module. No adapter needed.

use tests::wgsl;

#[test]
fn every_wgsl_module_validates() {
    let modules = wgsl::all_modules();
    assert!(!modules.is_empty(), "no WGSL modules registered");
    let failures: Vec<String> = modules
        .iter()
        .filter_map(|(name, src)| wgsl::validate(name, src).err())
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn every_wgsl_file_is_validated_as_part_of_a_module() {
    let modules = wgsl::all_modules();
    let files = wgsl::wgsl_files();
    assert!(
        !files.is_empty(),
        "found no .wgsl files under {:?}",
        wgsl::workspace_root()
    );
    let orphans: Vec<String> = files
        .iter()
        .filter(|path| {
            let text = std::fs::read_to_string(path).expect("readable .wgsl file");
            // The composer moves `enable` directives to the top of a module.
            let body: Vec<&str> = text
                .lines()
                .filter(|l| !l.trim_start().starts_with("enable "))
                .collect();
            let body = body.join("\n");
            !modules.iter().any(|(_, src)| src.contains(body.trim()))
        })
        .map(|p| p.display().to_string())
        .collect();
    assert!(
        orphans.is_empty(),
        "these .wgsl files are in no registered module (add them to their crate's \
         `wgsl_modules()`): {orphans:?}"
    );
}

#[test]
fn validation_rejects_a_broken_shader() {
    // Negative control: the check above must be able to fail.
    let (name, src) = &wgsl::all_modules()[0];
    let broken = src.replacen(';', "", 1);
    assert!(wgsl::validate(name, &broken).is_err());
    let bad_type = "fn f() -> u32 { return 1.5; }";
    assert!(wgsl::validate("bad_type", bad_type).is_err());
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Sample {
    a: u32,
    _pad0: [u32; 3],
    b: [f32; 4],
    c: f32,
    _pad1: u32,
    d: [f32; 2],
}

// vec4 aligns to 16 and vec2 to 8: naga puts b at 16, c at 32, d at 40, size 48.
const SAMPLE_WGSL: &str = "struct Sample { a: u32, b: vec4<f32>, c: f32, d: vec2<f32> }
@group(0) @binding(0) var<storage, read_write> s: array<Sample>;";

#[test]
fn layout_check_accepts_matching_struct() {
    tests::assert_wgsl_layout!(Sample, SAMPLE_WGSL, "Sample", [a, b, c, d]);
}

#[test]
fn layout_check_rejects_mismatches() {
    // A Rust struct that forgets the 16-byte alignment of vec4 must be caught.
    let err = tests::wgsl::check_layout(
        SAMPLE_WGSL,
        "Sample",
        32,
        &[("a", 0), ("b", 4), ("c", 20), ("d", 24)],
    )
    .unwrap_err();
    assert!(err.contains("size") && err.contains("fields"), "{err}");
    // A field the WGSL struct lacks is caught too.
    let extra = "struct Sample { a: u32, b: vec4<f32>, c: f32, d: vec2<f32>, e: u32 }";
    assert!(
        tests::wgsl::check_layout(
            extra,
            "Sample",
            48,
            &[("a", 0), ("b", 16), ("c", 32), ("d", 40)]
        )
        .is_err()
    );
    assert!(tests::wgsl::check_layout(SAMPLE_WGSL, "Missing", 4, &[]).is_err());
}
