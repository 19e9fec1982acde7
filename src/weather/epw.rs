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

use super::{days_in_month, is_leap, Weather, WeatherFormat, WeatherRecord, REFERENCE_YEAR};
use crate::error::{Error, Result};
use crate::site::Site;
use chrono::{NaiveDate, TimeDelta};
use std::path::Path;

/// Index of the dew-point field in a data row.
const DEW_POINT: usize = 7;
/// Index of the direct normal irradiance field.
const DNI: usize = 14;
/// Index of the diffuse horizontal irradiance field.
const DHI: usize = 15;
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

/// Parses header line 1 into the site.
fn parse_location(path: &Path, line: &str) -> Result<Site> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() < 10 || !fields[0].eq_ignore_ascii_case("LOCATION") {
        return Err(Error::input(
            path,
            Some(1),
            Some(line.trim()),
            "not an EPW header: line 1 must be `LOCATION,city,state,country,source,WMO,\
             latitude,longitude,time zone,elevation`",
        ));
    }
    let num = |i: usize, what: &str, lo: f64, hi: f64| -> Result<f64> {
        let v: f64 = fields[i].parse().map_err(|_| {
            Error::input(
                path,
                Some(1),
                Some(fields[i]),
                format!("{what} is not a number"),
            )
        })?;
        if !(lo..=hi).contains(&v) {
            return Err(Error::input(
                path,
                Some(1),
                Some(fields[i]),
                format!("{what} must be within {lo} … {hi}"),
            ));
        }
        Ok(v)
    };
    Ok(Site {
        latitude: num(6, "latitude (degrees north)", -90.0, 90.0)?,
        longitude: num(7, "longitude (degrees east)", -180.0, 180.0)?,
        utc_offset_h: num(8, "time zone (hours east of UTC)", -12.0, 14.0)?,
        elevation_m: num(9, "elevation (metres)", -1000.0, 10000.0)?,
    })
}

/// The one data period of header line 8.
struct DataPeriod {
    per_hour: u32,
    start: (u32, u32),
    end: (u32, u32),
}

impl DataPeriod {
    /// The period's days as (month, day), 29 February included when `leap`.
    fn days(&self, path: &Path, leap: bool) -> Result<Vec<(u32, u32)>> {
        let valid = |(m, d): (u32, u32)| d >= 1 && d <= days_in_month(m, leap);
        if !valid(self.start) || !valid(self.end) || self.end < self.start {
            return Err(Error::input(
                path,
                Some(8),
                Some(&format!(
                    "{}/{} – {}/{}",
                    self.start.0, self.start.1, self.end.0, self.end.1
                )),
                "data period dates must be valid and the period must not wrap the year end",
            ));
        }
        let mut out = Vec::new();
        for m in self.start.0..=self.end.0 {
            for d in 1..=days_in_month(m, leap) {
                if (m, d) >= self.start && (m, d) <= self.end {
                    out.push((m, d));
                }
            }
        }
        Ok(out)
    }
}

/// Parses header line 8, `DATA PERIODS,1,N,name,weekday,m/d,m/d`.
fn parse_data_periods(path: &Path, line: &str) -> Result<DataPeriod> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    let bad = |value: &str, message: &str| Error::input(path, Some(8), Some(value), message);
    if fields.len() < 7 || !fields[0].eq_ignore_ascii_case("DATA PERIODS") {
        return Err(bad(
            line.trim(),
            "EPW header line 8 must be `DATA PERIODS,1,N,name,start weekday,start m/d,end m/d`",
        ));
    }
    if fields[1] != "1" {
        return Err(bad(
            fields[1],
            "only EPW files with one data period are supported",
        ));
    }
    let per_hour: u32 = fields[2]
        .parse()
        .ok()
        .filter(|n| (1..=60).contains(n) && 60 % n == 0)
        .ok_or_else(|| {
            bad(
                fields[2],
                "records per hour must be a divisor of 60 (1, 2, 4, …)",
            )
        })?;
    let date = |s: &str| -> Result<(u32, u32)> {
        let mut it = s.split('/').map(str::trim);
        let m = it.next().and_then(|x| x.parse().ok());
        let d = it.next().and_then(|x| x.parse().ok());
        match (m, d) {
            (Some(m), Some(d)) if (1..=12).contains(&m) => Ok((m, d)),
            _ => Err(bad(s, "data period dates must be month/day")),
        }
    };
    Ok(DataPeriod {
        per_hour,
        start: date(fields[5])?,
        end: date(fields[6])?,
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
        stamp: f[..4]
            .iter()
            .map(|s| s.trim())
            .collect::<Vec<_>>()
            .join(","),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::input_parts;
    use crate::weather::temp_file;
    use chrono::NaiveDateTime;

    fn t(s: &str) -> NaiveDateTime {
        NaiveDateTime::parse_from_str(s, "%Y-%m-%dT%H:%M:%S").unwrap()
    }

    /// The 8 header lines of a synthetic EPW: Boulder-like site, `per_hour` rows per hour,
    /// data period `start`–`end` (m/d).
    fn header(per_hour: u32, start: &str, end: &str) -> String {
        let mut s =
            String::from("LOCATION,Test,CO,USA,synthetic,000000,40.000,-105.250,-7.0,1650.0\n");
        for l in [
            "DESIGN CONDITIONS,0",
            "TYPICAL/EXTREME PERIODS,0",
            "GROUND TEMPERATURES,0",
            "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
            "COMMENTS 1,synthetic",
            "COMMENTS 2,synthetic",
        ] {
            s.push_str(l);
            s.push('\n');
        }
        s.push_str(&format!(
            "DATA PERIODS,1,{per_hour},Data,Sunday,{start},{end}\n"
        ));
        s
    }

    /// One 35-field data row with the given dew point, DNI and DHI fields.
    fn row(
        year: i32,
        (month, day, hour, minute): (u32, u32, u32, u32),
        dew: &str,
        dni: &str,
        dhi: &str,
    ) -> String {
        let mut f: Vec<String> = vec![
            year.to_string(),
            month.to_string(),
            day.to_string(),
            hour.to_string(),
            minute.to_string(),
            "A7A7".into(),
            "10.0".into(),
            dew.into(),
        ];
        while f.len() < 35 {
            f.push("0".into());
        }
        f[DNI] = dni.into();
        f[DHI] = dhi.into();
        f.join(",") + "\n"
    }

    /// A one-day (1 January) hourly file whose row for hour h has DNI 10·h, DHI h.
    fn one_day() -> String {
        let mut s = header(1, "1/1", "1/1");
        for h in 1..=24 {
            s.push_str(&row(
                2021,
                (1, 1, h, 60),
                "-5.0",
                &(10 * h).to_string(),
                &h.to_string(),
            ));
        }
        s
    }

    #[test]
    fn bundled_greensboro_file() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw");
        let text = std::fs::read_to_string(&path).unwrap();
        let w = read(&path).unwrap();

        // The site is the header's fields 6–9 as written (EPW is east-positive already).
        let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        assert_eq!(head[7], "-79.950");
        assert_eq!(w.site.latitude, head[6].parse::<f64>().unwrap());
        assert_eq!(w.site.longitude, head[7].parse::<f64>().unwrap());
        assert_eq!(w.site.utc_offset_h, head[8].parse::<f64>().unwrap());
        assert_eq!(w.site.elevation_m, head[9].parse::<f64>().unwrap());

        assert_eq!(w.records.len(), 8760);
        assert_eq!(w.interval_minutes, 60);
        assert_eq!(w.format, WeatherFormat::Epw);
        // Hour-ending 1 of 1 January, evaluated at the middle of the hour, reference year.
        assert_eq!(w.records[0].time, t("2021-01-01T00:30:00"));
        assert_eq!(w.records[0].line, 9);
        assert_eq!(w.records[8759].time, t("2021-12-31T23:30:00"));

        // 21 March, hour-ending 12 (the README's record): find its line by splitting text.
        let (i, line) = text
            .lines()
            .enumerate()
            .find(|(_, l)| {
                let f: Vec<&str> = l.split(',').collect();
                f.len() > 15 && f[1] == "3" && f[2] == "21" && f[3] == "12"
            })
            .unwrap();
        let f: Vec<&str> = line.split(',').collect();
        let r = w.records.iter().find(|r| r.line == i + 1).unwrap();
        assert_eq!(r.time, t("2021-03-21T11:30:00"));
        assert_eq!(r.year, f[0].parse::<i32>().unwrap());
        assert_eq!(r.dni, f[14].parse::<f64>().unwrap());
        assert_eq!(r.dhi, f[15].parse::<f64>().unwrap());
        assert_eq!(r.dew_point_c, Some(f[7].parse::<f64>().unwrap()));
        assert!(r.dni > 0.0 && !r.missing);
        // TMY rows come from many years; times still run monotonically through 2021.
        assert!(w.records.windows(2).all(|p| p[1].time > p[0].time));
    }

    #[test]
    fn leap_year_file_keeps_29_february() {
        let mut s = header(1, "1/1", "12/31");
        for m in 1..=12 {
            for d in 1..=days_in_month(m, true) {
                for h in 1..=24 {
                    s.push_str(&row(2020, (m, d, h, 60), "1.0", "100", "50"));
                }
            }
        }
        let (_d, p) = temp_file("leap.epw", &s);
        let w = read(&p).unwrap();
        assert_eq!(w.records.len(), 366 * 24);
        // Jan (31 d) + 28 d of Feb = 59 days before 29 Feb: record 59·24 + 12 is its hour 13.
        let r = &w.records[59 * 24 + 12];
        assert_eq!((r.month, r.day, r.year), (2, 29, 2020));
        assert_eq!(r.time, t("2020-02-29T12:30:00"));
        assert_eq!(w.records.last().unwrap().time, t("2020-12-31T23:30:00"));
        assert!(w.warnings.is_empty(), "{:?}", w.warnings);

        // The same file claiming 2021 for 29 February is rejected at that row's line:
        // 8 header lines + 59·24 rows before it.
        let bad = s.replace("2020,2,29,1,", "2021,2,29,1,");
        let (_d, p) = temp_file("leap.epw", &bad);
        let (_, _, line, value) = input_parts(read(&p).unwrap_err());
        assert_eq!(
            (line, value.as_deref()),
            (Some(8 + 59 * 24 + 1), Some("2021"))
        );
    }

    #[test]
    fn sub_hourly_rows_are_evaluated_mid_interval() {
        // 4 rows per hour → 15-minute intervals; hour-ending 1, rows end 00:15 … 01:00.
        let mut s = header(4, " 1/ 1", " 1/ 1");
        for h in 1..=24 {
            for m in [15, 30, 45, 60] {
                s.push_str(&row(2021, (1, 1, h, m), "0", "1", "1"));
            }
        }
        let (_d, p) = temp_file("q.epw", &s);
        let w = read(&p).unwrap();
        assert_eq!((w.records.len(), w.interval_minutes), (96, 15));
        assert_eq!(w.records[0].time, t("2021-01-01T00:07:30"));
        assert_eq!(w.records[3].time, t("2021-01-01T00:52:30"));
        assert_eq!(w.records[4].time, t("2021-01-01T01:07:30"));
        assert_eq!(w.records[95].time, t("2021-01-01T23:52:30"));
    }

    #[test]
    fn missing_values_are_flagged_once() {
        let mut s = one_day();
        // Line 12 = hour 4: DNI missing; line 15 = hour 7: DHI blank; dew point 99.9.
        let lines: Vec<String> = s.lines().map(str::to_owned).collect();
        let mut l = lines.clone();
        l[11] = row(2021, (1, 1, 4, 60), "99.9", "9999", "4")
            .trim_end()
            .into();
        l[14] = row(2021, (1, 1, 7, 60), "", "70", "").trim_end().into();
        s = l.join("\n") + "\n";
        let (_d, p) = temp_file("m.epw", &s);
        let w = read(&p).unwrap();
        let r4 = &w.records[3];
        assert_eq!(
            (r4.line, r4.dni, r4.dhi, r4.missing, r4.dew_point_c),
            (12, 0.0, 4.0, true, None)
        );
        let r7 = &w.records[6];
        assert_eq!(
            (r7.line, r7.dni, r7.dhi, r7.missing, r7.dew_point_c),
            (15, 70.0, 0.0, true, None)
        );
        assert_eq!(w.records[0].dew_point_c, Some(-5.0));
        assert_eq!(w.missing_count(), 2);
        assert_eq!(w.warnings.len(), 1, "{:?}", w.warnings);
        assert!(
            w.warnings[0].contains("2 records") && w.warnings[0].contains("line 12"),
            "{}",
            w.warnings[0]
        );
    }

    #[test]
    fn truncated_files_name_the_last_line() {
        // 20 of the 24 rows: the file's last line is 8 + 20 = 28.
        let s: String = one_day()
            .lines()
            .take(28)
            .map(|l| format!("{l}\n"))
            .collect();
        let (_d, p) = temp_file("t.epw", &s);
        let (shown, path, line, _) = input_parts(read(&p).unwrap_err());
        assert_eq!((path, line), (p, Some(28)));
        assert!(shown.contains("20 of the 24"), "{shown}");

        // A row cut after its 10th field (line 9 + 5 = 14).
        let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
        l[13] = l[13].split(',').take(10).collect::<Vec<_>>().join(",");
        let (_d, p) = temp_file("t.epw", &(l.join("\n") + "\n"));
        let (shown, _, line, _) = input_parts(read(&p).unwrap_err());
        assert_eq!(line, Some(14));
        assert!(shown.contains("truncated"), "{shown}");

        // Only a header.
        let (_d, p) = temp_file("t.epw", "LOCATION,a,b,c,d,0,1,2,3,4\nDESIGN CONDITIONS,0\n");
        let (_, _, line, _) = input_parts(read(&p).unwrap_err());
        assert_eq!(line, Some(2));
    }

    #[test]
    fn bad_fields_name_line_and_value() {
        let cases: [(usize, String, &str); 6] = [
            // (line, replacement row, offending field as written)
            (10, row(2021, (1, 1, 2, 60), "0", "NaN", "2"), "NaN"),
            (11, row(2021, (1, 1, 3, 60), "0", "30", "-1"), "-1"),
            (12, row(2021, (1, 1, 4, 60), "0", "abc", "4"), "abc"),
            (13, row(2021, (13, 1, 5, 60), "0", "50", "5"), "13"),
            (14, row(2021, (1, 1, 0, 60), "0", "60", "6"), "0"),
            (15, row(2021, (1, 1, 7, 60), "inf", "70", "7"), "inf"),
        ];
        for (line, replacement, value) in cases {
            let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
            l[line - 1] = replacement.trim_end().into();
            let (_d, p) = temp_file("b.epw", &(l.join("\n") + "\n"));
            let (shown, path, got_line, got_value) = input_parts(read(&p).unwrap_err());
            assert_eq!(
                (path, got_line, got_value.as_deref()),
                (p, Some(line), Some(value)),
                "{shown}"
            );
        }
        // A row out of calendar order (hour 5 where hour 3 belongs, line 11).
        let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
        l[10] = row(2021, (1, 1, 5, 60), "0", "0", "0").trim_end().into();
        let (_d, p) = temp_file("b.epw", &(l.join("\n") + "\n"));
        let (shown, _, line, value) = input_parts(read(&p).unwrap_err());
        assert_eq!(
            (line, value.as_deref()),
            (Some(11), Some("2021,1,1,5")),
            "{shown}"
        );
    }

    #[test]
    fn wrong_header_names_line_one() {
        let s = one_day().replacen("LOCATION", "LOKATION", 1);
        let (_d, p) = temp_file("h.epw", &s);
        let (_, _, line, value) = input_parts(read(&p).unwrap_err());
        assert_eq!(line, Some(1));
        assert!(value.unwrap().starts_with("LOKATION"));
        // A bad latitude is named by value.
        let s = one_day().replacen("40.000", "95.0", 1);
        let (_d, p) = temp_file("h.epw", &s);
        let (_, _, line, value) = input_parts(read(&p).unwrap_err());
        assert_eq!((line, value.as_deref()), (Some(1), Some("95.0")));
    }
}
