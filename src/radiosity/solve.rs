//! The per-timestep solve of the fixed operator: B = S + ρ ⊙ (F̂ B) with S = ρ E_direct +
//! π Ke, by Gauss–Seidel sweeps until the residual, extrapolated by the observed
//! contraction, is below the tolerance of each row's B; warm-started from the previous
//! timestep's B + ΔS, which accumulates no noise (the operator is fixed), only the
//! iteration error the stop rule bounds at every step.

use super::sparse::Sparse;
use super::transport::Transport;
use crate::photometry::{grey, Rgb};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Per part, the radiosity of every row (fine and coarse) and the source it answers.
#[derive(Clone, Debug, Default)]
pub struct TransportState {
    pub(super) b: Vec<Vec<Rgb>>,
    pub(super) b_coarse: Vec<Vec<Rgb>>,
    s: Vec<Rgb>,
    s_coarse: Vec<Rgb>,
}

/// What one solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TransportReport {
    /// Gauss–Seidel sweeps, summed over parts and levels.
    pub sweeps: u32,
    /// Extrapolated relative iteration error at the stop (largest over parts).
    pub iteration_error: f64,
    /// True when started from a previous state.
    pub warm: bool,
    /// Wall time, s.
    pub seconds: f64,
}

impl Transport {
    /// Solves for the mesh direct irradiance `direct` (RGB W/m² per row, see
    /// [`Mesh::average_onto`](super::Mesh::average_onto)), warm-started from `previous` when
    /// given.
    pub fn solve(
        &self,
        direct: &[Rgb],
        previous: Option<&TransportState>,
    ) -> (TransportState, TransportReport) {
        let t0 = Instant::now();
        let s: Vec<Rgb> = direct
            .iter()
            .zip(&self.rho)
            .zip(&self.emit)
            .map(|((e, r), m)| *r * *e + *m)
            .collect();
        let mut s_coarse = vec![Rgb::ZERO; self.mesh.coarse_rows];
        for (r, &c) in self.mesh.coarse_of.iter().enumerate() {
            s_coarse[c as usize] += s[r] * self.mesh.area[r];
        }
        for (c, a) in s_coarse.iter_mut().zip(&self.coarse_area) {
            if *a > 0.0 {
                *c /= *a;
            }
        }
        let warm = previous.is_some_and(|p| p.b.len() == self.parts.len());
        let start = |prev: Option<&Vec<Rgb>>, prev_s: &[Rgb], s: &[Rgb]| -> Vec<Rgb> {
            match prev {
                Some(b) if warm => b
                    .iter()
                    .zip(prev_s)
                    .zip(s)
                    .map(|((b, ps), s)| *b + *s - *ps)
                    .collect(),
                _ => s.to_vec(),
            }
        };
        let tol = self.params.tolerance;
        let max = self.params.max_sweeps;
        let results: Vec<(Vec<Rgb>, Vec<Rgb>, u32, f64)> = self
            .parts
            .par_iter()
            .enumerate()
            .map(|(p, part)| {
                let (pb, pbc) = match previous {
                    Some(st) if warm => (Some(&st.b[p]), Some(&st.b_coarse[p])),
                    _ => (None, None),
                };
                let ps = previous.map_or(&[][..], |st| &st.s[..]);
                let psc = previous.map_or(&[][..], |st| &st.s_coarse[..]);
                let mut b = start(pb, ps, &s);
                let (n1, e1) = gauss_seidel(&part.f, &self.rho, &s, &mut b, tol, max);
                let mut bc = start(pbc, psc, &s_coarse);
                let (n2, e2) = gauss_seidel(
                    &part.f_coarse,
                    &self.coarse_rho,
                    &s_coarse,
                    &mut bc,
                    tol,
                    max,
                );
                (b, bc, n1 + n2, e1.max(e2))
            })
            .collect();
        let mut report = TransportReport {
            warm,
            ..TransportReport::default()
        };
        let mut state = TransportState {
            s,
            s_coarse,
            ..TransportState::default()
        };
        for (b, bc, n, e) in results {
            report.sweeps += n;
            report.iteration_error = report.iteration_error.max(e);
            state.b.push(b);
            state.b_coarse.push(bc);
        }
        report.seconds = t0.elapsed().as_secs_f64();
        (state, report)
    }

    /// Radiosity of mesh row `r` (mean over parts), RGB W/m².
    pub fn radiosity(&self, state: &TransportState, r: usize) -> Rgb {
        state.b.iter().map(|b| b[r]).fold(Rgb::ZERO, |a, x| a + x) / state.b.len() as f64
    }

    /// Number of independent parts the solution holds (their spread is its noise).
    pub fn parts(&self) -> usize {
        self.parts.len()
    }

    /// Radiosity of mesh row `r` in part `p` alone, RGB W/m².
    pub fn part_radiosity(&self, state: &TransportState, p: usize, r: usize) -> Rgb {
        state.b[p][r]
    }

    /// Radiosity of the coarse row containing mesh row `r` (mean over parts), RGB W/m²:
    /// the one-level-coarser solution the discretisation error is read from.
    pub fn coarse_radiosity(&self, state: &TransportState, r: usize) -> Rgb {
        let c = self.mesh.coarse_of[r] as usize;
        state
            .b_coarse
            .iter()
            .map(|b| b[c])
            .fold(Rgb::ZERO, |a, x| a + x)
            / state.b_coarse.len() as f64
    }

    /// Indirect irradiance received by mesh row `r` (mean over parts), RGB W/m².
    pub fn indirect_irradiance(&self, state: &TransportState, r: usize) -> Rgb {
        self.parts
            .iter()
            .zip(&state.b)
            .map(|(p, b)| p.f.row_dot(r, b))
            .fold(Rgb::ZERO, |a, x| a + x)
            / self.parts.len() as f64
    }
}

/// Gauss–Seidel sweeps of B = S + ρ ⊙ (F B) in row order from the given `b`; returns the
/// sweeps done and the extrapolated relative error at the stop.
fn gauss_seidel(
    f: &Sparse,
    rho: &[Rgb],
    s: &[Rgb],
    b: &mut [Rgb],
    tol: f64,
    max_sweeps: u32,
) -> (u32, f64) {
    let f = f.view();
    let s_max = s.iter().map(|x| grey(x.abs())).fold(0.0, f64::max);
    if s_max == 0.0 {
        b.iter_mut().for_each(|x| *x = Rgb::ZERO);
        return (0, 0.0);
    }
    // Relative to each row's own radiosity (a dim room beside a bright outdoor ground
    // must converge too), with a floor far below anything a sensor can read.
    let floor = 1e-6 * s_max;
    let mut prev_change = f64::INFINITY;
    let mut err = f64::INFINITY;
    let mut last = vec![Rgb::ZERO; b.len()];
    let mut sweeps = max_sweeps;
    let mut q = 0.0;
    for sweep in 1..=max_sweeps {
        let mut change = 0.0f64;
        for r in 0..b.len() {
            let new = s[r] + rho[r] * f.row_dot(r, b);
            let d = grey((new - b[r]).abs()) / grey(new.abs()).max(floor);
            change = change.max(d);
            last[r] = new - b[r];
            b[r] = new;
        }
        // The change per sweep shrinks geometrically by q (about ρ in a closed room, so
        // the tail grows as ρ/(1 − ρ)); the error left is about change·q/(1 − q).
        q = if prev_change.is_finite() && prev_change > 0.0 {
            (change / prev_change).clamp(0.5, MAX_CONTRACTION)
        } else {
            rho.iter().map(|r| r.max_element()).fold(0.5, f64::max)
        };
        prev_change = change;
        err = change * q / (1.0 - q);
        if err <= tol {
            sweeps = sweep;
            break;
        }
    }
    // Add the geometric tail the sweeps left (Aitken's extrapolation per row): near ρ = 1
    // it is most of the answer. What the extrapolation may miss is at most the tail
    // itself, so `err` stays the stated error.
    let tail = q / (1.0 - q);
    for (x, d) in b.iter_mut().zip(&last) {
        *x += *d * tail;
    }
    (sweeps, err)
}

/// Largest per-sweep contraction the stop rule extrapolates with: above ρ = 0.999 (the
/// reflectance clamp) a sweep contracts by about ρ.
const MAX_CONTRACTION: f64 = 0.9999;
