//! error_vs_time.svg: relMSE against cumulative GPU time, log-log, one curve per method; one
//! row per scene, indirect (left) and combined (right). Drawn with `plotters`' SVG backend
//! (text as SVG `<text>`, no font files needed).

use anyhow::{Result, anyhow};
use plotters::prelude::*;

use super::{MethodRun, Report};

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// The curve of one method: accumulated error for a static camera, per-frame error otherwise.
fn curve(m: &MethodRun, indirect: bool) -> Vec<(f64, f64)> {
    m.per_frame
        .iter()
        .filter_map(|f| {
            let t = f.cumulative_gpu_ms?;
            let e = if indirect {
                f.accumulated_rel_mse_indirect
                    .or(f.indirect.map(|e| e.rel_mse))?
            } else {
                f.accumulated_rel_mse_combined
                    .or(f.combined.map(|e| e.rel_mse))?
            };
            (t > 0.0 && e > 0.0 && t.is_finite() && e.is_finite()).then_some((t, e))
        })
        .collect()
}

pub fn svg(report: &Report) -> Result<String> {
    let rows = report.scenes.len().max(1);
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, (1000, 380 * rows as u32)).into_drawing_area();
        let e = |e| anyhow!("plotting: {e:?}");
        root.fill(&WHITE).map_err(e)?;
        let areas = root.split_evenly((rows, 2));
        for (i, sc) in report.scenes.iter().enumerate() {
            for (j, indirect) in [true, false].into_iter().enumerate() {
                let area = &areas[i * 2 + j];
                let curves: Vec<(&str, Vec<(f64, f64)>)> = sc
                    .methods
                    .iter()
                    .map(|m| (m.method.as_str(), curve(m, indirect)))
                    .filter(|(_, c)| !c.is_empty())
                    .collect();
                let title = format!(
                    "{} - {} ({})",
                    sc.scene,
                    if indirect { "indirect" } else { "combined" },
                    report.device
                );
                let pts = curves.iter().flat_map(|(_, c)| c.iter());
                let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                for &(x, y) in pts {
                    x0 = x0.min(x);
                    x1 = x1.max(x);
                    y0 = y0.min(y);
                    y1 = y1.max(y);
                }
                if curves.is_empty() {
                    (x0, x1, y0, y1) = (1.0, 10.0, 1e-3, 1.0);
                }
                let (x0, x1) = (x0 / 1.2, x1 * 1.2);
                let (y0, y1) = (y0 / 1.5, y1 * 1.5);
                let mut chart = ChartBuilder::on(area)
                    .caption(title, ("sans-serif", 16))
                    .margin(10)
                    .x_label_area_size(40)
                    .y_label_area_size(60)
                    .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
                    .map_err(e)?;
                chart
                    .configure_mesh()
                    .x_desc("cumulative GPU time (ms)")
                    .y_desc(if sc.camera == super::CameraMode::Static {
                        "relMSE of the accumulated image"
                    } else {
                        "relMSE of the frame"
                    })
                    .x_label_formatter(&|v| {
                        if *v >= 100.0 {
                            format!("{v:.0}")
                        } else {
                            format!("{v:.3}")
                        }
                    })
                    .y_label_formatter(&|v| format!("{v:.1e}"))
                    .draw()
                    .map_err(e)?;
                for (k, (name, c)) in curves.into_iter().enumerate() {
                    let color = PALETTE[k % PALETTE.len()];
                    chart
                        .draw_series(LineSeries::new(c, color.stroke_width(2)))
                        .map_err(e)?
                        .label(name)
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                        });
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .draw()
                    .map_err(e)?;
            }
        }
        root.present().map_err(e)?;
    }
    Ok(buf)
}
