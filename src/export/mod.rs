//! L7 time-series and metric outputs: `illuminance.csv` (write, stream with checkpoints,
//! read, merge shards), Radiance/DAYSIM-style `.ill`, `metrics.csv`, `summary.json` and
//! `surfaces.csv`; [`viewer`] serves the `.glb` solution viewer (`daystep view`).
//!
//! Every number is written with a fixed format (three decimals, −0 written as 0) and every
//! time as `YYYY-MM-DDTHH:MM:SS` local standard time (the time at which the sun was
//! evaluated), so outputs are byte-deterministic: a merged set of shards is byte-identical
//! to a single run. Whole files go through [`crate::files::write_atomic`]; the streaming
//! writer appends to `<name>.partial` and renames it over the output when finished, which
//! gives the same guarantee (a complete-looking file is complete) without holding a year of
//! rows in memory.

mod csv_read;
pub mod gltf;
pub mod grids;
pub mod plan_map;
pub mod plot;
pub mod report_page;
mod tjunction;
pub mod viewer;

use crate::error::{Error, Result};
use crate::files;
use crate::metrics::{MetricParams, SensorMetrics, Summary};
use chrono::{Datelike, NaiveDateTime, Timelike};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use csv_read::parse_csv;
pub use csv_read::{read_illuminance_csv, IlluminanceRows};

/// `chrono` format of the `time` column: local standard time, no offset.
pub const TIME_FORMAT: &str = "%Y-%m-%dT%H:%M:%S";

/// `time` as written in the CSV outputs (`YYYY-MM-DDTHH:MM:SS`).
pub fn format_time(time: NaiveDateTime) -> String {
    time.format(TIME_FORMAT).to_string()
}

/// A value with three decimals; −0 (and values rounding to −0.000) written as `0.000`, so
/// equal results give equal bytes.
pub fn format_value(v: f64) -> String {
    let mut s = String::with_capacity(12);
    push_value(&mut s, v);
    s
}

/// `v` in thousandths, rounded, when that is the exactly rounded decimal: `v` is not
/// zero, below 10⁶ and more than 10⁻⁶ thousandths from a rounding tie (below 10⁹, v·1000
/// is within 1.2·10⁻⁷ of the exact product, so such a fraction rounds as the exact one
/// does); `None` otherwise.
fn thousandths(v: f64) -> Option<i64> {
    let x = v * 1000.0;
    (v != 0.0 && x.abs() < 1e9 && (x.abs().fract() - 0.5).abs() > 1e-6).then(|| x.round() as i64)
}

/// Appends `v` as [`format_value`] writes it. A year's tables are millions of values, and
/// the general float formatting was a tenth of a warm annual run: away from a rounding
/// tie ([`thousandths`]), the value is written as an integer of thousandths.
pub fn push_value(s: &mut String, v: f64) {
    // Night steps are half of an annual series: their zeros skip the arithmetic.
    if v == 0.0 {
        s.push_str("0.000");
        return;
    }
    let Some(r) = thousandths(v) else {
        let f = format!("{v:.3}");
        s.push_str(if f == "-0.000" { "0.000" } else { &f });
        return;
    };
    // −0.000 (r = 0 from a negative v) gets no sign.
    if r < 0 {
        s.push('-');
    }
    let a = r.unsigned_abs();
    s.push_str(itoa::Buffer::new().format(a / 1000));
    s.push('.');
    let f = a % 1000;
    for d in [f / 100, f / 10 % 10, f % 10] {
        s.push(char::from(b'0' + d as u8));
    }
}

/// The value a table holds once `v` is written ([`push_value`]) and read back: the
/// metrics of a run are taken from these without reading its tables again.
pub fn written_value(v: f64) -> f64 {
    if v == 0.0 {
        return 0.0;
    }
    match thousandths(v) {
        // −0 is written 0.000 and read back as +0.
        Some(0) => 0.0,
        // Two exact integers divided: the double nearest the decimal, as parsing gives.
        Some(r) => r as f64 / 1000.0,
        None => format_value(v).parse::<f64>().unwrap_or(f64::NAN),
    }
}

/// The `illuminance.csv` header line `time,s0,s1,…` (newline included).
pub fn illuminance_header(sensors: usize) -> String {
    let mut s = String::from("time");
    for i in 0..sensors {
        s.push_str(&format!(",s{i}"));
    }
    s.push('\n');
    s
}

/// One CSV row `time,v0,v1,…` (newline included); lux or W/m², three decimals.
///
/// # Errors
/// [`Error::Numerical`] for a non-finite value (a bug upstream, never written silently).
pub fn csv_row(time: NaiveDateTime, values: &[f64]) -> Result<String> {
    let mut s = format_time(time);
    for (j, v) in values.iter().enumerate() {
        if !v.is_finite() {
            return Err(Error::Numerical(format!(
                "non-finite value {v} at {}, column {}",
                format_time(time),
                j + 1
            )));
        }
        s.push(',');
        push_value(&mut s, *v);
    }
    s.push('\n');
    Ok(s)
}

/// Checks that there is one row per time and every row has `width` values.
fn check_shape(times: &[NaiveDateTime], rows: &[Vec<f64>], width: usize) -> Result<()> {
    if times.len() != rows.len() {
        return Err(Error::Internal(format!(
            "{} times for {} rows",
            times.len(),
            rows.len()
        )));
    }
    if let Some((i, r)) = rows.iter().enumerate().find(|(_, r)| r.len() != width) {
        return Err(Error::Internal(format!(
            "row {i} has {} values, expected {width}",
            r.len()
        )));
    }
    Ok(())
}

/// The whole `illuminance.csv` text: header `time,s0,…` (one column per sensor of
/// `rows[0]`), one row per time, lux with three decimals.
///
/// # Errors
/// [`Error::Internal`] when the shapes disagree; [`Error::Numerical`] for non-finite values.
pub fn illuminance_csv_text(times: &[NaiveDateTime], rows: &[Vec<f64>]) -> Result<String> {
    let sensors = rows.first().map_or(0, Vec::len);
    check_shape(times, rows, sensors)?;
    let mut s = illuminance_header(sensors);
    for (t, r) in times.iter().zip(rows) {
        s.push_str(&csv_row(*t, r)?);
    }
    Ok(s)
}

/// Writes [`illuminance_csv_text`] to `path` atomically.
///
/// # Errors
/// As [`illuminance_csv_text`], and [`Error::Io`] naming the path.
pub fn write_illuminance_csv(
    path: &Path,
    times: &[NaiveDateTime],
    rows: &[Vec<f64>],
) -> Result<()> {
    files::write_atomic(path, illuminance_csv_text(times, rows)?.as_bytes())
}

/// Streams `illuminance.csv` row by row for checkpointed runs: rows are appended to
/// `<path>.partial`; [`IlluminanceWriter::checkpoint`] makes them durable;
/// [`IlluminanceWriter::finish`] renames the partial file over `path`. An interrupted run
/// continues with [`IlluminanceWriter::resume`]. The finished bytes equal
/// [`illuminance_csv_text`] of the same rows.
pub struct IlluminanceWriter {
    path: PathBuf,
    partial: PathBuf,
    out: BufWriter<File>,
    sensors: usize,
    header: String,
}

impl IlluminanceWriter {
    /// The partial file a writer for `path` appends to (`<path>.partial`).
    pub fn partial_path(path: &Path) -> PathBuf {
        let mut name = path.file_name().unwrap_or_default().to_os_string();
        name.push(".partial");
        path.with_file_name(name)
    }

    /// Starts a new file for `sensors` columns (an existing partial file is replaced).
    ///
    /// # Errors
    /// [`Error::Io`] naming the partial file.
    pub fn create(path: &Path, sensors: usize) -> Result<Self> {
        Self::create_with_header(path, illuminance_header(sensors), sensors)
    }

    /// [`IlluminanceWriter::create`] for another table of the same form: `header` (with
    /// its newline) names `time` and `columns` value columns.
    ///
    /// # Errors
    /// [`Error::Io`] naming the partial file.
    pub fn create_with_header(path: &Path, header: String, columns: usize) -> Result<Self> {
        let sensors = columns;
        let partial = Self::partial_path(path);
        if let Some(dir) = partial.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let file = File::create(&partial).map_err(|e| Error::io(&partial, e))?;
        let mut w = IlluminanceWriter {
            path: path.to_path_buf(),
            partial,
            out: BufWriter::new(file),
            sensors,
            header,
        };
        let h = w.header.clone();
        w.write(h.as_bytes())?;
        // On disk at once: a resume that re-reads a file it has just started (a run cut
        // between its final renames) must find the header.
        let p = &w.partial;
        w.out.flush().map_err(|e| Error::io(p, e))?;
        Ok(w)
    }

    /// Continues an interrupted file: keeps the complete rows of `<path>.partial` (an
    /// incomplete last line, cut by the interruption, is dropped) and returns the writer
    /// with the times already written, as in the file. Starts a new file when there is no
    /// partial file.
    ///
    /// # Errors
    /// [`Error::Input`] naming the partial file, line and value when its header is not the
    /// one for `sensors` columns or a complete row is malformed; [`Error::Io`].
    pub fn resume(path: &Path, sensors: usize) -> Result<(Self, Vec<String>)> {
        Self::resume_with_header(path, illuminance_header(sensors), sensors)
    }

    /// [`IlluminanceWriter::resume`] for a table made by
    /// [`IlluminanceWriter::create_with_header`].
    ///
    /// # Errors
    /// As [`IlluminanceWriter::resume`].
    pub fn resume_with_header(
        path: &Path,
        header: String,
        columns: usize,
    ) -> Result<(Self, Vec<String>)> {
        let sensors = columns;
        let partial = Self::partial_path(path);
        if !partial.exists() {
            return Ok((Self::create_with_header(path, header, sensors)?, Vec::new()));
        }
        let text = files::read_text(&partial)?;
        // Only complete lines count: a crash can cut the last one.
        let keep = text.rfind('\n').map_or(0, |i| i + 1);
        if keep == 0 {
            // Interrupted before the header was complete: nothing to keep.
            return Ok((Self::create_with_header(path, header, sensors)?, Vec::new()));
        }
        let text = &text[..keep];
        if !text.starts_with(&header) {
            return Err(Error::input(
                &partial,
                Some(1),
                Some(text.lines().next().unwrap_or("")),
                format!(
                    "cannot continue: the header is not the one for {sensors} columns \
                     (remove the file to start over)"
                ),
            ));
        }
        let (times, _) = parse_csv(&partial, text)?;
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(&partial)
            .map_err(|e| Error::io(&partial, e))?;
        // Drop the cut line; appends then continue after the last complete row.
        file.set_len(keep as u64)
            .map_err(|e| Error::io(&partial, e))?;
        let out = BufWriter::new(file);
        Ok((
            IlluminanceWriter {
                path: path.to_path_buf(),
                partial,
                out,
                sensors,
                header,
            },
            times,
        ))
    }

    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        self.out
            .write_all(bytes)
            .map_err(|e| Error::io(&self.partial, e))
    }

    /// Appends one row: `values` in lux, one per sensor.
    ///
    /// # Errors
    /// [`Error::Internal`] for a wrong number of values, [`Error::Numerical`] for a
    /// non-finite one, [`Error::Io`].
    pub fn append(&mut self, time: NaiveDateTime, values: &[f64]) -> Result<()> {
        if values.len() != self.sensors {
            return Err(Error::Internal(format!(
                "{} values for {} sensors",
                values.len(),
                self.sensors
            )));
        }
        let row = csv_row(time, values)?;
        self.write(row.as_bytes())
    }

    /// Flushes and syncs the rows written so far to disk.
    ///
    /// # Errors
    /// [`Error::Io`] naming the partial file.
    pub fn checkpoint(&mut self) -> Result<()> {
        let p = &self.partial;
        self.out.flush().map_err(|e| Error::io(p, e))?;
        self.out.get_ref().sync_all().map_err(|e| Error::io(p, e))
    }

    /// Checkpoints and renames the partial file over the output path.
    ///
    /// # Errors
    /// [`Error::Io`].
    pub fn finish(mut self) -> Result<()> {
        self.checkpoint()?;
        std::fs::rename(&self.partial, &self.path).map_err(|e| Error::io(&self.path, e))
    }
}

/// Merges shard `illuminance.csv` files (each holding some of the timesteps, all with the
/// same header) into `out`, rows in time order, byte-identical to what one run writes.
///
/// A time gap larger than the smallest step between consecutive rows is reported as missing
/// rows; rows missing before the first or after the last time cannot be seen here.
///
/// # Errors
/// [`Error::Input`] naming the part, line and value for a header that differs from the first
/// part's, a duplicate time, a gap, or a malformed row; [`Error::Io`].
pub fn merge_illuminance(parts: &[PathBuf], out: &Path) -> Result<()> {
    let Some(first) = parts.first() else {
        return Err(Error::arg("parts", 0, "no shard files to merge"));
    };
    let mut header: Option<String> = None;
    // (time, part index, line, values)
    let mut rows: Vec<(NaiveDateTime, usize, usize, Vec<f64>)> = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        let text = files::read_text(part)?;
        let head = text.lines().next().unwrap_or("").to_owned();
        match &header {
            None => header = Some(head),
            Some(h) if *h != head => {
                return Err(Error::input(
                    part,
                    Some(1),
                    Some(&head),
                    format!(
                        "header differs from {}'s `{h}`: shards of different runs?",
                        first.display()
                    ),
                ))
            }
            Some(_) => {}
        }
        let (times, values) = parse_csv(part, &text)?;
        for (i, (t, v)) in times.iter().zip(values).enumerate() {
            let time = NaiveDateTime::parse_from_str(t, TIME_FORMAT)
                .map_err(|_| Error::Internal(format!("time {t} parsed once, not twice")))?;
            rows.push((time, k, i + 2, v));
        }
    }
    rows.sort_by_key(|r| (r.0, r.1, r.2));
    let step = rows
        .windows(2)
        .map(|w| w[1].0 - w[0].0)
        .filter(|d| *d > chrono::TimeDelta::zero())
        .min();
    for w in rows.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let at = |r: &(NaiveDateTime, usize, usize, Vec<f64>), message: String| {
            Error::input(&parts[r.1], Some(r.2), Some(&format_time(r.0)), message)
        };
        if a.0 == b.0 {
            return Err(at(
                b,
                format!("duplicate time: also at {}:{}", parts[a.1].display(), a.2),
            ));
        }
        if Some(b.0 - a.0) != step {
            return Err(at(
                b,
                format!(
                    "missing rows: no row between {} and this time (the series' step is {} s)",
                    format_time(a.0),
                    step.map_or(0, |s| s.num_seconds())
                ),
            ));
        }
    }
    let mut text = header.unwrap_or_default();
    text.push('\n');
    for (t, _, _, v) in &rows {
        text.push_str(&csv_row(*t, v)?);
    }
    files::write_atomic(out, text.as_bytes())
}

/// Radiance/DAYSIM-style `.ill` text: one line per timestep, `month day hour v0 v1 …`, space
/// separated, `hour` the decimal local standard time (12:30 → 12.500), values in lux with
/// three decimals, no header.
///
/// # Errors
/// [`Error::Internal`] when the shapes disagree; [`Error::Numerical`] for non-finite values.
pub fn ill_text(times: &[NaiveDateTime], rows: &[Vec<f64>]) -> Result<String> {
    let sensors = rows.first().map_or(0, Vec::len);
    check_shape(times, rows, sensors)?;
    let mut s = String::new();
    for (t, r) in times.iter().zip(rows) {
        let hour =
            f64::from(t.hour()) + f64::from(t.minute()) / 60.0 + f64::from(t.second()) / 3600.0;
        s.push_str(&format!("{} {} {hour:.3}", t.month(), t.day()));
        for v in r {
            if !v.is_finite() {
                return Err(Error::Numerical(format!(
                    "non-finite value {v} at {}",
                    format_time(*t)
                )));
            }
            s.push(' ');
            s.push_str(&format_value(*v));
        }
        s.push('\n');
    }
    Ok(s)
}

/// Writes [`ill_text`] to `path` atomically.
///
/// # Errors
/// As [`ill_text`], and [`Error::Io`].
pub fn write_ill(path: &Path, times: &[NaiveDateTime], rows: &[Vec<f64>]) -> Result<()> {
    files::write_atomic(path, ill_text(times, rows)?.as_bytes())
}

/// `metrics.csv` text: header `sensor,da,cda,udi_below,udi_within,udi_above,ase_hours,mean_lux`
/// and one row per sensor named `s0, s1, …` as in `illuminance.csv` (percentages, hours,
/// lux; three decimals). With `grid` (one entry per sensor, [`grids::grid_column`]), a last
/// column `grid` holds each sensor's grid identifier (empty for none).
pub fn metrics_csv_text(per_sensor: &[SensorMetrics], grid: Option<&[Option<&str>]>) -> String {
    let mut s = String::from("sensor,da,cda,udi_below,udi_within,udi_above,ase_hours,mean_lux");
    s.push_str(if grid.is_some() { ",grid\n" } else { "\n" });
    for (i, m) in per_sensor.iter().enumerate() {
        let values = [
            m.da,
            m.cda,
            m.udi_below,
            m.udi_within,
            m.udi_above,
            m.ase_hours,
            m.mean_lux,
        ];
        s.push_str(&format!("s{i}"));
        for v in values {
            s.push(',');
            s.push_str(&format_value(v));
        }
        if let Some(g) = grid {
            s.push(',');
            s.push_str(g.get(i).copied().flatten().unwrap_or(""));
        }
        s.push('\n');
    }
    s
}

/// Writes [`metrics_csv_text`] to `path` atomically.
///
/// # Errors
/// [`Error::Io`].
pub fn write_metrics_csv(
    path: &Path,
    per_sensor: &[SensorMetrics],
    grid: Option<&[Option<&str>]>,
) -> Result<()> {
    files::write_atomic(path, metrics_csv_text(per_sensor, grid).as_bytes())
}

/// The `summary.json` document: `summary`, the `params` used and one-line `definitions` of
/// each metric with the thresholds filled in. Callers may add fields before writing.
pub fn summary_json_value(summary: &Summary, params: &MetricParams) -> serde_json::Value {
    let p = params;
    let occ = format!(
        "occupied hours = steps starting {}:00–{}:59 local standard time every day, \
         sun-down hours included (they count as dark)",
        p.occupancy_start_hour, p.occupancy_end_hour
    );
    serde_json::json!({
        "summary": summary,
        "params": params,
        "definitions": {
            "occupied_hours": occ,
            "da": format!("daylight autonomy: % of occupied hours with illuminance >= {} lx", p.da_threshold_lux),
            "cda": format!("continuous DA: occupied-hour mean of min(1, E / {} lx), %", p.da_threshold_lux),
            "udi_below": format!("% of occupied hours with E < {} lx, sun-down hours included", p.udi_min_lux),
            "udi_within": format!("useful daylight illuminance: % of occupied hours with {} <= E <= {} lx", p.udi_min_lux, p.udi_max_lux),
            "udi_above": format!("% of occupied hours with E > {} lx", p.udi_max_lux),
            "ase_hours": format!("occupied sun-up hours with direct-sun illuminance > {} lx", p.ase_threshold_lux),
            "mean_lux": "mean illuminance over occupied hours, sun-down hours as 0 lx",
            "sda_percent": format!("spatial DA: % of sensors (or area) with DA >= {} %", 100.0 * p.sda_da_fraction),
            "ase_percent": format!("annual sunlight exposure: % of sensors (or area) with ase_hours >= {} h", p.ase_hours),
            "means": "mean_* = mean over sensors (area-weighted when area_weighted is true)",
        },
    })
}

/// Writes [`summary_json_value`] to `path` atomically (pretty JSON, final newline).
///
/// # Errors
/// [`Error::Io`]; [`Error::Internal`] if serialisation fails.
pub fn write_summary_json(path: &Path, summary: &Summary, params: &MetricParams) -> Result<()> {
    write_json(path, &summary_json_value(summary, params))
}

/// Writes a JSON document to `path` atomically (pretty, final newline).
///
/// # Errors
/// [`Error::Io`]; [`Error::Internal`] if serialisation fails.
pub fn write_json(path: &Path, doc: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_string_pretty(doc)
        .map_err(|e| Error::Internal(format!("{}: {e}", path.display())))?;
    text.push('\n');
    files::write_atomic(path, text.as_bytes())
}

/// A column group of `surfaces.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceGroup {
    /// Group name as in the scene (no commas, quotes or line breaks).
    pub name: String,
    /// True for glazing: the column is the transmitted power `<name>_transmitted_w` (W);
    /// otherwise the mean incident irradiance `<name>_irradiance_w_m2` (W/m²).
    pub glazing: bool,
}

/// `surfaces.csv` text: header `time,<group>_irradiance_w_m2,…,<glazing>_transmitted_w`
/// (one column per group, in the given order), one row per time.
///
/// # Errors
/// [`Error::Input`] for a group name that would break the CSV; [`Error::Internal`] when the
/// shapes disagree; [`Error::Numerical`] for non-finite values.
pub fn surfaces_csv_text(
    groups: &[SurfaceGroup],
    times: &[NaiveDateTime],
    rows: &[Vec<f64>],
) -> Result<String> {
    check_shape(times, rows, groups.len())?;
    let mut s = String::from("time");
    for g in groups {
        if g.name.is_empty() || g.name.contains([',', '"', '\n', '\r']) {
            return Err(Error::arg(
                "surface group",
                &g.name,
                "a group name must be non-empty, without commas, quotes or line breaks",
            ));
        }
        let unit = if g.glazing {
            "transmitted_w"
        } else {
            "irradiance_w_m2"
        };
        s.push_str(&format!(",{}_{unit}", g.name));
    }
    s.push('\n');
    for (t, r) in times.iter().zip(rows) {
        s.push_str(&csv_row(*t, r)?);
    }
    Ok(s)
}

/// Writes [`surfaces_csv_text`] to `path` atomically.
///
/// # Errors
/// As [`surfaces_csv_text`], and [`Error::Io`].
pub fn write_surfaces_csv(
    path: &Path,
    groups: &[SurfaceGroup],
    times: &[NaiveDateTime],
    rows: &[Vec<f64>],
) -> Result<()> {
    files::write_atomic(path, surfaces_csv_text(groups, times, rows)?.as_bytes())
}

#[cfg(test)]
mod tests;
