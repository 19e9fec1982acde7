//! Adaptive sky subdivision (Besuievsky & Martín §4, eq. 1): start from the four upper
//! faces of an octahedron fixed in the scene frame and split a spherical triangle at its
//! edge midpoints while its solid angle exceeds a minimum and its irradiance L̂·ω exceeds a
//! maximum; L̂ averages the radiance at the three vertices and the centre. Every node that
//! adaptivity can produce is a node of the same fixed quadtree, so keys repeat exactly
//! across instants. The ground glow below the horizon is uniform and gets a fixed depth.

use super::node_geometry::{child_vertices, geometry, of_key, NodeGeometry};
use super::{SkyNodeKey, Source, SourceKey, SunKey};
use crate::photometry::{grey, Rgb};
use crate::sky::Sky;
use glam::DVec3;

/// Knobs of the sky subdivision; each trades sensor error against run time.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SkyParams {
    /// Depth every sky face is split to regardless of brightness (2 → 64 triangles).
    pub min_depth: u32,
    /// Deepest split allowed (depth 6 ≈ 0.4 msr, about 1.3° across).
    pub max_depth: u32,
    /// Nodes with a smaller solid angle (sr) are not split further.
    pub min_solid_angle_sr: f64,
    /// Split while L̂·ω exceeds this fraction of the whole sky's ∫L dω.
    pub max_irradiance_fraction: f64,
    /// Depth of the uniform ground-glow faces below the horizon.
    pub ground_depth: u32,
    /// Depth the ground-glow faces touching the horizon are split to (at least
    /// `ground_depth`). Glow from just below the horizon enters windows nearly level and
    /// lands on ceilings far inside, and where it lands moves fast with its angle there
    /// (a window head h above the ceiling's point reaches h / tan e), so a coarse face's
    /// steep centroid direction keeps it near the façade: deep rooms and corridors behind
    /// doors read low. Not in the paper; see docs/design.md.
    pub ground_horizon_depth: u32,
    /// Depth the sky faces touching the horizon are split to, whatever their brightness
    /// (0: only the brightness criteria). The sky just above the horizon enters windows as
    /// nearly level as the ground glow below it, and a parallel source images a window or
    /// a door on the surfaces behind it displaced by its angular size times their
    /// distance: on a 6 m throw an 11° face (depth 3) moves a door's image by more than
    /// the door's width, so deep interiors get bands of light in the wrong places and the
    /// sensors beside them read low. Not in the paper; see docs/design.md.
    #[serde(default)]
    pub sky_horizon_depth: u32,
    /// Also split while the spread of a node's radiance samples times its solid angle,
    /// (L_max − L_min)·ω, exceeds this fraction of the whole sky's ∫L dω: steep gradients
    /// near the horizon and around the sun make L̂ a poor average otherwise, and the
    /// product bounds the node's share of that error. Not in the paper; see docs/design.md.
    pub max_variation: f64,
    /// Sources below this fraction of the whole sky's ∫L dω are left out (and counted).
    pub negligible_fraction: f64,
}

impl Default for SkyParams {
    fn default() -> Self {
        SkyParams {
            min_depth: 2,
            max_depth: 5,
            min_solid_angle_sr: 2e-3,
            max_irradiance_fraction: 0.01,
            ground_depth: 1,
            ground_horizon_depth: 4,
            sky_horizon_depth: 4,
            max_variation: 0.002,
            negligible_fraction: 1e-7,
        }
    }
}

impl SkyParams {
    /// One level coarser everywhere: the reference for the discretisation-error estimate.
    pub fn coarser(&self) -> SkyParams {
        SkyParams {
            min_depth: self.min_depth.saturating_sub(1),
            max_depth: self.max_depth.saturating_sub(1).max(1),
            min_solid_angle_sr: self.min_solid_angle_sr * 4.0,
            max_irradiance_fraction: self.max_irradiance_fraction * 4.0,
            ground_depth: self.ground_depth.saturating_sub(1),
            ground_horizon_depth: self.ground_horizon_depth.saturating_sub(1),
            // Two levels: the adaptive criteria already split the bright band above the
            // horizon about one level short of this depth, so one level coarser barely
            // differs and left the quadrature error of unobstructed sensors under CIE
            // skies uncovered (worst error / lux_err 2.46; 1.90 with two levels).
            sky_horizon_depth: self.sky_horizon_depth.saturating_sub(2),
            max_variation: self.max_variation * 2.0,
            negligible_fraction: self.negligible_fraction,
        }
    }
}

/// The result of subdividing one sky.
#[derive(Clone, Debug, Default)]
pub struct SkySources {
    /// Sky and ground sources, in quadtree order (deterministic).
    pub sources: Vec<Source>,
    /// Sources left out because their energy was negligible.
    pub negligible: usize,
}

/// Average radiance of a node (`g`: its geometry): the solid-angle-weighted mean of the
/// radiance at its four children's centres, with their spread and the four values. Sky
/// nodes evaluate the sky just above the horizon for centres on it.
fn node_radiance(sky: &Sky, key: SkyNodeKey, g: &NodeGeometry) -> (Rgb, f64, [Rgb; 4]) {
    if !key.is_sky() {
        return (sky.ground_radiance, 0.0, [sky.ground_radiance; 4]);
    }
    // Centres of the four children: a 4-point centroid rule (same cost as the paper's
    // vertices + centre, smaller error on curved radiance; see docs/design.md).
    // A distribution that integrates exactly (an image) gives each child's mean instead.
    let l = match sky.distribution.as_ref() {
        Some(d) if d.integrates() => {
            let kids = (0..4u8).map(|k| child_vertices(key, &g.vertices, k));
            let means: Vec<Rgb> = kids
                .zip(g.child_centres)
                .map(|(k, c)| d.mean_over(&k).unwrap_or_else(|| sky.radiance(c)))
                .collect();
            [means[0], means[1], means[2], means[3]]
        }
        _ => g.child_centres.map(|c| sky.radiance(c)),
    };
    let w = g.child_solid_angles;
    let total: f64 = w.iter().sum();
    let mean = (0..4).fold(Rgb::ZERO, |a, k| a + l[k] * w[k]) / total;
    let (lo, hi) = l
        .iter()
        .map(|x| grey(*x))
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    (mean, hi - lo, l)
}

/// Sky or ground node `key` as a direction only (its centre, vertices and solid angle; no
/// radiance): bit-identical in those to the source a cut makes of it, since the cut's
/// vertices are the same splits [`SkyNodeKey::vertices`] repeats.
pub fn node_source(key: SkyNodeKey) -> Source {
    make_source(key, &of_key(key), Rgb::ZERO, [Rgb::ZERO; 4])
}

fn make_source(key: SkyNodeKey, g: &NodeGeometry, radiance: Rgb, children: [Rgb; 4]) -> Source {
    Source {
        key: if key.is_sky() {
            SourceKey::Sky(key)
        } else {
            SourceKey::Ground(key)
        },
        direction: g.centre,
        normal_irradiance: radiance * g.solid_angle,
        radiance,
        child_radiance: children,
        solid_angle: g.solid_angle,
        vertices: Some(g.vertices),
        true_direction: g.centre,
    }
}

/// Subdivides `sky` into parallel sources (sky above the horizon, ground glow below).
pub fn sky_sources(sky: &Sky, params: &SkyParams) -> SkySources {
    sky_sources_levels(sky, &[*params]).pop().expect("one cut")
}

/// [`sky_sources`] for each of `levels` (at most 8) in one walk of the quadtree: each
/// node's radiance is evaluated once for every cut that visits it, so a step's cut and
/// the coarser one of its error estimate cost little more than the finer alone. Each cut
/// is the same, to the bit and in order, as [`sky_sources`] at its level.
pub fn sky_sources_levels(sky: &Sky, levels: &[SkyParams]) -> Vec<SkySources> {
    assert!(levels.len() <= 8, "at most 8 levels in one walk");
    let mut out = vec![SkySources::default(); levels.len()];
    // Reference energy: ∫L dω over the sky at depth 2 (cheap, and only sets thresholds).
    // The walk below visits these nodes again and takes their radiance from here.
    let mut reference = 0.0;
    let mut depth2 = Vec::with_capacity(64);
    for b in 0..4u8 {
        for k1 in 0..4 {
            for k2 in 0..4 {
                let key = SkyNodeKey::root(b).child(k1).child(k2);
                let g = geometry(key, &key.vertices());
                let r = node_radiance(sky, key, &g);
                reference += grey(r.0 * g.solid_angle);
                depth2.push((key, r));
            }
        }
    }
    reference += grey(sky.ground_radiance) * 2.0 * std::f64::consts::PI;
    if reference <= 0.0 || !reference.is_finite() {
        return out;
    }
    // Each node carries its vertices down (the same splits `SkyNodeKey::vertices` repeats
    // from the root, so bit-identical, without the repetition), and the set of cuts still
    // splitting towards it (bit i: `levels[i]`); its geometry is remembered for the process
    // ([`node_geometry`]) down to `default`'s depth. Depth first in child order, so each
    // cut's sources come in the order of its own walk.
    let all = (1u16 << levels.len()) as u8 - 1;
    let mut stack: Vec<(SkyNodeKey, [DVec3; 3], u8)> = (0..8u8)
        .rev()
        .map(|b| (SkyNodeKey::root(b), SkyNodeKey::root(b).vertices(), all))
        .collect();
    while let Some((key, v, active)) = stack.pop() {
        let depth = key.depth();
        // A sky node every active cut splits by depth alone needs no radiance (a fifth
        // of a warm annual run's sky arithmetic went there).
        let by_depth = |p: &SkyParams| {
            depth < p.min_depth || (depth < p.sky_horizon_depth && touches_horizon(&v))
        };
        if key.is_sky() && (0..levels.len()).all(|i| active & (1 << i) == 0 || by_depth(&levels[i]))
        {
            for k in (0..4).rev() {
                stack.push((key.child(k), child_vertices(key, &v, k), active));
            }
            continue;
        }
        let g = geometry(key, &v);
        let (l, variation, children) = match depth2.iter().find(|(k, _)| *k == key) {
            Some((_, r)) => *r,
            None => node_radiance(sky, key, &g),
        };
        let omega = g.solid_angle;
        let mut splitting = 0u8;
        for (i, params) in levels.iter().enumerate() {
            if active & (1 << i) == 0 {
                continue;
            }
            let split = if key.is_sky() {
                by_depth(params)
                    || (depth < params.max_depth
                        && omega > params.min_solid_angle_sr
                        && (grey(l) * omega > params.max_irradiance_fraction * reference
                            || variation * omega > params.max_variation * reference))
            } else {
                grey(l) > 0.0
                    && (depth < params.ground_depth
                        || (depth < params.ground_horizon_depth && touches_horizon(&v)))
            };
            if split {
                splitting |= 1 << i;
            } else if grey(l) * omega <= params.negligible_fraction * reference || grey(l) <= 0.0 {
                out[i].negligible += 1;
            } else {
                out[i].sources.push(make_source(key, &g, l, children));
            }
        }
        if splitting != 0 {
            for k in (0..4).rev() {
                stack.push((key.child(k), child_vertices(key, &v, k), splitting));
            }
        }
    }
    out
}

/// True when a ground node has a vertex on the horizon (midpoint splits put those
/// vertices at z = 0 exactly, up to rounding).
fn touches_horizon(v: &[DVec3; 3]) -> bool {
    v.iter().any(|p| p.z.abs() < 1e-9)
}

/// The sun as a parallel source snapped to the grid of spacing `spacing_deg`, or `None`
/// when the sky has no sun. Returns the source and the snapping error, degrees.
pub fn sun_source(sky: &Sky, spacing_deg: f64) -> Option<(Source, f64)> {
    let sun = sky.sun?;
    if grey(sun.normal_irradiance) <= 0.0 || sun.direction.z <= 0.0 {
        return None;
    }
    let d = sun.direction;
    let alt = d.z.clamp(-1.0, 1.0).asin().to_degrees();
    let az = d.x.atan2(d.y).to_degrees();
    let key = SunKey::snap(alt, az, spacing_deg);
    let dir = key.direction();
    let err = dir.angle_between(d).to_degrees();
    Some((
        Source {
            key: SourceKey::Sun(key),
            direction: dir,
            normal_irradiance: sun.normal_irradiance,
            radiance: Rgb::ZERO,
            child_radiance: [Rgb::ZERO; 4],
            solid_angle: 0.0,
            vertices: None,
            true_direction: d,
        },
        err,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::spherical_triangle;
    use crate::sky::{SkyDistribution, Sun};
    use std::f64::consts::PI;

    struct Uniform(f64);
    impl SkyDistribution for Uniform {
        fn radiance(&self, _: DVec3) -> Rgb {
            Rgb::splat(self.0)
        }
    }
    struct Spot;
    impl SkyDistribution for Spot {
        fn radiance(&self, d: DVec3) -> Rgb {
            let s = DVec3::new(0.5, 0.0, 0.866).normalize();
            Rgb::splat(1.0 + 200.0 * d.dot(s).max(0.0).powi(40))
        }
    }
    fn sky(d: Box<dyn SkyDistribution>, ground: f64) -> Sky {
        Sky {
            distribution: Some(d),
            sun: None,
            ground_radiance: Rgb::splat(ground),
            description: String::new(),
            warnings: vec![],
        }
    }

    #[test]
    fn uniform_sky_sources_sum_to_exact_irradiance() {
        let s = sky(Box::new(Uniform(2.0)), 0.0);
        let src = sky_sources(&s, &SkyParams::default());
        // Horizontal irradiance from exact projected solid angles: π·L.
        let e: f64 = src
            .sources
            .iter()
            .map(|s| {
                let [a, b, c] = s.vertices.unwrap();
                s.radiance.x * spherical_triangle::projected_solid_angle(a, b, c, DVec3::Z)
            })
            .sum();
        assert!((e - 2.0 * PI).abs() < 1e-9, "{e}");
        // Uniform: no adaptive splitting beyond min_depth (or the irradiance cap).
        assert!(src
            .sources
            .iter()
            .all(|s| s.key != SourceKey::Ground(SkyNodeKey::root(4))));
        // A black ground is left out whole: its four faces are counted, not split.
        assert_eq!(src.negligible, 4);
    }

    #[test]
    fn bright_region_gets_denser_triangles() {
        let s = sky(Box::new(Spot), 0.1);
        let src = sky_sources(&s, &SkyParams::default());
        let spot = DVec3::new(0.5, 0.0, 0.866).normalize();
        let near: Vec<_> = src
            .sources
            .iter()
            .filter(|s| s.direction.dot(spot) > 0.99)
            .collect();
        let far: Vec<_> = src
            .sources
            .iter()
            .filter(|s| s.direction.dot(spot) < 0.5)
            .collect();
        let mean = |v: &[&Source]| v.iter().map(|s| s.solid_angle).sum::<f64>() / v.len() as f64;
        assert!(
            mean(&near) * 4.0 < mean(&far),
            "{} vs {}",
            mean(&near),
            mean(&far)
        );
        assert!(src
            .sources
            .iter()
            .any(|s| matches!(s.key, SourceKey::Ground(_))));
        // Vertices carried down the subdivision are those the key gives from the root.
        for s in &src.sources {
            let (SourceKey::Sky(k) | SourceKey::Ground(k)) = s.key else {
                panic!("a sky source")
            };
            assert_eq!(s.vertices, Some(k.vertices()));
        }
    }

    #[test]
    fn sun_snaps_and_reports_error() {
        let mut s = Sky::none();
        let d = crate::site::direction_from_alt_az(0.1, 123.4);
        s.sun = Some(Sun {
            direction: d,
            normal_irradiance: Rgb::splat(100.0),
        });
        let (src, err) = sun_source(&s, 0.25).unwrap();
        assert!(src.direction.z > 0.0 && err < 0.25);
        let below = crate::site::direction_from_alt_az(-0.1, 123.4);
        s.sun.as_mut().unwrap().direction = below;
        assert!(sun_source(&s, 0.25).is_none());
    }
}
