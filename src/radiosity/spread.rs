//! The batched apply's kernel: one held adjoint response (a sub-block of sensors, in
//! bfloat16) spread over every direction lighting its rows, for
//! [`super::coefficients::AdjointBlock::apply_many`].

use super::response::BLOCK;
use half::bf16;

/// One held response and the directions lighting its rows.
pub(super) struct Spread<'a> {
    /// X as rows × channels × `width`.
    pub(super) x: &'a [bf16],
    /// Per mesh row, its first entry in `entries`.
    pub(super) offsets: &'a [u32],
    /// (direction, lux-weighted RGB weight), grouped by row.
    pub(super) entries: &'a [(u32, [f32; 3])],
    pub(super) channels: usize,
    pub(super) width: usize,
    /// First column of X read.
    pub(super) first: usize,
    /// Result rows per direction (parts and the coarse level).
    pub(super) rows_per_direction: usize,
    /// This response's result row.
    pub(super) row: usize,
}

impl Spread<'_> {
    /// `local[(d · rows_per_direction + row) · wb ..][..wb] += Σ weight · X` over the
    /// `wb` columns from `first`, rows ascending, then each row's directions, then
    /// channels.
    ///
    /// Why a kernel of its own: this loop was the cold building year's second cost (13 %
    /// of CPU samples), built for the baseline CPU and for any width. The AVX2 build at
    /// the fixed width of a whole sub-block lets the compiler keep one direction's
    /// [`BLOCK`] sums in vector registers; the same operations in the same order, so
    /// bit-identical.
    #[allow(unsafe_code)] // calling the AVX2 build once the CPU is known to have AVX2
    pub(super) fn add_to(&self, local: &mut [f32], wb: usize) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.add_to_avx2(local, wb) };
        }
        self.add_to_any(local, wb)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn add_to_avx2(&self, local: &mut [f32], wb: usize) {
        self.add_to_any(local, wb)
    }

    #[inline(always)]
    fn add_to_any(&self, local: &mut [f32], wb: usize) {
        if wb == BLOCK && self.width == BLOCK {
            match self.channels {
                1 => return self.add_block::<1>(local),
                3 => return self.add_block::<3>(local),
                _ => {}
            }
        }
        self.add_any_width(local, wb)
    }

    /// [`Self::add_to_any`] at any width and channel count.
    #[inline(always)]
    fn add_any_width(&self, local: &mut [f32], wb: usize) {
        let (ch, w) = (self.channels, self.width);
        for r in 0..self.offsets.len() - 1 {
            let (e0, e1) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
            for &(d, v) in &self.entries[e0..e1] {
                let o = &mut local[(d as usize * self.rows_per_direction + self.row) * wb..][..wb];
                // Grey: one X for the three channels, so their weights add.
                let grey = [v[0] + v[1] + v[2]];
                let v: &[f32] = if ch == 1 { &grey } else { &v };
                for (c, &vc) in v.iter().enumerate() {
                    if vc == 0.0 {
                        continue;
                    }
                    let xs = &self.x[(r * ch + c) * w + self.first..][..wb];
                    for (o, xv) in o.iter_mut().zip(xs) {
                        *o += vc * xv.to_f32();
                    }
                }
            }
        }
    }

    /// [`Self::add_to_any`] for a whole sub-block (`first` 0, [`BLOCK`] wide) of `CH`
    /// channels.
    #[inline(always)]
    fn add_block<const CH: usize>(&self, local: &mut [f32]) {
        for r in 0..self.offsets.len() - 1 {
            let (e0, e1) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
            if e0 == e1 {
                continue;
            }
            // The row's X once in f32, for all the directions lighting it.
            let mut xf = [[0f32; BLOCK]; CH];
            for (c, xc) in xf.iter_mut().enumerate() {
                let xs: &[bf16; BLOCK] = self.x[(r * CH + c) * BLOCK..][..BLOCK]
                    .try_into()
                    .expect("BLOCK wide");
                for (o, v) in xc.iter_mut().zip(xs) {
                    *o = v.to_f32();
                }
            }
            for &(d, v) in &self.entries[e0..e1] {
                let at = (d as usize * self.rows_per_direction + self.row) * BLOCK;
                let o: &mut [f32; BLOCK] =
                    (&mut local[at..at + BLOCK]).try_into().expect("BLOCK wide");
                let grey = [v[0] + v[1] + v[2]];
                let v: &[f32] = if CH == 1 { &grey } else { &v };
                for (c, &vc) in v.iter().enumerate() {
                    if vc == 0.0 {
                        continue;
                    }
                    for (o, xv) in o.iter_mut().zip(&xf[c]) {
                        *o += vc * *xv;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Spread, BLOCK};
    use half::bf16;

    /// The whole-sub-block kernel gives the bits of the any-width loop, grey and
    /// coloured, with zero weights and unlit rows among them.
    #[test]
    fn whole_sub_block_kernel_matches_the_any_width_loop() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 40) as f32) / (1u64 << 24) as f32
        };
        for ch in [1usize, 3] {
            let rows = 7;
            let x: Vec<bf16> = (0..rows * ch * BLOCK)
                .map(|_| bf16::from_f32(next()))
                .collect();
            // Row 2 unlit; some weights zero.
            let counts = [2u32, 1, 0, 3, 1, 2, 1];
            let mut offsets = vec![0u32];
            let mut entries = Vec::new();
            for &c in &counts {
                for e in 0..c {
                    let v = [next(), if e == 1 { 0.0 } else { next() }, next()];
                    entries.push(((e + c) % 3, v));
                }
                offsets.push(entries.len() as u32);
            }
            let spread = Spread {
                x: &x,
                offsets: &offsets,
                entries: &entries,
                channels: ch,
                width: BLOCK,
                first: 0,
                rows_per_direction: 2,
                row: 1,
            };
            let (mut a, mut b) = (vec![0.5f32; 3 * 2 * BLOCK], vec![0.5f32; 3 * 2 * BLOCK]);
            spread.add_to(&mut a, BLOCK);
            spread.add_any_width(&mut b, BLOCK);
            assert!(
                a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits()),
                "{ch}"
            );
            assert!(
                a[BLOCK..2 * BLOCK].iter().any(|&v| v != 0.5),
                "{ch}: rows written"
            );
            assert!(
                a[..BLOCK].iter().all(|&v| v == 0.5),
                "{ch}: other rows untouched"
            );
        }
    }
}
