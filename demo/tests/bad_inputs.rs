//! Issue 14 (hardening): bad input is refused before any expensive work with a message that
//! names its cause, never a panic, an unbounded read or a silently wrong image; a failed run
//! leaves no output behind.
//!
//! One table: each case gives the `restir-demo` arguments, the expected exit code and a
//! substring of stderr. The corpus is `tests/bad_inputs/` (tiny text files) plus what this
//! test generates into its temporary directory (links to /dev/zero, binary garbage, EXR
//! references, and for issue 27 glTF scenes with textures, FIFOs, sparse 10 GiB files, a
//! 16384 x 8192 PNG). Every image is a few pixels, so the whole table runs in about a minute.
//!
//! Issue 27 (hardening the new inputs) has one case per defect, named `27-N-...` after its
//! number in the issue. A case may plant files before the run (`before`, given the process id
//! the run will have: each run starts in a shell that waits for a line, then execs restir-demo),
//! check what it left (`after`), and limit the run's address space (`mem_mib`: an unbounded
//! allocation aborts the run instead of the machine). `BAD_INPUTS_ONLY=a,b` runs the cases
//! whose names contain `a` or `b`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use restir_world::image_io::{Image, read_exr, write_exr};

mod common;
use common::cpu;

/// Longest a case may run: every case is a few pixels, most refused before any real work. The
/// cases that render one frame with a warning (the cache's, at 64 bounces) compile their
/// kernels on first use: past 120 s on lavapipe with Mesa's cache cold and another test binary
/// beside them (2026-12-04), so a hang is what runs past 300 s.
const CASE_TIMEOUT: Duration = Duration::from_secs(300);

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

/// What a case does before its run: given the run's process id and output directory.
type Before = Box<dyn Fn(u32, &Path)>;
/// What a case checks after its run, given the output directory.
type After = Box<dyn Fn(&Path) -> Result<(), String>>;

/// One row of the table.
struct Case {
    name: &'static str,
    args: Vec<String>,
    env: Vec<(&'static str, &'static str)>,
    /// Expected exit status (0: success, with a warning on stderr).
    code: i32,
    /// A substring of stderr.
    needle: String,
    /// Runs before the command starts, with its process id (the command is held until this
    /// returns) and its output directory: plants links, directories or damaged files.
    before: Option<Before>,
    /// Checks after the run (with the output directory): what is wrong, if anything.
    after: Option<After>,
    /// Address-space limit of the run in MiB: an unbounded allocation aborts it.
    mem_mib: Option<u64>,
    /// Do not add `--out` (commands without one).
    no_out: bool,
}

fn case(name: &'static str, args: &[&str], code: i32, needle: &str) -> Case {
    Case {
        name,
        args: args.iter().map(|s| s.to_string()).collect(),
        env: Vec::new(),
        code,
        needle: needle.to_owned(),
        before: None,
        after: None,
        mem_mib: None,
        no_out: false,
    }
}

/// A case of `args` (owned strings).
fn case_of(name: &'static str, args: Vec<String>, code: i32, needle: &str) -> Case {
    Case {
        args,
        ..case(name, &[], code, needle)
    }
}

/// `base` followed by `extra`.
fn plus(base: Vec<String>, extra: &[&str]) -> Vec<String> {
    let mut v = base;
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

/// The CPU reference on `cornell` with `flags` added.
fn cornell(name: &'static str, flags: &[&str], code: i32, needle: &str) -> Case {
    case_of(name, plus(cpu("cornell"), flags), code, needle)
}

/// The CPU reference on `file` of the corpus (`tests/bad_inputs/`).
fn scene_file(name: &'static str, file: &str, code: i32, needle: &str) -> Case {
    case_of(name, cpu(&corpus(file)), code, needle)
}

impl Case {
    fn env(mut self, key: &'static str, value: &'static str) -> Self {
        self.env.push((key, value));
        self
    }
    fn before(mut self, f: impl Fn(u32, &Path) + 'static) -> Self {
        self.before = Some(Box::new(f));
        self
    }
    fn after(mut self, f: impl Fn(&Path) -> Result<(), String> + 'static) -> Self {
        self.after = Some(Box::new(f));
        self
    }
    fn mem_mib(mut self, mib: u64) -> Self {
        self.mem_mib = Some(mib);
        self
    }
    fn no_out(mut self) -> Self {
        self.no_out = true;
        self
    }
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
    // A flag given already (--methods, --scene, --size, ...) has its value replaced; others
    // are appended.
    for pair in extra.chunks(2) {
        if let Some(i) = v.iter().position(|a| a == pair[0])
            && pair.len() == 2
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

/// Standard base64 with padding (for glTF data uris).
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A glTF of one emissive, textured triangle: buffer 0 holds the positions (view 0, 36
/// bytes), the texture coordinates `uvs` (view 1, 24 bytes) and u16 indices (view 2);
/// material 0 uses texture 0, image 0 is the file `image`. `edit` changes the JSON.
fn textured_gltf(image: &str, uvs: [f32; 6], edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let mut buf = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        buf.extend_from_slice(&v.to_le_bytes());
    }
    for v in uvs {
        buf.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        buf.extend_from_slice(&i.to_le_bytes());
    }
    let mut v = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "TEXCOORD_0": 1},
            "indices": 2,
            "material": 0
        }]}],
        "materials": [{
            "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
            "emissiveFactor": [1.0, 1.0, 1.0]
        }],
        "textures": [{"source": 0}],
        "images": [{"uri": image}],
        "buffers": [{
            "uri": format!("data:application/octet-stream;base64,{}", base64(&buf)),
            "byteLength": buf.len()
        }],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 24},
            {"buffer": 0, "byteOffset": 60, "byteLength": 6}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ]
    });
    edit(&mut v);
    serde_json::to_string_pretty(&v).unwrap()
}

const UVS: [f32; 6] = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];

/// A small PNG texture.
fn write_png(path: &Path) {
    image::RgbImage::from_pixel(4, 4, image::Rgb([200, 100, 50]))
        .save_with_format(path, image::ImageFormat::Png)
        .unwrap();
}

/// A file of `len` bytes that starts with `head` and is otherwise a hole (no disk space).
fn sparse(path: &Path, head: &[u8], len: u64) {
    use std::io::Write;
    let mut f = std::fs::File::create(path).unwrap();
    f.write_all(head).unwrap();
    f.set_len(len).unwrap();
}

fn mkfifo(path: &Path) {
    let _ = std::fs::remove_file(path);
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

/// A directory `name` under `dir` holding `scene.gltf` (written by `gltf`) and what `extra`
/// adds; returns the scene file.
fn scene_dir(dir: &Path, name: &str, gltf: String, extra: impl FnOnce(&Path)) -> String {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("scene.gltf"), gltf).unwrap();
    extra(&d);
    d.join("scene.gltf").display().to_string()
}

/// The glTF of [`textured_gltf`] with a point light of `intensity` (KHR_lights_punctual).
fn punctual_gltf(intensity: f64) -> String {
    textured_gltf("tex.png", UVS, |v| {
        v["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
        v["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": [
            {"type": "point", "intensity": intensity, "color": [1.0, 1.0, 1.0]}
        ]}});
        v["nodes"] = serde_json::json!([
            {"mesh": 0},
            {"translation": [0.3, 0.3, 1.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ]);
        v["scenes"] = serde_json::json!([{"nodes": [0, 1]}]);
    })
}

/// Whether the files under `dir` (recursively) are exactly `want` (names, any order).
fn names_under(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = files_under(dir)
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    v.sort();
    v
}

/// Issue 27 (hardening the new inputs): one case per defect, numbered as in the issue; the
/// files are generated into `g` (large ones as sparse files or small compressed images).
fn new_input_cases(tmp: &Path, g: &Path) -> Vec<Case> {
    let gs = |name: &str| g.join(name).display().to_string();
    let gltf = |image: &str| textured_gltf(image, UVS, |_| {});
    let edited = |edit: fn(&mut serde_json::Value)| textured_gltf("tex.png", UVS, edit);
    let with_png = |d: &Path| write_png(&d.join("tex.png"));
    write_png(&g.join("outside.png"));
    let mut v = Vec::new();

    // 1: an image uri that is a link to a file outside the scene's directory.
    let outside = g.join("outside.png");
    let scene = scene_dir(g, "image_link", gltf("tex.png"), |d| {
        let _ = std::fs::remove_file(d.join("tex.png"));
        std::os::unix::fs::symlink(&outside, d.join("tex.png")).unwrap();
    });
    v.push(case_of(
        "27-1-image-link-outside",
        cpu(&scene),
        1,
        "leads (through a link) outside the scene file's directory",
    ));

    // 2: links planted at the probe and temporary names truncate or overwrite their targets.
    let victims = g.join("victims");
    std::fs::create_dir_all(&victims).unwrap();
    let (v1, v2) = (victims.join("probe-target"), victims.join("tmp-target"));
    v.push(
        case_of("27-2-planted-output-links", cpu("cornell"), 0, "")
            .before({
                let (v1, v2) = (v1.clone(), v2.clone());
                move |pid, out| {
                    std::fs::create_dir_all(out).unwrap();
                    std::fs::write(&v1, "keep").unwrap();
                    std::fs::write(&v2, "keep").unwrap();
                    let link = |name: String, to: &Path| {
                        std::os::unix::fs::symlink(to, out.join(name)).unwrap()
                    };
                    link(format!(".restir-demo-probe-{pid}"), &v1);
                    for kind in ["direct", "indirect", "combined"] {
                        for ext in ["exr", "png"] {
                            let n = format!("cornell-cpu-reference-{kind}.{ext}");
                            link(format!(".{n}.tmp{pid}.{ext}"), &v2);
                        }
                    }
                }
            })
            .after(move |_| {
                for t in [&v1, &v2] {
                    let text = std::fs::read(t).unwrap_or_default();
                    if text != b"keep" {
                        return Err(format!("{} was written through a link", t.display()));
                    }
                }
                Ok(())
            }),
    );

    // 3: texture reads without a regular-file check or size cap.
    let scene = scene_dir(g, "texture_fifo", gltf("fifo.png"), |d| {
        mkfifo(&d.join("fifo.png"))
    });
    v.push(case_of(
        "27-3-texture-fifo",
        cpu(&scene),
        0,
        "not a regular file",
    ));
    let scene = scene_dir(g, "texture_sparse", gltf("big.png"), |d| {
        sparse(&d.join("big.png"), b"\x89PNG\r\n\x1a\n", 10 << 30)
    });
    v.push(
        case_of(
            "27-3-texture-10gib-sparse",
            cpu(&scene),
            0,
            "above the limit",
        )
        .mem_mib(4096),
    );

    // 4: accessors the gltf crate panics on.
    let scene = scene_dir(
        g,
        "texcoord_u32",
        edited(|v| v["accessors"][1]["componentType"] = 5125.into()),
        with_png,
    );
    v.push(case_of(
        "27-4-texcoord-unsigned-int",
        cpu(&scene),
        0,
        "TEXCOORD_0",
    ));
    let scene = scene_dir(
        g,
        "stride_4",
        edited(|v| v["bufferViews"][1]["byteStride"] = 4.into()),
        with_png,
    );
    v.push(case_of(
        "27-4-byte-stride-4-on-vec2",
        cpu(&scene),
        0,
        "byteStride 4",
    ));
    let scene = scene_dir(
        g,
        "index_float",
        edited(|v| {
            v["accessors"][2]["componentType"] = 5126.into();
            v["bufferViews"][2]["byteLength"] = 8.into();
            v["accessors"][2]["count"] = 2.into();
        }),
        with_png,
    );
    v.push(case_of("27-4-index-float", cpu(&scene), 1, "FLOAT"));

    // 5: ten images of one 16384 x 8192 greyscale PNG: each decoded at 512 MiB (RGBA).
    let scene = scene_dir(
        g,
        "bomb",
        edited(|v| {
            let n = 10;
            v["images"] = (0..n)
                .map(|_| serde_json::json!({"uri": "bomb.png"}))
                .collect();
            v["textures"] = (0..n).map(|i| serde_json::json!({"source": i})).collect();
            v["materials"] = (0..n)
                .map(|i| {
                    serde_json::json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": i}},
                                       "emissiveFactor": [1.0, 1.0, 1.0]})
                })
                .collect();
            let prim = v["meshes"][0]["primitives"][0].clone();
            v["meshes"][0]["primitives"] = (0..n)
                .map(|i| {
                    let mut p = prim.clone();
                    p["material"] = i.into();
                    p
                })
                .collect();
        }),
        |d| {
            let img = image::GrayImage::new(16384, 8192);
            let f = std::fs::File::create(d.join("bomb.png")).unwrap();
            let enc = image::codecs::png::PngEncoder::new_with_quality(
                std::io::BufWriter::new(f),
                image::codecs::png::CompressionType::Fast,
                image::codecs::png::FilterType::NoFilter,
            );
            img.write_with_encoder(enc).unwrap();
        },
    );
    v.push(case_of("27-5-decompression-bomb", cpu(&scene), 0, "halved").mem_mib(3072));

    // 6: a Radiance header line without end (600 MiB, sparse).
    sparse(&g.join("endless.hdr"), b"#?RADIANCE\n", 600 << 20);
    v.push(
        cornell(
            "27-6-hdr-endless-header-line",
            &["--env", &gs("endless.hdr")],
            1,
            "header line",
        )
        .mem_mib(1024),
    );

    // 7: an --env that is a FIFO.
    mkfifo(&g.join("fifo.hdr"));
    v.push(cornell(
        "27-7-env-fifo",
        &["--env", &gs("fifo.hdr")],
        1,
        "not a regular file",
    ));

    // 8, 9: punctual intensity without a cap; --punctual-intensity checked before scaling.
    let scene = scene_dir(g, "punctual_huge", punctual_gltf(3e38), with_png);
    v.push(case_of(
        "27-8-punctual-intensity-3e38",
        cpu(&scene),
        0,
        "clamped",
    ));
    let scene = scene_dir(g, "punctual_ten", punctual_gltf(10.0), with_png);
    v.push(case_of(
        "27-9-punctual-intensity-flag-overflow",
        plus(cpu(&scene), &["--punctual-intensity", "1e38"]),
        1,
        "--punctual-intensity 1e38",
    ));

    // 10: one non-finite KHR_texture_transform.
    let scene = scene_dir(
        g,
        "transform_inf",
        edited(|v| {
            v["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
            v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"] =
                serde_json::json!({"KHR_texture_transform": {"scale": [1e39, 1.0]}});
        }),
        with_png,
    );
    v.push(case_of(
        "27-10-texture-transform-inf",
        cpu(&scene),
        0,
        "KHR_texture_transform",
    ));

    // 11: textures ignored without a warning.
    let scene = scene_dir(
        g,
        "texcoord_count",
        edited(|v| v["accessors"][1]["count"] = 2.into()),
        with_png,
    );
    v.push(case_of(
        "27-11-texcoord-wrong-count",
        cpu(&scene),
        0,
        "TEXCOORD_0",
    ));
    let scene = scene_dir(
        g,
        "texcoord_vec3",
        edited(|v| {
            v["accessors"][1]["type"] = "VEC3".into();
            v["accessors"][1]["count"] = 2.into();
        }),
        with_png,
    );
    v.push(case_of("27-11-texcoord-vec3", cpu(&scene), 0, "TEXCOORD_0"));
    let scene = scene_dir(
        g,
        "image_view_outside",
        edited(|v| {
            let views = v["bufferViews"].as_array_mut().unwrap();
            views.push(serde_json::json!({"buffer": 0, "byteOffset": 60, "byteLength": 100}));
            v["images"][0] = serde_json::json!({"bufferView": 3, "mimeType": "image/png"});
        }),
        |_| {},
    );
    v.push(case_of(
        "27-11-image-view-outside-buffer",
        cpu(&scene),
        0,
        "outside its buffer",
    ));

    // 12: damaged reference cache entries are used.
    let cache = tmp.join("cache-27-12");
    v.push(case_of(
        "27-12-cache-fill",
        with_cache(compare(&[]), &cache),
        0,
        "",
    ));
    for (name, value) in [("27-12-cache-nan", f32::NAN), ("27-12-cache-zeros", 0.0)] {
        let c = cache.clone();
        let c2 = cache.clone();
        v.push(
            case_of(name, with_cache(compare(&[]), &cache), 0, "damaged")
                .before(move |_, _| {
                    for f in files_under(&c) {
                        if f.to_string_lossy().ends_with(".combined.exr") {
                            let img = Image::from_pixels(4, 4, vec![[value; 3]; 16]).unwrap();
                            write_exr(&f, &img).unwrap();
                        }
                    }
                })
                .after(move |_| {
                    for f in files_under(&c2) {
                        if f.to_string_lossy().ends_with(".combined.exr") {
                            let img = read_exr(&f).map_err(|e| e.to_string())?;
                            if !img.is_finite() || img.pixels.iter().all(|p| p == &[0.0; 3]) {
                                return Err("the damaged cache entry stayed".into());
                            }
                        }
                    }
                    Ok(())
                }),
        );
    }

    // 12b: cache entries that are not a regular file of an entry's size are dropped unopened,
    // with the reason (a FIFO blocked the read; /dev/zero and a sparse 4 GiB file were read
    // until memory ran out).
    type Make = fn(&Path);
    let entries: [(&'static str, &'static str, Make, &'static str); 3] = [
        (
            "27-12-cache-fifo",
            ".combined.exr",
            make_fifo,
            "not a regular file",
        ),
        (
            "27-12-cache-link-dev-zero",
            ".txt",
            link_dev_zero,
            "not a regular file",
        ),
        (
            "27-12-cache-sparse-4gib",
            ".txt",
            sparse_4gib,
            "bytes, more than",
        ),
    ];
    for (name, suffix, make, needle) in entries {
        let (c, c2) = (cache.clone(), cache.clone());
        let ours = move |f: &Path| f.to_string_lossy().ends_with(suffix);
        v.push(
            case_of(name, with_cache(compare(&[]), &cache), 0, needle)
                .before(move |_, _| {
                    for f in files_under(&c).iter().filter(|f| ours(f)) {
                        std::fs::remove_file(f).unwrap();
                        make(f);
                    }
                })
                .after(move |_| {
                    for f in files_under(&c2).iter().filter(|f| ours(f)) {
                        let meta = std::fs::symlink_metadata(f).map_err(|e| e.to_string())?;
                        if !meta.file_type().is_file() || meta.len() > 1 << 20 {
                            return Err(format!("{} stayed", f.display()));
                        }
                    }
                    Ok(())
                })
                .mem_mib(4096),
        );
    }

    // 13: --add-lights quads too large or degenerate.
    for (name, size) in [
        ("27-13-add-light-size-1e10", "1e10"),
        ("27-13-add-light-size-1e-15", "1e-15"),
    ] {
        v.push(case_of(
            name,
            plus(
                cpu("cornell"),
                &["--add-lights", "4", "--add-light-size", size],
            ),
            1,
            "--add-light-size",
        ));
    }

    // 14: a failed write leaves the other images of the set behind.
    v.push(
        case_of(
            "27-14-partial-output-set",
            cpu("cornell"),
            1,
            "cornell-cpu-reference-combined",
        )
        .before(|_, out| {
            std::fs::create_dir_all(out.join("cornell-cpu-reference-combined.exr")).unwrap();
        }),
    );

    // 15: compare --frames 1 times the warm-up frames.
    v.push(
        case_of("27-15-compare-one-frame", compare(&[]), 0, "warm-up").after(|out| {
            let md = std::fs::read_to_string(out.join("report.md")).unwrap_or_default();
            if md.contains("warm-up") {
                Ok(())
            } else {
                Err("report.md says nothing".into())
            }
        }),
    );

    // 16: two scenes with the same file name.
    let (a, b) = (g.join("same_a"), g.join("same_b"));
    for d in [&a, &b] {
        std::fs::create_dir_all(d).unwrap();
        std::fs::copy(corpus("ok_triangle.gltf"), d.join("tri.gltf")).unwrap();
    }
    let scenes = format!(
        "{},{}",
        a.join("tri.gltf").display(),
        b.join("tri.gltf").display()
    );
    let mut args = compare(&["--scene", &scenes]);
    args.retain(|a| a != "--no-exr");
    v.push(case_of("27-16-same-scene-names", args, 0, "").after(|out| {
        let refs: Vec<String> = names_under(out)
            .into_iter()
            .filter(|n| n.starts_with("reference_") && !n.contains("indirect"))
            .collect();
        match refs.len() {
            2 => Ok(()),
            _ => Err(format!("references {refs:?}: one overwrote the other")),
        }
    }));

    // 17: compare --out equal to a scene's directory.
    let scene = scene_dir(g, "out_is_scene_dir", gltf("strip.jpg"), |d| {
        write_png(&d.join("strip.jpg"))
    });
    let dir = g.join("out_is_scene_dir");
    let strip = std::fs::read(dir.join("strip.jpg")).unwrap();
    v.push(
        case_of(
            "27-17-compare-out-is-scene-dir",
            plus(
                compare(&["--scene", &scene]),
                &["--out", &dir.display().to_string()],
            ),
            1,
            "--out",
        )
        .after(move |_| match std::fs::read(dir.join("strip.jpg")) {
            Ok(b) if b == strip => Ok(()),
            _ => Err("the scene's strip.jpg was overwritten".into()),
        }),
    );

    // 18: a black sky on a scene without emitters renders black without the warning.
    let dark = corpus("no_lights.obj");
    v.push(case_of(
        "27-18-sky-zero",
        plus(cpu(&dark), &["--sky", "0"]),
        0,
        "no lights",
    ));
    v.push(case_of(
        "27-18-env-intensity-zero",
        plus(cpu(&dark), &["--sky", "1", "--env-intensity", "0"]),
        0,
        "no lights",
    ));

    // 19: view --screenshot new/dir/shot.png without a display leaves new/dir behind.
    let shot_root = g.join("shot_new");
    let shot = shot_root.join("dir/shot.png").display().to_string();
    v.push(
        case(
            "27-19-screenshot-dir-left",
            &["view", "--screenshot", &shot],
            1,
            "no display",
        )
        .env("DISPLAY", "")
        .env("WAYLAND_DISPLAY", "")
        .no_out()
        .after(move |_| match shot_root.exists() {
            true => Err(format!("{} was left behind", shot_root.display())),
            false => Ok(()),
        }),
    );

    // 20: a .hdr texture decoded as if it were sRGB.
    let scene = scene_dir(g, "texture_hdr", gltf("tex.hdr"), |d| {
        image::Rgb32FImage::from_pixel(4, 4, image::Rgb([2.0, 1.0, 0.5]))
            .save(d.join("tex.hdr"))
            .unwrap()
    });
    v.push(case_of(
        "27-20-texture-hdr",
        cpu(&scene),
        0,
        "only PNG and JPEG",
    ));

    // 21: the same configuration under two names.
    v.push(case_of(
        "27-21-methods-same-settings",
        compare(&["--methods", "world-restir,world-restir:both"]),
        1,
        "the same configuration",
    ));

    // 23: NaN texture coordinates reported as bad normals.
    let mut nan_uvs = UVS;
    nan_uvs[0] = f32::NAN;
    let scene = scene_dir(
        g,
        "nan_uvs",
        textured_gltf("tex.png", nan_uvs, |_| {}),
        with_png,
    );
    v.push(case_of(
        "27-23-nan-uvs",
        cpu(&scene),
        0,
        "texture coordinates",
    ));

    // 24: sizes world-restir cannot size its cells for.
    v.push(case(
        "27-24-world-restir-1x1",
        &[
            "render",
            "--method",
            "world-restir",
            "--size",
            "1x1",
            "--frames",
            "1",
        ],
        1,
        "--size 1x1",
    ));
    v.push(case_of(
        "27-24-compare-1x1",
        with_cache(
            compare(&["--methods", "nee,world-restir", "--size", "1x1"]),
            &tmp.join("out/27-24-compare-1x1/cache"),
        ),
        1,
        "--size 1x1",
    ));

    // 25: --cache that is a file or cannot be created.
    v.push(case_of(
        "27-25-cache-is-a-file",
        with_cache(compare(&[]), &g.join("zeros.exr")),
        1,
        "--cache",
    ));
    v.push(case_of(
        "27-25-cache-uncreatable",
        with_cache(compare(&[]), Path::new("/proc/restir-demo-cache")),
        1,
        "--cache",
    ));

    // 26: negative values after a space.
    v.push(cornell(
        "27-26-env-intensity-minus-1",
        &["--sky", "1", "--env-intensity", "-1"],
        1,
        "--env-intensity",
    ));
    v.push(cornell(
        "27-26-camera-minus-1",
        &["--camera", "-1"],
        1,
        "--camera -1",
    ));

    // 28: a depth the method's candidates cannot loop over is refused by its flags before any
    // work (it was refused after the adapter and the reference, naming neither flag).
    v.push(case_of(
        "27-28-bounces-times-candidates",
        compare(&["--bounces", "64", "--methods", "ris:2000"]),
        1,
        "--methods ris:2000 with --bounces 64",
    ));
    v
}

/// `restir-demo info` (with `env`): its stdout, or None when it fails (no such adapter).
/// `restir-demo info` with `env`: its exit code, stdout and stderr.
fn run_info(env: &[(&str, &str)]) -> (Option<i32>, String, String) {
    let mut c = Command::new(exe());
    c.arg("info");
    for (k, v) in env {
        c.env(k, v);
    }
    let o = c.output().expect("restir-demo runs");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (o.status.code(), text(&o.stdout), text(&o.stderr))
}

/// `info`'s stdout when it succeeds with `env`.
fn info(env: &[(&str, &str)]) -> Option<String> {
    let (code, out, _) = run_info(env);
    (code == Some(0)).then_some(out)
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
/// A FIFO at `p` (nobody writes it: opening it for reading blocks).
fn make_fifo(p: &Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(p)
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo {}", p.display());
}

/// A symbolic link at `p` to /dev/zero (endless bytes).
fn link_dev_zero(p: &Path) {
    std::os::unix::fs::symlink("/dev/zero", p).unwrap();
}

/// A sparse file of 4 GiB at `p`.
fn sparse_4gib(p: &Path) {
    std::fs::File::create(p).unwrap().set_len(4 << 30).unwrap();
}

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

/// The cases before issue 27's, numbered as in issue 14; `gen_dir` holds [`generate`]'s files.
fn cases(tmp: &Path, gen_dir: &Path) -> Vec<Case> {
    let g = |name: &str| gen_dir.join(name).display().to_string();
    // The CPU reference on a generated scene file, and compare against a generated reference.
    let generated = |name: &'static str, file: &str, code: i32, needle: &str| {
        case_of(name, cpu(&g(file)), code, needle)
    };
    let reference = |name: &'static str, file: &str, code: i32, needle: &str| {
        case_of(name, compare(&["--reference", &g(file)]), code, needle)
    };
    vec![
        // 15: checks before expensive work.
        cornell(
            "out-dir-unwritable",
            &["--out", "/proc/restir-demo-x/y"],
            1,
            "cannot create the output directory /proc/restir-demo-x/y",
        ),
        // With the reference cache inside the case's output: a reference rendered before the
        // error is found would be left behind there.
        case_of(
            "compare-bad-variant",
            with_cache(
                compare(&["--methods", "nee,ris:0"]),
                &tmp.join("out/compare-bad-variant/cache"),
            ),
            1,
            "ris:0",
        ),
        case_of(
            "compare-missing-second-scene",
            with_cache(
                compare(&["--scene", "cornell,doesnotexist"]),
                &tmp.join("out/compare-missing-second-scene/cache"),
            ),
            1,
            "\"doesnotexist\"",
        ),
        // 10: compare options that silently did something else.
        case_of(
            "equal-time-to-unlisted",
            compare(&["--methods", "nee,ris", "--equal-time-to", "world-restir"]),
            1,
            "--equal-time-to names \"world-restir\", which is not in --methods",
        ),
        case_of(
            "reference-spp-0",
            compare(&["--reference-spp", "0"]),
            1,
            "--reference-spp must be at least 2",
        ),
        // Issue 38: its rounding to an even count overflowed and the reference ran forever.
        case_of(
            "reference-spp-u32-max",
            compare(&["--reference-spp", "4294967295"]),
            1,
            "--reference-spp must be at most 1048576, got 4294967295",
        ),
        // 24 (paths): the depth is checked before any work, by flag.
        cornell("bounces-0", &["--bounces", "0"], 1, "--bounces"),
        cornell(
            "bounces-65",
            &["--bounces", "65"],
            1,
            "bounces 65 must be in 1..=64",
        ),
        cornell(
            "roulette-from-1",
            &["--roulette-from", "1"],
            1,
            "--roulette-from",
        ),
        cornell("mis-maybe", &["--mis", "maybe"], 2, "expected on or off"),
        case_of(
            "compare-bounces-0",
            compare(&["--bounces", "0"]),
            1,
            "--bounces",
        ),
        case_of(
            "methods-twice",
            compare(&["--methods", "nee,nee"]),
            1,
            "--methods lists \"nee\" twice",
        ),
        // The radiance cache holds every bounce's light: bounded paths are refused, and so
        // are its knobs out of range.
        case(
            "cache-bounded-paths",
            &["render", "--method", "ris+cache"],
            1,
            "render it with unbounded paths (--bounces 64",
        ),
        case_of(
            "cache-bounded-paths-compare",
            compare(&["--methods", "ris,ris+cache"]),
            1,
            "--methods ris+cache with --bounces 3",
        ),
        case(
            "cache-after-one",
            &["render", "--method", "ris+cache:after=1", "--bounces", "64"],
            1,
            "after",
        ),
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
        case_of(
            "compare-ris-above-cap",
            compare(&["--methods", "ris:70000"]),
            1,
            "must be in 1..=65535",
        ),
        case_of(
            "compare-world-restir-above-cap",
            compare(&["--methods", "world-restir:candidates=70000"]),
            1,
            "must be in 1..=65535",
        ),
        // 13: cameras that rendered black or static.
        cornell(
            "eye-target-overflow",
            &["--eye", "0,1,3e38", "--target", "0,1,-3e38"],
            1,
            "too far apart",
        ),
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
        generated("binary-obj", "binary.obj", 1, "not UTF-8 text"),
        scene_file(
            "missing-mtl-names-the-file",
            "missing_mtl.obj",
            0,
            "nowhere.mtl: ",
        ),
        // 4: unbounded reads.
        generated(
            "obj-link-to-dev-zero",
            "zero.obj",
            1,
            "zero.obj: not a regular file",
        ),
        generated(
            "gltf-buffer-link-to-dev-zero",
            "linked_zero.gltf",
            1,
            "outside the scene file's directory",
        ),
        // 5: uris followed anywhere.
        scene_file(
            "gltf-buffer-absolute",
            "buffer_dev_zero.gltf",
            1,
            "\"/dev/zero\" is absolute",
        ),
        scene_file(
            "gltf-buffer-traversal",
            "buffer_traversal.gltf",
            1,
            "leaves the scene file's directory",
        ),
        scene_file(
            "gltf-image-absolute",
            "image_absolute.gltf",
            1,
            "\"/etc/passwd\" is absolute",
        ),
        // 12: silently truncated glTF geometry.
        scene_file(
            "gltf-index-count-too-large",
            "index_count_too_large.gltf",
            1,
            "declares 6 elements",
        ),
        scene_file(
            "gltf-index-count-not-3",
            "index_count_not_3.gltf",
            1,
            "4 indices is not a multiple of 3",
        ),
        scene_file("gltf-control", "ok_triangle.gltf", 0, ""),
        // 8: a scene in units too small for 32-bit light densities is refused by its size.
        scene_file("tiny-units", "tiny_units.obj", 1, "units across"),
        // 11: lights and materials.
        scene_file("no-lights-warns", "no_lights.obj", 0, "no lights"),
        scene_file(
            "bad-ke-line",
            "bad_ke.obj",
            1,
            "bad_ke.mtl: MTL line 3: Ke expects 1 or 3 numbers, got \"abc def\"",
        ),
        scene_file(
            "usemtl-nosuch-warns",
            "usemtl_nosuch.obj",
            0,
            "usemtl \"nosuch\" names no material",
        ),
        // 9: references.
        reference("reference-png", "srgb.png", 1, "must be a linear OpenEXR"),
        reference("reference-png-named-exr", "png_named.exr", 1, "not OpenEXR"),
        reference(
            "reference-nan",
            "nan.exr",
            1,
            "NaN or infinite value at pixel (0, 0)",
        ),
        reference(
            "reference-inf",
            "inf.exr",
            1,
            "NaN or infinite value at pixel (0, 0)",
        ),
        reference(
            "reference-negative",
            "negative.exr",
            1,
            "negative value at pixel (0, 0)",
        ),
        reference("reference-zeros", "zeros.exr", 1, "black everywhere"),
        // 6: emission that overflows the accumulation.
        case_of(
            "furnace-le-huge",
            plus(cpu("furnace"), &["--le", "1e38"]),
            1,
            "Le 1e38 must be in [0, 1e10]",
        ),
        scene_file(
            "mtl-ke-huge-clamped",
            "huge_ke.obj",
            0,
            "clamped 1 materials",
        ),
        // Issue 15: scene flags and required glTF extensions.
        scene_file(
            "gltf-requires-draco",
            "requires_draco.gltf",
            1,
            "requires extension KHR_draco_mesh_compression (Draco-compressed meshes)",
        ),
        case_of(
            "camera-unknown-name",
            plus(cpu("cornell"), &["--camera", "Side"]),
            1,
            "--camera Side: no camera \"Side\" in the scene (expected a name or an index: \
                 the scene has 0 \"default\")",
        ),
        cornell(
            "camera-index-out-of-range",
            &["--camera", "1"],
            1,
            "no camera \"1\"",
        ),
        cornell(
            "add-lights-too-many",
            &["--add-lights", "1000001"],
            2,
            "--add-lights <ADD_LIGHTS>",
        ),
        cornell("add-lights-negative", &["--add-lights", "-3"], 2, "-3"),
        cornell(
            "add-light-power-nan",
            &["--add-lights", "10", "--add-light-power", "nan"],
            2,
            "--add-light-power <ADD_LIGHT_POWER>",
        ),
        cornell(
            "add-light-size-negative",
            &["--add-lights", "10", "--add-light-size=-1"],
            2,
            "--add-light-size <ADD_LIGHT_SIZE>",
        ),
        // --materials' uniform gloss: a roughness outside [0, 1], an unknown material.
        cornell(
            "materials-roughness-above-one",
            &["--materials", "metal:2"],
            2,
            "(R a roughness in [0, 1])",
        ),
        cornell(
            "materials-unknown",
            &["--materials", "glass:0.1"],
            2,
            "expected scene, diffuse, dielectric:R or metal:R",
        ),
        // Issue 15: environment light flags.
        cornell("sky-negative", &["--sky=-1,0,0"], 1, "--sky -1,0,0"),
        cornell("sky-nan", &["--sky", "nan"], 1, "must be finite"),
        cornell(
            "sky-two-values",
            &["--sky", "1,2"],
            1,
            "expected R,G,B or one number",
        ),
        cornell(
            "env-missing",
            &["--env", "/nonexistent/sky.hdr"],
            1,
            "/nonexistent/sky.hdr",
        ),
        cornell("env-not-hdr", &["--env", &g("srgb.png")], 1, ".hdr or .exr"),
        cornell(
            "env-nan-pixel",
            &["--env", &g("nan.exr")],
            1,
            "nan.exr: pixel (0, 0)",
        ),
        cornell(
            "env-negative-pixel",
            &["--env", &g("negative.exr")],
            1,
            "negative.exr: pixel (0, 0)",
        ),
        cornell(
            "env-undecodable",
            &["--env", &g("png_named.exr")],
            1,
            "cannot decode",
        ),
        cornell(
            "env-absurd-size",
            &["--env", &g("huge.hdr")],
            1,
            "100000x2 pixels is outside",
        ),
        cornell(
            "env-intensity-nan",
            &["--env", &g("zeros.exr"), "--env-intensity", "nan"],
            1,
            "--env-intensity: intensity NaN",
        ),
        cornell(
            "env-intensity-alone",
            &["--env-intensity", "2"],
            1,
            "--env-intensity scales --env or --sky",
        ),
        cornell(
            "sky-and-env",
            &["--sky", "1", "--env", &g("zeros.exr")],
            2,
            "cannot be used with",
        ),
        cornell(
            "add-light-power-without-count",
            &["--add-light-power", "5"],
            1,
            "need --add-lights N",
        ),
        cornell(
            "add-lights-radiance-overflow",
            &[
                "--add-lights",
                "1",
                "--add-light-power",
                "1e30",
                "--add-light-size",
                "1e-4",
            ],
            1,
            "--add-light-size 1e-4: bad scene option: add-lights: power 1e30",
        ),
        cornell(
            "add-lights-control",
            &["--add-lights", "20"],
            0,
            "added 20 lights",
        ),
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
        // A method's frame (info --method) is checked before the adapter is opened.
        case(
            "info-method-unknown",
            &["info", "--method", "nosuch"],
            1,
            "--method: unknown method \"nosuch\"",
        ),
        case(
            "info-method-cache-bounded",
            &["info", "--method", "ris+cache", "--bounces", "3"],
            1,
            "--method: method ris+cache: the radiance cache holds the light of every bounce",
        ),
        // Issue 38: with no arguments it ran `smoke` (a GPU job writing into ./out).
        case("38-no-arguments-prints-help", &[], 2, "Usage: restir-demo").no_out(),
        // Issue 38: "unexpected argument '-1'", which named no flag.
        cornell(
            "38-bounces-negative",
            &["--bounces", "-1"],
            2,
            "invalid value '-1' for '--bounces",
        ),
        // Issue 38: a camera overflow after the adapter, naming no flag.
        case_of(
            "38-dolly-fraction-overflow",
            gpu_render("4x4", &["--animation", "dolly", "--dolly-fraction=-1e38"]),
            1,
            "--dolly-fraction -1e38: frame 1's camera is not valid",
        ),
        // Issue 38: restir-gi's debug views at 1x1 failed ("image of 1x1 needs 1 pixels, has
        // 4": a padded buffer read whole). 9 files: the 6 images and its views M, rejected and
        // refused.
        case_of(
            "38-debug-views-1x1",
            gpu_render("1x1", &["--debug-views", "--animation", "orbit"]),
            0,
            "",
        )
        .after(|out| expect_files(out, 9)),
        // Issue 38: the debug views were written before the images, so a failed image write
        // left them behind (a directory planted at the last image's name makes it fail).
        case_of(
            "38-debug-views-written-with-the-images",
            gpu_render("4x4", &["--debug-views"]),
            1,
            "cornell-restir-gi-combined.png",
        )
        .before(|_, out| {
            std::fs::create_dir_all(out.join("cornell-restir-gi-combined.png")).unwrap();
        }),
    ]
}

/// `restir-demo render` of cornell with restir-gi (a GPU method with debug views) at `size`,
/// two frames, with `extra` flags.
fn gpu_render(size: &str, extra: &[&str]) -> Vec<String> {
    let base = [
        "render",
        "--scene",
        "cornell",
        "--method",
        "restir-gi",
        "--size",
        size,
        "--frames",
        "2",
    ];
    base.iter().chain(extra).map(|s| s.to_string()).collect()
}

/// That `out` holds `count` files.
fn expect_files(out: &Path, count: usize) -> Result<(), String> {
    let files = files_under(out);
    match files.len() == count {
        true => Ok(()),
        false => Err(format!("expected {count} files, found {files:?}")),
    }
}

/// The radiance cache's range and convergence, said as warnings where the scene still renders;
/// grid knobs that no image size fixes, named as knobs (each case failed on the binary
/// before: no warning, or "use a larger --size").
fn cache_and_knob_cases(g: &Path) -> Vec<Case> {
    // A closed white box lit by a lamp of 1e10: beyond the cache's 65504 per channel.
    let bright = g.join("bright_box.obj");
    std::fs::write(
        g.join("bright_box.mtl"),
        "newmtl white\nKd 0.7 0.7 0.7\nnewmtl lamp\nKd 0 0 0\nKe 1e10 1e10 1e10\n",
    )
    .unwrap();
    std::fs::write(
        &bright,
        "mtllib bright_box.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n\
         v 1 1 1\nv 0 1 1\nv 0.4 0.99 0.4\nv 0.6 0.99 0.4\nv 0.6 0.99 0.6\nv 0.4 0.99 0.6\n\
         usemtl white\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\nf 1 4 3 2\nf 5 6 7 8\n\
         usemtl lamp\nf 9 10 11 12\n",
    )
    .unwrap();
    let cache_with = |method: &str, scene: &str, extra: &[&str]| {
        let base = [
            "render",
            "--scene",
            scene,
            "--method",
            method,
            "--bounces",
            "64",
            "--size",
            "32x32",
            "--frames",
            "1",
        ];
        base.iter()
            .chain(extra)
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
    };
    let cache = |scene: &str, extra: &[&str]| cache_with("ris+cache", scene, extra);
    vec![
        case_of(
            "cache-range",
            cache(
                &bright.display().to_string(),
                &["--eye=0.5,0.5,0.1", "--target=0.5,0.5,1"],
            ),
            0,
            "the radiance cache holds it in units of",
        ),
        case_of(
            "cache-albedo-one",
            cache("furnace", &["--rho", "1"]),
            0,
            "its radiance does not converge",
        ),
        case_of(
            "cache-min-cell-size",
            cache_with("ris+cache:min-cell-size=1e38", "cornell", &[]),
            1,
            "the cache's cells: min-cell-size=100000000000000000000000000000000000000",
        ),
        case(
            "wgi-projected-size",
            &[
                "render",
                "--scene",
                "cornell",
                "--method",
                "world-restir-gi:projected-size=4096",
                "--size",
                "64x64",
            ],
            1,
            "world-restir-gi's cells: min-cell-size=",
        ),
        // colonnade's eye is 47 m from its target: an 18-degree orbit leaves the hall, and
        // the frame's reference was black (every method's relMSE read 0, silently).
        case(
            "compare-black-reference",
            &[
                "compare",
                "--scene",
                "colonnade",
                "--animation",
                "orbit",
                "--frames",
                "18",
                "--eval-every",
                "9",
                "--size",
                "16x16",
                "--reference-spp",
                "2",
                "--methods",
                "ris",
                "--no-cache",
                "--quiet",
            ],
            1,
            "the reference of frame 17 of the orbit camera: the camera at",
        ),
    ]
}

/// Cases that depend on the adapter's limits (skipped, with the reason printed, where the
/// limit is above what they need).
fn adapter_cases(gen_dir: &Path) -> Vec<Case> {
    let mut cases = Vec::new();

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
        tests::skip("bad_inputs smoke-above-binding-limit: no adapter or a limit above 1 GiB");
    }
    // Issue 27, 27: a 4096 x 2048 environment map (the documented maximum before) above the
    // GPU's storage binding (32 bytes a pixel): the error names --env and the file.
    let env_bytes = 4096 * 2048 * 32;
    if let Some(l) = adapter
        .as_deref()
        .and_then(|i| limit(i, "max_storage_buffer_binding_size"))
        && l < env_bytes
    {
        let big = gen_dir.join("big_env.hdr");
        image::Rgb32FImage::from_pixel(4096, 2048, image::Rgb([0.5, 0.5, 0.5]))
            .save(&big)
            .unwrap();
        let big = big.display().to_string();
        cases.push(case(
            "27-27-env-above-binding-limit",
            &[
                "render", "--method", "nee", "--size", "4x4", "--frames", "1", "--env", &big,
            ],
            1,
            &format!("--env {big}"),
        ));
    } else {
        tests::skip(
            "bad_inputs 27-27-env-above-binding-limit: no adapter or a limit above 256 MiB",
        );
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
        _ => tests::skip(
            "bad_inputs world-restir-on-gl: no GL adapter with under 20 storage buffers",
        ),
    }

    cases
}

/// Issue 60 (hardening the round-4 surfaces): each case failed on the binary of 37a8bb8 (NaN
/// pixels, a 10 KB error line, an error that did not name `--size`).
fn issue_60_cases(g: &Path) -> Vec<Case> {
    let gpu = |extra: &[&str]| {
        let base = [
            "render", "--method", "ris", "--size", "8x8", "--frames", "1",
        ];
        base.iter()
            .chain(extra)
            .map(|s| s.to_string())
            .collect::<Vec<_>>()
    };
    // The only light a lamp of area 1e-20 (NaN pixels before: its normal's squared length
    // underflowed): dropped with a warning, the image finite (black).
    let tiny = g.join("tiny_lamp.obj");
    std::fs::write(
        g.join("tiny_lamp.mtl"),
        "newmtl grey\nKd 0.7 0.7 0.7\nnewmtl lamp\nKd 0 0 0\nKe 10 10 10\n",
    )
    .unwrap();
    std::fs::write(
        &tiny,
        "mtllib tiny_lamp.mtl\nv -1 0 -1\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv 0 1 0\n\
         v 1.4142e-10 1 0\nv 0 1 1.4142e-10\nusemtl grey\nf 1 2 3 4\nusemtl lamp\nf 5 6 7\n",
    )
    .unwrap();
    let tiny = tiny.display().to_string();
    let long_name = "x".repeat(10_000);
    let mut v = vec![
        case_of(
            "60-denoise-phi-luminance-zero",
            gpu(&["--denoise", "phi-luminance=0"]),
            1,
            "phi-luminance 0 must be in 1e-6",
        ),
        case_of(
            "60-sky-1e30-denoise",
            gpu(&["--sky", "1e30", "--denoise"]),
            1,
            "at most 1e10",
        ),
        case_of(
            "60-lamp-of-area-1e-20",
            gpu(&["--scene", &tiny]),
            0,
            "of an area below 1e-18",
        ),
        case_of(
            "60-long-method-name",
            vec!["render".into(), "--method".into(), long_name],
            1,
            " characters)...",
        ),
    ];
    // A size whose G-buffer (64 bytes a pixel) is one row above the binding limit.
    match info(&[])
        .as_deref()
        .and_then(|i| limit(i, "max_storage_buffer_binding_size"))
    {
        Some(l) if l / 64 / 2048 < 16384 => {
            let h = l / 64 / 2048;
            let size = format!("2048x{}", h + 1);
            let needle = format!("--size {size}: the G-buffer needs");
            let mut c = case_of("60-size-above-binding-limit", gpu(&[]), 1, &needle);
            c.args[4] = size;
            v.push(c);
        }
        _ => {
            tests::skip("bad_inputs 60-size-above-binding-limit: no adapter or a limit above 2 GiB")
        }
    }
    v
}

#[test]
fn bad_inputs_are_refused_with_their_cause_and_leave_nothing_behind() {
    let tmp = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bad_inputs");
    let _ = std::fs::remove_dir_all(&tmp);
    let gen_dir = generate(&tmp.join("generated"));
    let mut cases = cases(&tmp, &gen_dir);
    cases.extend(new_input_cases(&tmp, &gen_dir));
    cases.extend(adapter_cases(&gen_dir));
    cases.extend(cache_and_knob_cases(&gen_dir));
    cases.extend(issue_60_cases(&gen_dir));
    let only = std::env::var("BAD_INPUTS_ONLY").ok();
    let mut failures = Vec::new();
    let mut ran = 0;
    for c in &cases {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|n| c.name.contains(n)))
        {
            continue;
        }
        ran += 1;
        let (problems, err) = run_case(c, &tmp);
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
        ran,
        failures.join("\n")
    );
}

/// Runs a case (its output under `tmp/out/NAME`); returns what went wrong and its stderr.
fn run_case(c: &Case, tmp: &Path) -> (Vec<String>, String) {
    let out = tmp.join("out").join(c.name);
    // stderr goes to a file and the run has a deadline: an unbounded read (a link to
    // /dev/zero read whole) fails the case instead of hanging the test.
    let log = tmp.join(format!("{}.stderr", c.name));
    let mut problems = Vec::new();
    let status = wait_with_deadline(start(c, &out, &log), &mut problems);
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
    problems.extend(check_outputs(c, &out));
    if let Some(after) = &c.after
        && let Err(e) = after(&out)
    {
        problems.push(e);
    }
    (problems, err)
}

/// Starts the case's run, stderr into `log`, after its `before` (given the run's process id).
fn start(c: &Case, out: &Path, log: &Path) -> std::process::Child {
    // Through a shell that waits for a line on stdin, then limits the address space and
    // execs restir-demo (same process id): `before` sees the id the run will have.
    let mut cmd = Command::new("sh");
    let limit = c.mem_mib.map_or(String::new(), |m| {
        format!("ulimit -v {} || exit 90; ", m * 1024)
    });
    cmd.arg("-c")
        .arg(format!("read _ignored; {limit}exec \"$0\" \"$@\""))
        .arg(exe())
        .args(&c.args);
    let wants_out = !c.no_out && c.args.first().is_some_and(|a| a != "info");
    if wants_out && !c.args.iter().any(|a| a == "--out") {
        cmd.arg("--out").arg(out);
    }
    for (k, v) in &c.env {
        cmd.env(k, v);
    }
    cmd.stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).expect("stderr log"));
    let mut child = cmd.spawn().expect("run restir-demo");
    if let Some(before) = &c.before {
        before(child.id(), out);
    }
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().expect("stdin");
        let _ = stdin.write_all(b"go\n");
    }
    child
}

/// The run's exit status, or `None` when it ran past [`CASE_TIMEOUT`] (then killed, and said
/// in `problems`).
fn wait_with_deadline(
    mut child: std::process::Child,
    problems: &mut Vec<String>,
) -> Option<std::process::ExitStatus> {
    let start = Instant::now();
    loop {
        if let Some(st) = child.try_wait().expect("wait for restir-demo") {
            return Some(st);
        }
        if start.elapsed() > CASE_TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            problems.push(format!(
                "still running after {} s (an unbounded read or a hang): killed",
                CASE_TIMEOUT.as_secs()
            ));
            return None;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A failed run must leave nothing in `out`; a successful one only finite, readable EXRs.
fn check_outputs(c: &Case, out: &Path) -> Vec<String> {
    let mut problems = Vec::new();
    if c.code != 0 {
        let left = files_under(out);
        if !left.is_empty() {
            problems.push(format!("a failed run left files behind: {left:?}"));
        }
        return problems;
    }
    for f in files_under(out) {
        // Links a case planted (at names the run must not use) are not its outputs.
        let link = std::fs::symlink_metadata(&f).is_ok_and(|m| m.is_symlink());
        if f.extension().is_some_and(|e| e == "exr") && !link {
            match read_exr(&f) {
                Ok(img) if img.is_finite() => {}
                Ok(_) => problems.push(format!("{} has NaN/Inf pixels", f.display())),
                Err(e) => problems.push(format!("{}: unreadable: {e}", f.display())),
            }
        }
    }
    problems
}

/// `info` stands on an adapter that cannot run every method (GL: 16 storage buffers a stage,
/// the renderer's pass needs 20): it names each such method with its reason and exits 0. It
/// exited 1 after its largest-image listing came in, which turned bad_inputs' GL case into a
/// skip.
#[test]
fn info_names_the_methods_an_adapter_cannot_run() {
    let (code, out, err) = run_info(&[("WGPU_BACKEND", "gl")]);
    if err.contains("no GPU adapter found") {
        tests::skip("bad_inputs info on GL: no GL adapter");
        return;
    }
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("largest image of cornell"), "{out}");
    if limit(&out, "max_storage_buffers_per_shader_stage").is_some_and(|l| l < 20) {
        assert!(
            out.contains("  ris: not on this adapter: ") && out.contains("storage buffers"),
            "{out}"
        );
    }
}

/// `info` lists the methods before it opens an adapter: on a machine without one (here an
/// adapter name that matches none) the list is printed, then the adapter's error (it needed
/// the adapter first).
#[test]
fn info_lists_the_methods_without_an_adapter() {
    let (code, out, err) = run_info(&[("WGPU_ADAPTER_NAME", "no-such-adapter")]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("WGPU_ADAPTER_NAME"), "{err}");
    for name in [
        "methods (--method",
        "  ris:",
        "  restir-gi:",
        "  world-restir-gi+cache:",
    ] {
        assert!(out.contains(name), "{name:?} missing from: {out}");
    }
}
