//! The sensors' direct sun of a step summed by daylight coefficients ([`super::Engine`]):
//! read from the snapped sun's cached sensor responses, with τ at the true angle.

use super::super::directions::Directions;
use super::Engine;
use crate::sensors::NodeResponse;
use crate::sources::{Source, SourceKey};

impl Engine<'_> {
    /// Each sensor's direct sun (lux) in each of several steps' `cuts` (a day's) from the
    /// sun among its sources (none: zeros), through `dirs`' sensor responses of its
    /// snapped cell, read for all the steps as one record
    /// ([`Directions::day_sun_responses`]), τ at the true angle.
    pub(super) fn sun_lux_many(&self, dirs: &Directions, cuts: &[&[Source]]) -> Vec<Vec<f64>> {
        let suns: Vec<Option<&Source>> = cuts
            .iter()
            .map(|c| c.iter().find(|s| matches!(s.key, SourceKey::Sun(_))))
            .collect();
        let present: Vec<&Source> = suns.iter().flatten().copied().collect();
        let res = dirs.quality().projection.resolution_for(true);
        // The sensors' sections only: the projections are not read.
        let mut responses = dirs.day_sun_responses(&present, res).into_iter();
        suns.iter()
            .map(|s| match s {
                Some(src) => self.lux(dirs, src, &responses.next().expect("a sun's responses")),
                None => vec![0.0; self.scene.sensors.len()],
            })
            .collect()
    }

    /// Each sensor's direct sun (lux) from `src`, given its responses `d`.
    fn lux(&self, dirs: &Directions, src: &Source, d: &[NodeResponse]) -> Vec<f64> {
        (0..self.scene.sensors.len())
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
