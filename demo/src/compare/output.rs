//! The files of a compare run: report.json, report.md, error_vs_time.svg, strip.png.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use restir_world::image_io::{self, tone_map};
use restir_world::metrics;

use super::{Err2, Report, plot};

/// One scene's row of the image strip: reference | each method's last frame | each method's
/// FLIP error map.
#[derive(Debug)]
pub struct StripRow {
    pub width: u32,
    pub height: u32,
    pub reference: Vec<[f32; 3]>,
    pub methods: Vec<(String, Option<Vec<[f32; 3]>>)>,
    pub exposure: f32,
}

pub fn write_all(out: &Path, report: &Report, strip: &[StripRow]) -> Result<()> {
    // Compact: the per-frame records make the pretty form several times larger.
    let json = serde_json::to_string(report)? + "\n";
    write(out, "report.json", json.as_bytes())?;
    write(out, "report.md", markdown(report, strip).as_bytes())?;
    write(out, "error_vs_time.svg", plot::svg(report)?.as_bytes())?;
    write_strip(&out.join("strip.png"), strip)?;
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
    Ok(image_io::write_png8(path, img)?)
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

fn rel(e: Option<Err2>) -> Option<f64> {
    e.map(|e| e.rel_mse)
}

fn trim(e: Option<Err2>) -> Option<f64> {
    e.map(|e| e.rel_mse_trimmed)
}

fn mse(e: Option<Err2>) -> Option<f64> {
    e.map(|e| e.mse)
}

fn markdown(r: &Report, strip: &[StripRow]) -> String {
    let mut s = String::new();
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
        "Errors against the reference, linear HDR: MSE and relMSE = mean((I-R)^2/(R^2+{})) per \
         channel; FLIP (mean, NVIDIA's implementation via `nv-flip`) on images tone-mapped with \
         the exposure that maps the reference's 99th-percentile luminance to 1. *Frame* errors \
         are single frames (the mean over the evaluated frames of the second half of the run); \
         *accumulated* errors are of the average of all frames (static camera only). GPU \
         times leave out the first {} frames of each run (pipeline compilation and first-use \
         costs); equal-time budgets use the median. *Bias* is the mean of the method's images \
         over the reference's, per channel, over the evaluated frames. *Trimmed* \
         relMSE leaves out the 0.1% of pixels with the largest error: with many small lights \
         the estimators are heavy-tailed (1/d^2 next to a light) and a handful of fireflies can \
         decide the plain mean, and so which method looks better.\n",
        r.rel_mse_eps,
        super::TIMING_WARMUP_FRAMES,
    );
    if let Some(sc) = r
        .scenes
        .iter()
        .find(|sc| sc.frames <= super::TIMING_WARMUP_FRAMES)
    {
        let _ = writeln!(
            s,
            "**This run has {} frames, not more than the {} warm-up frames: its GPU times \
             include the warm-up frames (all but the first of them), so they hold pipeline \
             compilation and first-use costs.** Run more --frames for times.\n",
            sc.frames,
            super::TIMING_WARMUP_FRAMES
        );
    }
    for sc in &r.scenes {
        let _ = writeln!(
            s,
            "## {} ({}x{}, {} frames, camera {:?}, {} triangles, {} emissive)\n",
            sc.scene,
            sc.width,
            sc.height,
            sc.frames,
            sc.camera,
            sc.triangles,
            sc.emissive_triangles
        );
        let rf = &sc.reference;
        let _ = writeln!(
            s,
            "Reference: {} ({}, {} spp{}); its own estimated relMSE: combined {}, indirect {}.\n",
            rf.source,
            rf.estimator,
            rf.samples,
            if rf.count > 1 {
                format!(", {} references for the moving camera", rf.count)
            } else {
                String::new()
            },
            sci(rf.self_rel_mse_combined),
            sci(rf.self_rel_mse_indirect),
        );
        let _ = writeln!(
            s,
            "| method | spp/frame | ms/frame median (mean) | median ms by stage | frame relMSE \
             indirect | frame relMSE indirect, 0.1% trimmed | frame relMSE direct (trimmed) | \
             frame relMSE combined (trimmed) | frame MSE indirect | frame MSE combined | frame \
             FLIP combined | accum. relMSE indirect | accum. relMSE combined | accum. FLIP \
             combined | bias indirect (mean / reference, RGB) | bias direct | bias combined | \
             grid overflows (most in a frame) |"
        );
        let _ = writeln!(
            s,
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
        );
        for m in &sc.methods {
            let stages: Vec<String> = m
                .ms_per_frame_by_stage_median
                .iter()
                .map(|st| format!("{} {}", st.name, sci(Some(st.ms))))
                .collect();
            let _ = writeln!(
                s,
                "| {}{} | {} | {} ({}) | {} | {} | {} | {} ({}) | {} ({}) | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                m.method,
                m.planted_bias
                    .map(|b| format!(" (planted bias x{b})"))
                    .unwrap_or_default(),
                m.spp_per_frame,
                sci(m.ms_per_frame_median),
                sci(m.ms_per_frame),
                stages.join(", "),
                sci(rel(m.frame_indirect)),
                sci(trim(m.frame_indirect)),
                sci(rel(m.frame_direct)),
                sci(trim(m.frame_direct)),
                sci(rel(m.frame_combined)),
                sci(trim(m.frame_combined)),
                sci(mse(m.frame_indirect)),
                sci(mse(m.frame_combined)),
                sci(m.frame_flip_combined),
                sci(rel(m.accumulated_indirect)),
                sci(rel(m.accumulated_combined)),
                sci(m.accumulated_flip_combined),
                rgb(m.bias_indirect),
                rgb(m.bias_direct),
                rgb(m.bias_combined),
                m.max_grid_overflows
                    .map_or_else(|| "-".to_owned(), |o| o.to_string()),
            );
        }
        s.push('\n');
        if let Some(eq) = &sc.equal_time {
            let _ = writeln!(
                s,
                "### Equal time against `{}` ({} ms/frame; frame relMSE indirect {} (trimmed {}), \
                 direct {} (trimmed {}), combined {} (trimmed {}))\n",
                eq.target,
                sci(Some(eq.target_ms_per_frame)),
                sci(rel(eq.target_frame_indirect)),
                sci(trim(eq.target_frame_indirect)),
                sci(rel(eq.target_frame_direct)),
                sci(trim(eq.target_frame_direct)),
                sci(rel(eq.target_frame_combined)),
                sci(trim(eq.target_frame_combined)),
            );
            let _ = writeln!(
                s,
                "| method | spp/frame in the same time | ms/frame | frame relMSE indirect | \
                 frame relMSE indirect, trimmed | frame relMSE combined | relMSE ratio indirect \
                 (method/{t}) | same, trimmed | relMSE ratio direct | same, trimmed | relMSE \
                 ratio combined | same, trimmed | equal-error speed-up of {t}, indirect | same, \
                 trimmed | equal-error speed-up, combined |",
                t = eq.target
            );
            let _ = writeln!(
                s,
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
            );
            for e in &eq.entries {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    e.method,
                    e.spp_per_frame,
                    sci(e.ms_per_frame),
                    sci(rel(e.frame_indirect)),
                    sci(trim(e.frame_indirect)),
                    sci(rel(e.frame_combined)),
                    sci(e.rel_mse_ratio_indirect),
                    sci(e.rel_mse_trimmed_ratio_indirect),
                    sci(e.rel_mse_ratio_direct),
                    sci(e.rel_mse_trimmed_ratio_direct),
                    sci(e.rel_mse_ratio_combined),
                    sci(e.rel_mse_trimmed_ratio_combined),
                    sci(e.equal_error_speedup_indirect),
                    sci(e.equal_error_speedup_indirect_trimmed),
                    sci(e.equal_error_speedup_combined),
                );
            }
            if let Some(t) = sc.methods.iter().find(|m| m.method == eq.target)
                && let Some(total) = t.ms_per_frame.filter(|&ms| ms > 0.0)
            {
                let shares: Vec<String> = t
                    .ms_per_frame_by_stage
                    .iter()
                    .map(|st| format!("{} {:.1}%", st.name, 100.0 * st.ms / total))
                    .collect();
                let _ = writeln!(
                    s,
                    "\n`{}` frame by stage (share of its GPU time): {}.",
                    eq.target,
                    shares.join(", ")
                );
            }
            let _ = writeln!(
                s,
                "\nEqual-error speed-up: the GPU time the method needs to reach the target's \
                 frame relMSE, from its equal-time error and the 1/N variance law of independent \
                 samples, divided by the target's time per frame. Values below 1 mean the target \
                 is slower at equal error.\n"
            );
        }
    }
    let _ = writeln!(
        s,
        "## Plots and images\n\n![relMSE against cumulative GPU time](error_vs_time.svg)\n\n\
         `error_vs_time.svg`: relMSE of the accumulated image (static camera; per-frame error for \
         a moving camera) against cumulative GPU time, log-log, one curve per method; left: \
         indirect, right: combined.\n\n![image strip](strip.png)\n"
    );
    for (row, sc) in strip.iter().zip(&r.scenes) {
        let names: Vec<&str> = row.methods.iter().map(|(n, _)| n.as_str()).collect();
        let _ = writeln!(
            s,
            "`strip.png`, row {}: reference | {} (last frame, combined) | FLIP error maps of \
             the same, in the same order (dark = no visible error).\n",
            sc.scene,
            names.join(" | ")
        );
    }
    s
}
