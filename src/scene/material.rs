//! Materials from MTL: diffuse reflectance `Kd`, glazing transmittance `Tf` with the angular
//! fall-off of a single clear pane (Radiance `glass`, n = 1.52), emitted radiance `Ke`.
//!
//! Glazing also reflects specularly, with Radiance `glass`'s reflectance
//! ([`glass_reflectance`], [`Material::specular_reflectance`]): about 8 % at normal
//! incidence, rising to 1 at grazing incidence. The global-line interreflection uses it;
//! direct light (sun and sky onto surfaces) is transmission-only.

use crate::photometry::Rgb;

/// A surface material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name as in the MTL file.
    pub name: String,
    /// Diffuse reflectance per channel, [0, 1).
    pub kd: Rgb,
    /// Normal-incidence transmittance per channel; all zero for opaque materials.
    pub tf: Rgb,
    /// Emitted radiance, W·sr⁻¹·m⁻² per channel, from the front face.
    pub ke: Rgb,
}

impl Material {
    /// True when the material is glazing (any `Tf` channel > 0).
    pub fn is_glazing(&self) -> bool {
        self.tf.max_element() > 0.0
    }
    /// True when the material emits light.
    pub fn is_emitter(&self) -> bool {
        self.ke.max_element() > 0.0
    }
    /// Diffuse reflectance used by the radiosity solver: `Kd` for opaque materials, zero
    /// for glazing (glazing reflects specularly only, see
    /// [`Material::specular_reflectance`]).
    pub fn reflectance(&self) -> Rgb {
        if self.is_glazing() {
            Rgb::ZERO
        } else {
            self.kd
        }
    }
    /// Transmittance (per channel, 0..1) at incidence with `|cos θ| = cos_incidence`
    /// (either side of the pane); zero for opaque materials.
    ///
    /// Each channel follows Radiance's `glass` with n = 1.52 (see [`glass_transmittance`]);
    /// a channel whose `Tf` is 0 transmits nothing. Finite for every input; non-finite or
    /// out-of-range `cos_incidence` is folded into [0, 1] first.
    pub fn transmittance(&self, cos_incidence: f64) -> Rgb {
        self.glazing_channels(glass_transmittance, cos_incidence)
    }
    /// Specular (mirror) reflectance (per channel, 0..1) at incidence with
    /// `|cos θ| = cos_incidence` (either side of the pane); zero for opaque materials, whose
    /// reflection is the diffuse [`Material::reflectance`].
    ///
    /// Each channel follows Radiance's `glass` with n = 1.52 (see [`glass_reflectance`]);
    /// a channel whose `Tf` is 0 still reflects at the front surface (Fresnel, ≈ 4 %).
    /// `specular_reflectance + transmittance ≤ 1` per channel at every angle.
    pub fn specular_reflectance(&self, cos_incidence: f64) -> Rgb {
        self.glazing_channels(glass_reflectance, cos_incidence)
    }
    /// `f(Tf channel, cos)` per channel for glazing, zero for opaque materials.
    fn glazing_channels(&self, f: fn(f64, f64) -> f64, cos_incidence: f64) -> Rgb {
        if !self.is_glazing() {
            return Rgb::ZERO;
        }
        Rgb::new(
            f(self.tf.x, cos_incidence),
            f(self.tf.y, cos_incidence),
            f(self.tf.z, cos_incidence),
        )
    }
}

/// Refractive index of the glazing pane (Radiance `glass` default).
pub const GLASS_INDEX: f64 = 1.52;

// Constants of Radiance's transmittance → transmissivity conversion for n = 1.52:
// t = (√(A + B T²) − C) / (D T), with A = C², C = (1 − r₀)², B = 2D = 4 r₀².
const GLASS_B: f64 = 0.007_252_223_9;
const GLASS_C: f64 = 0.916_653_066_1;
const GLASS_D: f64 = 0.003_626_111_9;

/// Transmittance of one clear pane (Radiance `glass`, n = 1.52, both polarisations averaged,
/// multiple internal reflections included) for normal-incidence transmittance `tn` ∈ [0, 1]
/// at incidence `|cos θ| = cos_incidence`.
///
/// Returns a value in [0, 1]: `tn` at normal incidence, 0 at grazing incidence and for
/// `tn` ≤ 0. Inputs outside their ranges (or NaN) are clamped, so the result is always finite.
///
/// A single pane with n = 1.52 cannot transmit more than (1 − r₀)/(1 + r₀) ≈ 0.918 at normal
/// incidence even without absorption; for larger `tn` the internal transmissivity would
/// exceed 1 and the formula blows up near grazing incidence. There the angular shape of the
/// lossless pane is used, scaled so that normal incidence still gives `tn`.
pub fn glass_transmittance(tn: f64, cos_incidence: f64) -> f64 {
    if tn.is_nan() || tn <= 0.0 {
        return 0.0;
    }
    let tn = tn.min(1.0);
    let cos_i = fold_cos(cos_incidence);
    if cos_i <= 0.0 {
        return 0.0;
    }
    let t = transmissivity(tn);
    if t <= 1.0 {
        pane(t, cos_i)
    } else {
        (pane(1.0, cos_i) * tn / pane(1.0, 1.0)).clamp(0.0, 1.0)
    }
}

/// Specular reflectance of one clear pane (Radiance `glass`, n = 1.52, both polarisations
/// averaged, multiple internal reflections included) for normal-incidence transmittance
/// `tn` ∈ [0, 1] at incidence `|cos θ| = cos_incidence`, from either side.
///
/// Per polarisation, with r the single-surface Fresnel reflectance and d = t^(1/cos θt)
/// the internal transmission along the refracted path (t the transmissivity that
/// [`glass_transmittance`] derives from `tn`): R = r + (1 − r)² r d² / (1 − r² d²)
/// (Radiance glass.c's r(1 + (1 − 2r)d²)/(1 − r²d²)). About 0.08 at normal incidence for
/// `tn` = 0.88, 1 at grazing incidence; `tn` = 0 gives the front surface alone (r ≈ 0.043).
///
/// `glass_reflectance + glass_transmittance ≤ 1` at every angle. Above the lossless limit
/// (`tn` > 0.918, see [`glass_transmittance`]) the pane is taken as non-absorbing:
/// R = 1 − T. Inputs outside their ranges (or NaN) are clamped like
/// [`glass_transmittance`]'s; NaN `tn` reflects nothing.
pub fn glass_reflectance(tn: f64, cos_incidence: f64) -> f64 {
    if tn.is_nan() {
        return 0.0;
    }
    let tn = tn.clamp(0.0, 1.0);
    let cos_i = fold_cos(cos_incidence);
    if cos_i <= 0.0 {
        return 1.0;
    }
    let t = transmissivity(tn);
    if t <= 1.0 {
        let (rs, rp, d) = fresnel(t, cos_i);
        let one = |r: f64| {
            let rd2 = r * r * d * d;
            if rd2 >= 1.0 {
                // r rounds to 1 only at grazing incidence: total reflection.
                1.0
            } else {
                r + (1.0 - r).powi(2) * r * d * d / (1.0 - rd2)
            }
        };
        (0.5 * (one(rs) + one(rp))).clamp(0.0, 1.0 - pane(t, cos_i))
    } else {
        (1.0 - glass_transmittance(tn, cos_i)).clamp(0.0, 1.0)
    }
}

/// `|cos θ|` folded into [0, 1] (NaN → 0, grazing).
fn fold_cos(cos_incidence: f64) -> f64 {
    if cos_incidence.is_nan() {
        0.0
    } else {
        cos_incidence.abs().min(1.0)
    }
}

/// Normal-incidence transmittance of a Radiance `glass` whose argument (internal
/// transmissivity) is `t` ∈ [0, 1]: the inverse of Radiance's transmittance →
/// transmissivity conversion used by [`glass_transmittance`] (its `tn` is this value), for
/// readers of models that give `glass` as Radiance does. Equals
/// (1 − r₀)² t / (1 − r₀² t²) with r₀ the normal-incidence Fresnel reflectance of one
/// surface at n = 1.52. NaN and values outside [0, 1] are clamped (NaN → 0).
pub fn glass_transmittance_from_transmissivity(t: f64) -> f64 {
    if t.is_nan() {
        return 0.0;
    }
    pane(t.clamp(0.0, 1.0), 1.0)
}

/// Radiance's internal transmissivity (the number a `glass` primitive takes) of a pane of
/// normal-incidence transmittance `tn` ∈ (0, 1] (n = 1.52): Radiance's transmittance →
/// transmissivity conversion, rationalised (A = C²) so small `tn` suffers no
/// cancellation; it equals Radiance's expression to ~1e-8. The inverse of
/// [`glass_transmittance_from_transmissivity`].
pub fn glass_transmissivity_from_transmittance(tn: f64) -> f64 {
    transmissivity(tn)
}

/// [`glass_transmissivity_from_transmittance`], the name this file's formulas use.
fn transmissivity(tn: f64) -> f64 {
    GLASS_B * tn / (((GLASS_C * GLASS_C + GLASS_B * tn * tn).sqrt() + GLASS_C) * GLASS_D)
}

/// Single-surface Fresnel reflectances (s, p) and the internal transmission t^(1/cos θt)
/// at incidence cosine `cos_i` ∈ (0, 1].
fn fresnel(t: f64, cos_i: f64) -> (f64, f64, f64) {
    let n = GLASS_INDEX;
    let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
    let sin_t = sin_i / n;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    // Fresnel reflectances in cosine form: equal to (sin(θ−θt)/sin(θ+θt))² and
    // (tan(θ−θt)/tan(θ+θt))² but without the 0/0 at normal incidence.
    let rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)).powi(2);
    let rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)).powi(2);
    (rs, rp, t.powf(1.0 / cos_t))
}

/// One pane with internal transmissivity `t` ≤ 1 at incidence cosine `cos_i` ∈ (0, 1].
fn pane(t: f64, cos_i: f64) -> f64 {
    let (rs, rp, a) = fresnel(t, cos_i);
    let one = |r: f64| {
        // With t = 1 and r rounding to 1 (grazing) the term is 0/0; its limit is 0.
        let ra = r * a;
        if ra >= 1.0 {
            0.0
        } else {
            (1.0 - r).powi(2) * a / ((1.0 - ra) * (1.0 + ra))
        }
    };
    (0.5 * (one(rs) + one(rp))).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn glazing(tf: Rgb) -> Material {
        Material {
            name: "glass".into(),
            kd: Rgb::splat(0.1),
            tf,
            ke: Rgb::ZERO,
        }
    }

    #[test]
    fn published_table_is_reproduced() {
        let angles = [0.0_f64, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0];
        let table = [
            (
                0.88,
                [0.8800, 0.8755, 0.8599, 0.7999, 0.6839, 0.4235, 0.2189],
            ),
            (
                0.60,
                [0.6000, 0.5835, 0.5572, 0.4986, 0.4120, 0.2358, 0.1036],
            ),
        ];
        for (tn, expected) in table {
            let m = glazing(Rgb::splat(tn));
            for (deg, want) in angles.iter().zip(expected) {
                let got = m.transmittance(deg.to_radians().cos());
                for c in got.to_array() {
                    assert!((c - want).abs() < 5e-4, "Tn {tn} at {deg}°: {c} vs {want}");
                }
            }
        }
    }

    #[test]
    fn transmissivity_round_trips_through_radiance_formula() {
        // Radiance's own conversion (its glass documentation), written out.
        let radiance = |tn: f64| {
            ((0.8402528435 + 0.0072522239 * tn * tn).sqrt() - 0.9166530661) / 0.0036261119 / tn
        };
        // Its ten-digit constants cancel at small tn: 1e-6 at tn = 0.05.
        for tn in [0.05, 0.2, 0.64, 0.88, 0.9] {
            let t = radiance(tn);
            let back = glass_transmittance_from_transmissivity(t);
            assert!((back - tn).abs() < 1e-6, "{tn}: {t} -> {back}");
            assert!((transmissivity(tn) - t).abs() < 1e-6);
        }
        // Honeybee's generic exterior window: transmittance 0.64 written as 0.6975761815…
        let hb = glass_transmittance_from_transmissivity(0.6975761815384331);
        // (honeybee computed it with the ten-digit formula: within 1e-7.)
        assert!((hb - 0.64).abs() < 1e-7, "{hb}");
        assert_eq!(glass_transmittance_from_transmissivity(0.0), 0.0);
        assert_eq!(glass_transmittance_from_transmissivity(f64::NAN), 0.0);
        let one = glass_transmittance_from_transmissivity(1.0);
        assert!(
            (one - (1.0 - 0.0426) / (1.0 + 0.0426)).abs() < 1e-3,
            "{one}"
        );
    }

    #[test]
    fn channels_are_independent_and_zero_tf_gives_zero() {
        let m = glazing(Rgb::new(0.88, 0.0, 0.6));
        let t = m.transmittance(1.0);
        assert!((t.x - 0.88).abs() < 1e-6 && t.y == 0.0 && (t.z - 0.6).abs() < 1e-6);
    }

    #[test]
    fn opaque_and_grazing_give_zero() {
        let opaque = glazing(Rgb::ZERO);
        assert_eq!(opaque.transmittance(1.0), Rgb::ZERO);
        assert_eq!(glazing(Rgb::splat(0.8)).transmittance(0.0), Rgb::ZERO);
        // Either side of the pane.
        let m = glazing(Rgb::splat(0.8));
        assert_eq!(m.transmittance(-0.5), m.transmittance(0.5));
    }

    #[test]
    fn finite_and_bounded_everywhere() {
        for tn in [
            1e-300,
            1e-9,
            0.01,
            0.5,
            0.9,
            0.918,
            0.919,
            0.95,
            1.0,
            2.0,
            f64::NAN,
        ] {
            let mut prev = f64::NEG_INFINITY;
            for k in 0..=2000 {
                let c = k as f64 / 2000.0;
                let t = glass_transmittance(tn, c);
                assert!(
                    t.is_finite() && (0.0..=1.0).contains(&t),
                    "tn {tn} cos {c}: {t}"
                );
                // Transmittance never increases towards grazing incidence.
                assert!(t >= prev - 1e-12, "tn {tn} cos {c}: {t} < {prev}");
                prev = t;
            }
            let t1 = glass_transmittance(tn, 1.0);
            if tn.is_finite() && tn <= 1.0 {
                assert!((t1 - tn).abs() < 1e-7 * tn.max(1e-3), "tn {tn}: {t1}");
            }
        }
        for c in [f64::NAN, f64::INFINITY, -2.0, 1e-300, 5e-324] {
            assert!(glass_transmittance(0.88, c).is_finite());
        }
    }

    /// Fresnel reflectance of one surface, written out independently of the module:
    /// s and p from Snell's law with angles (not cosines).
    fn fresnel_angles(theta: f64) -> (f64, f64) {
        let n = 1.52;
        let tt = (theta.sin() / n).asin();
        if theta == 0.0 {
            let r = ((n - 1.0) / (n + 1.0)).powi(2);
            return (r, r);
        }
        let rs = ((theta - tt).sin() / (theta + tt).sin()).powi(2);
        let rp = ((theta - tt).tan() / (theta + tt).tan()).powi(2);
        (rs, rp)
    }

    #[test]
    fn reflectance_matches_fresnel_written_out() {
        // A pane with internal transmission a along the refracted path: light bounces
        // between the faces, R = r + (1 − r)² r a² Σ (r a)^2k, averaged over s and p.
        for tn in [0.0, 0.6, 0.88] {
            for deg in [0.0_f64, 60.0] {
                let theta = deg.to_radians();
                let (rs, rp) = fresnel_angles(theta);
                // Radiance's transmissivity from tn: solve tn = T(t, 0°) for t by bisection
                // on the lossless-series transmittance, independently of the closed form.
                let r0 = fresnel_angles(0.0).0;
                let t_of = |t: f64| (1.0 - r0).powi(2) * t / (1.0 - r0 * r0 * t * t);
                let (mut lo, mut hi) = (0.0, 1.0);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if t_of(mid) < tn {
                        lo = mid
                    } else {
                        hi = mid
                    }
                }
                let t = 0.5 * (lo + hi);
                let cos_t = (1.0 - (theta.sin() / 1.52).powi(2)).sqrt();
                let a = t.powf(1.0 / cos_t);
                let series = |r: f64| {
                    let mut sum = r;
                    let mut term = (1.0 - r).powi(2) * r * a * a;
                    for _ in 0..200 {
                        sum += term;
                        term *= r * r * a * a;
                    }
                    sum
                };
                let want = 0.5 * (series(rs) + series(rp));
                let got = glass_reflectance(tn, theta.cos());
                assert!(
                    (got - want).abs() < 1e-6,
                    "tn {tn} at {deg}°: {got} vs {want}"
                );
            }
        }
        // Radiance's glass with Tn = 0.88: R(0°) ≈ 0.08.
        let r0 = glass_reflectance(0.88, 1.0);
        assert!((r0 - 0.08).abs() < 0.003, "{r0}");
    }

    #[test]
    fn reflectance_and_transmittance_conserve_energy() {
        for tn in [0.0, 1e-9, 0.3, 0.6, 0.88, 0.918, 0.919, 0.95, 1.0, 2.0] {
            let mut prev = 0.0;
            for k in 0..=2000 {
                let c = 1.0 - k as f64 / 2000.0;
                let r = glass_reflectance(tn, c);
                let t = glass_transmittance(tn, c);
                assert!(r.is_finite() && r >= 0.0, "tn {tn} cos {c}: {r}");
                assert!(r + t <= 1.0 + 1e-12, "tn {tn} cos {c}: R {r} + T {t}");
                // Reflectance rises towards grazing incidence beyond 60°; nearer normal
                // incidence the longer path in an absorbing pane may lower it slightly.
                if c <= 0.5 {
                    assert!(r >= prev - 1e-12, "tn {tn} cos {c}: {r} < {prev}");
                } else {
                    assert!(
                        r >= glass_reflectance(tn, 1.0) - 1e-3,
                        "tn {tn} cos {c}: {r}"
                    );
                }
                prev = r;
            }
            // R → 1 at grazing incidence.
            assert!(glass_reflectance(tn, 1e-6) > 0.999, "tn {tn}");
            assert_eq!(glass_reflectance(tn, 0.0), 1.0);
        }
        for c in [f64::NAN, f64::INFINITY, -2.0, 1e-300, 5e-324] {
            assert!(glass_reflectance(0.88, c).is_finite());
        }
        assert_eq!(glass_reflectance(f64::NAN, 0.5), 0.0);
    }

    #[test]
    fn specular_reflectance_per_channel_and_zero_when_opaque() {
        let m = glazing(Rgb::new(0.88, 0.0, 0.6));
        let r = m.specular_reflectance(0.5);
        assert_eq!(r.x, glass_reflectance(0.88, 0.5));
        assert_eq!(r.y, glass_reflectance(0.0, 0.5));
        assert_eq!(r.z, glass_reflectance(0.6, 0.5));
        assert_eq!(m.specular_reflectance(-0.5), r);
        assert_eq!(glazing(Rgb::ZERO).specular_reflectance(1.0), Rgb::ZERO);
        // The diffuse reflectance of glazing stays zero.
        assert_eq!(m.reflectance(), Rgb::ZERO);
    }
}
