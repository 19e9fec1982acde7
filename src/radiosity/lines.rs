//! Rays through the scene for the interreflection: tracing a ray through glazing to its
//! first opaque surface, cosine-distributed directions and barycentric coordinates, as the
//! global-line transport's sensor gather and glazing mirror use them
//! ([`super::transport`]).

use crate::math::bvh::Bvh;
use crate::math::frame::basis;
use crate::photometry::Rgb;
use crate::scene::{Material, Scene};
use glam::DVec3;
use std::f64::consts::PI;

/// Rays start this far (m) from their origin so they do not meet the surface they leave.
pub const T_MIN_M: f64 = 1e-7;
/// A line crossing more glazing panes than this is absorbed (bounds the loop).
const MAX_PANES: u32 = 32;

/// Ray-casting view of a scene for the solver: BVH, unit front normals, materials.
#[derive(Clone, Debug)]
pub struct Tracer {
    bvh: Bvh,
    normals: Vec<DVec3>,
    material: Vec<u32>,
    materials: Vec<Material>,
}

impl Tracer {
    /// Builds the BVH over the scene's triangles.
    pub fn new(scene: &Scene) -> Tracer {
        let tris: Vec<[DVec3; 3]> = scene.triangles.iter().map(|t| t.v).collect();
        Tracer {
            bvh: Bvh::build(&tris),
            normals: scene.triangles.iter().map(|t| t.normal()).collect(),
            material: scene.triangles.iter().map(|t| t.material).collect(),
            materials: scene.materials.clone(),
        }
    }

    /// Unit front normal of triangle `tri`.
    pub fn normal(&self, tri: u32) -> DVec3 {
        self.normals[tri as usize]
    }

    /// The first triangle (opaque or glazing) the ray `origin + t·dir` (unit `dir`) meets
    /// beyond [`T_MIN_M`], or `None` when it leaves the scene.
    pub fn first_hit(&self, origin: DVec3, dir: DVec3) -> Option<FirstHit> {
        let h = self.bvh.closest_hit(origin, dir, T_MIN_M, f64::INFINITY)?;
        Some(FirstHit {
            tri: h.triangle,
            point: origin + dir * h.t,
            cos: h.cos,
            glazing: self.material_of(h.triangle).is_glazing(),
        })
    }

    /// Material of triangle `tri`.
    pub fn material_of(&self, tri: u32) -> &Material {
        &self.materials[self.material[tri as usize] as usize]
    }

    /// Follows the ray `origin + t·dir` (unit `dir`) carrying `power`: glazing passes the
    /// line on with τ(θ); the first opaque triangle ends it.
    pub fn trace(&self, origin: DVec3, dir: DVec3, power: Rgb) -> Outcome {
        let mut o = origin;
        let mut p = power;
        let mut lost = Rgb::ZERO;
        for _ in 0..MAX_PANES {
            let Some(h) = self.bvh.closest_hit(o, dir, T_MIN_M, f64::INFINITY) else {
                return Outcome {
                    end: End::Escaped,
                    power: p,
                    glazing_loss: lost,
                };
            };
            let y = o + dir * h.t;
            let m = &self.materials[self.material[h.triangle as usize] as usize];
            if m.is_glazing() {
                let tau = m.transmittance(h.cos.abs());
                lost += p * (Rgb::ONE - tau);
                p *= tau;
                if p == Rgb::ZERO {
                    break;
                }
                o = y;
                continue;
            }
            // `cos` is dir·n: negative when the line meets the front face.
            let end = if h.cos < 0.0 {
                End::Front {
                    tri: h.triangle,
                    point: y,
                    cos: -h.cos,
                }
            } else {
                End::Back
            };
            return Outcome {
                end,
                power: p,
                glazing_loss: lost,
            };
        }
        Outcome {
            end: End::Back,
            power: Rgb::ZERO,
            glazing_loss: lost + p,
        }
    }
}

/// The first surface a ray meets ([`Tracer::first_hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// Triangle hit.
    pub tri: u32,
    /// Hit point, m.
    pub point: DVec3,
    /// Cosine between the ray direction and the triangle's front normal (signed: negative
    /// on the front face).
    pub cos: f64,
    /// Whether the triangle is glazing.
    pub glazing: bool,
}

/// Where a line ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    /// Front face of an opaque triangle at `point`; `cos` = cosine at the receiver (> 0).
    Front {
        /// Triangle hit.
        tri: u32,
        /// Hit point, m.
        point: DVec3,
        /// Cosine of incidence.
        cos: f64,
    },
    /// Back face of an opaque triangle (absorbed there).
    Back,
    /// Left the scene.
    Escaped,
}

/// A traced line: where it ended, the power (RGB W) that arrived there and the power lost
/// in glazing on the way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Where it ended.
    pub end: End,
    /// Power arriving at the end (W, RGB).
    pub power: Rgb,
    /// Power absorbed or reflected away by glazing on the way (W, RGB).
    pub glazing_loss: Rgb,
}

/// Uniform barycentric coordinates on a triangle from two uniforms.
pub fn uniform_barycentric(u1: f64, u2: f64) -> [f64; 3] {
    let s = u1.sqrt();
    [1.0 - s, s * (1.0 - u2), s * u2]
}

/// A cosine-distributed unit direction about unit `n` from two uniforms, and its cosine.
pub fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> (DVec3, f64) {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let c = (1.0 - u1).max(0.0).sqrt();
    let (a, b) = basis(n);
    let d = a * (r * phi.cos()) + b * (r * phi.sin()) + n * c;
    (d.normalize(), c)
}

/// Barycentric coordinates of point `p` (assumed in the plane) on triangle `v`, clamped
/// to the triangle and renormalised.
pub fn barycentric(v: [DVec3; 3], p: DVec3) -> [f64; 3] {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let d = p - v[0];
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (dp1, dp2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    let b1 = ((d22 * dp1 - d12 * dp2) / den).max(0.0);
    let b2 = ((d11 * dp2 - d12 * dp1) / den).max(0.0);
    let b0 = (1.0 - b1 - b2).max(0.0);
    let s = b0 + b1 + b2;
    [b0 / s, b1 / s, b2 / s]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::uniform;

    #[test]
    fn cosine_directions_have_mean_cosine_two_thirds() {
        // E[cos θ] under pdf cos θ/π is 2/3.
        let n = DVec3::new(0.2, -0.3, 0.9).normalize();
        let k = 20_000;
        let mut s = 0.0;
        for i in 0..k {
            let (d, c) = cosine_direction(n, uniform(1, 2, 2 * i), uniform(1, 2, 2 * i + 1));
            assert!((d.dot(n) - c).abs() < 1e-9 && c >= 0.0);
            s += c;
        }
        assert!((s / k as f64 - 2.0 / 3.0).abs() < 0.01);
    }

    #[test]
    fn barycentric_round_trips() {
        let v = [DVec3::ZERO, DVec3::X * 2.0, DVec3::new(0.5, 1.5, 0.0)];
        let b = uniform_barycentric(0.37, 0.81);
        let p = v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
        let q = barycentric(v, p);
        for k in 0..3 {
            assert!((b[k] - q[k]).abs() < 1e-12);
        }
    }
}
