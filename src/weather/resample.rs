//! Sub-hourly timesteps from a coarser weather file, by linear interpolation in time.
//!
//! Each record stands for an interval of `interval_minutes` centred on its evaluation time
//! (`time`, already mid-interval for EPW). A step of `step` minutes splits every interval
//! into `interval / step` sub-intervals; each sub-step is evaluated at its own centre, and
//! its DNI, DHI and dew point are interpolated linearly between the two records whose
//! times bracket it. Outside the first and last record's times, and across gaps in the
//! file longer than one interval, the nearest record's values are held. A sub-step is
//! `missing` when a record it draws on is.
//!
//! Linear interpolation keeps each hour's mean only where the irradiance is itself linear
//! over the two hours; around sunrise and sunset, and under broken cloud, it is a smoothing
//! of the file, not new information, which is why runs say so in their report.

use super::{Weather, WeatherRecord};
use crate::error::{Error, Result};
use chrono::{Datelike, TimeDelta};

/// `weather` at `step`-minute steps: the same file when `step` equals its interval,
/// interpolated when `step` divides it.
///
/// # Errors
/// An input error naming `--step` ([`Error::arg`]) when `step` is 0, longer than the interval or
/// does not divide it.
pub fn resample(weather: &Weather, step: u32) -> Result<Weather> {
    let interval = weather.interval_minutes;
    if step == interval {
        return Ok(weather.clone());
    }
    if step == 0 || step > interval || interval % step != 0 {
        return Err(Error::arg(
            "--step",
            step,
            format!(
                "must divide the weather file's interval ({interval} min): for example {}",
                divisors(interval)
            ),
        ));
    }
    let parts = interval / step;
    let half = TimeDelta::seconds(i64::from(interval) * 30);
    let recs = &weather.records;
    let mut out = Vec::with_capacity(recs.len() * parts as usize);
    for (i, r) in recs.iter().enumerate() {
        for j in 0..parts {
            let t = r.time - half + TimeDelta::seconds(i64::from(step) * (60 * i64::from(j) + 30));
            // Bracketing records: this one and its neighbour on t's side.
            let other = if t < r.time {
                i.checked_sub(1).map(|k| &recs[k])
            } else {
                recs.get(i + 1)
            };
            let other = other.filter(|o| (o.time - r.time).abs() <= half * 2);
            let rec = match other {
                Some(o) if o.time != r.time => {
                    let f = (t - r.time).num_milliseconds() as f64
                        / (o.time - r.time).num_milliseconds() as f64;
                    let lerp = |a: f64, b: f64| a + (b - a) * f;
                    WeatherRecord {
                        line: if f < 0.5 { r.line } else { o.line },
                        month: t.month(),
                        day: t.day(),
                        year: r.year,
                        time: t,
                        dni: lerp(r.dni, o.dni),
                        dhi: lerp(r.dhi, o.dhi),
                        dew_point_c: r.dew_point_c.zip(o.dew_point_c).map(|(a, b)| lerp(a, b)),
                        diffuse_illuminance_lux: r
                            .diffuse_illuminance_lux
                            .zip(o.diffuse_illuminance_lux)
                            .map(|(a, b)| lerp(a, b)),
                        missing: r.missing || o.missing,
                    }
                }
                _ => WeatherRecord {
                    month: t.month(),
                    day: t.day(),
                    time: t,
                    ..r.clone()
                },
            };
            out.push(rec);
        }
    }
    let mut w = weather.clone();
    w.records = out;
    w.interval_minutes = step;
    w.warnings.push(format!(
        "{step}-minute steps interpolated linearly from the file's {interval}-minute records"
    ));
    Ok(w)
}

/// A few valid steps for an interval, for the error message.
fn divisors(interval: u32) -> String {
    let d: Vec<String> = (1..=interval)
        .filter(|s| interval % s == 0 && *s >= 5)
        .map(|s| s.to_string())
        .collect();
    d.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::weather::{temp_file, wea};

    fn hourly() -> Weather {
        // 11:30, 12:30, 13:30 on 21 June; the middle one missing.
        let text = "place X\nlatitude 40\nlongitude 0\ntime_zone 0\nsite_elevation 0\n\
                    weather_data_file_units 1\n6 21 11.5 600 100\n6 21 12.5 800 200\n\
                    6 21 13.5 400 120\n";
        let (_d, p) = temp_file("h.wea", text);
        wea::read(&p).unwrap()
    }

    #[test]
    fn quarter_hours_interpolate_between_record_times() {
        let w = hourly();
        let q = resample(&w, 15).unwrap();
        assert_eq!(q.records.len(), 12);
        assert_eq!(q.interval_minutes, 15);
        let times: Vec<String> = q.records[4..8]
            .iter()
            .map(|r| r.time.format("%H:%M:%S").to_string())
            .collect();
        // The 12:30 record's hour, 12:00–13:00, split at its quarter-hour centres.
        assert_eq!(times, ["12:07:30", "12:22:30", "12:37:30", "12:52:30"]);
        // 12:07:30 lies 22.5/60 of the way from 12:30 back to 11:30.
        let f = 22.5 / 60.0;
        assert!((q.records[4].dni - (800.0 + (600.0 - 800.0) * f)).abs() < 1e-9);
        assert!((q.records[4].dhi - (200.0 + (100.0 - 200.0) * f)).abs() < 1e-9);
        // 12:52:30 lies 22.5/60 of the way towards 13:30.
        assert!((q.records[7].dni - (800.0 + (400.0 - 800.0) * f)).abs() < 1e-9);
        // Before the first record's time and after the last, the value is held.
        assert_eq!(q.records[0].dni, 600.0);
        assert_eq!(q.records[11].dni, 400.0);
        assert!(q.warnings.iter().any(|m| m.contains("interpolated")));
    }

    #[test]
    fn missing_records_spread_to_the_steps_that_use_them() {
        let mut w = hourly();
        w.records[1].missing = true;
        let q = resample(&w, 30).unwrap();
        let missing: Vec<bool> = q.records.iter().map(|r| r.missing).collect();
        // Every sub-step from 11:45 to 13:15 draws on the 12:30 record.
        assert_eq!(missing, [false, true, true, true, true, false]);
    }

    #[test]
    fn steps_that_do_not_divide_the_interval_are_refused() {
        let w = hourly();
        assert!(resample(&w, 60).unwrap() == w);
        for bad in [0, 7, 90] {
            let e = resample(&w, bad).unwrap_err().to_string();
            assert!(e.contains("--step") && e.contains("divide"), "{e}");
        }
    }
}
