//! The operator one level coarser (parent elements), from the same lines: the transport's
//! discretisation estimate is |fine − coarse| per sensor.

use super::mesh::Mesh;
use super::sparse::{merge_columns, Sparse};

/// The coarse operator: rows of the same parent merged (area-weighted), columns summed.
/// Built one coarse row at a time (its fine rows in order), so that no copy of the fine
/// operator's entries is held beside it.
pub(super) fn coarse_operator(f: &Sparse, mesh: &Mesh) -> Sparse {
    let n = mesh.coarse_rows;
    let mut area = vec![0.0; n];
    // Fine rows grouped by parent, ascending within each group.
    let mut start = vec![0usize; n + 1];
    for (r, &c) in mesh.coarse_of.iter().enumerate() {
        area[c as usize] += mesh.area[r];
        start[c as usize + 1] += 1;
    }
    for c in 0..n {
        start[c + 1] += start[c];
    }
    let mut next = start.clone();
    let mut fine = vec![0u32; mesh.coarse_of.len()];
    for (r, &c) in mesh.coarse_of.iter().enumerate() {
        fine[next[c as usize]] = r as u32;
        next[c as usize] += 1;
    }
    let entries = (0..n).flat_map(|c| {
        let mut row: Vec<(u32, [f64; 3])> = Vec::new();
        for &r in &fine[start[c]..start[c + 1]] {
            let w = mesh.area[r as usize] / area[c].max(1e-300);
            for (col, v) in f.mapped_row(r as usize, &mesh.coarse_of) {
                row.push((col, [v[0] as f64 * w, v[1] as f64 * w, v[2] as f64 * w]));
            }
        }
        merge_columns(row)
            .into_iter()
            .map(move |(col, v)| (c as u32, col, v.map(|x| x as f32)))
    });
    Sparse::from_sorted(n, entries)
}
