//! `restir-demo compare` end to end on a tiny scene (GPU: lavapipe in CI): every file is
//! written, the JSON parses and its numbers are finite, the reference against itself has zero
//! error, a method with a planted bias shows a larger error, and an external reference (the
//! first run's, as EXR) gives the same numbers.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn run(out: &Path, methods: &str, extra: &[&str]) {
    let exe = env!("CARGO_BIN_EXE_restir-demo");
    let mut args: Vec<String> = [
        "compare",
        "--scene",
        "cornell",
        "--size",
        "24x20",
        "--frames",
        "4",
        "--reference-spp",
        "64",
        "--methods",
        methods,
        "--no-cache",
        "--quiet",
        "--out",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.push(out.display().to_string());
    args.extend(extra.iter().map(|s| s.to_string()));
    let o = Command::new(exe)
        .args(&args)
        .output()
        .expect("run restir-demo");
    assert!(
        o.status.success(),
        "restir-demo {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn out_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn all_numbers_finite(v: &Value, path: &str) {
    match v {
        Value::Number(n) => {
            let x = n.as_f64().expect("number");
            assert!(x.is_finite(), "{path} = {x}");
        }
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| all_numbers_finite(x, &format!("{path}[{i}]"))),
        Value::Object(o) => o
            .iter()
            .for_each(|(k, x)| all_numbers_finite(x, &format!("{path}.{k}"))),
        _ => {}
    }
}

fn method<'a>(scene: &'a Value, name: &str) -> &'a Value {
    scene["methods"]
        .as_array()
        .expect("methods")
        .iter()
        .find(|m| m["method"] == name)
        .unwrap_or_else(|| panic!("no method {name}"))
}

fn f(v: &Value) -> f64 {
    v.as_f64()
        .unwrap_or_else(|| panic!("expected a number, got {v}"))
}

/// A method's times add up (issue 59: the check asserted only `ms_per_frame > 0`): each frame's
/// GPU time is the sum of its stages', the cumulative time the running sum, and the mean and
/// median per frame are those of the timed (last `timed_frames`) frames.
fn check_times(m: &Value) {
    let frames = m["per_frame"].as_array().expect("per_frame");
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1.0);
    let mut cumulative = 0.0;
    let mut gpu = Vec::new();
    for r in frames {
        let ms = f(&r["gpu_ms"]);
        let stages: f64 = r["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| f(&s["ms"]))
            .sum();
        assert!(
            close(stages, ms),
            "{}: stages {stages} against {ms}",
            m["method"]
        );
        cumulative += ms;
        assert!(
            close(f(&r["cumulative_gpu_ms"]), cumulative),
            "{}",
            m["method"]
        );
        gpu.push(ms);
    }
    let timed = &mut gpu[frames.len() - f(&m["timed_frames"]) as usize..];
    let mean = timed.iter().sum::<f64>() / timed.len() as f64;
    assert!(close(f(&m["ms_per_frame"]), mean), "{}: mean", m["method"]);
    timed.sort_by(f64::total_cmp);
    let n = timed.len();
    let median = if n % 2 == 1 {
        timed[n / 2]
    } else {
        0.5 * (timed[n / 2 - 1] + timed[n / 2])
    };
    assert!(
        close(f(&m["ms_per_frame_median"]), median),
        "{}: median",
        m["method"]
    );
}

fn report(out: &Path) -> Value {
    let text = std::fs::read_to_string(out.join("report.json")).unwrap();
    serde_json::from_str(&text).expect("report.json parses")
}

#[test]
fn compare_end_to_end() {
    let out = out_dir("compare_e2e");
    run(
        &out,
        "nee,ris,ris:16,world-restir",
        &["--plant-bias", "ris:16=1.5"],
    );
    check_files(&out);
    let json = report(&out);
    all_numbers_finite(&json, "report");
    assert!(!json["device"].as_str().unwrap_or("").is_empty());
    let timestamps = json["timestamps"] != false;
    let scene = &json["scenes"][0];
    let self_err = f(&scene["reference"]["self_rel_mse"]["indirect"]);
    assert!(
        self_err > 0.0 && self_err < 1.0,
        "reference relMSE {self_err}"
    );
    let [nee, ris, biased, wr] = ["nee", "ris", "ris:16", "world-restir"].map(|m| method(scene, m));
    assert!(f(&wr["images"]["indirect"]["frame"]["rel_mse"]) > 0.0);
    check_equal_time(&scene["equal_time"]);
    assert_eq!(nee["per_frame"].as_array().unwrap().len(), 4);
    for m in [nee, ris, biased] {
        assert!(!timestamps || f(&m["ms_per_frame"]) > 0.0);
        if timestamps {
            check_times(m);
        }
        for image in ["direct", "indirect", "combined"] {
            let e = &m["images"][image];
            for key in ["frame", "accumulated"] {
                assert!(f(&e[key]["rel_mse"]) > 0.0, "{image} {key}");
            }
            assert!(f(&e["frame_flip"]) > 0.0, "{image}");
        }
    }
    check_planted_bias(ris, biased);
    // Times leave out the warm-up frames; the grid is reported for world-restir only.
    assert_eq!(f(&ris["timed_frames"]), 2.0);
    assert!(!timestamps || f(&ris["ms_per_frame_median"]) > 0.0);
    assert_eq!(f(&wr["max_grid_overflows"]), 0.0);
    assert!(nee["max_grid_overflows"].is_null());
    // Dispatches are counted a frame, world-restir's grid passes and scan beside the path's.
    let dispatches = |m: &Value| f(&m["dispatches_per_frame"]);
    assert!(dispatches(ris) >= 1.0 && dispatches(ris).fract() == 0.0);
    assert!(
        dispatches(wr) > dispatches(ris),
        "world-restir's grid passes uncounted"
    );
    // Accumulating frames lowers the error of an unbiased method.
    let ris_indirect = &ris["images"]["indirect"];
    assert!(f(&ris_indirect["accumulated"]["rel_mse"]) < f(&ris_indirect["frame"]["rel_mse"]));

    // The same run against the first run's reference given as external EXRs: same numbers.
    let out2 = out_dir("compare_e2e_external");
    let r = out.join("reference_cornell.exr");
    let ri = out.join("reference_cornell.indirect.exr");
    run(
        &out2,
        "nee",
        &[
            "--reference",
            r.to_str().unwrap(),
            "--reference-indirect",
            ri.to_str().unwrap(),
        ],
    );
    let json2 = report(&out2);
    let scene2 = &json2["scenes"][0];
    assert_eq!(scene2["reference"]["source"], "external");
    assert_eq!(
        method(scene2, "nee")["images"]["indirect"]["accumulated"],
        nee["images"]["indirect"]["accumulated"],
        "external reference gives other numbers"
    );
}

/// Every output is written; the plot names the methods, report.md has their rows.
fn check_files(out: &Path) {
    for file in [
        "report.md",
        "report.json",
        "error_vs_time.svg",
        "strip.jpg",
        "reference_cornell.exr",
        "reference_cornell.indirect.exr",
    ] {
        let p = out.join(file);
        let len = std::fs::metadata(&p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .len();
        assert!(len > 0, "{file} is empty");
    }
    let svg = std::fs::read_to_string(out.join("error_vs_time.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("nee") && svg.contains("ris"));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| nee |") && md.contains("Equal time"));
}

/// world-restir is the equal-time target; nee and ris are measured against it.
fn check_equal_time(eq: &Value) {
    assert_eq!(eq["target"], "world-restir");
    let entries = eq["entries"].as_array().expect("equal-time entries");
    assert_eq!(
        entries.len(),
        2,
        "nee and ris (the biased copy is left out)"
    );
    for e in entries {
        assert!(e["spp_per_frame"].as_u64().unwrap() >= 1);
        let indirect = &e["images"]["indirect"];
        assert!(f(&indirect["rel_mse_ratio"]) > 0.0);
        assert!(f(&indirect["equal_error_speedup"]) > 0.0);
    }
}

/// Negative control: `biased` is `ris`'s estimator and seed with the indirect image scaled by
/// 1.5; its errors and its bias column see it, its direct column does not.
fn check_planted_bias(ris: &Value, biased: &Value) {
    assert_eq!(f(&biased["planted_bias"]), 1.5);
    let (a, b) = (
        f(&ris["images"]["indirect"]["accumulated"]["rel_mse"]),
        f(&biased["images"]["indirect"]["accumulated"]["rel_mse"]),
    );
    assert!(b > 1.5 * a, "planted bias not seen: {b} vs {a}");
    for c in 0..3 {
        let bias = |m: &Value, image: &str| f(&m["images"][image]["bias"][c]);
        let (r, p) = (bias(ris, "indirect"), bias(biased, "indirect"));
        assert!((p / r - 1.5).abs() < 1e-3, "bias column: {p} vs 1.5 x {r}");
        assert!(r > 0.5 && r < 1.5, "ris bias {r}");
        let (rd, pd) = (bias(ris, "direct"), bias(biased, "direct"));
        assert!(
            (pd / rd - 1.0).abs() < 1e-6,
            "direct bias column: {pd} vs {rd}"
        );
        assert!(rd > 0.5 && rd < 1.5, "ris direct bias {rd}");
    }
}

#[test]
fn compare_moving_camera() {
    let out = out_dir("compare_orbit");
    run(
        &out,
        "nee,world-restir",
        &["--animation", "orbit", "--eval-every", "2"],
    );
    let json = report(&out);
    all_numbers_finite(&json, "report");
    let scene = &json["scenes"][0];
    assert_eq!(scene["camera"], "orbit");
    assert_eq!(
        f(&scene["reference"]["count"]),
        2.0,
        "frames 1 and 3 evaluated"
    );
    for name in ["nee", "world-restir"] {
        let m = method(scene, name);
        let frames = m["per_frame"].as_array().unwrap();
        let evaluated: Vec<u64> = frames
            .iter()
            .filter(|fr| !fr["images"]["indirect"].is_null())
            .map(|fr| fr["frame"].as_u64().unwrap())
            .collect();
        assert_eq!(evaluated, [1, 3], "{name}");
        assert!(
            m["images"]["indirect"]["accumulated"].is_null(),
            "no accumulation for a moving camera"
        );
    }
}
