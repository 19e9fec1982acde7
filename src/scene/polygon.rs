//! Planar polygons with holes (honeybee `Face3D`, Radiance `polygon`) triangulated for the
//! scene: projected onto the plane of the boundary's Newell normal and ear-cut by `earcutr`
//! (a port of mapbox's earcut, which handles concave outlines, holes and the "seam" edges
//! exporters use to join a hole to its outline).
//!
//! The triangles keep the input's own vertices (no projected or rebuilt coordinates), so a
//! model converted from millimetres gives the same vertices as the same model in metres.

use glam::{DVec2, DVec3};

/// What was wrong with one planar polygon (reported as warnings by the readers).
#[derive(Clone, Debug, PartialEq)]
pub enum PolygonIssue {
    /// The outline encloses no area (fewer than three distinct vertices, all collinear, or a
    /// figure of eight whose lobes cancel): no triangles are made.
    ZeroArea,
    /// Some vertex lies further than the tolerance from the mean plane (m). Triangulated
    /// anyway, on its projection.
    NonPlanar {
        /// Largest distance of a vertex from the mean plane, m.
        deviation_m: f64,
    },
    /// Two edges of the outline or of its holes cross each other (a bow-tie): the
    /// triangles made cover what the ear-cutting makes of it, which need not be what the
    /// modeller meant.
    SelfIntersecting,
}

/// A polygon (outer boundary + holes), model frame, metres, triangulated.
pub struct Triangulated {
    /// Triangles, counter-clockwise seen from the front (as [`super::Triangle::v`]).
    pub triangles: Vec<[DVec3; 3]>,
    /// What was wrong with the polygon (empty for a clean one).
    pub issues: Vec<PolygonIssue>,
}

/// Above this many vertices (boundary and holes together) the O(n²) self-intersection
/// test is skipped: a polygon that large is a mesh exported as one face, and testing it
/// would cost more than the rest of the import.
pub const SELF_INTERSECTION_TEST_MAX_VERTICES: usize = 4096;

/// A polygon whose area is below this fraction of the square of its extent counts as
/// zero-area: its Newell normal is rounding noise, not a direction.
const RELATIVE_ZERO_AREA: f64 = 1e-12;

/// Triangulates a planar polygon with holes. The triangles' front (counter-clockwise seen from the
/// front, as `Triangle::v`) is the side the boundary's Newell normal points to (right-hand rule, the
/// convention of both honeybee Face3D and Radiance `polygon`); hole winding does not matter.
/// Concave boundaries and holes are handled; `tolerance_m` is the planarity tolerance.
///
/// Repeated consecutive vertices are dropped first. A `tolerance_m` that is not a positive
/// finite number skips the planarity check (honeybee's tolerance 0 means "no checks").
/// Holes with fewer than three distinct vertices are ignored. Never panics: non-finite
/// coordinates give [`PolygonIssue::ZeroArea`] and no triangles (the readers reject them
/// with an error before calling this).
pub fn triangulate(boundary: &[DVec3], holes: &[Vec<DVec3>], tolerance_m: f64) -> Triangulated {
    let mut issues = Vec::new();
    let outer = dedupe(boundary);
    let rings_ok = |r: &[DVec3]| r.iter().all(|v| v.is_finite());
    if outer.len() < 3 || !rings_ok(&outer) || !holes.iter().all(|h| rings_ok(h)) {
        return zero_area();
    }
    let holes: Vec<Vec<DVec3>> = holes
        .iter()
        .map(|h| dedupe(h))
        .filter(|h| h.len() >= 3)
        .collect();

    // Relative to the first vertex, so that far-from-origin models keep their precision.
    let o = outer[0];
    let newell = newell(&outer, o);
    let (lo, hi) = outer
        .iter()
        .fold((outer[0], outer[0]), |(a, b), v| (a.min(*v), b.max(*v)));
    let extent = (hi - lo).max_element();
    let area = 0.5 * newell.length();
    if !(area.is_normal() && area > RELATIVE_ZERO_AREA * extent * extent) {
        return zero_area();
    }
    let n = newell / (2.0 * area);

    if tolerance_m.is_finite() && tolerance_m > 0.0 {
        let d = outer.iter().map(|v| (*v - o).dot(n)).sum::<f64>() / outer.len() as f64;
        let deviation = outer
            .iter()
            .chain(holes.iter().flatten())
            .map(|v| ((*v - o).dot(n) - d).abs())
            .fold(0.0, f64::max);
        if deviation > tolerance_m {
            issues.push(PolygonIssue::NonPlanar {
                deviation_m: deviation,
            });
        }
    }

    // A right-handed basis of the plane: (u, v, n), so the boundary projects counter-clockwise.
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let project = |p: DVec3| DVec2::new((p - o).dot(u), (p - o).dot(v));
    let mut all: Vec<DVec3> = outer.clone();
    let mut hole_starts = Vec::with_capacity(holes.len());
    for h in &holes {
        hole_starts.push(all.len());
        all.extend_from_slice(h);
    }
    let flat: Vec<DVec2> = all.iter().map(|p| project(*p)).collect();
    if !flat.iter().all(|p| p.is_finite()) {
        return zero_area();
    }

    if all.len() <= SELF_INTERSECTION_TEST_MAX_VERTICES {
        let mut rings = vec![(0, outer.len())];
        rings.extend(
            holes
                .iter()
                .zip(&hole_starts)
                .map(|(h, s)| (*s, *s + h.len())),
        );
        if crosses(&flat, &rings, extent) {
            issues.push(PolygonIssue::SelfIntersecting);
        }
    }

    let coords: Vec<f64> = flat.iter().flat_map(|p| [p.x, p.y]).collect();
    let Ok(indices) = earcutr::earcut(&coords, &hole_starts, 2) else {
        // earcut gives up only on outlines it cannot make sense of.
        if !issues.contains(&PolygonIssue::SelfIntersecting) {
            issues.push(PolygonIssue::SelfIntersecting);
        }
        return Triangulated {
            triangles: Vec::new(),
            issues,
        };
    };
    let mut triangles = Vec::with_capacity(indices.len() / 3);
    for t in indices.chunks_exact(3) {
        let Some(&[a, b, c]) = [t[0], t[1], t[2]]
            .iter()
            .map(|&i| all.get(i).copied())
            .collect::<Option<Vec<_>>>()
            .as_deref()
        else {
            continue;
        };
        // earcut's output winding is its own: turn each triangle to face along n, and
        // drop the slivers it makes of collinear runs.
        let s = (b - a).cross(c - a).dot(n);
        if !s.is_finite() || s == 0.0 {
            continue;
        }
        triangles.push(if s > 0.0 { [a, b, c] } else { [a, c, b] });
    }
    if triangles.is_empty() {
        issues.push(PolygonIssue::ZeroArea);
    }
    Triangulated { triangles, issues }
}

/// The unit Newell normal of a closed ring (right-hand rule), `None` when the ring
/// encloses no area or is not finite.
pub fn newell_normal(ring: &[DVec3]) -> Option<DVec3> {
    let ring = dedupe(ring);
    let o = *ring.first()?;
    newell(&ring, o).try_normalize()
}

/// True when every vertex of `inner` lies within `tolerance_m` of the plane of `boundary`
/// and inside its outline or within `tolerance_m` of it, and not inside any of `holes`
/// (further than `tolerance_m` from the hole's edges): the test for an aperture lying in
/// its parent face. Vertices only: an inner outline whose edges leave a concave outline
/// between two inside vertices passes. False for a boundary enclosing no area.
pub fn encloses(
    boundary: &[DVec3],
    holes: &[Vec<DVec3>],
    inner: &[DVec3],
    tolerance_m: f64,
) -> bool {
    let Some(n) = newell_normal(boundary) else {
        return false;
    };
    let o = boundary[0];
    let extent = boundary
        .iter()
        .chain(inner)
        .map(|v| (*v - o).abs().max_element())
        .fold(0.0, f64::max);
    // Never tighter than rounding at the model's size.
    let tol = tolerance_m.max(0.0).max(1e-9 * extent);
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let flat = |r: &[DVec3]| -> Vec<DVec2> {
        r.iter()
            .map(|p| DVec2::new((*p - o).dot(u), (*p - o).dot(v)))
            .collect()
    };
    let outer = flat(boundary);
    let holes: Vec<Vec<DVec2>> = holes.iter().map(|h| flat(h)).collect();
    inner.iter().all(|p| {
        if ((*p - o).dot(n)).abs() > tol {
            return false;
        }
        let q = DVec2::new((*p - o).dot(u), (*p - o).dot(v));
        let in_outer = point_in_ring(q, &outer) || distance_to_ring(q, &outer) <= tol;
        let in_hole = holes
            .iter()
            .any(|h| h.len() >= 3 && point_in_ring(q, h) && distance_to_ring(q, h) > tol);
        in_outer && !in_hole
    })
}

/// Even-odd point-in-polygon test.
fn point_in_ring(q: DVec2, ring: &[DVec2]) -> bool {
    let mut inside = false;
    for (i, a) in ring.iter().enumerate() {
        let b = ring[(i + 1) % ring.len()];
        if (a.y > q.y) != (b.y > q.y) {
            let x = a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x);
            if q.x < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Distance from `q` to the nearest edge of a closed ring.
fn distance_to_ring(q: DVec2, ring: &[DVec2]) -> f64 {
    let mut best = f64::INFINITY;
    for (i, a) in ring.iter().enumerate() {
        let b = ring[(i + 1) % ring.len()];
        let ab = b - *a;
        let t = if ab.length_squared() > 0.0 {
            ((q - *a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        best = best.min((q - (*a + ab * t)).length());
    }
    best
}

fn zero_area() -> Triangulated {
    Triangulated {
        triangles: Vec::new(),
        issues: vec![PolygonIssue::ZeroArea],
    }
}

/// `ring` without vertices equal to the one before (the closing vertex too, which
/// exporters often repeat).
fn dedupe(ring: &[DVec3]) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::with_capacity(ring.len());
    for v in ring {
        if out.last() != Some(v) {
            out.push(*v);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    out
}

/// Newell's vector of a closed ring (twice the vector area), vertices taken relative to `o`.
fn newell(ring: &[DVec3], o: DVec3) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (i, a) in ring.iter().enumerate() {
        let b = ring[(i + 1) % ring.len()];
        n += (*a - o).cross(b - o);
    }
    n
}

/// True when two edges of the rings (`(start, end)` ranges into `p`) cross at a point
/// inside both. Edges that only touch, overlap along a line (an exporter's seam) or share
/// a vertex do not count.
fn crosses(p: &[DVec2], rings: &[(usize, usize)], extent: f64) -> bool {
    let mut edges = Vec::new();
    for &(s, e) in rings {
        for i in s..e {
            edges.push((i, if i + 1 == e { s } else { i + 1 }));
        }
    }
    // Orientation values below this are collinear within rounding.
    let eps = 1e-12 * extent * extent;
    let orient = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
    let side = |x: f64| {
        if x > eps {
            1
        } else if x < -eps {
            -1
        } else {
            0
        }
    };
    for (k, &(a, b)) in edges.iter().enumerate() {
        let (pa, pb) = (p[a], p[b]);
        let (lo, hi) = (pa.min(pb), pa.max(pb));
        for &(c, d) in &edges[k + 1..] {
            if a == c || a == d || b == c || b == d {
                continue;
            }
            let (pc, pd) = (p[c], p[d]);
            if pc.max(pd).cmplt(lo).any() || pc.min(pd).cmpgt(hi).any() {
                continue;
            }
            let (o1, o2) = (side(orient(pa, pb, pc)), side(orient(pa, pb, pd)));
            let (o3, o4) = (side(orient(pc, pd, pa)), side(orient(pc, pd, pb)));
            if o1 * o2 < 0 && o3 * o4 < 0 {
                return true;
            }
        }
    }
    false
}

#[cfg(test)]
#[path = "polygon_tests.rs"]
mod tests;
