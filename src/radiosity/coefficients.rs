//! Grey daylight coefficients of many directions at once, by blocked adjoint solves: for
//! each direction n (its mesh irradiance per unit normal irradiance, `W_n`) and sensor s,
//! the indirect illuminance at s per W/m² of grey normal irradiance, Σ_r X\[r\]\[s\] · ρ_r
//! W_n,r, X the adjoint response of [`super::response`], in each independent part and
//! one mesh level coarser (the same noise and discretisation estimates as a forward
//! solve).
//!
//! Why this order: X is rows × 3 × sensors per part and level, which for 1 620 sensors on
//! a 20 000-row mesh would be 3 GB. Sensors are therefore solved in blocks sized to a
//! memory budget; each block's X is applied to every direction and dropped, so memory is
//! the budget plus the coefficients (directions × sensors × (parts + 1) × 4 bytes). Each
//! adjoint system is still solved in fixed sub-blocks of [`BLOCK`] sensors, so the values
//! do not depend on the budget or the thread count.
//!
//! Grey: the coefficients are collapsed to illuminance (179 lm/W × the photopic weights),
//! which is exact when every source is grey (Perez skies, their ground glow and the sun:
//! what annual runs use); coloured skies keep the forward solve.

use super::response::{adjoint_block, BLOCK};
use super::transport::Transport;
use crate::photometry::{lux, Rgb};
use rayon::prelude::*;
use std::time::Instant;

/// The adjoint responses of one block of sensors, all parts and both levels, ready to turn
/// any direction's mesh irradiance into its grey daylight coefficients at those sensors.
pub struct AdjointBlock {
    /// Sensors of the block.
    pub sensors: std::ops::Range<usize>,
    parts: usize,
    /// Per (part, level, sub-block of [`BLOCK`]): its first sensor and X (rows × 3 × width).
    x: Vec<(usize, usize, usize, Vec<f32>)>,
    /// Gauss–Seidel sweeps, summed over the block's systems.
    pub sweeps: u64,
    /// Wall time of the solves, s.
    pub seconds: f64,
}

/// One direction's source terms, lux-weighted: (row, per channel lw_c · ρ_c · W_c) on the
/// fine mesh and on the coarse one (area averages).
type Terms = (Vec<(u32, [f32; 3])>, Vec<(u32, [f32; 3])>);

impl Transport {
    /// Bytes of adjoint responses per sensor (all parts and both levels).
    pub fn adjoint_bytes_per_sensor(&self) -> u64 {
        self.parts.len() as u64 * (self.rows() + self.mesh.coarse_rows) as u64 * 3 * 4
    }

    /// Sensors per [`AdjointBlock`] so that one block's responses take at most `max_bytes`
    /// (a multiple of [`BLOCK`], at least one).
    pub fn adjoint_block_size(&self, max_bytes: u64) -> usize {
        let per = self.adjoint_bytes_per_sensor().max(1);
        ((max_bytes / per) as usize / BLOCK * BLOCK).max(BLOCK)
    }

    /// Solves the adjoint systems of the sensors `sensors` (all parts, both levels), in
    /// sub-blocks of [`BLOCK`] sensors counted from sensor 0, so the values do not depend on
    /// how a caller blocks them.
    pub fn adjoint_block(&self, sensors: std::ops::Range<usize>) -> AdjointBlock {
        let t0 = Instant::now();
        let parts = self.parts.len();
        let first = sensors.start / BLOCK * BLOCK;
        let subs: Vec<usize> = (first..sensors.end).step_by(BLOCK).collect();
        let jobs: Vec<(usize, usize, usize)> = (0..parts)
            .flat_map(|p| {
                let subs = &subs;
                (0..2).flat_map(move |l| subs.iter().map(move |&b| (p, l, b)))
            })
            .collect();
        let tol = self.params.tolerance;
        let max = self.params.max_sweeps;
        let k = self.parts.first().map_or(0, |p| p.g.rows());
        let solved: Vec<(Vec<f32>, u32)> = jobs
            .par_iter()
            .map(|&(p, l, b)| {
                let (f, g, rho) = self.level(p, l);
                adjoint_block(f, g, rho, b..(b + BLOCK).min(k), tol, max)
            })
            .collect();
        let sweeps = solved.iter().map(|s| s.1 as u64).sum();
        AdjointBlock {
            sensors,
            parts,
            x: jobs
                .into_iter()
                .zip(solved)
                .map(|((p, l, b), (x, _))| (p, l, b, x))
                .collect(),
            sweeps,
            seconds: t0.elapsed().as_secs_f64(),
        }
    }
}

impl AdjointBlock {
    /// The grey daylight coefficients at this block's sensors of one direction whose mesh
    /// irradiance per unit normal irradiance is `weights` ((row, RGB W/m² per W/m²)):
    /// `parts` rows of per-sensor fine indirect illuminance, then one row of the coarse
    /// level's mean over parts, each as wide as the block; lux per W/m².
    pub fn apply(&self, op: &Transport, weights: &[(u32, Rgb)]) -> Vec<f32> {
        let (fine, coarse) = op.terms(weights);
        let n = self.sensors.len();
        let k0 = self.sensors.start;
        let mut out = vec![0f32; (self.parts + 1) * n];
        let inv_parts = 1.0 / self.parts.max(1) as f32;
        let k = op.parts.first().map_or(0, |p| p.g.rows());
        for (p, l, b, x) in &self.x {
            let w = (b + BLOCK).min(k) - b;
            // The overlap of this sub-block with the block's sensors.
            let lo = (*b).max(k0);
            let hi = (b + w).min(self.sensors.end);
            if lo >= hi {
                continue;
            }
            let (src, row, scale) = if *l == 0 {
                (&fine, *p, 1.0)
            } else {
                (&coarse, self.parts, inv_parts)
            };
            let o = &mut out[row * n + (lo - k0)..row * n + (hi - k0)];
            for &(r, v) in src.iter() {
                for (c, &vc) in v.iter().enumerate() {
                    if vc == 0.0 {
                        continue;
                    }
                    let vc = vc * scale;
                    let xs = &x[(r as usize * 3 + c) * w + (lo - b)..][..hi - lo];
                    for (o, xv) in o.iter_mut().zip(xs) {
                        *o += vc * *xv;
                    }
                }
            }
        }
        out
    }
}

impl Transport {
    /// Source terms of one direction (see [`Terms`]); the coarse level reads the area
    /// average of the fine source over each coarse row, as [`Transport::solve`] does.
    fn terms(&self, w: &[(u32, Rgb)]) -> Terms {
        let lw = [
            lux(Rgb::new(1.0, 0.0, 0.0)),
            lux(Rgb::new(0.0, 1.0, 0.0)),
            lux(Rgb::new(0.0, 0.0, 1.0)),
        ];
        let s: Vec<(u32, Rgb)> = w
            .iter()
            .map(|&(r, e)| (r, self.rho[r as usize] * e))
            .filter(|(_, v)| *v != Rgb::ZERO)
            .collect();
        let coarse = self.coarse_source(&s);
        let weigh = |l: Vec<(u32, Rgb)>| -> Vec<(u32, [f32; 3])> {
            l.into_iter()
                .map(|(r, v)| {
                    (
                        r,
                        [
                            (v.x * lw[0]) as f32,
                            (v.y * lw[1]) as f32,
                            (v.z * lw[2]) as f32,
                        ],
                    )
                })
                .collect()
        };
        (weigh(s), weigh(coarse))
    }
}
