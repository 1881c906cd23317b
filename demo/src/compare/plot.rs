//! error_vs_time.svg: relMSE against cumulative GPU time, log-log, one curve per method; one
//! row per scene, indirect (left) and combined (right). Drawn with `plotters`' SVG backend
//! (text as SVG `<text>`, no font files needed).

use std::ops::Range;

use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::CameraMode;
use super::report::{ImageKind, MethodRun, Report, SceneReport};

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

/// The images plotted, left to right.
const PANELS: [ImageKind; 2] = [ImageKind::Indirect, ImageKind::Combined];

/// A method's curve: (cumulative GPU ms, relMSE) of the accumulated image for a static
/// camera, of each frame otherwise; only positive, finite points (the axes are logarithmic).
fn curve(m: &MethodRun, kind: ImageKind) -> Vec<(f64, f64)> {
    m.per_frame
        .iter()
        .filter_map(|f| {
            let t = f.cumulative_gpu_ms?;
            let e = f.images.get(kind).as_ref()?;
            let e = e.accumulated_rel_mse.unwrap_or(e.error.rel_mse);
            (t > 0.0 && e > 0.0 && t.is_finite() && e.is_finite()).then_some((t, e))
        })
        .collect()
}

/// The log-log ranges that hold every point, with a margin (around a decade each without
/// points).
fn ranges(curves: &[(&str, Vec<(f64, f64)>)]) -> (Range<f64>, Range<f64>) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in curves.iter().flat_map(|(_, c)| c.iter()) {
        (x0, x1) = (x0.min(x), x1.max(x));
        (y0, y1) = (y0.min(y), y1.max(y));
    }
    if curves.is_empty() {
        (x0, x1, y0, y1) = (1.0, 10.0, 1e-3, 1.0);
    }
    (x0 / 1.2..x1 * 1.2, y0 / 1.5..y1 * 1.5)
}

fn plot_error<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotting: {e:?}")
}

pub fn svg(report: &Report) -> Result<String> {
    let rows = report.scenes.len().max(1);
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, (1000, 380 * rows as u32)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let areas = root.split_evenly((rows, PANELS.len()));
        for (i, sc) in report.scenes.iter().enumerate() {
            for (j, kind) in PANELS.into_iter().enumerate() {
                let title = format!("{} - {} ({})", sc.scene, kind.name(), report.device);
                panel(&areas[i * PANELS.len() + j], &title, sc, kind)?;
            }
        }
        root.present().map_err(plot_error)?;
    }
    Ok(buf)
}

/// One scene's curves of the image `kind`.
fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    sc: &SceneReport,
    kind: ImageKind,
) -> Result<()> {
    let curves: Vec<(&str, Vec<(f64, f64)>)> = sc
        .methods
        .iter()
        .map(|m| (m.method.as_str(), curve(m, kind)))
        .filter(|(_, c)| !c.is_empty())
        .collect();
    let (x, y) = ranges(&curves);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(x.log_scale(), y.log_scale())
        .map_err(plot_error)?;
    chart
        .configure_mesh()
        .x_desc("cumulative GPU time (ms)")
        .y_desc(if sc.camera == CameraMode::Static {
            "relMSE of the accumulated image"
        } else {
            "relMSE of the frame"
        })
        .x_label_formatter(&|v| match *v >= 100.0 {
            true => format!("{v:.0}"),
            false => format!("{v:.3}"),
        })
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .draw()
        .map_err(plot_error)?;
    for (k, (name, c)) in curves.into_iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        chart
            .draw_series(LineSeries::new(c, color.stroke_width(2)))
            .map_err(plot_error)?
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
        .map_err(plot_error)?;
    Ok(())
}
