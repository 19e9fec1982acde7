//! LEED v4.1 Daylight Option 1 (IES LM-83): sDA300/50% with operable blinds operated hour by
//! hour ([`super::leed_schedule`]), ASE1000,250h with every blind open from direct sun only,
//! per grid and area-weighted, the hours that cannot comply and the credit points.
//!
//! Follows honeybee-radiance-postprocess 0.5.25 (`leed/leed.py`: `leed_option_one`,
//! `leed_states_schedule`, `_leed_summary`, `shade_transmittance_per_light_path`;
//! `metrics.py`: `da_array2d`, `ase_array2d`; `annual.py`: `occupancy_schedule_8_to_6`),
//! read for this port; the code is daystep's own. In short:
//!
//! - occupied steps: LEED's fixed schedule, 8:00 to 18:00 (hours 8 … 17) every day, 3650 h
//!   a year hourly; the caller marks which sun-up steps are occupied and gives the count of
//!   all occupied steps (sun-down ones included), which DA divides by;
//! - light is a sum over light paths in their order: static apertures ([`Shade::Static`])
//!   and aperture groups, each open or shaded; shaded is the open light × the shade's
//!   visible transmittance ([`DEFAULT_SHADE_TRANSMITTANCE`] = 0.05, honeybee's default), or
//!   a second simulated state ([`Shade::Arrays`]);
//! - the blind schedule is computed per grid and merged over grids: a group is shaded at a
//!   step when any grid that sees it wants it shaded, and every grid's sDA uses the merged
//!   schedule;
//! - DA: occupied steps with E ≥ 300 lx over all occupied steps, %; a sensor passes sDA
//!   when DA ≥ 50 %; the sum is taken in f64 of f32 terms, as honeybee's;
//! - ASE: occupied steps with the open direct-sun sum > 1000 lx (strict); a sensor fails
//!   when they make ≥ 250 h;
//! - per grid sDA = passing share, ASE = failing share, by sensor count, or by sensor area
//!   when every grid has areas; the total over grids is weighted the same way;
//! - points: 0 when any grid has a step that cannot comply; else 3 for sDA ≥ 75 %, 2 for
//!   ≥ 55 %, 1 for ≥ 40 %, plus one when every grid's sDA ≥ 55 % ("exemplary performance"
//!   when already 3), the sDAs rounded to 2 decimals first as honeybee does.
//!
//! Data layout: every array is hour-major, `value[step * sensors + sensor]`, f32 lux, over
//! the run's sun-up steps (the steps honeybee's matrices hold).

use super::leed_schedule::{grid_schedule, GridSchedule};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Shade transmittance honeybee uses when none is given (`leed_option_one`), a fraction.
pub const DEFAULT_SHADE_TRANSMITTANCE: f64 = 0.05;
/// DA threshold of sDA300/50%, lux (E ≥ it).
pub const DA_LUX: f64 = 300.0;
/// DA a sensor needs to pass sDA, % (≥).
pub const SDA_DA_PCT: f64 = 50.0;
/// ASE direct-sun threshold, lux (E > it).
pub const ASE_LUX: f32 = 1000.0;
/// ASE hours: a sensor fails when its hours above [`ASE_LUX`] are ≥ this, hours.
pub const ASE_HOURS: f64 = 250.0;

/// The shaded state of a light path.
#[derive(Clone, Copy, Debug)]
pub enum Shade<'a> {
    /// Static apertures: no blinds, always open.
    Static,
    /// A diffuse shade of this visible transmittance (0 … 1) over the open state's light:
    /// honeybee's default (`use_states = False`).
    Transmittance(f64),
    /// A second simulated state, total and direct-sun arrays in the layout of the open ones.
    Arrays {
        /// Total illuminance with the group shaded, lux.
        total: &'a [f32],
        /// Direct-sun illuminance with the group shaded, lux.
        direct: &'a [f32],
    },
}

/// The light one path (static apertures or one aperture group) brings to a grid.
#[derive(Clone, Copy, Debug)]
pub struct LightPath<'a> {
    /// Group name (the blind schedule's column); any name for static apertures.
    pub name: &'a str,
    /// Total illuminance through it, open, lux, hour-major (`[step * sensors + sensor]`).
    pub total: &'a [f32],
    /// Direct-sun-only illuminance through it, open, lux, same layout.
    pub direct: &'a [f32],
    /// Its shaded state.
    pub shade: Shade<'a>,
}

/// One sensor grid (a room) and the light paths that reach it.
#[derive(Clone, Debug)]
pub struct LeedGrid<'a> {
    /// Grid name.
    pub name: &'a str,
    /// Number of sensors (≥ 1).
    pub sensors: usize,
    /// Area of each sensor's cell, m² (or any unit), when known.
    pub areas: Option<&'a [f64]>,
    /// Light paths, in the order their light is summed.
    pub paths: Vec<LightPath<'a>>,
}

/// The time axis shared by the grids.
#[derive(Clone, Copy, Debug)]
pub struct LeedPeriod<'a> {
    /// One entry per sun-up step: occupied under LEED's 8:00–18:00 schedule.
    pub occupied: &'a [bool],
    /// Occupied steps of the whole period, sun-down ones included (DA's denominator).
    pub total_occupied_steps: usize,
    /// Step length, hours.
    pub hours_per_step: f64,
}

/// LEED results of one grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LeedGridResult {
    /// Grid name.
    pub name: String,
    /// sDA300/50% with the blind schedule, % of sensors (or of area).
    pub sda_pct: f64,
    /// sDA with every blind always open, %.
    pub sda_blinds_open_pct: f64,
    /// sDA with every blind always shaded, %.
    pub sda_blinds_shaded_pct: f64,
    /// ASE1000,250h, % of sensors (or of area) failing.
    pub ase_pct: f64,
    /// Steps that cannot comply with the 2 % rule × the step length, hours.
    pub hours_fail_to_comply: f64,
    /// Sensor count, or floor area when area-weighted.
    pub total_weight: f64,
    /// Per sensor DA with the schedule, %.
    #[serde(skip)]
    pub da: Vec<f64>,
    /// Per sensor hours with direct sun > 1000 lx, blinds open, hours.
    #[serde(skip)]
    pub ase_hours: Vec<f64>,
    /// The sun-up steps (indices) that cannot comply.
    #[serde(skip)]
    pub fail_steps: Vec<usize>,
}

/// The hourly blind states, merged over grids.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlindSchedule {
    /// Aperture group names, in first-seen order over the grids.
    pub groups: Vec<String>,
    /// Per group, per sun-up step: true when shaded (false at unoccupied steps).
    pub shaded: Vec<Vec<bool>>,
}

impl BlindSchedule {
    /// `leed_blinds.csv`: a header `time,<group>,…` and one row per occupied sun-up step,
    /// 0 open and 1 shaded. `times` labels the sun-up steps (one per step, as the caller
    /// prints times), `occupied` is the period's mask.
    pub fn csv(&self, times: &[impl std::fmt::Display], occupied: &[bool]) -> String {
        let mut out = String::from("time");
        for g in &self.groups {
            out.push(',');
            out.push_str(g);
        }
        out.push('\n');
        for (step, t) in times.iter().enumerate().filter(|(s, _)| occupied[*s]) {
            out.push_str(&t.to_string());
            for s in &self.shaded {
                out.push_str(if s[step] { ",1" } else { ",0" });
            }
            out.push('\n');
        }
        out
    }
}

/// LEED v4.1 Daylight Option 1 results (`leed.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LeedResult {
    /// sDA300/50% with blinds operated hour by hour per group, over all grids, %.
    pub sda_pct: f64,
    /// ASE1000,250h with blinds open, direct sun only, over all grids, %.
    pub ase_pct: f64,
    /// Credit points, 0 … 3.
    pub points: u32,
    /// True when 3 points and every grid reaches sDA ≥ 55 % (honeybee's "Exemplary
    /// performance").
    pub exemplary_performance: bool,
    /// Distinct steps at which some grid cannot comply × the step length, hours.
    pub hours_fail_to_comply: f64,
    /// True when the shares are weighted by sensor area (every grid has areas).
    pub area_weighted: bool,
    /// Per grid.
    pub grids: Vec<LeedGridResult>,
    /// The hourly blind states (written as `leed_blinds.csv` by the caller).
    #[serde(skip)]
    pub blinds: BlindSchedule,
}

/// Python's `round(x, 2)`: Rust's formatting rounds the exact binary value half to even,
/// as Python does.
pub fn round2(x: f64) -> f64 {
    format!("{x:.2}").parse().unwrap_or(x)
}

/// Points from the area-weighted sDA and the grids' sDA (honeybee's table), and whether it
/// is exemplary performance. `any_fail`: a grid has a step that cannot comply (0 points).
pub fn points(sda_pct: f64, grid_sda_pct: &[f64], any_fail: bool) -> (u32, bool) {
    if any_fail {
        return (0, false);
    }
    let sda = round2(sda_pct);
    let mut p = match sda {
        s if s >= 75.0 => 3,
        s if s >= 55.0 => 2,
        s if s >= 40.0 => 1,
        _ => 0,
    };
    if grid_sda_pct.iter().all(|g| round2(*g) >= 55.0) {
        if p <= 2 {
            p += 1;
        } else {
            return (3, true);
        }
    }
    (p, false)
}

fn check_series(grid: &str, what: &str, v: &[f32], len: usize) -> Result<()> {
    if v.len() != len {
        return Err(Error::arg(
            &format!("{what} of grid {grid}"),
            v.len(),
            format!("needs steps × sensors = {len} values"),
        ));
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(Error::arg(
            &format!("{what} of grid {grid}"),
            v[i],
            format!("value {i} is not a finite illuminance"),
        ));
    }
    Ok(())
}

/// Refuses inconsistent or non-finite input, naming the grid and the array.
fn validate(grids: &[LeedGrid], period: &LeedPeriod) -> Result<()> {
    if grids.is_empty() {
        return Err(Error::arg(
            "LEED grids",
            0,
            "needs at least one sensor grid",
        ));
    }
    let steps = period.occupied.len();
    if period.occupied.iter().filter(|o| **o).count() > period.total_occupied_steps {
        return Err(Error::arg(
            "total_occupied_steps",
            period.total_occupied_steps,
            "is less than the occupied sun-up steps",
        ));
    }
    if !(period.hours_per_step.is_finite() && period.hours_per_step > 0.0) {
        return Err(Error::arg(
            "hours_per_step",
            period.hours_per_step,
            "must be > 0",
        ));
    }
    for g in grids {
        if g.sensors == 0 {
            return Err(Error::arg(&format!("grid {}", g.name), 0, "has no sensors"));
        }
        let len = steps * g.sensors;
        for p in &g.paths {
            let what = format!("light path {}", p.name);
            check_series(g.name, &format!("{what} total"), p.total, len)?;
            check_series(g.name, &format!("{what} direct"), p.direct, len)?;
            match p.shade {
                Shade::Transmittance(t) if !(0.0..=1.0).contains(&t) => {
                    return Err(Error::arg(
                        &format!("shade transmittance of {what}"),
                        t,
                        "must be within 0 … 1",
                    ))
                }
                Shade::Arrays { total, direct } => {
                    check_series(g.name, &format!("{what} shaded total"), total, len)?;
                    check_series(g.name, &format!("{what} shaded direct"), direct, len)?;
                }
                _ => {}
            }
        }
        if let Some(a) = g.areas {
            if a.len() != g.sensors {
                return Err(Error::arg(
                    &format!("sensor areas of grid {}", g.name),
                    a.len(),
                    format!("needs one per sensor ({})", g.sensors),
                ));
            }
            if let Some(x) = a.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                return Err(Error::arg(
                    &format!("sensor areas of grid {}", g.name),
                    x,
                    "must be finite and ≥ 0",
                ));
            }
            if a.iter().sum::<f64>() <= 0.0 {
                return Err(Error::arg(
                    &format!("sensor areas of grid {}", g.name),
                    0,
                    "must not all be 0",
                ));
            }
        }
    }
    Ok(())
}

/// Merges the grids' schedules by group name: shaded when any grid shades it.
fn merge_schedules(grids: &[LeedGrid], per_grid: &[GridSchedule], steps: usize) -> BlindSchedule {
    let mut out = BlindSchedule::default();
    for (g, s) in grids.iter().zip(per_grid) {
        for (p, path) in g.paths.iter().enumerate() {
            if !path.operable() {
                continue;
            }
            let k = match out.groups.iter().position(|n| n == path.name) {
                Some(k) => k,
                None => {
                    out.groups.push(path.name.to_string());
                    out.shaded.push(vec![false; steps]);
                    out.groups.len() - 1
                }
            };
            for (o, v) in out.shaded[k].iter_mut().zip(&s.shaded[p]) {
                *o |= *v;
            }
        }
    }
    out
}

/// Per-sensor counts of occupied steps with the f64 sum of the paths' total ≥ 300 lx, with
/// each path shaded where `shaded(path, step)`.
fn da_counts(
    grid: &LeedGrid,
    occupied: &[bool],
    shaded: &dyn Fn(usize, usize) -> bool,
) -> Vec<usize> {
    let n = grid.sensors;
    let mut counts = vec![0usize; n];
    for step in (0..occupied.len()).filter(|&s| occupied[s]) {
        let base = step * n;
        for (s, c) in counts.iter_mut().enumerate() {
            let mut e = 0.0f64;
            for (p, path) in grid.paths.iter().enumerate() {
                e += f64::from(path.total_at(base + s, shaded(p, step)));
            }
            *c += usize::from(e >= DA_LUX);
        }
    }
    counts
}

/// The weight of the sensors where `pass`, and the total weight: areas (m²) when given,
/// else counts.
pub(super) fn share(pass: &[bool], areas: Option<&[f64]>) -> (f64, f64) {
    match areas {
        Some(a) => {
            let total: f64 = a.iter().sum();
            let yes: f64 = a
                .iter()
                .zip(pass)
                .filter(|(_, p)| **p)
                .map(|(a, _)| a)
                .sum();
            (yes, total)
        }
        None => (
            pass.iter().filter(|p| **p).count() as f64,
            pass.len() as f64,
        ),
    }
}

/// LEED v4.1 Daylight Option 1 over the grids (see the module doc).
///
/// # Errors
/// [`Error::Input`] for no grids, a grid without sensors, arrays of the wrong length or
/// holding NaN or infinities, a transmittance outside 0 … 1, bad areas, or fewer total
/// occupied steps than occupied sun-up steps.
pub fn leed_option_one(grids: &[LeedGrid], period: &LeedPeriod) -> Result<LeedResult> {
    validate(grids, period)?;
    let steps = period.occupied.len();
    let per_grid: Vec<GridSchedule> = grids
        .iter()
        .map(|g| grid_schedule(g, period.occupied))
        .collect();
    let blinds = merge_schedules(grids, &per_grid, steps);
    let area_weighted = grids.iter().all(|g| g.areas.is_some());
    let total_occ = period.total_occupied_steps as f64;
    let da_pct = |c: usize| {
        if period.total_occupied_steps == 0 {
            0.0
        } else {
            c as f64 / total_occ * 100.0
        }
    };
    let mut results = Vec::with_capacity(grids.len());
    let (mut all_w, mut all_sda, mut all_ase_pass) = (0.0, 0.0, 0.0);
    for (g, sched) in grids.iter().zip(&per_grid) {
        let areas = if area_weighted { g.areas } else { None };
        let group_of: Vec<Option<usize>> = g
            .paths
            .iter()
            .map(|p| {
                p.operable()
                    .then(|| blinds.groups.iter().position(|n| n == p.name))
                    .flatten()
            })
            .collect();
        let scheduled = da_counts(g, period.occupied, &|p, step| {
            group_of[p].is_some_and(|k| blinds.shaded[k][step])
        });
        let open = da_counts(g, period.occupied, &|_, _| false);
        let closed = da_counts(g, period.occupied, &|_, _| true);
        let da: Vec<f64> = scheduled.iter().map(|c| da_pct(*c)).collect();
        let passes =
            |c: &[usize]| -> Vec<bool> { c.iter().map(|c| da_pct(*c) >= SDA_DA_PCT).collect() };
        // ASE: open direct sum in f32, path order, > 1000 lx, occupied steps.
        let n = g.sensors;
        let mut above = vec![0usize; n];
        for step in (0..steps).filter(|&s| period.occupied[s]) {
            for (s, a) in above.iter_mut().enumerate() {
                let mut e = 0.0f32;
                for p in &g.paths {
                    e += p.direct[step * n + s];
                }
                *a += usize::from(e > ASE_LUX);
            }
        }
        let ase_hours: Vec<f64> = above
            .iter()
            .map(|a| *a as f64 * period.hours_per_step)
            .collect();
        let ase_pass: Vec<bool> = ase_hours.iter().map(|h| *h < ASE_HOURS).collect();
        let (sda_w, w) = share(&passes(&scheduled), areas);
        let (open_w, _) = share(&passes(&open), areas);
        let (closed_w, _) = share(&passes(&closed), areas);
        let (ase_w, _) = share(&ase_pass, areas);
        all_w += w;
        all_sda += sda_w;
        all_ase_pass += ase_w;
        results.push(LeedGridResult {
            name: g.name.to_string(),
            sda_pct: sda_w / w * 100.0,
            sda_blinds_open_pct: open_w / w * 100.0,
            sda_blinds_shaded_pct: closed_w / w * 100.0,
            // As honeybee: the failing share from the passing one.
            ase_pct: (w - ase_w) / w * 100.0,
            hours_fail_to_comply: sched.fail_steps.len() as f64 * period.hours_per_step,
            total_weight: w,
            da,
            ase_hours,
            fail_steps: sched.fail_steps.clone(),
        });
    }
    let sda_pct = all_sda / all_w * 100.0;
    let ase_pct = (all_w - all_ase_pass) / all_w * 100.0;
    let mut fail: Vec<usize> = per_grid
        .iter()
        .flat_map(|s| s.fail_steps.iter().copied())
        .collect();
    fail.sort_unstable();
    fail.dedup();
    let grid_sda: Vec<f64> = results.iter().map(|r| r.sda_pct).collect();
    let (points, exemplary_performance) = points(sda_pct, &grid_sda, !fail.is_empty());
    Ok(LeedResult {
        sda_pct,
        ase_pct,
        points,
        exemplary_performance,
        hours_fail_to_comply: fail.len() as f64 * period.hours_per_step,
        area_weighted,
        grids: results,
        blinds,
    })
}

#[cfg(test)]
#[path = "leed_tests.rs"]
mod tests;
