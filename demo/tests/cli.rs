//! The CLI end to end on the CPU reference path (no GPU needed): outputs written, bad input
//! rejected with a message and a non-zero exit.

use std::process::Command;

mod common;
use common::cpu;

fn demo() -> Command {
    Command::new(env!("CARGO_BIN_EXE_restir-demo"))
}

#[test]
fn cpu_reference_render_writes_all_outputs() {
    let out = std::env::temp_dir().join(format!("restir-demo-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = demo()
        .args([
            "render",
            "--scene",
            "furnace-sphere",
            "--method",
            "cpu-reference",
        ])
        .args(["--size", "8x6", "--spp", "2", "--frames", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for kind in ["direct", "indirect", "combined"] {
        for ext in ["exr", "png"] {
            let p = out.join(format!("furnace-sphere-cpu-reference-{kind}.{ext}"));
            assert!(p.exists(), "{} missing", p.display());
        }
    }
    let img =
        restir_world::image_io::read_exr(&out.join("furnace-sphere-cpu-reference-direct.exr"))
            .unwrap();
    assert_eq!((img.width, img.height), (8, 6));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_scene_file_name_with_dots_keeps_its_outputs_apart() {
    let dir = std::env::temp_dir().join(format!("restir-demo-cli-dots-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // A lit quad over a floor; the file name has dots before its extension.
    let obj = dir.join("scan.v2.final.obj");
    std::fs::write(dir.join("m.mtl"), "newmtl lamp\nKd 0 0 0\nKe 5 5 5\n").unwrap();
    std::fs::write(
        &obj,
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nv 0 1 0\nv 1 1 0\nv 1 1 1\n\
         v 0 1 1\nf 1 2 3 4\nusemtl lamp\nf 5 6 7 8\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = demo()
        .args(cpu(obj.to_str().unwrap()))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut files: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "scan.v2.final-cpu-reference-combined.exr",
            "scan.v2.final-cpu-reference-combined.png",
            "scan.v2.final-cpu-reference-direct.exr",
            "scan.v2.final-cpu-reference-direct.png",
            "scan.v2.final-cpu-reference-indirect.exr",
            "scan.v2.final-cpu-reference-indirect.png",
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_input_fails_with_a_clear_message() {
    let cases: [(&[&str], &str); 6] = [
        (
            &["render", "--scene", "kitchen"],
            "neither a built-in scene",
        ),
        (
            &["render", "--scene", "/nonexistent/x.obj"],
            "/nonexistent/x.obj",
        ),
        (
            &["render", "--scene", "x.ply", "--method", "cpu-reference"],
            "x.ply",
        ),
        (&["render", "--size", "0x4"], "size"),
        (&["render", "--eye", "1,2"], "x,y,z"),
        (
            &[
                "render",
                "--scene",
                "furnace",
                "--up",
                "0,0,1",
                "--method",
                "cpu-reference",
            ],
            "parallel",
        ),
    ];
    for (args, needle) in cases {
        let o = demo().args(args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

/// `render`'s PNGs are exposed as compare's images by default (the combined image's
/// 99th-percentile luminance to 1), so a bright scene is not white (issue 38: Sponza under a
/// sky came out white at the old default exposure 1); `--exposure 1` is the old image, whose
/// saturation shows the scene is bright enough for the check to fail.
#[test]
fn render_pngs_are_exposed_for_the_image() {
    let out = std::env::temp_dir().join(format!("restir-demo-cli-exp-{}", std::process::id()));
    let saturated = |exposure: &[&str]| {
        let _ = std::fs::remove_dir_all(&out);
        let o = demo()
            .args(["render", "--scene", "furnace", "--le", "4", "--method"])
            .args([
                "cpu-reference",
                "--size",
                "8x8",
                "--spp",
                "1",
                "--frames",
                "1",
            ])
            .args(exposure)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        let png = image::open(out.join("furnace-cpu-reference-combined.png"))
            .unwrap()
            .to_rgb8();
        let full = png.as_raw().iter().filter(|&&b| b == 255).count();
        (full as f64 / png.as_raw().len() as f64, stdout)
    };
    let (auto, stdout) = saturated(&[]);
    assert!(stdout.contains("PNG exposure"), "{stdout}");
    assert!(
        auto < 0.05,
        "{:.0}% of the default PNG saturated",
        auto * 100.0
    );
    let (one, _) = saturated(&["--exposure", "1"]);
    assert!(one > 0.9, "exposure 1 saturates only {:.0}%", one * 100.0);
    std::fs::remove_dir_all(&out).unwrap();
}
