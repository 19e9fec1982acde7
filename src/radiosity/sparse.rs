//! Sparse matrices of the operator and the gather: compressed rows with f32 values, one
//! per entry when every entry is grey (the same in R, G and B), else three; a row–vector
//! product and column aggregation (for the coarse level). The arrays are held in memory
//! or read in place from the operator's memory-mapped cache record ([`Buf`]).

use crate::cache::MappedRecord;
use crate::photometry::{ChannelValues, Rgb};
use std::ops::Deref;
use std::sync::Arc;

/// An array of `T`, owned or read in place from a memory-mapped cache record.
///
/// Why: the operator is a run's largest holding (about 250 MB on the generated
/// building), and once it is stored the record already holds the same bytes. Read in
/// place, its pages can be given back to the kernel whenever a stage is done with them
/// ([`MappedRecord::release`]) and come back from the page cache when read again, instead
/// of staying resident for the whole stage.
#[derive(Debug)]
pub enum Buf<T> {
    /// Held in memory.
    Owned(Vec<T>),
    /// Bytes `bytes` of `record`.
    Mapped {
        /// The record that holds the array.
        record: Arc<MappedRecord>,
        /// Where in the record's bytes.
        bytes: std::ops::Range<usize>,
        /// The element type.
        _t: std::marker::PhantomData<T>,
    },
}

impl<T> From<Vec<T>> for Buf<T> {
    fn from(v: Vec<T>) -> Self {
        Buf::Owned(v)
    }
}

impl<T> Default for Buf<T> {
    fn default() -> Self {
        Buf::Owned(Vec::new())
    }
}

impl<T: Clone> Clone for Buf<T> {
    fn clone(&self) -> Self {
        match self {
            Buf::Owned(v) => Buf::Owned(v.clone()),
            Buf::Mapped { record, bytes, .. } => Buf::Mapped {
                record: Arc::clone(record),
                bytes: bytes.clone(),
                _t: std::marker::PhantomData,
            },
        }
    }
}

impl<T: bytemuck::Pod> Buf<T> {
    /// `slice`, which must lie inside `record`'s bytes, read in place; `None` otherwise.
    pub fn mapped(record: &Arc<MappedRecord>, slice: &[T]) -> Option<Buf<T>> {
        let base = record.bytes().as_ptr() as usize;
        let start = (slice.as_ptr() as usize).checked_sub(base)?;
        let end = start + std::mem::size_of_val(slice);
        (end <= record.bytes().len()).then(|| Buf::Mapped {
            record: Arc::clone(record),
            bytes: start..end,
            _t: std::marker::PhantomData,
        })
    }

    /// Gives back the pages of elements `range` when read in place
    /// ([`MappedRecord::release_range`]); nothing when held.
    pub fn release_range(&self, range: std::ops::Range<usize>) {
        if let Buf::Mapped { record, bytes, .. } = self {
            let size = std::mem::size_of::<T>();
            record.release_range(bytes.start + range.start * size..bytes.start + range.end * size);
        }
    }

    /// The record it is read from, if any.
    pub fn record(&self) -> Option<&Arc<MappedRecord>> {
        match self {
            Buf::Owned(_) => None,
            Buf::Mapped { record, .. } => Some(record),
        }
    }
}

impl<T: bytemuck::Pod> Deref for Buf<T> {
    type Target = [T];
    #[inline]
    fn deref(&self) -> &[T] {
        match self {
            Buf::Owned(v) => v,
            Buf::Mapped { record, bytes, .. } => {
                bytemuck::cast_slice(&record.bytes()[bytes.clone()])
            }
        }
    }
}

/// Sparse rows: row r holds (column, value) pairs `cols[offsets[r]..offsets[r+1]]`, entry
/// k's value `vals[k]` (grey) or `vals[3k..3k + 3]` (RGB).
#[derive(Clone, Debug, Default)]
pub(super) struct Sparse {
    pub(super) offsets: Buf<u32>,
    pub(super) cols: Buf<u32>,
    pub(super) vals: Buf<f32>,
    pub(super) rgb: bool,
}

/// A [`Sparse`]'s arrays as slices, taken once before a loop over its entries (a mapped
/// array's slice costs a few checks each time it is taken).
#[derive(Clone, Copy)]
pub(super) struct View<'a> {
    pub(super) offsets: &'a [u32],
    pub(super) cols: &'a [u32],
    pub(super) vals: &'a [f32],
    pub(super) rgb: bool,
}

impl View<'_> {
    /// Entry `k`'s value in R, G and B.
    #[inline]
    pub(super) fn val(&self, k: usize) -> [f32; 3] {
        if self.rgb {
            [self.vals[3 * k], self.vals[3 * k + 1], self.vals[3 * k + 2]]
        } else {
            [self.vals[k]; 3]
        }
    }

    /// Row `r`'s product with `x`.
    #[inline]
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

    /// Number of rows.
    pub(super) fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

impl Sparse {
    /// Its arrays as slices.
    #[inline]
    pub(super) fn view(&self) -> View<'_> {
        View {
            offsets: &self.offsets,
            cols: &self.cols,
            vals: &self.vals,
            rgb: self.rgb,
        }
    }

    /// Gives back the pages of entries `range` (their columns and values) where they are
    /// read in place: for one pass over the entries in order, which need not keep what it
    /// has read resident.
    pub(super) fn release_entries(&self, range: std::ops::Range<usize>) {
        self.cols.release_range(range.clone());
        let per = if self.rgb { 3 } else { 1 };
        self.vals.release_range(range.start * per..range.end * per);
    }

    /// Whether every entry is grey (then stored with one value each).
    pub(super) fn is_grey(&self) -> bool {
        !self.rgb
    }

    /// Bytes of its arrays.
    pub(super) fn bytes(&self) -> u64 {
        4 * (self.offsets.len() + self.cols.len() + self.vals.len()) as u64
    }

    /// Bytes of its arrays held in memory (not read in place from a record).
    pub(super) fn owned_bytes(&self) -> u64 {
        let owned = |len: usize, mapped: bool| if mapped { 0 } else { 4 * len as u64 };
        owned(self.offsets.len(), self.offsets.record().is_some())
            + owned(self.cols.len(), self.cols.record().is_some())
            + owned(self.vals.len(), self.vals.record().is_some())
    }

    pub(super) fn row_dot(&self, r: usize, x: &[Rgb]) -> Rgb {
        self.view().row_dot(r, x)
    }

    pub(super) fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Row offsets, columns and values (one per entry when grey, else three), checked
    /// against the shape (`rows`, `columns`): `None` when they do not fit, so a stale or
    /// foreign record is never used.
    pub(super) fn from_parts(
        offsets: Buf<u32>,
        cols: Buf<u32>,
        vals: Buf<f32>,
        (rows, columns): (usize, usize),
    ) -> Option<Sparse> {
        let rgb = match vals.len() {
            n if n == cols.len() => false,
            n if n == 3 * cols.len() => true,
            _ => return None,
        };
        let ok = offsets.len() == rows + 1
            && offsets.first() == Some(&0)
            && offsets.windows(2).all(|w| w[0] <= w[1])
            && *offsets.last().unwrap_or(&1) as usize == cols.len()
            && cols.iter().all(|&j| (j as usize) < columns)
            && vals.iter().all(|x| x.is_finite());
        ok.then_some(Sparse {
            offsets,
            cols,
            vals,
            rgb,
        })
    }

    /// Builds rows from (row, col, value) triples sorted by (row, col), no duplicates.
    pub(super) fn from_sorted(
        n_rows: usize,
        entries: impl Iterator<Item = (u32, u32, [f32; 3])>,
    ) -> Sparse {
        Sparse::from_sorted_len(n_rows, 0, entries)
    }

    /// [`Self::from_sorted`] for at most `most` entries, known beforehand: its arrays are
    /// made that large at once, never grown (growing a large one copies it, holding it
    /// twice), and shrunk to their entries at the end (a large allocation's pages that
    /// were never written are never resident).
    pub(super) fn from_sorted_len(
        n_rows: usize,
        most: usize,
        entries: impl Iterator<Item = (u32, u32, [f32; 3])>,
    ) -> Sparse {
        let mut offsets = vec![0u32; n_rows + 1];
        let mut cols = Vec::with_capacity(most);
        let mut vals = ChannelValues::with_capacity(most);
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
        let rgb = !vals.is_grey();
        Sparse {
            offsets: Buf::Owned(offsets),
            cols: Buf::Owned(cols),
            vals: Buf::Owned(vals.into_values()),
            rgb,
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
        let m = self.view();
        let (a, b) = (m.offsets[r] as usize, m.offsets[r + 1] as usize);
        merge_columns(
            (a..b)
                .map(|k| (map[m.cols[k] as usize], m.val(k)))
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
        assert_eq!(
            (m.view().val(0), m.view().val(1)),
            ([0.5; 3], [0.1, 0.2, 0.3])
        );
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
