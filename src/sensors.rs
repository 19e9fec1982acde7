//! L6 sensor illuminance from every parallel source.
//!
//! A sky or ground node contributes L̂ · ∫_node V(ω) τ(ω) max(0, n·ω) dω. The integral is
//! geometry only: where visibility is the same at the node's corners and centre it is the
//! node's exact projected solid angle (Lambert's contour formula, clipped at the sensor's
//! horizon); where it differs the node is split (same quadtree as the sky), the node with
//! the largest visibility uncertainty first, until the sensor's summed uncertainty
//! is below a tolerance or a maximum depth is reached — the paper's visibility-driven
//! refinement, in direction space, driven by the stated error. The sun
//! contributes E_n · cos θ · τ along its snapped direction. Radiance is applied per child of
//! each node (the sources carry their four children's radiance), one level finer than the
//! sources' L̂, and the difference to L̂ is reported as an error estimate. Visibility is an exact ray cast
//! (two-sided opaque occluders, glazing multiplies by τ(θ)).

use crate::math::bvh::Bvh;
use crate::math::spherical_triangle::{
    self, clip_to_hemisphere, projected_solid_angle_polygon, split,
};
use crate::photometry::{grey, lux, Rgb};
use crate::scene::{Scene, Sensor};
use crate::sources::Source;
use glam::DVec3;
use rayon::prelude::*;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

/// Ray-casting view of a scene for visibility queries.
pub struct Visibility<'a> {
    scene: &'a Scene,
    bvh: Bvh,
    normals: Vec<DVec3>,
}

/// Offset (m) below which hits are ignored, so a sensor on a surface does not see itself.
const T_MIN_M: f64 = 1e-6;

impl<'a> Visibility<'a> {
    /// Builds the ray-casting structure over the scene's triangles.
    pub fn new(scene: &'a Scene) -> Self {
        let tris: Vec<[DVec3; 3]> = scene.triangles.iter().map(|t| t.v).collect();
        Visibility {
            scene,
            bvh: Bvh::build(&tris),
            normals: scene.triangles.iter().map(|t| t.normal()).collect(),
        }
    }

    /// Transmission (per channel) from `origin` to infinity along unit `dir`: glazing
    /// multiplies by τ(θ), an opaque surface stops the light.
    pub fn transmission(&self, origin: DVec3, dir: DVec3) -> Rgb {
        self.trace(origin, dir, dir).0
    }

    /// As [`Self::transmission`], with the glazing's angle of incidence taken from
    /// `incidence` instead of `dir` (the sun: visibility follows the snapped direction, the
    /// glass sees the true one).
    pub fn transmission_for(&self, origin: DVec3, dir: DVec3, incidence: DVec3) -> Rgb {
        self.trace(origin, dir, incidence).0
    }

    /// Transmission, the opaque triangle that stopped the ray (if any), and whether any
    /// glazing was crossed.
    fn trace(&self, origin: DVec3, dir: DVec3, incidence: DVec3) -> (Rgb, Option<u32>, bool) {
        let mut t = Rgb::ONE;
        let mut stopper = None;
        let mut glazing = false;
        self.bvh
            .hits_in_order(origin, dir, T_MIN_M, f64::INFINITY, |hit| {
                let tri = &self.scene.triangles[hit.triangle as usize];
                let m = &self.scene.materials[tri.material as usize];
                if m.is_glazing() {
                    glazing = true;
                    t *= m.transmittance(self.normals[hit.triangle as usize].dot(incidence).abs());
                    t.max_element() > 0.0
                } else {
                    t = Rgb::ZERO;
                    stopper = Some(hit.triangle);
                    false
                }
            });
        (t, stopper, glazing)
    }

    /// True when no triangle can lie inside the pyramid from `apex` spanned by the unit
    /// directions `poly` (a convex spherical polygon) above the plane through `apex` with
    /// normal `n`: the whole pyramid is then provably unobstructed.
    fn pyramid_is_empty(&self, apex: DVec3, n: DVec3, poly: &[DVec3]) -> bool {
        let centre = poly.iter().fold(DVec3::ZERO, |a, &b| a + b);
        let mut planes = Vec::with_capacity(poly.len() + 1);
        for k in 0..poly.len() {
            let mut e = poly[k].cross(poly[(k + 1) % poly.len()]);
            if e.dot(centre) < 0.0 {
                e = -e;
            }
            planes.push((e, e.dot(apex)));
        }
        planes.push((n, n.dot(apex) + T_MIN_M));
        !self.bvh.any_in_region(&planes)
    }
}

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
struct Rays<'v, 'a> {
    vis: &'v Visibility<'a>,
    p: DVec3,
    n: DVec3,
    memo: HashMap<[u64; 3], (Rgb, Option<u32>, bool)>,
    cast: u64,
}

impl Rays<'_, '_> {
    fn trace(&mut self, d: DVec3) -> (Rgb, Option<u32>, bool) {
        let key = [d.x.to_bits(), d.y.to_bits(), d.z.to_bits()];
        if let Some(t) = self.memo.get(&key) {
            return *t;
        }
        self.cast += 1;
        let t = self.vis.trace(self.p, d, d);
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
        let traced: Vec<(Rgb, Option<u32>, bool)> = poly
            .iter()
            .chain(std::iter::once(&centre))
            .map(|d| self.trace(*d))
            .collect();
        let first = traced[0].0;
        let uniform = traced
            .iter()
            .all(|s| (s.0 - first).abs().max_element() < 1e-9);
        let mean = traced.iter().fold(Rgb::ZERO, |a, s| a + s.0) / traced.len() as f64;
        let (lo, hi) = traced
            .iter()
            .map(|s| grey(s.0))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            });
        // Proofs that the samples speak for the whole node: every sample stopped by the
        // same opaque triangle (convex, so it covers the node's whole pyramid behind it),
        // or every sample clear and no triangle inside the pyramid at all.
        let same_stopper = traced[0].1.is_some() && traced.iter().all(|s| s.1 == traced[0].1);
        let all_clear = traced.iter().all(|s| s.1.is_none() && !s.2);
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

/// A partly visible (sub-)node waiting to be split or accepted.
struct Pending {
    /// Uncertainty of its contribution, lux (half range × psa × radiance).
    u: f64,
    /// Insertion order, for a deterministic tie break.
    seq: u64,
    source: usize,
    /// The child of the source node it lies in; `None` for a whole source node.
    child: Option<usize>,
    tri: [DVec3; 3],
    depth: u32,
    mean: Rgb,
    psa: f64,
}

impl PartialEq for Pending {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Pending {
    fn cmp(&self, o: &Self) -> Ordering {
        self.u.total_cmp(&o.u).then(o.seq.cmp(&self.seq))
    }
}

/// Accumulates a node's contribution: fine (per-child radiance) and coarse (L̂).
fn add(
    out: &mut SensorDirect,
    s: &Source,
    child: Option<usize>,
    value: Rgb,
    psa_children: Option<[f64; 4]>,
) {
    let fine = match (child, psa_children) {
        (Some(k), _) => s.child_radiance[k] * value,
        (None, Some(w)) => {
            let total: f64 = w.iter().sum();
            if total > 0.0 {
                (0..4).fold(Rgb::ZERO, |a, k| {
                    a + s.child_radiance[k] * value * (w[k] / total)
                })
            } else {
                Rgb::ZERO
            }
        }
        (None, None) => s.radiance * value,
    };
    out.sky += fine;
    out.radiance_error += fine - s.radiance * value;
}

/// Accepts a partly visible node at its sample mean and states its uncertainty.
fn finish(out: &mut SensorDirect, s: &Source, item: &Pending, n: DVec3) {
    let w = item
        .child
        .is_none()
        .then(|| split(item.tri[0], item.tri[1], item.tri[2]).map(|k| clipped_psa(&k, n)));
    add(out, s, item.child, item.mean * item.psa, w);
    out.visibility_err_lux += item.u;
}

/// Direct irradiance of one sensor from every source. Partly visible nodes are split
/// largest-uncertainty first (see [`SensorParams`]).
pub fn sensor_direct(
    vis: &Visibility,
    sensor: &Sensor,
    sources: &[Source],
    params: &SensorParams,
) -> SensorDirect {
    let mut out = SensorDirect::default();
    let (p, n) = (sensor.position, sensor.normal);
    let mut rays = Rays {
        vis,
        p,
        n,
        memo: HashMap::new(),
        cast: 0,
    };
    let mut heap = BinaryHeap::new();
    let mut seq = 0;
    let mut pending_err = 0.0;
    let mut pending_value = 0.0;
    let max_cos = (0.5 * params.sample_angle_deg).to_radians().cos();
    for (i, s) in sources.iter().enumerate() {
        let Some(tri) = s.vertices else {
            let cos = n.dot(s.true_direction);
            if cos > 0.0 {
                rays.cast += 1;
                out.sun += s.normal_irradiance
                    * vis.transmission_for(p, s.direction, s.true_direction)
                    * cos;
            }
            continue;
        };
        // Sample; accept what is proven, split what is wide, trust the samples of the rest
        // (see `sample_angle_deg`).
        let mut stack = vec![(tri, None::<usize>, 0u32)];
        while let Some((t, child, depth)) = stack.pop() {
            let Some(ns) = rays.sample(&t) else {
                continue;
            };
            let c = spherical_triangle::centre(t[0], t[1], t[2]);
            let wide = t.iter().any(|v| v.dot(c) < max_cos);
            if !ns.proven && wide && depth < params.visibility_depth {
                for (k, sub) in split(t[0], t[1], t[2]).into_iter().enumerate().rev() {
                    stack.push((sub, child.or(Some(k)), depth + 1));
                }
                continue;
            }
            if ns.uniform {
                let w = child
                    .is_none()
                    .then(|| split(t[0], t[1], t[2]).map(|k| clipped_psa(&k, n)));
                add(&mut out, s, child, ns.mean * ns.psa, w);
            } else {
                let l = child.map_or(s.radiance, |k| s.child_radiance[k]);
                let u = ns.half_range * ns.psa * lux(l);
                pending_err += u;
                pending_value += lux(s.radiance * ns.mean * ns.psa);
                seq += 1;
                heap.push(Pending {
                    u,
                    seq,
                    source: i,
                    child,
                    tri: t,
                    depth,
                    mean: ns.mean,
                    psa: ns.psa,
                });
            }
        }
    }
    while !heap.is_empty() {
        let estimate = lux(out.sun + out.sky) + pending_value;
        if pending_err <= params.visibility_tolerance * estimate {
            break;
        }
        let top = heap.pop().expect("peeked");
        if top.depth >= params.visibility_depth {
            // As deep as allowed: accept at its sample mean, uncertainty stated.
            pending_err -= top.u;
            pending_value -= lux(sources[top.source].radiance * top.mean * top.psa);
            finish(&mut out, &sources[top.source], &top, n);
            continue;
        }
        pending_err -= top.u;
        let s = &sources[top.source];
        pending_value -= lux(s.radiance * top.mean * top.psa);
        for (k, sub) in split(top.tri[0], top.tri[1], top.tri[2])
            .into_iter()
            .enumerate()
        {
            let child = top.child.or(Some(k));
            let Some(ns) = rays.sample(&sub) else {
                continue;
            };
            if ns.uniform {
                add(&mut out, s, child, ns.mean * ns.psa, None);
            } else {
                let u = ns.half_range * ns.psa * lux(s.child_radiance[child.expect("set above")]);
                pending_err += u;
                pending_value += lux(s.radiance * ns.mean * ns.psa);
                seq += 1;
                heap.push(Pending {
                    u,
                    seq,
                    source: top.source,
                    child,
                    tri: sub,
                    depth: top.depth + 1,
                    mean: ns.mean,
                    psa: ns.psa,
                });
            }
        }
    }
    // Accept what is left at its sample mean; its range is the stated uncertainty.
    for item in heap.into_sorted_vec() {
        finish(&mut out, &sources[item.source], &item, n);
    }
    out.rays = rays.cast;
    out
}

/// Direct irradiance of every sensor (in order), computed in parallel; the result does not
/// depend on the thread count.
pub fn all_sensors_direct(
    vis: &Visibility,
    sensors: &[Sensor],
    sources: &[Source],
    params: &SensorParams,
) -> Vec<SensorDirect> {
    sensors
        .par_iter()
        .map(|s| sensor_direct(vis, s, sources, params))
        .collect()
}
