//! Issue 14 (hardening): bad input is refused before any expensive work with a message that
//! names its cause, never a panic, an unbounded read or a silently wrong image; a failed run
//! leaves no output behind.
//!
//! One table: each case gives the `restir-demo` arguments, the expected exit code and a
//! substring of stderr. The corpus is `tests/bad_inputs/` (tiny text files) plus what this
//! test generates into its temporary directory (links to /dev/zero, binary garbage, EXR
//! references). Every image is a few pixels, so the whole table runs in seconds.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use restir_world::image_io::{Image, read_exr, write_exr};

/// Longest a case may run: every case is a few pixels, refused before any real work.
const CASE_TIMEOUT: Duration = Duration::from_secs(60);

fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_restir-demo")
}

fn corpus(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/bad_inputs")
        .join(name)
        .display()
        .to_string()
}

/// One row of the table.
struct Case {
    name: &'static str,
    args: Vec<String>,
    env: Vec<(&'static str, &'static str)>,
    /// Expected exit status (0: success, with a warning on stderr).
    code: i32,
    /// A substring of stderr.
    needle: String,
}

fn case(name: &'static str, args: &[&str], code: i32, needle: &str) -> Case {
    Case {
        name,
        args: args.iter().map(|s| s.to_string()).collect(),
        env: Vec::new(),
        code,
        needle: needle.to_owned(),
    }
}

impl Case {
    fn env(mut self, key: &'static str, value: &'static str) -> Self {
        self.env.push((key, value));
        self
    }
}

/// The CPU reference at 4x4, one frame: no GPU needed.
fn cpu(scene: &str) -> Vec<String> {
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

fn compare(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = [
        "compare",
        "--scene",
        "cornell",
        "--size",
        "4x4",
        "--frames",
        "1",
        "--reference-spp",
        "2",
        "--methods",
        "nee",
        "--no-cache",
        "--quiet",
        "--no-exr",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    // Later flags override earlier ones for single-valued options; --methods and --scene
    // are replaced rather than appended.
    for pair in extra.chunks(2) {
        if let Some(i) = v.iter().position(|a| a == pair[0])
            && pair.len() == 2
            && (pair[0] == "--methods" || pair[0] == "--scene" || pair[0] == "--reference-spp")
        {
            v[i + 1] = pair[1].to_owned();
        } else {
            v.extend(pair.iter().map(|s| s.to_string()));
        }
    }
    v
}

/// `args` with the reference cache in `cache` instead of `--no-cache`.
fn with_cache(mut args: Vec<String>, cache: &Path) -> Vec<String> {
    args.retain(|a| a != "--no-cache");
    args.push("--cache".into());
    args.push(cache.display().to_string());
    args
}

/// Files no committed text can be: written into `dir`.
fn generate(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let zero = dir.join("zero.obj");
    let _ = std::fs::remove_file(&zero);
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    std::fs::write(
        dir.join("binary.obj"),
        [0x76u8, 0x20, 0xff, 0xfe, 0x00, 0x80],
    )
    .unwrap();
    // A glTF next to a link to /dev/zero, its buffer named relatively.
    let _ = std::fs::remove_file(dir.join("zero.bin"));
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
    let gltf = std::fs::read_to_string(corpus("buffer_dev_zero.gltf")).unwrap();
    std::fs::write(
        dir.join("linked_zero.gltf"),
        gltf.replace("\"/dev/zero\"", "\"zero.bin\""),
    )
    .unwrap();
    let exr = |name: &str, v: f32| {
        let img = Image::from_pixels(4, 4, vec![[v, 0.5, 0.5]; 16]).unwrap();
        write_exr(&dir.join(name), &img).unwrap();
    };
    exr("nan.exr", f32::NAN);
    exr("inf.exr", f32::INFINITY);
    exr("negative.exr", -1.0);
    write_exr(&dir.join("zeros.exr"), &Image::new(4, 4)).unwrap();
    image::RgbImage::new(4, 4)
        .save_with_format(dir.join("srgb.png"), image::ImageFormat::Png)
        .unwrap();
    std::fs::copy(dir.join("srgb.png"), dir.join("png_named.exr")).unwrap();
    // A Radiance HDR header claiming a 100000 x 2 map, without pixels.
    std::fs::write(
        dir.join("huge.hdr"),
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 100000\n",
    )
    .unwrap();
    dir.to_owned()
}

/// `restir-demo info` (with `env`): its stdout, or None when it fails (no such adapter).
fn info(env: &[(&str, &str)]) -> Option<String> {
    let mut c = Command::new(exe());
    c.arg("info");
    for (k, v) in env {
        c.env(k, v);
    }
    let o = c.output().ok()?;
    o.status
        .success()
        .then(|| String::from_utf8_lossy(&o.stdout).into_owned())
}

fn limit(info: &str, name: &str) -> Option<u64> {
    let key = format!("{name}=");
    let at = info.find(&key)? + key.len();
    info[at..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

/// Every file under `dir` (recursively).
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(files_under(&p));
            } else {
                out.push(p);
            }
        }
    }
    out
}

#[test]
fn bad_inputs_are_refused_with_their_cause_and_leave_nothing_behind() {
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_inputs");
    let _ = std::fs::remove_dir_all(&tmp);
    let gen_dir = generate(&tmp.join("generated"));
    let g = |name: &str| gen_dir.join(name).display().to_string();

    let mut cases = vec![
        // 15: checks before expensive work.
        Case {
            args: [
                cpu("cornell"),
                vec!["--out".into(), "/proc/restir-demo-x/y".into()],
            ]
            .concat(),
            ..case(
                "out-dir-unwritable",
                &[],
                1,
                "cannot create the output directory /proc/restir-demo-x/y",
            )
        },
        // With the reference cache inside the case's output: a reference rendered before the
        // error is found would be left behind there.
        Case {
            args: with_cache(
                compare(&["--methods", "nee,ris:0"]),
                &tmp.join("out/compare-bad-variant/cache"),
            ),
            ..case("compare-bad-variant", &[], 1, "ris:0")
        },
        Case {
            args: with_cache(
                compare(&["--scene", "cornell,doesnotexist"]),
                &tmp.join("out/compare-missing-second-scene/cache"),
            ),
            ..case("compare-missing-second-scene", &[], 1, "\"doesnotexist\"")
        },
        // 10: compare options that silently did something else.
        Case {
            args: compare(&["--methods", "nee,ris", "--equal-time-to", "world-restir"]),
            ..case(
                "equal-time-to-unlisted",
                &[],
                1,
                "--equal-time-to names \"world-restir\", which is not in --methods",
            )
        },
        Case {
            args: compare(&["--reference-spp", "0"]),
            ..case(
                "reference-spp-0",
                &[],
                1,
                "--reference-spp must be at least 2",
            )
        },
        Case {
            args: compare(&["--methods", "nee,nee"]),
            ..case("methods-twice", &[], 1, "--methods lists \"nee\" twice")
        },
        // 7: candidate counts the GPU would silently cap.
        case(
            "candidates-above-cap",
            &["render", "--method", "ris", "--candidates", "65536"],
            2,
            "65536 is not in 1..=65535",
        ),
        case(
            "candidates-zero",
            &["render", "--method", "cpu-reference", "--candidates", "0"],
            2,
            "0 is not in 1..=65535",
        ),
        case(
            "candidates-with-a-gpu-method",
            &["render", "--method", "ris", "--candidates", "4"],
            1,
            "--method ris:K",
        ),
        case(
            "unknown-tracer",
            &["render", "--tracer", "optix"],
            2,
            "unknown tracer \"optix\"; known: auto, bvh, ray-query",
        ),
        Case {
            args: compare(&["--methods", "ris:70000"]),
            ..case("compare-ris-above-cap", &[], 1, "must be in 1..=65535")
        },
        Case {
            args: compare(&["--methods", "world-restir:candidates=70000"]),
            ..case(
                "compare-world-restir-above-cap",
                &[],
                1,
                "must be in 1..=65535",
            )
        },
        // 13: cameras that rendered black or static.
        Case {
            args: [
                cpu("cornell"),
                vec![
                    "--eye".into(),
                    "0,1,3e38".into(),
                    "--target".into(),
                    "0,1,-3e38".into(),
                ],
            ]
            .concat(),
            ..case("eye-target-overflow", &[], 1, "too far apart")
        },
        // 14: a long dolly used to reach the target at frame 100 and fail there.
        case(
            "long-dolly",
            &[
                "compare",
                "--scene",
                "cornell",
                "--methods",
                "nee",
                "--animation",
                "dolly",
                "--frames",
                "150",
                "--eval-every",
                "75",
                "--reference-spp",
                "2",
                "--size",
                "4x4",
            ],
            0,
            "",
        ),
        case(
            "orbit-zero-frames",
            &[
                "render",
                "--method",
                "world-restir",
                "--animation",
                "orbit",
                "--anim-frames",
                "0",
                "--size",
                "4x4",
                "--frames",
                "1",
            ],
            1,
            "--anim-frames must be at least 1",
        ),
        // 16: messages that name their cause.
        case(
            "bad-backend",
            &["smoke", "--size", "4x4"],
            1,
            "WGPU_BACKEND=\"foo\"",
        )
        .env("WGPU_BACKEND", "foo"),
        Case {
            args: cpu(&g("binary.obj")),
            ..case("binary-obj", &[], 1, "not UTF-8 text")
        },
        Case {
            args: cpu(&corpus("missing_mtl.obj")),
            ..case("missing-mtl-names-the-file", &[], 0, "nowhere.mtl: ")
        },
        // 4: unbounded reads.
        Case {
            args: cpu(&g("zero.obj")),
            ..case(
                "obj-link-to-dev-zero",
                &[],
                1,
                "zero.obj: not a regular file",
            )
        },
        Case {
            args: cpu(&g("linked_zero.gltf")),
            ..case(
                "gltf-buffer-link-to-dev-zero",
                &[],
                1,
                "outside the scene file's directory",
            )
        },
        // 5: uris followed anywhere.
        Case {
            args: cpu(&corpus("buffer_dev_zero.gltf")),
            ..case("gltf-buffer-absolute", &[], 1, "\"/dev/zero\" is absolute")
        },
        Case {
            args: cpu(&corpus("buffer_traversal.gltf")),
            ..case(
                "gltf-buffer-traversal",
                &[],
                1,
                "leaves the scene file's directory",
            )
        },
        Case {
            args: cpu(&corpus("image_absolute.gltf")),
            ..case("gltf-image-absolute", &[], 1, "\"/etc/passwd\" is absolute")
        },
        // 12: silently truncated glTF geometry.
        Case {
            args: cpu(&corpus("index_count_too_large.gltf")),
            ..case("gltf-index-count-too-large", &[], 1, "declares 6 elements")
        },
        Case {
            args: cpu(&corpus("index_count_not_3.gltf")),
            ..case(
                "gltf-index-count-not-3",
                &[],
                1,
                "4 indices is not a multiple of 3",
            )
        },
        Case {
            args: cpu(&corpus("ok_triangle.gltf")),
            ..case("gltf-control", &[], 0, "")
        },
        // 8: a scene in units too small for 32-bit light densities is refused by its size.
        Case {
            args: cpu(&corpus("tiny_units.obj")),
            ..case("tiny-units", &[], 1, "units across")
        },
        // 11: lights and materials.
        Case {
            args: cpu(&corpus("no_lights.obj")),
            ..case("no-lights-warns", &[], 0, "no lights")
        },
        Case {
            args: cpu(&corpus("bad_ke.obj")),
            ..case(
                "bad-ke-line",
                &[],
                1,
                "bad_ke.mtl: MTL line 3: Ke expects 1 or 3 numbers, got \"abc def\"",
            )
        },
        Case {
            args: cpu(&corpus("usemtl_nosuch.obj")),
            ..case(
                "usemtl-nosuch-warns",
                &[],
                0,
                "usemtl \"nosuch\" names no material",
            )
        },
        // 9: references.
        Case {
            args: compare(&["--reference", &g("srgb.png")]),
            ..case("reference-png", &[], 1, "must be a linear OpenEXR")
        },
        Case {
            args: compare(&["--reference", &g("png_named.exr")]),
            ..case("reference-png-named-exr", &[], 1, "not OpenEXR")
        },
        Case {
            args: compare(&["--reference", &g("nan.exr")]),
            ..case(
                "reference-nan",
                &[],
                1,
                "NaN or infinite value at pixel (0, 0)",
            )
        },
        Case {
            args: compare(&["--reference", &g("inf.exr")]),
            ..case(
                "reference-inf",
                &[],
                1,
                "NaN or infinite value at pixel (0, 0)",
            )
        },
        Case {
            args: compare(&["--reference", &g("negative.exr")]),
            ..case(
                "reference-negative",
                &[],
                1,
                "negative value at pixel (0, 0)",
            )
        },
        Case {
            args: compare(&["--reference", &g("zeros.exr")]),
            ..case("reference-zeros", &[], 1, "black everywhere")
        },
        // 6: emission that overflows the accumulation.
        Case {
            args: [cpu("furnace"), vec!["--le".into(), "1e38".into()]].concat(),
            ..case("furnace-le-huge", &[], 1, "Le 1e38 must be in [0, 1e10]")
        },
        Case {
            args: cpu(&corpus("huge_ke.obj")),
            ..case("mtl-ke-huge-clamped", &[], 0, "clamped 1 materials")
        },
        // Issue 15: scene flags and required glTF extensions.
        Case {
            args: cpu(&corpus("requires_draco.gltf")),
            ..case(
                "gltf-requires-draco",
                &[],
                1,
                "requires extension KHR_draco_mesh_compression (Draco-compressed meshes)",
            )
        },
        Case {
            args: [cpu("cornell"), vec!["--camera".into(), "Side".into()]].concat(),
            ..case(
                "camera-unknown-name",
                &[],
                1,
                "--camera Side: no camera \"Side\" in the scene (expected a name or an index: \
                 the scene has 0 \"default\")",
            )
        },
        Case {
            args: [cpu("cornell"), vec!["--camera".into(), "1".into()]].concat(),
            ..case("camera-index-out-of-range", &[], 1, "no camera \"1\"")
        },
        Case {
            args: [
                cpu("cornell"),
                vec!["--add-lights".into(), "1000001".into()],
            ]
            .concat(),
            ..case("add-lights-too-many", &[], 2, "--add-lights <ADD_LIGHTS>")
        },
        Case {
            args: [cpu("cornell"), vec!["--add-lights".into(), "-3".into()]].concat(),
            ..case("add-lights-negative", &[], 2, "-3")
        },
        Case {
            args: [
                cpu("cornell"),
                vec![
                    "--add-lights".into(),
                    "10".into(),
                    "--add-light-power".into(),
                    "nan".into(),
                ],
            ]
            .concat(),
            ..case(
                "add-light-power-nan",
                &[],
                2,
                "--add-light-power <ADD_LIGHT_POWER>",
            )
        },
        Case {
            args: [
                cpu("cornell"),
                vec![
                    "--add-lights".into(),
                    "10".into(),
                    "--add-light-size=-1".into(),
                ],
            ]
            .concat(),
            ..case(
                "add-light-size-negative",
                &[],
                2,
                "--add-light-size <ADD_LIGHT_SIZE>",
            )
        },
        // Issue 15: environment light flags.
        Case {
            args: [cpu("cornell"), vec!["--sky=-1,0,0".into()]].concat(),
            ..case("sky-negative", &[], 1, "--sky -1,0,0")
        },
        Case {
            args: [cpu("cornell"), vec!["--sky".into(), "nan".into()]].concat(),
            ..case("sky-nan", &[], 1, "must be finite")
        },
        Case {
            args: [cpu("cornell"), vec!["--sky".into(), "1,2".into()]].concat(),
            ..case("sky-two-values", &[], 1, "expected R,G,B or one number")
        },
        Case {
            args: [
                cpu("cornell"),
                vec!["--env".into(), "/nonexistent/sky.hdr".into()],
            ]
            .concat(),
            ..case("env-missing", &[], 1, "/nonexistent/sky.hdr")
        },
        Case {
            args: [cpu("cornell"), vec!["--env".into(), g("srgb.png")]].concat(),
            ..case("env-not-hdr", &[], 1, ".hdr or .exr")
        },
        Case {
            args: [cpu("cornell"), vec!["--env".into(), g("nan.exr")]].concat(),
            ..case("env-nan-pixel", &[], 1, "nan.exr: pixel (0, 0)")
        },
        Case {
            args: [cpu("cornell"), vec!["--env".into(), g("negative.exr")]].concat(),
            ..case("env-negative-pixel", &[], 1, "negative.exr: pixel (0, 0)")
        },
        Case {
            args: [cpu("cornell"), vec!["--env".into(), g("png_named.exr")]].concat(),
            ..case("env-undecodable", &[], 1, "cannot decode")
        },
        Case {
            args: [cpu("cornell"), vec!["--env".into(), g("huge.hdr")]].concat(),
            ..case("env-absurd-size", &[], 1, "100000x2 pixels is outside")
        },
        Case {
            args: [
                cpu("cornell"),
                vec![
                    "--env".into(),
                    g("zeros.exr"),
                    "--env-intensity".into(),
                    "nan".into(),
                ],
            ]
            .concat(),
            ..case(
                "env-intensity-nan",
                &[],
                1,
                "--env-intensity: intensity NaN",
            )
        },
        Case {
            args: [cpu("cornell"), vec!["--env-intensity".into(), "2".into()]].concat(),
            ..case(
                "env-intensity-alone",
                &[],
                1,
                "--env-intensity scales --env or --sky",
            )
        },
        Case {
            args: [
                cpu("cornell"),
                vec!["--sky".into(), "1".into(), "--env".into(), g("zeros.exr")],
            ]
            .concat(),
            ..case("sky-and-env", &[], 2, "cannot be used with")
        },
        Case {
            args: [cpu("cornell"), vec!["--add-light-power".into(), "5".into()]].concat(),
            ..case(
                "add-light-power-without-count",
                &[],
                1,
                "need --add-lights N",
            )
        },
        Case {
            args: [
                cpu("cornell"),
                vec![
                    "--add-lights".into(),
                    "1".into(),
                    "--add-light-power".into(),
                    "1e30".into(),
                    "--add-light-size".into(),
                    "1e-6".into(),
                ],
            ]
            .concat(),
            ..case(
                "add-lights-radiance-overflow",
                &[],
                1,
                "--add-lights: bad scene option: add-lights: power 1e30",
            )
        },
        Case {
            args: [cpu("cornell"), vec!["--add-lights".into(), "20".into()]].concat(),
            ..case("add-lights-control", &[], 0, "added 20 lights")
        },
        // 3: memory before allocation.
        case(
            "cpu-reference-too-large",
            &[
                "render",
                "--method",
                "cpu-reference",
                "--threads",
                "1",
                "--size",
                "16384x16384",
                "--frames",
                "1",
            ],
            1,
            "GiB of memory, above the limit",
        ),
    ];

    // 2: smoke above the storage binding limit (the adapter's limit decides the size).
    let adapter = info(&[]);
    if let Some(l) = adapter
        .as_deref()
        .and_then(|i| limit(i, "max_storage_buffer_binding_size"))
        && l < 16384 * 16384 * 4
    {
        let side = ((l / 4) as f64).sqrt() as u32 + 1;
        let size = format!("{side}x{side}");
        cases.push(case(
            "smoke-above-binding-limit",
            &["smoke", "--size", &size],
            1,
            "max_storage_buffer_binding_size",
        ));
    } else {
        eprintln!("skipping smoke-above-binding-limit: no adapter or a limit above 1 GiB");
    }
    // 1: world-restir on a backend with 16 storage buffers per stage (GL).
    match info(&[("WGPU_BACKEND", "gl")]) {
        Some(i) if limit(&i, "max_storage_buffers_per_shader_stage").is_some_and(|l| l < 20) => {
            cases.push(
                case(
                    "world-restir-on-gl",
                    &[
                        "render",
                        "--method",
                        "world-restir",
                        "--size",
                        "16x16",
                        "--frames",
                        "2",
                    ],
                    1,
                    "max_storage_buffers_per_shader_stage",
                )
                .env("WGPU_BACKEND", "gl"),
            );
        }
        _ => eprintln!("skipping world-restir-on-gl: no GL adapter with under 20 storage buffers"),
    }

    let mut failures = Vec::new();
    for c in &cases {
        let out = tmp.join("out").join(c.name);
        let mut cmd = Command::new(exe());
        cmd.args(&c.args);
        if !c.args.iter().any(|a| a == "--out") && c.args.first().is_some_and(|a| a != "info") {
            cmd.arg("--out").arg(&out);
        }
        for (k, v) in &c.env {
            cmd.env(k, v);
        }
        // stderr goes to a file and the run has a deadline: an unbounded read (a link to
        // /dev/zero read whole) fails the case instead of hanging the test.
        let log = tmp.join(format!("{}.stderr", c.name));
        cmd.stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).expect("stderr log"));
        let mut child = cmd.spawn().expect("run restir-demo");
        let start = Instant::now();
        let mut problems = Vec::new();
        let status = loop {
            if let Some(st) = child.try_wait().expect("wait for restir-demo") {
                break Some(st);
            }
            if start.elapsed() > CASE_TIMEOUT {
                let _ = child.kill();
                let _ = child.wait();
                problems.push(format!(
                    "still running after {} s (an unbounded read or a hang): killed",
                    CASE_TIMEOUT.as_secs()
                ));
                break None;
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        let err = std::fs::read_to_string(&log).unwrap_or_default();
        let code = status.and_then(|s| s.code());
        if code == Some(101) || err.contains("panicked") {
            problems.push("panicked".to_owned());
        }
        if code != Some(c.code) {
            problems.push(format!("exit code {code:?}, expected {}", c.code));
        }
        if !err.contains(&c.needle) {
            problems.push(format!("stderr lacks {:?}", c.needle));
        }
        if c.code != 0 {
            let left = files_under(&out);
            if !left.is_empty() {
                problems.push(format!("a failed run left files behind: {left:?}"));
            }
        } else {
            for f in files_under(&out) {
                if f.extension().is_some_and(|e| e == "exr") {
                    let img = read_exr(&f).expect("read an output EXR");
                    if !img.is_finite() {
                        problems.push(format!("{} has NaN/Inf pixels", f.display()));
                    }
                }
            }
        }
        if !problems.is_empty() {
            failures.push(format!(
                "{}: {}\n  args: {:?}\n  stderr: {}",
                c.name,
                problems.join("; "),
                c.args,
                err.trim()
            ));
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
