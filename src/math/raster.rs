//! Scan conversion of one triangle into a regular pixel grid, sampling pixel centres.
//!
//! Pixel `(i, j)` covers `[i, i+1) × [j, j+1)` and is sampled at its centre. A consistent
//! tie rule on edges ("owner" edges) makes triangles that share an edge cover every centre
//! on it exactly once, so a quad-tree split of a triangle covers exactly its parent's pixels
//! (up to rounding of the midpoints), which the LDI refinement relies on.

use glam::DVec2;

/// Calls `visit(i, j, depth)` for every pixel whose centre lies inside the triangle `p`
/// (pixel coordinates), with `depth` interpolated linearly from the per-vertex `depth`.
/// Triangles with zero or non-finite area cover nothing.
pub fn rasterize(
    p: [DVec2; 3],
    depth: [f64; 3],
    width: u32,
    height: u32,
    visit: impl FnMut(u32, u32, f64),
) {
    rasterize_within(p, depth, width, height, |_| (i64::MIN, i64::MAX), visit);
}

/// [`rasterize`] visiting, in row `j`, only the pixels `i` with `lo ≤ i ≤ hi` for
/// `(lo, hi) = span(j)`: the pixels visited and their depths are those [`rasterize`]
/// visits there, to the bit.
pub fn rasterize_within(
    p: [DVec2; 3],
    depth: [f64; 3],
    width: u32,
    height: u32,
    span: impl Fn(u32) -> (i64, i64),
    mut visit: impl FnMut(u32, u32, f64),
) {
    let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
    if !(area2.is_finite()) || area2 == 0.0 {
        return;
    }
    // Counter-clockwise order so that "inside" is the positive side of every edge.
    let (p, depth) = if area2 < 0.0 {
        ([p[0], p[2], p[1]], [depth[0], depth[2], depth[1]])
    } else {
        (p, depth)
    };
    let area2 = area2.abs();
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    let i0 = (lo.x - 0.5).ceil().max(0.0) as i64;
    let j0 = (lo.y - 0.5).ceil().max(0.0) as i64;
    let i1 = ((hi.x - 0.5).floor() as i64).min(width as i64 - 1);
    let j1 = ((hi.y - 0.5).floor() as i64).min(height as i64 - 1);
    if i0 > i1 || j0 > j1 {
        return;
    }
    // Edge k runs from p[k] to p[k+1]; its function is positive inside.
    let edges: [(DVec2, DVec2, bool); 3] = std::array::from_fn(|k| {
        let a = p[k];
        let b = p[(k + 1) % 3];
        let d = b - a;
        // Owner rule: of the two orientations of a shared edge exactly one owns it.
        let owner = d.y > 0.0 || (d.y == 0.0 && d.x < 0.0);
        (a, d, owner)
    });
    let inside = |e: f64, owner: bool| e > 0.0 || (e == 0.0 && owner);
    for j in j0..=j1 {
        let y = j as f64 + 0.5;
        // The row's span from the edges' crossings of it, widened by a pixel each side:
        // only a bound on where to test (every pixel is still tested exactly, so the
        // covered set is the same), sparing the tests left of a slanted triangle.
        let (mut lo_x, mut hi_x) = (f64::NEG_INFINITY, f64::INFINITY);
        for (a, d, _) in &edges {
            if d.y != 0.0 {
                let x = a.x + d.x * (y - a.y) / d.y;
                if d.y < 0.0 {
                    lo_x = lo_x.max(x);
                } else {
                    hi_x = hi_x.min(x);
                }
            }
        }
        let (start, end) = if lo_x.is_nan() || hi_x.is_nan() {
            (i0, i1)
        } else {
            (
                ((lo_x - 1.5).floor().max(i0 as f64) as i64).min(i1 + 1),
                ((hi_x + 0.5).ceil().min(i1 as f64) as i64).max(i0 - 1),
            )
        };
        let (keep_lo, keep_hi) = span(j as u32);
        let (start, end) = (start.max(keep_lo), end.min(keep_hi));
        let mut entered = false;
        for i in start..=end {
            let c = DVec2::new(i as f64 + 0.5, y);
            let mut w = [0.0; 3];
            let mut ok = true;
            for (k, (a, d, owner)) in edges.iter().enumerate() {
                let e = d.perp_dot(c - *a);
                if !inside(e, *owner) {
                    ok = false;
                    break;
                }
                w[k] = e;
            }
            if ok {
                entered = true;
                // w[k] is the weight of the vertex opposite edge k, i.e. vertex k+2.
                let z = (w[0] * depth[2] + w[1] * depth[0] + w[2] * depth[1]) / area2;
                visit(i as u32, j as u32, z);
            } else if entered {
                break; // convex: once we leave the span, the row is done
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cover(p: [DVec2; 3], w: u32, h: u32) -> Vec<(u32, u32)> {
        let mut v = Vec::new();
        rasterize(p, [0.0; 3], w, h, |i, j, _| v.push((i, j)));
        v
    }

    #[test]
    fn area_converges_and_depth_interpolates() {
        let p = [
            DVec2::new(1.3, 2.1),
            DVec2::new(90.7, 10.2),
            DVec2::new(40.1, 77.7),
        ];
        let exact = 0.5 * (p[1] - p[0]).perp_dot(p[2] - p[0]);
        let n = cover(p, 100, 100).len() as f64;
        assert!((n - exact).abs() / exact < 0.02, "{n} vs {exact}");
        // Depth is an affine function of position: check at one covered pixel.
        let d = [1.0, 2.0, 5.0];
        rasterize(p, d, 100, 100, |i, j, z| {
            let c = DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
            let a = (p[1] - p[0]).perp_dot(p[2] - p[0]);
            let l1 = (c - p[0]).perp_dot(p[2] - p[0]) / a;
            let l2 = (p[1] - p[0]).perp_dot(c - p[0]) / a;
            let expect = d[0] * (1.0 - l1 - l2) + d[1] * l1 + d[2] * l2;
            assert!((z - expect).abs() < 1e-9);
        });
    }

    #[test]
    fn shared_edges_cover_each_centre_exactly_once() {
        // A square split along its diagonal, with vertices on pixel centres so ties occur.
        let a = DVec2::new(0.5, 0.5);
        let b = DVec2::new(8.5, 0.5);
        let c = DVec2::new(8.5, 8.5);
        let d = DVec2::new(0.5, 8.5);
        let mut count = vec![0; 100];
        for t in [[a, b, c], [a, c, d]] {
            for (i, j) in cover(t, 10, 10) {
                count[(j * 10 + i) as usize] += 1;
            }
        }
        assert!(count.iter().all(|&c| c <= 1));
        // Interior and diagonal pixels (strictly inside the square) are covered once.
        for j in 1..8 {
            for i in 1..8 {
                assert_eq!(count[j * 10 + i], 1, "pixel {i},{j}");
            }
        }
    }

    #[test]
    fn children_partition_parent() {
        let p = [
            DVec2::new(0.2, 0.3),
            DVec2::new(31.9, 5.5),
            DVec2::new(12.25, 29.75),
        ];
        let m = |a: DVec2, b: DVec2| (a + b) * 0.5;
        let (ab, bc, ca) = (m(p[0], p[1]), m(p[1], p[2]), m(p[2], p[0]));
        let kids = [[p[0], ab, ca], [ab, p[1], bc], [ca, bc, p[2]], [ab, bc, ca]];
        let mut parent = cover(p, 32, 32);
        let mut children: Vec<_> = kids.iter().flat_map(|k| cover(*k, 32, 32)).collect();
        parent.sort();
        children.sort();
        assert_eq!(parent, children);
    }

    #[test]
    fn degenerate_and_offscreen_cover_nothing() {
        let line = [DVec2::ZERO, DVec2::new(5.0, 5.0), DVec2::new(10.0, 10.0)];
        assert!(cover(line, 16, 16).is_empty());
        let off = [
            DVec2::new(-9.0, -9.0),
            DVec2::new(-1.0, -9.0),
            DVec2::new(-5.0, -1.0),
        ];
        assert!(cover(off, 16, 16).is_empty());
        let nan = [DVec2::new(f64::NAN, 0.0), DVec2::X, DVec2::Y];
        assert!(cover(nan, 16, 16).is_empty());
    }

    /// Every pixel of the grid tested against the edges with the owner rule, as the
    /// rasteriser defines coverage: the reference for its row spans.
    fn every_pixel(p: [DVec2; 3], d: [f64; 3], w: u32, h: u32) -> Vec<(u32, u32, u64)> {
        let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        if !area2.is_finite() || area2 == 0.0 {
            return Vec::new();
        }
        let (p, d) = if area2 < 0.0 {
            ([p[0], p[2], p[1]], [d[0], d[2], d[1]])
        } else {
            (p, d)
        };
        let mut out = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let c = DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
                let mut e = [0.0; 3];
                let inside = (0..3).all(|k| {
                    let (a, b) = (p[k], p[(k + 1) % 3]);
                    let dd = b - a;
                    let owner = dd.y > 0.0 || (dd.y == 0.0 && dd.x < 0.0);
                    e[k] = dd.perp_dot(c - a);
                    e[k] > 0.0 || (e[k] == 0.0 && owner)
                });
                if inside {
                    let z = (e[0] * d[2] + e[1] * d[0] + e[2] * d[1]) / area2.abs();
                    out.push((i, j, z.to_bits()));
                }
            }
        }
        out
    }

    /// The row spans only bound where pixels are tested: the covered pixels and their
    /// depths are those of testing every pixel of the bounding box, slivers and
    /// off-screen corners included.
    #[test]
    fn row_spans_cover_what_testing_every_pixel_covers() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |scale: f64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * scale - 0.1 * scale
        };
        for k in 0..2000 {
            let scale = [12.0, 70.0, 300.0][k % 3];
            let mut p = [0; 3].map(|_| DVec2::new(next(scale), next(scale)));
            if k % 5 == 0 {
                // A sliver: the third vertex near the first edge.
                p[2] = p[0] + (p[1] - p[0]) * 0.37 + DVec2::new(1e-3, -2e-3);
            }
            let d = [next(1.0), next(1.0), next(1.0)];
            let (w, h) = (64, 48);
            let mut got = Vec::new();
            rasterize(p, d, w, h, |i, j, z| got.push((i, j, z.to_bits())));
            assert_eq!(got, every_pixel(p, d, w, h), "triangle {p:?}");
        }
    }
}
