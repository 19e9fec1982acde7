//! Unit tests of the BVH ([`super`]): hits against brute force, ordering, degenerate and
//! empty inputs, region queries.

use super::*;
use crate::math::rng::uniform;

/// Unit normal of a vertex triple (test helper).
struct Triangle([DVec3; 3]);
impl From<[DVec3; 3]> for Triangle {
    fn from(v: [DVec3; 3]) -> Self {
        Triangle(v)
    }
}
impl Triangle {
    fn normal(&self) -> DVec3 {
        (self.0[1] - self.0[0])
            .cross(self.0[2] - self.0[0])
            .normalize()
    }
}

fn square(z: f64) -> Vec<[DVec3; 3]> {
    let p = |x: f64, y: f64| DVec3::new(x, y, z);
    vec![
        [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
        [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
    ]
}

fn all_hits(bvh: &Bvh, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Vec<Hit> {
    let mut v = Vec::new();
    bvh.hits_in_order(o, d, t_min, t_max, |h| {
        v.push(h);
        true
    });
    v
}

/// What a visit that stops at its first hit on a `stops` triangle sees through
/// [`Bvh::hits_in_order_until`].
fn visits_until(
    bvh: &Bvh,
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
    stops: impl Fn(u32) -> bool + Copy,
) -> Vec<Hit> {
    let mut v = Vec::new();
    bvh.hits_in_order_until(o, d, t_min, t_max, stops, |h| {
        v.push(h);
        !stops(h.triangle)
    });
    v
}

#[test]
fn pruned_visits_keep_a_stop_dropped_as_a_coplanar_duplicate() {
    // A pane (0, 1) with an opaque copy of itself (2, 3) in the same place and
    // orientation, and an opaque square beyond (4, 5). The copy's hit is the nearest stop,
    // but the list keeps the pane's (lower index) and drops it: the walk goes on to the
    // square, with or without pruning.
    let tris: Vec<_> = square(1.0)
        .into_iter()
        .chain(square(1.0))
        .chain(square(3.0))
        .collect();
    let bvh = Bvh::build(&tris);
    let stops = |t: u32| t >= 2;
    let o = DVec3::new(0.3, 0.6, 0.0);
    let want = all_hits(&bvh, o, DVec3::Z, 0.0, f64::INFINITY);
    assert_eq!(
        want.iter().map(|h| h.triangle).collect::<Vec<_>>(),
        vec![1, 5]
    );
    assert_eq!(
        visits_until(&bvh, o, DVec3::Z, 0.0, f64::INFINITY, stops),
        want
    );
}

/// Reference: the same intersection test over every triangle, no hierarchy.
fn brute_hits(tris: &[[DVec3; 3]], o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Vec<Hit> {
    let ray = Ray::new(o, d);
    let mut hits = Vec::new();
    for (i, t) in tris.iter().enumerate() {
        if is_degenerate(t) {
            continue;
        }
        if let Some((t, cos, n)) = ray.hit_triangle(t, t_min, t_max) {
            hits.push((
                Hit {
                    triangle: i as u32,
                    t,
                    cos,
                },
                n,
            ));
        }
    }
    sort_and_dedup(&mut hits);
    hits.into_iter().map(|h| h.0).collect()
}

#[test]
fn unit_square_hit_at_analytic_t_from_both_sides() {
    let bvh = Bvh::build(&square(0.0));
    assert_eq!(bvh.len(), 2);
    let h = all_hits(
        &bvh,
        DVec3::new(0.3, 0.6, 2.0),
        -DVec3::Z,
        0.0,
        f64::INFINITY,
    );
    assert_eq!(h.len(), 1);
    assert_eq!(h[0].triangle, 1);
    assert!((h[0].t - 2.0).abs() < 1e-12);
    assert!((h[0].cos + 1.0).abs() < 1e-12);
    // From below: the back face counts too, with a positive cosine.
    let h = all_hits(
        &bvh,
        DVec3::new(0.7, 0.2, -1.5),
        DVec3::Z,
        0.0,
        f64::INFINITY,
    );
    assert_eq!(h.len(), 1);
    assert_eq!(h[0].triangle, 0);
    assert!((h[0].t - 1.5).abs() < 1e-12 && (h[0].cos - 1.0).abs() < 1e-12);
    // Oblique: from (0.5, 0.5, 1) along (1, 0, -1)/√2 reaches z = 0 at x = 1.5 → miss;
    // along (0.3, 0, -1)/|…| it reaches x = 0.8 at t = √(1.09).
    let d = DVec3::new(0.3, 0.0, -1.0).normalize();
    let h = bvh
        .closest_hit(DVec3::new(0.5, 0.5, 1.0), d, 0.0, f64::INFINITY)
        .unwrap();
    assert!((h.t - 1.09_f64.sqrt()).abs() < 1e-12);
    assert!((h.cos + 1.0 / 1.09_f64.sqrt()).abs() < 1e-12);
    let d = DVec3::new(1.0, 0.0, -1.0).normalize();
    assert!(!bvh.any_hit(DVec3::new(0.5, 0.5, 1.0), d, 0.0, f64::INFINITY));
}

#[test]
fn rays_just_outside_miss_and_edges_are_watertight() {
    let bvh = Bvh::build(&square(0.0));
    for (x, y) in [
        (1.0 + 1e-9, 0.5),
        (-1e-9, 0.5),
        (0.5, 1.0 + 1e-9),
        (0.5, -1e-9),
    ] {
        assert!(
            !bvh.any_hit(DVec3::new(x, y, 1.0), -DVec3::Z, 0.0, 10.0),
            "({x}, {y})"
        );
    }
    // Just inside hits.
    assert!(bvh.any_hit(DVec3::new(1.0 - 1e-9, 0.5, 1.0), -DVec3::Z, 0.0, 10.0));
    // Through the shared diagonal and the shared vertices: exactly one reported hit.
    for (x, y) in [(0.5, 0.5), (0.25, 0.25), (0.0, 0.0), (1.0, 1.0)] {
        let h = all_hits(&bvh, DVec3::new(x, y, 1.0), -DVec3::Z, 0.0, 10.0);
        assert_eq!(h.len(), 1, "({x}, {y}): {h:?}");
        assert_eq!(h[0].triangle, 0);
    }
}

#[test]
fn three_parallel_planes_in_order_with_range_and_early_stop() {
    let mut tris = square(2.0);
    tris.extend(square(0.0));
    tris.extend(square(1.0));
    let bvh = Bvh::build(&tris);
    let o = DVec3::new(0.4, 0.3, -1.0);
    let h = all_hits(&bvh, o, DVec3::Z, 0.0, f64::INFINITY);
    let ts: Vec<f64> = h.iter().map(|h| h.t).collect();
    assert_eq!(ts.len(), 3);
    for (t, want) in ts.iter().zip([1.0, 2.0, 3.0]) {
        assert!((t - want).abs() < 1e-12, "{ts:?}");
    }
    let ids: Vec<u32> = h.iter().map(|h| h.triangle).collect();
    assert_eq!(ids, vec![2, 4, 0]);
    // Only t_min < t < t_max counts (exact boundary equality is up to rounding).
    let h = all_hits(&bvh, o, DVec3::Z, 1.0 + 1e-9, 3.0 - 1e-9);
    assert_eq!(h.len(), 1);
    assert!((h[0].t - 2.0).abs() < 1e-12);
    assert_eq!(all_hits(&bvh, o, DVec3::Z, 1.0 - 1e-9, 3.0 + 1e-9).len(), 3);
    assert_eq!(all_hits(&bvh, o, DVec3::Z, 0.0, 1.0 - 1e-9).len(), 0);
    // Early stop after the second hit.
    let mut seen = 0;
    bvh.hits_in_order(o, DVec3::Z, 0.0, f64::INFINITY, |_| {
        seen += 1;
        seen < 2
    });
    assert_eq!(seen, 2);
    assert_eq!(
        bvh.closest_hit(o, DVec3::Z, 0.0, f64::INFINITY)
            .unwrap()
            .triangle,
        2
    );
}

#[test]
fn degenerate_never_hit_sliver_hit_parallel_missed() {
    let z = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    let tris = vec![
        [z(0.0, 0.0), z(1.0, 1.0), z(2.0, 2.0)], // collinear
        [z(0.0, 0.0), z(0.0, 0.0), z(1.0, 0.0)], // repeated vertex
        [z(0.1, 0.1), z(0.3, 0.3), z(0.7, 0.7)], // collinear, inexact coordinates
        // Sliver: base 1 m, height 2e-10 m → area 1e-10 m².
        [
            DVec3::new(0.0, 5.0, 0.0),
            DVec3::new(1.0, 5.0, 0.0),
            DVec3::new(0.5, 5.0 + 2e-10, 0.0),
        ],
    ];
    let bvh = Bvh::build(&tris);
    assert_eq!((bvh.len(), bvh.hittable_len()), (4, 1));
    for p in [z(1.0, 1.0), z(0.3, 0.3), z(0.5, 0.5), z(0.0, 0.0)] {
        for d in [-DVec3::Z, DVec3::new(1.0, -1.0, -1.0).normalize()] {
            assert!(all_hits(&bvh, p - d, d, 0.0, 10.0).is_empty());
        }
    }
    let h = bvh
        .closest_hit(DVec3::new(0.5, 5.0 + 0.5e-10, 1.0), -DVec3::Z, 0.0, 2.0)
        .unwrap();
    assert_eq!(h.triangle, 3);
    assert!((h.t - 1.0).abs() < 1e-12);
    assert!(!bvh.any_hit(DVec3::new(0.5, 5.0 + 3e-10, 1.0), -DVec3::Z, 0.0, 2.0));
    assert!(!bvh.any_hit(DVec3::new(0.5, 5.0 - 1e-10, 1.0), -DVec3::Z, 0.0, 2.0));

    // Parallel rays: in the plane (axis-aligned and generic) and offset from it.
    let n = DVec3::new(1.0, 2.0, 3.0).normalize();
    let u = n.any_orthonormal_vector();
    let w = n.cross(u);
    let c = DVec3::new(0.3, -0.7, 0.2);
    let tilted = [c - u - w, c + 2.0 * u - w, c + w];
    let bvh2 = Bvh::build(&[tilted, square(0.0)[0]]);
    for k in 0..200 {
        let a = k as f64 * 0.1;
        let d = (a.cos() * u + a.sin() * w).normalize();
        assert!(!bvh2.any_hit(c - 3.0 * d, d, 0.0, 10.0), "in-plane {k}");
        assert!(
            !bvh2.any_hit(c + 1e-6 * n - 3.0 * d, d, 0.0, 10.0),
            "offset {k}"
        );
    }
    assert!(!bvh2.any_hit(DVec3::new(-1.0, 0.5, 0.0), DVec3::X, 0.0, 10.0));
    assert!(!bvh2.any_hit(DVec3::new(-1.0, 0.5, 1e-9), DVec3::X, 0.0, 10.0));
}

#[test]
fn far_coordinates_keep_precision() {
    let off = DVec3::new(1000.0, -1000.0, 1000.0);
    let tris: Vec<_> = square(0.0)
        .into_iter()
        .map(|t| t.map(|v| v + off))
        .collect();
    let bvh = Bvh::build(&tris);
    let o = off + DVec3::new(0.123456789, 0.987654321, 3.25);
    let h = bvh.closest_hit(o, -DVec3::Z, 0.0, f64::INFINITY).unwrap();
    assert!((h.t - 3.25).abs() < 1e-10);
    assert!(!bvh.any_hit(off + DVec3::new(1.0 + 1e-9, 0.5, 1.0), -DVec3::Z, 0.0, 5.0));
}

#[test]
fn closed_fan_mesh_never_leaks() {
    // A cube whose faces are fans around their centres: rays from inside aimed exactly
    // at the mesh's vertices and edges must all hit.
    let mut tris = Vec::new();
    for axis in 0..3 {
        for s in [-1.0, 1.0] {
            let e = |i: usize| DVec3::from_array(std::array::from_fn(|k| (k == i) as u8 as f64));
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let c = e(axis) * s;
            let corners = [
                c - e(a) - e(b),
                c + e(a) - e(b),
                c + e(a) + e(b),
                c - e(a) + e(b),
            ];
            for k in 0..4 {
                tris.push([c, corners[k], corners[(k + 1) % 4]]);
            }
        }
    }
    let bvh = Bvh::build(&tris);
    let origins = [DVec3::ZERO, DVec3::new(0.1, -0.2, 0.3)];
    let mut targets = Vec::new();
    for t in &tris {
        for v in t {
            targets.push(*v);
        }
        targets.push((t[0] + t[1]) * 0.5);
        targets.push((t[1] + t[2]) * 0.5);
        targets.push((t[0] + t[2]) * 0.5);
    }
    for o in origins {
        for &p in &targets {
            let d = (p - o).normalize();
            let h = all_hits(&bvh, o, d, 0.0, 100.0);
            // One hit per face plane met: 1 inside a face, 2 on a cube edge, 3 at a
            // corner; never zero (a leak) and never the same plane twice.
            assert!(!h.is_empty(), "leak from {o} to {p}");
            let want = (p - o).length();
            for (k, a) in h.iter().enumerate() {
                assert!((a.t - want).abs() < 1e-12, "from {o} to {p}: {h:?}");
                let na = Triangle::from(tris[a.triangle as usize]).normal();
                for b in &h[k + 1..] {
                    let nb = Triangle::from(tris[b.triangle as usize]).normal();
                    assert!(na.dot(nb) < 0.5, "same plane twice: {h:?}");
                }
            }
            let on_faces = [p.x, p.y, p.z].iter().filter(|c| c.abs() == 1.0).count();
            // Off-centre, the normalised direction misses an exact edge or corner by
            // rounding, so fewer planes may be met; from the centre it is exact.
            if o == DVec3::ZERO {
                assert_eq!(h.len(), on_faces, "from {o} to {p}: {h:?}");
            } else {
                assert!(h.len() <= on_faces, "from {o} to {p}: {h:?}");
            }
        }
    }
}

#[test]
fn bvh_equals_brute_force_on_random_rays() {
    let seed = 0x5eed_b5b5;
    let r = |stream: u64, i: u64| uniform(seed, stream, i);
    let n_tris = 400u64;
    let mut tris = Vec::new();
    for i in 0..n_tris {
        let c = DVec3::new(r(0, i), r(1, i), r(2, i)) * 20.0 - 10.0;
        // Mostly small triangles, some large ones spanning much of the box.
        let size = if i % 10 == 0 {
            8.0
        } else {
            0.3 + 2.0 * r(3, i)
        };
        let v = |k: u64| {
            c + (DVec3::new(r(4 + 3 * k, i), r(5 + 3 * k, i), r(6 + 3 * k, i)) - 0.5) * size
        };
        tris.push([v(0), v(1), v(2)]);
    }
    // A few degenerate ones mixed in.
    tris.push([DVec3::ZERO, DVec3::ZERO, DVec3::ONE]);
    tris.push([DVec3::ZERO, DVec3::ONE, DVec3::splat(2.0)]);
    let bvh = Bvh::build(&tris);
    let mut total = 0;
    for i in 0..4000u64 {
        let o = DVec3::new(r(20, i), r(21, i), r(22, i)) * 24.0 - 12.0;
        let z = 2.0 * r(23, i) - 1.0;
        let phi = std::f64::consts::TAU * r(24, i);
        let s = (1.0 - z * z).sqrt();
        let d = DVec3::new(s * phi.cos(), s * phi.sin(), z);
        let (t_min, t_max) = if i % 3 == 0 {
            (0.5, 8.0)
        } else {
            (0.0, f64::INFINITY)
        };
        let want = brute_hits(&tris, o, d, t_min, t_max);
        let got = all_hits(&bvh, o, d, t_min, t_max);
        assert_eq!(got, want, "ray {i}");
        assert_eq!(bvh.any_hit(o, d, t_min, t_max), !want.is_empty());
        assert_eq!(bvh.closest_hit(o, d, t_min, t_max), want.first().copied());
        // A visit that stops at its first "opaque" triangle (every third) sees the same
        // hits when the traversal prunes past it.
        let stops = |t: u32| t % 3 == 0;
        let until = visits_until(&bvh, o, d, t_min, t_max, stops);
        let end = want.iter().position(|h| stops(h.triangle));
        assert_eq!(until, want[..end.map_or(want.len(), |e| e + 1)], "ray {i}");
        total += want.len();
    }
    assert!(total > 500, "test should exercise many hits, got {total}");
}

#[test]
fn empty_bvh() {
    let bvh = Bvh::build(&[]);
    assert!(bvh.is_empty());
    assert!(!bvh.any_hit(DVec3::ZERO, DVec3::Z, 0.0, f64::INFINITY));
    assert!(bvh
        .closest_hit(DVec3::ZERO, DVec3::Z, 0.0, f64::INFINITY)
        .is_none());
}

#[test]
fn f32_boxes_round_outwards_by_at_most_one_step() {
    let seed = 0xb0c5;
    for i in 0..20_000u64 {
        let mag = 10f64.powf(uniform(seed, 0, i) * 24.0 - 12.0);
        let x = match i % 4 {
            0 => mag,
            1 => -mag,
            2 => (mag as f32) as f64, // exactly representable
            _ => 0.0,
        };
        let (lo, hi) = (f32_toward(x, false), f32_toward(x, true));
        assert!(lo as f64 <= x && x <= hi as f64, "{x}: {lo} {hi}");
        if (x as f32) as f64 == x {
            assert_eq!((lo, hi), (x as f32, x as f32));
        } else {
            assert_eq!(hi, next_up_f32(lo), "{x}");
        }
    }
}

#[test]
fn every_node_box_holds_its_triangles_far_from_the_origin() {
    // f32 boxes at 1e6 m are 6 cm apart: the rounding must still hold every vertex.
    let off = DVec3::new(1.0e6, -2.5e6, 3.0e5);
    let r = |stream: u64, i: u64| uniform(0xfa7, stream, i);
    let tris: Vec<[DVec3; 3]> = (0..300u64)
        .map(|i| {
            let c = off + (DVec3::new(r(0, i), r(1, i), r(2, i)) - 0.5) * 50.0;
            [0, 1, 2].map(|k| c + (DVec3::new(r(3 + k, i), r(6 + k, i), r(9 + k, i)) - 0.5))
        })
        .collect();
    let bvh = Bvh::build(&tris);
    // Walk down from the root: every child's box contains its subtree's vertices.
    fn check(bvh: &Bvh, ni: usize) -> (DVec3, DVec3) {
        let n = &bvh.nodes[ni];
        let mut all = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for j in (0..4).filter(|&j| n.count[j] != EMPTY) {
            let (lo, hi) = if n.count[j] > 0 {
                let s = n.child[j] as usize;
                let vs = bvh.tris[s..s + n.count[j] as usize].iter().flatten();
                vs.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), v| {
                    (a.min(*v), b.max(*v))
                })
            } else {
                check(bvh, n.child[j] as usize)
            };
            assert!(
                n.lo(j).cmple(lo).all() && n.hi(j).cmpge(hi).all(),
                "node {ni} child {j}"
            );
            all = (all.0.min(lo), all.1.max(hi));
        }
        all
    }
    check(&bvh, 0);
    // And rays aimed at vertices still find them.
    for (i, t) in tris.iter().enumerate().take(100) {
        let target = t[i % 3];
        let o = target + DVec3::new(0.3, -0.2, 7.0);
        let d = (target - o).normalize();
        assert!(bvh.any_hit(o, d, 0.0, 20.0), "triangle {i}");
    }
}

#[test]
fn the_four_wide_tree_holds_every_triangle_once() {
    // Sizes around the collapse's edge cases: a leaf root, a root with two or three
    // children, and deep trees.
    for n in [1usize, 2, 3, 5, 9, 17, 40, 333, 2000] {
        let r = |stream: u64, i: u64| uniform(0x4a1, stream, i);
        let tris: Vec<[DVec3; 3]> = (0..n as u64)
            .map(|i| {
                let c = DVec3::new(r(0, i), r(1, i), r(2, i)) * 20.0;
                [0, 1, 2].map(|k| c + DVec3::new(r(3 + k, i), r(6 + k, i), r(9 + k, i)))
            })
            .collect();
        let bvh = Bvh::build(&tris);
        let mut seen = vec![0u32; bvh.tris.len()];
        let mut inner = vec![0u32; bvh.nodes.len()];
        let mut stack = vec![0usize];
        inner[0] = 1;
        while let Some(ni) = stack.pop() {
            let node = &bvh.nodes[ni];
            let used = (0..4).filter(|&j| node.count[j] != EMPTY).count();
            // Slots are filled from the first; a node holds four unless its subtree has
            // fewer leaves.
            assert!((0..used).all(|j| node.count[j] != EMPTY), "n {n} node {ni}");
            for j in 0..used {
                let (c, k) = (node.child[j] as usize, node.count[j] as usize);
                if k > 0 {
                    seen[c..c + k].iter_mut().for_each(|s| *s += 1);
                } else {
                    inner[c] += 1;
                    stack.push(c);
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "n {n}: {seen:?}");
        assert!(
            inner.iter().all(|&s| s == 1),
            "n {n}: a node reached twice or never"
        );
    }
}
