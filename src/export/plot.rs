//! Error-against-time plot of a convergence study (`convergence.svg`), with plotters' SVG
//! backend: one curve per knob, log–log axes, the base preset's rungs ringed.

use crate::error::{Error, Result};
use plotters::prelude::*;
use std::path::Path;

/// One curve: a name and its (seconds, relative error, is base) points, coarse to fine.
pub struct Curve {
    /// Legend entry.
    pub name: String,
    /// (wall time s, relative error as a fraction, base setting) per rung.
    pub points: Vec<(f64, f64, bool)>,
}

/// Relative errors below this are drawn at it (the finest rung of each ladder is 0).
const FLOOR: f64 = 1e-4;

/// Writes the plot to `path` (SVG, 900 × 600), atomically.
///
/// # Errors
/// [`Error::Io`] when the file cannot be written; [`Error::Internal`] when drawing fails.
pub fn error_vs_time_svg(path: &Path, title: &str, curves: &[Curve]) -> Result<()> {
    let mut svg = String::new();
    draw(&mut svg, title, curves).map_err(|e| Error::Internal(format!("plot: {e}")))?;
    crate::files::write_atomic(path, svg.as_bytes())
}

fn draw(svg: &mut String, title: &str, curves: &[Curve]) -> std::result::Result<(), String> {
    let pts = curves.iter().flat_map(|c| c.points.iter());
    let (mut x0, mut x1, mut y1) = (f64::INFINITY, 0.0f64, FLOOR * 10.0);
    for p in pts {
        x0 = x0.min(p.0);
        x1 = x1.max(p.0);
        y1 = y1.max(p.1);
    }
    if !x0.is_finite() || x0 <= 0.0 {
        x0 = 0.01;
    }
    let x1 = x1.max(x0 * 10.0);
    let root = SVGBackend::with_string(svg, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 * 0.7..x1 * 1.4).log_scale(),
            (FLOOR * 0.7..y1 * 1.5).log_scale(),
        )
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("wall time of one cold instant, s")
        .y_desc("RMS relative error vs finest setting")
        .y_label_formatter(&|v| format!("{:.2} %", 100.0 * v))
        .draw()
        .map_err(|e| e.to_string())?;
    for (i, c) in curves.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let line: Vec<(f64, f64)> = c.points.iter().map(|p| (p.0, p.1.max(FLOOR))).collect();
        chart
            .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(c.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart
            .draw_series(line.iter().map(|p| Circle::new(*p, 3, color.filled())))
            .map_err(|e| e.to_string())?;
        let base = c
            .points
            .iter()
            .filter(|p| p.2)
            .map(|p| (p.0, p.1.max(FLOOR)));
        chart
            .draw_series(base.map(|p| Circle::new(p, 7, BLACK.stroke_width(1))))
            .map_err(|e| e.to_string())?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_an_svg_with_one_legend_entry_per_curve() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("c.svg");
        let curves = [
            Curve {
                name: "sky subdivision".into(),
                points: vec![(0.5, 0.03, false), (1.0, 0.01, true), (4.0, 0.0, false)],
            },
            Curve {
                name: "interreflection lines".into(),
                points: vec![(0.3, 0.1, false), (2.0, 0.0, false)],
            },
        ];
        error_vs_time_svg(&p, "office", &curves).unwrap();
        let s = std::fs::read_to_string(&p).unwrap();
        assert!(s.starts_with("<svg"), "{}", &s[..50.min(s.len())]);
        assert!(s.contains("sky subdivision") && s.contains("interreflection lines"));
        assert!(s.contains("office"));
    }
}
