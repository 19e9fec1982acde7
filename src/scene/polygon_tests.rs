//! Unit tests of [`super::triangulate`]: areas against the shoelace formula, orientation,
//! holes of either winding, repeated and collinear vertices, the three issues, and random
//! input that must never panic.

use super::*;
use proptest::prelude::*;

fn p(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(x, y, z)
}

/// Points in the plane z = 0.
fn xy(pts: &[(f64, f64)]) -> Vec<DVec3> {
    pts.iter().map(|&(x, y)| p(x, y, 0.0)).collect()
}

fn area(t: &Triangulated) -> f64 {
    t.triangles
        .iter()
        .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
        .sum()
}

/// Every triangle's unit normal.
fn normals(t: &Triangulated) -> Vec<DVec3> {
    t.triangles
        .iter()
        .map(|[a, b, c]| (*b - *a).cross(*c - *a).normalize())
        .collect()
}

const SQUARE: [(f64, f64); 4] = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)];

#[test]
fn concave_l_has_its_exact_area() {
    // 3 × 3 square less its 2 × 2 upper-right corner: 9 − 4 = 5 m².
    let l = xy(&[
        (0.0, 0.0),
        (3.0, 0.0),
        (3.0, 1.0),
        (1.0, 1.0),
        (1.0, 3.0),
        (0.0, 3.0),
    ]);
    let t = triangulate(&l, &[], 0.01);
    assert!(t.issues.is_empty(), "{:?}", t.issues);
    assert_eq!(t.triangles.len(), 4);
    assert!((area(&t) - 5.0).abs() < 1e-12, "{}", area(&t));
    // Every vertex is one of the input's, bit for bit.
    for v in t.triangles.iter().flatten() {
        assert!(l.contains(v), "{v}");
    }
}

#[test]
fn square_with_hole_is_outer_minus_hole_for_either_hole_winding() {
    let outer = xy(&SQUARE);
    let hole = xy(&[(1.0, 1.0), (2.0, 1.0), (2.0, 3.0), (1.0, 3.0)]);
    let reversed: Vec<DVec3> = hole.iter().rev().copied().collect();
    for h in [hole, reversed] {
        let t = triangulate(&outer, std::slice::from_ref(&h), 0.01);
        assert!(t.issues.is_empty(), "{:?}", t.issues);
        assert!((area(&t) - (16.0 - 2.0)).abs() < 1e-12, "{}", area(&t));
        // Nothing inside the hole: no triangle's centroid lies in it.
        for [a, b, c] in &t.triangles {
            let m = (*a + *b + *c) / 3.0;
            assert!(!(m.x > 1.0 && m.x < 2.0 && m.y > 1.0 && m.y < 3.0), "{m}");
        }
        assert!(normals(&t).iter().all(|n| *n == DVec3::Z));
    }
}

#[test]
fn front_follows_the_boundary_winding() {
    let ccw = xy(&SQUARE);
    let cw: Vec<DVec3> = ccw.iter().rev().copied().collect();
    let up = triangulate(&ccw, &[], 0.01);
    let down = triangulate(&cw, &[], 0.01);
    assert!(normals(&up).iter().all(|n| *n == DVec3::Z));
    assert!(normals(&down).iter().all(|n| *n == -DVec3::Z));
    // A wall in the XZ plane wound (0,0,0) → (4,0,0) → (4,0,3): right-hand rule gives −Y.
    let wall = [
        p(0.0, 0.0, 0.0),
        p(4.0, 0.0, 0.0),
        p(4.0, 0.0, 3.0),
        p(0.0, 0.0, 3.0),
    ];
    let t = triangulate(&wall, &[], 0.01);
    assert!((area(&t) - 12.0).abs() < 1e-12);
    for n in normals(&t) {
        assert!((n - p(0.0, -1.0, 0.0)).length() < 1e-15, "{n}");
    }
}

#[test]
fn repeated_and_collinear_vertices_change_nothing() {
    let messy = xy(&[
        (0.0, 0.0),
        (0.0, 0.0),
        (2.0, 0.0),
        (4.0, 0.0),
        (4.0, 4.0),
        (4.0, 4.0),
        (2.0, 4.0),
        (0.0, 4.0),
        (0.0, 0.0),
    ]);
    let t = triangulate(&messy, &[], 0.01);
    assert!(t.issues.is_empty(), "{:?}", t.issues);
    assert!((area(&t) - 16.0).abs() < 1e-12);
    for [a, b, c] in &t.triangles {
        assert!((*b - *a).cross(*c - *a).length() > 0.0);
    }
    // A degenerate hole (two points) is ignored.
    let t = triangulate(&xy(&SQUARE), &[xy(&[(1.0, 1.0), (2.0, 2.0)])], 0.01);
    assert!((area(&t) - 16.0).abs() < 1e-12);
}

#[test]
fn bow_tie_is_self_intersecting() {
    // Lobes of different size, so the Newell area (their difference) is not zero.
    let t = triangulate(
        &xy(&[(0.0, 0.0), (4.0, 2.0), (4.0, 0.0), (0.0, 4.0)]),
        &[],
        0.01,
    );
    assert!(
        t.issues.contains(&PolygonIssue::SelfIntersecting),
        "{:?}",
        t.issues
    );
    // A symmetric one encloses no net area.
    let t = triangulate(
        &xy(&[(0.0, 0.0), (2.0, 2.0), (2.0, 0.0), (0.0, 2.0)]),
        &[],
        0.01,
    );
    assert_eq!(t.issues, [PolygonIssue::ZeroArea]);
    assert!(t.triangles.is_empty());
    // A hole crossing the boundary is self-intersecting too.
    let t = triangulate(
        &xy(&SQUARE),
        &[xy(&[(3.0, 1.0), (5.0, 1.0), (5.0, 2.0), (3.0, 2.0)])],
        0.01,
    );
    assert!(
        t.issues.contains(&PolygonIssue::SelfIntersecting),
        "{:?}",
        t.issues
    );
}

#[test]
fn a_door_touching_the_wall_bottom_is_cut_out() {
    // The door's sill lies on the wall's bottom edge, as honeybee doors do; and a window
    // touching a wall's corner.
    let wall = xy(&[(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0)]);
    let door = xy(&[(1.0, 0.0), (2.0, 0.0), (2.0, 2.0), (1.0, 2.0)]);
    let corner = xy(&[(3.0, 2.0), (4.0, 2.0), (4.0, 3.0), (3.0, 3.0)]);
    for holes in [vec![door.clone()], vec![door, corner]] {
        let t = triangulate(&wall, &holes, 0.01);
        assert!(t.issues.is_empty(), "{:?}", t.issues);
        let want = 12.0 - holes.iter().map(|h| shoelace(h)).sum::<f64>();
        assert!((area(&t) - want).abs() < 1e-12, "{} vs {want}", area(&t));
        assert!(encloses(&wall, &[], &holes[0], 0.01));
    }
}

#[test]
fn encloses_needs_the_plane_the_outline_and_no_hole() {
    let wall = xy(&SQUARE);
    let win = xy(&[(1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)]);
    assert!(encloses(&wall, &[], &win, 0.01));
    // Within tolerance of the plane and of the outline.
    let near: Vec<DVec3> = win.iter().map(|v| *v + p(2.005, 0.0, 0.005)).collect();
    assert!(encloses(&wall, &[], &near, 0.01));
    let off_plane: Vec<DVec3> = win.iter().map(|v| *v + p(0.0, 0.0, 0.5)).collect();
    assert!(!encloses(&wall, &[], &off_plane, 0.01));
    let beyond: Vec<DVec3> = win.iter().map(|v| *v + p(2.5, 0.0, 0.0)).collect();
    assert!(!encloses(&wall, &[], &beyond, 0.01));
    let hole = xy(&[(0.5, 0.5), (2.5, 0.5), (2.5, 2.5), (0.5, 2.5)]);
    assert!(!encloses(&wall, &[hole], &win, 0.01));
    assert!(!encloses(
        &xy(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]),
        &[],
        &win,
        0.01
    ));
}

#[test]
fn a_seam_joining_a_hole_is_not_self_intersecting() {
    // The outline walks in to the hole along x = 0..1 at y = 1 and back out along the same
    // line, as exporters write a face with a hole as one polygon.
    let seam = xy(&[
        (0.0, 0.0),
        (4.0, 0.0),
        (4.0, 4.0),
        (0.0, 4.0),
        (0.0, 1.0),
        (1.0, 1.0),
        (1.0, 3.0),
        (2.0, 3.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (0.0, 1.0),
    ]);
    let t = triangulate(&seam, &[], 0.01);
    assert!(
        !t.issues.contains(&PolygonIssue::SelfIntersecting),
        "{:?}",
        t.issues
    );
    assert!((area(&t) - 14.0).abs() < 1e-9, "{}", area(&t));
}

#[test]
fn warped_quad_is_non_planar_beyond_tolerance_only() {
    // One corner lifted by h: the Newell normal is the diagonals' cross product
    // (−h, −h, 2), and every corner lies h / (2 √(2h² + 4)) from the mean plane.
    let quad = |h: f64| {
        [
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, h),
            p(0.0, 1.0, 0.0),
        ]
    };
    let t = triangulate(&quad(0.2), &[], 0.01);
    match t.issues.as_slice() {
        [PolygonIssue::NonPlanar { deviation_m }] => {
            let want = 0.2 / (2.0 * (2.0 * 0.04 + 4.0_f64).sqrt());
            assert!(
                (deviation_m - want).abs() < 1e-15,
                "{deviation_m} vs {want}"
            )
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(t.triangles.len(), 2);
    assert!(triangulate(&quad(0.02), &[], 0.01).issues.is_empty());
    // Tolerance 0 checks nothing.
    assert!(triangulate(&quad(0.2), &[], 0.0).issues.is_empty());
}

#[test]
fn degenerate_input_gives_zero_area() {
    let zero = [PolygonIssue::ZeroArea];
    assert_eq!(triangulate(&[], &[], 0.01).issues, zero);
    assert_eq!(
        triangulate(&xy(&[(0.0, 0.0), (1.0, 0.0)]), &[], 0.01).issues,
        zero
    );
    let line = xy(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]);
    assert_eq!(triangulate(&line, &[], 0.01).issues, zero);
    let same = xy(&[(1.0, 1.0), (1.0, 1.0), (1.0, 1.0)]);
    assert_eq!(triangulate(&same, &[], 0.01).issues, zero);
    let nan = [p(0.0, 0.0, 0.0), p(f64::NAN, 0.0, 0.0), p(0.0, 1.0, 0.0)];
    assert_eq!(triangulate(&nan, &[], 0.01).issues, zero);
    let inf = [
        p(0.0, 0.0, 0.0),
        p(1.0, 0.0, 0.0),
        p(0.0, f64::INFINITY, 0.0),
    ];
    assert_eq!(triangulate(&inf, &[], 0.01).issues, zero);
    let huge = [
        p(0.0, 0.0, 0.0),
        p(f64::MAX, 0.0, 0.0),
        p(0.0, f64::MAX, 0.0),
    ];
    assert!(triangulate(&huge, &[], 0.01)
        .triangles
        .iter()
        .flatten()
        .all(|v| v.is_finite()));
}

#[test]
fn far_from_origin_keeps_precision() {
    let off = p(4.0e6, 5.0e6, 120.0);
    let ring: Vec<DVec3> = xy(&SQUARE).iter().map(|v| *v + off).collect();
    let t = triangulate(&ring, &[], 0.01);
    assert!(t.issues.is_empty());
    assert!((area(&t) - 16.0).abs() < 1e-6, "{}", area(&t));
}

/// A simple polygon, star-shaped about the origin: n ≥ 4 vertices at angles
/// (k + jitter) 2π/n, so that no angular gap reaches π, radii in [0.2, 1], scaled and laid
/// on the plane through the origin with normal `normal`.
fn star(jitter: &[f64], radii: &[f64], scale: f64, normal: DVec3) -> Vec<DVec3> {
    let n = normal.normalize();
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let count = jitter.len() as f64;
    jitter
        .iter()
        .zip(radii)
        .enumerate()
        .map(|(k, (j, r))| {
            let t = (k as f64 + j) * std::f64::consts::TAU / count;
            (u * t.cos() + v * t.sin()) * r * scale
        })
        .collect()
}

/// Twice the area of a planar ring (the length of its Newell vector).
fn shoelace(ring: &[DVec3]) -> f64 {
    0.5 * newell(ring, ring[0]).length()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_points_never_panic(
        pts in proptest::collection::vec((-10.0..10.0f64, -10.0..10.0f64, -1.0..1.0f64), 0..24),
        hole in proptest::collection::vec((-10.0..10.0f64, -10.0..10.0f64, -1.0..1.0f64), 0..8),
        tol in prop_oneof![Just(0.0), 0.0..1.0f64, Just(f64::NAN)],
    ) {
        let ring: Vec<DVec3> = pts.iter().map(|&(x, y, z)| p(x, y, z)).collect();
        let hole: Vec<DVec3> = hole.iter().map(|&(x, y, z)| p(x, y, z)).collect();
        let t = triangulate(&ring, &[hole], tol);
        for [a, b, c] in &t.triangles {
            let s = 0.5 * (*b - *a).cross(*c - *a).length();
            prop_assert!(s.is_finite());
        }
    }

    #[test]
    fn extreme_and_repeated_points_never_panic(
        pts in proptest::collection::vec(
            (0usize..6, prop_oneof![Just(1.0), Just(1e-300), Just(1e300), Just(-1e150)]),
            0..30,
        ),
        holes in proptest::collection::vec(proptest::collection::vec(0usize..6, 0..6), 0..3),
    ) {
        // Few distinct points: many repeats, collinear runs, holes equal to the outline.
        let grid = [p(0.0, 0.0, 0.0), p(1.0, 0.0, 0.0), p(1.0, 1.0, 0.0), p(0.0, 1.0, 0.0),
            p(0.5, 0.5, 0.0), p(2.0, 0.0, 0.0)];
        let ring: Vec<DVec3> = pts.iter().map(|&(i, k)| grid[i] * k).collect();
        let holes: Vec<Vec<DVec3>> =
            holes.iter().map(|h| h.iter().map(|&i| grid[i]).collect()).collect();
        let t = triangulate(&ring, &holes, 0.01);
        for [a, b, c] in &t.triangles {
            prop_assert!(a.is_finite() && b.is_finite() && c.is_finite());
        }
    }

    #[test]
    fn simple_polygons_cover_their_area(
        jitter in proptest::collection::vec(0.0..0.9f64, 4..40),
        radii in proptest::collection::vec(0.2..1.0f64, 40),
        scale in prop_oneof![Just(1e-3), 0.1..100.0f64],
        normal in (-1.0..1.0f64, -1.0..1.0f64, 0.1..1.0f64),
    ) {
        let ring = star(&jitter, &radii, scale, p(normal.0, normal.1, normal.2));
        let t = triangulate(&ring, &[], 1e-6 * scale);
        let want = shoelace(&ring);
        let got = area(&t);
        prop_assert!(got.is_finite());
        // Never more than the boundary encloses; all of it unless it is a sliver.
        prop_assert!(got <= want * (1.0 + 1e-9) + 1e-12, "{} > {}", got, want);
        if !t.issues.contains(&PolygonIssue::ZeroArea) {
            prop_assert!((got - want).abs() <= 1e-9 * want.max(1e-12), "{} vs {}", got, want);
            prop_assert!(!t.issues.contains(&PolygonIssue::SelfIntersecting));
        }
    }
}
