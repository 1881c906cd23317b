//! `cargo xtask device-bench`: one prepared run of every benchmark on a GPU machine.
//!
//! `--prepare` builds, here and without a GPU, every bench binary of the `tests` package and
//! `restir-demo` in release, and copies them (symbols stripped) into one bundle directory of at
//! most 64 MiB (gzipped when they do not fit unpacked) with `run.sh`, Sponza for the trace bench,
//! this machine's Vulkan loader and `MANIFEST.txt`. `--run` runs the bundle's `run.sh` here:
//! the steps, their budgets and the files it writes are in `device_bench.sh`. `--dev` builds
//! with the dev profile instead (CI's lavapipe check: its test build is warm, a release build
//! is not) and skips the size limit: such a bundle is for this machine only.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// The run script, written into the bundle as `run.sh`.
const RUN_SH: &str = include_str!("device_bench.sh");

/// The bundle's default directory, relative to the workspace.
const BUNDLE: &str = "target/device-bench";

/// Where `--run` writes its files unless `--out` says otherwise.
const RESULTS: &str = "target/device-bench-out";

/// The most a bundle may hold: what a GPU machine's session carries.
const MAX_BYTES: u64 = 64 << 20;

/// The public scene the trace bench reads (`tests::scenes_dir()`), bundled when present.
const SPONZA: &str = "sponza-capsaicin";

const USAGE: &str = "usage: cargo xtask device-bench [--prepare] [--dev] [--bundle DIR] [--run \
                     [--budget SECONDS] [--lavapipe] [--out DIR]]\n  --prepare  build every bench \
                     and restir-demo in release into the bundle (default target/device-bench; \
                     `--out DIR` without --run names it too), at most 64 MiB\n  --run  run the \
                     bundle's run.sh here: results into --out (default target/device-bench-out); \
                     --lavapipe: small sizes within 150 s\n  on a GPU machine: sh \
                     target/device-bench/run.sh --out DIR";

/// What the command line asks for.
struct Options {
    prepare: bool,
    run: bool,
    dev: bool,
    bundle: PathBuf,
    /// Arguments for run.sh.
    run_args: Vec<String>,
}

fn options(workspace: &Path, args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        prepare: false,
        run: false,
        dev: false,
        bundle: workspace.join(BUNDLE),
        run_args: Vec::new(),
    };
    let mut out = None;
    let mut args = args.iter();
    while let Some(arg) = args.next() {
        let mut value = || {
            args.next()
                .cloned()
                .ok_or(format!("{arg} needs a value\n{USAGE}"))
        };
        match arg.as_str() {
            "--prepare" => o.prepare = true,
            "--run" => o.run = true,
            "--dev" => o.dev = true,
            "--bundle" => o.bundle = workspace.join(value()?),
            "--out" => out = Some(value()?),
            "--budget" => o.run_args.extend(["--budget".into(), value()?]),
            "--lavapipe" => o.run_args.push(arg.clone()),
            _ => return Err(format!("unknown argument {arg}\n{USAGE}")),
        }
    }
    match (o.prepare, o.run, out) {
        (false, false, _) => return Err(USAGE.into()),
        (true, false, Some(dir)) => o.bundle = workspace.join(dir),
        (_, true, out) => {
            let out = out.map_or(workspace.join(RESULTS), |d| workspace.join(d));
            o.run_args
                .extend(["--out".into(), out.display().to_string()]);
        }
        _ => {}
    }
    Ok(o)
}

/// `cargo xtask device-bench ARGS`.
pub fn main(workspace: &Path, args: &[String]) -> Result<(), String> {
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!("{USAGE}");
        return Ok(());
    }
    let o = options(workspace, args)?;
    if o.prepare {
        prepare(workspace, &o.bundle, o.dev)?;
    }
    if o.run {
        let script = o.bundle.join("run.sh");
        if !script.is_file() {
            return Err(format!(
                "no bundle at {}: run `cargo xtask device-bench --prepare` first",
                o.bundle.display()
            ));
        }
        crate::ensure_vulkan()?;
        let args: Vec<&str> = o.run_args.iter().map(String::as_str).collect();
        crate::run(Command::new("sh").arg(&script), "run.sh", &args)?;
    }
    Ok(())
}

/// Builds the binaries and writes the bundle into `bundle` (replacing what was there).
fn prepare(workspace: &Path, bundle: &Path, dev: bool) -> Result<(), String> {
    // How long preparing took, said to the user (a runner's report, not a benchmark).
    let started = Instant::now();
    let mut binaries = build(workspace, dev, &["-p", "tests", "--benches"])?;
    // Apart: in one build the tests' `planted-defects` feature would reach the demo's renderer.
    binaries.extend(build(
        workspace,
        dev,
        &["-p", "demo", "--bin", "restir-demo"],
    )?);
    if bundle.exists() {
        std::fs::remove_dir_all(bundle).map_err(|e| io_error(bundle, e))?;
    }
    let bin = bundle.join("bin");
    std::fs::create_dir_all(&bin).map_err(|e| io_error(&bin, e))?;
    for (name, path) in &binaries {
        copy_stripped(path, &bin.join(name))?;
    }
    let sponza = copy_sponza(workspace, bundle)?;
    let loader = copy_vulkan_loader(bundle)?;
    let run_sh = bundle.join("run.sh");
    std::fs::write(&run_sh, RUN_SH).map_err(|e| io_error(&run_sh, e))?;
    let packed = !dev && dir_bytes(bundle)? > MAX_BYTES - (64 << 10);
    if packed {
        for (name, _) in &binaries {
            crate::run(
                &mut Command::new("gzip"),
                "gzip",
                &["-6", "-n", &path_str(&bin.join(name))],
            )?;
        }
    }
    let manifest = manifest(bundle, dev, packed, sponza.as_deref(), loader.as_deref())?;
    let path = bundle.join("MANIFEST.txt");
    std::fs::write(&path, manifest).map_err(|e| io_error(&path, e))?;
    let bytes = dir_bytes(bundle)?;
    let mib = bytes as f64 / f64::from(1 << 20);
    if !dev && bytes > MAX_BYTES {
        return Err(format!(
            "the bundle {} holds {mib:.1} MiB, over the 64 MiB a GPU machine's session carries",
            bundle.display()
        ));
    }
    println!(
        "xtask: bundle {} ({mib:.1} MiB, {} binaries{}) prepared in {:.0} s; on the GPU \
         machine: sh {}/run.sh --out DIR (8 minutes; --lavapipe on a CPU)",
        bundle.display(),
        binaries.len(),
        if packed { ", gzipped" } else { "" },
        started.elapsed().as_secs_f64(),
        bundle.display()
    );
    Ok(())
}

/// `cargo build` (release unless `dev`) of `select`: the (name, path) of each bench and binary
/// it built, from cargo's JSON messages.
fn build(workspace: &Path, dev: bool, select: &[&str]) -> Result<Vec<(String, PathBuf)>, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace)
        .args(["build", "--message-format=json-render-diagnostics"])
        .args(select)
        .stdout(Stdio::piped());
    if !dev {
        cmd.arg("--release");
    }
    let out = cmd
        .spawn()
        .and_then(|c| c.wait_with_output())
        .map_err(|e| format!("could not run cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "`cargo build {}` failed ({})",
            select.join(" "),
            out.status
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    Ok(text.lines().filter_map(executable).collect())
}

/// The (target name, executable) of a compiler-artifact message of a bench or binary target.
fn executable(line: &str) -> Option<(String, PathBuf)> {
    let msg: serde_json::Value = serde_json::from_str(line).ok()?;
    if msg["reason"] != "compiler-artifact" {
        return None;
    }
    let kinds = msg["target"]["kind"].as_array()?;
    if !kinds.iter().any(|k| k == "bench" || k == "bin") {
        return None;
    }
    let name = msg["target"]["name"].as_str()?.to_owned();
    Some((name, PathBuf::from(msg["executable"].as_str()?)))
}

/// Copies the executable `from` to `to` without its symbols (`strip`), or as it is where this
/// machine has no `strip`.
fn copy_stripped(from: &Path, to: &Path) -> Result<(), String> {
    if crate::on_path("strip") {
        let args = ["-o", &path_str(to), &path_str(from)];
        crate::run(&mut Command::new("strip"), "strip", &args)
    } else {
        std::fs::copy(from, to)
            .map(drop)
            .map_err(|e| io_error(from, e))
    }
}

/// Copies Sponza (geometry and licence) into `bundle/scenes`; its source directory, or None
/// (then the trace bench prints its skip line on the GPU machine).
fn copy_sponza(workspace: &Path, bundle: &Path) -> Result<Option<PathBuf>, String> {
    let scenes = std::env::var_os("RESTIR_SCENES_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace.join("../shared/scenes"));
    let from = scenes.join(SPONZA);
    if !from.is_dir() {
        eprintln!(
            "xtask: no {} (set RESTIR_SCENES_DIR): trace will skip Sponza",
            from.display()
        );
        return Ok(None);
    }
    let to = bundle.join("scenes").join(SPONZA);
    std::fs::create_dir_all(&to).map_err(|e| io_error(&to, e))?;
    for entry in std::fs::read_dir(&from).map_err(|e| io_error(&from, e))? {
        let entry = entry.map_err(|e| io_error(&from, e))?;
        let dest = to.join(entry.file_name());
        std::fs::copy(entry.path(), &dest).map_err(|e| io_error(&dest, e))?;
        set_writable(&dest)?;
    }
    Ok(Some(from.canonicalize().unwrap_or(from)))
}

/// Copies this machine's `libvulkan.so.1` into `bundle/lib` (run.sh uses it only where the GPU
/// machine has none); the file it copied, or None.
fn copy_vulkan_loader(bundle: &Path) -> Result<Option<PathBuf>, String> {
    let listed = Command::new("ldconfig")
        .arg("-p")
        .output()
        .ok()
        .and_then(|o| {
            let text = String::from_utf8_lossy(&o.stdout).into_owned();
            text.lines()
                .find(|l| l.trim_start().starts_with("libvulkan.so.1 "))
                .and_then(|l| l.split("=> ").nth(1))
                .map(|p| PathBuf::from(p.trim()))
        });
    let Some(loader) = listed.and_then(|p| p.canonicalize().ok()) else {
        return Ok(None);
    };
    let lib = bundle.join("lib");
    std::fs::create_dir_all(&lib).map_err(|e| io_error(&lib, e))?;
    let dest = lib.join("libvulkan.so.1");
    std::fs::copy(&loader, &dest).map_err(|e| io_error(&dest, e))?;
    Ok(Some(loader))
}

/// MANIFEST.txt: what the bundle holds, what it was built from and what it needs.
fn manifest(
    bundle: &Path,
    dev: bool,
    packed: bool,
    sponza: Option<&Path>,
    loader: Option<&Path>,
) -> Result<String, String> {
    let output = |program: &str, args: &[&str]| {
        Command::new(program)
            .args(args)
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
            .unwrap_or_else(|_| format!("({program} not found)"))
    };
    let bin = bundle.join("bin");
    let demo = bin.join(if packed {
        "restir-demo.gz"
    } else {
        "restir-demo"
    });
    let dirty = !output("git", &["status", "--porcelain"]).is_empty();
    let mut m = format!(
        "restir-world device-bench bundle: commit {}{}, {} profile, built {} with {}\n",
        output("git", &["rev-parse", "--short", "HEAD"]),
        if dirty {
            " with uncommitted changes"
        } else {
            ""
        },
        if dev { "dev" } else { "release" },
        output("date", &["-u", "+%Y-%m-%d %H:%M UTC"]),
        output("rustc", &["-V"]),
    );
    m += "run: sh run.sh [--budget SECONDS] [--out DIR] [--lavapipe] (run.sh --help)\n\n";
    m += &format!(
        "x86_64 Linux, glibc {} or newer. The binaries do not link libvulkan (ldd below): \
         wgpu's Vulkan backend (ash) opens libvulkan.so.1 with dlopen at run time, so the GPU \
         machine needs libvulkan.so.1 and its vendor's driver (ICD: e.g. NVIDIA's \
         nvidia_icd.json, installed with the driver). {}\n\n",
        glibc_needed(&demo, packed),
        match loader {
            Some(l) => format!(
                "lib/libvulkan.so.1 is this machine's loader ({}); run.sh puts it on \
                 LD_LIBRARY_PATH only where the machine has no libvulkan.so.1.",
                l.display()
            ),
            None => "No loader is bundled (none found here).".into(),
        }
    );
    m += &match sponza {
        Some(s) => format!(
            "scenes/{SPONZA}: Sponza for the trace bench, from {}.\n",
            s.display()
        ),
        None => {
            "No Sponza: the trace bench prints its skip line and runs cornell and many-lights.\n"
                .into()
        }
    };
    m += "\nfiles (bytes):\n";
    for (path, bytes) in files(bundle)? {
        m += &format!("  {bytes:>10}  {path}\n");
    }
    if !packed {
        m += &format!(
            "\nldd bin/restir-demo:\n{}\n",
            output("ldd", &[&path_str(&demo)])
        );
    }
    Ok(m)
}

/// The highest `GLIBC_2.N` symbol version the (not gzipped) executable names.
fn glibc_needed(exe: &Path, packed: bool) -> String {
    let Ok(bytes) = (if packed {
        Command::new("gzip")
            .args(["-dc", &path_str(exe)])
            .output()
            .map(|o| o.stdout)
    } else {
        std::fs::read(exe)
    }) else {
        return "(unknown)".into();
    };
    let tag = b"GLIBC_2.";
    let minor = bytes
        .windows(tag.len())
        .enumerate()
        .filter(|(_, w)| w == tag)
        .filter_map(|(i, _)| {
            let digits = bytes[i + tag.len()..]
                .iter()
                .take_while(|b| b.is_ascii_digit());
            std::str::from_utf8(&digits.copied().collect::<Vec<u8>>())
                .ok()?
                .parse::<u32>()
                .ok()
        })
        .max();
    minor.map_or("(unknown)".into(), |m| format!("2.{m}"))
}

/// Every file under `dir` (relative path, bytes), sorted.
fn files(dir: &Path) -> Result<Vec<(String, u64)>, String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).map_err(|e| io_error(&d, e))? {
            let path = entry.map_err(|e| io_error(&d, e))?.path();
            let meta = std::fs::metadata(&path).map_err(|e| io_error(&path, e))?;
            if meta.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(dir).unwrap_or(&path);
                out.push((rel.display().to_string(), meta.len()));
            }
        }
    }
    out.sort();
    Ok(out)
}

fn dir_bytes(dir: &Path) -> Result<u64, String> {
    Ok(files(dir)?.iter().map(|(_, b)| b).sum())
}

/// Copied files keep the source's permissions: the public scenes are read-only.
fn set_writable(path: &Path) -> Result<(), String> {
    let mut perms = std::fs::metadata(path)
        .map_err(|e| io_error(path, e))?
        .permissions();
    #[allow(clippy::permissions_set_readonly_false)] // the bundle's own copy, not shared
    perms.set_readonly(false);
    std::fs::set_permissions(path, perms).map_err(|e| io_error(path, e))
}

fn path_str(path: &Path) -> String {
    path.display().to_string()
}

fn io_error(path: &Path, e: std::io::Error) -> String {
    format!("{}: {e}", path.display())
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    /// Stub binaries: each prints a RESULT line naming itself (scan its shape, twice);
    /// `restir-demo info` outlives its budget, `denoise` fails, `restir-demo compare` writes a
    /// report.
    const STUB: &str = r#"#!/bin/sh
name=$(basename "$0")
case $name in
denoise) exit 3 ;;
scan) echo "RESULT gpu-scan wg=${SCAN_BENCH_WG:-default}"; echo "RESULT gpu-scan wg=${SCAN_BENCH_WG:-default}" ;;
restir-demo) [ "$1" = compare ] || exec sleep 60
    while [ "$1" != --out ]; do shift; done; mkdir -p "$2"; echo report >"$2/report.md"; echo '{}' >"$2/report.json" ;;
*) echo "RESULT $name" ;;
esac
"#;

    /// run.sh in its lavapipe mode over stubs: the order, a step killed at its budget and one
    /// that fails noted while the run goes on, each RESULT line once, only the files it names.
    #[test]
    fn run_sh_budgets_and_files() {
        let dir = std::env::temp_dir().join(format!("xtask-device-bench-{}", std::process::id()));
        let (bin, out) = (dir.join("bin"), dir.join("out"));
        std::fs::create_dir_all(&bin).unwrap();
        let names = [
            "restir-demo",
            "scan",
            "hash",
            "trace",
            "restir_gi",
            "world_restir",
            "floors",
            "reservoir",
            "cache",
            "denoise",
            "history",
        ];
        for name in names {
            let exe = path_str(&bin.join(name));
            std::fs::write(&exe, STUB).unwrap();
            // One binary gzipped, as in a bundle over 64 MiB unpacked; the others as they are.
            let gzip = if name == "scan" {
                " && gzip -n "
            } else {
                " && true "
            };
            let cmd = format!("chmod +x {exe}{gzip}{exe}");
            assert!(
                Command::new("sh")
                    .args(["-c", &cmd])
                    .status()
                    .unwrap()
                    .success()
            );
        }
        std::fs::write(dir.join("run.sh"), RUN_SH).unwrap();
        let run = Command::new("sh")
            .arg(dir.join("run.sh"))
            .args(["--lavapipe", "--budget", "40", "--out", &path_str(&out)])
            .output()
            .unwrap();
        let read = |f: &str| std::fs::read_to_string(out.join(f)).unwrap_or_default();
        let (log, results) = (read("log.txt"), read("results.txt"));
        let written = std::fs::read_dir(&out).map(|d| d.count()).unwrap_or(0);
        let (device, report) = (read("device.txt"), read("compare-1080.json"));
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(run.status.code(), Some(1), "denoise failed:\n{log}");
        // Killed at its budget of 1 s (or skipped, where a second began before its start).
        assert!(log.contains("timed out or skipped: device;"), "{log}");
        assert!(log.contains("--- denoise: FAILED (exit 3)"), "{log}");
        let want = "RESULT gpu-scan wg=default\nRESULT gpu-scan wg=32\nRESULT gpu-scan wg=64\n\
                    RESULT hash\nRESULT trace\nRESULT restir_gi\nRESULT world_restir\n\
                    RESULT floors\nRESULT reservoir\nRESULT cache\nRESULT history\n";
        assert_eq!(results, want, "{log}");
        assert_eq!(
            (device.as_str(), report.as_str(), written),
            ("", "{}\n", 7),
            "{log}"
        );
    }
}
