//! Warm start for a changed direct irradiance (next instant's sun and sky): the system is
//! linear, so B_new = B_old + (I − ρF)⁻¹ ρ·ΔE. Only the signed change ΔS = ρ·(E_new −
//! E_old) is shot (lines carry the sign of the unshot radiosity of their source), so the
//! noise added is ∝ Σ A|ΔS| instead of Σ A·S: small changes are cheap.
//!
//! Drift guard: each warm start inherits the previous result and its variance, and adds
//! its own noise and truncation bias; both accumulate. A warm start therefore re-anchors
//! (solves cold from S_new) when either
//! * `params.reanchor_every` warm starts have been chained since the last cold solve, or
//! * the carried error (previous estimated error) already exceeds `target_rel_error`,
//!
//! which bounds the drift to at most `reanchor_every` increments of bounded error.

use super::hmc::{run, solve};
use super::{RadiosityParams, RadiosityState, SolveReport, Tracer};
use crate::hierarchy::Hierarchy;
use crate::photometry::Rgb;

/// Solves for new direct irradiance `new_direct` (RGB W/m², per element of
/// `new_hierarchy`, leaf totals as [`crate::transfer::transfer`] returns) starting from
/// `previous` (same scene). The new hierarchy's leaves are merged into the state's
/// hierarchy; elements finer than the new hierarchy take the value of their nearest
/// ancestor in it. Returns the new state and the report (`warm == false` when the drift
/// guard re-anchored with a cold solve).
pub fn warm_start(
    previous: &RadiosityState,
    tracer: &Tracer,
    new_hierarchy: &Hierarchy,
    new_direct: &[Rgb],
    params: &RadiosityParams,
) -> (RadiosityState, SolveReport) {
    let mut state = previous.clone();
    for i in new_hierarchy.leaves() {
        state.ensure(new_hierarchy.elements[i as usize].key);
    }
    // New direct irradiance per state element: the element itself or its nearest ancestor
    // in the new hierarchy (leaf totals there).
    let lookup = |mut key: crate::hierarchy::ElementKey| loop {
        if let Some(j) = new_hierarchy.get(key) {
            return new_direct.get(j as usize).copied().unwrap_or(Rgb::ZERO);
        }
        match key.parent() {
            Some(p) => key = p,
            None => return Rgb::ZERO,
        }
    };
    let new_e: Vec<Rgb> = state
        .hierarchy
        .elements
        .iter()
        .map(|el| lookup(el.key))
        .collect();
    let reanchor = previous.warm_steps + 1 > params.reanchor_every
        || previous.batches < 2
        || previous.base_error + super::convergence::relative_noise(previous)
            > params.target_rel_error;
    state.generation = previous.generation + 1;
    if reanchor {
        for (c, e) in state.cells.iter_mut().zip(&new_e) {
            c.direct = *e;
        }
        let report = solve(&mut state, tracer, params);
        return (state, report);
    }
    // Carry the previous result as the base; shoot the change.
    let n = state.cells.len();
    #[allow(clippy::needless_range_loop)] // reads the state before writing its cell
    for i in 0..n {
        let b = state.radiosity(i as u32);
        let bs = state.radiosity_std_err(i as u32);
        let e = state.indirect_irradiance(i as u32);
        let es = state.indirect_std_err(i as u32);
        let c = &mut state.cells[i];
        c.base_b = b;
        c.base_b_var = bs * bs;
        c.base_e = e;
        c.base_e_var = es * es;
        c.shoot_direct = new_e[i] - c.direct;
        c.shoot_emit = Rgb::ZERO;
        c.direct = new_e[i];
        c.sum_b = Rgb::ZERO;
        c.sum_b2 = Rgb::ZERO;
        c.sum_e = Rgb::ZERO;
        c.sum_e2 = Rgb::ZERO;
    }
    state.batches = 0;
    state.warm_steps = previous.warm_steps + 1;
    // The truncation bias bound is not per element: carry the whole-state bound.
    state.base_error = previous.bias;
    let mut report = run(&mut state, tracer, params, true);
    if report.stop == Some(super::StopReason::NothingToShoot) {
        report.estimated_error = state.base_error + super::convergence::relative_noise(&state);
    }
    (state, report)
}
