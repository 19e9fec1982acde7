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
use chrono::{DateTime, Datelike, NaiveDate, NaiveDateTime, Utc};
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
    /// Diffuse horizontal illuminance, lux, when the file gives one (EPW field 19; 999999
    /// or blank is missing): EN 17037's daylight hours are ranked by it.
    pub diffuse_illuminance_lux: Option<f64>,
    /// True when DNI or DHI was missing in the file (both are then reported as given or 0).
    pub missing: bool,
}

impl Weather {
    /// Number of records flagged [`WeatherRecord::missing`].
    pub fn missing_count(&self) -> usize {
        self.records.iter().filter(|r| r.missing).count()
    }

    /// The sunniest usable record at `site`: the one with the largest global horizontal
    /// irradiance (W/m²), DNI × sin(solar altitude) + DHI, the beam counting only while the
    /// sun is above the horizon. Missing records are skipped; of equal records the last
    /// wins. `None` when every record is missing or there are none.
    ///
    /// The solar position is taken at [`WeatherRecord::utc`], as in an annual run, so this
    /// is the step of such a run with the most daylight on a horizontal plane.
    pub fn sunniest_record(&self, site: &Site) -> Option<&WeatherRecord> {
        self.records
            .iter()
            .filter(|r| !r.missing)
            .map(|r| {
                let sun = crate::site::solar_position::solar_position(r.utc(site), site);
                let beam = r.dni * sun.altitude_deg().to_radians().sin().max(0.0);
                (beam + r.dhi, r)
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, r)| r)
    }

    /// A warning when the file's site is more than 0.1° (latitude or longitude) from
    /// `site`, the one a run uses; `None` when they agree.
    ///
    /// `sequence::annual::run_annual` adds it to its report's warnings.
    pub fn site_mismatch_warning(&self, site: &Site) -> Option<String> {
        let ws = &self.site;
        ((ws.latitude - site.latitude).abs() > 0.1 || (ws.longitude - site.longitude).abs() > 0.1)
            .then(|| {
                format!(
                    "the weather file's site ({:.2}°, {:.2}°) differs from the scene file's ({:.2}°, {:.2}°) by more than 0.1°: using the scene file's",
                    ws.latitude, ws.longitude, site.latitude, site.longitude
                )
            })
    }

    /// `date`'s month and day in the calendar year the file's times are built in (the
    /// first record's year; [`REFERENCE_YEAR`] for a file without records), so a date
    /// range given in any year selects the same days of a typical year. A day that year
    /// lacks (29 February of a common year) is returned unchanged.
    pub fn same_day_in_file_year(&self, date: NaiveDate) -> NaiveDate {
        let year = self
            .records
            .first()
            .map_or(REFERENCE_YEAR, |r| r.time.year());
        NaiveDate::from_ymd_opt(year, date.month(), date.day()).unwrap_or(date)
    }
}

impl WeatherRecord {
    /// The instant of [`WeatherRecord::time`] in UTC at `site` (its standard-time offset,
    /// truncated to whole seconds), the instant an annual run evaluates the sun at.
    pub fn utc(&self, site: &Site) -> DateTime<Utc> {
        crate::site::local_to_utc(self.time, site.utc_offset_h)
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

    /// A record at `time` (local standard time) with the given irradiances.
    fn record(line: usize, time: &str, dni: f64, dhi: f64, missing: bool) -> WeatherRecord {
        let time = NaiveDateTime::parse_from_str(time, "%Y-%m-%dT%H:%M").unwrap();
        WeatherRecord {
            line,
            month: time.month(),
            day: time.day(),
            year: time.year(),
            time,
            dni,
            dhi,
            dew_point_c: None,
            diffuse_illuminance_lux: None,
            missing,
        }
    }

    fn weather(site: Site, records: Vec<WeatherRecord>) -> Weather {
        Weather {
            site,
            records,
            path: PathBuf::from("<test>"),
            format: WeatherFormat::Epw,
            warnings: vec![],
            interval_minutes: 60,
        }
    }

    #[test]
    fn sunniest_record_has_the_largest_global_horizontal_irradiance() {
        // On the equator at the equinox the sun culminates near the zenith and stands about
        // 15° high at 07:00 solar time, so the beam on the horizontal is ≈ DNI at noon and
        // ≈ 0.26 DNI at 07:00, and nothing at midnight.
        let site = Site {
            latitude: 0.0,
            longitude: 0.0,
            utc_offset_h: 0.0,
            elevation_m: 0.0,
        };
        let noon = record(1, "2021-03-20T12:00", 600.0, 0.0, false); // ≈ 600 W/m²
        let early = record(2, "2021-03-20T07:00", 1000.0, 0.0, false); // ≈ 260 W/m²
        let night = record(3, "2021-03-20T00:00", 3000.0, 0.0, false); // sun below: 0
        let missing = record(4, "2021-03-21T12:00", 0.0, 5000.0, true); // skipped
        let diffuse = record(5, "2021-03-21T09:00", 0.0, 650.0, false); // 650 W/m²
        let all = vec![noon, early, night, missing, diffuse];
        let w = weather(site, all.clone());
        assert_eq!(w.sunniest_record(&site).map(|r| r.line), Some(5));
        // Without the overcast record the noon beam wins, not the larger low-sun DNI.
        let w = weather(site, all[..4].to_vec());
        assert_eq!(w.sunniest_record(&site).map(|r| r.line), Some(1));
        // Only missing records: nothing usable.
        let w = weather(site, vec![all[3].clone()]);
        assert_eq!(w.sunniest_record(&site), None);
    }

    #[test]
    fn record_utc_subtracts_the_standard_time_offset() {
        let site = Site {
            utc_offset_h: 5.5,
            ..Site::default()
        };
        let r = record(1, "2021-06-21T12:00", 0.0, 0.0, false);
        assert_eq!(r.utc(&site).naive_utc().to_string(), "2021-06-21 06:30:00");
    }

    #[test]
    fn site_mismatch_beyond_a_tenth_of_a_degree_warns() {
        let file_site = Site {
            latitude: 10.0,
            longitude: 20.0,
            ..Site::default()
        };
        let w = weather(file_site, vec![]);
        let near = Site {
            latitude: 10.09,
            longitude: 19.91,
            ..file_site
        };
        assert_eq!(w.site_mismatch_warning(&near), None);
        for far in [
            Site {
                latitude: 10.2,
                ..file_site
            },
            Site {
                longitude: 19.8,
                ..file_site
            },
        ] {
            let text = w.site_mismatch_warning(&far).expect("a warning");
            assert!(text.contains("(10.00°, 20.00°)"), "{text}");
            let scene = format!("({:.2}°, {:.2}°)", far.latitude, far.longitude);
            assert!(text.contains(&scene), "{text}");
        }
    }

    #[test]
    fn dates_move_into_the_file_year() {
        let date = |s: &str| NaiveDate::parse_from_str(s, "%Y-%m-%d").unwrap();
        let leap = weather(
            Site::default(),
            vec![record(1, "2020-01-01T00:30", 0.0, 0.0, false)],
        );
        assert_eq!(
            leap.same_day_in_file_year(date("2024-02-29")),
            date("2020-02-29")
        );
        assert_eq!(
            leap.same_day_in_file_year(date("1999-07-04")),
            date("2020-07-04")
        );
        // A common year lacks 29 February: the date is kept as given.
        let common = weather(
            Site::default(),
            vec![record(1, "2021-01-01T00:30", 0.0, 0.0, false)],
        );
        assert_eq!(
            common.same_day_in_file_year(date("2024-02-29")),
            date("2024-02-29")
        );
        let empty = weather(Site::default(), vec![]);
        assert_eq!(
            empty.same_day_in_file_year(date("2024-05-01")),
            NaiveDate::from_ymd_opt(REFERENCE_YEAR, 5, 1).unwrap()
        );
    }

    #[test]
    fn calendar_helpers() {
        assert_eq!(days_in_month(2, true), 29);
        assert_eq!(days_in_month(2, false), 28);
        assert_eq!(days_in_month(13, false), 0);
        assert!(is_leap(2000) && is_leap(2020) && !is_leap(1900) && !is_leap(2021));
    }
}
