//! L1 weather: EnergyPlus EPW and Radiance/DAYSIM WEA files read into one record type.
//!
//! Conventions (the same as the rest of daystep, whatever the file's own convention):
//! - the site's longitude is EAST positive and its time zone a UTC offset in hours (EPW
//!   already uses both; WEA's west-positive longitude and standard meridian are converted);
//! - every record carries `time`, the local standard time (no daylight-saving time) at which
//!   the sun is to be evaluated for it: the middle of an EPW record's interval (EPW records
//!   are interval-ENDING), a WEA row's decimal hour as written (WEA rows already give the
//!   evaluation time);
//! - irradiance in W/m²: direct normal (DNI) and diffuse horizontal (DHI);
//! - a missing irradiance value becomes 0 with `missing = true`, and the file gets one
//!   warning naming the first such line and the count, so a run can skip and report them.
//!
//! Years: typical-year files (TMY) mix records from different years, so a record's year is
//! kept in [`WeatherRecord::year`] but `time` is built in one calendar year: the fixed
//! non-leap reference year [`REFERENCE_YEAR`] (2021) when the file has no 29 February, and
//! the leap year of its 29 February records when it has one (see [`epw`] and [`wea`]).

pub mod epw;
mod epw_header;
pub mod resample;
pub mod wea;

pub use resample::resample;

use crate::error::{Error, Result};
use crate::site::Site;
use chrono::NaiveDateTime;
use std::path::{Path, PathBuf};

/// Non-leap calendar year in which `time` is built for files without 29 February, so a
/// typical year (records from many years) becomes one monotonic series.
pub const REFERENCE_YEAR: i32 = 2021;

/// Leap year in which `time` is built for WEA files that hold 29 February (WEA rows carry no
/// year).
pub const LEAP_REFERENCE_YEAR: i32 = 2020;

/// Which file format a [`Weather`] was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum WeatherFormat {
    /// EnergyPlus weather file (`.epw`).
    Epw,
    /// Radiance `gendaymtx` / DAYSIM weather file (`.wea`).
    Wea,
}

/// A weather file: the site from its header and one record per timestep.
#[derive(Clone, Debug, PartialEq)]
pub struct Weather {
    /// Site from the file header (longitude east positive, UTC offset in hours).
    pub site: Site,
    /// Records in file order (which is time order: the readers check it).
    pub records: Vec<WeatherRecord>,
    /// The file read.
    pub path: PathBuf,
    /// The format it was read as.
    pub format: WeatherFormat,
    /// Things a user should know that did not stop the read (missing values, mixed years).
    pub warnings: Vec<String>,
    /// Length of one record's interval, minutes (60 for hourly files).
    pub interval_minutes: u32,
}

/// One timestep of a weather file.
#[derive(Clone, Debug, PartialEq)]
pub struct WeatherRecord {
    /// 1-based line of the file this record came from.
    pub line: usize,
    /// Month 1–12 as written.
    pub month: u32,
    /// Day of month as written.
    pub day: u32,
    /// Year as written (EPW), or the year `time` is built in (WEA, which has none).
    pub year: i32,
    /// Local standard time at which the sun is evaluated for this record (see the module
    /// doc for the year it is built in).
    pub time: NaiveDateTime,
    /// Direct normal irradiance, W/m² (0 when missing).
    pub dni: f64,
    /// Diffuse horizontal irradiance, W/m² (0 when missing).
    pub dhi: f64,
    /// Dew-point temperature, °C, when the file gives one.
    pub dew_point_c: Option<f64>,
    /// True when DNI or DHI was missing in the file (both are then reported as given or 0).
    pub missing: bool,
}

impl Weather {
    /// Number of records flagged [`WeatherRecord::missing`].
    pub fn missing_count(&self) -> usize {
        self.records.iter().filter(|r| r.missing).count()
    }
}

/// Reads an EPW or WEA file: by extension (`.epw`, `.wea`, any case), otherwise by content
/// (an EPW starts with `LOCATION,`, a WEA with `place` or another WEA header keyword).
///
/// # Errors
/// [`Error::Input`] naming the file, 1-based line and offending value for any bad field,
/// a truncated file or a file that is neither format; [`Error::Io`] when it cannot be read.
pub fn read_weather(path: &Path) -> Result<Weather> {
    let text = crate::files::read_text(path)?;
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("epw") => epw::parse(path, &text),
        Some("wea") => wea::parse(path, &text),
        _ => match sniff(&text) {
            Some(WeatherFormat::Epw) => epw::parse(path, &text),
            Some(WeatherFormat::Wea) => wea::parse(path, &text),
            None => Err(Error::input(
                path,
                Some(1),
                text.lines().next().map(|l| l.trim()),
                "not a weather file: an EPW starts with `LOCATION,`, a WEA with `place <name>`",
            )),
        },
    }
}

/// Guesses the format from the first non-blank line.
fn sniff(text: &str) -> Option<WeatherFormat> {
    let first = text.lines().find(|l| !l.trim().is_empty())?.trim_start();
    if first.to_ascii_uppercase().starts_with("LOCATION,") {
        Some(WeatherFormat::Epw)
    } else {
        let word = first.split_whitespace().next()?;
        wea::HEADER_KEYS
            .contains(&word)
            .then_some(WeatherFormat::Wea)
    }
}

/// Days in `month` (1–12) of a leap (`leap = true`) or common year; 0 for a bad month.
pub(crate) fn days_in_month(month: u32, leap: bool) -> u32 {
    match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if leap => 29,
        2 => 28,
        _ => 0,
    }
}

/// True for a Gregorian leap year.
pub(crate) fn is_leap(year: i32) -> bool {
    (year % 4 == 0 && year % 100 != 0) || year % 400 == 0
}

/// Test helper shared by the readers' tests: writes `text` to `name` in a new tempdir.
#[cfg(test)]
pub(crate) fn temp_file(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    (dir, p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_chosen_by_extension_then_content() {
        let epw = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw"),
        )
        .unwrap();
        // An EPW under a neutral name is recognised by its first line.
        let (_d, p) = temp_file("climate.txt", &epw);
        let w = read_weather(&p).unwrap();
        assert_eq!(w.format, WeatherFormat::Epw);
        assert_eq!(w.records.len(), 8760);

        let wea = "place X\nlatitude 10\nlongitude 20\ntime_zone 15\nsite_elevation 0\n\
                   weather_data_file_units 1\n1 1 12.5 100 50\n";
        let (_d, p) = temp_file("climate.dat", wea);
        assert_eq!(read_weather(&p).unwrap().format, WeatherFormat::Wea);

        // Neither format: the error names line 1 and its text.
        let (_d, p) = temp_file("climate.dat", "hello,world\n");
        let (shown, path, line, value) = crate::error::input_parts(read_weather(&p).unwrap_err());
        assert_eq!(
            (path, line, value.as_deref()),
            (p, Some(1), Some("hello,world"))
        );
        assert!(shown.contains("not a weather file"), "{shown}");
    }

    #[test]
    fn calendar_helpers() {
        assert_eq!(days_in_month(2, true), 29);
        assert_eq!(days_in_month(2, false), 28);
        assert_eq!(days_in_month(13, false), 0);
        assert!(is_leap(2000) && is_leap(2020) && !is_leap(1900) && !is_leap(2021));
    }
}
