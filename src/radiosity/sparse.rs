//! Sparse matrices of the operator and the gather: compressed rows with f32 values, one
//! per entry when every entry is grey (the same in R, G and B), else three; a row–vector
//! product and column aggregation (for the coarse level).

use crate::photometry::{ChannelValues, Rgb};

/// Sparse rows: row r holds (column, value) pairs `cols[offsets[r]..offsets[r+1]]`, entry
/// k's value `vals.get(k)`.
#[derive(Clone, Debug, Default)]
pub(super) struct Sparse {
    pub(super) offsets: Vec<u32>,
    pub(super) cols: Vec<u32>,
    pub(super) vals: ChannelValues,
}

impl Sparse {
    /// Entry `k`'s value in R, G and B.
    #[inline]
    pub(super) fn val(&self, k: usize) -> [f32; 3] {
        self.vals.get(k)
    }

    /// Whether every entry is grey (then stored with one value each).
    pub(super) fn is_grey(&self) -> bool {
        self.vals.is_grey()
    }

    /// Bytes of its arrays.
    pub(super) fn bytes(&self) -> u64 {
        4 * (self.offsets.len() + self.cols.len()) as u64 + self.vals.bytes()
    }

    pub(super) fn row_dot(&self, r: usize, x: &[Rgb]) -> Rgb {
        let (a, b) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
        let mut s = Rgb::ZERO;
        for k in a..b {
            let v = self.val(k);
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
        let mut vals = ChannelValues::default();
        for (r, c, v) in entries {
            offsets[r as usize + 1] += 1;
            cols.push(c);
            vals.push(v);
        }
        for r in 0..n_rows {
            offsets[r + 1] += offsets[r];
        }
        // Grown by doubling: up to half the capacity would be spare, and the operator's
        // matrices are held for the whole set-up.
        cols.shrink_to_fit();
        vals.shrink_to_fit();
        Sparse {
            offsets,
            cols,
            vals,
        }
    }

    /// Aggregates columns through `map` (column → coarse column), rows kept; row by row,
    /// without a copy of the entries.
    pub(super) fn map_cols(&self, map: &[u32]) -> Sparse {
        let entries = (0..self.rows()).flat_map(|r| {
            self.mapped_row(r, map)
                .into_iter()
                .map(move |(c, v)| (r as u32, c, v))
        });
        Sparse::from_sorted(self.rows(), entries)
    }

    /// Row `r` with its columns aggregated through `map`, sorted by column.
    pub(super) fn mapped_row(&self, r: usize, map: &[u32]) -> Vec<(u32, [f32; 3])> {
        let (a, b) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
        merge_columns(
            (a..b)
                .map(|k| (map[self.cols[k] as usize], self.val(k)))
                .collect(),
        )
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grey_and_coloured_rows_read_as_rgb() {
        let grey = [(0, 1, [0.5f32; 3]), (1, 0, [0.25; 3])];
        let g = Sparse::from_sorted(2, grey.into_iter());
        assert!(g.is_grey());
        assert_eq!(g.bytes(), 4 * (3 + 2 + 2));
        let mixed = [(0, 1, [0.5f32; 3]), (1, 0, [0.1, 0.2, 0.3])];
        let m = Sparse::from_sorted(2, mixed.into_iter());
        assert!(!m.is_grey());
        assert_eq!((m.val(0), m.val(1)), ([0.5; 3], [0.1, 0.2, 0.3]));
        let x = [Rgb::new(1.0, 2.0, 3.0), Rgb::new(4.0, 5.0, 6.0)];
        assert_eq!(g.row_dot(0, &x), Rgb::new(2.0, 2.5, 3.0));
        let c = |v: f32, x: f64| f64::from(v) * x;
        assert_eq!(
            m.row_dot(1, &x),
            Rgb::new(c(0.1, 1.0), c(0.2, 2.0), c(0.3, 3.0))
        );
        // Aggregating columns keeps a grey matrix grey.
        assert!(g.map_cols(&[0, 0]).is_grey());
    }
}
