//! L7 annual (climate-based) daylight metrics, computed as honeybee-radiance-postprocess
//! 0.5.25 computes them, so results are comparable with Ladybug Tools studies:
//!
//! - the occupied period is every day, steps whose start lies in the hours 8:00 … 17:xx
//!   (`occupancy_end_hour` 17 inclusive: 10 h/day, 3650 h/year), local standard time;
//! - percentages divide by ALL occupied steps, sun-down ones included: an occupied step with
//!   the sun down fails DA and cDA and counts in UDI-below, whatever illuminance it holds;
//! - DA counts E ≥ threshold, UDI-within 100 ≤ E ≤ 3000 (both inclusive), UDI-above
//!   E > 3000 (strict), UDI-below E < 100 plus the occupied sun-down steps;
//! - ASE counts occupied sun-up steps whose direct-sun illuminance is > 1000 lx (strict),
//!   times the step length in hours; a sensor fails when that is ≥ 250 h;
//! - sDA = % of sensors (or of area) with DA ≥ 50 %, ASE = % of sensors (or of area) failing.
//!
//! Illuminance is daylight only, lux; percentages are 0–100.

pub mod en17037;
pub mod leed;
pub mod leed_schedule;

use crate::error::{Error, Result};
use chrono::{NaiveDateTime, TimeDelta, Timelike};
use serde::{Deserialize, Serialize};

/// Thresholds and schedule of the annual metrics; defaults are honeybee's (IES LM-83).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricParams {
    /// First occupied hour (a step is occupied when its start's hour is within the range).
    pub occupancy_start_hour: u32,
    /// Last occupied hour, inclusive (17: steps starting 17:00 … 17:59 are occupied).
    pub occupancy_end_hour: u32,
    /// Daylight autonomy and continuous DA threshold, lux (DA counts E ≥ it).
    pub da_threshold_lux: f64,
    /// Lower bound of useful daylight illuminance, lux (inclusive).
    pub udi_min_lux: f64,
    /// Upper bound of useful daylight illuminance, lux (inclusive).
    pub udi_max_lux: f64,
    /// sDA temporal threshold as a fraction: a sensor passes when DA ≥ 100 × this %.
    pub sda_da_fraction: f64,
    /// ASE direct-sun illuminance threshold, lux (counts E_direct > it).
    pub ase_threshold_lux: f64,
    /// ASE hours: a sensor fails when its hours above the threshold are ≥ this.
    pub ase_hours: f64,
}

impl Default for MetricParams {
    fn default() -> Self {
        MetricParams {
            occupancy_start_hour: 8,
            occupancy_end_hour: 17,
            da_threshold_lux: 300.0,
            udi_min_lux: 100.0,
            udi_max_lux: 3000.0,
            sda_da_fraction: 0.5,
            ase_threshold_lux: 1000.0,
            ase_hours: 250.0,
        }
    }
}

impl MetricParams {
    /// Checks that the schedule and thresholds make sense.
    ///
    /// # Errors
    /// [`Error::Input`] naming the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        let p = self;
        if p.occupancy_start_hour > p.occupancy_end_hour || p.occupancy_end_hour > 23 {
            return Err(Error::arg(
                "occupancy hours",
                format!("{}–{}", p.occupancy_start_hour, p.occupancy_end_hour),
                "need 0 ≤ start ≤ end ≤ 23 (end inclusive)",
            ));
        }
        for (name, v) in [
            ("da_threshold_lux", p.da_threshold_lux),
            ("udi_min_lux", p.udi_min_lux),
            ("udi_max_lux", p.udi_max_lux),
            ("ase_threshold_lux", p.ase_threshold_lux),
            ("ase_hours", p.ase_hours),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::arg(name, v, "must be a finite number ≥ 0"));
            }
        }
        if p.da_threshold_lux == 0.0 {
            return Err(Error::arg(
                "da_threshold_lux",
                0,
                "must be > 0 (cDA divides by it)",
            ));
        }
        if p.udi_min_lux > p.udi_max_lux {
            return Err(Error::arg(
                "udi_min_lux",
                p.udi_min_lux,
                "must not exceed udi_max_lux",
            ));
        }
        if !(0.0..=1.0).contains(&p.sda_da_fraction) {
            return Err(Error::arg(
                "sda_da_fraction",
                p.sda_da_fraction,
                "must be a fraction within 0 … 1",
            ));
        }
        Ok(())
    }
}

/// True when the step evaluated at `time` (local standard time, at the middle of a step of
/// `step_minutes`) is occupied: its start, `time − step/2`, lies in an hour from
/// `occupancy_start_hour` to `occupancy_end_hour` inclusive. An hourly step evaluated at
/// 12:30 starts at 12:00; with the defaults 8:30 … 17:30 are occupied, 7:30 and 18:30 not.
pub fn is_occupied(time: NaiveDateTime, step_minutes: u32, params: &MetricParams) -> bool {
    // Half a step in seconds: a 15-minute step at 8:07:30 starts at 8:00.
    let start = time - TimeDelta::seconds(i64::from(step_minutes) * 30);
    (params.occupancy_start_hour..=params.occupancy_end_hour).contains(&start.hour())
}

/// Annual metrics of one sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SensorMetrics {
    /// Daylight autonomy: % of occupied hours with E ≥ the DA threshold.
    pub da: f64,
    /// Continuous daylight autonomy: occupied-hour mean of min(1, E/threshold), %.
    pub cda: f64,
    /// % of occupied hours with E < the UDI minimum, occupied sun-down hours included.
    pub udi_below: f64,
    /// % of occupied hours with UDI minimum ≤ E ≤ UDI maximum.
    pub udi_within: f64,
    /// % of occupied hours with E > the UDI maximum.
    pub udi_above: f64,
    /// Occupied sun-up hours with direct-sun illuminance > the ASE threshold, hours.
    pub ase_hours: f64,
    /// Mean illuminance over all occupied hours, lux, sun-down hours counting as 0 lx.
    pub mean_lux: f64,
    /// Occupied hours the percentages divide by (sun-up and sun-down), hours.
    pub occupied_hours: f64,
}

/// The metrics of one sensor from its time series (one entry per step, all the same length):
/// total and direct-sun-only illuminance (lux), whether the step is occupied and whether the
/// sun is up, and the step length in hours. Illuminance at sun-down steps is ignored (the
/// step counts as dark, as honeybee never simulates it). With no occupied steps every
/// metric is 0.
///
/// # Panics
/// When the four slices differ in length (a caller bug).
pub fn sensor_metrics(
    total_lux: &[f64],
    direct_sun_lux: &[f64],
    occupied: &[bool],
    sun_up: &[bool],
    hours_per_step: f64,
    params: &MetricParams,
) -> SensorMetrics {
    let n = total_lux.len();
    assert!(
        direct_sun_lux.len() == n && occupied.len() == n && sun_up.len() == n,
        "sensor_metrics: series lengths differ ({n}, {}, {}, {})",
        direct_sun_lux.len(),
        occupied.len(),
        sun_up.len()
    );
    let mut acc = SensorAccumulator::default();
    for i in 0..n {
        acc.add(
            total_lux[i],
            direct_sun_lux[i],
            occupied[i],
            sun_up[i],
            params,
        );
    }
    acc.finish(hours_per_step)
}

/// [`sensor_metrics`] one step at a time: the counts and sums of one sensor's series,
/// taken in time order (so the sums are the same to the bit), without holding the series.
#[derive(Clone, Copy, Debug, Default)]
pub struct SensorAccumulator {
    occ: usize,
    dark: usize,
    da: usize,
    below: usize,
    within: usize,
    above: usize,
    ase: usize,
    cda: f64,
    sum: f64,
}

impl SensorAccumulator {
    /// Adds one step: total and direct-sun illuminance (lux), whether it is occupied and
    /// whether the sun is up.
    pub fn add(
        &mut self,
        total_lux: f64,
        direct_sun_lux: f64,
        occupied: bool,
        sun_up: bool,
        p: &MetricParams,
    ) {
        if !occupied {
            return;
        }
        self.occ += 1;
        if !sun_up {
            self.dark += 1;
            return;
        }
        let e = total_lux;
        self.sum += e;
        self.da += usize::from(e >= p.da_threshold_lux);
        self.cda += if e >= p.da_threshold_lux {
            1.0
        } else {
            e / p.da_threshold_lux
        };
        self.below += usize::from(e < p.udi_min_lux);
        self.within += usize::from(e >= p.udi_min_lux && e <= p.udi_max_lux);
        self.above += usize::from(e > p.udi_max_lux);
        self.ase += usize::from(direct_sun_lux > p.ase_threshold_lux);
    }

    /// The metrics of the steps added, each `hours_per_step` long.
    pub fn finish(&self, hours_per_step: f64) -> SensorMetrics {
        let occ = self.occ;
        let pct = |count: f64| {
            if occ == 0 {
                0.0
            } else {
                100.0 * count / occ as f64
            }
        };
        SensorMetrics {
            da: pct(self.da as f64),
            cda: pct(self.cda),
            udi_below: pct((self.below + self.dark) as f64),
            udi_within: pct(self.within as f64),
            udi_above: pct(self.above as f64),
            ase_hours: self.ase as f64 * hours_per_step,
            mean_lux: if occ == 0 { 0.0 } else { self.sum / occ as f64 },
            occupied_hours: occ as f64 * hours_per_step,
        }
    }
}

/// Space-wide summary of the per-sensor metrics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Spatial daylight autonomy: % of sensors (or of area) with DA ≥ 100 × sda_da_fraction %.
    pub sda_percent: f64,
    /// Annual sunlight exposure: % of sensors (or of area) with ase_hours ≥ the ASE hours.
    pub ase_percent: f64,
    /// Mean DA over sensors (area-weighted when weights are given), %.
    pub mean_da: f64,
    /// Mean cDA, %.
    pub mean_cda: f64,
    /// Mean UDI-below, %.
    pub mean_udi_below: f64,
    /// Mean UDI-within, %.
    pub mean_udi_within: f64,
    /// Mean UDI-above, %.
    pub mean_udi_above: f64,
    /// Mean ASE hours, hours.
    pub mean_ase_hours: f64,
    /// Mean of the sensors' occupied-hour mean illuminance, lux.
    pub mean_lux: f64,
    /// Number of sensors.
    pub sensors: usize,
    /// Occupied hours of the schedule (the same for every sensor), hours.
    pub occupied_hours: f64,
    /// True when the means and percentages are weighted by sensor area.
    pub area_weighted: bool,
}

/// Tolerance on the sDA comparison: 100 × 0.55 is 55.000000000000007 in floating point, and a
/// DA of exactly 55 % must pass.
const SDA_EPS: f64 = 1e-9;

/// Summarises per-sensor metrics; `area_weights` (one per sensor, m² or any unit) weight the
/// percentages and means as honeybee's LEED summary does. No sensors → all zero.
///
/// # Errors
/// [`Error::Input`] for negative or non-finite weights or weights summing to 0;
/// [`Error::Internal`] when the weights' count differs from the sensors' or the sensors'
/// occupied hours differ (they come from one schedule).
pub fn summary(
    per_sensor: &[SensorMetrics],
    area_weights: Option<&[f64]>,
    params: &MetricParams,
) -> Result<Summary> {
    let n = per_sensor.len();
    let ones = vec![1.0; n];
    let w = match area_weights {
        Some(w) if w.len() != n => {
            return Err(Error::Internal(format!(
                "{} area weights for {n} sensors",
                w.len()
            )))
        }
        Some(w) => {
            if let Some(bad) = w.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                return Err(Error::arg(
                    "sensor area weights",
                    bad,
                    "must be finite and ≥ 0",
                ));
            }
            if n > 0 && w.iter().sum::<f64>() <= 0.0 {
                return Err(Error::arg("sensor area weights", 0, "must not all be 0"));
            }
            w
        }
        None => &ones[..],
    };
    let occupied_hours = per_sensor.first().map_or(0.0, |s| s.occupied_hours);
    if let Some(s) = per_sensor
        .iter()
        .find(|s| s.occupied_hours != occupied_hours)
    {
        return Err(Error::Internal(format!(
            "sensors with different occupied hours ({occupied_hours} and {})",
            s.occupied_hours
        )));
    }
    let total: f64 = w.iter().sum();
    let mean = |f: &dyn Fn(&SensorMetrics) -> f64| {
        if n == 0 {
            0.0
        } else {
            per_sensor.iter().zip(w).map(|(s, w)| w * f(s)).sum::<f64>() / total
        }
    };
    let da_pass = 100.0 * params.sda_da_fraction - SDA_EPS;
    Ok(Summary {
        sda_percent: mean(&|s| if s.da >= da_pass { 100.0 } else { 0.0 }),
        ase_percent: mean(&|s| {
            if s.ase_hours >= params.ase_hours {
                100.0
            } else {
                0.0
            }
        }),
        mean_da: mean(&|s| s.da),
        mean_cda: mean(&|s| s.cda),
        mean_udi_below: mean(&|s| s.udi_below),
        mean_udi_within: mean(&|s| s.udi_within),
        mean_udi_above: mean(&|s| s.udi_above),
        mean_ase_hours: mean(&|s| s.ase_hours),
        mean_lux: mean(&|s| s.mean_lux),
        sensors: n,
        occupied_hours,
        area_weighted: area_weights.is_some(),
    })
}

/// Daylight factor, %: 100 × indoor illuminance / unobstructed outdoor horizontal
/// illuminance (both lux, under a CIE overcast sky). NaN when the outdoor value is not > 0.
pub fn daylight_factor(indoor_lux: f64, outdoor_horizontal_lux: f64) -> f64 {
    if outdoor_horizontal_lux > 0.0 {
        100.0 * indoor_lux / outdoor_horizontal_lux
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests;
