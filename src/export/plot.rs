//! Error-against-time plot of a convergence study (`convergence.svg`), with plotters' SVG
//! backend: one curve per knob, time linear and error logarithmic, each point's timing
//! spread as a bar, the base preset's rungs ringed, each knob's reference (finest)
//! setting a labelled mark on the bottom line.

use crate::error::{Error, Result};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// One rung of a curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Median time (CPU time for a convergence study), s.
    pub seconds: f64,
    /// Fastest and slowest timed run, s (drawn as a horizontal bar).
    pub seconds_min: f64,
    /// See `seconds_min`.
    pub seconds_max: f64,
    /// Relative error as a fraction.
    pub rel_err: f64,
    /// The base preset's setting (ringed).
    pub is_base: bool,
    /// `Some(setting)` for the ladder's reference (finest) rung: its error is 0 by
    /// construction, so it is drawn as a labelled mark on the axis, not as a measurement.
    pub reference: Option<String>,
}

/// One curve: a name and its points, coarse to fine.
pub struct Curve {
    /// Legend entry.
    pub name: String,
    /// The rungs, coarse to fine.
    pub points: Vec<Point>,
}

/// Okabe & Ito's colour-blind-safe palette without its yellow, which is hard to see on
/// white; black last, as the base rungs' rings are black too.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0xE6, 0x9F, 0x00), // orange
    RGBColor(0x56, 0xB4, 0xE9), // sky blue
    RGBColor(0x00, 0x9E, 0x73), // bluish green
    RGBColor(0x00, 0x72, 0xB2), // blue
    RGBColor(0xD5, 0x5E, 0x00), // vermillion
    RGBColor(0xCC, 0x79, 0xA7), // reddish purple
    RGBColor(0x00, 0x00, 0x00), // black
];

/// Grey for curves beyond the palette's seven (the presets' ladder is the eighth).
const GREY: RGBColor = RGBColor(0x99, 0x99, 0x99);

/// The colour of curve `i`: the palette's seven, then grey.
pub fn color(i: usize) -> RGBColor {
    PALETTE.get(i).copied().unwrap_or(GREY)
}

/// Errors below this fraction (0.001 %) are drawn on it: they are round-off, not
/// convergence (an iteration tolerance's finest rungs agree to 1e-11), and a log axis
/// down to them would squash every real difference into its top.
const ERROR_FLOOR: f64 = 1e-5;

/// Writes the plot to `path` (SVG, 900 × 600), atomically.
///
/// # Errors
/// [`Error::Io`] when the file cannot be written; [`Error::Internal`] when drawing fails.
pub fn error_vs_time_svg(path: &Path, title: &str, curves: &[Curve]) -> Result<()> {
    let mut svg = String::new();
    draw(&mut svg, title, curves).map_err(|e| Error::Internal(format!("plot: {e}")))?;
    crate::files::write_atomic(path, svg.as_bytes())
}

/// The axes' ranges: time (s) over every run's spread, padded, except references more
/// than twice as slow as every measured run: those are drawn at the right edge with their
/// time in their label, so one slow reference does not squash the curves; error over the measured (non-reference)
/// points, at least [`ERROR_FLOOR`], with the bottom a little below the smallest one, where
/// the references are marked.
fn ranges(curves: &[Curve]) -> ((f64, f64), (f64, f64)) {
    let pts = || curves.iter().flat_map(|c| c.points.iter());
    let measured_pts = || pts().filter(|p| p.reference.is_none());
    let mut x0 = pts().map(|p| p.seconds_min).fold(f64::INFINITY, f64::min);
    let slowest = measured_pts().map(|p| p.seconds_max).fold(0.0, f64::max);
    // References up to twice the slowest measured run are on the axis; slower ones clip.
    let mut x1 = pts()
        .filter(|p| slowest <= 0.0 || p.seconds_max <= 2.0 * slowest)
        .map(|p| p.seconds_max)
        .fold(0.0, f64::max);
    if !(x0.is_finite() && x0 > 0.0) {
        x0 = 0.01;
    }
    x1 = x1.max(x0 * 1.1);
    let measured = || pts().filter(|p| p.reference.is_none()).map(|p| p.rel_err);
    let mut y0 = measured()
        .map(|e| e.max(ERROR_FLOOR))
        .fold(f64::INFINITY, f64::min);
    let mut y1 = measured().fold(0.0, f64::max);
    if !y0.is_finite() {
        y0 = 1e-3;
    }
    y1 = y1.max(y0 * 10.0);
    y0 /= 16.0; // room for the reference marks and their label rows below the smallest error
    ((x0, x1), (y0, y1 * 1.6))
}

/// A relative error as a percentage with two significant digits at least (0.0021 %, 0.21 %,
/// 2.1 %), so small errors do not all read "0.00 %".
fn percent(v: f64) -> String {
    let pct = 100.0 * v;
    let decimals = if pct > 0.0 {
        (1.0 - pct.log10().floor()).clamp(0.0, 6.0) as usize
    } else {
        0
    };
    format!("{pct:.decimals$} %")
}

fn draw(svg: &mut String, title: &str, curves: &[Curve]) -> std::result::Result<(), String> {
    let ((x0, x1), (y0, y1)) = ranges(curves);
    let root = SVGBackend::with_string(svg, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    // Linear time axis padded by 5 % of the span: its labels then cover the data, which a
    // log axis over less than a decade does not.
    let pad = 0.05 * (x1 - x0);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0 - pad).max(0.0)..x1 + pad, (y0..y1).log_scale())
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("CPU time of one cold instant, s (median of the repeats; bar: least to most)")
        .y_desc("RMS relative error vs the knob's finest setting")
        .x_labels(10)
        .y_label_formatter(&|v| percent(*v))
        .draw()
        .map_err(|e| e.to_string())?;
    let floor = (y0 * 1.3).max(ERROR_FLOOR);
    // Every reference mark (curve, time), in time order: its rank picks its label's row.
    let mut refs: Vec<(usize, f64)> = curves
        .iter()
        .enumerate()
        .flat_map(|(i, c)| {
            c.points
                .iter()
                .filter(|p| p.reference.is_some())
                .map(move |p| (i, p.seconds))
        })
        .collect();
    refs.sort_by(|a, b| a.1.total_cmp(&b.1));
    const ROWS: usize = 4;
    const ROW: f64 = 1.9;
    for (i, c) in curves.iter().enumerate() {
        let color = color(i);
        let measured: Vec<&Point> = c.points.iter().filter(|p| p.reference.is_none()).collect();
        let line: Vec<(f64, f64)> = measured
            .iter()
            .map(|p| (p.seconds, p.rel_err.max(floor)))
            .collect();
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
        chart
            .draw_series(measured.iter().map(|p| {
                let y = p.rel_err.max(floor);
                PathElement::new(
                    vec![(p.seconds_min, y), (p.seconds_max, y)],
                    color.stroke_width(1),
                )
            }))
            .map_err(|e| e.to_string())?;
        let base = c
            .points
            .iter()
            .filter(|p| p.is_base && p.reference.is_none())
            .map(|p| (p.seconds, p.rel_err.max(floor)));
        chart
            .draw_series(base.map(|p| Circle::new(p, 7, BLACK.stroke_width(1))))
            .map_err(|e| e.to_string())?;
        // The reference: a hollow triangle on the bottom line, labelled with its setting;
        // one beyond the time axis sits on its right edge, its label giving its time.
        // Labels go in rows by the reference's rank in time, so neighbours do not overlap.
        for p in c.points.iter().filter(|p| p.reference.is_some()) {
            let beyond = p.seconds > x1;
            let x = p.seconds.min(x1);
            let at = (x, y0 * 1.15);
            chart
                .draw_series(std::iter::once(TriangleMarker::new(
                    at,
                    6,
                    color.stroke_width(2),
                )))
                .map_err(|e| e.to_string())?;
            let setting = p.reference.as_deref().unwrap_or_default();
            let label = if beyond {
                format!("ref: {setting} ({:.0} s) \u{2192}", p.seconds)
            } else {
                format!("ref: {setting}")
            };
            let rank = refs.iter().position(|r| *r == (i, p.seconds)).unwrap_or(0);
            // Right of the mark in the plot's left half, left of it in the right half, so
            // the label stays inside the plot.
            let h = if x > 0.5 * (x0 + x1) {
                HPos::Right
            } else {
                HPos::Left
            };
            let style = ("sans-serif", 11)
                .into_font()
                .color(&color)
                .pos(Pos::new(h, VPos::Center));
            let y = y0 * 1.45 * ROW.powi((rank % ROWS) as i32);
            chart
                .draw_series(std::iter::once(Text::new(label, (x, y), style)))
                .map_err(|e| e.to_string())?;
        }
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
        let pt = |t: f64, e: f64, base: bool, reference: Option<&str>| Point {
            seconds: t,
            seconds_min: t * 0.9,
            seconds_max: t * 1.1,
            rel_err: e,
            is_base: base,
            reference: reference.map(str::to_string),
        };
        let curves = [
            Curve {
                name: "sky subdivision".into(),
                points: vec![
                    pt(4.5, 0.03, false, None),
                    pt(5.0, 0.01, true, None),
                    pt(9.0, 0.0, false, Some("reference sky")),
                ],
            },
            Curve {
                name: "interreflection lines".into(),
                points: vec![pt(4.2, 0.1, false, None), pt(6.0, 0.0, false, Some("8192"))],
            },
        ];
        error_vs_time_svg(&p, "office", &curves).unwrap();
        let s = std::fs::read_to_string(&p).unwrap();
        assert!(s.starts_with("<svg"), "{}", &s[..50.min(s.len())]);
        assert!(s.contains("sky subdivision") && s.contains("interreflection lines"));
        assert!(s.contains("office"));
        // The references are labelled, not drawn as measured zeros.
        assert!(s.contains("ref: reference sky") && s.contains("ref: 8192"));
        // Okabe–Ito without its yellow.
        assert!(s.contains("#E69F00") && !s.to_uppercase().contains("#F0E442"));
    }

    #[test]
    fn error_labels_keep_two_significant_digits() {
        assert_eq!(percent(0.01), "1.0 %");
        assert_eq!(percent(0.1), "10 %");
        assert_eq!(percent(1e-5), "0.0010 %");
        assert_eq!(percent(0.0), "0 %");
    }

    /// A rung at `t` s timed from `t - lo` to `t + hi`, with relative error `e`.
    fn rung(t: f64, (lo, hi): (f64, f64), e: f64, reference: Option<&str>) -> Point {
        Point {
            seconds: t,
            seconds_min: t - lo,
            seconds_max: t + hi,
            rel_err: e,
            is_base: false,
            reference: reference.map(str::to_string),
        }
    }

    #[test]
    fn axes_cover_every_run() {
        let pt = |t, e, r| rung(t, (0.2, 0.3), e, r);
        let curves = [Curve {
            name: "k".into(),
            points: vec![
                pt(4.0, 0.05, None),
                pt(6.0, 0.002, None),
                pt(9.5, 0.0, Some("f")),
            ],
        }];
        let ((x0, x1), (y0, y1)) = ranges(&curves);
        assert!(x0 <= 3.8 && x1 >= 9.8 && x0 > 3.0 && x1 < 11.0, "{x0} {x1}");
        // The reference's zero does not set the error axis; it sits below the smallest.
        assert!(y0 < 0.002 && y0 > 1e-4 && y1 >= 0.05, "{y0} {y1}");
    }

    #[test]
    fn round_off_errors_and_a_slow_reference_do_not_set_the_axes() {
        let pt = |t, e, r| rung(t, (0.0, 0.0), e, r);
        let curves = [Curve {
            name: "k".into(),
            points: vec![
                pt(4.0, 0.05, None),
                pt(6.0, 1e-13, None),
                pt(450.0, 0.0, Some("reference")),
            ],
        }];
        let ((x0, x1), (y0, _)) = ranges(&curves);
        assert!(x0 <= 4.0 && (6.0..10.0).contains(&x1), "{x0} {x1}");
        assert!(y0 >= ERROR_FLOOR / 20.0, "{y0}");
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("c.svg");
        error_vs_time_svg(&p, "t", &curves).unwrap();
        let s = std::fs::read_to_string(&p).unwrap();
        assert!(
            s.contains("ref: reference (450 s)"),
            "the clipped reference names its time"
        );
    }
}
