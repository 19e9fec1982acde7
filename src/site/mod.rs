//! L1 where and when: the site, and the sun's position for an instant.

pub mod solar_position;

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
