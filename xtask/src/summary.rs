//! The summary table that opens docs/results.md: for each part and scene of the committed
//! compare reports, the method with the best efficiency, 1 / (single-frame relMSE x median GPU
//! ms per frame), for the combined image and for the indirect light, as a factor over `ris`
//! in the same run, with its relMSE and its time. Generated from the reports' `report.json`,
//! so that it can never disagree with the tables below it.

use std::path::Path;

use serde_json::Value;

/// The method every factor is measured against: the baseline of every part.
const BASELINE: &str = "ris";

/// The images summarised: the combined image (what a user sees) and the indirect light (what
/// the global-illumination methods change). The direct image is left out: a method that
/// leaves it alone but runs a faster frame would "win" it.
const IMAGES: [(&str, &str); 3] = [
    ("combined", "combined image"),
    ("indirect", "indirect light"),
    ("denoised", "denoised image"),
];

/// One method of one scene's run: its name, median GPU ms per frame, and single-frame relMSE
/// per image of [`IMAGES`].
struct MethodFigures {
    name: String,
    ms: f64,
    rel_mse: [Option<f64>; IMAGES.len()],
}

impl MethodFigures {
    fn efficiency(&self, image: usize) -> Option<f64> {
        let e = self.rel_mse[image]?;
        (e > 0.0 && self.ms > 0.0).then(|| 1.0 / (e * self.ms))
    }
}

/// The summary section (Markdown, ending in a blank line) of the parts `(title, report.json)`.
pub fn summary(parts: &[(&str, &Path)]) -> Result<String, String> {
    let mut rows = String::new();
    let mut devices: Vec<String> = Vec::new();
    let mut seeds: Vec<String> = Vec::new();
    for (title, path) in parts {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("reading {} (run its part first): {e}", path.display()))?;
        let report: Value =
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        if let Some(d) = report.get("device").and_then(Value::as_str)
            && !devices.iter().any(|x| x == d)
        {
            devices.push(d.to_owned());
        }
        let seed = seed_of(report.get("command").and_then(Value::as_str).unwrap_or(""));
        if !seeds.contains(&seed) {
            seeds.push(seed);
        }
        let scenes = report
            .get("scenes")
            .and_then(Value::as_array)
            .ok_or_else(|| format!("{}: no scenes", path.display()))?;
        for scene in scenes {
            rows += &scene_row(title, scene).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    let device = match devices.as_slice() {
        [] => String::new(),
        d => format!(", on {}", d.join(", ")),
    };
    let seeds = seeds.join(", ");
    Ok(format!(
        "# Summary: which method wins where\n\n\
         Generated from the reports below: one run of each part, seed {seeds}{device}. For \
         each part and scene: the method with the best efficiency, 1 / (single-frame relMSE x median GPU ms \
         per frame), for the combined image and for the indirect light; its factor over \
         `{BASELINE}`'s efficiency in the same run (above 1: lower error than `{BASELINE}` at \
         equal GPU time), its relMSE and its GPU time per frame. On a CPU adapter the times \
         are CPU times: compare within a row. The denoised image (the last frame after the \
         denoiser, its time included) only where a part runs `--denoise`. Three seeds and \
         moving cameras are measured in the notes after the reports.\n\n\
         | part | scene, camera | `{BASELINE}`: relMSE combined / indirect, ms per frame \
         | best for the combined image | best for the indirect light | best for the denoised \
         image |\n\
         |---|---|---|---|---|---|\n{rows}\n"
    ))
}

/// One line per scene and method of the compare report at `path`: its relMSE and GPU time,
/// and its efficiency over [`BASELINE`]'s, for each image of [`IMAGES`] (what `cargo xtask
/// demo` says it measured).
pub fn method_lines(path: &Path) -> Result<Vec<String>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let report: Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let scenes = report
        .get("scenes")
        .and_then(Value::as_array)
        .ok_or_else(|| format!("{}: no scenes", path.display()))?;
    let mut lines = Vec::new();
    for scene in scenes {
        let name = scene.get("scene").and_then(Value::as_str).unwrap_or("?");
        let methods: Vec<MethodFigures> = scene
            .get("methods")
            .and_then(Value::as_array)
            .map(|m| m.iter().filter_map(method_figures).collect())
            .unwrap_or_default();
        let baseline = methods.iter().find(|m| m.name == BASELINE);
        for m in &methods {
            let images: Vec<String> = IMAGES
                .iter()
                .enumerate()
                .filter(|(i, _)| m.rel_mse[*i].is_some())
                .map(|(i, (key, _))| {
                    let factor = match (m.efficiency(i), baseline.and_then(|b| b.efficiency(i))) {
                        (Some(e), Some(b)) if m.name != BASELINE => {
                            format!(", {:.2}x `{BASELINE}`'s efficiency", e / b)
                        }
                        _ => String::new(),
                    };
                    format!("{key} relMSE {}{factor}", relmse(m.rel_mse[i]))
                })
                .collect();
            lines.push(format!(
                "{name}, {}: {} ms/frame; {}",
                m.name,
                ms(m.ms),
                images.join("; ")
            ));
        }
    }
    Ok(lines)
}

/// The `--seed` of a report's command line (compare's default: 1).
fn seed_of(command: &str) -> String {
    let words: Vec<&str> = command.split_whitespace().collect();
    let mut seed = "1";
    for (i, w) in words.iter().enumerate() {
        if let Some(s) = w.strip_prefix("--seed=") {
            seed = s;
        } else if *w == "--seed"
            && let Some(s) = words.get(i + 1)
        {
            seed = s;
        }
    }
    seed.to_owned()
}

/// One table row: a scene of a part.
fn scene_row(title: &str, scene: &Value) -> Result<String, String> {
    let name = scene
        .get("scene")
        .and_then(Value::as_str)
        .ok_or("a scene without a name")?;
    let camera = scene.get("camera").and_then(Value::as_str).unwrap_or("?");
    let size = match (
        scene.get("width").and_then(Value::as_f64),
        scene.get("height").and_then(Value::as_f64),
    ) {
        (Some(w), Some(h)) => format!(", {w}x{h}"),
        _ => String::new(),
    };
    let methods: Vec<MethodFigures> = scene
        .get("methods")
        .and_then(Value::as_array)
        .ok_or_else(|| format!("{name}: no methods"))?
        .iter()
        .filter_map(method_figures)
        .collect();
    let baseline = methods.iter().find(|m| m.name == BASELINE);
    let baseline_cell = match baseline {
        Some(b) => format!(
            "{} / {}, {} ms",
            relmse(b.rel_mse[0]),
            relmse(b.rel_mse[1]),
            ms(b.ms)
        ),
        None => "not run".into(),
    };
    let mut row = format!("| {title} | {name}, {camera}{size} | {baseline_cell} |");
    for image in 0..IMAGES.len() {
        let best = methods
            .iter()
            .filter_map(|m| Some((m, m.efficiency(image)?)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let cell = match best {
            None => "-".into(),
            Some((m, eff)) => {
                let factor = baseline
                    .and_then(|b| b.efficiency(image))
                    .map(|b| format!("**{:.2}x** `{BASELINE}`, ", eff / b))
                    .unwrap_or_default();
                format!(
                    "`{}`: {factor}relMSE {} at {} ms",
                    m.name,
                    relmse(m.rel_mse[image]),
                    ms(m.ms)
                )
            }
        };
        row += &format!(" {cell} |");
    }
    Ok(row + "\n")
}

/// A method's figures; `None` for a planted control or a method without a time.
fn method_figures(method: &Value) -> Option<MethodFigures> {
    if method
        .get("planted_bias")
        .is_some_and(|p| *p != Value::Null)
    {
        return None;
    }
    let name = method.get("method")?.as_str()?.to_owned();
    let ms = method.get("ms_per_frame_median")?.as_f64()?;
    // Reports since the denoiser keep each image under `images`; the older (one-bounce)
    // report has `frame_combined`, `frame_indirect`, ...
    let rel_mse = IMAGES.map(|(key, _)| {
        method
            .pointer(&format!("/images/{key}/frame/rel_mse"))
            .or_else(|| method.pointer(&format!("/frame_{key}/rel_mse")))
            .and_then(Value::as_f64)
    });
    Some(MethodFigures { name, ms, rel_mse })
}

/// relMSE to three significant digits (below 0.001 as the reports print it, `8.39e-4`).
fn relmse(e: Option<f64>) -> String {
    match e {
        None => "-".into(),
        Some(e) if e >= 100.0 => format!("{e:.0}"),
        Some(e) if e >= 0.001 => {
            let decimals = (2.0 - e.log10().floor()).max(0.0) as usize;
            format!("{e:.decimals$}")
        }
        Some(e) => format!("{e:.2e}"),
    }
}

/// Milliseconds, whole above 10.
fn ms(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_the_most_efficient_method_in_both_report_layouts() {
        let scene: Value = serde_json::from_str(
            r#"{"scene": "cornell", "camera": "static", "width": 64, "height": 64, "methods": [
              {"method": "ris", "ms_per_frame_median": 100.0, "planted_bias": null,
               "images": {"combined": {"frame": {"rel_mse": 0.2}},
                          "indirect": {"frame": {"rel_mse": 0.4}},
                          "denoised": {"frame": {"rel_mse": 0.01}}}},
              {"method": "fast", "ms_per_frame_median": 50.0,
               "frame_combined": {"rel_mse": 0.3}, "frame_indirect": {"rel_mse": 0.4}},
              {"method": "planted", "ms_per_frame_median": 1.0, "planted_bias": 0.5,
               "images": {"combined": {"frame": {"rel_mse": 0.001}}}}
            ]}"#,
        )
        .unwrap();
        let row = scene_row("part", &scene).unwrap();
        assert_eq!(relmse(Some(0.02453)), "0.0245");
        assert_eq!(relmse(Some(0.58)), "0.580");
        assert_eq!(relmse(Some(16.21)), "16.2");
        assert_eq!(relmse(Some(8.39e-4)), "8.39e-4");
        // fast: combined 1/(0.3 x 50) against ris's 1/(0.2 x 100): 1.33x; indirect 2x.
        assert!(
            row.contains("| part | cornell, static, 64x64 | 0.200 / 0.400, 100 ms |"),
            "{row}"
        );
        assert!(
            row.contains("`fast`: **1.33x** `ris`, relMSE 0.300 at 50 ms |"),
            "{row}"
        );
        assert!(
            row.contains("`fast`: **2.00x** `ris`, relMSE 0.400 at 50 ms |"),
            "{row}"
        );
        assert!(!row.contains("planted"), "{row}");
        // Only ris has a denoised image: it is the best there (1x itself).
        assert!(
            row.ends_with("`ris`: **1.00x** `ris`, relMSE 0.0100 at 100 ms |\n"),
            "{row}"
        );
    }

    #[test]
    fn says_what_each_method_measured() {
        let dir = std::env::temp_dir().join(format!("xtask-lines-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("report.json");
        std::fs::write(
            &path,
            r#"{"scenes": [{"scene": "cornell", "methods": [
              {"method": "ris", "ms_per_frame_median": 100.0,
               "images": {"combined": {"frame": {"rel_mse": 0.2}},
                          "indirect": {"frame": {"rel_mse": 0.4}}}},
              {"method": "fast", "ms_per_frame_median": 50.0,
               "images": {"combined": {"frame": {"rel_mse": 0.3}},
                          "indirect": {"frame": {"rel_mse": 0.4}}}}]}]}"#,
        )
        .unwrap();
        let lines = method_lines(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            lines,
            [
                "cornell, ris: 100 ms/frame; combined relMSE 0.200; indirect relMSE 0.400",
                "cornell, fast: 50 ms/frame; combined relMSE 0.300, 1.33x `ris`'s efficiency; \
                 indirect relMSE 0.400, 2.00x `ris`'s efficiency"
            ]
        );
    }

    #[test]
    fn reads_the_seed_of_a_command() {
        assert_eq!(seed_of("restir-demo compare --frames 18"), "1");
        assert_eq!(seed_of("restir-demo compare --seed 3 --frames 18"), "3");
        assert_eq!(seed_of("restir-demo compare --seed=2"), "2");
    }
}
