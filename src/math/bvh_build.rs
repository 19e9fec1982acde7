//! Building the [`Bvh`](super::Bvh): binned surface-area heuristic over triangle
//! centroids, median split past a depth bound, triangles copied into leaf order; the
//! binary tree is then collapsed into the 4-wide one the queries walk.

use super::*;

/// Histogram bins per axis for the surface-area heuristic.
const BINS: usize = 16;
/// A node with at most this many triangles is always a leaf.
const MIN_LEAF: usize = 2;
/// A node with more triangles than this is always split.
const MAX_LEAF: usize = 8;
/// Cost of visiting a node relative to one triangle test (surface-area heuristic).
const TRAVERSAL_COST: f64 = 1.0;
/// Beyond this depth nodes are median-split, which bounds the depth by 40 + log2(n) and so
/// the traversal stack below.
const SAH_MAX_DEPTH: usize = 40;

/// A node of the binary tree the build makes: a leaf (`count > 0` triangles from
/// `start`) or an inner node (`count == 0`, children at `start` and `start + 1`); its box
/// in f32, rounded outwards.
#[derive(Clone, Copy, Debug, Default)]
struct BinNode {
    lo: [f32; 3],
    hi: [f32; 3],
    start: u32,
    count: u32,
}

impl BinNode {
    /// Sets the box to the f32 box that contains `lo..hi`.
    fn set_box(&mut self, lo: DVec3, hi: DVec3) {
        self.lo = lo.to_array().map(|x| f32_toward(x, false));
        self.hi = hi.to_array().map(|x| f32_toward(x, true));
    }

    /// Half the surface area of its box.
    fn half_area(&self) -> f64 {
        let lo = DVec3::from_array(self.lo.map(f64::from));
        let hi = DVec3::from_array(self.hi.map(f64::from));
        half_area(lo, hi)
    }
}

/// Collapses the binary tree `bin` (root 0) into a 4-wide one: each 4-wide node takes a
/// binary node's children and opens the largest (by surface area) inner ones among them
/// until it holds four. The boxes are the binary nodes' own, so every box still holds its
/// triangles.
fn collapse(bin: &[BinNode]) -> Vec<Node> {
    let mut out = vec![Node::default()];
    // (4-wide node, the binary nodes it holds)
    let mut work: Vec<(usize, Vec<usize>)> = vec![(
        0,
        if bin[0].count > 0 {
            vec![0]
        } else {
            vec![bin[0].start as usize, bin[0].start as usize + 1]
        },
    )];
    while let Some((k, mut slots)) = work.pop() {
        while slots.len() < 4 {
            let widest = slots
                .iter()
                .enumerate()
                .filter(|(_, b)| bin[**b].count == 0)
                .max_by(|a, b| bin[*a.1].half_area().total_cmp(&bin[*b.1].half_area()))
                .map(|(i, _)| i);
            let Some(i) = widest else { break };
            let b = slots[i];
            slots[i] = bin[b].start as usize;
            slots.push(bin[b].start as usize + 1);
        }
        for (j, &b) in slots.iter().enumerate() {
            let n = bin[b];
            for a in 0..3 {
                out[k].corners[0][a][j] = n.lo[a];
                out[k].corners[1][a][j] = n.hi[a];
            }
            if n.count > 0 {
                out[k].child[j] = n.start;
                out[k].count[j] = n.count;
            } else {
                let c = out.len();
                out.push(Node::default());
                out[k].child[j] = c as u32;
                out[k].count[j] = 0;
                work.push((c, vec![n.start as usize, n.start as usize + 1]));
            }
        }
    }
    out
}

/// Half the surface area of a box (the heuristic only needs ratios).
fn half_area(lo: DVec3, hi: DVec3) -> f64 {
    let d = (hi - lo).max(DVec3::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

impl Bvh {
    /// Builds the hierarchy over `triangles` (each three vertices, metres). Zero-area and
    /// non-finite triangles are kept out of the tree (never hit) but keep their indices.
    pub fn build(triangles: &[[DVec3; 3]]) -> Bvh {
        let mut refs: Vec<u32> = Vec::with_capacity(triangles.len());
        let mut boxes = vec![(DVec3::ZERO, DVec3::ZERO); triangles.len()];
        let mut cents = vec![DVec3::ZERO; triangles.len()];
        let mut scale = 1.0_f64;
        for (i, t) in triangles.iter().enumerate() {
            if is_degenerate(t) {
                continue;
            }
            refs.push(i as u32);
            let lo = t[0].min(t[1]).min(t[2]);
            let hi = t[0].max(t[1]).max(t[2]);
            boxes[i] = (lo, hi);
            cents[i] = (lo + hi) * 0.5;
            scale = scale
                .max(lo.abs().max_element())
                .max(hi.abs().max_element());
        }
        let mut bvh = Bvh {
            input_len: triangles.len(),
            ..Bvh::default()
        };
        if refs.is_empty() {
            return bvh;
        }
        // Rounding in the slab test is a few ulps of the coordinates (≈1e-13 m at 1e3 m);
        // 1e-9 relative padding covers it with a wide margin and costs nothing measurable.
        let pad = DVec3::splat(1e-9 * scale);
        let mut nodes = vec![BinNode::default()];
        let mut work = vec![(0usize, 0usize, refs.len(), 0usize)];
        while let Some((ni, s, e, depth)) = work.pop() {
            let items = &mut refs[s..e];
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            let mut clo = lo;
            let mut chi = hi;
            for &i in items.iter() {
                let (blo, bhi) = boxes[i as usize];
                lo = lo.min(blo);
                hi = hi.max(bhi);
                clo = clo.min(cents[i as usize]);
                chi = chi.max(cents[i as usize]);
            }
            nodes[ni].set_box(lo - pad, hi + pad);
            let n = items.len();
            let split = if n <= MIN_LEAF {
                None
            } else {
                choose_split(items, &boxes, &cents, clo, chi, half_area(lo, hi), depth)
            };
            match split {
                None => {
                    nodes[ni].start = s as u32;
                    nodes[ni].count = n as u32;
                }
                Some(mid) => {
                    let left = nodes.len();
                    nodes.push(BinNode::default());
                    nodes.push(BinNode::default());
                    nodes[ni].start = left as u32;
                    nodes[ni].count = 0;
                    work.push((left + 1, s + mid, e, depth + 1));
                    work.push((left, s, s + mid, depth + 1));
                }
            }
        }
        bvh.tris = refs.iter().map(|&i| triangles[i as usize]).collect();
        bvh.normals = bvh.tris.iter().map(face_normal).collect();
        bvh.ids = refs;
        bvh.nodes = collapse(&nodes);
        bvh
    }
}

/// Chooses how to split `items` (reordering them): `Some(mid)` puts the left child in
/// `items[..mid]`, `None` makes a leaf.
fn choose_split(
    items: &mut [u32],
    boxes: &[(DVec3, DVec3)],
    cents: &[DVec3],
    clo: DVec3,
    chi: DVec3,
    node_area: f64,
    depth: usize,
) -> Option<usize> {
    let n = items.len();
    let ext = chi - clo;
    let axis_long = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let median = |items: &mut [u32]| {
        let mid = n / 2;
        items.select_nth_unstable_by(mid, |&a, &b| {
            cents[a as usize][axis_long].total_cmp(&cents[b as usize][axis_long])
        });
        Some(mid)
    };
    if ext.max_element() <= 0.0 {
        // All centroids coincide: no spatial split separates them.
        return if n <= MAX_LEAF { None } else { Some(n / 2) };
    }
    if depth >= SAH_MAX_DEPTH {
        return median(items);
    }
    let bin_of = |i: u32, axis: usize| -> usize {
        let f = (cents[i as usize][axis] - clo[axis]) / ext[axis] * BINS as f64;
        (f as usize).min(BINS - 1)
    };
    let mut best = (f64::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if ext[axis] <= 0.0 {
            continue;
        }
        let mut count = [0usize; BINS];
        let mut blo = [DVec3::splat(f64::INFINITY); BINS];
        let mut bhi = [DVec3::splat(f64::NEG_INFINITY); BINS];
        for &i in items.iter() {
            let b = bin_of(i, axis);
            count[b] += 1;
            blo[b] = blo[b].min(boxes[i as usize].0);
            bhi[b] = bhi[b].max(boxes[i as usize].1);
        }
        // right_cost[b]: cost of bins b.. as one child.
        let mut right_cost = [0.0; BINS];
        let (mut lo, mut hi, mut c) = (
            DVec3::splat(f64::INFINITY),
            DVec3::splat(f64::NEG_INFINITY),
            0,
        );
        for b in (1..BINS).rev() {
            lo = lo.min(blo[b]);
            hi = hi.max(bhi[b]);
            c += count[b];
            right_cost[b] = if c > 0 {
                half_area(lo, hi) * c as f64
            } else {
                f64::NAN
            };
        }
        let (mut lo, mut hi, mut c) = (
            DVec3::splat(f64::INFINITY),
            DVec3::splat(f64::NEG_INFINITY),
            0,
        );
        for b in 1..BINS {
            lo = lo.min(blo[b - 1]);
            hi = hi.max(bhi[b - 1]);
            c += count[b - 1];
            if c == 0 || c == n {
                continue;
            }
            let cost = half_area(lo, hi) * c as f64 + right_cost[b];
            if cost < best.0 {
                best = (cost, axis, b);
            }
        }
    }
    if !best.0.is_finite() {
        return median(items);
    }
    let split_cost = TRAVERSAL_COST * node_area + best.0;
    if n <= MAX_LEAF && split_cost >= n as f64 * node_area {
        return None;
    }
    let (_, axis, b) = best;
    // In-place partition: items with bin < b first.
    let mut mid = 0;
    for k in 0..n {
        if bin_of(items[k], axis) < b {
            items.swap(k, mid);
            mid += 1;
        }
    }
    if mid == 0 || mid == n {
        return median(items);
    }
    Some(mid)
}
