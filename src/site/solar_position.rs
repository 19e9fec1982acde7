//! Solar position for an instant and site. PLACEHOLDER.

use super::Site;
use chrono::{DateTime, Utc};
use glam::DVec3;

/// The sun's apparent position seen from a site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolarPosition {
    /// Topocentric zenith angle including refraction, degrees.
    pub zenith_deg: f64,
    /// Azimuth, degrees clockwise from north (east = 90°).
    pub azimuth_deg: f64,
}

impl SolarPosition {
    /// Apparent altitude, degrees (90 − zenith).
    pub fn altitude_deg(&self) -> f64 {
        90.0 - self.zenith_deg
    }
    /// Unit vector to the sun, scene frame (x east, y north, z up).
    pub fn direction(&self) -> DVec3 {
        super::direction_from_alt_az(self.altitude_deg(), self.azimuth_deg)
    }
}

/// Apparent sun position at `instant` from `site` (standard atmosphere refraction).
pub fn solar_position(instant: DateTime<Utc>, site: &Site) -> SolarPosition {
    let _ = (instant, site);
    todo!()
}
