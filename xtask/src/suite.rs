//! The test suite as `cargo xtask test` runs it: cargo builds every test binary of the workspace,
//! then each runs here with libtest's per-test times, its output passed through; the doc tests
//! run last through cargo. At the end: the time of each binary, the slowest tests, and one
//! closing line `tests: N passed, N failed; checks skipped: N` (each skip listed with the table).
//! The same table is written to
//! `target/test-times.md` (docs/testing.md keeps a measured copy).
//!
//! Two binaries run at once (`XTASK_TEST_JOBS` sets another count): one binary's tests leave a
//! core idle while shaders compile or a lone slow test finishes, and the other fills it. The
//! binaries the last run's table (`target/test-times.md`, else the one in docs/testing.md) found
//! slowest start first. Each binary's
//! output is printed whole when it ends, so two binaries' lines never interleave.
//!
//! libtest reports a test's time only with `-Z unstable-options --report-time`, which a stable
//! test binary accepts when `RUSTC_BOOTSTRAP=1` is in its environment; it is set for the test
//! binaries alone, never for cargo or rustc, so no build depends on it.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex, mpsc};
use std::time::Instant;

/// The slowest tests listed.
const SLOWEST: usize = 20;

/// Test binaries run at once unless `XTASK_TEST_JOBS` says otherwise.
const DEFAULT_JOBS: usize = 2;

/// Where the last run's table is written (and read back to start the slowest binaries first).
const TIMES: &str = "target/test-times.md";

/// The table kept in the docs: the order on a clean clone.
const MEASURED: &str = "docs/testing.md";

/// The file the tests append a line to for each check they skip (`tests::skip`, through
/// `RESTIR_TEST_SKIPS`): counted and listed in the summary.
const SKIPS: &str = "target/test-skips.txt";

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
    let mut binaries = build(workspace, cargo_args)?;
    // The measured table in docs/testing.md, then this tree's last run where it measured more.
    let mut last = last_times(&workspace.join(MEASURED));
    last.extend(last_times(&workspace.join(TIMES)));
    // Slowest first; a binary the last table does not know (new, or no table yet) counts as slow.
    binaries.sort_by(|a, b| {
        let t = |x: &TestBinary| last.get(&x.name()).copied().unwrap_or(f64::INFINITY);
        t(b).total_cmp(&t(a))
    });
    let skips_file = workspace.join(SKIPS);
    let _ = std::fs::remove_file(&skips_file);
    let skips_path = skips_file.display().to_string();
    let mut envs = envs.to_vec();
    envs.push(("RESTIR_TEST_SKIPS", skips_path.as_str()));
    let envs = envs.as_slice();
    let mut outcomes = run_binaries(binaries, jobs()?, test_args, envs)?;
    // Doc tests (only for a whole-workspace run: a selection of test targets names none).
    if cargo_args.is_empty() {
        outcomes.push(run_doc_tests(workspace, test_args, envs)?);
    }
    let skips = std::fs::read_to_string(&skips_file).unwrap_or_default();
    let mut table = table(&outcomes, started.elapsed().as_secs_f64());
    table += &skipped(&skips);
    println!("\n{table}");
    let out = workspace.join(TIMES);
    if let Err(e) = std::fs::write(&out, &table) {
        eprintln!("xtask: could not write {}: {e}", out.display());
    }
    let (passed, failed) = outcomes
        .iter()
        .fold((0, 0), |(p, f), o| (p + o.passed, f + o.failed));
    let skipped = skips.lines().count();
    println!("tests: {passed} passed, {failed} failed; checks skipped: {skipped}");
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

/// `XTASK_TEST_JOBS` (binaries run at once), or the default.
fn jobs() -> Result<usize, String> {
    match std::env::var("XTASK_TEST_JOBS") {
        Err(_) => Ok(DEFAULT_JOBS),
        Ok(v) => match v.parse::<usize>() {
            Ok(n) if (1..=64).contains(&n) => Ok(n),
            _ => Err(format!(
                "XTASK_TEST_JOBS must be a whole number from 1 to 64, not {v:?}"
            )),
        },
    }
}

/// Each binary's seconds in the table at `path` (none if there is no table).
fn last_times(path: &Path) -> std::collections::HashMap<String, f64> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut times = std::collections::HashMap::new();
    // Rows `| name | seconds | passed | failed | ignored |` of the first table.
    for line in text.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() == 7
            && let Ok(s) = cells[2].parse::<f64>()
        {
            times.insert(cells[1].to_owned(), s);
        }
    }
    times
}

/// Runs `binaries` in order, `jobs` at a time, printing each one's output whole as it ends.
/// The outcomes come back in the order the binaries ended.
fn run_binaries(
    binaries: Vec<TestBinary>,
    jobs: usize,
    test_args: &[String],
    envs: &[(&str, &str)],
) -> Result<Vec<Outcome>, String> {
    let count = binaries.len();
    let queue = Arc::new(Mutex::new(VecDeque::from(binaries)));
    let (send, receive) = mpsc::channel();
    let envs: Vec<(String, String)> = envs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    std::thread::scope(|scope| {
        for _ in 0..jobs.min(count) {
            let (queue, send, envs) = (Arc::clone(&queue), send.clone(), &envs);
            scope.spawn(move || {
                while let Some(b) = queue.lock().map(|mut q| q.pop_front()).ok().flatten() {
                    println!("     Running {} ({})", b.name(), b.path.display());
                    if send.send(run_binary(&b, test_args, envs)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(send);
        let mut outcomes = Vec::with_capacity(count);
        for result in receive {
            let (o, output) = result?;
            print!("{output}");
            outcomes.push(o);
        }
        Ok(outcomes)
    })
}

/// Runs one test binary with per-test times: its outcome and its whole standard output.
fn run_binary(
    b: &TestBinary,
    test_args: &[String],
    envs: &[(String, String)],
) -> Result<(Outcome, String), String> {
    let mut cmd = Command::new(&b.path);
    cmd.current_dir(&b.dir)
        .env("RUSTC_BOOTSTRAP", "1")
        .env("CARGO_MANIFEST_DIR", &b.dir)
        .envs(envs.iter().map(|(k, v)| (k, v)))
        .args(["-Z", "unstable-options", "--report-time"])
        .args(test_args);
    let mut output = format!("\n---- {} ----\n", b.name());
    let mut o = capture(cmd, &b.name(), &mut |line| {
        output.push_str(line);
        output.push('\n');
    })?;
    o.name = b.name();
    Ok((o, output))
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
    let mut o = capture(cmd, "doc tests", &mut |line| println!("{line}"))?;
    o.name = "doc tests".into();
    Ok(o)
}

/// Runs `cmd`, handing each line of its standard output to `echo` and reading libtest's lines
/// from it.
fn capture(mut cmd: Command, what: &str, echo: &mut dyn FnMut(&str)) -> Result<Outcome, String> {
    let started = Instant::now();
    let mut child = cmd
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("could not run {what}: {e}"))?;
    let mut o = Outcome::default();
    if let Some(stdout) = child.stdout.take() {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            echo(&line);
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

/// The checks the tests skipped (one line each in `skips`), each with its count.
fn skipped(skips: &str) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for line in skips.lines().filter(|l| !l.is_empty()) {
        match counts.iter_mut().find(|(l, _)| *l == line) {
            Some((_, n)) => *n += 1,
            None => counts.push((line, 1)),
        }
    }
    let total: usize = counts.iter().map(|(_, n)| n).sum();
    let mut t = format!("\nChecks skipped: {total}.\n");
    for (line, n) in counts {
        t += &format!("- {line} (x{n})\n");
    }
    t
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
        "\nThe {SLOWEST} slowest tests (each test's own time; a binary runs two at once, beside another binary):\n\n\
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
    fn lists_the_skipped_checks_with_their_counts() {
        let t = skipped("a: no scenes\nb: no GL\na: no scenes\n");
        assert_eq!(
            t,
            "\nChecks skipped: 3.\n- a: no scenes (x2)\n- b: no GL (x1)\n"
        );
        assert_eq!(skipped(""), "\nChecks skipped: 0.\n");
    }

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
    fn reads_back_the_binaries_times_of_its_table() {
        let o = |name: &str, seconds| Outcome {
            name: name.into(),
            seconds,
            passed: 1,
            tests: vec![("t".into(), seconds)],
            ..Default::default()
        };
        let dir = std::env::temp_dir().join(format!("xtask-times-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("times.md");
        std::fs::write(&path, table(&[o("tests/a", 12.5), o("b", 0.5)], 13.0)).unwrap();
        let times = last_times(&path);
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(times.len(), 2);
        assert_eq!((times["tests/a"], times["b"]), (12.5, 0.5));
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
