//! Materials from MTL: diffuse reflectance `Kd`, glazing transmittance `Tf` with the angular
//! fall-off of a single clear pane (Radiance `glass`, n = 1.52), emitted radiance `Ke`.

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
    /// for glazing (its specular reflection is not modelled).
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
        if !self.is_glazing() {
            return Rgb::ZERO;
        }
        Rgb::new(
            glass_transmittance(self.tf.x, cos_incidence),
            glass_transmittance(self.tf.y, cos_incidence),
            glass_transmittance(self.tf.z, cos_incidence),
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
    let cos_i = if cos_incidence.is_nan() {
        0.0
    } else {
        cos_incidence.abs().min(1.0)
    };
    if cos_i <= 0.0 {
        return 0.0;
    }
    // Internal transmissivity, rationalised (A = C²) so small `tn` suffers no cancellation;
    // it equals Radiance's expression to ~1e-8.
    let t = GLASS_B * tn / (((GLASS_C * GLASS_C + GLASS_B * tn * tn).sqrt() + GLASS_C) * GLASS_D);
    if t <= 1.0 {
        pane(t, cos_i)
    } else {
        (pane(1.0, cos_i) * tn / pane(1.0, 1.0)).clamp(0.0, 1.0)
    }
}

/// One pane with internal transmissivity `t` ≤ 1 at incidence cosine `cos_i` ∈ (0, 1].
fn pane(t: f64, cos_i: f64) -> f64 {
    let n = GLASS_INDEX;
    let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
    let sin_t = sin_i / n;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    // Fresnel reflectances in cosine form: equal to (sin(θ−θt)/sin(θ+θt))² and
    // (tan(θ−θt)/tan(θ+θt))² but without the 0/0 at normal incidence.
    let rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)).powi(2);
    let rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)).powi(2);
    let a = t.powf(1.0 / cos_t);
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
}
