//! The exact enclosure of a box room, the reference of the closed-room transport tests:
//! closed-form configuration factors between axis-aligned rectangles (patch to patch and
//! point to patch), the radiosity system over patches solved directly, and Gauss–Legendre
//! nodes for integrating over a receiver.

use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// An axis-aligned rectangle on a face of a box room: the axis of its normal, the plane's
/// coordinate on that axis, its ranges on the two other axes (increasing axis order), m.
#[derive(Clone, Copy, Debug)]
pub(super) struct Patch {
    pub(super) axis: usize,
    pub(super) at: f64,
    pub(super) range: [[f64; 2]; 2],
}

impl Patch {
    /// The two in-plane axes, in increasing order.
    fn plane_axes(&self) -> [usize; 2] {
        match self.axis {
            0 => [1, 2],
            1 => [0, 2],
            _ => [0, 1],
        }
    }
    pub(super) fn area(&self) -> f64 {
        (self.range[0][1] - self.range[0][0]) * (self.range[1][1] - self.range[1][0])
    }
    /// Its range on `axis` (an in-plane axis).
    fn along(&self, axis: usize) -> [f64; 2] {
        self.range[self.plane_axes().iter().position(|&a| a == axis).unwrap()]
    }
}

/// (1/2π) Σ over the 16 corner combinations of ±g: the quadruple integral of the kernel
/// whose fourth antiderivative is g, over x ∈ a, y ∈ b, ξ ∈ c, η ∈ d.
fn corner_sum(
    a: [f64; 2],
    b: [f64; 2],
    c: [f64; 2],
    d: [f64; 2],
    g: impl Fn(f64, f64, f64, f64) -> f64,
) -> f64 {
    let mut s = 0.0;
    for (i, x) in a.into_iter().enumerate() {
        for (j, y) in b.into_iter().enumerate() {
            for (k, xi) in c.into_iter().enumerate() {
                for (l, eta) in d.into_iter().enumerate() {
                    let sign = if (i + j + k + l) % 2 == 0 { 1.0 } else { -1.0 };
                    s += sign * g(x, y, xi, eta);
                }
            }
        }
    }
    s / (2.0 * PI)
}

/// x·√s·atan(x/√s), zero at s = 0 (its limit).
fn x_sqrt_atan(x: f64, s: f64) -> f64 {
    if s > 0.0 {
        x * s.sqrt() * (x / s.sqrt()).atan()
    } else {
        0.0
    }
}

/// q·ln q, zero at q = 0 (its limit).
fn q_ln(q: f64) -> f64 {
    if q > 0.0 {
        q.ln()
    } else {
        0.0
    }
}

/// A₁F₁₂ between two axis-aligned rectangles facing each other across a box room, m²:
/// Howell's catalogue C-11 (parallel, any offset) and C-14 (perpendicular, any offset),
/// each the quadruple integral of cos θ₁ cos θ₂/(π r²) in closed form via corner sums.
/// Coplanar rectangles see nothing of each other.
pub(super) fn area_factor(p: &Patch, q: &Patch) -> f64 {
    if p.axis == q.axis {
        let h = (p.at - q.at).abs();
        if h == 0.0 {
            return 0.0;
        }
        // x√(y²+h²) atan(x/√(y²+h²)) + y√(x²+h²) atan(y/√(x²+h²)) − h²/2 ln(x²+y²+h²).
        let g = |x: f64, y: f64, xi: f64, eta: f64| {
            let (u, v) = (x - xi, y - eta);
            x_sqrt_atan(u, v * v + h * h) + x_sqrt_atan(v, u * u + h * h)
                - 0.5 * h * h * q_ln(u * u + v * v + h * h)
        };
        return corner_sum(p.range[0], p.range[1], q.range[0], q.range[1], g);
    }
    // The planes meet on a line along the third axis m; each rectangle's other
    // coordinate becomes its distance from that line (it lies on one side of it).
    let m = 3 - p.axis - q.axis;
    let dist = |r: [f64; 2], line: f64| {
        let (a, b) = ((r[0] - line).abs(), (r[1] - line).abs());
        [a.min(b), a.max(b)]
    };
    let y = dist(p.along(q.axis), q.at);
    let eta = dist(q.along(p.axis), p.at);
    // u√s atan(u/√s) + (u² − s)/4 · ln(u² + s), u = x − ξ, s = y² + η².
    let g = |x: f64, y: f64, xi: f64, eta: f64| {
        let (u, s) = (x - xi, y * y + eta * eta);
        x_sqrt_atan(u, s) + 0.25 * (u * u - s) * q_ln(u * u + s)
    };
    corner_sum(p.along(m), y, q.along(m), eta, g)
}

/// The configuration factor from a point `at` with unit normal `n` to a planar polygon in
/// front of it (Lambert's contour formula; vertices in order).
fn point_factor(at: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    let mut s = 0.0;
    for k in 0..poly.len() {
        let (a, b) = (poly[k] - at, poly[(k + 1) % poly.len()] - at);
        let c = a.cross(b);
        if c.length_squared() > 0.0 {
            s += a.angle_between(b) * n.dot(c.normalize());
        }
    }
    s.abs() / (2.0 * PI)
}

/// The configuration factor from a point with axis-aligned normal `n` to the part of
/// `p` in front of it.
pub(super) fn point_to_patch(at: DVec3, n: DVec3, p: &Patch) -> f64 {
    let m = (0..3).find(|&k| n[k] != 0.0).unwrap();
    let sign = n[m].signum();
    let mut r = p.range;
    if p.axis == m {
        if sign * (p.at - at[m]) <= 0.0 {
            return 0.0;
        }
    } else {
        let k = p.plane_axes().iter().position(|&a| a == m).unwrap();
        if sign > 0.0 {
            r[k][0] = r[k][0].max(at[m]);
        } else {
            r[k][1] = r[k][1].min(at[m]);
        }
        if r[k][1] <= r[k][0] {
            return 0.0;
        }
    }
    let [a, b] = p.plane_axes();
    let corner = |u: f64, v: f64| {
        let mut c = DVec3::ZERO;
        c[p.axis] = p.at;
        c[a] = u;
        c[b] = v;
        c
    };
    let poly = [
        corner(r[0][0], r[1][0]),
        corner(r[0][1], r[1][0]),
        corner(r[0][1], r[1][1]),
        corner(r[0][0], r[1][1]),
    ];
    point_factor(at, n, &poly)
}

/// The closed room [0, s]³ cut into n × n patches per face, its exact patch-to-patch
/// factors, and the radiosity B = ρ (E_d + F B) with `e_floor` W/m² of direct light on
/// the floor: (patches, B, mean irradiance from the room over all faces).
pub(super) fn room_reference(
    s: f64,
    n: usize,
    rho: impl Fn(&Patch) -> f64,
    e_floor: f64,
) -> (Vec<Patch>, Vec<f64>, f64) {
    let h = s / n as f64;
    let mut patches = Vec::new();
    for axis in 0..3 {
        for at in [0.0, s] {
            for i in 0..n {
                for j in 0..n {
                    let (i, j) = (i as f64, j as f64);
                    patches.push(Patch {
                        axis,
                        at,
                        range: [[i * h, (i + 1.0) * h], [j * h, (j + 1.0) * h]],
                    });
                }
            }
        }
    }
    let k = patches.len();
    let f: Vec<Vec<f64>> = (0..k)
        .into_par_iter()
        .map(|i| {
            let a = patches[i].area();
            (0..k)
                .map(|j| area_factor(&patches[i], &patches[j]) / a)
                .collect()
        })
        .collect();
    let rhos: Vec<f64> = patches.iter().map(&rho).collect();
    let direct: Vec<f64> = patches
        .iter()
        .map(|p| {
            if p.axis == 2 && p.at == 0.0 {
                e_floor
            } else {
                0.0
            }
        })
        .collect();
    let mut b: Vec<f64> = (0..k).map(|i| rhos[i] * direct[i]).collect();
    for _ in 0..10_000 {
        let mut change: f64 = 0.0;
        for i in 0..k {
            let e: f64 = f[i].iter().zip(&b).map(|(f, b)| f * b).sum();
            let new = rhos[i] * (direct[i] + e);
            change = change.max((new - b[i]).abs());
            b[i] = new;
        }
        if change < 1e-13 {
            break;
        }
    }
    let total: f64 = patches.iter().map(Patch::area).sum();
    let mean = (0..k)
        .map(|i| patches[i].area() * f[i].iter().zip(&b).map(|(f, b)| f * b).sum::<f64>())
        .sum::<f64>()
        / total;
    (patches, b, mean)
}

/// Gauss–Legendre nodes and weights on [0, 1].
pub(super) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    // P_n and P_n' at x by the three-term recurrence.
    let legendre = |x: f64| {
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=n {
            let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
            (p0, p1) = (p1, p2);
        }
        (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
    };
    (1..=n)
        .map(|i| {
            let mut x = (PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
            for _ in 0..100 {
                let (p, dp) = legendre(x);
                x -= p / dp;
                if (p / dp).abs() < 1e-15 {
                    break;
                }
            }
            let (_, dp) = legendre(x);
            (0.5 * (1.0 - x), 1.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}
