//! Grey daylight coefficients of many directions at once, by blocked adjoint solves: for
//! each direction n (its mesh irradiance per unit normal irradiance, `W_n`) and sensor s,
//! the indirect illuminance at s per W/m² of grey normal irradiance, Σ_r X\[r\]\[s\] · ρ_r
//! W_n,r, X the adjoint response of [`super::response`], in each independent part and
//! one mesh level coarser (the same noise and discretisation estimates as a forward
//! solve).
//!
//! Why this order: X is rows × 3 × sensors per part and level, which for 1 620 sensors on
//! a 20 000-row mesh would be 3 GB in f32. Sensors are therefore solved in blocks sized to a
//! memory budget; each block's X is applied to every direction and dropped, so memory is
//! the budget plus the coefficients (directions × sensors × (parts + 1) × 4 bytes). Each
//! adjoint system is still solved in fixed sub-blocks of [`BLOCK`] sensors, so the values
//! do not depend on the budget or the thread count.
//!
//! Grey: the coefficients are collapsed to illuminance (179 lm/W × the photopic weights),
//! which is exact when every source is grey (Perez skies, their ground glow and the sun:
//! what annual runs use); coloured skies keep the forward solve.
//!
//! Held in 16 bits (issue 28): a block's responses are solved in f32 and kept as
//! bfloat16, half the bytes, so a memory cap holds twice the sensors per block. Every
//! response and every source weight is non-negative, so a coefficient's rounding error is
//! at most [`RESPONSE_ROUNDOFF`] of its value; the stated error adds it. bfloat16 rather
//! than IEEE half: its f32 exponent range keeps the 10⁻⁸ responses of far site rows,
//! which half would flush to zero. The coarse level is read only as the mean of the
//! parts, so its responses are averaged over the parts (in f32) before they are held:
//! one coarse copy instead of one per part.

use super::response::{Adjoint, BLOCK};
use super::transport::Transport;
use crate::photometry::{lux, Rgb};
use half::bf16;
use rayon::prelude::*;
use std::time::Instant;

/// Largest relative rounding error of a held response (bfloat16's unit roundoff, 2⁻⁸),
/// and so of a daylight coefficient made of them (all terms non-negative).
pub const RESPONSE_ROUNDOFF: f64 = 1.0 / 256.0;

/// One sub-block's responses as held.
struct Held {
    /// The part, or `None` for the coarse level's mean over parts.
    part: Option<usize>,
    /// First sensor of the sub-block of [`BLOCK`].
    sub: usize,
    /// X as rows × channels × width.
    x: Vec<bf16>,
}

/// The adjoint responses of one block of sensors, all parts and both levels, ready to turn
/// any direction's mesh irradiance into its grey daylight coefficients at those sensors.
pub struct AdjointBlock {
    /// Sensors of the block.
    pub sensors: std::ops::Range<usize>,
    parts: usize,
    /// Channels of X: 3, or 1 for a grey operator ([`Transport::is_grey`]).
    channels: usize,
    /// Per sub-block of [`BLOCK`]: each part's fine X, then the coarse mean.
    x: Vec<Held>,
    /// Gauss–Seidel sweeps, summed over the block's systems.
    pub sweeps: u64,
    /// Wall time of the solves, s.
    pub seconds: f64,
}

/// One direction's source terms, lux-weighted: (row, per channel lw_c · ρ_c · W_c) on the
/// fine mesh and on the coarse one (area averages).
type Terms = (Vec<(u32, [f32; 3])>, Vec<(u32, [f32; 3])>);

impl Transport {
    /// Whether every reflectance and every operator entry (line transfer F and sensor
    /// gather G, both levels) is grey: the three colour channels' adjoint systems are then
    /// one, and the daylight coefficients solve it once (a third of the memory and time).
    pub fn is_grey(&self) -> bool {
        let grey_rgb = |v: &Rgb| v.x == v.y && v.y == v.z;
        let grey_sparse = |s: &super::sparse::Sparse| s.is_grey();
        self.rho.iter().all(grey_rgb)
            && self.coarse_rho.iter().all(grey_rgb)
            && self.parts.iter().all(|p| {
                grey_sparse(&p.f)
                    && grey_sparse(&p.g)
                    && grey_sparse(&p.f_coarse)
                    && grey_sparse(&p.g_coarse)
            })
    }

    /// Bytes the operator keeps resident while the adjoint solves read it: its sparse
    /// matrices held in memory (4-byte offsets and columns, 4-byte values, one per entry
    /// when grey, else three), the largest part's matrices read in place from its cache
    /// record (the solves give a part's pages back when done with it,
    /// [`Transport::release_pages`]), the per-row reflectance and emission, and the mesh
    /// (about 160 bytes per row with its element hierarchy).
    pub fn bytes(&self) -> u64 {
        let owned: u64 = self
            .parts
            .iter()
            .flat_map(|p| p.matrices())
            .map(|m| m.owned_bytes())
            .sum();
        let mapped = self
            .parts
            .iter()
            .map(|p| {
                p.matrices()
                    .iter()
                    .map(|m| m.bytes() - m.owned_bytes())
                    .sum::<u64>()
            })
            .max()
            .unwrap_or(0);
        owned + mapped + (self.rows() as u64) * (2 * 24 + 160) + self.mesh.coarse_rows as u64 * 32
    }

    /// Channels the adjoint responses keep: 1 for a grey operator, else 3.
    fn adjoint_channels(&self) -> usize {
        if self.is_grey() {
            1
        } else {
            3
        }
    }

    /// Bytes of adjoint responses held per sensor: every part's fine level and the coarse
    /// mean, 2 bytes per value.
    pub fn adjoint_bytes_per_sensor(&self) -> u64 {
        (self.parts.len() * self.rows() + self.mesh.coarse_rows) as u64
            * self.adjoint_channels() as u64
            * 2
    }

    /// Bytes the solves take beside the held responses with `threads` solving: one
    /// transposed operator (column and values per entry), and per thread a sub-block's f32
    /// responses and their right-hand side (rows × channels × [`BLOCK`] × 4 bytes each; the
    /// right-hand side is held only at the rows the sub-block's gathers reach, so this is
    /// its bound).
    pub fn adjoint_scratch_bytes(&self, threads: usize) -> u64 {
        let ch = self.adjoint_channels() as u64;
        let entries = self.parts.iter().map(|p| p.f.cols.len()).max().unwrap_or(0) as u64;
        let per_thread = 2 * self.rows() as u64 * ch * BLOCK as u64 * 4;
        threads as u64 * per_thread + entries * (4 + 4 * ch) + (self.rows() as u64 + 1) * 4
    }

    /// Sensors per [`AdjointBlock`] so that one block's responses take at most `max_bytes`
    /// (a multiple of [`BLOCK`], at least one).
    pub fn adjoint_block_size(&self, max_bytes: u64) -> usize {
        let per = self.adjoint_bytes_per_sensor().max(1);
        ((max_bytes / per) as usize / BLOCK * BLOCK).max(BLOCK)
    }

    /// The sensors per block for `sensors` sensors in blocks of at most `most` (a
    /// multiple of [`BLOCK`]): as many blocks as `most` needs, evened out, each a multiple
    /// of [`BLOCK`]. Blocks of 160 and 2 sensors held the first's responses through the
    /// second's solves; two of 96 hold a little over half as much, in the same time.
    pub fn balanced_block(sensors: usize, most: usize) -> usize {
        let blocks = sensors.div_ceil(most.max(1)).max(1);
        (sensors.div_ceil(blocks).div_ceil(BLOCK) * BLOCK).clamp(BLOCK, most.max(BLOCK))
    }

    /// Solves the adjoint systems of the sensors `sensors` (all parts, both levels), in
    /// sub-blocks of [`BLOCK`] sensors counted from sensor 0, so the values do not depend on
    /// how a caller blocks them.
    pub fn adjoint_block(&self, sensors: std::ops::Range<usize>) -> AdjointBlock {
        let t0 = Instant::now();
        let parts = self.parts.len();
        let first = sensors.start / BLOCK * BLOCK;
        let subs: Vec<usize> = (first..sensors.end).step_by(BLOCK).collect();
        let channels = self.adjoint_channels();
        let mut sweeps = 0u64;
        // From a slice, not in place: an in-place collect may keep the f32 allocation.
        let to_held = |part: Option<usize>, sub: usize, x: Vec<f32>| Held {
            part,
            sub,
            x: x.iter().map(|&v| bf16::from_f32(v)).collect(),
        };
        // The coarse level first, summed over parts in f32 (before any fine responses are
        // held; its rows are few), then its mean held in 16 bits.
        let mut sums: Vec<Vec<f32>> = Vec::new();
        for p in 0..parts {
            let (xs, n) = self.solve_subs(p, 1, &subs, |_, x| x);
            sweeps += n;
            if sums.is_empty() {
                sums = xs;
            } else {
                for (sum, x) in sums.iter_mut().zip(&xs) {
                    sum.iter_mut().zip(x).for_each(|(a, v)| *a += v);
                }
            }
        }
        let inv = 1.0 / parts.max(1) as f32;
        let mut x: Vec<Held> = sums
            .into_iter()
            .zip(&subs)
            .map(|(mut sum, &b)| {
                sum.iter_mut().for_each(|a| *a *= inv);
                to_held(None, b, sum)
            })
            .collect();
        for p in 0..parts {
            let (held, n) = self.solve_subs(p, 0, &subs, |b, xb| to_held(Some(p), b, xb));
            sweeps += n;
            x.extend(held);
        }
        AdjointBlock {
            sensors,
            parts,
            channels,
            x,
            sweeps,
            seconds: t0.elapsed().as_secs_f64(),
        }
    }

    /// Solves the adjoint systems of part `p` at level `l` (0 fine, 1 coarse) for the
    /// sub-blocks of [`BLOCK`] sensors starting at `subs`, in parallel against one
    /// transposed operator, each sub-block's f32 responses (rows × channels × width) passed
    /// to `keep` as soon as they are solved: a block never holds a whole part in f32
    /// beside what it keeps (that was half the block again at its last part, and took a
    /// run capped at 4 GiB to 4.7 GB). Returns what `keep` made, in `subs` order, and the
    /// sweeps.
    fn solve_subs<T: Send>(
        &self,
        p: usize,
        l: usize,
        subs: &[usize],
        keep: impl Fn(usize, Vec<f32>) -> T + Sync,
    ) -> (Vec<T>, u64) {
        let (f, g, rho) = self.level(p, l);
        let adjoint = Adjoint::of(f, rho, self.adjoint_channels());
        // The transposed copy is what the sweeps read: the operator's pages read in place
        // go back to the kernel, as do the gather's once the solves are done.
        self.release_pages();
        let k = self.parts.first().map_or(0, |p| p.g.rows());
        let (tol, max) = (self.params.tolerance, self.params.max_sweeps);
        let solved: Vec<(T, u32)> = subs
            .par_iter()
            .map(|&b| {
                let (x, n) = adjoint.solve(g, b..(b + BLOCK).min(k), tol, max);
                (keep(b, x), n)
            })
            .collect();
        self.release_pages();
        let sweeps = solved.iter().map(|s| s.1 as u64).sum();
        (solved.into_iter().map(|s| s.0).collect(), sweeps)
    }
}

impl AdjointBlock {
    /// The grey daylight coefficients at this block's sensors of one direction whose mesh
    /// irradiance per unit normal irradiance is `weights` ((row, RGB W/m² per W/m²)):
    /// `parts` rows of per-sensor fine indirect illuminance, then one row of the coarse
    /// level's mean over parts, each as wide as the block; lux per W/m².
    pub fn apply(&self, op: &Transport, weights: &[(u32, Rgb)]) -> Vec<f32> {
        let terms = [op.direction_terms(weights)];
        self.apply_many(op, &terms).pop().unwrap_or_default()
    }

    /// [`Self::apply`] for many directions at once (each its [`DirectionTerms`]), one
    /// result per direction, bit-identical to applying them one by one.
    ///
    /// Why: one direction's coefficients read the block's responses at every row it
    /// lights, hundreds of megabytes on a large grid, for a few multiply-adds per value
    /// read; memory bandwidth was the cold year's largest cost. Here each row's responses
    /// are read once for all the directions lighting it (the terms regrouped by row), so
    /// the responses stream once per batch. Per value, the sums run in the same order as
    /// one by one (parts and levels, then rows ascending, then channels).
    pub fn apply_many(&self, op: &Transport, terms: &[DirectionTerms]) -> Vec<Vec<f32>> {
        let n = self.sensors.len();
        let k0 = self.sensors.start;
        let nd = terms.len();
        let parts = self.parts;
        let stride = (parts + 1) * n;
        let k = op.parts.first().map_or(0, |p| p.g.rows());
        let ch = self.channels;
        // Per level, each row's (direction, weights), directions ascending.
        let by_row = |level: usize, rows: usize| {
            let mut offsets = vec![0u32; rows + 1];
            for t in terms {
                for &(r, _) in if level == 0 { &t.0 .0 } else { &t.0 .1 } {
                    offsets[r as usize + 1] += 1;
                }
            }
            for r in 0..rows {
                offsets[r + 1] += offsets[r];
            }
            let mut fill = offsets.clone();
            let mut entries = vec![(0u32, [0f32; 3]); offsets[rows] as usize];
            for (d, t) in terms.iter().enumerate() {
                for &(r, v) in if level == 0 { &t.0 .0 } else { &t.0 .1 } {
                    let at = &mut fill[r as usize];
                    entries[*at as usize] = (d as u32, v);
                    *at += 1;
                }
            }
            (offsets, entries)
        };
        let levels = [by_row(0, op.rows()), by_row(1, op.mesh.coarse_rows)];
        // Sub-blocks of sensors in parallel (disjoint columns); within one, parts and
        // levels in their order, as one by one.
        let mut subs: Vec<usize> = self.x.iter().map(|e| e.sub).collect();
        subs.sort_unstable();
        subs.dedup();
        let done: Vec<(usize, usize, Vec<f32>)> = subs
            .par_iter()
            .filter_map(|&b| {
                let w = (b + BLOCK).min(k) - b;
                // The overlap of this sub-block with the block's sensors.
                let lo = b.max(k0);
                let hi = (b + w).min(self.sensors.end);
                if lo >= hi {
                    return None;
                }
                let wb = hi - lo;
                let mut local = vec![0f32; nd * (parts + 1) * wb];
                for held in self.x.iter().filter(|e| e.sub == b) {
                    let (row, level) = held.part.map_or((parts, 1), |p| (p, 0));
                    let (offsets, entries) = &levels[level];
                    let s = super::spread::Spread {
                        x: &held.x,
                        offsets,
                        entries,
                        channels: ch,
                        width: w,
                        first: lo - b,
                        rows_per_direction: parts + 1,
                        row,
                    };
                    s.add_to(&mut local, wb);
                }
                Some((lo - k0, wb, local))
            })
            .collect();
        let mut out = vec![vec![0f32; stride]; nd];
        for (at, wb, local) in done {
            for (d, o) in out.iter_mut().enumerate() {
                for row in 0..=parts {
                    o[row * n + at..][..wb]
                        .copy_from_slice(&local[(d * (parts + 1) + row) * wb..][..wb]);
                }
            }
        }
        out
    }
}

/// One direction's source terms ([`Transport::direction_terms`]), ready for
/// [`AdjointBlock::apply_many`].
#[derive(Clone, Debug, Default)]
pub struct DirectionTerms(Terms);

impl DirectionTerms {
    /// Bytes [`Self::write_to`] writes: two counts, then 16 bytes an entry.
    pub fn encoded_bytes(&self) -> u64 {
        8 + 16 * (self.0 .0.len() + self.0 .1.len()) as u64
    }

    /// Writes the terms (little-endian, every f32 by its bits) for [`Self::read_from`]:
    /// a cold run's later adjoint blocks read them back instead of making them again.
    ///
    /// # Errors
    /// What `w` returns.
    pub fn write_to(&self, w: &mut impl std::io::Write) -> std::io::Result<()> {
        let (fine, coarse) = &self.0;
        let mut buf = Vec::with_capacity(self.encoded_bytes() as usize);
        for l in [fine, coarse] {
            buf.extend_from_slice(&(l.len() as u32).to_le_bytes());
        }
        for (r, v) in fine.iter().chain(coarse) {
            buf.extend_from_slice(&r.to_le_bytes());
            for c in v {
                buf.extend_from_slice(&c.to_bits().to_le_bytes());
            }
        }
        w.write_all(&buf)
    }

    /// The terms [`Self::write_to`] wrote, bit for bit.
    ///
    /// # Errors
    /// What `r` returns (a short read is `UnexpectedEof`).
    pub fn read_from(r: &mut impl std::io::Read) -> std::io::Result<DirectionTerms> {
        use std::io::Read;
        let mut counts = [0u8; 8];
        r.read_exact(&mut counts)?;
        let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let mut buf = Vec::new();
        let mut list = |n: u32| -> std::io::Result<Vec<(u32, [f32; 3])>> {
            // Read as the bytes come, not into a buffer sized by the count: a damaged
            // count then ends in a short read, not in a huge allocation.
            buf.clear();
            r.by_ref().take(16 * u64::from(n)).read_to_end(&mut buf)?;
            if buf.len() != 16 * n as usize {
                return Err(std::io::ErrorKind::UnexpectedEof.into());
            }
            Ok(buf
                .chunks_exact(16)
                .map(|e| {
                    let f = |i: usize| f32::from_bits(word(&e[4 * i..]));
                    (word(e), [f(1), f(2), f(3)])
                })
                .collect())
        };
        let fine = list(word(&counts))?;
        let coarse = list(word(&counts[4..]))?;
        Ok(DirectionTerms((fine, coarse)))
    }
}

impl Transport {
    /// The source terms of one direction whose mesh irradiance per unit normal irradiance
    /// is `weights` ((row, RGB W/m² per W/m²), rows ascending).
    pub fn direction_terms(&self, weights: &[(u32, Rgb)]) -> DirectionTerms {
        DirectionTerms(self.terms(weights))
    }

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

#[cfg(test)]
mod tests {
    use super::super::response::BLOCK;
    use super::super::Transport;
    use super::DirectionTerms;

    /// Balanced blocks are whole sub-blocks, no larger than asked and no more of them.
    #[test]
    fn balanced_blocks_even_out_within_the_most() {
        assert_eq!(
            Transport::balanced_block(162, 160),
            96,
            "160 + 2 became 96 + 66"
        );
        assert_eq!(Transport::balanced_block(1620, 224), 224);
        for k in (1..3000).step_by(7) {
            for most in [BLOCK, 64, 160, 224, 1024] {
                let b = Transport::balanced_block(k, most);
                assert!(
                    b % BLOCK == 0 && b <= most,
                    "{k} sensors, at most {most}: {b}"
                );
                assert!(k.div_ceil(b) <= k.div_ceil(most), "{k}, {most}: {b}");
            }
        }
    }

    fn bits(t: &DirectionTerms) -> Vec<u32> {
        let (fine, coarse) = &t.0;
        [fine, coarse]
            .iter()
            .flat_map(|l| {
                std::iter::once(l.len() as u32).chain(
                    l.iter().flat_map(|(r, v)| {
                        std::iter::once(*r).chain(v.iter().map(|c| c.to_bits()))
                    }),
                )
            })
            .collect()
    }

    #[test]
    fn direction_terms_read_back_bit_for_bit_and_a_short_or_damaged_file_is_an_error() {
        let t = DirectionTerms((
            vec![
                (0, [1.0, -0.0, f32::MIN_POSITIVE]),
                (70_000, [3.5e-9, 2.0, 1e30]),
            ],
            vec![(3, [0.25, 0.5, 0.75])],
        ));
        let empty = DirectionTerms::default();
        let mut buf = Vec::new();
        for x in [&t, &empty, &t] {
            x.write_to(&mut buf).unwrap();
        }
        let want = 2 * t.encoded_bytes() + empty.encoded_bytes();
        assert_eq!(buf.len() as u64, want);
        let mut r = &buf[..];
        for x in [&t, &empty, &t] {
            assert_eq!(bits(&DirectionTerms::read_from(&mut r).unwrap()), bits(x));
        }
        assert!(DirectionTerms::read_from(&mut r).is_err(), "nothing left");
        let mut damaged = buf.clone();
        damaged[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = DirectionTerms::read_from(&mut &damaged[..]).unwrap_err();
        assert_eq!(
            e.kind(),
            std::io::ErrorKind::UnexpectedEof,
            "a count past the end"
        );
        let n = t.encoded_bytes() as usize;
        for cut in [0, 3, 8, n - 1] {
            let mut short = &buf[..cut];
            assert!(
                DirectionTerms::read_from(&mut short).is_err(),
                "cut at {cut}"
            );
        }
    }
}
