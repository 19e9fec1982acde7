//! L1 where and when: the site, and the sun's position for an instant.

pub mod solar_position;
mod spa_tables;

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// A site on the Earth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Site {
    /// Latitude, degrees, north positive.
    pub latitude: f64,
    /// Longitude, degrees, EAST positive (Radiance's `-o` is west positive).
    pub longitude: f64,
    /// Standard time zone of all local times, hours east of UTC (no daylight-saving time).
    pub utc_offset_h: f64,
    /// Elevation above sea level, metres.
    #[serde(default)]
    pub elevation_m: f64,
}

impl Default for Site {
    /// Greenwich at sea level, UTC.
    fn default() -> Self {
        Site {
            latitude: 51.4769,
            longitude: 0.0,
            utc_offset_h: 0.0,
            elevation_m: 0.0,
        }
    }
}

/// Unit direction towards a point of the sky given altitude and azimuth (degrees; azimuth
/// clockwise from north, i.e. east = 90°), in the scene frame (x east, y north, z up).
pub fn direction_from_alt_az(altitude_deg: f64, azimuth_deg: f64) -> DVec3 {
    let (alt, az) = (altitude_deg.to_radians(), azimuth_deg.to_radians());
    DVec3::new(alt.cos() * az.sin(), alt.cos() * az.cos(), alt.sin())
}

/// The instant in UTC of the local standard time `local` of a site `utc_offset_h` hours east
/// of Greenwich (no daylight-saving time), the offset truncated to whole seconds: the
/// instant a weather record's sun is evaluated at.
pub fn local_to_utc(
    local: chrono::NaiveDateTime,
    utc_offset_h: f64,
) -> chrono::DateTime<chrono::Utc> {
    (local - chrono::TimeDelta::seconds((utc_offset_h * 3600.0) as i64)).and_utc()
}

/// Parses an instant: local standard time of the site `YYYY-MM-DDTHH:MM[:SS]` (the site's
/// UTC offset applies; no daylight-saving time), or RFC 3339 with an explicit offset.
/// Returns the instant in UTC and the local standard date-time.
///
/// # Errors
/// [`crate::Error::Input`] naming the argument and the value.
pub fn parse_time(
    text: &str,
    utc_offset_h: f64,
) -> crate::Result<(chrono::DateTime<chrono::Utc>, chrono::NaiveDateTime)> {
    use chrono::{DateTime, NaiveDateTime, TimeDelta};
    let offset = TimeDelta::milliseconds((utc_offset_h * 3_600_000.0).round() as i64);
    if let Ok(t) = DateTime::parse_from_rfc3339(text) {
        let utc = t.with_timezone(&chrono::Utc);
        return Ok((utc, utc.naive_utc() + offset));
    }
    for fmt in [
        "%Y-%m-%dT%H:%M:%S",
        "%Y-%m-%dT%H:%M",
        "%Y-%m-%d %H:%M:%S",
        "%Y-%m-%d %H:%M",
    ] {
        if let Ok(local) = NaiveDateTime::parse_from_str(text, fmt) {
            return Ok(((local - offset).and_utc(), local));
        }
    }
    Err(crate::Error::arg(
        "--time",
        text,
        "expected local standard time YYYY-MM-DDTHH:MM[:SS] or RFC 3339 with an offset",
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use chrono::{Datelike, Timelike};

    #[test]
    fn local_and_rfc3339_times() {
        let (utc, local) = parse_time("2024-06-21T12:00", -5.0).unwrap();
        assert_eq!(utc.hour(), 17);
        assert_eq!(local.hour(), 12);
        let (utc, local) = parse_time("2024-06-21T12:00:00+02:00", -5.0).unwrap();
        assert_eq!(utc.hour(), 10);
        assert_eq!((local.day(), local.hour()), (21, 5));
        assert!(parse_time("21/06/2024", 0.0).is_err());
    }
}
