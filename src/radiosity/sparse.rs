//! Sparse RGB matrices of the operator and the gather: compressed rows with f32 values,
//! a row–vector product and column aggregation (for the coarse level).

use crate::photometry::Rgb;

/// Sparse rows: row r holds (column, value) pairs `cols[offsets[r]..offsets[r+1]]`.
#[derive(Clone, Debug, Default)]
pub(super) struct Sparse {
    pub(super) offsets: Vec<u32>,
    pub(super) cols: Vec<u32>,
    pub(super) vals: Vec<[f32; 3]>,
}

impl Sparse {
    pub(super) fn row_dot(&self, r: usize, x: &[Rgb]) -> Rgb {
        let (a, b) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
        let mut s = Rgb::ZERO;
        for k in a..b {
            let v = self.vals[k];
            let xj = x[self.cols[k] as usize];
            s += Rgb::new(v[0] as f64 * xj.x, v[1] as f64 * xj.y, v[2] as f64 * xj.z);
        }
        s
    }

    pub(super) fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Builds rows from (row, col, value) triples sorted by (row, col), no duplicates.
    pub(super) fn from_sorted(
        n_rows: usize,
        entries: impl Iterator<Item = (u32, u32, [f32; 3])>,
    ) -> Sparse {
        let mut offsets = vec![0u32; n_rows + 1];
        let mut cols = Vec::new();
        let mut vals = Vec::new();
        for (r, c, v) in entries {
            offsets[r as usize + 1] += 1;
            cols.push(c);
            vals.push(v);
        }
        for r in 0..n_rows {
            offsets[r + 1] += offsets[r];
        }
        Sparse {
            offsets,
            cols,
            vals,
        }
    }

    /// Aggregates columns through `map` (column → coarse column), rows kept.
    pub(super) fn map_cols(&self, map: &[u32]) -> Sparse {
        let mut entries = Vec::new();
        for r in 0..self.rows() {
            let (a, b) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
            let row: Vec<(u32, [f32; 3])> = (a..b)
                .map(|k| (map[self.cols[k] as usize], self.vals[k]))
                .collect();
            for (c, v) in merge_columns(row) {
                entries.push((r as u32, c, v));
            }
        }
        Sparse::from_sorted(self.rows(), entries.into_iter())
    }
}

/// Sorts one row's (column, value) entries and sums the values of equal columns.
pub(super) fn merge_columns<T: Copy + std::ops::AddAssign>(
    mut row: Vec<(u32, [T; 3])>,
) -> Vec<(u32, [T; 3])> {
    row.sort_by_key(|e| e.0);
    let mut out: Vec<(u32, [T; 3])> = Vec::with_capacity(row.len());
    for (c, v) in row {
        match out.last_mut() {
            Some((lc, lv)) if *lc == c => {
                for (a, b) in lv.iter_mut().zip(v) {
                    *a += b;
                }
            }
            _ => out.push((c, v)),
        }
    }
    out
}
