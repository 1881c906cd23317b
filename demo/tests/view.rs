//! `restir-demo view` in a real window: an X server (Xvfb through `xvfb-run`, which `cargo xtask
//! test` installs when missing) and the adapter the other GPU tests use (lavapipe in CI). The
//! window's screenshot (the last frame denoised, as shown by default) must equal the offline
//! `render --denoise` of the same camera, method, seed and size; a scripted camera path must move the camera and restart the accumulation; without a
//! display the command must fail with a clear message.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

use restir_world::image_io::{Image, read_exr};

const BIN: &str = env!("CARGO_BIN_EXE_restir-demo");

/// `cargo xtask test` sets it: it made sure a virtual X server exists, so a missing one is a
/// failure, not a skip.
const REQUIRED_ENV: &str = "RESTIR_VIEW_TESTS_REQUIRE_DISPLAY";

/// `xvfb-run -a` picks a free display number racily: one window test at a time.
static XVFB: Mutex<()> = Mutex::new(());

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}

/// How the window tests reach a display: their own Xvfb server, else the session's display.
/// `None` (after printing why) only outside `cargo xtask test` on a machine without either.
fn display() -> Option<bool> {
    if on_path("xvfb-run") {
        return Some(true);
    }
    if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
        return Some(false);
    }
    assert!(
        std::env::var_os(REQUIRED_ENV).is_none(),
        "xvfb-run is not on PATH although `cargo xtask test` should have installed it \
         (apt-get install xvfb xauth)"
    );
    eprintln!(
        "skipped: the window tests need xvfb-run or a DISPLAY, and neither is here; \
         `cargo xtask test` installs xvfb (as root with apt-get) and runs them"
    );
    None
}

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("restir-view-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The words of a command line.
fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// A window test's display (as [`display`]) and its fresh output directory `name`; `None`
/// when it skips.
fn window_test(name: &str) -> Option<(bool, PathBuf)> {
    let xvfb = display()?;
    Some((xvfb, out_dir(name)))
}

/// Runs `restir-demo view ARGS` in a window; panics unless it exits 0.
fn view(xvfb: bool, dir: &Path, args: &[&str]) -> String {
    let _one = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let mut cmd = if xvfb {
        let mut c = Command::new("xvfb-run");
        c.args(["-a", "-s", "-screen 0 1280x1024x24", BIN]);
        c
    } else {
        Command::new(BIN)
    };
    // A private runtime directory keeps the Vulkan loader's Wayland probe quiet.
    let runtime = dir.join("xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    let o = cmd
        .arg("view")
        .args(args)
        .env("XDG_RUNTIME_DIR", &runtime)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "view {args:?} failed ({}):\n{stdout}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

fn render(dir: &Path, args: &[&str]) -> Output {
    let o = Command::new(BIN)
        .arg("render")
        .args(args)
        .arg("--out")
        .arg(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The screenshot's tolerance against the offline render: both run the same frames of the
/// same method on the same device, so they agree to float round-off: every channel within
/// 1e-4 relative (1e-6 absolute near black).
fn same_image(a: &Image, b: &Image) -> Result<(), String> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(format!(
            "sizes differ: {}x{} against {}x{}",
            a.width, a.height, b.width, b.height
        ));
    }
    let mut worst = (0.0f32, 0);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        for c in 0..3 {
            let excess = (p[c] - q[c]).abs() - (1e-6 + 1e-4 * q[c].abs());
            // NaN anywhere counts as the worst difference.
            let excess = if excess.is_nan() {
                f32::INFINITY
            } else {
                excess
            };
            if excess > worst.0 {
                worst = (excess, i);
            }
        }
    }
    if worst.0 > 0.0 {
        let i = worst.1;
        return Err(format!(
            "pixel {i} differs beyond the tolerance: {:?} against {:?}",
            a.pixels[i], b.pixels[i]
        ));
    }
    Ok(())
}

#[test]
fn screenshot_equals_the_offline_render() {
    let Some((xvfb, dir)) = window_test("shot") else {
        return;
    };
    let common = words("--scene cornell --method world-restir --size 48x40 --seed 3");
    let shot = dir.join("shot.png");
    let mut args = common.to_vec();
    let shot_arg = shot.to_str().unwrap();
    args.extend(["--exit-after-frames", "30", "--screenshot", shot_arg]);
    let stdout = view(xvfb, &dir, &args);
    assert!(stdout.contains("view: 30 frames"), "{stdout}");
    assert!(stdout.contains("accumulated 30"), "{stdout}");
    // The overlay's timings come from the same spans as `compare` (when timestamps exist).
    if stdout.contains("view: GPU") {
        for span in [
            "primary",
            "generate",
            "build",
            "spatial",
            "shade",
            "accumulate",
            "denoise",
        ] {
            let named = |before: &str| stdout.contains(&format!("{before}{span}="));
            assert!(named(" ") || named("("), "{span}: {stdout}");
        }
    }
    let view_exr = read_exr(&dir.join("shot.exr")).unwrap();
    // The window shows the last frame denoised: `render --denoise`'s denoised image.
    let mut args = common.to_vec();
    // The window's exposure (1) for render's PNG, whose default is the image's own.
    args.extend(["--frames", "30", "--denoise", "--exposure", "1"]);
    render(&dir.join("render"), &args);
    let offline = read_exr(&dir.join("render/cornell-world-restir-denoised.exr")).unwrap();
    same_image(&view_exr, &offline).unwrap();
    assert!(view_exr.mean()[0] > 0.01, "the screenshot is black");
    // The PNG is the shown image: the offline PNG's bytes at the same exposure.
    let png = image::open(&shot).unwrap().to_rgb8();
    let offline_png = image::open(dir.join("render/cornell-world-restir-denoised.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(png.dimensions(), offline_png.dimensions());
    let max_step = png
        .as_raw()
        .iter()
        .zip(offline_png.as_raw())
        .map(|(a, b)| a.abs_diff(*b))
        .max();
    assert!(max_step <= Some(1), "PNG differs by {max_step:?} levels");
    // Negative control: another seed is another image, and the check says so.
    let mut args = common.to_vec();
    args[7] = "4"; // --seed
    args.extend(["--frames", "30", "--denoise"]);
    render(&dir.join("other-seed"), &args);
    let other = read_exr(&dir.join("other-seed/cornell-world-restir-denoised.exr")).unwrap();
    assert!(same_image(&view_exr, &other).is_err());
    // And one frame fewer is another image too.
    let mut args = common.to_vec();
    args.extend(["--frames", "29", "--denoise"]);
    render(&dir.join("fewer"), &args);
    let fewer = read_exr(&dir.join("fewer/cornell-world-restir-denoised.exr")).unwrap();
    assert!(same_image(&view_exr, &fewer).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The summary's accumulated frame count and camera eye.
fn accumulated_and_eye(stdout: &str) -> (u32, String) {
    let acc = stdout
        .lines()
        .find_map(|l| l.split("accumulated ").nth(1))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no accumulated count in {stdout}"));
    let eye = stdout
        .lines()
        .find_map(|l| l.strip_prefix("view: camera eye "))
        .and_then(|l| l.split(' ').next())
        .unwrap_or_else(|| panic!("no camera in {stdout}"))
        .to_owned();
    (acc, eye)
}

#[test]
fn a_camera_path_moves_the_camera_and_restarts_accumulation() {
    let Some((xvfb, dir)) = window_test("path") else {
        return;
    };
    let common = words("--scene cornell --method nee --size 24x24 --exit-after-frames 30");
    // Negative control: a still camera accumulates every frame and stays where it was.
    let still = view(xvfb, &dir, &common);
    let (still_acc, still_eye) = accumulated_and_eye(&still);
    assert_eq!(still_acc, 30, "{still}");
    let mut args = common.to_vec();
    args.extend(["--camera-path", "orbit", "--camera-path-frames", "10"]);
    let moved = view(xvfb, &dir, &args);
    let (acc, eye) = accumulated_and_eye(&moved);
    // Frames 1..=9 each moved the camera and restarted: 30 - 9 frames since the last move.
    assert_eq!(acc, 21, "{moved}");
    assert_ne!(eye, still_eye, "the orbit did not move the camera");
    let mut args = common.to_vec();
    args.extend(["--camera-path", "dolly", "--camera-path-frames", "5"]);
    let (acc, eye) = accumulated_and_eye(&view(xvfb, &dir, &args));
    assert_eq!(acc, 26);
    assert_ne!(eye, still_eye);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn without_a_display_it_says_so_and_suggests_render() {
    let o = Command::new(BIN)
        .args(["view", "--scene", "cornell", "--exit-after-frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("no display"), "{err}");
    assert!(err.contains("restir-demo render"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // A display that is named but not there.
    let o = Command::new(BIN)
        .args(["view", "--scene", "cornell", "--exit-after-frames", "1"])
        .env("DISPLAY", ":8765")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("cannot open the display (DISPLAY=:8765)"),
        "{err}"
    );
    assert!(err.contains("restir-demo render"), "{err}");
    // Bad flags fail before any window, display or not.
    for bad in [
        &["--scale", "3"][..],
        &["--exit-after-frames", "0"],
        &["--method", "nope"],
        &["--exposure", "-1"],
        &["--scene", "no-such-scene"],
        &["--camera-path", "orbit", "--camera-path-frames", "1"],
    ] {
        let (code, err) = view_without_display(bad);
        assert_ne!(code, Some(0), "{bad:?}");
        assert!(
            !err.contains("no display"),
            "{bad:?} was not checked first: {err}"
        );
        assert!(!err.contains("panicked"), "{bad:?}: {err}");
    }
    // And say which flag: a view the method does not draw (it showed another image), a size
    // the cache's cells cannot be sized for (a message naming nothing, after the adapter).
    for (bad, needle) in [
        (
            &["--method", "nee", "--show", "rejected"][..],
            "--show rejected: nee has no such view",
        ),
        (
            &["--method", "ris+cache", "--bounces", "64", "--size", "1x1"],
            "--size 1x1 at --scale 1 (with --method ris+cache): method ris+cache: the cache's cells",
        ),
    ] {
        let (code, err) = view_without_display(&[&["--scene", "cornell"][..], bad].concat());
        assert_eq!(code, Some(1), "{bad:?}: {err}");
        assert!(err.contains(needle), "{bad:?}: {err}");
    }
}

/// `view` with `args` and no display: its exit code and stderr.
fn view_without_display(args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(BIN)
        .arg("view")
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Closing the window (the window manager's WM_DELETE_WINDOW, sent here by hand to a bare Xvfb
/// server of the test's own) ends `view` with exit code 0 and writes --screenshot.
#[cfg(target_os = "linux")]
#[test]
fn closing_the_window_exits_0() {
    use std::process::Stdio;
    use std::time::Duration;
    use x11rb::connection::Connection;
    use x11rb::protocol::xproto::{ClientMessageEvent, ConnectionExt, EventMask};

    if display().is_none() {
        return;
    }
    if !on_path("Xvfb") {
        assert!(
            std::env::var_os(REQUIRED_ENV).is_none(),
            "Xvfb is not on PATH although `cargo xtask test` should have installed it"
        );
        eprintln!("skipped: no Xvfb (cargo xtask test installs it)");
        return;
    }
    let _one = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let dir = out_dir("close");
    let (mut server, display) = start_xvfb();
    let runtime = dir.join("xdg");
    std::fs::create_dir_all(&runtime).unwrap();
    let shot = dir.join("closed.png");
    let mut child = Command::new(BIN)
        .args([
            "view", "--scene", "cornell", "--method", "nee", "--size", "16x16",
        ])
        .arg("--screenshot")
        .arg(&shot)
        .env("DISPLAY", &display)
        .env_remove("WAYLAND_DISPLAY")
        .env("XDG_RUNTIME_DIR", &runtime)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (conn, screen) = x11rb::connect(Some(&display)).unwrap();
    let atom = |name: &[u8]| conn.intern_atom(false, name).unwrap().reply().unwrap().atom;
    let (protocols, delete) = (atom(b"WM_PROTOCOLS"), atom(b"WM_DELETE_WINDOW"));
    let window = view_window(&conn, conn.setup().roots[screen].root, &mut child);
    // Let it render a few frames, then close it as a window manager would.
    std::thread::sleep(Duration::from_secs(3));
    // Negative control: without a --exit-after-frames it runs until closed.
    assert!(child.try_wait().unwrap().is_none(), "view exited unclosed");
    let event = ClientMessageEvent::new(32, window, protocols, [delete, 0, 0, 0, 0]);
    conn.send_event(false, window, EventMask::NO_EVENT, event)
        .unwrap();
    conn.flush().unwrap();
    let exited = wait_for_exit(&mut child, Duration::from_secs(60));
    let _ = server.kill();
    let _ = server.wait();
    assert!(exited, "view did not exit after its window was closed");
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("view: wrote"), "{stdout}");
    assert_eq!(read_exr(&dir.join("closed.exr")).unwrap().width, 16);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A bare Xvfb server of the test's own and its display name (`:N`): `-displayfd 1` makes it
/// pick a free display and print its number once it is ready.
#[cfg(target_os = "linux")]
fn start_xvfb() -> (std::process::Child, String) {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut server = Command::new("Xvfb")
        .args([
            "-displayfd",
            "1",
            "-screen",
            "0",
            "1024x768x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(server.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    (server, format!(":{}", line.trim()))
}

/// The window `view` (`child`) opens under `root`, once it is there; panics when `view` exits
/// first or no window comes within two minutes.
#[cfg(target_os = "linux")]
fn view_window(
    conn: &impl x11rb::connection::Connection,
    root: u32,
    child: &mut std::process::Child,
) -> u32 {
    use std::time::{Duration, Instant};
    use x11rb::protocol::xproto::{AtomEnum, ConnectionExt};
    let start = Instant::now();
    loop {
        let children = conn.query_tree(root).unwrap().reply().unwrap().children;
        let found = children.into_iter().find(|&w| {
            conn.get_property(false, w, AtomEnum::WM_NAME, AtomEnum::ANY, 0, 256)
                .ok()
                .and_then(|c| c.reply().ok())
                .is_some_and(|p| p.value.starts_with(b"restir-demo view"))
        });
        if let Some(w) = found {
            return w;
        }
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            if let Some(mut e) = child.stderr.take() {
                let _ = std::io::Read::read_to_string(&mut e, &mut err);
            }
            panic!("view exited ({status}) before its window appeared: {err}");
        }
        assert!(start.elapsed() < Duration::from_secs(120), "no window");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Whether `child` exits within `limit` (it is killed when it does not).
#[cfg(target_os = "linux")]
fn wait_for_exit(child: &mut std::process::Child, limit: std::time::Duration) -> bool {
    let deadline = std::time::Instant::now() + limit;
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    true
}
