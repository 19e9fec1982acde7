//! Sensor responses through the global-line operator, by its adjoint: for every mesh row r
//! and sensor s, X\[r\]\[s\] = ∂(indirect irradiance at s)/∂(unshot exitance S_r), the
//! solution of X_r = G_sr + Σ_k ρ_k F_kr X_k (the transpose of B = S + ρ ⊙ F B, read by
//! the sensor gather G). With X, a sensor's indirect irradiance for any source is
//! Σ_r X\[r\]\[s\] ⊙ S_r: no per-timestep solve.
//!
//! Why: an annual run solves the same operator for thousands of source vectors but reads
//! it at only a few hundred sensors. One adjoint solve per sensor (all sensors at once, as
//! vectors) replaces one forward solve per timestep, and a source direction's response
//! becomes a short vector per sensor (a daylight coefficient) that every later timestep
//! reuses. The result is the forward solution reordered, so it equals
//! [`Transport::sensors`] within the iteration tolerance, with the same noise (spread of
//! the parts) and discretisation (coarse level) estimates.
//!
//! Memory is rows × sensors × 3 × 4 bytes per part and level, so [`Transport::response`]
//! declines (returns `None`) above a byte budget and callers keep the forward solve.

use super::sparse::Sparse;
use super::transport::Transport;
use super::TransportSensor;
use crate::photometry::Rgb;
use rayon::prelude::*;
use std::time::Instant;

/// Sensors solved together (a fixed block: results do not depend on the thread count).
pub const BLOCK: usize = 32;

/// The adjoint responses of a [`Transport`]'s sensors (see the module doc).
#[derive(Clone, Debug)]
pub struct SensorResponse {
    sensors: usize,
    /// Per (part, level) with level 0 fine and 1 coarse: rows × 3 × sensors, f32, channel
    /// planes per row (X[r][c][s]).
    x: Vec<Vec<f32>>,
    /// Per (part, level): the response to the scene's own emitters, 3 × sensors.
    emitted: Vec<Vec<f32>>,
    /// Gauss–Seidel sweeps summed over parts, levels and sensor blocks.
    pub sweeps: u64,
    /// Wall time of the solve, s.
    pub seconds: f64,
}

/// One source direction's daylight coefficients: per (part, level), 3 × sensors values of
/// indirect irradiance (W/m²) per unit normal irradiance of the source (W/m²).
#[derive(Clone, Debug, Default)]
pub struct DirectionResponse(Vec<f32>);

impl Transport {
    /// The adjoint responses of this operator's sensors, or `None` when they would take
    /// more than `max_bytes` (then use [`Transport::solve`] per timestep).
    pub fn response(&self, max_bytes: u64) -> Option<SensorResponse> {
        let t0 = Instant::now();
        let k = self.parts.first().map_or(0, |p| p.g.rows());
        let rows = self.rows() + self.mesh.coarse_rows;
        let bytes = self.parts.len() as u64 * rows as u64 * 3 * k as u64 * 4;
        if bytes > max_bytes || self.parts.is_empty() {
            return None;
        }
        let tol = self.params.tolerance;
        let max = self.params.max_sweeps;
        let blocks = k.div_ceil(BLOCK).max(1);
        // One transposed operator per part and level, shared by its sensor blocks.
        let solved: Vec<(Vec<f32>, u32)> = (0..self.parts.len())
            .flat_map(|p| (0..2).map(move |l| (p, l)))
            .flat_map(|(p, l)| {
                let (f, g, rho) = self.level(p, l);
                let adjoint = Adjoint::of(f, rho, 3);
                (0..blocks)
                    .into_par_iter()
                    .map(|b| {
                        let s0 = b * BLOCK;
                        adjoint.solve(g, s0..(s0 + BLOCK).min(k), tol, max)
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let mut x: Vec<Vec<f32>> = Vec::new();
        let mut sweeps = 0u64;
        let mut it = solved.into_iter();
        for _p in 0..self.parts.len() {
            for l in 0..2 {
                let n = if l == 0 {
                    self.rows()
                } else {
                    self.mesh.coarse_rows
                };
                let mut full = vec![0f32; n * 3 * k];
                for b in 0..blocks {
                    let (xb, sw) = it.next().expect("one result per job");
                    sweeps += sw as u64;
                    let s0 = b * BLOCK;
                    let w = (s0 + BLOCK).min(k) - s0;
                    for r in 0..n {
                        for c in 0..3 {
                            let dst = (r * 3 + c) * k + s0;
                            let src = (r * 3 + c) * w;
                            full[dst..dst + w].copy_from_slice(&xb[src..src + w]);
                        }
                    }
                }
                x.push(full);
            }
        }
        let mut resp = SensorResponse {
            sensors: k,
            x,
            emitted: Vec::new(),
            sweeps,
            seconds: 0.0,
        };
        resp.emitted = resp.apply(self, &self.emit);
        resp.seconds = t0.elapsed().as_secs_f64();
        Some(resp)
    }
}

impl SensorResponse {
    /// Number of sensors.
    pub fn sensors(&self) -> usize {
        self.sensors
    }

    /// Per (part, level), 3 × sensors: the response to unshot exitance `s` given on the
    /// fine rows (the coarse level reads its area average, as [`Transport::solve`] does).
    fn apply(&self, op: &Transport, s: &[Rgb]) -> Vec<Vec<f32>> {
        let sparse: Vec<(u32, Rgb)> = s
            .iter()
            .enumerate()
            .filter(|(_, v)| **v != Rgb::ZERO)
            .map(|(r, v)| (r as u32, *v))
            .collect();
        self.apply_sparse(op, &sparse)
    }

    fn apply_sparse(&self, op: &Transport, s: &[(u32, Rgb)]) -> Vec<Vec<f32>> {
        let k = self.sensors;
        let coarse = op.coarse_source(s);
        self.x
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let src = if i % 2 == 0 { s } else { &coarse[..] };
                // f32 lanes: this loop is the per-direction cost (rows × 3 × sensors).
                let mut out = vec![0f32; 3 * k];
                for &(r, v) in src {
                    for c in 0..3 {
                        let w = v[c] as f32;
                        if w == 0.0 {
                            continue;
                        }
                        let row = &x[(r as usize * 3 + c) * k..][..k];
                        for (o, xv) in out[c * k..(c + 1) * k].iter_mut().zip(row) {
                            *o += w * *xv;
                        }
                    }
                }
                out
            })
            .collect()
    }

    /// The daylight coefficients of one source direction, from its mesh irradiance per
    /// unit normal irradiance `weights` (row, RGB W/m² per W/m²).
    pub fn direction(&self, op: &Transport, weights: &[(u32, Rgb)]) -> DirectionResponse {
        let s: Vec<(u32, Rgb)> = weights
            .iter()
            .map(|&(r, w)| (r, op.rho[r as usize] * w))
            .filter(|(_, v)| *v != Rgb::ZERO)
            .collect();
        DirectionResponse(self.apply_sparse(op, &s).into_iter().flatten().collect())
    }

    /// A zeroed accumulator for [`SensorResponse::add`], holding the emitters' response.
    pub fn start(&self) -> Vec<f64> {
        self.emitted.iter().flatten().map(|&v| v as f64).collect()
    }

    /// Adds one source of normal irradiance `e` (RGB W/m²) with coefficients `d` to `acc`.
    pub fn add(&self, acc: &mut [f64], e: Rgb, d: &DirectionResponse) {
        let k = self.sensors;
        for (i, (a, v)) in acc.chunks_mut(k).zip(d.0.chunks(k)).enumerate() {
            let w = e[i % 3];
            if w == 0.0 {
                continue;
            }
            for (a, v) in a.iter_mut().zip(v) {
                *a += w * *v as f64;
            }
        }
    }

    /// Each sensor's indirect irradiance from an accumulator, with the same mean, noise
    /// and discretisation estimates as [`Transport::sensors`].
    pub fn sensors_of(&self, acc: &[f64]) -> Vec<TransportSensor> {
        let k = self.sensors;
        let parts = self.x.len() / 2;
        let n = parts as f64;
        let at = |p: usize, l: usize, s: usize| -> Rgb {
            let base = (p * 2 + l) * 3 * k;
            Rgb::new(acc[base + s], acc[base + k + s], acc[base + 2 * k + s])
        };
        (0..k)
            .map(|s| {
                let fine: Vec<Rgb> = (0..parts).map(|p| at(p, 0, s)).collect();
                let coarse = (0..parts).fold(Rgb::ZERO, |a, p| a + at(p, 1, s)) / n;
                TransportSensor::from_parts(&fine, coarse)
            })
            .collect()
    }
}

impl Transport {
    /// Part `p`'s operator, gather and reflectances at level `l` (0 fine, 1 coarse).
    pub(super) fn level(&self, p: usize, l: usize) -> (&Sparse, &Sparse, &[Rgb]) {
        let part = &self.parts[p];
        if l == 0 {
            (&part.f, &part.g, &self.rho[..])
        } else {
            (&part.f_coarse, &part.g_coarse, &self.coarse_rho[..])
        }
    }

    /// The coarse level's source of a sparse fine source `s` ((row, value)): the area
    /// average over each coarse row's children, as [`Transport::solve`] takes it.
    pub(super) fn coarse_source(&self, s: &[(u32, Rgb)]) -> Vec<(u32, Rgb)> {
        let mut acc: Vec<(u32, Rgb)> = s
            .iter()
            .map(|&(r, v)| {
                (
                    self.mesh.coarse_of[r as usize],
                    v * self.mesh.area[r as usize],
                )
            })
            .collect();
        acc.sort_by_key(|e| e.0);
        let mut coarse: Vec<(u32, Rgb)> = Vec::new();
        for (c, v) in acc {
            match coarse.last_mut() {
                Some((lc, lv)) if *lc == c => *lv += v,
                _ => coarse.push((c, v)),
            }
        }
        for (c, v) in &mut coarse {
            let a = self.coarse_area[*c as usize];
            *v = if a > 0.0 { *v / a } else { Rgb::ZERO };
        }
        coarse
    }
}

/// Entries of an operator read between two givings-back of their pages while it is
/// transposed ([`Adjoint::of`]): 4 MB of columns.
const RELEASE_ENTRIES: usize = 1 << 20;

/// One part and level's adjoint operator: Fᵀ with ρ of the source row folded in, as the
/// adjoint's Gauss–Seidel reads it (row i lists (k, ρ_k F_ki), `channels` values per
/// entry). Made once and shared by every block of sensors solved against it: the
/// transposition is a random-access pass over every entry, as costly as a sweep.
pub(super) struct Adjoint {
    /// Row i's entries are `count[i]..count[i + 1]`.
    count: Vec<u32>,
    cols: Vec<u32>,
    vals: Vec<f32>,
    channels: usize,
    /// Largest reflectance (at least 0.5): the first sweep's contraction estimate.
    rho_max: f64,
}

/// The right-hand side of a block's adjoint systems, Gᵀ, at the rows where it is not all
/// zero: `rows` ascending, and each one's channels × width values in `vals`, as the dense
/// rows × channels × width array would hold them (the same sums in the same order).
struct Rhs {
    rows: Vec<u32>,
    vals: Vec<f32>,
}

impl Rhs {
    /// Gᵀ of gather `g` for the sensors `range`, `ch` values per entry.
    fn of(g: &super::sparse::View, range: std::ops::Range<usize>, ch: usize) -> Rhs {
        let w = range.len();
        let span = ch * w;
        // (row, place in the row, value) in the order the dense sums took them; a stable
        // sort by row keeps that order within each place.
        let mut entries: Vec<(u32, u32, f32)> = Vec::new();
        for (j, s) in range.enumerate() {
            for e in g.offsets[s] as usize..g.offsets[s + 1] as usize {
                let v = g.val(e);
                for (c, &vc) in v.iter().enumerate().take(ch) {
                    entries.push((g.cols[e], (c * w + j) as u32, vc));
                }
            }
        }
        entries.sort_by_key(|e| e.0);
        let mut rows: Vec<u32> = Vec::new();
        let mut vals: Vec<f32> = Vec::new();
        for (r, at, v) in entries {
            if rows.last() != Some(&r) {
                rows.push(r);
                vals.resize(vals.len() + span, 0.0);
            }
            let base = vals.len() - span;
            vals[base + at as usize] += v;
        }
        Rhs { rows, vals }
    }

    /// Row `i`'s values (`span` of them), or `None` where it is all zero; rows are asked
    /// for in ascending order, `at` keeping the place (0 at a sweep's start).
    #[inline(always)]
    fn row(&self, at: &mut usize, i: usize, span: usize) -> Option<&[f32]> {
        if self.rows.get(*at).is_some_and(|&r| r as usize == i) {
            let v = &self.vals[*at * span..(*at + 1) * span];
            *at += 1;
            Some(v)
        } else {
            None
        }
    }
}

impl Adjoint {
    /// The adjoint of operator `f` with reflectances `rho`, keeping `channels` values per
    /// entry.
    pub(super) fn of(f_in: &Sparse, rho: &[Rgb], channels: usize) -> Adjoint {
        let f = f_in.view();
        let n = f.rows();
        let ch = channels;
        let mut count = vec![0u32; n + 1];
        for &c in f.cols {
            count[c as usize + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut cols = vec![0u32; f.cols.len()];
        // `ch` values per entry: a grey block keeps one.
        let mut vals = vec![0f32; ch * f.cols.len()];
        // The entries are read once, in order: where they are read in place, what has been
        // read goes back to the kernel as the pass goes, so that F and its transpose are
        // not resident together (on the corridor building, 35 MB at the solves' peak).
        let mut released = 0usize;
        for (kr, (&r, w)) in rho.iter().zip(f.offsets.windows(2)).enumerate() {
            if w[0] as usize - released >= RELEASE_ENTRIES {
                f_in.release_entries(released..w[0] as usize);
                released = w[0] as usize;
            }
            for e in w[0] as usize..w[1] as usize {
                let i = f.cols[e] as usize;
                let at = fill[i] as usize;
                fill[i] += 1;
                cols[at] = kr as u32;
                let v = f.val(e);
                let rv = [
                    (r.x * v[0] as f64) as f32,
                    (r.y * v[1] as f64) as f32,
                    (r.z * v[2] as f64) as f32,
                ];
                vals[at * ch..(at + 1) * ch].copy_from_slice(&rv[..ch]);
            }
        }
        let rho_max = rho.iter().map(|r| r.max_element()).fold(0.5, f64::max);
        Adjoint {
            count,
            cols,
            vals,
            channels,
            rho_max,
        }
    }

    /// Gauss–Seidel for the sensors `range` of gather `g`: returns X as rows × channels
    /// × |range| and the sweeps done. With one channel (grey ρ, F and G,
    /// [`Transport::is_grey`]) the three systems are one, solved once with channel 0's
    /// values (the same arithmetic as each of the three).
    pub(super) fn solve(
        &self,
        g: &Sparse,
        range: std::ops::Range<usize>,
        tol: f64,
        max_sweeps: u32,
    ) -> (Vec<f32>, u32) {
        let g = g.view();
        let n = self.count.len() - 1;
        let w = range.len();
        let ch = self.channels;
        if w == 0 || n == 0 {
            return (vec![0.0; n * ch * w], 0);
        }
        // Gᵀ for the block, kept only at the rows some sensor's gather reaches (a dense
        // copy was a second rows × channels × width array per thread beside X); x starts
        // at it.
        let gt = Rhs::of(&g, range, ch);
        let g_max = gt.vals.iter().fold(0f32, |a, v| a.max(v.abs()));
        let mut x = vec![0f32; n * ch * w];
        let span = ch * w;
        for (&r, v) in gt.rows.iter().zip(gt.vals.chunks_exact(span)) {
            x[r as usize * span..(r as usize + 1) * span].copy_from_slice(v);
        }
        if g_max == 0.0 {
            return (x, 0);
        }
        let floor = 1e-6 * g_max;
        let mut new = vec![0f32; ch * w];
        let mut prev_change = f64::INFINITY;
        for sweep in 1..=max_sweeps {
            let change = self.sweep(&gt, &mut x, &mut new, w, floor);
            let q = if prev_change.is_finite() && prev_change > 0.0 {
                (change / prev_change).clamp(0.5, 0.999)
            } else {
                self.rho_max
            };
            prev_change = change;
            if change * q / (1.0 - q) <= tol {
                return (x, sweep);
            }
        }
        (x, max_sweeps)
    }

    /// One Gauss–Seidel sweep over every row of X (rows × channels × `w`, updated in
    /// place, with `gt` its right-hand side and `new` one row's scratch); returns the
    /// largest relative change of a row (below `floor` absolute). Built for AVX2 where
    /// the CPU has it: the same operations in the same order, so bit-identical.
    #[allow(unsafe_code)] // calling the AVX2 build once the CPU is known to have AVX2
    fn sweep(&self, gt: &Rhs, x: &mut [f32], new: &mut [f32], w: usize, floor: f32) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.sweep_avx2(gt, x, new, w, floor) };
        }
        self.sweep_any(gt, x, new, w, floor)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sweep_avx2(&self, gt: &Rhs, x: &mut [f32], new: &mut [f32], w: usize, floor: f32) -> f64 {
        self.sweep_any(gt, x, new, w, floor)
    }

    #[inline(always)]
    fn sweep_any(&self, gt: &Rhs, x: &mut [f32], new: &mut [f32], w: usize, floor: f32) -> f64 {
        match (self.channels, w) {
            (1, BLOCK) => return self.sweep_block::<1>(gt, x, floor),
            (3, BLOCK) => return self.sweep_block::<3>(gt, x, floor),
            _ => {}
        }
        let n = self.count.len() - 1;
        let ch = self.channels;
        let (count, cols, vals) = (&self.count, &self.cols, &self.vals);
        let span = ch * w;
        let mut change = 0f64;
        let mut at = 0;
        for i in 0..n {
            match gt.row(&mut at, i, span) {
                Some(g) => new.copy_from_slice(g),
                None => new.fill(0.0),
            }
            for e in count[i] as usize..count[i + 1] as usize {
                let src = cols[e] as usize * span;
                let v = &vals[e * ch..(e + 1) * ch];
                for (c, &coef) in v.iter().enumerate() {
                    if coef == 0.0 {
                        continue;
                    }
                    let xs = &x[src + c * w..src + (c + 1) * w];
                    for (o, xv) in new[c * w..(c + 1) * w].iter_mut().zip(xs) {
                        *o += coef * *xv;
                    }
                }
            }
            let old = &mut x[i * span..(i + 1) * span];
            let (mut d, mut m) = (0f32, 0f32);
            for (o, nv) in old.iter().zip(new.iter()) {
                d = d.max((nv - o).abs());
                m = m.max(nv.abs());
            }
            change = change.max(d as f64 / m.max(floor) as f64);
            old.copy_from_slice(new);
        }
        change
    }

    /// [`Self::sweep_any`] for a whole block of sensors, reading X and its right-hand side
    /// `gt` as rows of one channel's [`BLOCK`] values, `CH` (channels) of them per mesh
    /// row. At a fixed width and a constant channel count the compiler unrolls each entry
    /// into a few vector operations with no bounds checks: 3.2× fewer CPU samples in the
    /// sweep than the variable-width loop on the 10 k building, and 1.5× fewer than the
    /// fixed width with the channel count known only at run time (a software prefetch of
    /// the rows ahead made it slower, and was left out). The same operations in the same
    /// order, so bit-identical.
    #[inline(always)]
    fn sweep_block<const CH: usize>(&self, gt: &Rhs, x: &mut [f32], floor: f32) -> f64 {
        // Row `r` of a one-channel-wide view of X or of a row of `gt`, at its fixed width.
        fn row(v: &[f32], r: usize) -> &[f32; BLOCK] {
            v[r * BLOCK..(r + 1) * BLOCK]
                .try_into()
                .expect("BLOCK wide")
        }
        let (count, cols, vals) = (&self.count, &self.cols, &self.vals);
        let mut change = 0f64;
        let mut new = [[0f32; BLOCK]; CH];
        let mut at = 0;
        for i in 0..count.len() - 1 {
            match gt.row(&mut at, i, CH * BLOCK) {
                Some(g) => {
                    for (c, n) in new.iter_mut().enumerate() {
                        *n = *row(g, c);
                    }
                }
                None => new = [[0f32; BLOCK]; CH],
            }
            for e in count[i] as usize..count[i + 1] as usize {
                let k = cols[e] as usize;
                for (c, &coef) in vals[e * CH..(e + 1) * CH].iter().enumerate() {
                    if coef == 0.0 {
                        continue;
                    }
                    for (o, xv) in new[c].iter_mut().zip(row(x, k * CH + c)) {
                        *o += coef * *xv;
                    }
                }
            }
            let old = &mut x[i * CH * BLOCK..(i + 1) * CH * BLOCK];
            let (mut d, mut m) = (0f32, 0f32);
            for (o, nv) in old.iter().zip(new.as_flattened()) {
                d = d.max((nv - o).abs());
                m = m.max(nv.abs());
            }
            change = change.max(d as f64 / m.max(floor) as f64);
            old.copy_from_slice(new.as_flattened());
        }
        change
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sparse_right_hand_side_holds_the_dense_sums_bit_for_bit() {
        // Five sensors' gathers over seven mesh rows, RGB, rows hit two and three times by
        // one sensor with values of unlike sizes (the sums' order matters to the bits),
        // rows 2 and 5 reached by none.
        let offsets = vec![0u32, 2, 5, 5, 9, 10];
        let cols = vec![0u32, 3, 1, 1, 6, 3, 4, 3, 3, 6];
        let mut vals: Vec<f32> = (0..cols.len() * 3)
            .map(|i| (i as f32 * 0.37).sin() * 10f32.powi((i % 7) as i32 - 3))
            .collect();
        // Sensor 3's three entries at row 3: 1 + 3e-8 + 3e-8 is 1 in f32 in this order,
        // not in the reverse one.
        for (e, v) in [(5, 1.0), (7, 3e-8), (8, 3e-8)] {
            vals[3 * e..3 * e + 3].fill(v);
        }
        let g = Sparse::from_parts(offsets.into(), cols.into(), vals.into(), (5, 7)).unwrap();
        for ch in [1, 3] {
            for range in [0..5, 1..4, 2..3] {
                let (w, span) = (range.len(), ch * range.len());
                let mut dense = vec![0f32; 7 * span];
                for (j, s) in range.clone().enumerate() {
                    let v = g.view();
                    for e in v.offsets[s] as usize..v.offsets[s + 1] as usize {
                        for c in 0..ch {
                            dense[(v.cols[e] as usize * ch + c) * w + j] += v.val(e)[c];
                        }
                    }
                }
                let rhs = Rhs::of(&g.view(), range.clone(), ch);
                let mut at = 0;
                for i in 0..7 {
                    let want = &dense[i * span..(i + 1) * span];
                    match rhs.row(&mut at, i, span) {
                        Some(got) => {
                            let bits =
                                |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                            assert_eq!(bits(got), bits(want), "row {i}, {ch} channels, {range:?}");
                        }
                        None => assert!(want.iter().all(|&x| x == 0.0), "row {i} dropped"),
                    }
                }
                assert!(rhs.rows.len() < 7, "rows no gather reaches are not held");
            }
        }
    }
}
