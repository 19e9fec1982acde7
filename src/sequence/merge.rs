//! The tables after an annual run: `metrics.csv` and `summary.json` (also per sensor grid
//! and per room) from a finished run's illuminance, and the merge of shard folders into
//! the files one run writes.

use crate::error::{Error, Result};
use crate::export;
use crate::metrics::{self, MetricParams};
use chrono::NaiveDateTime;
use std::path::Path;

pub(crate) fn parse_times(times: &[String]) -> Result<Vec<NaiveDateTime>> {
    times
        .iter()
        .map(|t| {
            NaiveDateTime::parse_from_str(t, export::TIME_FORMAT)
                .map_err(|e| Error::Internal(format!("time {t}: {e}")))
        })
        .collect()
}

/// Computes `metrics.csv` and `summary.json` in `out` from its `illuminance.csv` and
/// `direct_sun.csv` (a finished run or a merge).
///
/// Returns the per-sensor metrics (sensor order), which `report.html` maps.
///
/// # Errors
/// Missing or malformed input files; files that cannot be written.
pub fn write_metrics(
    out: &Path,
    step_minutes: u32,
    params: &MetricParams,
) -> Result<Vec<metrics::SensorMetrics>> {
    params.validate()?;
    // Both tables row by row, in step: a year of a large grid is never held whole.
    let (tp, sp) = (out.join("illuminance.csv"), out.join("direct_sun.csv"));
    let mut total = export::IlluminanceRows::open(&tp)?;
    let mut sun = export::IlluminanceRows::open(&sp)?;
    let mut tables = MetricTables::new(total.columns(), step_minutes, params);
    let (mut tv, mut sv) = (Vec::new(), Vec::new());
    let mut rows = 0usize;
    loop {
        let (t, s) = (total.next_row(&mut tv)?, sun.next_row(&mut sv)?);
        let (Some(t), Some(s)) = (t, s) else {
            if total.next_row(&mut tv)?.is_some() || sun.next_row(&mut sv)?.is_some() {
                return Err(Error::input(
                    &sp,
                    Some(rows + 2),
                    None,
                    format!("has a different number of rows from {}", tp.display()),
                ));
            }
            break;
        };
        rows += 1;
        if t != s || tv.len() != sv.len() {
            return Err(Error::input(
                &sp,
                Some(rows + 1),
                Some(&s),
                format!(
                    "row {rows} differs in time or width from {}'s {t}",
                    tp.display()
                ),
            ));
        }
        tables.row(parse_times(&[t])?[0], &tv, &sv);
    }
    tables.write(out)
}

/// `metrics.csv` and `summary.json` accumulated row by row, in time order: from the
/// tables on disk ([`write_metrics`]) or from the rows as a run writes them (their values
/// as the tables hold them, [`export::written_value`]), the same bits either way.
pub struct MetricTables<'p> {
    acc: Vec<metrics::SensorAccumulator>,
    rows: usize,
    step_minutes: u32,
    params: &'p MetricParams,
}

impl<'p> MetricTables<'p> {
    /// Empty tables of `sensors` columns, for steps of `step_minutes`.
    pub fn new(sensors: usize, step_minutes: u32, params: &'p MetricParams) -> Self {
        MetricTables {
            acc: vec![metrics::SensorAccumulator::default(); sensors],
            rows: 0,
            step_minutes,
            params,
        }
    }

    /// Adds the row at `time`: total and direct-sun illuminance per sensor, lux, as the
    /// tables hold them.
    pub fn row(&mut self, time: NaiveDateTime, total: &[f64], sun: &[f64]) {
        self.rows += 1;
        let occupied = metrics::is_occupied(time, self.step_minutes, self.params);
        // Night steps are written as 0 lx: counted dark whether flagged or not.
        for (a, (&e, &es)) in self.acc.iter_mut().zip(total.iter().zip(sun)) {
            a.add(e, es, occupied, true, self.params);
        }
    }

    /// Writes `metrics.csv` and `summary.json` in `out` (with its `grids.json`), and returns
    /// the per-sensor metrics.
    ///
    /// # Errors
    /// Files that cannot be read or written.
    pub fn write(self, out: &Path) -> Result<Vec<metrics::SensorMetrics>> {
        let params = self.params;
        let sensors = if self.rows == 0 { 0 } else { self.acc.len() };
        let hours = self.step_minutes as f64 / 60.0;
        let per: Vec<metrics::SensorMetrics> = self.acc[..sensors]
            .iter()
            .map(|a| a.finish(hours))
            .collect();
        let grids = export::grids::read_grids_json(out, sensors)?;
        let column = grids
            .as_deref()
            .map(|g| export::grids::grid_column(g, sensors));
        export::write_metrics_csv(&out.join("metrics.csv"), &per, column.as_deref())?;
        let summary = metrics::summary(&per, None, params)?;
        let mut doc = export::summary_json_value(&summary, params);
        if let Some(grids) = &grids {
            // The same summary over each grid's and each room's sensors.
            let of = |ks: &[usize]| -> Result<serde_json::Value> {
                let sub: Vec<_> = ks.iter().map(|&k| per[k].clone()).collect();
                let s = metrics::summary(&sub, None, params)?;
                serde_json::to_value(s).map_err(|e| Error::Internal(format!("summary.json: {e}")))
            };
            let mut by_grid = serde_json::Map::new();
            for g in grids {
                by_grid.insert(g.identifier.clone(), of(&g.sensors)?);
            }
            let mut by_room = serde_json::Map::new();
            for (room, ks) in export::grids::rooms(grids) {
                by_room.insert(room, of(&ks)?);
            }
            doc["grids"] = by_grid.into();
            doc["rooms"] = by_room.into();
        }
        export::write_json(&out.join("summary.json"), &doc)?;
        Ok(per)
    }
}

/// Writes `out/report.html` ([`export::report_page`]) for the run of `scene` with the
/// per-sensor `metrics` of [`write_metrics`]; no LEED or EN 17037 tables.
///
/// # Errors
/// The file cannot be written.
pub fn write_report_page(
    out: &Path,
    scene: &crate::scene::Scene,
    metrics: &[metrics::SensorMetrics],
    params: &MetricParams,
    title: String,
) -> Result<()> {
    export::report_page::write_report_html(
        &out.join("report.html"),
        &export::report_page::ReportInputs {
            title,
            scene,
            metrics,
            params,
            leed: None,
            leed_times: &[],
            en17037: None,
        },
    )
}

/// Merges shard folders into `out` (the same files a single run writes) and computes the
/// metrics, which it returns (per sensor) for `report.html`.
///
/// # Errors
/// Shards that do not fit together (headers, duplicate or missing times), I/O.
pub fn merge(
    parts: &[std::path::PathBuf],
    out: &Path,
    step_minutes: u32,
    params: &MetricParams,
) -> Result<Vec<metrics::SensorMetrics>> {
    check_shards(parts)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    for f in ["illuminance.csv", "direct_sun.csv", "surfaces.csv"] {
        let files: Vec<_> = parts.iter().map(|p| p.join(f)).collect();
        // surfaces.csv only when the shards were asked for it.
        if f == "surfaces.csv" && !files.iter().all(|p| p.exists()) {
            continue;
        }
        export::merge_illuminance(&files, &out.join(f))?;
    }
    merge_grids(parts, out)?;
    write_metrics(out, step_minutes, params)
}

/// Carries the shards' `grids.json` over to the merge: every shard of one study has the
/// same sensors and so the same grids, which is checked.
fn merge_grids(parts: &[std::path::PathBuf], out: &Path) -> Result<()> {
    let mut first: Option<(std::path::PathBuf, String)> = None;
    for p in parts {
        let path = p.join(export::grids::GRIDS_JSON);
        let text = if path.exists() {
            crate::files::read_text(&path)?
        } else {
            String::new()
        };
        match &first {
            None => first = Some((path, text)),
            Some((f, t)) if *t != text => {
                return Err(Error::input(
                    &path,
                    None,
                    None,
                    format!(
                        "the sensor grids differ from {}'s: the folders are not shards of one \
                         study",
                        f.display()
                    ),
                ))
            }
            Some(_) => {}
        }
    }
    match first {
        Some((_, t)) if !t.is_empty() => {
            crate::files::write_atomic(&out.join(export::grids::GRIDS_JSON), t.as_bytes())
        }
        _ => Ok(()),
    }
}

/// Every shard k/n of one study must be given once: a missing shard whose days are only
/// at the ends of the period would otherwise merge into a shorter series without notice.
/// Reads each folder's `report.json` (folders without one are not checked).
fn check_shards(parts: &[std::path::PathBuf]) -> Result<()> {
    let mut seen: Vec<(u32, u32, &std::path::PathBuf)> = Vec::new();
    for p in parts {
        let path = p.join("report.json");
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let shard = serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| v.get("shard").and_then(|s| s.as_str()).map(str::to_owned));
        let Some((k, n)) = shard.as_deref().and_then(|s| s.split_once('/')) else {
            continue;
        };
        if let (Ok(k), Ok(n)) = (k.parse::<u32>(), n.parse::<u32>()) {
            seen.push((k, n, p));
        }
    }
    let Some(&(_, n, _)) = seen.first() else {
        return Ok(());
    };
    if let Some((k, m, p)) = seen.iter().find(|s| s.1 != n) {
        return Err(Error::input(
            p.join("report.json"),
            None,
            Some(&format!("{k}/{m}")),
            format!("shard of {m}, but the first folder is a shard of {n}"),
        ));
    }
    if seen.len() == parts.len() {
        for k in 1..=n {
            if !seen.iter().any(|s| s.0 == k) {
                return Err(Error::input(
                    parts[0].join("report.json"),
                    None,
                    Some(&format!("{k}/{n}")),
                    format!("shard {k}/{n} is missing: merge needs all {n} shard folders"),
                ));
            }
        }
    }
    Ok(())
}
