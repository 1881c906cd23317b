//! The files of a compare run: report.json, report.md, error_vs_time.svg, strip.jpg.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use restir_world::image_io::{self, tone_map};
use restir_world::metrics;

use super::reference::Reference;
use super::report::{DenoisedErrors, EqualTime, Err2, ImageKind, MethodRun, Report, SceneReport};
use super::{Rgb, TIMING_WARMUP_FRAMES, plot};

/// JPEG quality of the strip image: the encoder keeps full-resolution colour, so two 256-pixel
/// rows of up to twelve images need a low quality to stay under 500 kB (70 gave 531 kB for nine).
const STRIP_JPEG_QUALITY: u8 = 40;

/// One scene's row of the image strip: reference | each method's last frame | each method's
/// FLIP error map.
#[derive(Debug)]
pub struct StripRow {
    pub width: u32,
    pub height: u32,
    pub reference: Rgb,
    pub methods: Vec<(String, Option<Rgb>)>,
    pub exposure: f32,
}

impl StripRow {
    /// The row of a scene's reference and each method's last image. The strip shows the
    /// methods without a variant (one column each), all when every listed method is a
    /// variant: variants live in the tables and the plot.
    pub fn new(reference: &Reference, lasts: Vec<(String, Option<Rgb>)>, exposure: f32) -> Self {
        let plain: Vec<_> = lasts
            .iter()
            .filter(|(n, _)| !n.contains(':'))
            .cloned()
            .collect();
        Self {
            width: reference.width,
            height: reference.height,
            reference: reference.combined.clone(),
            methods: if plain.is_empty() { lasts } else { plain },
            exposure,
        }
    }
}

pub fn write_all(out: &Path, report: &Report, strip: &[StripRow]) -> Result<()> {
    // Compact: the per-frame records make the pretty form several times larger.
    let json = serde_json::to_string(report)? + "\n";
    write(out, "report.json", json.as_bytes())?;
    write(out, "report.md", markdown(report, strip).as_bytes())?;
    write(out, "error_vs_time.svg", plot::svg(report)?.as_bytes())?;
    write_strip(&out.join("strip.jpg"), strip)?;
    Ok(())
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> Result<()> {
    Ok(image_io::write_bytes(&dir.join(name), bytes)?)
}

/// A perceptually ordered dark-to-bright colour map (black, purple, red, orange, pale yellow)
/// for error maps in [0, 1].
fn heat(v: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 5] = [
        [0.0, 0.0, 0.02],
        [0.32, 0.07, 0.45],
        [0.75, 0.17, 0.35],
        [0.98, 0.55, 0.15],
        [0.99, 0.99, 0.75],
    ];
    let v = if v.is_nan() { 1.0 } else { v.clamp(0.0, 1.0) } * 4.0;
    let i = (v.floor() as usize).min(3);
    let t = v - i as f32;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    [0, 1, 2].map(|c| ((a[c] + (b[c] - a[c]) * t) * 255.0 + 0.5) as u8)
}

fn write_strip(path: &Path, rows: &[StripRow]) -> Result<()> {
    const GAP: u32 = 2;
    let cols = rows
        .iter()
        .map(|r| 1 + 2 * r.methods.len() as u32)
        .max()
        .unwrap_or(1);
    let tile_w = rows.iter().map(|r| r.width).max().unwrap_or(1);
    let width = cols * tile_w + (cols - 1) * GAP;
    let height: u32 =
        rows.iter().map(|r| r.height).sum::<u32>() + GAP * rows.len().saturating_sub(1) as u32;
    let mut img = image::RgbImage::from_pixel(width.max(1), height.max(1), image::Rgb([255; 3]));
    let mut y0 = 0;
    for row in rows {
        let mut put = |col: u32, px: &dyn Fn(usize) -> [u8; 3]| {
            let x0 = col * (tile_w + GAP);
            for y in 0..row.height {
                for x in 0..row.width {
                    let i = (y * row.width + x) as usize;
                    img.put_pixel(x0 + x, y0 + y, image::Rgb(px(i)));
                }
            }
        };
        put(0, &|i| tone_map(row.reference[i], row.exposure));
        let n = row.methods.len() as u32;
        for (k, (_, last)) in row.methods.iter().enumerate() {
            let Some(last) = last else { continue };
            put(1 + k as u32, &|i| tone_map(last[i], row.exposure));
            let (_, map) =
                metrics::flip(last, &row.reference, row.width, row.height, row.exposure)?;
            put(1 + n + k as u32, &|i| heat(map[i]));
        }
        y0 += row.height + GAP;
    }
    Ok(image_io::write_jpeg(path, &img, STRIP_JPEG_QUALITY)?)
}

fn sci(v: Option<f64>) -> String {
    match v {
        Some(v) if v.is_finite() => {
            if v == 0.0 {
                "0".into()
            } else if (1e-2..1e4).contains(&v.abs()) {
                format!("{v:.3}")
            } else {
                format!("{v:.2e}")
            }
        }
        Some(_) => "non-finite".into(),
        None => "-".into(),
    }
}

/// Three ratios as `r/g/b` with three decimals, or `-`.
fn rgb(v: Option<[f64; 3]>) -> String {
    v.map_or_else(
        || "-".to_owned(),
        |v| format!("{:.3}/{:.3}/{:.3}", v[0], v[1], v[2]),
    )
}

/// relMSE with the trimmed relMSE in parentheses.
fn rel_trimmed(e: Option<Err2>) -> String {
    format!(
        "{} ({})",
        sci(e.map(|e| e.rel_mse)),
        sci(e.map(|e| e.rel_mse_trimmed))
    )
}

/// A value with another in parentheses (a plain and a trimmed ratio).
fn pair(a: Option<f64>, b: Option<f64>) -> String {
    format!("{} ({})", sci(a), sci(b))
}

/// A Markdown table: the header, its separator and one line per row.
fn table(s: &mut String, header: &[String], rows: impl IntoIterator<Item = Vec<String>>) {
    let line = |cells: &[String]| format!("| {} |", cells.join(" | "));
    let _ = writeln!(s, "{}", line(header));
    let _ = writeln!(s, "|{}", "---|".repeat(header.len()));
    for row in rows {
        let _ = writeln!(s, "{}", line(&row));
    }
    s.push('\n');
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| (*s).to_owned()).collect()
}

fn markdown(r: &Report, strip: &[StripRow]) -> String {
    let mut s = String::new();
    write_header(&mut s, r);
    for sc in &r.scenes {
        write_scene(&mut s, sc);
    }
    write_images_section(&mut s, r, strip);
    s
}

/// The title, the device, the command and what the numbers mean.
fn write_header(s: &mut String, r: &Report) {
    let _ = writeln!(s, "# Speed against error\n");
    let _ = writeln!(
        s,
        "Device: **{}** ({}, {}, driver {}). GPU time from timestamp queries{}.\n",
        r.device,
        r.device_type,
        r.backend,
        r.driver,
        if r.timestamps {
            ""
        } else {
            " (unavailable on this adapter: times are missing)"
        }
    );
    let roulette = match r.roulette_from {
        0 => "no Russian roulette".to_owned(),
        d => format!("Russian roulette from bounce {d}"),
    };
    let mis = if r.mis { ", MIS of emission hits" } else { "" };
    let _ = writeln!(
        s,
        "Paths: **{} bounce{}** of indirect light ({roulette}{mis}), for every method and the \
         reference.\n",
        r.bounces,
        if r.bounces == 1 { "" } else { "s" }
    );
    if r.device_type.contains("Cpu") {
        let _ = writeln!(
            s,
            "This adapter is a CPU (lavapipe): its \"GPU\" times are CPU times. Compare \
             ratios measured in the same run, not absolute milliseconds.\n"
        );
    }
    let _ = writeln!(
        s,
        "Command: `{}`  \nrestir-world {}\n",
        r.command, r.version
    );
    let _ = writeln!(
        s,
        "Errors against the reference, linear HDR, for each image (direct, indirect and \
         combined; the direct reference is the reference's combined image minus its indirect \
         one): MSE and relMSE = mean((I-R)^2/(R^2+{})) per channel; FLIP (mean, NVIDIA's \
         implementation via `nv-flip`) on images tone-mapped with the exposure that maps the \
         reference image's 99th-percentile luminance to 1. *Frame* errors are single frames \
         (the mean over the evaluated frames of the second half of the run); *accumulated* \
         errors are of the average of all frames (static camera only). GPU times leave out \
         the first {} frames of each run (pipeline compilation and first-use costs); \
         equal-time budgets use the median. *Bias* is the mean of the method's images over \
         the reference's, per channel, over the evaluated frames. *Trimmed* relMSE (in \
         parentheses) leaves out the 0.1% of pixels with the largest error: with many small \
         lights the estimators are heavy-tailed (1/d^2 next to a light) and a handful of \
         fireflies can decide the plain mean, and so which method looks better.\n",
        r.rel_mse_eps, TIMING_WARMUP_FRAMES,
    );
    if let Some(sc) = r.scenes.iter().find(|sc| sc.frames <= TIMING_WARMUP_FRAMES) {
        let _ = writeln!(
            s,
            "**This run has {} frames, not more than the {TIMING_WARMUP_FRAMES} warm-up \
             frames: its GPU times include the warm-up frames (all but the first of them), so \
             they hold pipeline compilation and first-use costs.** Run more --frames for \
             times.\n",
            sc.frames,
        );
    }
}

/// A scene's section: its reference, the methods' times, their errors image by image and the
/// equal-time comparison.
fn write_scene(s: &mut String, sc: &SceneReport) {
    let _ = writeln!(
        s,
        "## {} ({}x{}, {} frames, camera {:?}, {} triangles, {} emissive)\n",
        sc.scene, sc.width, sc.height, sc.frames, sc.camera, sc.triangles, sc.emissive_triangles
    );
    let rf = &sc.reference;
    let moving = match rf.count {
        1 => String::new(),
        n => format!(", {n} references for the moving camera"),
    };
    let own: Vec<String> = rf
        .self_rel_mse
        .iter()
        .filter_map(|(k, e)| e.map(|e| format!("{} {}", k.name(), sci(Some(e)))))
        .collect();
    let _ = writeln!(
        s,
        "Reference: {} ({}, {} spp{moving}); its own estimated relMSE: {}.\n",
        rf.source,
        rf.estimator,
        rf.samples,
        if own.is_empty() {
            "-".into()
        } else {
            own.join(", ")
        },
    );
    write_times(s, &sc.methods);
    for kind in ImageKind::ALL {
        write_errors(s, &sc.methods, kind);
    }
    write_denoised(s, &sc.methods);
    if let Some(eq) = &sc.equal_time {
        write_equal_time(s, eq, &sc.methods);
    }
}

/// The method's name, with its planted bias (a negative control).
fn method_name(m: &MethodRun) -> String {
    match m.planted_bias {
        Some(b) => format!("{} (planted bias x{b})", m.method),
        None => m.method.clone(),
    }
}

fn write_times(s: &mut String, methods: &[MethodRun]) {
    let header = strings(&[
        "method",
        "spp/frame",
        "ms/frame median (mean)",
        "median ms by stage",
        "grid overflows (most in a frame)",
        "bytes/pixel (path reuse)",
        "dispatches/frame",
    ]);
    let rows = methods.iter().map(|m| {
        let stages: Vec<String> = m
            .ms_per_frame_by_stage_median
            .iter()
            .map(|st| format!("{} {}", st.name, sci(Some(st.ms))))
            .collect();
        vec![
            method_name(m),
            m.spp_per_frame.to_string(),
            pair(m.ms_per_frame_median, m.ms_per_frame),
            stages.join(", "),
            m.max_grid_overflows
                .map_or_else(|| "-".to_owned(), |o| o.to_string()),
            match m.reuse_bytes_per_pixel {
                Some(r) => format!("{:.0} ({r:.0})", m.bytes_per_pixel),
                None => format!("{:.0}", m.bytes_per_pixel),
            },
            format!("{:.1}", m.dispatches_per_frame),
        ]
    });
    table(s, &header, rows);
}

/// Every method's errors on the image `kind`.
fn write_errors(s: &mut String, methods: &[MethodRun], kind: ImageKind) {
    let _ = writeln!(s, "{} image:\n", kind.name());
    let header = strings(&[
        "method",
        "frame relMSE (trimmed)",
        "frame MSE",
        "frame FLIP",
        "accum. relMSE (trimmed)",
        "accum. FLIP",
        "bias (mean / reference, RGB)",
    ]);
    let rows = methods.iter().map(|m| {
        let e = m.images.get(kind);
        vec![
            method_name(m),
            rel_trimmed(e.frame),
            sci(e.frame.map(|e| e.mse)),
            sci(e.frame_flip),
            rel_trimmed(e.accumulated),
            sci(e.accumulated_flip),
            rgb(e.bias),
        ]
    });
    table(s, &header, rows);
}

/// The denoised frames of every method run with `--denoise`, and which method gives the best
/// denoised image per unit of GPU time.
fn write_denoised(s: &mut String, methods: &[MethodRun]) {
    let runs: Vec<(&MethodRun, &DenoisedErrors)> = methods
        .iter()
        .filter_map(|m| Some((m, m.images.denoised.as_ref()?)))
        .collect();
    if runs.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "denoised image (the combined frame after the denoiser; frame times include its \
         `denoise` span):\n"
    );
    let header = strings(&[
        "method",
        "frame relMSE (trimmed)",
        "raw/denoised frame relMSE",
        "frame FLIP (raw)",
        "bias (mean / reference, RGB)",
        "frame-to-frame change, denoised (raw)",
        "denoise ms/frame (share)",
        "efficiency 1/(relMSE x ms) (trimmed)",
    ]);
    let efficiency = |m: &MethodRun, e: &DenoisedErrors, trimmed: bool| -> Option<f64> {
        let f = e.errors.frame?;
        let rel = if trimmed {
            f.rel_mse_trimmed
        } else {
            f.rel_mse
        };
        Some(1.0 / (rel * m.ms_per_frame_median?))
    };
    let rows = runs.iter().map(|(m, e)| {
        let raw = m.images.combined.frame.map(|f| f.rel_mse);
        let ratio = raw.zip(e.errors.frame).map(|(r, d)| r / d.rel_mse);
        let denoise_ms = m
            .ms_per_frame_by_stage_median
            .iter()
            .find(|st| st.name == "denoise")
            .map(|st| st.ms);
        let share = denoise_ms
            .zip(m.ms_per_frame_median)
            .map_or_else(String::new, |(d, t)| format!(" ({:.0}%)", 100.0 * d / t));
        vec![
            method_name(m),
            rel_trimmed(e.errors.frame),
            sci(ratio),
            format!(
                "{} ({})",
                sci(e.errors.frame_flip),
                sci(m.images.combined.frame_flip)
            ),
            rgb(e.errors.bias),
            pair(e.temporal_change, e.raw_temporal_change),
            format!("{}{share}", sci(denoise_ms)),
            pair(efficiency(m, e, false), efficiency(m, e, true)),
        ]
    });
    table(s, &header, rows);
    let best = runs
        .iter()
        .filter_map(|(m, e)| Some((m, efficiency(m, e, false)?)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((m, eff)) = best {
        let _ = writeln!(
            s,
            "Best denoised image per unit of GPU time: `{}` (efficiency {}).\n",
            m.method,
            sci(Some(eff))
        );
    }
}

fn write_equal_time(s: &mut String, eq: &EqualTime, methods: &[MethodRun]) {
    let target_errors: Vec<String> = eq
        .target_frame
        .iter()
        .map(|(k, e)| format!("{} {}", k.name(), rel_trimmed(*e)))
        .collect();
    let _ = writeln!(
        s,
        "### Equal time against `{}` ({} ms/frame; frame relMSE (trimmed) {})\n",
        eq.target,
        sci(Some(eq.target_ms_per_frame)),
        target_errors.join(", "),
    );
    let mut header = strings(&["method", "spp/frame in the same time", "ms/frame"]);
    for kind in ImageKind::ALL {
        let k = kind.name();
        header.push(format!("{k}: frame relMSE (trimmed)"));
        header.push(format!("{k}: relMSE ratio, method/{} (trimmed)", eq.target));
        header.push(format!(
            "{k}: equal-error speed-up of {} (trimmed)",
            eq.target
        ));
    }
    let rows = eq.entries.iter().map(|e| {
        let mut row = vec![
            e.method.clone(),
            e.spp_per_frame.to_string(),
            sci(e.ms_per_frame),
        ];
        for (_, i) in e.images.iter() {
            row.push(rel_trimmed(i.frame));
            row.push(pair(i.rel_mse_ratio, i.rel_mse_trimmed_ratio));
            row.push(pair(i.equal_error_speedup, i.equal_error_speedup_trimmed));
        }
        row
    });
    table(s, &header, rows);
    if let Some(t) = methods.iter().find(|m| m.method == eq.target)
        && let Some(total) = t.ms_per_frame.filter(|&ms| ms > 0.0)
    {
        let shares: Vec<String> = t
            .ms_per_frame_by_stage
            .iter()
            .map(|st| format!("{} {:.1}%", st.name, 100.0 * st.ms / total))
            .collect();
        let _ = writeln!(
            s,
            "`{}` frame by stage (share of its GPU time): {}.\n",
            eq.target,
            shares.join(", ")
        );
    }
    let _ = writeln!(
        s,
        "Equal-error speed-up: the GPU time the method needs to reach the target's frame \
         relMSE, from its equal-time error and the 1/N variance law of independent samples, \
         divided by the target's time per frame. Values below 1 mean the target is slower at \
         equal error.\n"
    );
}

/// Where the plot and the image strip are, and what each strip row shows.
fn write_images_section(s: &mut String, r: &Report, strip: &[StripRow]) {
    let _ = writeln!(
        s,
        "## Plots and images\n\n![relMSE against cumulative GPU time](error_vs_time.svg)\n\n\
         `error_vs_time.svg`: relMSE of the accumulated image (static camera; per-frame error for \
         a moving camera) against cumulative GPU time, log-log, one curve per method; left: \
         indirect, right: combined.\n\n![image strip](strip.jpg)\n"
    );
    for (row, sc) in strip.iter().zip(&r.scenes) {
        let names: Vec<&str> = row.methods.iter().map(|(n, _)| n.as_str()).collect();
        let _ = writeln!(
            s,
            "`strip.jpg`, row {}: reference | {} (last frame, combined) | FLIP error maps of \
             the same, in the same order (dark = no visible error).\n",
            sc.scene,
            names.join(" | ")
        );
    }
}
