//! The operator one level coarser (parent elements), from the same lines: the transport's
//! discretisation estimate is |fine − coarse| per sensor.

use super::mesh::Mesh;
use super::sparse::{merge_columns, Sparse};

/// The coarse operator: rows of the same parent merged (area-weighted), columns summed.
pub(super) fn coarse_operator(f: &Sparse, mesh: &Mesh) -> Sparse {
    let cols = f.map_cols(&mesh.coarse_of);
    let mut rows: Vec<Vec<(u32, [f64; 3])>> = vec![Vec::new(); mesh.coarse_rows];
    let mut area = vec![0.0; mesh.coarse_rows];
    for (r, &c) in mesh.coarse_of.iter().enumerate() {
        area[c as usize] += mesh.area[r];
    }
    for (r, &c) in mesh.coarse_of.iter().enumerate() {
        let w = mesh.area[r] / area[c as usize].max(1e-300);
        let (a, b) = (cols.offsets[r] as usize, cols.offsets[r + 1] as usize);
        for k in a..b {
            let v = cols.val(k);
            rows[c as usize].push((
                cols.cols[k],
                [v[0] as f64 * w, v[1] as f64 * w, v[2] as f64 * w],
            ));
        }
    }
    let mut entries = Vec::new();
    for (r, row) in rows.into_iter().enumerate() {
        for (c, v) in merge_columns(row) {
            entries.push((r as u32, c, v.map(|x| x as f32)));
        }
    }
    Sparse::from_sorted(mesh.coarse_rows, entries.into_iter())
}
