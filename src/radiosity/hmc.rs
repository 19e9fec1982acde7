//! Stochastic Jacobi shooting with per-line hierarchical refinement (Bekaert et al. 1998).
//!
//! A batch: B = U = S (or ΔS on a warm start); then steps, each shooting all unshot power
//! of the leaves with local lines (source leaf ∝ A·Σ_c|U_c|, so each line carries the same
//! total power P_T/N and the sign of U on a warm start). Every line is refined on its own,
//! with no stored links: starting from (source leaf, root of the hit triangle), the power
//! oracle estimates the power the pair exchanges, A_r·F̃·ρ_r·|U_s| with the cheap form
//! factor F̃ = f·max(cos_r, 2f)·max(cos_s, 2f), f = A_s/(πd² + A_s) (RenderPark), d and the
//! cosines between the two elements' centroids (a function of the pair only); while it
//! exceeds ε × the batch's initial power, the larger of the two elements above A_min is
//! split (leaves are split on the fly with [`crate::hierarchy::Hierarchy::insert`]) and
//! the line descends to the child containing its end point. With
//! `multilevel_deposit` (Bekaert's HMC) the irradiance P/A_r is deposited at the element
//! reached (possibly an inner one: push spreads it down): less noise, but a leaf then gets
//! the average over a coarser element of the light from some sources and its own share of
//! the light from others — a discretisation bias (≈ 1–4 % on furnace edge elements) that
//! the batch spread does not see. By default the line goes on down to the leaf containing
//! its end point: the oracles only refine the mesh, every leaf's value is the unbiased
//! average of its own irradiance, and the stated error covers the error.
//! After the step, push: each leaf's received irradiance is the sum over its ancestors;
//! its new unshot radiosity is ρ·E. At the end of the batch, pull: inner elements get the
//! area-weighted mean of their children, and every element's batch value is accumulated.
//!
//! Determinism: lines of a step are traced in parallel in fixed chunks (pure functions of
//! the counter-based RNG), then deposited (with refinement) sequentially in line order.
//!
//! Glazing here transmits only (reflectance 0): its specular reflection (Radiance `glass`,
//! ≈ 8 % at normal incidence) is modelled by the default global-line transport
//! ([`super::transport`]) but not by this optional solver nor its sensor gather
//! ([`super::gather_sensor`]), which therefore read somewhat less interreflected light
//! next to windows.

use super::convergence::{self, budget_stop, EnergyAcc, SolveReport, StopReason};
use super::lines::{barycentric, cosine_direction, uniform_barycentric, End, Outcome, Tracer};
use super::{child_of, grey_abs, RadiosityParams, RadiosityState};
use crate::hierarchy::MAX_DEPTH;
use crate::math::rng::{mix64, uniform};
use crate::photometry::Rgb;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::time::Instant;

/// Lines per parallel work item.
const CHUNK: u64 = 1024;

/// Cold solve: discards any previous result of `state` and solves from its source
/// radiosity S = ρ·E_direct + π·Ke until the target error or a budget stops it.
pub fn solve(state: &mut RadiosityState, tracer: &Tracer, params: &RadiosityParams) -> SolveReport {
    state.reset_cold();
    run(state, tracer, params, false)
}

/// One traced line, before deposit.
struct LineRec {
    src: u32,
    src_bary: [f64; 3],
    src_grey: f64,
    out: Outcome,
}

/// Result of one batch.
enum Batch {
    Done,
    Stopped(StopReason),
}

/// Per-batch bookkeeping.
#[derive(Default)]
struct BatchAcc {
    escaped: Rgb,
    lost: Rgb,
    lines: u64,
    steps: u64,
}

/// Runs batches on the shoot set up in `state` (cold or warm).
pub(crate) fn run(
    state: &mut RadiosityState,
    tracer: &Tracer,
    params: &RadiosityParams,
    warm: bool,
) -> SolveReport {
    let t0 = Instant::now();
    let min_batches = params.batches.max(2);
    let mut report = SolveReport {
        warm,
        ..SolveReport::default()
    };
    let mut energy = EnergyAcc::default();
    let mut unshot_grey_sum = 0.0;
    let (mut lines_in_batches, mut secs_in_batches) = (0u64, 0.0);
    let mut error = f64::INFINITY;
    let stop = loop {
        if state.batches >= min_batches && error <= params.target_rel_error {
            break StopReason::TargetError;
        }
        let secs = t0.elapsed().as_secs_f64();
        if let Some(r) = budget_stop(
            params,
            report.lines,
            secs,
            state.batches,
            lines_in_batches,
            secs_in_batches,
        ) {
            break r;
        }
        let tb = Instant::now();
        let mut acc = BatchAcc::default();
        let (outcome, totals, unshot_grey, p0) =
            one_batch(state, tracer, params, t0, report.lines, &mut acc);
        report.lines += acc.lines;
        report.iterations += acc.steps;
        if p0 == 0.0 {
            break StopReason::NothingToShoot;
        }
        match outcome {
            Batch::Done => {}
            Batch::Stopped(r) if state.batches > 0 => {
                report.discarded_batches += 1;
                break r;
            }
            Batch::Stopped(_) => {} // keep the only (partial) batch; it is flagged below
        }
        accumulate(state);
        energy.add(totals);
        unshot_grey_sum += unshot_grey;
        lines_in_batches += acc.lines;
        secs_in_batches += tb.elapsed().as_secs_f64();
        let bias = convergence::truncation_bias(state, unshot_grey_sum / state.batches as f64);
        report.truncation_bias = bias + state.base_error;
        error = convergence::relative_noise(state) + report.truncation_bias;
        if let Batch::Stopped(r) = outcome {
            break r;
        }
    };
    report.stop = Some(stop);
    if state.batches == 0 {
        report.truncation_bias = state.base_error;
    }
    state.bias = report.truncation_bias;
    report.batches = state.batches;
    report.seconds = t0.elapsed().as_secs_f64();
    report.estimated_error = if stop == StopReason::NothingToShoot {
        state.base_error
    } else {
        error
    };
    report.elements = state.hierarchy.elements.len();
    report.leaves = state.hierarchy.leaf_count();
    report.energy = energy.balance();
    report
}

/// Adds the finished batch (pulled to inner elements) to every element's sums.
fn accumulate(state: &mut RadiosityState) {
    let h = &state.hierarchy;
    for i in (0..h.elements.len()).rev() {
        if let Some(fc) = h.elements[i].first_child {
            let (mut b, mut e) = (Rgb::ZERO, Rgb::ZERO);
            for k in 0..4 {
                let c = &state.cells[fc as usize + k];
                let a = h.elements[fc as usize + k].area;
                b += c.b * a;
                e += c.e * a;
            }
            let a = h.elements[i].area;
            state.cells[i].b = b / a;
            state.cells[i].e = e / a;
        }
    }
    for c in &mut state.cells {
        c.sum_b += c.b;
        c.sum_b2 += c.b * c.b;
        c.sum_e += c.e;
        c.sum_e2 += c.e * c.e;
    }
    state.batches += 1;
}

/// One shooting batch. Returns how it ended, its energy totals [daylight_in, emitted,
/// absorbed, escaped, unshot] (W), its unshot grey power left, and its initial sampling
/// power (0: nothing to shoot).
fn one_batch(
    state: &mut RadiosityState,
    tracer: &Tracer,
    params: &RadiosityParams,
    t0: Instant,
    lines_before: u64,
    acc: &mut BatchAcc,
) -> (Batch, [Rgb; 5], f64, f64) {
    // Start: B = U = ρ·E_shoot + M_shoot, nothing received.
    for (i, el) in state.hierarchy.elements.iter().enumerate() {
        let c = &mut state.cells[i];
        let s = state.rho[el.key.tri as usize] * c.shoot_direct + c.shoot_emit;
        c.b = s;
        c.unshot = s;
        c.e = Rgb::ZERO;
        c.recv = Rgb::ZERO;
    }
    let (mut p0, mut p0_grey) = (0.0, 0.0);
    let (mut daylight, mut emitted) = (Rgb::ZERO, Rgb::ZERO);
    for i in state.hierarchy.leaves() {
        let el = &state.hierarchy.elements[i as usize];
        let c = &state.cells[i as usize];
        p0 += el.area * c.unshot.abs().element_sum();
        p0_grey += el.area * grey_abs(c.unshot);
        if !state.glazing[el.key.tri as usize] {
            daylight += c.shoot_direct * el.area;
        }
        emitted += c.shoot_emit * el.area;
    }
    if p0 == 0.0 {
        return (Batch::Done, [Rgb::ZERO; 5], 0.0, 0.0);
    }
    // Line counts, the stop threshold and the oracle are relative to the full source
    // power, not to what this batch shoots: a warm start shooting a 10 % change then uses
    // about 10 % of a cold solve's lines, each carrying the same power.
    let (mut p_full, mut p_full_grey) = (0.0, 0.0);
    for i in state.hierarchy.leaves() {
        let el = &state.hierarchy.elements[i as usize];
        let c = &state.cells[i as usize];
        let s = state.rho[el.key.tri as usize] * c.direct + state.emit[el.key.tri as usize];
        p_full += el.area * s.abs().element_sum();
        p_full_grey += el.area * grey_abs(s);
    }
    let p_scale = p_full.max(p0);
    let p_ref_grey = p_full_grey.max(p0_grey);
    let batch_id = state.batches as u64;
    let mut outcome = Batch::Done;
    for step in 0u64.. {
        // Sampling table over the leaves, ∝ A·Σ_c|U_c|.
        let mut leaves = Vec::new();
        let mut cdf = Vec::new();
        let mut w_total = 0.0;
        for i in state.hierarchy.leaves() {
            let w = state.hierarchy.elements[i as usize].area
                * state.cells[i as usize].unshot.abs().element_sum();
            if w > 0.0 {
                w_total += w;
                leaves.push(i);
                cdf.push(w_total);
            }
        }
        if w_total <= params.unshot_stop * p_scale || leaves.is_empty() {
            break;
        }
        let n = ((params.lines_per_step as f64 * w_total / p_scale).ceil() as u64)
            .max(params.min_lines_per_step)
            .max(1);
        if lines_before + acc.lines + n > params.max_lines {
            outcome = Batch::Stopped(StopReason::LineBudget);
            break;
        }
        if t0.elapsed().as_secs_f64() > params.max_seconds {
            outcome = Batch::Stopped(StopReason::TimeBudget);
            break;
        }
        let stream = mix64(mix64(mix64(state.generation) ^ batch_id) ^ step);
        let recs = trace_step(
            state,
            tracer,
            params.seed,
            stream,
            n,
            &leaves,
            &cdf,
            w_total,
        );
        for r in &recs {
            deposit(state, tracer, params, p_ref_grey, r, acc);
        }
        push(state);
        acc.lines += n;
        acc.steps += 1;
    }
    // Energy of the batch.
    let mut absorbed = acc.lost;
    let mut unshot = Rgb::ZERO;
    let mut unshot_grey = 0.0;
    for i in state.hierarchy.leaves() {
        let el = &state.hierarchy.elements[i as usize];
        let c = &state.cells[i as usize];
        let tri = el.key.tri as usize;
        if !state.glazing[tri] {
            absorbed += (Rgb::ONE - state.rho[tri]) * (c.shoot_direct + c.e) * el.area;
        }
        unshot += c.unshot * el.area;
        unshot_grey += grey_abs(c.unshot) * el.area;
    }
    (
        outcome,
        [daylight, emitted, absorbed, acc.escaped, unshot],
        unshot_grey,
        p0,
    )
}

/// Samples and traces the `n` lines of one step in parallel (fixed chunks, in order).
#[allow(clippy::too_many_arguments)]
fn trace_step(
    state: &RadiosityState,
    tracer: &Tracer,
    seed: u64,
    stream: u64,
    n: u64,
    leaves: &[u32],
    cdf: &[f64],
    w_total: f64,
) -> Vec<LineRec> {
    let chunks = n.div_ceil(CHUNK);
    let per_chunk: Vec<Vec<LineRec>> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let (a, b) = (c * CHUNK, ((c + 1) * CHUNK).min(n));
            (a..b)
                .map(|l| {
                    let u = |d: u64| uniform(seed, stream, 5 * l + d);
                    let t = u(0) * w_total;
                    let k = cdf.partition_point(|&x| x <= t).min(leaves.len() - 1);
                    let src = leaves[k];
                    let el = &state.hierarchy.elements[src as usize];
                    let unshot = state.cells[src as usize].unshot;
                    let bary = uniform_barycentric(u(1), u(2));
                    let v = el.vertices;
                    let x = v[0] * bary[0] + v[1] * bary[1] + v[2] * bary[2];
                    let nrm = tracer.normal(el.key.tri);
                    let (dir, _) = cosine_direction(nrm, u(3), u(4));
                    // P = U·A/(p·N) with p = A·Σ|U|/W: every line carries W/N in total.
                    let power = unshot * (w_total / (unshot.abs().element_sum() * n as f64));
                    LineRec {
                        src,
                        src_bary: bary,
                        src_grey: grey_abs(unshot),
                        out: tracer.trace(x, dir, power),
                    }
                })
                .collect()
        })
        .collect();
    per_chunk.into_iter().flatten().collect()
}

/// Deposits one line, refining (source, receiver) by the power and area oracles.
fn deposit(
    state: &mut RadiosityState,
    tracer: &Tracer,
    params: &RadiosityParams,
    p_ref: f64,
    r: &LineRec,
    acc: &mut BatchAcc,
) {
    acc.lost += r.out.glazing_loss;
    let (tri, y) = match r.out.end {
        End::Escaped => {
            acc.escaped += r.out.power;
            return;
        }
        End::Back => {
            acc.lost += r.out.power;
            return;
        }
        End::Front { tri, point, .. } => (tri, point),
    };
    let root = state.hierarchy.elements[tri as usize].vertices;
    let mut b_r = barycentric(root, y);
    let mut b_s = r.src_bary;
    let (mut s, mut rcv) = (r.src, tri);
    let rho_r = state.rho[tri as usize].max_element();
    let (n_s, n_r) = (
        tracer.normal(state.hierarchy.elements[s as usize].key.tri),
        tracer.normal(tri),
    );
    let threshold = params.epsilon * p_ref;
    loop {
        let es = &state.hierarchy.elements[s as usize];
        let er = &state.hierarchy.elements[rcv as usize];
        let (a_s, a_r) = (es.area, er.area);
        // The oracle sees the pair of elements (centroids), never the line's own end
        // points: a decision that depended on where the line lands would deposit near
        // hits on small children and far hits on their parent, biasing the children.
        let cs = (es.vertices[0] + es.vertices[1] + es.vertices[2]) / 3.0;
        let cr = (er.vertices[0] + er.vertices[1] + er.vertices[2]) / 3.0;
        let dv = cr - cs;
        let d2 = dv.length_squared();
        let (cos_s, cos_r) = if d2 > 0.0 {
            let d = d2.sqrt();
            ((n_s.dot(dv) / d).abs(), (n_r.dot(dv) / d).abs())
        } else {
            (1.0, 1.0)
        };
        let f = a_s / (PI * d2 + a_s);
        let ff = f * cos_r.max(2.0 * f) * cos_s.max(2.0 * f);
        if a_r * ff * rho_r * r.src_grey <= threshold {
            break;
        }
        let can_s = a_s > params.a_min && es.key.depth() + 1 < MAX_DEPTH;
        let can_r = a_r > params.a_min && er.key.depth() + 1 < MAX_DEPTH;
        if can_r && (a_r >= a_s || !can_s) {
            let fc = state.split_leaf(rcv);
            rcv = fc + child_of(&mut b_r) as u32;
        } else if can_s {
            let fc = state.split_leaf(s);
            s = fc + child_of(&mut b_s) as u32;
        } else {
            break;
        }
    }
    if !params.multilevel_deposit {
        // Deposit at the leaf containing the hit: each leaf's estimate is then the plain
        // average of its own irradiance, with no smoothing across the cut.
        while let Some(fc) = state.hierarchy.elements[rcv as usize].first_child {
            rcv = fc + child_of(&mut b_r) as u32;
        }
    }
    let a = state.hierarchy.elements[rcv as usize].area;
    state.cells[rcv as usize].recv += r.out.power / a;
}

/// Push after a step: each leaf's received irradiance is the sum over its ancestors; it
/// becomes the leaf's new unshot radiosity ρ·E (and is added to B and E).
fn push(state: &mut RadiosityState) {
    let h = &state.hierarchy;
    let mut acc = vec![Rgb::ZERO; h.elements.len()];
    for (i, el) in h.elements.iter().enumerate() {
        // Parents precede their children in the arena.
        acc[i] = state.cells[i].recv + el.parent.map_or(Rgb::ZERO, |p| acc[p as usize]);
        state.cells[i].recv = Rgb::ZERO;
    }
    for (i, el) in h.elements.iter().enumerate() {
        if el.first_child.is_none() {
            let c = &mut state.cells[i];
            let u = state.rho[el.key.tri as usize] * acc[i];
            c.e += acc[i];
            c.b += u;
            c.unshot = u;
        }
    }
}
