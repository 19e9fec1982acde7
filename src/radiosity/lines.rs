//! Local lines: sampling a point and a cosine-distributed direction on an element, tracing
//! the line through glazing to its first opaque surface, and the sensor gather that reads
//! the solved radiosity along cosine-distributed rays.
//!
//! [`gather_sensor`] serves the local-line HMC solver ([`super::hmc`]) and, like it, treats
//! glazing as transmitting only. The global-line transport ([`super::transport`]) also
//! follows the specular reflection of glazing, using [`Tracer::first_hit`].

use super::{RadiosityState, MAX_RHO};
use crate::math::bvh::Bvh;
use crate::math::frame::basis;
use crate::math::rng::{mix64, uniform};
use crate::photometry::Rgb;
use crate::scene::{Material, Scene};
use glam::DVec3;
use std::collections::BTreeMap;
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

/// Indirect irradiance at a sensor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorIndirect {
    /// Irradiance from the surfaces' radiosity, RGB W/m².
    pub irradiance: Rgb,
    /// 1σ standard error: ray sampling plus the radiosity noise of the elements read.
    pub std_err: Rgb,
    /// Rays cast.
    pub rays: u32,
}

/// Indirect irradiance (RGB W/m²) at `point` facing unit `normal`, from the solved
/// radiosity: E = ∫ L cos θ dω with L = B/π for diffuse surfaces; with cosine-distributed
/// rays (pdf cos θ/π) the estimator is E = mean(B_hit·τ) over about `rays` rays, cast as
/// [`GATHER_BATCHES`] independent jittered-stratified batches. Rays pass
/// glazing with τ(θ); rays meeting a back face or leaving the scene contribute nothing (sky
/// and sun are the direct gather's). The random numbers are a pure function of `seed`.
///
/// The standard error adds the ray-sampling variance to the radiosity variance of the
/// elements read, Σ_e w_e² σ_e² with w_e the share of rays reading element e (an element
/// read by many rays contributes its error coherently).
pub fn gather_sensor(
    state: &RadiosityState,
    tracer: &Tracer,
    point: DVec3,
    normal: DVec3,
    rays: u32,
    seed: u64,
) -> SensorIndirect {
    let n = normal.normalize();
    let stream = mix64(seed ^ 0x5e45_0a11);
    // GATHER_BATCHES independent jittered-stratified patterns of m × m rays each: the
    // strata cut the noise, and the spread of the independent batch means is an honest
    // standard error (the sample variance of stratified rays would overstate it).
    let m = ((rays / GATHER_BATCHES).max(1) as f64)
        .sqrt()
        .floor()
        .max(1.0) as u64;
    let mut batch_means = Vec::with_capacity(GATHER_BATCHES as usize);
    let mut weights: BTreeMap<u32, f64> = BTreeMap::new();
    let mut k = 0u64;
    for _ in 0..GATHER_BATCHES {
        let mut sum = Rgb::ZERO;
        for i in 0..m {
            for j in 0..m {
                let u1 = (i as f64 + uniform(seed, stream, 2 * k)) / m as f64;
                let u2 = (j as f64 + uniform(seed, stream, 2 * k + 1)) / m as f64;
                k += 1;
                let (d, _) = cosine_direction(n, u1, u2);
                let out = tracer.trace(point, d, Rgb::ONE);
                if let End::Front { tri, point: y, .. } = out.end {
                    let root = state.hierarchy.elements[tri as usize].vertices;
                    let leaf = state.leaf_at(tri, barycentric(root, y));
                    *weights.entry(leaf).or_default() += crate::photometry::grey(out.power);
                    sum += state.radiosity(leaf) * out.power;
                }
            }
        }
        batch_means.push(sum / (m * m) as f64);
    }
    let total = k as f64;
    let b = GATHER_BATCHES as f64;
    let mean = batch_means.iter().fold(Rgb::ZERO, |a, x| a + *x) / b;
    let spread = batch_means
        .iter()
        .fold(Rgb::ZERO, |a, x| a + (*x - mean) * (*x - mean))
        / (b - 1.0)
        / b;
    let mut elem_var = Rgb::ZERO;
    for (&leaf, &w) in &weights {
        let s = state.radiosity_std_err(leaf);
        elem_var += s * s * (w / total).powi(2);
    }
    SensorIndirect {
        irradiance: mean,
        std_err: super::sqrt3(spread + elem_var),
        rays: k as u32,
    }
}

/// Independent stratified batches of the sensor gather (see [`gather_sensor`]).
pub const GATHER_BATCHES: u32 = 8;

/// Largest reflectance of the scene's opaque materials, clamped below 1 (for bounds).
pub(crate) fn rho_max(state: &RadiosityState) -> f64 {
    state
        .rho
        .iter()
        .map(|r| r.max_element())
        .fold(0.0, f64::max)
        .min(MAX_RHO)
}

#[cfg(test)]
mod tests {
    use super::*;

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
