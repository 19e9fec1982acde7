//! Convergence: the batch-noise error estimate, the stop rule and the solve report.
//!
//! Error metric (relative, dimensionless): ε̂ = √(Σ_leaves A σ² / Σ_leaves A B²) with σ the
//! 1σ standard error of the leaf's radiosity from the spread of independent batches (σ of
//! the luminance-weighted grey value, taking the channels as fully correlated, an upper
//! bound) — the area-weighted RMS relative noise — plus the truncation bias bound
//! ρ_max/(1 − ρ_max) · U_left / Σ A·B (U_left: unshot power when the batches stopped).
//! A sensor averages many elements, so its relative error is usually well below ε̂; use
//! [`super::gather_sensor`]'s own standard error there.

use super::{grey_abs, RadiosityParams, RadiosityState};
use crate::photometry::{grey, Rgb};
use serde::Serialize;

/// Why a solve stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum StopReason {
    /// The estimated relative error reached `target_rel_error`.
    TargetError,
    /// The next batch would exceed `max_lines` (or the first one did).
    LineBudget,
    /// The next batch would exceed `max_seconds` (or the first one did).
    TimeBudget,
    /// Nothing to shoot (no daylight and no emitters, or no change on a warm start).
    NothingToShoot,
}

/// Energy bookkeeping of a solve, W (RGB), mean over batches: `daylight_in + emitted =
/// absorbed + escaped + unshot` up to Monte Carlo noise (`residual` and its standard error).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct EnergyBalance {
    /// Direct (sun + sky) power arriving at opaque front faces (glazing not counted: what
    /// it lets through is counted where it lands). On a warm start: its change.
    pub daylight_in: Rgb,
    /// Self-emitted power Σ A·π·Ke (0 on a warm start).
    pub emitted: Rgb,
    /// Absorbed: Σ A (1 − ρ)(E_direct + E_indirect) + lines ending on back faces + power
    /// lost in glazing.
    pub absorbed: Rgb,
    /// Power of lines leaving the scene.
    pub escaped: Rgb,
    /// Power still unshot when the batches stopped.
    pub unshot: Rgb,
    /// daylight_in + emitted − absorbed − escaped − unshot.
    pub residual: Rgb,
    /// 1σ standard error of `residual` over batches.
    pub residual_std_err: Rgb,
}

/// What a solve did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SolveReport {
    /// What stopped it.
    pub stop: Option<StopReason>,
    /// Lines traced, all batches (including a discarded partial batch).
    pub lines: u64,
    /// Shooting steps (Jacobi iterations), all batches.
    pub iterations: u64,
    /// Completed batches averaged into the result.
    pub batches: u32,
    /// Batches abandoned because a budget ran out in their middle (only when none had
    /// completed is a partial batch kept, and then the error is infinite).
    pub discarded_batches: u32,
    /// Wall-clock time, s.
    pub seconds: f64,
    /// Estimated relative error ε̂ (see the module doc), including `truncation_bias`;
    /// infinite with fewer than two batches.
    pub estimated_error: f64,
    /// Relative truncation bias bound (part of `estimated_error`).
    pub truncation_bias: f64,
    /// Elements and leaves of the hierarchy after the solve.
    pub elements: usize,
    /// Leaves after the solve.
    pub leaves: usize,
    /// True when this was a warm start (false also when a warm start re-anchored).
    pub warm: bool,
    /// Energy bookkeeping.
    pub energy: EnergyBalance,
}

/// Per-batch energy totals, accumulated into mean and variance.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct EnergyAcc {
    pub n: u32,
    pub sum: [Rgb; 5],
    pub res_sum: Rgb,
    pub res_sum2: Rgb,
}

impl EnergyAcc {
    /// Adds one batch: [daylight_in, emitted, absorbed, escaped, unshot].
    pub fn add(&mut self, v: [Rgb; 5]) {
        self.n += 1;
        for (s, x) in self.sum.iter_mut().zip(v) {
            *s += x;
        }
        let r = v[0] + v[1] - v[2] - v[3] - v[4];
        self.res_sum += r;
        self.res_sum2 += r * r;
    }
    pub fn balance(&self) -> EnergyBalance {
        if self.n == 0 {
            return EnergyBalance::default();
        }
        let n = self.n as f64;
        EnergyBalance {
            daylight_in: self.sum[0] / n,
            emitted: self.sum[1] / n,
            absorbed: self.sum[2] / n,
            escaped: self.sum[3] / n,
            unshot: self.sum[4] / n,
            residual: self.res_sum / n,
            residual_std_err: super::sqrt3(super::mean_var(self.res_sum, self.res_sum2, self.n)),
        }
    }
}

/// The relative noise part of ε̂ over the leaves of `state`.
pub fn relative_noise(state: &RadiosityState) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for i in state.hierarchy.leaves() {
        let a = state.hierarchy.elements[i as usize].area;
        let s = grey(state.radiosity_std_err(i));
        num += a * s * s;
        den += a * grey(state.radiosity(i)).powi(2);
    }
    if num == 0.0 {
        0.0
    } else if den == 0.0 || !num.is_finite() {
        f64::INFINITY
    } else {
        (num / den).sqrt()
    }
}

/// Truncation bias bound relative to the total radiosity power, for unshot power
/// `unshot_w` (grey W) left at the end of the batches.
pub fn truncation_bias(state: &RadiosityState, unshot_w: f64) -> f64 {
    let rho = super::lines::rho_max(state);
    let total: f64 = state
        .hierarchy
        .leaves()
        .map(|i| state.hierarchy.elements[i as usize].area * grey_abs(state.radiosity(i)))
        .sum();
    if unshot_w == 0.0 {
        0.0
    } else if total == 0.0 {
        f64::INFINITY
    } else {
        rho / (1.0 - rho) * unshot_w / total
    }
}

/// Budget check before starting a batch: stop if the next batch, estimated from the mean
/// cost of the completed ones, would exceed a budget.
pub(crate) fn budget_stop(
    params: &RadiosityParams,
    lines: u64,
    seconds: f64,
    batches_done: u32,
    lines_in_batches: u64,
    seconds_in_batches: f64,
) -> Option<StopReason> {
    if lines >= params.max_lines {
        return Some(StopReason::LineBudget);
    }
    if seconds >= params.max_seconds {
        return Some(StopReason::TimeBudget);
    }
    if batches_done > 0 {
        let n = batches_done as f64;
        if lines as f64 + lines_in_batches as f64 / n > params.max_lines as f64 {
            return Some(StopReason::LineBudget);
        }
        if seconds + seconds_in_batches / n > params.max_seconds {
            return Some(StopReason::TimeBudget);
        }
    }
    None
}
