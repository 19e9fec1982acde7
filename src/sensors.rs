//! L6 sensor illuminance from every parallel source.
//!
//! A sky or ground node contributes L̂ · ∫_node V(ω) τ(ω) max(0, n·ω) dω. The integral is
//! geometry only: where visibility is the same at the node's corners and centre it is the
//! node's exact projected solid angle (Lambert's contour formula, clipped at the sensor's
//! horizon); where it differs the node is split (same quadtree as the sky) down to a
//! maximum depth — the paper's visibility-driven refinement, in direction space. The sun
//! contributes E_n · cos θ · τ along its snapped direction. Radiance is applied per child of
//! each node (the sources carry their four children's radiance), one level finer than the
//! sources' L̂, and the difference to L̂ is reported as an error estimate. Visibility is an exact ray cast
//! (two-sided opaque occluders, glazing multiplies by τ(θ)).

use crate::math::bvh::Bvh;
use crate::math::spherical_triangle::{clip_to_hemisphere, projected_solid_angle_polygon, split};
use crate::photometry::{grey, lux, Rgb};
use crate::scene::{Scene, Sensor};
use crate::sources::Source;
use glam::DVec3;
use rayon::prelude::*;

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
        self.transmission_for(origin, dir, dir)
    }

    /// As [`Self::transmission`], with the glazing's angle of incidence taken from
    /// `incidence` instead of `dir` (the sun: visibility follows the snapped direction, the
    /// glass sees the true one).
    pub fn transmission_for(&self, origin: DVec3, dir: DVec3, incidence: DVec3) -> Rgb {
        let mut t = Rgb::ONE;
        self.bvh
            .hits_in_order(origin, dir, T_MIN_M, f64::INFINITY, |hit| {
                let tri = &self.scene.triangles[hit.triangle as usize];
                let m = &self.scene.materials[tri.material as usize];
                if m.is_glazing() {
                    t *= m.transmittance(self.normals[hit.triangle as usize].dot(incidence).abs());
                    t.max_element() > 0.0
                } else {
                    t = Rgb::ZERO;
                    false
                }
            });
        t
    }
}

/// Knobs of the sensor gather.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorParams {
    /// Deepest split of a partly visible node, relative to the node (3 → 64 sub-triangles).
    pub visibility_depth: u32,
}

impl Default for SensorParams {
    fn default() -> Self {
        SensorParams {
            visibility_depth: 4,
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
    /// Variance-like visibility uncertainty, lux²: Σ over partly visible nodes at the
    /// deepest split of (half the range of their visibility samples × projected solid
    /// angle × L̂)².
    pub visibility_var_lux2: f64,
    /// Signed difference (RGB, W/m²) between weighting each node's children by their own
    /// radiance and weighting the whole node by L̂: the error of the coarser sky
    /// representation, an upper estimate of the finer one's.
    pub radiance_error: Rgb,
}

/// Visibility samples of a node (corners and centre of its part above the sensor's
/// horizon) and that part's projected solid angle; `None` when nothing is above.
fn sample_node(
    vis: &Visibility,
    p: DVec3,
    n: DVec3,
    tri: &[DVec3; 3],
    rays: &mut u64,
) -> Option<(Vec<Rgb>, f64)> {
    let poly = clip_to_hemisphere(tri, n);
    if poly.len() < 3 {
        return None;
    }
    let psa = projected_solid_angle_polygon(&poly, n);
    if psa <= 0.0 {
        return None;
    }
    let centre = poly.iter().fold(DVec3::ZERO, |a, &b| a + b).normalize();
    let samples: Vec<Rgb> = poly
        .iter()
        .chain(std::iter::once(&centre))
        .map(|d| vis.transmission(p, *d))
        .collect();
    *rays += samples.len() as u64;
    Some((samples, psa))
}

/// (uniform value, or the mean and the half range in grey) of a node's samples.
fn summarise(samples: &[Rgb]) -> (bool, Rgb, f64) {
    let first = samples[0];
    let uniform = samples
        .iter()
        .all(|s| (*s - first).abs().max_element() < 1e-9);
    let mean = samples.iter().fold(Rgb::ZERO, |a, &b| a + b) / samples.len() as f64;
    let (lo, hi) = samples
        .iter()
        .map(|s| grey(*s))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
    (uniform, mean, 0.5 * (hi - lo))
}

fn clipped_psa(tri: &[DVec3; 3], n: DVec3) -> f64 {
    let poly = clip_to_hemisphere(tri, n);
    if poly.len() < 3 {
        0.0
    } else {
        projected_solid_angle_polygon(&poly, n)
    }
}

/// ∫_tri V τ max(0, n·ω) dω for one node, adaptively (see the module doc). `var`
/// accumulates (half range × projected solid angle)² of partly visible nodes at the
/// deepest split.
fn node_integral(
    vis: &Visibility,
    p: DVec3,
    n: DVec3,
    tri: [DVec3; 3],
    depth_left: u32,
    rays: &mut u64,
    var: &mut f64,
) -> Rgb {
    let Some((samples, psa)) = sample_node(vis, p, n, &tri, rays) else {
        return Rgb::ZERO;
    };
    let (uniform, mean, half_range) = summarise(&samples);
    if uniform {
        return samples[0] * psa;
    }
    if depth_left == 0 {
        *var += (half_range * psa).powi(2);
        return mean * psa;
    }
    split(tri[0], tri[1], tri[2])
        .iter()
        .map(|k| node_integral(vis, p, n, *k, depth_left - 1, rays, var))
        .fold(Rgb::ZERO, |a, b| a + b)
}

/// The same integral split over the node's four children (split order), so each child's
/// radiance can weight its own part.
fn node_children(
    vis: &Visibility,
    p: DVec3,
    n: DVec3,
    tri: [DVec3; 3],
    depth_left: u32,
    rays: &mut u64,
    var: &mut f64,
) -> [Rgb; 4] {
    let Some((samples, psa)) = sample_node(vis, p, n, &tri, rays) else {
        return [Rgb::ZERO; 4];
    };
    let kids = split(tri[0], tri[1], tri[2]);
    let (uniform, mean, half_range) = summarise(&samples);
    if uniform {
        return kids.map(|k| samples[0] * clipped_psa(&k, n));
    }
    if depth_left == 0 {
        *var += (half_range * psa).powi(2);
        return kids.map(|k| mean * clipped_psa(&k, n));
    }
    kids.map(|k| node_integral(vis, p, n, k, depth_left - 1, rays, var))
}

/// Direct irradiance of one sensor from every source.
pub fn sensor_direct(
    vis: &Visibility,
    sensor: &Sensor,
    sources: &[Source],
    params: &SensorParams,
) -> SensorDirect {
    let mut out = SensorDirect::default();
    let (p, n) = (sensor.position, sensor.normal);
    for s in sources {
        match s.vertices {
            Some(tri) => {
                let mut var = 0.0;
                let g = node_children(
                    vis,
                    p,
                    n,
                    tri,
                    params.visibility_depth,
                    &mut out.rays,
                    &mut var,
                );
                let fine = (0..4).fold(Rgb::ZERO, |a, k| a + s.child_radiance[k] * g[k]);
                let coarse = s.radiance * (g[0] + g[1] + g[2] + g[3]);
                out.sky += fine;
                out.radiance_error += fine - coarse;
                out.visibility_var_lux2 += lux(s.radiance).powi(2) * var;
            }
            None => {
                let cos = n.dot(s.true_direction);
                if cos > 0.0 {
                    out.rays += 1;
                    out.sun += s.normal_irradiance
                        * vis.transmission_for(p, s.direction, s.true_direction)
                        * cos;
                }
            }
        }
    }
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
