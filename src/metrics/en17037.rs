//! EN 17037 daylight provision (method 2, climate-based), per grid and over all grids, at
//! the three levels minimum, medium and high.
//!
//! Follows honeybee-radiance-postprocess 0.5.25 (`en17037.py`: `en17037_compute`,
//! `en17037_to_folder`, `_write_en17037_summary`; `metrics.py`: `da_array2d`) and, for the
//! daylight hours, honeybee-radiance 1.66.299 (`cli/schedule.py`,
//! `epw_to_daylight_hours`) with ladybug-core's `highest_values`; read for this port, the
//! code is daystep's own:
//!
//! - the period is the **daylight hours**: the 4380 hours of the year (half of it) with the
//!   largest diffuse horizontal illuminance of the weather file ([`daylight_hours`]); the
//!   schedule must hold exactly 4380 steps, hourly (honeybee refuses any other count);
//! - a sensor meets an illuminance E_T when E ≥ E_T (inclusive, f32 as the matrices) for at
//!   least half the daylight hours: count / 4380 × 100 ≥ 50, sun-down hours in the schedule
//!   counting as not met;
//! - the share of the space meeting it is % of sensors, or of sensor area when areas are
//!   given; the target illuminance must be met over ≥ 50 % of the space, the minimum
//!   illuminance over ≥ 95 %;
//! - levels: minimum 300 lx target / 100 lx minimum, medium 500 / 300, high 750 / 500;
//! - over several grids the share is the grids' shares weighted by their sensor count (or
//!   area, when every grid has areas).
//!
//! Data layout: hour-major, `total[step * sensors + sensor]`, f32 lux, over the sun-up
//! steps, the total over every light path with blinds open.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Steps of the daylight-hours schedule (half of 8760 hours).
pub const DAYLIGHT_HOURS: usize = 4380;
/// Share of the daylight hours an illuminance must be met for, % (≥).
pub const TIME_PCT: f64 = 50.0;
/// Share of the space the target illuminance must be met over, % (≥).
pub const TARGET_SPACE_PCT: f64 = 50.0;
/// Share of the space the minimum illuminance must be met over, % (≥).
pub const MINIMUM_SPACE_PCT: f64 = 95.0;
/// (level, target lux, minimum lux) of EN 17037's Table A.1.
pub const LEVELS: [(&str, f32, f32); 3] = [
    ("minimum", 300.0, 100.0),
    ("medium", 500.0, 300.0),
    ("high", 750.0, 500.0),
];

/// One level's result (`en17037.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Level {
    /// Target illuminance, lux.
    pub target_lux: f64,
    /// Share of the space meeting the target for half the daylight hours, %.
    pub target_area_pct: f64,
    /// True when that share is ≥ 50 %.
    pub target_pass: bool,
    /// Minimum illuminance, lux.
    pub minimum_lux: f64,
    /// Share of the space meeting the minimum for half the daylight hours, %.
    pub minimum_area_pct: f64,
    /// True when that share is ≥ 95 %.
    pub minimum_pass: bool,
}

/// The three levels.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Levels {
    /// Minimum level (300 / 100 lx).
    pub minimum: Level,
    /// Medium level (500 / 300 lx).
    pub medium: Level,
    /// High level (750 / 500 lx).
    pub high: Level,
}

/// One grid's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridResult {
    /// Grid name.
    pub name: String,
    /// Sensor count, or floor area when the grid has areas.
    pub total_weight: f64,
    /// The levels.
    #[serde(flatten)]
    pub levels: Levels,
}

/// All grids (`en17037.json`): the levels over all grids, and per grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct En17037Result {
    /// The levels over all grids.
    #[serde(flatten)]
    pub levels: Levels,
    /// True when the shares are weighted by sensor area (every grid has areas).
    pub area_weighted: bool,
    /// Per grid.
    pub grids: Vec<GridResult>,
}

/// One grid's input.
#[derive(Clone, Copy, Debug)]
pub struct En17037Grid<'a> {
    /// Grid name.
    pub name: &'a str,
    /// Number of sensors (≥ 1).
    pub sensors: usize,
    /// Area of each sensor's cell, when known.
    pub areas: Option<&'a [f64]>,
    /// Total illuminance, blinds open, lux, `[step * sensors + sensor]` over sun-up steps.
    pub total: &'a [f32],
}

/// The daylight hours of a year: the [`DAYLIGHT_HOURS`] hours with the largest diffuse
/// horizontal illuminance (lux, or irradiance: only the order matters), ties to the earlier
/// hour (Python's stable sort, as ladybug's `highest_values`). One flag per hour.
///
/// # Errors
/// [`Error::Input`] unless there are 8760 finite values.
pub fn daylight_hours(diffuse_horizontal: &[f64]) -> Result<Vec<bool>> {
    if diffuse_horizontal.len() != 8760 {
        return Err(Error::arg(
            "diffuse horizontal series",
            diffuse_horizontal.len(),
            "the daylight hours need one value per hour of a year (8760)",
        ));
    }
    if let Some(x) = diffuse_horizontal.iter().find(|x| !x.is_finite()) {
        return Err(Error::arg("diffuse horizontal series", x, "must be finite"));
    }
    let mut order: Vec<usize> = (0..8760).collect();
    // Stable: equal values keep their hour order, the earlier first.
    order.sort_by(|a, b| diffuse_horizontal[*b].total_cmp(&diffuse_horizontal[*a]));
    let mut flags = vec![false; 8760];
    for &h in &order[..DAYLIGHT_HOURS] {
        flags[h] = true;
    }
    Ok(flags)
}

/// Share (%) of the space where `pass`, and the weight: honeybee's `pass_mask.mean() × 100`
/// by count, `(area passing / area) × 100` by area.
fn space_pct(pass: &[bool], areas: Option<&[f64]>) -> (f64, f64) {
    let (yes, total) = super::leed::share(pass, areas);
    let pct = if total > 0.0 {
        yes / total * 100.0
    } else {
        0.0
    };
    (pct, total)
}

fn validate(grid: &En17037Grid, steps: usize) -> Result<()> {
    let what = format!("grid {}", grid.name);
    if grid.sensors == 0 {
        return Err(Error::arg(&what, 0, "has no sensors"));
    }
    if grid.total.len() != steps * grid.sensors {
        return Err(Error::arg(
            &format!("illuminance of {what}"),
            grid.total.len(),
            format!("needs steps × sensors = {} values", steps * grid.sensors),
        ));
    }
    if let Some(i) = grid.total.iter().position(|x| !x.is_finite()) {
        return Err(Error::arg(
            &format!("illuminance of {what}"),
            grid.total[i],
            format!("value {i} is not a finite illuminance"),
        ));
    }
    if let Some(a) = grid.areas {
        if a.len() != grid.sensors || a.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
            return Err(Error::arg(
                &format!("sensor areas of {what}"),
                a.len(),
                format!("need {} finite areas ≥ 0", grid.sensors),
            ));
        }
    }
    Ok(())
}

/// Per sensor: meets `lux` for at least half the daylight hours.
fn meets(grid: &En17037Grid, daylight: &[bool], lux: f32) -> Vec<bool> {
    let n = grid.sensors;
    let mut count = vec![0usize; n];
    for step in (0..daylight.len()).filter(|&s| daylight[s]) {
        let row = &grid.total[step * n..(step + 1) * n];
        for (c, e) in count.iter_mut().zip(row) {
            *c += usize::from(*e >= lux);
        }
    }
    count
        .iter()
        .map(|c| *c as f64 / DAYLIGHT_HOURS as f64 * 100.0 >= TIME_PCT)
        .collect()
}

/// EN 17037 daylight provision of the grids. `daylight` has one flag per sun-up step (in
/// the daylight hours or not); `daylight_steps` counts the schedule's steps over the whole
/// year, sun-down ones included, and must be [`DAYLIGHT_HOURS`].
///
/// # Errors
/// [`Error::Input`] for no grids, a grid without sensors, arrays of the wrong length or
/// with NaN or infinities, bad areas, or a schedule of other than 4380 steps.
pub fn en17037(
    grids: &[En17037Grid],
    daylight: &[bool],
    daylight_steps: usize,
) -> Result<En17037Result> {
    if grids.is_empty() {
        return Err(Error::arg(
            "EN 17037 grids",
            0,
            "needs at least one sensor grid",
        ));
    }
    if daylight_steps != DAYLIGHT_HOURS || daylight.iter().filter(|d| **d).count() > daylight_steps
    {
        return Err(Error::arg(
            "daylight hours",
            daylight_steps,
            "EN 17037 needs the 4380 hourly daylight hours (half the year with the most daylight)",
        ));
    }
    let area_weighted = grids.iter().all(|g| g.areas.is_some());
    let mut per_grid = Vec::with_capacity(grids.len());
    // Per grid, per level: (target %, minimum %); and the grid's weight.
    let mut shares: Vec<([(f64, f64); 3], f64)> = Vec::new();
    for g in grids {
        validate(g, daylight.len())?;
        // Each grid by its own areas when it has them (honeybee's en17037_compute); the
        // combination by area only when every grid has them.
        let areas = g.areas;
        let mut lv = [(0.0, 0.0); 3];
        let mut weight = 0.0;
        for (k, (_, target, minimum)) in LEVELS.iter().enumerate() {
            let (t, w) = space_pct(&meets(g, daylight, *target), areas);
            let (m, _) = space_pct(&meets(g, daylight, *minimum), areas);
            lv[k] = (t, m);
            weight = w;
        }
        let combine_weight = if area_weighted {
            weight
        } else {
            g.sensors as f64
        };
        per_grid.push(GridResult {
            name: g.name.to_string(),
            total_weight: weight,
            levels: levels(&lv),
        });
        shares.push((lv, combine_weight));
    }
    let total: f64 = shares.iter().map(|(_, w)| w).sum();
    let mut all = [(0.0, 0.0); 3];
    for (k, a) in all.iter_mut().enumerate() {
        let t: f64 = shares.iter().map(|(lv, w)| lv[k].0 * w).sum();
        let m: f64 = shares.iter().map(|(lv, w)| lv[k].1 * w).sum();
        *a = if total > 0.0 {
            (t / total, m / total)
        } else {
            (0.0, 0.0)
        };
    }
    Ok(En17037Result {
        levels: levels(&all),
        area_weighted,
        grids: per_grid,
    })
}

fn levels(lv: &[(f64, f64); 3]) -> Levels {
    let level = |k: usize| {
        let (_, target, minimum) = LEVELS[k];
        Level {
            target_lux: f64::from(target),
            target_area_pct: lv[k].0,
            target_pass: lv[k].0 >= TARGET_SPACE_PCT,
            minimum_lux: f64::from(minimum),
            minimum_area_pct: lv[k].1,
            minimum_pass: lv[k].1 >= MINIMUM_SPACE_PCT,
        }
    };
    Levels {
        minimum: level(0),
        medium: level(1),
        high: level(2),
    }
}

#[cfg(test)]
#[path = "en17037_tests.rs"]
mod tests;
