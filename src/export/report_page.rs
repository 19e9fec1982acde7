//! `report.html`: one self-contained page per annual run with the plan maps of DA, UDI and
//! ASE hours per sensor grid ([`super::plan_map`]), the summary per grid, the LEED v4.1 and
//! EN 17037 tables and the LEED blind schedule as a day × hour heat map.
//!
//! Self-contained: inline SVG and CSS only, no script, no external font, image or link; a
//! `Content-Security-Policy` of `default-src 'none'` makes the browser itself refuse any
//! request the page might make. The grid rows of the tables and the map sections carry
//! `data-grid` attributes, in the same order, for tools and tests.

use super::plan_map::{self, esc, Scale};
use crate::error::Result;
use crate::metrics::en17037::{En17037Result, Level, Levels};
use crate::metrics::leed::LeedResult;
use crate::metrics::{self, MetricParams, SensorMetrics};
use crate::scene::Scene;
use chrono::{Datelike, NaiveDate, NaiveDateTime, Timelike};
use std::fmt::Write;
use std::path::Path;

/// Everything the annual report page shows.
pub struct ReportInputs<'a> {
    /// Page title.
    pub title: String,
    /// The scene of the run (sensor positions, grids, rooms, floor faces).
    pub scene: &'a Scene,
    /// Per sensor metrics, in the scene's sensor order.
    pub metrics: &'a [SensorMetrics],
    /// The thresholds the metrics used.
    pub params: &'a MetricParams,
    /// LEED v4.1 Daylight Option 1, when computed.
    pub leed: Option<&'a LeedResult>,
    /// Local times of the LEED steps (one per entry of each `leed.blinds.shaded[g]`).
    pub leed_times: &'a [NaiveDateTime],
    /// EN 17037 daylight provision, when computed.
    pub en17037: Option<&'a En17037Result>,
}

/// The page's Content-Security-Policy: nothing may be fetched; inline styles only.
pub const CSP: &str = "default-src 'none'; style-src 'unsafe-inline'; img-src data:; \
                       form-action 'none'; base-uri 'none'";

/// Colour of a shaded step on the blind heat map (Okabe & Ito blue).
pub const SHADED: &str = "#0072b2";
/// Colour of an open (or unoccupied) sun-up step on the blind heat map (Okabe & Ito
/// orange, lightened).
pub const OPEN: &str = "#f5d490";

const STYLE: &str = "body{font:14px/1.4 system-ui,sans-serif;color:#111;background:#fff;\
margin:16px 24px;max-width:1200px}h1{font-size:22px;margin:0 0 4px}h2{font-size:18px;\
margin:24px 0 8px;border-bottom:1px solid #ccc}h3{font-size:15px;margin:16px 0 4px}\
table{border-collapse:collapse;margin:4px 0 8px}th,td{border:1px solid #bbb;padding:2px 8px;\
text-align:right}th{background:#f2f2f2}td.l,th.l{text-align:left}.pass{color:#006d2c}\
.fail{color:#b2182b;font-weight:600}.maps{display:flex;flex-wrap:wrap;gap:12px}\
svg.map{outline:1px solid #0f1e2d}svg text.t{font:600 13px system-ui,sans-serif}\
svg text.s{font:11px system-ui,sans-serif}p.note{color:#444;margin:2px 0}";

/// One grid of the page: identifier, room and its sensors (scene order).
struct GridView {
    id: String,
    room: Option<String>,
    sensors: Vec<usize>,
}

fn grids_of(scene: &Scene, n: usize) -> Vec<GridView> {
    let spans = super::grids::spans_of(scene);
    if spans.is_empty() {
        return vec![GridView {
            id: super::grids::ALL_SENSORS.into(),
            room: None,
            sensors: (0..n).collect(),
        }];
    }
    spans
        .into_iter()
        .map(|g| GridView {
            id: g.identifier,
            room: g.room,
            sensors: g.sensors.into_iter().filter(|&k| k < n).collect(),
        })
        .collect()
}

/// The page as a string (what [`write_report_html`] writes).
///
/// # Errors
/// [`crate::Error::Input`] when the metrics and the thresholds do not make a summary.
pub fn report_html(r: &ReportInputs) -> Result<String> {
    let n = r.metrics.len().min(r.scene.sensors.len());
    let grids = grids_of(r.scene, n);
    let mut s = String::new();
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">\n\
         <meta name=\"viewport\" content=\"width=device-width\">\n<title>{}</title>\n\
         <style>{STYLE}</style></head><body>\n<h1>{}</h1>\n",
        esc(&r.title),
        esc(&r.title)
    );
    let p = r.params;
    let _ = writeln!(
        s,
        "<p class=\"note\">{} sensors in {} grid(s). Occupied hours {}:00–{}:59 every day; \
         DA ≥ {} lx; UDI {}–{} lx; ASE: direct sun &gt; {} lx, a sensor fails at ≥ {} h; \
         sDA: DA ≥ {} %.</p>",
        n,
        grids.len(),
        p.occupancy_start_hour,
        p.occupancy_end_hour,
        p.da_threshold_lux,
        p.udi_min_lux,
        p.udi_max_lux,
        p.ase_threshold_lux,
        p.ase_hours,
        100.0 * p.sda_da_fraction
    );
    summary_table(&mut s, r, &grids)?;
    maps(&mut s, r, &grids);
    if let Some(l) = r.leed {
        leed_table(&mut s, l);
    }
    if let Some(e) = r.en17037 {
        en17037_table(&mut s, e);
    }
    if let Some(l) = r.leed {
        blind_maps(&mut s, l, r.leed_times);
    }
    s.push_str("</body></html>\n");
    Ok(s)
}

/// Writes `report.html` (atomically).
///
/// # Errors
/// As [`report_html`]; [`crate::Error::Io`] when the file cannot be written.
pub fn write_report_html(path: &Path, r: &ReportInputs) -> Result<()> {
    crate::files::write_atomic(path, report_html(r)?.as_bytes())
}

fn summary_table(s: &mut String, r: &ReportInputs, grids: &[GridView]) -> Result<()> {
    s.push_str(
        "<h2>Summary per grid</h2>\n<table id=\"summary\"><tr><th class=\"l\">grid</th>\
         <th class=\"l\">room</th><th>sensors</th><th>sDA (%)</th><th>ASE (%)</th>\
         <th>mean DA (%)</th><th>mean UDI within (%)</th><th>mean ASE (h)</th>\
         <th>mean E (lx)</th><th>map</th></tr>\n",
    );
    for (i, g) in grids.iter().enumerate() {
        let sub: Vec<SensorMetrics> = g.sensors.iter().map(|&k| r.metrics[k].clone()).collect();
        if sub.is_empty() {
            continue;
        }
        let m = metrics::summary(&sub, None, r.params)?;
        let _ = writeln!(
            s,
            "<tr data-grid=\"{}\"><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{}</td>\
             <td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td><td>{:.1}</td>\
             <td>{:.0}</td><td><a href=\"#map-{i}\">map</a></td></tr>",
            esc(&g.id),
            esc(&g.id),
            esc(g.room.as_deref().unwrap_or("")),
            m.sensors,
            m.sda_percent,
            m.ase_percent,
            m.mean_da,
            m.mean_udi_within,
            m.mean_ase_hours,
            m.mean_lux
        );
    }
    s.push_str("</table>\n");
    Ok(())
}

/// The three scales: DA and UDI-within on 0–100 % (viridis), ASE hours from 0 to a round
/// number above the largest value (cividis), with the fail threshold marked.
pub fn scales(metrics: &[SensorMetrics], params: &MetricParams) -> [Scale; 3] {
    let pct = |name: &str, threshold: Option<(f64, String)>| Scale {
        name: name.into(),
        unit: "%".into(),
        lo: 0.0,
        hi: 100.0,
        classes: 10,
        gradient: colorous::VIRIDIS,
        threshold,
    };
    let ase_max = metrics.iter().map(|m| m.ase_hours).fold(0.0, f64::max);
    [
        pct(
            &format!("Daylight autonomy DA{}", params.da_threshold_lux),
            Some((
                100.0 * params.sda_da_fraction,
                format!("sDA: ≥ {} %", 100.0 * params.sda_da_fraction),
            )),
        ),
        pct(
            &format!("UDI {}–{} lx", params.udi_min_lux, params.udi_max_lux),
            None,
        ),
        Scale {
            name: format!("ASE hours, direct sun > {} lx", params.ase_threshold_lux),
            unit: "h".into(),
            lo: 0.0,
            hi: plan_map::nice_ceil(ase_max, 1.0),
            classes: 10,
            gradient: colorous::CIVIDIS,
            threshold: Some((params.ase_hours, format!("fails ≥ {} h", params.ase_hours))),
        },
    ]
}

fn maps(s: &mut String, r: &ReportInputs, grids: &[GridView]) {
    s.push_str(
        "<h2>Plan maps</h2>\n<p class=\"note\">Seen from above, north up; each square \
                is a sensor (hover for its value), the line the room's floor outline.</p>\n",
    );
    let [da, udi, ase] = scales(r.metrics, r.params);
    for (i, g) in grids.iter().enumerate() {
        if g.sensors.is_empty() {
            continue;
        }
        let pts: Vec<_> = g
            .sensors
            .iter()
            .map(|&k| r.scene.sensors[k].position.truncate())
            .collect();
        let tris = plan_map::floor_triangles(r.scene, &g.sensors, g.room.as_deref());
        let vals = |f: fn(&SensorMetrics) -> f64| -> Vec<f64> {
            g.sensors.iter().map(|&k| f(&r.metrics[k])).collect()
        };
        let _ = writeln!(
            s,
            "<section class=\"grid-maps\" id=\"map-{i}\" data-grid=\"{}\"><h3>{}{}</h3>\
             <div class=\"maps\">",
            esc(&g.id),
            esc(&g.id),
            g.room
                .as_deref()
                .map(|r| format!(" (room {})", esc(r)))
                .unwrap_or_default()
        );
        for (scale, v) in [
            (&da, vals(|m| m.da)),
            (&udi, vals(|m| m.udi_within)),
            (&ase, vals(|m| m.ase_hours)),
        ] {
            s.push_str(&plan_map::map_svg(&pts, &g.sensors, &v, scale, &tris));
            s.push('\n');
        }
        s.push_str("</div></section>\n");
    }
}

fn pass(b: bool) -> &'static str {
    if b {
        "<td class=\"pass\">pass</td>"
    } else {
        "<td class=\"fail\">fail</td>"
    }
}

fn leed_table(s: &mut String, l: &LeedResult) {
    let _ = writeln!(
        s,
        "<h2>LEED v4.1 Daylight, Option 1</h2>\n<p class=\"note\">sDA300/50% with the blinds \
         operated hour by hour, ASE1000,250h with blinds open; shares by {}.</p>\n\
         <table id=\"leed\"><tr><th class=\"l\">grid</th><th>sDA (%)</th><th>sDA, blinds \
         open (%)</th><th>sDA, blinds shaded (%)</th><th>ASE (%)</th><th>hours that cannot \
         comply (h)</th></tr>",
        if l.area_weighted {
            "sensor area"
        } else {
            "sensor count"
        }
    );
    for g in &l.grids {
        let _ = writeln!(
            s,
            "<tr data-grid=\"{}\"><td class=\"l\">{}</td><td>{:.1}</td><td>{:.1}</td>\
             <td>{:.1}</td><td>{:.1}</td><td>{:.0}</td></tr>",
            esc(&g.name),
            esc(&g.name),
            g.sda_pct,
            g.sda_blinds_open_pct,
            g.sda_blinds_shaded_pct,
            g.ase_pct,
            g.hours_fail_to_comply
        );
    }
    let _ = writeln!(
        s,
        "<tr><th class=\"l\">all grids</th><th>{:.1}</th><th></th><th></th><th>{:.1}</th>\
         <th>{:.0}</th></tr></table>\n<p class=\"note\"><b>Points: {}</b>{}</p>",
        l.sda_pct,
        l.ase_pct,
        l.hours_fail_to_comply,
        l.points,
        if l.exemplary_performance {
            " (exemplary performance)"
        } else {
            ""
        }
    );
}

fn level_rows(s: &mut String, grid: Option<&str>, levels: &Levels) {
    for (name, lv) in [
        ("minimum", &levels.minimum),
        ("medium", &levels.medium),
        ("high", &levels.high),
    ] {
        let Level {
            target_lux,
            target_area_pct,
            target_pass,
            minimum_lux,
            minimum_area_pct,
            minimum_pass,
        } = lv;
        let attr = grid
            .map(|g| format!(" data-grid=\"{}\"", esc(g)))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "<tr{attr}><td class=\"l\">{}</td><td class=\"l\">{name}</td><td>{target_lux}</td>\
             <td>{target_area_pct:.1}</td>{}<td>{minimum_lux}</td><td>{minimum_area_pct:.1}\
             </td>{}</tr>",
            esc(grid.unwrap_or("all grids")),
            pass(*target_pass),
            pass(*minimum_pass)
        );
    }
}

fn en17037_table(s: &mut String, e: &En17037Result) {
    s.push_str(
        "<h2>EN 17037 daylight provision</h2>\n<p class=\"note\">Share of the space where \
         the illuminance is met for half the daylight hours: the target over ≥ 50 %, the \
         minimum over ≥ 95 %.</p>\n<table id=\"en17037\"><tr><th class=\"l\">grid</th>\
         <th class=\"l\">level</th><th>target (lx)</th><th>space (%)</th><th>target</th>\
         <th>minimum (lx)</th><th>space (%)</th><th>minimum</th></tr>\n",
    );
    level_rows(s, None, &e.levels);
    for g in &e.grids {
        level_rows(s, Some(&g.name), &g.levels);
    }
    s.push_str("</table>\n");
}

/// Per group, a day × hour heat map of the blind schedule: a column per day from the first
/// to the last step's date, a row per hour of the day (0 at the top), an hour shaded when
/// any of its steps is, open when it has steps and none is shaded, blank without steps.
fn blind_maps(s: &mut String, l: &LeedResult, times: &[NaiveDateTime]) {
    let b = &l.blinds;
    if b.groups.is_empty() || times.is_empty() {
        return;
    }
    let (first, last) = (
        times.iter().min().expect("non-empty").date(),
        times.iter().max().expect("non-empty").date(),
    );
    let days = (last - first).num_days() as usize + 1;
    let cw = (900.0 / days as f64).clamp(1.0, 12.0);
    let ch = 6.0;
    let (x0, y0) = (34.0, 8.0);
    let w = x0 + cw * days as f64 + 8.0;
    let h = y0 + 24.0 * ch + 36.0;
    let _ = writeln!(
        s,
        "<h2>Blind states (LEED schedule)</h2>\n<p class=\"note\">Day of the year across, hour \
         of the day down; <span style=\"color:{SHADED}\">■</span> shaded, <span \
         style=\"color:#c08a20\">■</span> open or unoccupied sun-up hour, blank: night.</p>"
    );
    for (g, shaded) in b.groups.iter().zip(&b.shaded) {
        // 0 no step, 1 open, 2 shaded.
        let mut cell = vec![0u8; days * 24];
        for (t, sh) in times.iter().zip(shaded) {
            let k = (t.date() - first).num_days() as usize * 24 + t.hour() as usize;
            cell[k] = cell[k].max(if *sh { 2 } else { 1 });
        }
        let _ = write!(
            s,
            "<h3>{}</h3><svg class=\"blinds\" data-group=\"{}\" width=\"{w:.0}\" \
             height=\"{h:.0}\" viewBox=\"0 0 {w:.0} {h:.0}\">",
            esc(g),
            esc(g)
        );
        for (k, c) in cell.iter().enumerate().filter(|(_, c)| **c > 0) {
            let (d, hr) = (k / 24, k % 24);
            let _ = write!(
                s,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{cw:.2}\" height=\"{ch}\" fill=\"{}\"/>",
                x0 + cw * d as f64,
                y0 + ch * hr as f64,
                if *c == 2 { SHADED } else { OPEN }
            );
        }
        for hr in [0, 6, 12, 18, 24] {
            let _ = write!(
                s,
                "<text x=\"{}\" y=\"{:.1}\" class=\"s\" text-anchor=\"end\">{hr}:00</text>",
                x0 - 3.0,
                y0 + ch * hr as f64 + 4.0
            );
        }
        month_ticks(s, first, days, x0, cw, y0 + 24.0 * ch);
        s.push_str("</svg>\n");
    }
}

/// Labels along the day axis: each month's first day, or the first day when the period
/// holds no month start.
fn month_ticks(s: &mut String, first: NaiveDate, days: usize, x0: f64, cw: f64, y: f64) {
    let mut last_x = f64::MIN;
    for d in 0..days {
        let date = first + chrono::Days::new(d as u64);
        if date.day() != 1 && d != 0 {
            continue;
        }
        let x = x0 + cw * d as f64;
        if x - last_x < 40.0 {
            continue;
        }
        last_x = x;
        let _ = write!(
            s,
            "<path d=\"M{x:.1},{y:.1}v5\" stroke=\"#222\"/><text x=\"{x:.1}\" y=\"{:.1}\" \
             class=\"s\">{}</text>",
            y + 16.0,
            date.format("%b %-d")
        );
    }
}

#[cfg(test)]
#[path = "report_tests.rs"]
mod tests;
