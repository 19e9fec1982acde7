//! The sensors' direct sun of a step summed by daylight coefficients ([`super::Engine`]):
//! read from the snapped sun's cached sensor responses, with τ at the true angle.

use super::super::directions::Directions;
use super::Engine;
use crate::sources::{Source, SourceKey};

impl Engine<'_> {
    /// Each sensor's direct sun (lux) from the sun among `sources` (none: zeros), through
    /// `dirs`' cached sensor responses of its snapped cell, τ at the true angle.
    pub(super) fn sun_lux(&self, dirs: &Directions, sources: &[Source]) -> Vec<f64> {
        let k = self.scene.sensors.len();
        let Some(src) = sources.iter().find(|s| matches!(s.key, SourceKey::Sun(_))) else {
            return vec![0.0; k];
        };
        let res = dirs.quality().projection.resolution_for(true);
        // The sensors' section only: the projection is not read.
        let d = dirs.sensor_responses(src, res);
        (0..k)
            .map(|i| {
                let cos = self.scene.sensors[i].normal.dot(src.true_direction);
                if cos > 0.0 {
                    crate::photometry::lux(
                        src.normal_irradiance * dirs.sun_transmission(i, src, &d[i]),
                    ) * cos
                } else {
                    0.0
                }
            })
            .collect()
    }
}
