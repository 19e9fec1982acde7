//! EnergyPlus weather files (EPW).
//!
//! Layout: 8 header lines (`LOCATION,city,state,country,source,WMO,latitude,longitude,time
//! zone,elevation` first, `DATA PERIODS,1,N,name,weekday,start m/d,end m/d` eighth), then one
//! comma-separated row per record: `year,month,day,hour,minute,flags,dry bulb,dew point,…`
//! with global horizontal at field index 13, DNI at 14 and DHI at 15 (W/m²). EPW longitude is
//! already east positive and the time zone hours east of UTC, as daystep uses them.
//!
//! **Time convention.** EPW records are interval-ENDING: hour 13 of an hourly file holds the
//! mean of 12:00–13:00. The sun is evaluated at the middle of the interval, so hour-ending 13
//! becomes `time` 12:30 (hour 1 → 00:30, hour 24 → 23:30 of the same day). Sub-hourly files
//! (`DATA PERIODS,1,N,…` with N records per hour, N dividing 60) use the row's position
//! within its hour: the k-th of N rows (k = 0…N−1) of hour h ends at (h−1) h + (k+1)·60/N min
//! and is evaluated half an interval earlier; the minute field is checked (0–60) but not
//! used, because files disagree on whether the last row of an hour says 0 or 60.
//!
//! **Years.** A file without 29 February (8760 hourly rows for a year) builds `time` in the
//! non-leap reference year 2021 ([`super::REFERENCE_YEAR`]), whatever years its rows name
//! (TMY files mix them); a file with 29 February (8784 rows) builds every `time` in the year
//! of its 29 February rows, which must be a leap year (a warning says so when other rows name
//! other years). [`super::WeatherRecord::year`] always keeps the row's own year.
//!
//! **Checks.** Rows must follow the data period's calendar exactly (month, day, hour in
//! order, N rows per hour); a file that ends before the period's last row is truncated and
//! the error names its last line; a row with fewer fields than the first data row (or fewer
//! than 16) is truncated too. DNI/DHI of 9999 or blank are missing (→ 0, `missing`, one
//! warning per file); a dew point of 99.9 or more, or blank, is missing (→ `None`). Any other
//! non-numeric, non-finite or negative irradiance, or an out-of-range month/day/hour/minute,
//! is an [`Error::Input`] naming the file, the 1-based line and the field.

use super::epw_header::{parse_data_periods, parse_location};
use super::{days_in_month, is_leap, Weather, WeatherFormat, WeatherRecord, REFERENCE_YEAR};
use crate::error::{Error, Result};
use chrono::{NaiveDate, TimeDelta};
use std::path::Path;

/// Index of the dew-point field in a data row.
const DEW_POINT: usize = 7;
/// Index of the direct normal irradiance field.
const DNI: usize = 14;
/// Index of the diffuse horizontal irradiance field.
const DHI: usize = 15;
/// Index of the diffuse horizontal illuminance field (optional: files may stop before it).
const DIFFUSE_ILLUMINANCE: usize = 18;
/// EPW's missing-value code for illuminance (and anything above it).
const MISSING_ILLUMINANCE: f64 = 999_999.0;
/// EPW's missing-value code for irradiance.
const MISSING_IRRADIANCE: f64 = 9999.0;
/// EPW's missing-value code for the dew point (and anything above it).
const MISSING_DEW_POINT: f64 = 99.9;

/// Reads an EPW file (see the module doc for conventions and checks).
///
/// # Errors
/// [`Error::Input`] naming file, line and value; [`Error::Io`] when it cannot be read.
pub fn read(path: &Path) -> Result<Weather> {
    parse(path, &crate::files::read_text(path)?)
}

/// One data row as parsed, before the calendar checks.
struct Row {
    line: usize,
    year: i32,
    month: u32,
    day: u32,
    hour: u32,
    dni: Option<f64>,
    dhi: Option<f64>,
    dew: Option<f64>,
    diffuse_lux: Option<f64>,
    /// `year,month,day,hour` as written, for error messages.
    stamp: String,
}

/// Parses EPW text; `path` names the source in errors and is stored in the result.
///
/// # Errors
/// [`Error::Input`] naming file, line and value (see the module doc).
pub fn parse(path: &Path, text: &str) -> Result<Weather> {
    let lines: Vec<&str> = text.lines().collect();
    let site = parse_location(path, lines.first().copied().unwrap_or(""))?;
    if lines.len() < 8 {
        return Err(Error::input(
            path,
            Some(lines.len()),
            None,
            "file ends inside the 8-line EPW header",
        ));
    }
    let period = parse_data_periods(path, lines[7])?;

    // Rows as written, checked field by field: at most one per line, so the capacity follows
    // the text, never the data period's claim (60 rows an hour → 50 MB for any file).
    let mut rows = Vec::with_capacity(lines.len() - 8);
    let mut width = None;
    let mut last_line = 8;
    for (i, raw) in lines.iter().enumerate().skip(8) {
        let line = i + 1;
        if raw.trim().is_empty() {
            continue;
        }
        last_line = line;
        let fields: Vec<&str> = raw.split(',').collect();
        let want = *width.get_or_insert(fields.len().max(DHI + 1));
        if fields.len() < want {
            return Err(Error::input(
                path,
                Some(line),
                Some(raw.trim()),
                format!(
                    "truncated data row: {} fields, the file's rows have {want} \
                     (DNI and DHI are fields 15 and 16)",
                    fields.len()
                ),
            ));
        }
        rows.push(parse_row(path, line, &fields)?);
    }

    // Leap files: `time` is built in the year of the 29 February rows.
    let feb29 = rows.iter().find(|r| r.month == 2 && r.day == 29);
    let mut warnings = Vec::new();
    let time_year = match feb29 {
        Some(r) if !is_leap(r.year) => {
            return Err(Error::input(
                path,
                Some(r.line),
                Some(&r.year.to_string()),
                "a 29 February row names a year that is not a leap year",
            ))
        }
        Some(r) => {
            if let Some(other) = rows.iter().find(|o| o.year != r.year) {
                warnings.push(format!(
                    "{}: rows name different years (line {} says {}, the 29 February rows {}); \
                     all times are built in {}",
                    path.display(),
                    other.line,
                    other.year,
                    r.year,
                    r.year
                ));
            }
            r.year
        }
        None => REFERENCE_YEAR,
    };
    let leap = feb29.is_some();

    // The data period's calendar, one entry per day.
    let days = period.days(path, leap)?;
    let per_hour = period.per_hour as usize;
    let per_day = 24 * per_hour;
    let expected = days.len() * per_day;
    let step_s = 3600 / i64::from(period.per_hour);

    let mut records = Vec::with_capacity(rows.len());
    for (k, r) in rows.iter().enumerate() {
        if k >= expected {
            return Err(Error::input(
                path,
                Some(r.line),
                Some(&r.stamp),
                format!(
                    "more rows than the data period implies ({expected}: {} days × 24 h × {} \
                     per hour)",
                    days.len(),
                    period.per_hour
                ),
            ));
        }
        let (month, day) = days[k / per_day];
        let hour = ((k / per_hour) % 24 + 1) as u32;
        let sub = (k % per_hour) as i64;
        if (r.month, r.day, r.hour) != (month, day, hour) {
            return Err(Error::input(
                path,
                Some(r.line),
                Some(&r.stamp),
                format!(
                    "row out of sequence: expected month {month}, day {day}, hour {hour} \
                     (row {} of the data period)",
                    k + 1
                ),
            ));
        }
        let date = NaiveDate::from_ymd_opt(time_year, month, day)
            .ok_or_else(|| Error::Internal(format!("calendar day {month}/{day} invalid")))?;
        // Middle of the interval: hour-ending h, sub-row k ends at (h−1)h + (k+1)·step.
        let mid_s = i64::from(hour - 1) * 3600 + (sub + 1) * step_s - step_s / 2;
        let time = date.and_time(chrono::NaiveTime::MIN) + TimeDelta::seconds(mid_s);
        records.push(WeatherRecord {
            line: r.line,
            month,
            day,
            year: r.year,
            time,
            dni: r.dni.unwrap_or(0.0),
            dhi: r.dhi.unwrap_or(0.0),
            dew_point_c: r.dew,
            diffuse_illuminance_lux: r.diffuse_lux,
            missing: r.dni.is_none() || r.dhi.is_none(),
        });
    }
    if records.len() < expected {
        return Err(Error::input(
            path,
            Some(last_line),
            lines.get(last_line - 1).map(|l| l.trim()),
            format!(
                "file ends after {} of the {expected} rows its data period implies \
                 (truncated?)",
                records.len()
            ),
        ));
    }

    let missing: Vec<&WeatherRecord> = records.iter().filter(|r| r.missing).collect();
    if let Some(first) = missing.first() {
        warnings.push(format!(
            "{}: {} records have missing DNI or DHI (9999 or blank; first at line {}); they are \
             read as 0 and flagged missing",
            path.display(),
            missing.len(),
            first.line
        ));
    }

    Ok(Weather {
        site,
        records,
        path: path.to_path_buf(),
        format: WeatherFormat::Epw,
        warnings,
        interval_minutes: 60 / period.per_hour,
    })
}

/// Parses and range-checks one data row's fields.
fn parse_row(path: &Path, line: usize, f: &[&str]) -> Result<Row> {
    let bad =
        |i: usize, message: String| Error::input(path, Some(line), Some(f[i].trim()), message);
    let int = |i: usize, what: &str, lo: i64, hi: i64| -> Result<i64> {
        let v: i64 = f[i]
            .trim()
            .parse()
            .map_err(|_| bad(i, format!("{what} is not an integer")))?;
        if !(lo..=hi).contains(&v) {
            return Err(bad(i, format!("{what} must be within {lo} … {hi}")));
        }
        Ok(v)
    };
    let year = int(0, "year", -9999, 9999)? as i32;
    let month = int(1, "month", 1, 12)? as u32;
    let day = int(2, "day", 1, i64::from(days_in_month(month, true)))? as u32;
    let hour = int(3, "hour (hour-ending, 1–24)", 1, 24)? as u32;
    int(4, "minute", 0, 60)?;

    let dew = match f[DEW_POINT].trim() {
        "" => None,
        s => {
            let v: f64 = s
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| bad(DEW_POINT, "dew point (°C) is not a finite number".into()))?;
            (v < MISSING_DEW_POINT).then_some(v)
        }
    };
    let irradiance = |i: usize, what: &str| -> Result<Option<f64>> {
        let s = f[i].trim();
        if s.is_empty() {
            return Ok(None);
        }
        let v: f64 = s
            .parse()
            .map_err(|_| bad(i, format!("{what} (W/m²) is not a number")))?;
        if !v.is_finite() || v < 0.0 {
            return Err(bad(
                i,
                format!("{what} (W/m²) must be a finite number ≥ 0 (9999 or blank = missing)"),
            ));
        }
        Ok((v != MISSING_IRRADIANCE).then_some(v))
    };
    Ok(Row {
        line,
        year,
        month,
        day,
        hour,
        dni: irradiance(DNI, "direct normal irradiance")?,
        dhi: irradiance(DHI, "diffuse horizontal irradiance")?,
        dew,
        diffuse_lux: match f.get(DIFFUSE_ILLUMINANCE).map(|s| s.trim()) {
            None | Some("") => None,
            Some(s) => {
                let v: f64 = s
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite() && *v >= 0.0)
                    .ok_or_else(|| {
                        bad(
                            DIFFUSE_ILLUMINANCE,
                            "diffuse horizontal illuminance (lux) must be a finite number ≥ 0 \
                         (999999 or blank = missing)"
                                .into(),
                        )
                    })?;
                (v < MISSING_ILLUMINANCE).then_some(v)
            }
        },
        stamp: f[..4]
            .iter()
            .map(|s| s.trim())
            .collect::<Vec<_>>()
            .join(","),
    })
}

#[cfg(test)]
#[path = "epw_tests.rs"]
mod tests;
