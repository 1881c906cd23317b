//! `cargo xtask test` and `cargo xtask demo`: the README's two commands.
//!
//! Both first make sure a Vulkan driver is present. On a machine without one (a fresh headless
//! Debian box, CI) they install Mesa's CPU driver, lavapipe, when running as root with apt-get;
//! otherwise they print the exact command to run and exit non-zero. `test` also makes sure a
//! virtual X server (`xvfb-run`) exists for the viewer's window tests, installed the same way.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

mod device_bench;
mod suite;
mod summary;

const LAVAPIPE_PACKAGES: [&str; 2] = ["mesa-vulkan-drivers", "libvulkan1"];

/// A virtual X server for the viewer's window tests (`xvfb-run`) and the X11 client libraries
/// winit loads at run time.
const XVFB_PACKAGES: [&str; 6] = [
    "xvfb",
    "xauth",
    "libxkbcommon-x11-0",
    "libx11-xcb1",
    "libxcursor1",
    "libxi6",
];

/// The shared libraries of [`XVFB_PACKAGES`] that winit opens on X11.
const X11_LIBRARIES: [&str; 4] = [
    "libxkbcommon-x11.so.0",
    "libX11-xcb.so.1",
    "libXcursor.so.1",
    "libXi.so.6",
];

/// Set for the tests by `cargo xtask test`: a virtual X server is there, so the window tests
/// fail instead of skipping when they find none.
const VIEW_TESTS_ENV: &str = "RESTIR_VIEW_TESTS_REQUIRE_DISPLAY";

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let task = args.next();
    let rest: Vec<String> = args.collect();
    let result = match task.as_deref() {
        Some("test") => test(&rest),
        Some("demo") => demo(&rest),
        Some("results") => results(&rest),
        Some("device-bench") => device_bench::main(&workspace_root(), &rest),
        _ => {
            eprintln!(
                "usage: cargo xtask <test|demo|results|device-bench> [args...]\n  test  run every test of the \
                 workspace on the available adapter, the viewer's under Xvfb, and print each \
                 binary's time and the slowest tests ([CARGO ARGS] [-- TEST ARGS])\n  demo  build \
                 in release, render cornell and many-lights with world-restir-gi (and denoised) into \
                 out/ and compare ris, restir-di, restir-gi and world-restir-gi on both (with \
                 args: run `restir-demo` with them instead)\n  results  regenerate \
                 docs/results.md: run the comparisons of its parts, then write it from their \
                 reports ([PART] [COMPARE ARGS]; `results assemble`: write it from the \
                 committed reports, rendering nothing)\n  device-bench  build every bench and the \
                 demo into one bundle for a GPU machine, or run it ([--prepare] [--run \
                 [--lavapipe] [--budget S]]; --help)"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `cargo xtask test [CARGO ARGS] [-- TEST ARGS]`: cargo args select test targets (e.g. `-p
/// tests --test paths`, then no doc tests run); test args go to every test binary (filters).
fn test(args: &[String]) -> Result<(), String> {
    ensure_vulkan()?;
    let display = ensure_xvfb()?;
    // Print the adapter up front, so every log names the device the tests ran on.
    cargo(&["run", "--quiet", "--package", "demo", "--", "info"])?;
    let (cargo_args, test_args) = match args.iter().position(|a| a == "--") {
        Some(i) => (&args[..i], &args[i + 1..]),
        None => (args, &[][..]),
    };
    let mut envs: Vec<(&str, &str)> = Vec::new();
    if display {
        envs.push((VIEW_TESTS_ENV, "1"));
    }
    let gpu_present =
        Path::new("/dev/dri").exists() || std::env::var_os("WGPU_ADAPTER_NAME").is_some();
    if !gpu_present && mesa_major().is_some_and(|m| m >= RAY_QUERY_MESA_MAJOR) {
        // lavapipe is the adapter and has ray queries: their tests must run, not skip.
        eprintln!("xtask: Mesa with ray queries: RESTIR_REQUIRE_RAY_QUERY=1");
        envs.push(("RESTIR_REQUIRE_RAY_QUERY", "1"));
    }
    suite::run(&workspace_root(), cargo_args, test_args, &envs)
}

/// The size and frames of everything the default demo renders.
const DEMO_SIZE: &str = "256x256";
const DEMO_FRAMES: &str = "16";

/// A comparison of the demo: `methods` at equal time against `ris` on many-lights and cornell
/// at the demo's size and frames, into `out`, with `extra` flags.
fn demo_compare<'a>(methods: &'a str, extra: &[&'a str], out: &'a str) -> Vec<&'a str> {
    let mut args = vec![
        "compare",
        "--scene",
        "many-lights,cornell",
        "--methods",
        methods,
        "--equal-time-to",
        "ris",
    ];
    args.extend(extra);
    args.extend([
        "--size",
        DEMO_SIZE,
        "--frames",
        DEMO_FRAMES,
        "--reference-spp",
        "128",
        "--out",
        out,
        "--no-exr",
    ]);
    args
}

/// The default demo's comparison: the methods that win at the default paths (restir-gi and
/// world-restir-gi for the indirect light, restir-di for the direct light) against their
/// baseline `ris`: a few minutes on two CPU cores with lavapipe. The `+cache` methods need
/// unbounded paths (`--bounces 64`), so they cannot share this run: [`demo_cache_compare`]
/// is printed instead.
fn demo_default_compare() -> Vec<&'static str> {
    demo_compare(
        "ris,restir-di,restir-gi,world-restir-gi",
        &[],
        "out/compare",
    )
}

/// The comparison of the radiance cache at unbounded paths that the demo prints (not runs:
/// its reference at 64 bounces would about double the demo's time).
fn demo_cache_compare() -> Vec<&'static str> {
    demo_compare("ris,ris+cache", &["--bounces", "64"], "out/compare-cache")
}

/// The configurations of docs/results.md: (part, title, output folder, compare arguments). The
/// default depth is what a user gets; unbounded paths are what the radiance cache is measured
/// against; one bounce without MIS is the comparison every method was first measured in; the
/// glossy scenes are where resampling is hard (restir-di reuses light at glossy vertices, the
/// other stages leave most of them to the path; a part of their own: their own scenes, at
/// 128x128, every kernel of theirs specialized for glossy materials).
/// A part's arguments follow [`RESULTS_COMMON`]'s; one that names `--scene` or `--size` replaces
/// [`RESULTS_SCENES`] or [`RESULTS_SIZE`].
const RESULTS_PARTS: [(&str, &str, &str, &[&str]); 5] = [
    (
        "default-depth",
        "the default paths (3 bounces, MIS)",
        "docs/results/default-depth",
        &[
            "--methods",
            "nee,ris,world-restir,restir-di,world-restir+restir-di,restir-gi,\
             restir-gi+world-restir,world-restir-gi",
        ],
    ),
    (
        "denoised",
        "denoised (the default paths, `--denoise`)",
        "docs/results/denoised",
        &["--methods", "ris,restir-gi,world-restir-gi", "--denoise"],
    ),
    (
        "cache",
        "unbounded paths and the radiance cache",
        "docs/results/cache",
        &[
            "--methods",
            "ris,ris+cache,world-restir,world-restir+cache,restir-gi+world-restir,\
             restir-gi+world-restir+cache",
            "--bounces",
            "64",
        ],
    ),
    (
        "one-bounce",
        "one bounce without MIS",
        "docs/results",
        &[
            "--methods",
            "nee,ris,world-restir,restir-di,world-restir+restir-di,world-restir:unified,\
             world-restir:biased,world-restir:one-over-z,world-restir:paper-grid,\
             world-restir:no-reuse",
            "--bounces",
            "1",
            "--mis",
            "off",
        ],
    ),
    (
        "glossy",
        "glossy materials (the default paths)",
        "docs/results/glossy",
        &[
            "--scene",
            "glossy,cornell-glossy",
            "--size",
            "128x128",
            "--methods",
            "nee,ris,restir-di,world-restir,restir-gi,world-restir-gi,\
             restir-di+world-restir-gi+world-restir",
        ],
    ),
];

/// The scenes and size of a part that names none.
const RESULTS_SCENES: [&str; 2] = ["--scene", "many-lights,cornell"];
const RESULTS_SIZE: [&str; 2] = ["--size", "256x256"];

/// The arguments every part of docs/results.md shares.
const RESULTS_COMMON: [&str; 7] = [
    "compare",
    "--frames",
    "18",
    "--reference-spp",
    "256",
    "--no-exr",
    "--cache",
];

/// Scenes `cargo xtask demo` (no arguments) renders with [`DEMO_METHOD`] at 256x256, each
/// well under a minute in release on a 2-core lavapipe machine; the images land in
/// `out/<scene>/`.
const DEMO_SCENES: [&str; 2] = ["cornell", "many-lights"];

/// The method the demo renders: world-space ReSTIR GI, the one the README recommends for a
/// moving camera and, on a CPU adapter such as this demo's, for the lowest error per GPU time
/// (docs/results.md).
const DEMO_METHOD: &str = "world-restir-gi";

fn demo(args: &[String]) -> Result<(), String> {
    ensure_vulkan()?;
    let base = ["run", "--release", "--package", "demo", "--"];
    if args.is_empty() {
        let root = workspace_root();
        for scene in DEMO_SCENES {
            let out = format!("out/{scene}");
            let mut run = base.to_vec();
            run.extend(["render", "--scene", scene, "--method", DEMO_METHOD]);
            run.extend([
                "--size",
                DEMO_SIZE,
                "--frames",
                DEMO_FRAMES,
                "--seed",
                "1",
                "--out",
                &out,
            ]);
            // Last: `--denoise` takes an optional value (its knobs).
            run.push("--denoise");
            cargo(&run)?;
        }
        let mut run = base.to_vec();
        run.extend(demo_default_compare());
        cargo(&run)?;
        // `render` names its files SCENE-METHOD-IMAGE with the method's other characters as '-'.
        let tag = DEMO_METHOD.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "-");
        let denoised: Vec<String> = DEMO_SCENES
            .iter()
            .map(|scene| {
                let file = format!("out/{scene}/{scene}-{tag}-denoised.png");
                root.join(file).display().to_string()
            })
            .collect();
        println!(
            "xtask: rendered {DEMO_METHOD}, the method the README recommends for a moving \
             camera and for the lowest error per time on a CPU adapter: {} (the last frame \
             denoised; beside it the {DEMO_FRAMES} frames \
             accumulated, -combined, -direct and -indirect, each .png and .exr)",
            denoised.join(", ")
        );
        let report = root.join("out/compare/report.md");
        println!(
            "xtask: compared ris, restir-di (direct light), restir-gi and world-restir-gi \
             (indirect light) at equal time against ris ({}); what each measured, on this \
             machine:",
            report.display()
        );
        for line in summary::method_lines(&report.with_extension("json"))? {
            println!("  {line}");
        }
        println!(
            "xtask: the +cache methods need unbounded paths and a comparison of their own: \
             cargo xtask demo {}",
            demo_cache_compare().join(" ")
        );
        return Ok(());
    }
    let mut run = base.to_vec();
    run.extend(args.iter().map(String::as_str));
    cargo(&run)
}

/// `cargo xtask results [PART] [compare arguments]`: runs every part of docs/results.md (or the
/// one named: default-depth, cache, one-bounce, glossy; `assemble`: none, so nothing is
/// rendered) into its folder, then writes docs/results.md: a summary table from the parts' `report.json`
/// ([`summary::summary`]), the parts' `report.md` (image links pointing into docs/results/) and
/// docs/results-notes.md.
fn results(args: &[String]) -> Result<(), String> {
    let (only, extra) = match args.first().map(String::as_str) {
        Some(a) if a == "assemble" || RESULTS_PARTS.iter().any(|(p, ..)| *p == a) => {
            (Some(a), &args[1..])
        }
        _ => (None, args),
    };
    let root = workspace_root();
    for (part, _, dir, part_args) in RESULTS_PARTS {
        if only.is_some_and(|o| o != part) {
            continue;
        }
        ensure_vulkan()?;
        let mut run = vec!["run", "--release", "--package", "demo", "--"];
        run.extend(RESULTS_COMMON);
        run.extend(["out/cache", "--out", dir]);
        for default in [RESULTS_SCENES, RESULTS_SIZE] {
            if !part_args.contains(&default[0]) {
                run.extend(default);
            }
        }
        run.extend(part_args);
        run.extend(extra.iter().map(String::as_str));
        cargo(&run)?;
    }
    let reports: Vec<(&str, PathBuf)> = RESULTS_PARTS
        .iter()
        .map(|(_, title, dir, _)| (*title, root.join(dir).join("report.json")))
        .collect();
    let reports: Vec<(&str, &Path)> = reports.iter().map(|(t, p)| (*t, p.as_path())).collect();
    let mut body = summary::summary(&reports)?;
    for (_, title, dir, _) in RESULTS_PARTS {
        let report = root.join(dir).join("report.md");
        let text = std::fs::read_to_string(&report)
            .map_err(|e| format!("reading {} (run its part first): {e}", report.display()))?;
        let link = dir.trim_start_matches("docs/");
        body += &text
            .replacen(
                "# Speed against error",
                &format!("# Speed against error: {title}"),
                1,
            )
            .replace(
                "](error_vs_time.svg)",
                &format!("]({link}/error_vs_time.svg)"),
            )
            .replace("](strip.jpg)", &format!("]({link}/strip.jpg)"));
        body += "\n";
    }
    let header = "<!-- Generated by `cargo xtask results` from the reports under results/ and \
                  results-notes.md (the hand-written measurements that need several runs); \
                  edit those, not this file. -->\n\n";
    let notes_path = root.join("docs/results-notes.md");
    let notes = std::fs::read_to_string(&notes_path)
        .map_err(|e| format!("reading {}: {e}", notes_path.display()))?;
    let out = root.join("docs/results.md");
    std::fs::write(&out, format!("{header}{body}{notes}"))
        .map_err(|e| format!("writing {}: {e}", out.display()))?;
    println!("xtask: wrote {}", out.display());
    Ok(())
}

fn cargo(args: &[&str]) -> Result<(), String> {
    cargo_with_env(args, &[])
}

fn cargo_with_env(args: &[&str], envs: &[(&str, &str)]) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(&cargo);
    cmd.envs(envs.iter().copied()).current_dir(workspace_root());
    run(&mut cmd, "cargo", args)
}

/// Runs `cmd` (the program `name`) with `args`; an error unless it exits 0.
fn run(cmd: &mut Command, name: &str, args: &[&str]) -> Result<(), String> {
    let status = cmd
        .args(args)
        .status()
        .map_err(|e| format!("could not run {name}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{name} {}` failed ({status})", args.join(" ")))
    }
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Makes sure a Vulkan loader and at least one driver exist, installing lavapipe if allowed.
fn ensure_vulkan() -> Result<(), String> {
    if !cfg!(target_os = "linux") {
        return Ok(()); // Metal / DX12 machines need no help from us.
    }
    if let Ok(backend) = std::env::var("WGPU_BACKEND")
        && !backend.to_lowercase().contains("vulkan")
    {
        return Ok(()); // the user chose another backend (e.g. gl)
    }
    if vulkan_present() {
        return ensure_ray_query_mesa();
    }
    let install = format!("apt-get install -y {}", LAVAPIPE_PACKAGES.join(" "));
    if !is_root() || !on_path("apt-get") {
        return Err(format!(
            "no Vulkan driver found. Install Mesa's CPU Vulkan driver (lavapipe):\n    \
             sudo apt-get update && sudo {install}\nor install your GPU's Vulkan driver, then \
             run this command again."
        ));
    }
    // On Debian 12, straight from bookworm-backports (Mesa 25, ray queries): one install.
    let backports = use_bookworm_backports()?;
    let from = if backports {
        " from bookworm-backports"
    } else {
        ""
    };
    eprintln!(
        "xtask: no Vulkan driver found; installing lavapipe{from}: apt-get update && {install}"
    );
    apt_install(&LAVAPIPE_PACKAGES, backports.then_some(BACKPORTS))?;
    if vulkan_present() {
        eprintln!("xtask: lavapipe installed");
        Ok(())
    } else {
        Err("installed lavapipe but still found no Vulkan loader and driver".into())
    }
}

/// The Debian 12 suite lavapipe with ray queries (Mesa 25) comes from.
const BACKPORTS: &str = "bookworm-backports";

/// The first Mesa whose lavapipe exposes wgpu's `EXPERIMENTAL_RAY_QUERY`.
const RAY_QUERY_MESA_MAJOR: u32 = 25;

/// Whether lavapipe should come from bookworm-backports (Debian 12 as root with apt-get): then
/// makes sure that suite of the machine's own Debian mirror (read from its apt sources) is an
/// apt source. Anywhere else false.
fn use_bookworm_backports() -> Result<bool, String> {
    let bookworm = std::fs::read_to_string("/etc/os-release")
        .is_ok_and(|s| s.lines().any(|l| l == "VERSION_CODENAME=bookworm"));
    if !bookworm || !is_root() || !on_path("apt-get") {
        return Ok(false);
    }
    let mirror = debian_mirror().ok_or(
        "Debian 12 without a bookworm suite in /etc/apt/sources.list{,.d}: cannot find the \
         mirror to take Mesa 25 (ray queries) from bookworm-backports",
    )?;
    let sources = Path::new("/etc/apt/sources.list.d/restir-bookworm-backports.sources");
    if !apt_sources().contains("bookworm-backports") {
        let stanza = format!(
            "Types: deb\nURIs: {mirror}\nSuites: bookworm-backports\nComponents: main\n\
             Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n"
        );
        std::fs::write(sources, stanza)
            .map_err(|e| format!("writing {}: {e}", sources.display()))?;
    }
    Ok(true)
}

/// On Debian 12 as root with lavapipe older than Mesa 25 already installed: upgrades it from
/// bookworm-backports, so that the ray-query tracer is tested. Anywhere else it changes nothing.
fn ensure_ray_query_mesa() -> Result<(), String> {
    if !lavapipe_installed() || mesa_major().is_some_and(|m| m >= RAY_QUERY_MESA_MAJOR) {
        return Ok(());
    }
    if !use_bookworm_backports()? {
        return Ok(());
    }
    eprintln!("xtask: installing lavapipe from bookworm-backports (Mesa 25: ray queries)");
    apt_install(&LAVAPIPE_PACKAGES, Some(BACKPORTS))?;
    match mesa_major() {
        Some(m) if m >= RAY_QUERY_MESA_MAJOR => Ok(()),
        m => Err(format!(
            "installed lavapipe from bookworm-backports but found Mesa {m:?}"
        )),
    }
}

fn lavapipe_installed() -> bool {
    mesa_major().is_some()
}

/// The major version of the installed `mesa-vulkan-drivers` package.
fn mesa_major() -> Option<u32> {
    let out = Command::new("dpkg-query")
        .args(["-W", "-f", "${Version}", "mesa-vulkan-drivers"])
        .output()
        .ok()?;
    let version = String::from_utf8_lossy(&out.stdout);
    version.split(['.', ':']).next()?.trim().parse().ok()
}

/// Every apt source line of the machine.
fn apt_sources() -> String {
    let mut all = std::fs::read_to_string("/etc/apt/sources.list").unwrap_or_default();
    if let Ok(dir) = std::fs::read_dir("/etc/apt/sources.list.d") {
        for entry in dir.flatten() {
            all.push('\n');
            all.push_str(&std::fs::read_to_string(entry.path()).unwrap_or_default());
        }
    }
    all
}

/// The URI of the machine's Debian mirror: of the deb822 stanza or one-line source whose suites
/// include plain `bookworm`.
fn debian_mirror() -> Option<String> {
    let sources = apt_sources();
    for stanza in sources.split("\n\n") {
        let field = |name: &str| {
            stanza
                .lines()
                .find_map(|l| l.strip_prefix(name))
                .map(str::trim)
        };
        if let (Some(uris), Some(suites)) = (field("URIs:"), field("Suites:"))
            && suites.split_whitespace().any(|s| s == "bookworm")
        {
            return uris.split_whitespace().next().map(str::to_owned);
        }
    }
    sources.lines().find_map(|l| {
        let words: Vec<&str> = l.split_whitespace().collect();
        match words[..] {
            ["deb", uri, "bookworm", ..] => Some(uri.to_owned()),
            _ => None,
        }
    })
}

/// Makes sure the viewer's window tests can open a window: `xvfb-run` and winit's X11
/// libraries, installed when running as root with apt-get. Returns whether they are there
/// (then the tests require them). Elsewhere than Linux the tests use the desktop's display.
fn ensure_xvfb() -> Result<bool, String> {
    if !cfg!(target_os = "linux") {
        return Ok(false);
    }
    if xvfb_present() {
        return Ok(true);
    }
    let install = format!("apt-get install -y {}", XVFB_PACKAGES.join(" "));
    if !is_root() || !on_path("apt-get") {
        if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
            eprintln!(
                "xtask: no xvfb-run; the viewer's window tests open their windows on this \
                 DISPLAY (for a virtual X server instead: sudo {install})"
            );
            return Ok(false);
        }
        return Err(format!(
            "the viewer's window tests need a virtual X server (xvfb-run) and the X11 client \
             libraries; install them:\n    sudo apt-get update && sudo {install}\nthen run this \
             command again."
        ));
    }
    eprintln!("xtask: no xvfb-run or X11 libraries found; installing: apt-get update && {install}");
    apt_install(&XVFB_PACKAGES, None)?;
    if xvfb_present() {
        eprintln!("xtask: xvfb installed");
        Ok(true)
    } else {
        Err("installed xvfb but still found no xvfb-run or X11 libraries".into())
    }
}

fn xvfb_present() -> bool {
    let libs = Command::new("ldconfig")
        .arg("-p")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    on_path("xvfb-run") && X11_LIBRARIES.iter().all(|l| libs.contains(l))
}

/// `apt-get update`, then an install of `packages` (from the suite `suite` when given).
fn apt_install(packages: &[&str], suite: Option<&str>) -> Result<(), String> {
    run_apt(&["update", "-qq"])?;
    let mut args = vec!["install", "-y", "-qq", "--no-install-recommends"];
    if let Some(suite) = suite {
        args.extend(["-t", suite]);
    }
    args.extend(packages);
    run_apt(&args)
}

fn run_apt(args: &[&str]) -> Result<(), String> {
    let mut cmd = Command::new("apt-get");
    cmd.env("DEBIAN_FRONTEND", "noninteractive");
    run(&mut cmd, "apt-get", args)
}

/// A Vulkan loader (`libvulkan.so.1`) and at least one installable client driver manifest.
fn vulkan_present() -> bool {
    let loader = Command::new("ldconfig")
        .arg("-p")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains("libvulkan.so.1"))
        .unwrap_or(false)
        || [
            "/usr/lib/x86_64-linux-gnu",
            "/usr/lib/aarch64-linux-gnu",
            "/usr/lib",
            "/usr/lib64",
        ]
        .iter()
        .any(|d| Path::new(d).join("libvulkan.so.1").exists());
    let explicit_driver = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|s| !s.is_empty()));
    let driver = explicit_driver
        || [
            "/usr/share/vulkan/icd.d",
            "/etc/vulkan/icd.d",
            "/usr/local/share/vulkan/icd.d",
        ]
        .iter()
        .any(|d| {
            std::fs::read_dir(d)
                .map(|mut entries| {
                    entries
                        .any(|e| e.is_ok_and(|e| e.path().extension().is_some_and(|x| x == "json")))
                })
                .unwrap_or(false)
        });
    loader && driver
}

fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(1).map(|uid| uid == "0"))
        })
        .unwrap_or(false)
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}
