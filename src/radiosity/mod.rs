//! L6 diffuse interreflection: hierarchical Monte Carlo radiosity (Besuievsky & Martín §6,
//! after the sun and sky shoot; Bekaert et al. 1998) by stochastic Jacobi shooting with
//! local lines.
//!
//! * **System.** Per element, radiosity B = S + ρ·E_ind (W/m², RGB), where the source
//!   radiosity S = ρ·E_direct + π·Ke is the first-reflected daylight plus self-emission
//!   (Ke is radiance, π·Ke exitance) and E_ind is the irradiance received from other
//!   surfaces. Only the front face (triangle normal side, counter-clockwise vertices) emits
//!   and receives; a line meeting the back face of an opaque triangle is absorbed there
//!   (counted in the energy balance as absorbed). Glazing (ρ = 0) lets a line through with
//!   its transmittance τ(θ); the rest of the line's power is counted as absorbed (this
//!   solver does not follow glazing's specular reflection; the global-line
//!   [`transport`] does).
//! * **Shooting (incremental Jacobi).** Each step shoots all unshot power with local lines:
//!   a source leaf ∝ A·Σ|unshot| (so every line carries the same power), a uniform point on
//!   it, a cosine-distributed direction, the first hit by the exact BVH ray cast. The
//!   power is deposited at the receiving element found by descending the quadtree; the
//!   power oracle refines on the fly (no stored links, see [`hmc`]). After each step a push
//!   turns received irradiance into the leaves' new unshot radiosity ρ·E. A step shooting
//!   unshot power U uses `lines_per_step · U / U₀` lines, so the whole shooting phase costs
//!   about `lines_per_step / (1 − ρ̄)` lines.
//! * **Batches instead of RenderPark's regular phase.** RenderPark follows the shooting
//!   phase with regular Jacobi steps whose estimates are merged; successive steps are
//!   correlated (each starts from the previous estimate), so their spread understates the
//!   error, badly as ρ → 1. Here a solve is a sequence of *independent* shooting batches
//!   (different random streams, same hierarchy), averaged: the per-element standard error
//!   of the mean over batches is then an honest 1σ noise estimate, at any ρ. A batch stops
//!   when its unshot power falls below `unshot_stop` of the power it started with; the
//!   power left unshot gives a bound on the truncation bias, added to the stated error.
//! * **Determinism.** Every random number is a pure function of (seed, warm-start
//!   generation, batch, step, line), lines are traced in parallel in fixed chunks and
//!   deposited sequentially in line order, so the result is bit-identical for any number
//!   of threads (unless the time budget stops the run).
//!
//! Use: [`RadiosityState::new`] (or [`RadiosityState::from_direct`]), [`solve`], then
//! [`RadiosityState::radiosity`] / [`gather_sensor`]; next instant: [`warm_start`].

pub mod convergence;
pub mod hmc;
pub mod lines;
pub mod response;
pub mod transport;
pub mod warm_start;

pub use convergence::{EnergyBalance, SolveReport, StopReason};
pub use hmc::solve;
pub use lines::{gather_sensor, SensorIndirect, Tracer};
pub use response::{DirectionResponse, SensorResponse};
pub use transport::{
    Transport, TransportParams, TransportReport, TransportSensor, TransportState, TransportStats,
};
pub use warm_start::warm_start;

use crate::hierarchy::Hierarchy;
use crate::photometry::{grey, Rgb};
use crate::scene::Scene;
use crate::transfer::DirectIrradiance;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Knobs of the solver. Every field has a default (`#[serde(default)]`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RadiosityParams {
    /// Stop when the estimated relative error (area-weighted RMS over leaves of the 1σ
    /// standard error relative to the local radiosity, plus the truncation bias bound) is
    /// at or below this, once `batches` batches are done. Default 0.02. Smaller: error
    /// ∝ 1/√lines, so halving it costs 4× the time.
    pub target_rel_error: f64,
    /// Hard cap on lines traced (all batches). Default 50 000 000. The run stops before a
    /// batch that would not fit (estimated from the batches done so far).
    pub max_lines: u64,
    /// Hard cap on wall-clock time, s. Default 120. A run stopped by time is not
    /// reproducible bit for bit (the batch count depends on the machine).
    pub max_seconds: f64,
    /// Minimum number of independent batches before the noise estimate is trusted (≥ 2).
    /// Default 8: the standard error from 8 batches is itself uncertain by about ±25 %.
    /// More batches: a steadier error estimate, same total cost for the same error.
    pub batches: u32,
    /// Lines for a shooting step whose unshot power equals the batch's initial power; later
    /// steps use proportionally fewer. Default 20 000. One batch costs about this /(1 − ρ̄);
    /// larger values mean fewer, less noisy batches (same error per line).
    pub lines_per_step: u64,
    /// Fewest lines in any step (keeps the last steps from being all noise). Default 256.
    pub min_lines_per_step: u64,
    /// A batch stops shooting once its unshot power is below this fraction of its initial
    /// power. Default 1e-4: the truncation bias is at most about this × ρ/(1 − ρ) relative.
    pub unshot_stop: f64,
    /// Area oracle A_min, m²: elements are not split below this area. Default 1e-3 m²
    /// (≈ 4.5 cm triangles). Smaller: finer radiosity detail, more elements and more
    /// noise per element (relative noise ∝ 1/√A).
    pub a_min: f64,
    /// Power oracle ε: a (source, receiver) pair is refined while the power it exchanges is
    /// above ε × the batch's initial power. Default 5e-4 (RenderPark). Smaller: more
    /// elements.
    pub epsilon: f64,
    /// Deposit each line at the element where the oracle stops refining (Bekaert et al.
    /// 1998: less noise on large elements) instead of at the leaf containing its end
    /// point. Default false: the multi-level deposit smooths some sources' light over
    /// coarser elements than others', a discretisation bias the error estimate misses.
    pub multilevel_deposit: bool,
    /// Seed of every random number (results are a pure function of it).
    pub seed: u64,
    /// Warm starts: after this many consecutive warm starts the next one re-solves cold
    /// (re-anchor; bounds the accumulation of noise and truncation bias). Default 24.
    pub reanchor_every: u32,
}

impl Default for RadiosityParams {
    fn default() -> Self {
        RadiosityParams {
            target_rel_error: 0.02,
            max_lines: 50_000_000,
            max_seconds: 120.0,
            batches: 8,
            lines_per_step: 20_000,
            min_lines_per_step: 256,
            unshot_stop: 1e-4,
            a_min: 1e-3,
            epsilon: 5e-4,
            multilevel_deposit: false,
            seed: 0x5eed,
            reanchor_every: 24,
        }
    }
}

/// Everything the solver keeps per element (all RGB; irradiance and radiosity W/m²).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Cell {
    /// Direct irradiance (sun + sky) of this element (leaf total).
    pub direct: Rgb,
    /// Direct irradiance shot in the current solve (cold: `direct`; warm: its change).
    pub shoot_direct: Rgb,
    /// Self-emitted exitance shot in the current solve (cold: π·Ke; warm: 0).
    pub shoot_emit: Rgb,
    /// Radiosity and its variance carried over from the previous solve (warm start).
    pub base_b: Rgb,
    /// Variance of `base_b`.
    pub base_b_var: Rgb,
    /// Indirect irradiance carried over from the previous solve.
    pub base_e: Rgb,
    /// Variance of `base_e`.
    pub base_e_var: Rgb,
    /// Current batch: radiosity increment, unshot radiosity, received indirect irradiance.
    pub b: Rgb,
    /// Unshot radiosity of the current batch.
    pub unshot: Rgb,
    /// Indirect irradiance received in the current batch.
    pub e: Rgb,
    /// Irradiance deposited at this element during the current step (pushed after it).
    pub recv: Rgb,
    /// Sums over completed batches of `b`, `b²`, `e`, `e²`.
    pub sum_b: Rgb,
    /// Σ b².
    pub sum_b2: Rgb,
    /// Σ e.
    pub sum_e: Rgb,
    /// Σ e².
    pub sum_e2: Rgb,
}

/// The solver state over a hierarchy: per element the radiosity of the solve so far, its
/// standard error, and the bookkeeping of the batches. Element indices are those of
/// [`RadiosityState::hierarchy`] (which the solver may refine further; it only appends).
#[derive(Clone, Debug)]
pub struct RadiosityState {
    pub(crate) hierarchy: Hierarchy,
    pub(crate) cells: Vec<Cell>,
    /// Diffuse reflectance per input triangle (0 for glazing).
    pub(crate) rho: Vec<Rgb>,
    /// Emitted exitance π·Ke per input triangle, W/m².
    pub(crate) emit: Vec<Rgb>,
    /// Glazing flag per input triangle.
    pub(crate) glazing: Vec<bool>,
    /// Completed batches of the current solve.
    pub(crate) batches: u32,
    /// Warm-start generation (0 = cold); part of every random stream.
    pub(crate) generation: u64,
    /// Warm starts since the last cold solve.
    pub(crate) warm_steps: u32,
    /// Relative truncation bias bound carried by the base (previous solves).
    pub(crate) base_error: f64,
    /// Relative truncation bias bound of the current result (base included).
    pub(crate) bias: f64,
}

impl RadiosityState {
    /// A state ready for a cold solve: `direct[i]` is the direct irradiance (sun + sky, RGB
    /// W/m²) of element `i` of `hierarchy` (leaf totals, as [`crate::transfer::transfer`]
    /// returns; missing trailing elements take their parent's value). Initial unshot
    /// radiosity is S = ρ·E_direct + π·Ke.
    pub fn new(scene: &Scene, hierarchy: Hierarchy, direct: &[Rgb]) -> RadiosityState {
        let rho: Vec<Rgb> = scene
            .triangles
            .iter()
            .map(|t| {
                // ρ ≥ 1 makes the closed-enclosure system singular: clamp just below.
                scene.materials[t.material as usize]
                    .reflectance()
                    .clamp(Rgb::ZERO, Rgb::splat(MAX_RHO))
            })
            .collect();
        let emit = scene
            .triangles
            .iter()
            .map(|t| scene.materials[t.material as usize].ke * PI)
            .collect();
        let glazing = scene
            .triangles
            .iter()
            .map(|t| scene.materials[t.material as usize].is_glazing())
            .collect();
        let mut cells = vec![Cell::default(); hierarchy.elements.len()];
        for (i, el) in hierarchy.elements.iter().enumerate() {
            cells[i].direct = match direct.get(i) {
                Some(&d) => d,
                None => el.parent.map_or(Rgb::ZERO, |p| cells[p as usize].direct),
            };
        }
        let mut s = RadiosityState {
            hierarchy,
            cells,
            rho,
            emit,
            glazing,
            batches: 0,
            generation: 0,
            warm_steps: 0,
            base_error: 0.0,
            bias: 0.0,
        };
        s.reset_cold();
        s
    }

    /// [`Self::new`] with the sun and sky irradiance of [`DirectIrradiance`] summed.
    pub fn from_direct(
        scene: &Scene,
        hierarchy: Hierarchy,
        direct: &DirectIrradiance,
    ) -> RadiosityState {
        let e: Vec<Rgb> = direct
            .sun
            .iter()
            .zip(&direct.sky)
            .map(|(a, b)| *a + *b)
            .collect();
        RadiosityState::new(scene, hierarchy, &e)
    }

    /// Prepares a cold solve: shoot everything, nothing carried over.
    pub(crate) fn reset_cold(&mut self) {
        for (i, c) in self.cells.iter_mut().enumerate() {
            let tri = self.hierarchy.elements[i].key.tri as usize;
            c.shoot_direct = c.direct;
            c.shoot_emit = self.emit[tri];
            c.base_b = Rgb::ZERO;
            c.base_b_var = Rgb::ZERO;
            c.base_e = Rgb::ZERO;
            c.base_e_var = Rgb::ZERO;
            c.sum_b = Rgb::ZERO;
            c.sum_b2 = Rgb::ZERO;
            c.sum_e = Rgb::ZERO;
            c.sum_e2 = Rgb::ZERO;
        }
        self.batches = 0;
        self.warm_steps = 0;
        self.base_error = 0.0;
        self.bias = 0.0;
    }

    /// The hierarchy the state lives on (the input one, possibly refined further).
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.hierarchy
    }

    /// Number of completed batches of the last solve.
    pub fn batches(&self) -> u32 {
        self.batches
    }

    /// Diffuse reflectance (clamped below 1) of element `i`.
    pub fn reflectance(&self, i: u32) -> Rgb {
        self.rho[self.hierarchy.elements[i as usize].key.tri as usize]
    }

    /// Source radiosity S = ρ·E_direct + π·Ke of element `i`, W/m².
    pub fn source_radiosity(&self, i: u32) -> Rgb {
        let tri = self.hierarchy.elements[i as usize].key.tri as usize;
        self.rho[tri] * self.cells[i as usize].direct + self.emit[tri]
    }

    /// Direct irradiance of element `i` (sun + sky), W/m².
    pub fn direct_irradiance(&self, i: u32) -> Rgb {
        self.cells[i as usize].direct
    }

    /// Radiosity B of element `i` (RGB W/m²): the mean over batches (plus the carried-over
    /// base after a warm start). Before any batch completes, the source radiosity.
    pub fn radiosity(&self, i: u32) -> Rgb {
        let c = &self.cells[i as usize];
        if self.batches == 0 {
            return c.base_b + c.shoot_direct * self.reflectance(i) + c.shoot_emit;
        }
        c.base_b + c.sum_b / self.batches as f64
    }

    /// 1σ standard error of [`Self::radiosity`] (RGB W/m²) from the spread of the batches
    /// (infinite with fewer than two batches, unless nothing was shot).
    pub fn radiosity_std_err(&self, i: u32) -> Rgb {
        let c = &self.cells[i as usize];
        sqrt3(c.base_b_var + mean_var(c.sum_b, c.sum_b2, self.batches))
    }

    /// Indirect irradiance (from other surfaces, front face) of element `i`, RGB W/m².
    pub fn indirect_irradiance(&self, i: u32) -> Rgb {
        let c = &self.cells[i as usize];
        if self.batches == 0 {
            return c.base_e;
        }
        c.base_e + c.sum_e / self.batches as f64
    }

    /// 1σ standard error of [`Self::indirect_irradiance`], RGB W/m².
    pub fn indirect_std_err(&self, i: u32) -> Rgb {
        let c = &self.cells[i as usize];
        sqrt3(c.base_e_var + mean_var(c.sum_e, c.sum_e2, self.batches))
    }

    /// The leaf of triangle `tri` containing the point with barycentric coordinates `bary`
    /// (on the input triangle), by descending the quadtree.
    pub fn leaf_at(&self, tri: u32, bary: [f64; 3]) -> u32 {
        let mut i = tri;
        let mut b = bary;
        while let Some(fc) = self.hierarchy.elements[i as usize].first_child {
            let k = child_of(&mut b);
            i = fc + k as u32;
        }
        i
    }

    /// Area-weighted mean over all leaves of `f(leaf)`, and the total leaf area (m²).
    pub fn area_mean(&self, f: impl Fn(u32) -> Rgb) -> (Rgb, f64) {
        let mut sum = Rgb::ZERO;
        let mut area = 0.0;
        for i in self.hierarchy.leaves() {
            let a = self.hierarchy.elements[i as usize].area;
            sum += f(i) * a;
            area += a;
        }
        (if area > 0.0 { sum / area } else { Rgb::ZERO }, area)
    }

    /// Splits leaf `i` (its four children inherit its values, nothing deposited on them
    /// yet) and returns the index of its first child.
    pub(crate) fn split_leaf(&mut self, i: u32) -> u32 {
        if let Some(fc) = self.hierarchy.elements[i as usize].first_child {
            return fc;
        }
        let key = self.hierarchy.elements[i as usize].key;
        let first = self.hierarchy.insert(key.child(0));
        let mut c = self.cells[i as usize];
        c.recv = Rgb::ZERO;
        self.cells.resize(first as usize + 4, c);
        first
    }

    /// Ensures the element `key` exists (splitting leaves as needed); returns its index.
    pub(crate) fn ensure(&mut self, key: crate::hierarchy::ElementKey) -> u32 {
        if let Some(i) = self.hierarchy.get(key) {
            return i;
        }
        let p = self.ensure(key.parent().expect("roots always exist"));
        let fc = self.split_leaf(p);
        fc + (key.path & 3) as u32
    }
}

/// Reflectances are clamped to this (the system is singular at ρ = 1).
pub const MAX_RHO: f64 = 0.999;

/// Variance of the mean of `m` samples from their sum and sum of squares (infinite for
/// m < 2 unless every sample is zero).
pub(crate) fn mean_var(sum: Rgb, sum2: Rgb, m: u32) -> Rgb {
    if m < 2 {
        return if sum2 == Rgb::ZERO {
            Rgb::ZERO
        } else {
            Rgb::splat(f64::INFINITY)
        };
    }
    let n = m as f64;
    let mean = sum / n;
    ((sum2 - mean * sum) / (n - 1.0) / n).max(Rgb::ZERO)
}

pub(crate) use crate::hierarchy::child_of;

/// Per-channel square root of a variance (negative rounding noise → 0).
pub(crate) fn sqrt3(v: Rgb) -> Rgb {
    v.max(Rgb::ZERO).to_array().map(f64::sqrt).into()
}

/// Luminance-weighted magnitude of an RGB value (for oracles and error metrics).
pub(crate) fn grey_abs(v: Rgb) -> f64 {
    grey(v.abs())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hierarchy::split;
    use glam::DVec3;

    #[test]
    fn child_of_matches_the_geometric_split() {
        let v = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.3, 0.0),
            DVec3::new(0.4, 1.7, 0.1),
        ];
        for (u, w) in [(0.1, 0.2), (0.7, 0.1), (0.2, 0.6), (0.3, 0.3), (0.45, 0.45)] {
            let b = [1.0 - u - w, u, w];
            let p = v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
            let mut nb = b;
            let k = child_of(&mut nb);
            let c = split(v)[k as usize];
            let q = c[0] * nb[0] + c[1] * nb[1] + c[2] * nb[2];
            assert!((p - q).length() < 1e-12, "{k}: {p} vs {q}");
        }
    }

    #[test]
    fn mean_var_of_constant_samples_is_zero() {
        let s = Rgb::splat(3.0 * 4.0);
        let s2 = Rgb::splat(3.0 * 16.0);
        assert_eq!(mean_var(s, s2, 3), Rgb::ZERO);
        assert!(mean_var(Rgb::ONE, Rgb::ONE, 1).x.is_infinite());
        // Samples 1 and 3: variance 2, of the mean 1.
        assert!((mean_var(Rgb::splat(4.0), Rgb::splat(10.0), 2).x - 1.0).abs() < 1e-12);
    }
}
