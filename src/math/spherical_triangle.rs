//! Spherical triangles on the unit sphere: solid angle, projected (cosine-weighted) solid
//! angle, centroid direction and the 4-way midpoint split used by the sky quadtree.

use glam::DVec3;

/// Solid angle (sr) of the spherical triangle with unit vertices `a, b, c`
/// (Van Oosterom & Strackee 1983), exact for any orientation.
pub fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// Projected solid angle (sr) ∫ n·ω dω over the spherical triangle `a, b, c` for a receiver
/// with unit normal `n`, by Lambert's contour formula. Exact when the whole triangle lies in
/// the receiver's upper hemisphere (`n·a, n·b, n·c ≥ 0`); callers split triangles that cross
/// the receiver's horizon.
pub fn projected_solid_angle(a: DVec3, b: DVec3, c: DVec3, n: DVec3) -> f64 {
    let edge = |p: DVec3, q: DVec3| {
        let x = p.cross(q);
        let len = x.length();
        if len < 1e-300 {
            return 0.0;
        }
        let gamma = len.atan2(p.dot(q));
        gamma * n.dot(x) / len
    };
    (0.5 * (edge(a, b) + edge(b, c) + edge(c, a))).abs()
}

/// Unit direction of the triangle's vertex centroid.
pub fn centre(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (a + b + c).normalize()
}

/// The four children of a midpoint split, in quadtree order: corner at `a`, corner at `b`,
/// corner at `c`, then the middle triangle. Midpoints are renormalised onto the sphere, so
/// children tile the parent exactly along great-circle edges.
pub fn split(a: DVec3, b: DVec3, c: DVec3) -> [[DVec3; 3]; 4] {
    let ab = (a + b).normalize();
    let bc = (b + c).normalize();
    let ca = (c + a).normalize();
    [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn octant() -> [DVec3; 3] {
        [DVec3::X, DVec3::Y, DVec3::Z]
    }

    #[test]
    fn octant_solid_angle_and_projection() {
        let [a, b, c] = octant();
        assert!((solid_angle(a, b, c) - PI / 2.0).abs() < 1e-12);
        // Cosine-weighted: a quarter of the hemisphere's π.
        assert!((projected_solid_angle(a, b, c, DVec3::Z) - PI / 4.0).abs() < 1e-12);
    }

    #[test]
    fn children_tile_parent() {
        let [a, b, c] = octant();
        let kids = split(a, b, c);
        let sa: f64 = kids.iter().map(|k| solid_angle(k[0], k[1], k[2])).sum();
        let sp: f64 = kids
            .iter()
            .map(|k| projected_solid_angle(k[0], k[1], k[2], DVec3::Z))
            .sum();
        assert!((sa - PI / 2.0).abs() < 1e-12);
        assert!((sp - PI / 4.0).abs() < 1e-12);
    }

    #[test]
    fn projection_against_quadrature() {
        // A small tilted triangle: compare with a brute-force sum of sub-triangles.
        let a = DVec3::new(0.2, 0.1, 1.0).normalize();
        let b = DVec3::new(0.6, 0.0, 0.8).normalize();
        let c = DVec3::new(0.1, 0.7, 0.7).normalize();
        let n = DVec3::new(0.3, 0.2, 0.9).normalize();
        fn rec(t: [DVec3; 3], n: DVec3, d: u32) -> f64 {
            if d == 0 {
                return solid_angle(t[0], t[1], t[2]) * n.dot(centre(t[0], t[1], t[2]));
            }
            split(t[0], t[1], t[2])
                .iter()
                .map(|k| rec(*k, n, d - 1))
                .sum()
        }
        let brute = rec([a, b, c], n, 7);
        let exact = projected_solid_angle(a, b, c, n);
        assert!((brute - exact).abs() / exact < 1e-5, "{brute} vs {exact}");
    }
}

/// Clips a spherical polygon (unit vertices, great-arc edges) to the hemisphere
/// `n·ω ≥ 0`. The horizon is a great circle, so the result again has great-arc edges.
pub fn clip_to_hemisphere(poly: &[DVec3], n: DVec3) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 2);
    for k in 0..poly.len() {
        let a = poly[k];
        let b = poly[(k + 1) % poly.len()];
        let (sa, sb) = (n.dot(a), n.dot(b));
        if sa >= 0.0 {
            out.push(a);
        }
        if (sa > 0.0 && sb < 0.0) || (sa < 0.0 && sb > 0.0) {
            // Positive combination of a and b with n·x = 0: on the minor arc from a to b.
            let x = if sa > 0.0 {
                b * sa - a * sb
            } else {
                a * sb - b * sa
            };
            out.push(x.normalize());
        }
    }
    out
}

/// Projected solid angle (sr) of a spherical polygon lying in `n·ω ≥ 0`, by Lambert's
/// contour formula (see [`projected_solid_angle`]).
pub fn projected_solid_angle_polygon(poly: &[DVec3], n: DVec3) -> f64 {
    let mut sum = 0.0;
    for k in 0..poly.len() {
        let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
        let x = p.cross(q);
        let len = x.length();
        if len > 1e-300 {
            sum += len.atan2(p.dot(q)) * n.dot(x) / len;
        }
    }
    (0.5 * sum).abs()
}

#[cfg(test)]
mod clip_tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn vertical_receiver_sees_half_of_the_sky_faces() {
        // A vertical receiver facing +x sees the sky half of its hemisphere: π/2.
        let n = DVec3::X;
        let faces = [
            [DVec3::X, DVec3::Y, DVec3::Z],
            [DVec3::Y, DVec3::NEG_X, DVec3::Z],
            [DVec3::NEG_X, DVec3::NEG_Y, DVec3::Z],
            [DVec3::NEG_Y, DVec3::X, DVec3::Z],
        ];
        let total: f64 = faces
            .iter()
            .map(|f| projected_solid_angle_polygon(&clip_to_hemisphere(f, n), n))
            .sum();
        assert!((total - PI / 2.0).abs() < 1e-12, "{total}");
    }
}
