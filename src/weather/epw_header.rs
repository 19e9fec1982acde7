//! The two EPW header lines daystep reads (the layout is in [`super::epw`]'s docs): line 1,
//! `LOCATION`, gives the site (fields 6–9: latitude, longitude east positive, time zone in
//! hours east of UTC, elevation in metres); line 8, `DATA PERIODS`, gives the records per
//! hour and the calendar the data rows must follow. The six lines between are not used.
//! Errors name the file, the line and the offending field.

use super::days_in_month;
use crate::error::{Error, Result};
use crate::site::Site;
use std::path::Path;

/// Parses header line 1 into the site.
pub(super) fn parse_location(path: &Path, line: &str) -> Result<Site> {
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
pub(super) struct DataPeriod {
    /// Records per hour (a divisor of 60).
    pub(super) per_hour: u32,
    /// First day, (month, day).
    start: (u32, u32),
    /// Last day, (month, day).
    end: (u32, u32),
}

impl DataPeriod {
    /// The period's days as (month, day), 29 February included when `leap`.
    pub(super) fn days(&self, path: &Path, leap: bool) -> Result<Vec<(u32, u32)>> {
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
pub(super) fn parse_data_periods(path: &Path, line: &str) -> Result<DataPeriod> {
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
