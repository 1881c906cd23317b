//! The test suite as `cargo xtask test` runs it: cargo builds every test binary of the workspace,
//! then each runs here with libtest's per-test times, its output passed through; the doc tests
//! run last through cargo. At the end: the time of each binary, the slowest tests, and one
//! closing line `tests: N passed, N failed`. The same table is written to
//! `target/test-times.md` (docs/testing.md keeps a measured copy).
//!
//! libtest reports a test's time only with `-Z unstable-options --report-time`, which a stable
//! test binary accepts when `RUSTC_BOOTSTRAP=1` is in its environment; it is set for the test
//! binaries alone, never for cargo or rustc, so no build depends on it.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// The slowest tests listed.
const SLOWEST: usize = 20;

/// One test binary cargo built: its package, target name, path and package directory (the
/// working directory cargo test would give it).
struct TestBinary {
    package: String,
    target: String,
    path: PathBuf,
    dir: PathBuf,
}

impl TestBinary {
    fn name(&self) -> String {
        if self.package == self.target {
            self.package.clone()
        } else {
            format!("{}/{}", self.package, self.target)
        }
    }
}

/// What one binary ran.
#[derive(Default)]
struct Outcome {
    name: String,
    seconds: f64,
    passed: u32,
    failed: u32,
    ignored: u32,
    /// (test, seconds) of each test that reported a time.
    tests: Vec<(String, f64)>,
}

/// Builds and runs the suite: `cargo_args` go to `cargo test --no-run` (e.g. `-p tests --test
/// paths`), `test_args` to every test binary (filters, `--nocapture`). `envs` are set for the
/// test binaries. An error names what failed.
pub fn run(
    workspace: &Path,
    cargo_args: &[String],
    test_args: &[String],
    envs: &[(&str, &str)],
) -> Result<(), String> {
    // Wall time of the whole run, reported in the table (a runner's report, not a benchmark).
    let started = Instant::now();
    let binaries = build(workspace, cargo_args)?;
    let mut outcomes = Vec::new();
    for b in &binaries {
        outcomes.push(run_binary(b, test_args, envs)?);
    }
    // Doc tests (only for a whole-workspace run: a selection of test targets names none).
    if cargo_args.is_empty() {
        outcomes.push(run_doc_tests(workspace, test_args, envs)?);
    }
    let table = table(&outcomes, started.elapsed().as_secs_f64());
    println!("\n{table}");
    let out = workspace.join("target/test-times.md");
    if let Err(e) = std::fs::write(&out, &table) {
        eprintln!("xtask: could not write {}: {e}", out.display());
    }
    let (passed, failed) = outcomes
        .iter()
        .fold((0, 0), |(p, f), o| (p + o.passed, f + o.failed));
    println!("tests: {passed} passed, {failed} failed");
    let failing: Vec<&str> = outcomes
        .iter()
        .filter(|o| o.failed > 0)
        .map(|o| o.name.as_str())
        .collect();
    if failing.is_empty() {
        Ok(())
    } else {
        Err(format!("tests failed in {}", failing.join(", ")))
    }
}

/// `cargo test --workspace --no-run` with `cargo_args`: the test binaries it built.
fn build(workspace: &Path, cargo_args: &[String]) -> Result<Vec<TestBinary>, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace).args([
        "test",
        "--no-run",
        "--message-format=json-render-diagnostics",
    ]);
    if cargo_args.is_empty() {
        cmd.arg("--workspace");
    }
    cmd.args(cargo_args).stdout(Stdio::piped());
    let out = cmd
        .spawn()
        .and_then(|c| c.wait_with_output())
        .map_err(|e| format!("could not run cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!("building the tests failed ({})", out.status));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    Ok(text.lines().filter_map(test_binary).collect())
}

/// The test binary a line of cargo's JSON messages announces, if any.
fn test_binary(line: &str) -> Option<TestBinary> {
    // A test harness: its profile (not only its target) is a test one.
    let profile = line.split_once("\"profile\":{")?.1.split_once('}')?.0;
    if !line.contains("\"reason\":\"compiler-artifact\"") || !profile.contains("\"test\":true") {
        return None;
    }
    let path = PathBuf::from(json_string(line, "executable")?);
    let manifest = PathBuf::from(json_string(line, "manifest_path")?);
    let target = json_string(line, "name")?;
    let package = manifest
        .parent()?
        .file_name()?
        .to_string_lossy()
        .into_owned();
    Some(TestBinary {
        package,
        target,
        path,
        dir: manifest.parent()?.to_owned(),
    })
}

/// The first string value of `"key":"..."` in a JSON line (paths and names here hold no
/// escapes).
fn json_string(line: &str, key: &str) -> Option<String> {
    let pat = format!("\"{key}\":\"");
    let start = line.find(&pat)? + pat.len();
    let end = start + line[start..].find('"')?;
    Some(line[start..end].to_owned())
}

/// Runs one test binary with per-test times, passing its output through.
fn run_binary(
    b: &TestBinary,
    test_args: &[String],
    envs: &[(&str, &str)],
) -> Result<Outcome, String> {
    println!("     Running {} ({})", b.name(), b.path.display());
    let mut cmd = Command::new(&b.path);
    cmd.current_dir(&b.dir)
        .env("RUSTC_BOOTSTRAP", "1")
        .env("CARGO_MANIFEST_DIR", &b.dir)
        .envs(envs.iter().copied())
        .args(["-Z", "unstable-options", "--report-time"])
        .args(test_args);
    let mut o = capture(cmd, &b.name())?;
    o.name = b.name();
    Ok(o)
}

/// `cargo test --workspace --doc`, its output passed through and counted.
fn run_doc_tests(
    workspace: &Path,
    test_args: &[String],
    envs: &[(&str, &str)],
) -> Result<Outcome, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace)
        .envs(envs.iter().copied())
        .args(["test", "--workspace", "--doc", "--"])
        .args(test_args);
    let mut o = capture(cmd, "doc tests")?;
    o.name = "doc tests".into();
    Ok(o)
}

/// Runs `cmd`, echoing its standard output line by line and reading libtest's lines from it.
fn capture(mut cmd: Command, what: &str) -> Result<Outcome, String> {
    let started = Instant::now();
    let mut child = cmd
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("could not run {what}: {e}"))?;
    let mut o = Outcome::default();
    if let Some(stdout) = child.stdout.take() {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            println!("{line}");
            read_line(&line, &mut o);
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("waiting for {what}: {e}"))?;
    o.seconds = started.elapsed().as_secs_f64();
    if !status.success() && o.failed == 0 {
        // Crashed or refused its arguments: count it as one failure.
        o.failed = 1;
    }
    Ok(o)
}

/// Reads `test NAME ... ok <1.234s>` and `test result: ...` lines.
fn read_line(line: &str, o: &mut Outcome) {
    if let Some(rest) = line.strip_prefix("test result: ") {
        for part in rest.split(';') {
            let mut words = part.split_whitespace().rev();
            let (Some(what), Some(n)) = (words.next(), words.next()) else {
                continue;
            };
            let n = n.parse::<u32>().unwrap_or(0);
            match what {
                "passed" => o.passed += n,
                "failed" => o.failed += n,
                "ignored" => o.ignored += n,
                _ => {}
            }
        }
    } else if let Some(rest) = line.strip_prefix("test ")
        && let Some((name, result)) = rest.split_once(" ... ")
        && let Some(time) = result
            .split_once('<')
            .and_then(|(_, t)| t.strip_suffix("s>"))
            .and_then(|t| t.parse::<f64>().ok())
    {
        o.tests.push((name.to_owned(), time));
    }
}

/// The time table: each binary's wall time and counts, then the slowest tests.
fn table(outcomes: &[Outcome], total: f64) -> String {
    let mut t = format!(
        "## Test times\n\nThe suite: {} passed, {} failed, {} ignored in {:.0} s (wall, \
         building included).\n\n| binary | s | passed | failed | ignored |\n|---|---:|---:|---:|---:|\n",
        outcomes.iter().map(|o| o.passed).sum::<u32>(),
        outcomes.iter().map(|o| o.failed).sum::<u32>(),
        outcomes.iter().map(|o| o.ignored).sum::<u32>(),
        total
    );
    let mut by_time: Vec<&Outcome> = outcomes.iter().collect();
    by_time.sort_by(|a, b| b.seconds.total_cmp(&a.seconds));
    for o in by_time {
        t += &format!(
            "| {} | {:.1} | {} | {} | {} |\n",
            o.name, o.seconds, o.passed, o.failed, o.ignored
        );
    }
    let mut tests: Vec<(String, &str, f64)> = outcomes
        .iter()
        .flat_map(|o| {
            o.tests
                .iter()
                .map(|(n, s)| (o.name.clone(), n.as_str(), *s))
        })
        .collect();
    tests.sort_by(|a, b| b.2.total_cmp(&a.2));
    t += &format!(
        "\nThe {SLOWEST} slowest tests (each test's own time; a binary runs two at once):\n\n\
         | binary | test | s |\n|---|---|---:|\n"
    );
    for (binary, name, s) in tests.iter().take(SLOWEST) {
        t += &format!("| {binary} | {name} | {s:.1} |\n");
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_libtest_lines() {
        let mut o = Outcome::default();
        read_line("test a::b ... ok <1.500s>", &mut o);
        read_line("test c ... FAILED <0.250s>", &mut o);
        read_line("test d ... ignored", &mut o);
        read_line(
            "test result: FAILED. 3 passed; 1 failed; 2 ignored; 0 measured; 0 filtered out; \
             finished in 1.75s",
            &mut o,
        );
        assert_eq!((o.passed, o.failed, o.ignored), (3, 1, 2));
        assert_eq!(o.tests, vec![("a::b".into(), 1.5), ("c".into(), 0.25)]);
    }

    #[test]
    fn finds_test_binaries_in_cargo_messages() {
        let line = r#"{"reason":"compiler-artifact","package_id":"path+file:///w/tests#0.1.0","manifest_path":"/w/tests/Cargo.toml","target":{"kind":["test"],"crate_types":["bin"],"name":"paths","src_path":"/w/tests/tests/paths.rs","edition":"2024","doc":false,"doctest":false,"test":true},"profile":{"opt_level":"1","test":true},"executable":"/w/target/debug/deps/paths-1234","fresh":true}"#;
        let b = test_binary(line).expect("a test binary");
        assert_eq!(b.name(), "tests/paths");
        assert_eq!(b.path, PathBuf::from("/w/target/debug/deps/paths-1234"));
        assert_eq!(b.dir, PathBuf::from("/w/tests"));
        assert!(
            test_binary(&line.replace(
                "\"executable\":\"/w/target/debug/deps/paths-1234\"",
                "\"executable\":null"
            ))
            .is_none()
        );
    }
}
