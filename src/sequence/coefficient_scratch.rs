//! The rows a cold run's missing coefficients fill, kept on disk while the adjoint's
//! sensor blocks fill them ([`super::Coefficients::prepare`]): each block writes its
//! sensors' columns of every node's rows, and each node's rows are read whole once the
//! blocks are done.
//!
//! Why: held in memory, they were the largest holding beside the blocks' responses and
//! solves (93 MB of the 10 000-triangle building's 380 MB peak, 1 332 nodes × 5 + 9 rows
//! of 1 620 sensors). Written block by block to an unnamed file in the system's temporary
//! folder, they sit in the page cache instead (on a `tmpfs` `TMPDIR`, still in memory, but
//! not in the process's). Values are written and read bit for bit, so the coefficients do
//! not depend on it. Where no file can be made, the rows are held in memory as before.

use crate::files::{read_at, write_at};
use std::fs::File;
use std::io;

/// Every node's rows, `rows` × `sensors` f32 each, on disk or held.
pub(super) struct Scratch {
    rows: usize,
    sensors: usize,
    /// The file, or `None` when the rows are held.
    file: Option<File>,
    held: Vec<f32>,
}

impl Scratch {
    /// Room for `nodes` nodes of `rows` rows of `sensors` f32 (zero until written).
    pub fn new(nodes: usize, rows: usize, sensors: usize) -> Scratch {
        let len = (nodes * rows * sensors * 4) as u64;
        let file = tempfile::tempfile()
            .and_then(|f| f.set_len(len).map(|_| f))
            .ok();
        let held = if file.is_some() {
            Vec::new()
        } else {
            vec![0f32; nodes * rows * sensors]
        };
        Scratch {
            rows,
            sensors,
            file,
            held,
        }
    }

    /// Whether the rows are on disk.
    #[cfg(test)]
    pub fn on_disk(&self) -> bool {
        self.file.is_some()
    }

    /// Element offset of node `node`'s row `row` at sensor `s0`.
    fn at(&self, node: usize, row: usize, s0: usize) -> usize {
        (node * self.rows + row) * self.sensors + s0
    }

    /// Writes `values` into node `node`'s row `row` from sensor `s0` on.
    pub fn write(&mut self, node: usize, row: usize, s0: usize, values: &[f32]) -> io::Result<()> {
        let at = self.at(node, row, s0);
        match &self.file {
            Some(f) => write_at(f, bytemuck::cast_slice(values), at as u64 * 4),
            None => {
                self.held[at..at + values.len()].copy_from_slice(values);
                Ok(())
            }
        }
    }

    /// Node `node`'s rows `rows`, whole.
    pub fn read(&self, node: usize, rows: std::ops::Range<usize>) -> io::Result<Vec<f32>> {
        let (a, b) = (self.at(node, rows.start, 0), self.at(node, rows.end, 0));
        match &self.file {
            Some(f) => {
                let mut v = vec![0f32; b - a];
                read_at(f, bytemuck::cast_slice_mut(&mut v), a as u64 * 4)?;
                Ok(v)
            }
            None => Ok(self.held[a..b].to_vec()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns written block by block, in any order, read back whole bit for bit, on disk
    /// and held alike; rows never written read zero.
    #[test]
    fn rows_written_by_blocks_read_back_whole() {
        let (nodes, rows, k) = (3, 4, 10);
        let value = |n: usize, r: usize, s: usize| (n * 1000 + r * 100 + s) as f32 + 0.25;
        let mut disk = Scratch::new(nodes, rows, k);
        assert!(disk.on_disk(), "a temporary file can be made here");
        let mut held = Scratch {
            file: None,
            held: vec![0f32; nodes * rows * k],
            ..Scratch::new(0, rows, k)
        };
        for sc in [&mut disk, &mut held] {
            for s0 in [6, 0, 3] {
                let w = if s0 == 6 { 4 } else { 3 };
                for n in 0..nodes {
                    for r in 0..rows - 1 {
                        let v: Vec<f32> = (s0..s0 + w).map(|s| value(n, r, s)).collect();
                        sc.write(n, r, s0, &v).unwrap();
                    }
                }
            }
            for n in 0..nodes {
                let got = sc.read(n, 0..rows).unwrap();
                let want: Vec<f32> = (0..rows)
                    .flat_map(|r| {
                        (0..k).map(move |s| if r < rows - 1 { value(n, r, s) } else { 0.0 })
                    })
                    .collect();
                assert_eq!(got, want);
                assert_eq!(sc.read(n, 1..3).unwrap(), want[k..3 * k].to_vec());
            }
        }
    }
}
