//! L6 sensor illuminance from every parallel source.
//!
//! A sky or ground node contributes Σ_children L_c · ∫_child V(ω) τ(ω) max(0, n·ω) dω. The
//! integral is geometry only ([`node_response`], cached by node key): where visibility is
//! the same at a piece's corners and centre and provably holds for the whole piece it is
//! the exact projected solid angle (Lambert's contour formula, clipped at the sensor's
//! horizon); otherwise the piece is split (same quadtree as the sky) while it is wide or
//! its visibility range is large, down to a maximum depth — the paper's visibility-driven
//! refinement, in direction space. The sun contributes E_n · cos θ · τ along its snapped
//! direction ([`sun_response`]). Radiance is applied per child of each node (the sources
//! carry their four children's radiance), one level finer than the sources' L̂, and the
//! difference to L̂ is reported as an error estimate. Visibility is an exact ray cast
//! through the run's shared [`Tracer`] (two-sided opaque occluders, glazing multiplies by
//! τ(θ)). Direct light is
//! transmission-only: glazing's specular reflection of sky and sun is not added here (the
//! interreflection, [`crate::radiosity`], includes it for light reflected by
//! surfaces).

use crate::math::spherical_triangle::{
    self, clip_to_hemisphere, projected_solid_angle_polygon, split,
};
use crate::photometry::{grey, Rgb};
use crate::scene::Sensor;
use crate::trace::{Outcome, Tracer};
use glam::DVec3;
use std::collections::HashMap;

/// Knobs of the sensor gather.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorParams {
    /// Deepest split of a partly visible node, relative to the node (6 → 4096 sub-triangles).
    pub visibility_depth: u32,
    /// Partly visible nodes are split, largest uncertainty first, until their summed
    /// visibility uncertainty is below this fraction of the sensor's direct illuminance.
    pub visibility_tolerance: f64,
    /// Nodes wider than this (degrees, corner to corner through the centre) are split before
    /// their samples are trusted: four samples of a wide node can all miss a thin band of
    /// sky between an obstruction and a window head.
    pub sample_angle_deg: f64,
}

impl Default for SensorParams {
    fn default() -> Self {
        SensorParams {
            visibility_depth: 6,
            visibility_tolerance: 0.005,
            sample_angle_deg: 4.0,
        }
    }
}

/// Direct irradiance at one sensor (RGB, W/m²), sun and sky (with ground glow) apart.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorDirect {
    /// From the sun.
    pub sun: Rgb,
    /// From sky and ground-glow nodes.
    pub sky: Rgb,
    /// Rays cast for this sensor.
    pub rays: u64,
    /// Visibility uncertainty, lux: Σ over partly visible nodes left unsplit of half the
    /// range of their visibility samples × projected solid angle × radiance. A linear sum:
    /// neighbouring boundary nodes err the same way, so their errors add up.
    pub visibility_err_lux: f64,
    /// Signed difference (RGB, W/m²) between weighting each node's children by their own
    /// radiance and weighting the whole node by L̂: the error of the coarser sky
    /// representation, an upper estimate of the finer one's.
    pub radiance_error: Rgb,
}

/// One sensor's ray casts, memoised by exact direction (neighbouring nodes share corners).
struct Rays<'v> {
    vis: &'v Tracer,
    p: DVec3,
    n: DVec3,
    /// Keyed by the direction's bits: ahash, not SipHash (its hashing was 2 % of a cold
    /// annual run); only looked up, so the order of the map is never read.
    memo: HashMap<[u64; 3], Outcome, ahash::RandomState>,
    cast: u64,
}

impl Rays<'_> {
    fn trace(&mut self, d: DVec3) -> Outcome {
        let key = [d.x.to_bits(), d.y.to_bits(), d.z.to_bits()];
        if let Some(t) = self.memo.get(&key) {
            return *t;
        }
        self.cast += 1;
        let t = self.vis.trace(self.p, d, Rgb::ONE);
        self.memo.insert(key, t);
        t
    }

    /// Samples a node at the corners and centre of its part above the sensor's horizon.
    /// `None` when nothing of the node is above the horizon.
    fn sample(&mut self, tri: &[DVec3; 3]) -> Option<NodeSample> {
        let poly = clip_to_hemisphere(tri, self.n);
        if poly.len() < 3 {
            return None;
        }
        let psa = projected_solid_angle_polygon(&poly, self.n);
        if psa <= 0.0 {
            return None;
        }
        let centre = poly.iter().fold(DVec3::ZERO, |a, &b| a + b).normalize();
        let traced: Vec<Outcome> = poly
            .iter()
            .chain(std::iter::once(&centre))
            .map(|d| self.trace(*d))
            .collect();
        let first = traced[0].transmission();
        let uniform = traced
            .iter()
            .all(|s| (s.transmission() - first).abs().max_element() < 1e-9);
        let mean = traced.iter().fold(Rgb::ZERO, |a, s| a + s.transmission()) / traced.len() as f64;
        let (lo, hi) = traced
            .iter()
            .map(|s| grey(s.transmission()))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        // Proofs that the samples speak for the whole node: every sample stopped by the
        // same opaque triangle (convex, so it covers the node's whole pyramid behind it),
        // or every sample clear and no triangle inside the pyramid at all.
        let stopper = traced[0].end.stopper();
        let same_stopper = stopper.is_some() && traced.iter().all(|s| s.end.stopper() == stopper);
        let all_clear = traced
            .iter()
            .all(|s| s.end.stopper().is_none() && s.panes == 0);
        let proven = uniform
            && (same_stopper || (all_clear && self.vis.pyramid_is_empty(self.p, self.n, &poly)));
        Some(NodeSample {
            uniform,
            proven,
            mean: if uniform { first } else { mean },
            half_range: 0.5 * (hi - lo),
            psa,
        })
    }
}

/// What the samples of one node say.
struct NodeSample {
    /// All samples equal.
    uniform: bool,
    /// Uniform, and proven to hold for the whole node (see [`Rays::sample`]).
    proven: bool,
    /// Sample mean transmission.
    mean: Rgb,
    /// Half the range of the samples, grey.
    half_range: f64,
    /// Projected solid angle of the node's part above the horizon, sr.
    psa: f64,
}

fn clipped_psa(tri: &[DVec3; 3], n: DVec3) -> f64 {
    let poly = clip_to_hemisphere(tri, n);
    if poly.len() < 3 {
        0.0
    } else {
        projected_solid_angle_polygon(&poly, n)
    }
}

/// Geometry-only response of one sensor to one sky or ground node, for time series where
/// the same node recurs under different skies: per child of the node (split order),
/// ∫_child V(ω) τ(ω) max(0, n·ω) dω (RGB, sr); the sensor's irradiance from the node is
/// Σ_c L_c ⊙ `child[c]` for child radiances L_c. The stop rule is node-local and
/// radiance-free, so the response can be cached by node key.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeResponse {
    /// Visible projected solid angle per child, with glazing transmission (RGB, sr).
    pub child: [Rgb; 4],
    /// Visibility uncertainty per child: Σ half-range × projected solid angle of the
    /// partly visible pieces accepted unsplit (grey, sr); × radiance gives W/m².
    pub uncertainty: [f64; 4],
    /// Rays cast.
    pub rays: u64,
}

/// The [`NodeResponse`] of `sensor` to the node with vertices `tri`. Pieces are split while
/// wide (see [`SensorParams::sample_angle_deg`]) or partly visible with half-range ×
/// projected solid angle above `visibility_tolerance` × the node's projected solid angle / 4,
/// down to `visibility_depth`.
pub fn node_response(
    vis: &Tracer,
    sensor: &Sensor,
    tri: [DVec3; 3],
    params: &SensorParams,
) -> NodeResponse {
    let (p, n) = (sensor.position, sensor.normal);
    let mut out = NodeResponse::default();
    let node_psa = clipped_psa(&tri, n);
    if node_psa <= 0.0 {
        return out;
    }
    let mut rays = Rays {
        vis,
        p,
        n,
        memo: HashMap::with_capacity_and_hasher(64, ahash::RandomState::new()),
        cast: 0,
    };
    let tol = params.visibility_tolerance * node_psa / 4.0;
    let max_cos = (0.5 * params.sample_angle_deg).to_radians().cos();
    // The node's own children first, so every piece belongs to one child.
    let mut stack: Vec<([DVec3; 3], usize, u32)> = split(tri[0], tri[1], tri[2])
        .into_iter()
        .enumerate()
        .rev()
        .map(|(k, t)| (t, k, 1))
        .collect();
    while let Some((t, child, depth)) = stack.pop() {
        let Some(ns) = rays.sample(&t) else {
            continue;
        };
        let c = spherical_triangle::centre(t[0], t[1], t[2]);
        let wide = t.iter().any(|v| v.dot(c) < max_cos);
        let unsure = !ns.uniform && ns.half_range * ns.psa > tol;
        if !ns.proven && (wide || unsure) && depth < params.visibility_depth {
            for sub in split(t[0], t[1], t[2]).into_iter().rev() {
                stack.push((sub, child, depth + 1));
            }
            continue;
        }
        out.child[child] += ns.mean * ns.psa;
        if !ns.uniform {
            out.uncertainty[child] += ns.half_range * ns.psa;
        }
    }
    out.rays = rays.cast;
    out
}

/// Geometry-only response of one sensor to the sun along the snapped direction `dir`:
/// the transmission (RGB) of the ray, and whether it crossed glazing (whose τ(θ) must then
/// be re-evaluated at the true sun direction: [`Tracer::transmission_for`]). The
/// irradiance is E_n ⊙ transmission × max(0, n·true direction).
pub fn sun_response(vis: &Tracer, sensor: &Sensor, dir: DVec3) -> (Rgb, bool) {
    if sensor.normal.dot(dir) <= -1e-3 {
        return (Rgb::ZERO, false);
    }
    let out = vis.trace(sensor.position, dir, Rgb::ONE);
    let t = out.transmission();
    (t, out.panes > 0 && t != Rgb::ZERO)
}

#[cfg(test)]
mod response_tests {
    use super::*;
    use crate::scene::{Material, ModelInput, Scene, Triangle};
    use crate::sources::SkyNodeKey;

    #[test]
    fn unobstructed_nodes_sum_to_pi_and_children_to_their_psa() {
        // A lone upward sensor over a tiny floor: Σ over the upper hemisphere's nodes of
        // the visible projected solid angle is π (Lambert), each child's its exact psa.
        let input = ModelInput {
            materials: vec![Material {
                name: "floor".into(),
                kd: Rgb::splat(0.2),
                tf: Rgb::ZERO,
                ke: Rgb::ZERO,
            }],
            triangles: vec![Triangle {
                v: [
                    DVec3::new(-0.1, -0.1, 0.0),
                    DVec3::new(0.1, -0.1, 0.0),
                    DVec3::new(0.0, 0.1, 0.0),
                ],
                material: 0,
                group: 0,
            }],
            sensors: vec![(DVec3::new(0.0, 0.0, 0.5), DVec3::Z)],
            ..ModelInput::default()
        };
        let scene = Scene::from_model(std::path::Path::new("<t>"), input).unwrap();
        let vis = Tracer::new(&scene);
        let p = SensorParams::default();
        let mut total = 0.0;
        for base in 0..4 {
            for k in 0..4 {
                let node = SkyNodeKey::root(base).child(k);
                let v = node.vertices();
                let r = node_response(&vis, &scene.sensors[0], v, &p);
                let exact: Vec<f64> = split(v[0], v[1], v[2])
                    .iter()
                    .map(|c| clipped_psa(c, DVec3::Z))
                    .collect();
                for (c, e) in exact.iter().enumerate() {
                    assert!((r.child[c].x - e).abs() < 1e-12, "{base}/{k}/{c}");
                    assert_eq!(r.uncertainty[c], 0.0);
                }
                total += r.child.iter().map(|x| x.x).sum::<f64>();
            }
        }
        assert!((total - std::f64::consts::PI).abs() < 1e-9, "{total}");
    }
}
