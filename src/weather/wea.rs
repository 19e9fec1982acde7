//! Radiance `gendaymtx` / DAYSIM weather files (WEA).
//!
//! Layout: header lines `place <name>`, `latitude <deg N>`, `longitude <deg WEST positive>`,
//! `time_zone <standard meridian, deg WEST positive>` (75 for UTC−5), `site_elevation <m>`,
//! `weather_data_file_units 1` (DNI and DHI in W/m², the only units accepted); then rows
//! `month day hour DNI DHI` with `hour` the decimal local standard time at which the sun is
//! evaluated (12.5 = 12:30), used as is.
//!
//! Conversion to daystep's conventions: longitude_east = −longitude_wea, utc_offset_h =
//! −time_zone/15. WEA rows carry no year: `time` is built in 2021
//! ([`super::REFERENCE_YEAR`]), or in 2020 ([`super::LEAP_REFERENCE_YEAR`]) when a row is on
//! 29 February. Rows must run forward in time. DNI/DHI of 9999 are read as missing (→ 0,
//! `missing`, one warning), as in EPW, since WEAs converted from EPW files carry the code;
//! negative, non-finite or non-numeric values are [`Error::Input`] naming file, line and value.
//! The interval is the difference of the first two rows' times (60 min for a single row).

use super::{
    days_in_month, Weather, WeatherFormat, WeatherRecord, LEAP_REFERENCE_YEAR, REFERENCE_YEAR,
};
use crate::error::{Error, Result};
use crate::site::Site;
use chrono::{Datelike, NaiveDate, NaiveTime, TimeDelta};
use std::path::Path;

/// The header keywords of a WEA file, in the order Radiance writes them.
pub const HEADER_KEYS: [&str; 6] = [
    "place",
    "latitude",
    "longitude",
    "time_zone",
    "site_elevation",
    "weather_data_file_units",
];

/// A data row as parsed: (line, month, day, seconds after midnight, DNI, DHI; `None` =
/// missing).
type WeaRow = (usize, u32, u32, i64, Option<f64>, Option<f64>);

/// Reads a WEA file (see the module doc for conventions and checks).
///
/// # Errors
/// [`Error::Input`] naming file, line and value; [`Error::Io`] when it cannot be read.
pub fn read(path: &Path) -> Result<Weather> {
    parse(path, &crate::files::read_text(path)?)
}

/// Parses WEA text; `path` names the source in errors and is stored in the result.
///
/// # Errors
/// [`Error::Input`] naming file, line and value (see the module doc).
pub fn parse(path: &Path, text: &str) -> Result<Weather> {
    let mut latitude = None;
    let mut longitude_west = None;
    let mut time_zone_west = None;
    let mut elevation = 0.0;
    // Rows as parsed: (line, month, day, seconds after midnight, dni, dhi).
    let mut rows: Vec<WeaRow> = Vec::new();

    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() {
            continue;
        }
        let words: Vec<&str> = trimmed.split_whitespace().collect();
        let bad =
            |value: &str, message: String| Error::input(path, Some(line), Some(value), message);
        if HEADER_KEYS.contains(&words[0]) {
            if !rows.is_empty() {
                return Err(bad(trimmed, "WEA header line after the data rows".into()));
            }
            if words[0] == "place" {
                continue;
            }
            let value = words.get(1).copied().unwrap_or("");
            let num = |lo: f64, hi: f64| -> Result<f64> {
                value
                    .parse::<f64>()
                    .ok()
                    .filter(|v| (lo..=hi).contains(v))
                    .ok_or_else(|| {
                        bad(
                            value,
                            format!("`{}` needs a number within {lo} … {hi}", words[0]),
                        )
                    })
            };
            match words[0] {
                "latitude" => latitude = Some(num(-90.0, 90.0)?),
                "longitude" => longitude_west = Some(num(-180.0, 180.0)?),
                "time_zone" => time_zone_west = Some(num(-210.0, 180.0)?),
                "site_elevation" => elevation = num(-1000.0, 10000.0)?,
                _ => {
                    if value != "1" {
                        return Err(bad(
                            value,
                            "only `weather_data_file_units 1` (DNI and DHI in W/m²) is supported"
                                .into(),
                        ));
                    }
                }
            }
            continue;
        }
        if rows.is_empty()
            && (latitude.is_none() || longitude_west.is_none() || time_zone_west.is_none())
        {
            return Err(bad(
                trimmed,
                "not a WEA file: `latitude`, `longitude` and `time_zone` header lines must come \
                 before the data rows"
                    .into(),
            ));
        }
        if words.len() != 5 {
            return Err(bad(
                trimmed,
                format!(
                    "a WEA row is `month day hour DNI DHI`, found {} fields",
                    words.len()
                ),
            ));
        }
        let int = |w: &str, what: &str, lo: u32, hi: u32| -> Result<u32> {
            w.parse::<u32>()
                .ok()
                .filter(|v| (lo..=hi).contains(v))
                .ok_or_else(|| bad(w, format!("{what} must be an integer within {lo} … {hi}")))
        };
        let month = int(words[0], "month", 1, 12)?;
        let day = int(words[1], "day", 1, days_in_month(month, true))?;
        let hour: f64 = words[2]
            .parse()
            .ok()
            .filter(|h: &f64| (0.0..24.0).contains(h))
            .ok_or_else(|| bad(words[2], "hour must be a decimal hour within 0 … 24".into()))?;
        let seconds = (hour * 3600.0).round() as i64;
        if seconds >= 86_400 {
            return Err(bad(
                words[2],
                "hour rounds to 24:00; use 0 of the next day".into(),
            ));
        }
        let irradiance = |w: &str, what: &str| -> Result<Option<f64>> {
            let v: f64 = w
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| bad(w, format!("{what} (W/m²) must be a finite number ≥ 0")))?;
            Ok((v != 9999.0).then_some(v))
        };
        let dni = irradiance(words[3], "direct normal irradiance")?;
        let dhi = irradiance(words[4], "diffuse horizontal irradiance")?;
        rows.push((line, month, day, seconds, dni, dhi));
    }

    let (Some(lat), Some(lon_w), Some(tz_w)) = (latitude, longitude_west, time_zone_west) else {
        return Err(Error::input(
            path,
            Some(1),
            text.lines().next().map(str::trim),
            "not a WEA file: `latitude`, `longitude` and `time_zone` header lines are required",
        ));
    };
    let site = Site {
        latitude: lat,
        // WEA is west positive; `+ 0.0` turns −0 into 0.
        longitude: -lon_w + 0.0,
        utc_offset_h: -tz_w / 15.0 + 0.0,
        elevation_m: elevation,
    };

    let year = if rows.iter().any(|r| r.1 == 2 && r.2 == 29) {
        LEAP_REFERENCE_YEAR
    } else {
        REFERENCE_YEAR
    };
    let mut records: Vec<WeatherRecord> = Vec::with_capacity(rows.len());
    for &(line, month, day, seconds, dni, dhi) in &rows {
        let date = NaiveDate::from_ymd_opt(year, month, day)
            .ok_or_else(|| Error::Internal(format!("calendar day {month}/{day} invalid")))?;
        let time = date.and_time(NaiveTime::MIN) + TimeDelta::seconds(seconds);
        if let Some(prev) = records.last() {
            if time <= prev.time {
                return Err(Error::input(
                    path,
                    Some(line),
                    Some(&format!("{month} {day} {}", seconds as f64 / 3600.0)),
                    format!(
                        "rows must run forward in time (line {} is at or after it)",
                        prev.line
                    ),
                ));
            }
        }
        records.push(WeatherRecord {
            line,
            month,
            day,
            year: time.year(),
            time,
            dni: dni.unwrap_or(0.0),
            dhi: dhi.unwrap_or(0.0),
            dew_point_c: None,
            diffuse_illuminance_lux: None,
            missing: dni.is_none() || dhi.is_none(),
        });
    }
    let interval_minutes = match records.as_slice() {
        [a, b, ..] => ((b.time - a.time).num_seconds() as f64 / 60.0).round() as u32,
        _ => 60,
    };
    let mut warnings = Vec::new();
    let missing: Vec<&WeatherRecord> = records.iter().filter(|r| r.missing).collect();
    if let Some(first) = missing.first() {
        warnings.push(format!(
            "{}: {} records have missing DNI or DHI (9999; first at line {}); they are read as \
             0 and flagged missing",
            path.display(),
            missing.len(),
            first.line
        ));
    }
    Ok(Weather {
        site,
        records,
        path: path.to_path_buf(),
        format: WeatherFormat::Wea,
        warnings,
        interval_minutes: interval_minutes.max(1),
    })
}

/// WEA text for `weather` (Radiance conventions: west-positive longitude and standard
/// meridian). Hours and irradiances are written in Rust's shortest exact form, so reading
/// the text back gives the same times (to the second) and values. Missing records are written
/// with their values of 0 (what `gendaymtx` should see), so the `missing` flag does not
/// survive the trip.
pub fn to_text(weather: &Weather, place: &str) -> String {
    let s = &weather.site;
    let place: String = place
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    let mut out = format!(
        "place {}\nlatitude {}\nlongitude {}\ntime_zone {}\nsite_elevation {}\n\
         weather_data_file_units 1\n",
        place.trim(),
        s.latitude,
        -s.longitude + 0.0,
        -s.utc_offset_h * 15.0 + 0.0,
        s.elevation_m
    );
    for r in &weather.records {
        let seconds = (r.time - r.time.date().and_time(NaiveTime::MIN)).num_seconds();
        out.push_str(&format!(
            "{} {} {} {} {}\n",
            r.time.month(),
            r.time.day(),
            seconds as f64 / 3600.0,
            r.dni,
            r.dhi
        ));
    }
    out
}

/// Writes [`to_text`] to `path` atomically.
///
/// # Errors
/// [`Error::Io`] naming the path.
pub fn write(path: &Path, weather: &Weather, place: &str) -> Result<()> {
    crate::files::write_atomic(path, to_text(weather, place).as_bytes())
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

    const SAN_FRANCISCO: &str = "place San_Francisco\nlatitude 37.62\nlongitude 122.4\n\
        time_zone 120\nsite_elevation 2.0\nweather_data_file_units 1\n\
        6 21 11.5 750 90\n6 21 12.5 800 100\n6 21 13.5 9999 110\n";

    #[test]
    fn west_positive_header_is_converted() {
        let (_d, p) = temp_file("sf.wea", SAN_FRANCISCO);
        let w = read(&p).unwrap();
        // 122.4° W → −122.4° east; meridian 120° W → UTC −8 h.
        assert_eq!(w.site.longitude, -122.4);
        assert_eq!(w.site.utc_offset_h, -8.0);
        assert_eq!((w.site.latitude, w.site.elevation_m), (37.62, 2.0));
        assert_eq!(w.records.len(), 3);
        assert_eq!(w.interval_minutes, 60);
        let r = &w.records[1];
        assert_eq!(
            (r.line, r.time, r.dni, r.dhi),
            (8, t("2021-06-21T12:30:00"), 800.0, 100.0)
        );
        assert!(w.records[2].missing && w.records[2].dni == 0.0);
        assert_eq!(w.warnings.len(), 1);
    }

    #[test]
    fn round_trip_through_wea_text() {
        // A site east of Greenwich and one west of it, UTC+5:45 and UTC−7.
        let (_d, p) = temp_file("sf.wea", SAN_FRANCISCO);
        let mut w = read(&p).unwrap();
        w.records[2].missing = false; // written as 0, read back as a real 0
        for (lon, tz, lon_text, tz_text) in [
            (85.3, 5.75, "longitude -85.3\n", "time_zone -86.25\n"),
            (-105.25, -7.0, "longitude 105.25\n", "time_zone 105\n"),
        ] {
            w.site.longitude = lon;
            w.site.utc_offset_h = tz;
            w.records[0].time = t("2021-06-21T11:07:30"); // 11.125 h, exact in decimal
            let text = to_text(&w, "Test place");
            assert!(text.contains(lon_text) && text.contains(tz_text), "{text}");
            assert!(text.contains("\n6 21 11.125 750 90\n"), "{text}");
            let (_d2, q) = temp_file("rt.wea", &text);
            let back = read(&q).unwrap();
            assert_eq!(back.site, w.site);
            for (a, b) in back.records.iter().zip(&w.records) {
                assert_eq!(
                    (a.time, a.dni, a.dhi, a.missing),
                    (b.time, b.dni, b.dhi, b.missing)
                );
            }
        }
    }

    #[test]
    fn leap_day_uses_a_leap_year() {
        let text = "latitude 0\nlongitude 0\ntime_zone 0\n2 29 0.25 0 0\n3 1 0.25 0 0\n";
        let (_d, p) = temp_file("l.wea", text);
        let w = read(&p).unwrap();
        assert_eq!(w.records[0].time, t("2020-02-29T00:15:00"));
        // 29 Feb 00:15 → 1 Mar 00:15 is one day.
        assert_eq!(w.interval_minutes, 24 * 60);
    }

    #[test]
    fn bad_rows_name_line_and_value() {
        let head = "place x\nlatitude 10\nlongitude 20\ntime_zone 15\nsite_elevation 0\nweather_data_file_units 1\n";
        for (row, value) in [
            ("1 1 12.5 NaN 10", "NaN"),
            ("1 1 12.5 100 -3", "-3"),
            ("13 1 12.5 100 10", "13"),
            ("1 1 24.5 100 10", "24.5"),
            ("1 1 12.5 100", "1 1 12.5 100"),
        ] {
            let text = format!("{head}1 1 11.5 0 0\n{row}\n");
            let (_d, p) = temp_file("b.wea", &text);
            let (shown, path, line, got) = input_parts(read(&p).unwrap_err());
            assert_eq!(
                (path, line, got.as_deref()),
                (p, Some(8), Some(value)),
                "{shown}"
            );
        }
        // Time running backwards.
        let (_d, p) = temp_file("b.wea", &format!("{head}1 1 11.5 0 0\n1 1 10.5 0 0\n"));
        let (_, _, line, _) = input_parts(read(&p).unwrap_err());
        assert_eq!(line, Some(8));
        // Units other than 1.
        let (_d, p) = temp_file("b.wea", &head.replace("units 1", "units 2"));
        let (_, _, line, value) = input_parts(read(&p).unwrap_err());
        assert_eq!((line, value.as_deref()), (Some(6), Some("2")));
        // Data before the header.
        let (_d, p) = temp_file("b.wea", "place x\n1 1 12.5 0 0\n");
        let (_, _, line, _) = input_parts(read(&p).unwrap_err());
        assert_eq!(line, Some(2));
    }
}
