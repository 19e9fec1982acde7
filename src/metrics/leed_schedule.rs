//! The LEED v4.1 / IES LM-83 operable-blind schedule of one sensor grid: hour by hour, which
//! aperture groups ("light paths") are shaded so that no more than 2 % of the sensors see
//! 1000 lx or more of direct sunlight.
//!
//! Follows honeybee-radiance-postprocess 0.5.25 (`leed/leed.py`, `leed_states_schedule`;
//! `leed/leed_schedule.py`, `shd_trans_schedule_descending` and
//! `states_schedule_descending`), read for this port; the code is daystep's own:
//!
//! - a sensor is over-lit when its direct-sun illuminance, summed over the light paths in
//!   their order in single precision, is **≥ 1000 lx** (inclusive here, while ASE counts
//!   > 1000 lx); a step is compliant when (over-lit sensors) / (sensors) ≤ 0.02;
//! - up to [`BRUTE_FORCE_MAX_PATHS`] light paths (static apertures counted among them) every
//!   combination of open/shaded groups is tried, in the order of Python's
//!   `itertools.product` (first group slowest, open before shaded); among the compliant
//!   ones the one with the **largest** over-lit share is kept (honeybee's `argmax`: the
//!   least shading that still complies), the first on ties; with none compliant the step
//!   stays all open and is reported as failing. This branch judges every sun-up step,
//!   occupied or not (honeybee computes the combinations before filtering by occupancy), so
//!   an unoccupied sun-up step can fail the grid;
//! - beyond that, worst offender first: the groups are ranked by how many sensors they
//!   alone light to ≥ 1000 lx direct (descending, ties in path order) and shaded one after
//!   another until the step complies or every group is shaded; only occupied steps.
//!
//! Data layout: every array is hour-major, `value[step * sensors + sensor]` over the
//! sun-up steps, so one step's sensors are contiguous (the schedule works step by step).

use super::leed::{LeedGrid, LightPath, Shade};
use rayon::prelude::*;

/// Direct-sun illuminance from which a sensor counts as over-lit in the schedule, lux (≥).
pub const SCHEDULE_DIRECT_LUX: f32 = 1000.0;
/// Largest share of over-lit sensors (a fraction, ≤) a compliant step may have.
pub const MAX_OVERLIT_SHARE: f64 = 0.02;
/// Light paths (static apertures included) up to which every combination is tried.
pub const BRUTE_FORCE_MAX_PATHS: usize = 6;

/// The blind schedule of one grid.
#[derive(Clone, Debug, PartialEq)]
pub struct GridSchedule {
    /// Per light path of the grid (in its order), per sun-up step: true when shaded.
    /// Static paths and unoccupied steps are always false (open).
    pub shaded: Vec<Vec<bool>>,
    /// Sun-up steps (indices) at which no combination complies with the 2 % rule.
    pub fail_steps: Vec<usize>,
}

impl LightPath<'_> {
    /// Direct illuminance at flat index `i` in the open or the shaded state, lux (f32, as
    /// honeybee multiplies its float32 arrays by the transmittance).
    #[inline]
    pub(crate) fn direct_at(&self, i: usize, shaded: bool) -> f32 {
        match (shaded, &self.shade) {
            (false, _) | (true, Shade::Static) => self.direct[i],
            (true, Shade::Transmittance(t)) => self.direct[i] * (*t as f32),
            (true, Shade::Arrays { direct, .. }) => direct[i],
        }
    }

    /// Total illuminance at flat index `i` in the open or shaded state, lux (f32 product,
    /// widened by the caller before summing, as honeybee's float64 sum of float32 terms).
    #[inline]
    pub(crate) fn total_at(&self, i: usize, shaded: bool) -> f32 {
        match (shaded, &self.shade) {
            (false, _) | (true, Shade::Static) => self.total[i],
            (true, Shade::Transmittance(t)) => self.total[i] * (*t as f32),
            (true, Shade::Arrays { total, .. }) => total[i],
        }
    }

    /// True for an aperture group with blinds (not static apertures).
    pub fn operable(&self) -> bool {
        !matches!(self.shade, Shade::Static)
    }
}

/// Fraction of sensors over-lit at `step` with the paths shaded where `shaded(path)`.
fn overlit_share(grid: &LeedGrid, step: usize, shaded: &dyn Fn(usize) -> bool) -> f64 {
    let n = grid.sensors;
    let base = step * n;
    let mut count = 0usize;
    for s in 0..n {
        // Summed in path order in f32: honeybee's `sum()` of float32 arrays.
        let mut e = 0.0f32;
        for (p, path) in grid.paths.iter().enumerate() {
            e += path.direct_at(base + s, shaded(p));
        }
        count += usize::from(e >= SCHEDULE_DIRECT_LUX);
    }
    // The same division honeybee does (count / grid_count), so that 1/50 is exactly 0.02.
    count as f64 / n as f64
}

/// The blind schedule of one grid; `occupied` has one entry per sun-up step. The grid has
/// been validated by the caller (lengths, finite values, at least one sensor).
pub fn grid_schedule(grid: &LeedGrid, occupied: &[bool]) -> GridSchedule {
    if grid.paths.len() <= BRUTE_FORCE_MAX_PATHS {
        brute_force(grid, occupied)
    } else {
        descending(grid, occupied)
    }
}

/// Every combination of the operable paths; see the module doc for the choice.
fn brute_force(grid: &LeedGrid, occupied: &[bool]) -> GridSchedule {
    let operable: Vec<usize> = (0..grid.paths.len())
        .filter(|&p| grid.paths[p].operable())
        .collect();
    let k = operable.len();
    // bit of path p in a combination index: the first operable path is the most
    // significant, so that index order is itertools.product's order (open = 0 first).
    let mut bit = vec![None; grid.paths.len()];
    for (j, &p) in operable.iter().enumerate() {
        bit[p] = Some(k - 1 - j);
    }
    // Static paths take part in honeybee's product as [1, 1]: duplicates that come after
    // their first occurrence and so never win the argmax; leaving them out changes nothing.
    let per_step: Vec<(usize, bool)> = (0..occupied.len())
        .into_par_iter()
        .map(|step| {
            let mut best: Option<(f64, usize)> = None;
            for combo in 0..(1usize << k) {
                let shaded = |p: usize| bit[p].is_some_and(|b| combo >> b & 1 == 1);
                let share = overlit_share(grid, step, &shaded);
                if share > MAX_OVERLIT_SHARE {
                    continue;
                }
                if best.is_none_or(|(b, _)| share > b) {
                    best = Some((share, combo));
                }
            }
            // No compliant combination: honeybee's argmax over all −inf is index 0.
            (best.map_or(0, |(_, c)| c), best.is_none())
        })
        .collect();
    let mut shaded = vec![vec![false; occupied.len()]; grid.paths.len()];
    let mut fail_steps = Vec::new();
    for (step, &(combo, fail)) in per_step.iter().enumerate() {
        if fail {
            fail_steps.push(step);
        }
        if occupied[step] {
            for (p, b) in bit.iter().enumerate() {
                shaded[p][step] = b.is_some_and(|b| combo >> b & 1 == 1);
            }
        }
    }
    GridSchedule { shaded, fail_steps }
}

/// Worst offender first, occupied steps only; see the module doc.
fn descending(grid: &LeedGrid, occupied: &[bool]) -> GridSchedule {
    let n = grid.sensors;
    let np = grid.paths.len();
    let per_step: Vec<Option<(Vec<bool>, bool)>> = (0..occupied.len())
        .into_par_iter()
        .map(|step| {
            if !occupied[step] || overlit_share(grid, step, &|_| false) <= MAX_OVERLIT_SHARE {
                return None;
            }
            let base = step * n;
            // Rank by the sensors each path alone (open) lights to ≥ 1000 lx; a stable sort
            // keeps ties in path order.
            let lit: Vec<usize> = grid
                .paths
                .iter()
                .map(|p| {
                    p.direct[base..base + n]
                        .iter()
                        .filter(|&&e| e >= SCHEDULE_DIRECT_LUX)
                        .count()
                })
                .collect();
            let mut order: Vec<usize> = (0..np).collect();
            order.sort_by(|a, b| lit[*b].cmp(&lit[*a]));
            let mut shaded = vec![false; np];
            let by_transmittance = grid
                .paths
                .iter()
                .all(|p| !matches!(p.shade, Shade::Arrays { .. }));
            // Transmittance mode: honeybee subtracts direct × (1 − t) from the float32 sum,
            // the result in float64. Both-state mode: it re-sums the paths' float32 arrays.
            let mut sum: Vec<f64> = (0..n)
                .map(|s| {
                    let mut e = 0.0f32;
                    for p in &grid.paths {
                        e += p.direct[base + s];
                    }
                    f64::from(e)
                })
                .collect();
            let mut ok = false;
            for &p in &order {
                shaded[p] = true;
                let share = if by_transmittance {
                    let keep = match grid.paths[p].shade {
                        Shade::Transmittance(t) => 1.0 - t,
                        _ => 0.0, // static: transmittance 1, nothing taken off
                    };
                    let mut count = 0usize;
                    for (s, e) in sum.iter_mut().enumerate() {
                        *e -= f64::from(grid.paths[p].direct[base + s]) * keep;
                        count += usize::from(*e >= f64::from(SCHEDULE_DIRECT_LUX));
                    }
                    count as f64 / n as f64
                } else {
                    overlit_share(grid, step, &|q| shaded[q])
                };
                if share <= MAX_OVERLIT_SHARE {
                    ok = true;
                    break;
                }
            }
            Some((shaded, !ok))
        })
        .collect();
    let mut shaded = vec![vec![false; occupied.len()]; np];
    let mut fail_steps = Vec::new();
    for (step, r) in per_step.into_iter().enumerate() {
        if let Some((s, fail)) = r {
            for (p, v) in s.into_iter().enumerate() {
                shaded[p][step] = v && grid.paths[p].operable();
            }
            if fail {
                fail_steps.push(step);
            }
        }
    }
    GridSchedule { shaded, fail_steps }
}
