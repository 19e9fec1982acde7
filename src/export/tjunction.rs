//! T-junctions of the solution mesh closed for display: where a vertex of one element lies
//! on the edge of a larger neighbour in the same plane (the hierarchical mesh refines
//! elements unevenly), rasterisers leave single-pixel gaps along that edge, because the two
//! sides' edges do not share end points. Each such triangle is split into a fan around its
//! centroid through every vertex on its edges, so both sides of every edge then end at the
//! same vertices.

use glam::DVec3;
use std::collections::HashMap;

/// How far (m) a vertex may lie from an edge, or must lie from its ends, to count as on it:
/// 5× the 10 µm grid vertices are welded on, well above `f32` rounding at hundreds of metres.
const TOLERANCE_M: f64 = 5e-5;

/// A grid cell's integer coordinates.
type Cell = (i64, i64, i64);

/// The triangles `indices` (triples into `positions`, glTF frame, m) with every T-junction
/// split, vertices counting only against triangles of their own plane (`plane`, an id per
/// vertex). Returns the new triangle indices, where index `positions.len() + k` is the k-th
/// new vertex, and the new vertices as the three corners whose mean they are (the split
/// triangle's centroid). Deterministic: no hash-map order reaches the output.
pub(crate) fn split_t_junctions(
    positions: &[[f32; 3]],
    plane: &[u32],
    indices: &[u32],
) -> (Vec<u32>, Vec<[u32; 3]>) {
    let at = |i: u32| {
        let v = positions[i as usize];
        DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
    };
    // A uniform grid of the vertices, cells about one mean edge long.
    let edges = indices.len().max(1) as f64;
    let mean_edge = indices
        .chunks_exact(3)
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| at(a).distance(at(b)))
        .sum::<f64>()
        / edges;
    let cell = mean_edge.max(1e-3);
    let key = |p: DVec3| -> Cell {
        (
            (p.x / cell).floor() as i64,
            (p.y / cell).floor() as i64,
            (p.z / cell).floor() as i64,
        )
    };
    let mut grid: HashMap<(u32, Cell), Vec<u32>> = HashMap::new();
    for i in 0..positions.len() as u32 {
        grid.entry((plane[i as usize], key(at(i))))
            .or_default()
            .push(i);
    }
    // The vertices strictly inside edge a→b, ordered from a.
    let on_edge = |a: u32, b: u32| -> Vec<u32> {
        let (pa, pb) = (at(a), at(b));
        let d = pb - pa;
        let len = d.length();
        if len <= 2.0 * TOLERANCE_M {
            return Vec::new();
        }
        let lo = key(pa.min(pb) - DVec3::splat(TOLERANCE_M));
        let hi = key(pa.max(pb) + DVec3::splat(TOLERANCE_M));
        let mut found: Vec<(f64, u32)> = Vec::new();
        for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                for z in lo.2..=hi.2 {
                    let Some(cands) = grid.get(&(plane[a as usize], (x, y, z))) else {
                        continue;
                    };
                    for &v in cands {
                        let s = (at(v) - pa).dot(d) / len;
                        let off = (at(v) - pa - d * (s / len)).length();
                        if s > TOLERANCE_M && s < len - TOLERANCE_M && off < TOLERANCE_M {
                            found.push((s, v));
                        }
                    }
                }
            }
        }
        found.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        found.dedup_by_key(|f| f.1);
        found.into_iter().map(|f| f.1).collect()
    };
    let mut out = Vec::with_capacity(indices.len());
    let mut centroids = Vec::new();
    for t in indices.chunks_exact(3) {
        let mut ring = Vec::new();
        for k in 0..3 {
            ring.push(t[k]);
            ring.extend(on_edge(t[k], t[(k + 1) % 3]));
        }
        if ring.len() == 3 {
            out.extend_from_slice(t);
            continue;
        }
        let c = (positions.len() + centroids.len()) as u32;
        centroids.push([t[0], t[1], t[2]]);
        for k in 0..ring.len() {
            out.extend_from_slice(&[c, ring[k], ring[(k + 1) % ring.len()]]);
        }
    }
    (out, centroids)
}
