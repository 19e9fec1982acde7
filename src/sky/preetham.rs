//! Preetham, Shirley & Smits (1999, "A practical analytic model for daylight") clear sky
//! with its own absolute zenith luminance, and the sun through the paper's appendix
//! transmittances.
//!
//! Sky: luminance Y and chromaticity x, y each follow the Perez form
//! F(θ, γ) = (1 + A·e^{B/cos θ})(1 + C·e^{Dγ} + E·cos²γ), value = value_z·F(θ, γ)/F(0, θ_s),
//! with coefficients linear in turbidity T. (x, y, Y) → XYZ → RGB in Radiance's primaries
//! (R 0.640/0.330, G 0.290/0.600, B 0.150/0.060, equal-energy white), scaled so that
//! 179·(0.265R + 0.670G + 0.065B) = Y exactly, then divided by 179 lm/W → W·sr⁻¹·m⁻².
//!
//! Sun: normal irradiance = 128 000 lx / 179 lm/W × τ(λ) per channel, τ = τ_Rayleigh·τ_aerosol
//! evaluated at one representative wavelength per channel ([`SUN_WAVELENGTHS_UM`]). Ozone,
//! mixed-gas and water-vapour absorption of the appendix are left out: their bands lie
//! mostly outside these three wavelengths and the ozone table values were not verified.
//!
//! The fit is valid for T ∈ [2, 10] with the sun above the horizon; T outside is clamped
//! with a warning (at T > 10.9 Y_z turns negative for a low sun).

use super::{
    check_ground_reflectance, check_sun_direction, ground_radiance, horizontal_irradiance, Sky,
    SkyDistribution, Sun, MIN_COS_ZENITH,
};
use crate::photometry::{grey, Rgb, EFFICACY_LM_PER_W};
use crate::{Error, Result};
use glam::{DMat3, DVec3};

/// Turbidity range over which the model is used; values outside are clamped.
pub const TURBIDITY_RANGE: (f64, f64) = (2.0, 10.0);

/// Extraterrestrial normal illuminance of the sun assumed for the direct beam, lux.
pub const EXTRATERRESTRIAL_ILLUMINANCE_LX: f64 = 128_000.0;

/// Wavelengths (µm) at which the beam transmittance is evaluated for R, G and B: close to
/// the dominant wavelengths of Radiance's primaries (≈ 611, 549 and 466 nm).
pub const SUN_WAVELENGTHS_UM: [f64; 3] = [0.61, 0.55, 0.47];

/// Perez-form coefficients (A..E) as p·T + q for Y, x, y (Preetham 1999, appendix).
const Y_COEFF: [[f64; 2]; 5] = [
    [0.1787, -1.4630],
    [-0.3554, 0.4275],
    [-0.0227, 5.3251],
    [0.1206, -2.5771],
    [-0.0670, 0.3703],
];
const X_COEFF: [[f64; 2]; 5] = [
    [-0.0193, -0.2592],
    [-0.0665, 0.0008],
    [-0.0004, 0.2125],
    [-0.0641, -0.8989],
    [-0.0033, 0.0452],
];
const YC_COEFF: [[f64; 2]; 5] = [
    [-0.0167, -0.2608],
    [-0.0950, 0.0092],
    [-0.0079, 0.2102],
    [-0.0441, -1.6537],
    [-0.0109, 0.0529],
];
/// Zenith chromaticity matrices: rows for T², T, 1; columns for θ_s³, θ_s², θ_s, 1.
const MX: [[f64; 4]; 3] = [
    [0.00166, -0.00375, 0.00209, 0.0],
    [-0.02903, 0.06377, -0.03202, 0.00394],
    [0.11693, -0.21196, 0.06052, 0.25886],
];
const MY: [[f64; 4]; 3] = [
    [0.00275, -0.00610, 0.00317, 0.0],
    [-0.04214, 0.08970, -0.04153, 0.00516],
    [0.15346, -0.26756, 0.06670, 0.26688],
];

/// One Perez-form function with its coefficients for a turbidity.
#[derive(Clone, Copy, Debug)]
struct PerezForm([f64; 5]);

impl PerezForm {
    fn new(table: &[[f64; 2]; 5], t: f64) -> Self {
        PerezForm(table.map(|[p, q]| p * t + q))
    }
    /// F(θ, γ) with θ given by its cosine.
    fn eval(&self, cos_theta: f64, gamma: f64) -> f64 {
        let [a, b, c, d, e] = self.0;
        let cg = gamma.cos();
        (1.0 + a * (b / cos_theta.max(MIN_COS_ZENITH)).exp())
            * (1.0 + c * (d * gamma).exp() + e * cg * cg)
    }
}

/// Zenith luminance Y_z (kcd/m²) and chromaticity x_z, y_z for turbidity `turbidity` and
/// sun zenith angle `theta_s_rad` (radians). Pure formula: no clamping of T.
pub fn zenith(turbidity: f64, theta_s_rad: f64) -> (f64, f64, f64) {
    let t = turbidity;
    let chi = (4.0 / 9.0 - t / 120.0) * (std::f64::consts::PI - 2.0 * theta_s_rad);
    let yz = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
    let th = [theta_s_rad.powi(3), theta_s_rad.powi(2), theta_s_rad, 1.0];
    let tv = [t * t, t, 1.0];
    let quad = |m: &[[f64; 4]; 3]| -> f64 {
        (0..3)
            .map(|i| tv[i] * (0..4).map(|j| m[i][j] * th[j]).sum::<f64>())
            .sum()
    };
    (yz, quad(&MX), quad(&MY))
}

/// Relative luminance Y/Y_z (dimensionless) at view zenith `theta_rad`, angle `gamma_rad`
/// from the sun, sun zenith `theta_s_rad` (radians) for turbidity `turbidity` (unclamped).
pub fn relative_luminance(turbidity: f64, theta_rad: f64, gamma_rad: f64, theta_s_rad: f64) -> f64 {
    let f = PerezForm::new(&Y_COEFF, turbidity);
    f.eval(theta_rad.cos(), gamma_rad) / f.eval(1.0, theta_s_rad)
}

/// Linear map CIE XYZ → RGB in Radiance's primaries with equal-energy white (X=Y=Z ↦ R=G=B).
fn xyz_to_rgb() -> DMat3 {
    let prim = [(0.640, 0.330), (0.290, 0.600), (0.150, 0.060)];
    let col = |(x, y): (f64, f64)| DVec3::new(x / y, 1.0, (1.0 - x - y) / y);
    let p = DMat3::from_cols(col(prim[0]), col(prim[1]), col(prim[2]));
    // Scale the primaries so that R = G = B = 1 gives the white point XYZ = (1, 1, 1).
    let s = p.inverse() * DVec3::ONE;
    let rgb_to_xyz = DMat3::from_cols(p.x_axis * s.x, p.y_axis * s.y, p.z_axis * s.z);
    rgb_to_xyz.inverse()
}

/// RGB triple in luminance units (grey(rgb) = Y, cd/m²) for chromaticity (x, y) and
/// luminance Y (cd/m²). Out-of-gamut negative channels are cut to 0 and the triple is
/// rescaled so that its weighted sum 0.265R + 0.670G + 0.065B is exactly Y (Radiance's rounded weights
/// 0.265/0.670/0.065 differ from the exact primaries' by < 2·10⁻⁴).
fn xyy_to_rgb_luminance(m: &DMat3, x: f64, y: f64, lum: f64) -> Rgb {
    if lum <= 0.0 || y <= 0.0 {
        return Rgb::ZERO;
    }
    let xyz = DVec3::new(x / y * lum, lum, (1.0 - x - y) / y * lum);
    let rgb = (*m * xyz).max(Rgb::ZERO);
    let g = grey(rgb);
    if g > 0.0 {
        rgb * (lum / g)
    } else {
        Rgb::ZERO
    }
}

/// The Preetham distribution for one turbidity and sun position.
struct PreethamDistribution {
    sun_dir: DVec3,
    fy: PerezForm,
    fx: PerezForm,
    fyc: PerezForm,
    /// value_z / F(0, θ_s) for Y (cd/m²), x, y.
    ky: f64,
    kx: f64,
    kyc: f64,
    to_rgb: DMat3,
}

impl SkyDistribution for PreethamDistribution {
    fn radiance(&self, dir: DVec3) -> Rgb {
        let gamma = dir.dot(self.sun_dir).clamp(-1.0, 1.0).acos();
        let lum = self.ky * self.fy.eval(dir.z, gamma);
        let x = self.kx * self.fx.eval(dir.z, gamma);
        let y = self.kyc * self.fyc.eval(dir.z, gamma);
        xyy_to_rgb_luminance(&self.to_rgb, x, y, lum) / EFFICACY_LM_PER_W
    }
}

/// Relative optical air mass (Kasten 1966) for sun zenith `theta_s` (radians).
fn air_mass(theta_s: f64) -> f64 {
    1.0 / (theta_s.cos() + 0.15 * (93.885 - theta_s.to_degrees()).powf(-1.253))
}

/// Beam transmittance at wavelength `lambda_um` (µm) for turbidity `t` and air mass `m`:
/// Rayleigh τ_R = exp(−0.008735·m·λ^−4.08) times Ångström aerosol τ_a = exp(−β·m·λ^−α),
/// β = 0.04608T − 0.04586, α = 1.3 (Preetham 1999 appendix).
fn beam_transmittance(lambda_um: f64, t: f64, m: f64) -> f64 {
    let beta = 0.04608 * t - 0.04586;
    let tau_r = (-0.008735 * m * lambda_um.powf(-4.08)).exp();
    let tau_a = (-beta * m * lambda_um.powf(-1.3)).exp();
    tau_r * tau_a
}

/// Preetham clear sky for `turbidity` (clamped to [2, 10] with a warning; NaN is an error),
/// sun direction `sun_dir` (scene frame) and ground reflectance ∈ [0, 1]. Absolute
/// luminance from the model's own Y_z; the sun's normal irradiance from the appendix
/// transmittances (see module docs). Sun at or below the horizon → dark sky, no sun, with a
/// warning.
pub fn sky(turbidity: f64, sun_dir: DVec3, ground_reflectance: f64) -> Result<Sky> {
    if turbidity.is_nan() {
        return Err(Error::arg(
            "turbidity",
            turbidity,
            "turbidity must be a number (the Preetham fit covers 2 to 10)",
        ));
    }
    let sun_dir = check_sun_direction(sun_dir)?;
    let rho = check_ground_reflectance(ground_reflectance)?;
    let mut warnings = Vec::new();
    let (lo, hi) = TURBIDITY_RANGE;
    let t = turbidity.clamp(lo, hi);
    if t != turbidity {
        warnings.push(format!(
            "turbidity {turbidity} is outside the Preetham model's fitted range [{lo}, {hi}]; \
             using {t}"
        ));
    }
    let description = format!("preetham turbidity={t}");

    if sun_dir.z <= 0.0 {
        let mut s = Sky::none();
        s.description = description;
        s.warnings = warnings;
        s.warnings.push(format!(
            "sun at or below the horizon (altitude {:.2}°): Preetham sky is dark",
            sun_dir.z.clamp(-1.0, 1.0).asin().to_degrees()
        ));
        return Ok(s);
    }

    let theta_s = sun_dir.z.clamp(-1.0, 1.0).acos();
    let (yz_kcd, xz, yz) = zenith(t, theta_s);
    let (fy, fx, fyc) = (
        PerezForm::new(&Y_COEFF, t),
        PerezForm::new(&X_COEFF, t),
        PerezForm::new(&YC_COEFF, t),
    );
    let dist = PreethamDistribution {
        sun_dir,
        fy,
        fx,
        fyc,
        ky: 1000.0 * yz_kcd / fy.eval(1.0, theta_s),
        kx: xz / fx.eval(1.0, theta_s),
        kyc: yz / fyc.eval(1.0, theta_s),
        to_rgb: xyz_to_rgb(),
    };
    let e_sky = horizontal_irradiance(&dist);
    if !e_sky.is_finite() {
        return Err(Error::Numerical(format!(
            "Preetham sky horizontal irradiance {e_sky:?} for {description}"
        )));
    }

    let m = air_mass(theta_s);
    let e_ext = EXTRATERRESTRIAL_ILLUMINANCE_LX / EFFICACY_LM_PER_W;
    let normal = Rgb::from_array(SUN_WAVELENGTHS_UM.map(|l| e_ext * beam_transmittance(l, t, m)));
    let sun = Sun {
        direction: sun_dir,
        normal_irradiance: normal,
    };

    Ok(Sky {
        distribution: Some(Box::new(dist)),
        sun: Some(sun),
        ground_radiance: ground_radiance(rho, e_sky + normal * sun_dir.z),
        description,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::lux;
    use crate::site::direction_from_alt_az;

    /// docs/derivations.md, "Preetham clear sky": (T, θ_s°, Y_z kcd/m², x_z, y_z).
    const ZENITH: [(f64, f64, f64, f64, f64); 16] = [
        (2.0, 0.0, 15.5007, 0.2667, 0.2772),
        (2.0, 30.0, 5.8867, 0.2514, 0.2559),
        (2.0, 60.0, 3.4873, 0.2380, 0.2420),
        (2.0, 80.0, 2.4575, 0.2580, 0.2709),
        (3.0, 0.0, 29.4773, 0.2707, 0.2824),
        (3.0, 30.0, 10.4131, 0.2534, 0.2598),
        (3.0, 60.0, 5.1392, 0.2449, 0.2526),
        (3.0, 80.0, 2.8293, 0.2632, 0.2783),
        (6.0, 0.0, 57.1798, 0.2825, 0.2978),
        (6.0, 30.0, 22.0667, 0.2631, 0.2760),
        (6.0, 60.0, 9.5853, 0.2655, 0.2818),
        (6.0, 80.0, 3.8006, 0.2802, 0.3009),
        (10.0, 0.0, 76.3556, 0.2983, 0.3185),
        (10.0, 30.0, 33.7397, 0.2846, 0.3083),
        (10.0, 60.0, 14.3603, 0.2924, 0.3148),
        (10.0, 80.0, 4.7606, 0.3064, 0.3315),
    ];

    #[test]
    fn zenith_table() {
        for &(t, ts, y, x, yc) in &ZENITH {
            let (gy, gx, gyc) = zenith(t, ts.to_radians());
            assert!((gy - y).abs() < 1e-3, "T={t} θs={ts}: Y {gy} vs {y}");
            assert!((gx - x).abs() < 1e-4, "T={t} θs={ts}: x {gx} vs {x}");
            assert!((gyc - yc).abs() < 1e-4, "T={t} θs={ts}: y {gyc} vs {yc}");
        }
    }

    /// docs/derivations.md, "Preetham clear sky": Y/Y_z at θ_s = 30° for (θ, γ) = (85°, 115°), (60°, 30°), (45°, 75°).
    #[test]
    fn relative_luminance_table() {
        let cases = [
            (2.0, [2.28688, 2.22918, 0.71809]),
            (3.0, [0.77007, 1.45239, 0.57311]),
            (6.0, [0.40979, 1.06257, 0.51417]),
        ];
        let angles = [(85.0, 115.0), (60.0, 30.0), (45.0, 75.0)];
        for (t, want) in cases {
            for ((th, g), w) in angles.iter().zip(want) {
                let got = relative_luminance(
                    t,
                    f64::to_radians(*th),
                    f64::to_radians(*g),
                    30f64.to_radians(),
                );
                assert!((got - w).abs() < 1e-4, "T={t} ({th},{g}): {got} vs {w}");
            }
        }
    }

    /// View direction at zenith angle `theta` whose angle to a sun at zenith `ts`, azimuth 0
    /// (north) is `gamma` (degrees), from the spherical law of cosines.
    fn view_dir(theta: f64, gamma: f64, ts: f64) -> DVec3 {
        let (t, g, s) = (theta.to_radians(), gamma.to_radians(), ts.to_radians());
        let cos_dphi = ((g.cos() - t.cos() * s.cos()) / (t.sin() * s.sin())).clamp(-1.0, 1.0);
        direction_from_alt_az(90.0 - theta, cos_dphi.acos().to_degrees())
    }

    #[test]
    fn sky_luminance_is_absolute_and_follows_table() {
        let sun = direction_from_alt_az(60.0, 0.0);
        for (t, rel) in [
            (3.0, [0.77007, 1.45239, 0.57311]),
            (6.0, [0.40979, 1.06257, 0.51417]),
        ] {
            let s = sky(t, sun, 0.2).unwrap();
            assert!(s.warnings.is_empty());
            let (yz, _, _) = zenith(t, 30f64.to_radians());
            let lz = lux(s.radiance(DVec3::Z));
            assert!((lz / (1000.0 * yz) - 1.0).abs() < 1e-9, "{lz} vs {yz} kcd");
            for ((th, g), w) in [(85.0, 115.0), (60.0, 30.0), (45.0, 75.0)].iter().zip(rel) {
                let l = lux(s.radiance(view_dir(*th, *g, 30.0)));
                assert!((l / lz - w).abs() < 1e-3, "T={t} ({th},{g}): {}", l / lz);
            }
        }
    }

    #[test]
    fn rgb_conversion_preserves_luminance_and_white() {
        let m = xyz_to_rgb();
        // Equal-energy white → equal channels.
        let w = xyy_to_rgb_luminance(&m, 1.0 / 3.0, 1.0 / 3.0, 100.0);
        assert!((w - Rgb::splat(100.0)).abs().max_element() < 0.1, "{w:?}");
        // A blue-sky chromaticity: luminance preserved, blue > red.
        let b = xyy_to_rgb_luminance(&m, 0.25, 0.26, 5000.0);
        assert!((grey(b) - 5000.0).abs() < 1e-9 && b.z > b.x);
        // The primaries map to themselves.
        let r = m * DVec3::new(0.64 / 0.33, 1.0, 0.03 / 0.33);
        assert!(r.y.abs() < 1e-9 && r.z.abs() < 1e-9 && r.x > 0.0);
    }

    #[test]
    fn sun_transmittance_and_ground_glow() {
        let sun_dir = direction_from_alt_az(45.0, 180.0);
        let s = sky(3.0, sun_dir, 0.2).unwrap();
        let sun = s.sun.unwrap();
        let n = sun.normal_irradiance;
        // Rayleigh and aerosol scattering are stronger in the blue: R > G > B, all below
        // the extraterrestrial 128 klx / 179.
        assert!(n.x > n.y && n.y > n.z && n.x < 128_000.0 / 179.0, "{n:?}");
        // Closed form for the G channel at 0.55 µm.
        let m = 1.0 / (45f64.to_radians().cos() + 0.15 * (93.885 - 45.0f64).powf(-1.253));
        let beta = 0.04608 * 3.0 - 0.04586;
        let tau =
            (-0.008735 * m * 0.55f64.powf(-4.08)).exp() * (-beta * m * 0.55f64.powf(-1.3)).exp();
        assert!((n.y - 128_000.0 / 179.0 * tau).abs() < 1e-9);
        // Ground = ρ (E_sky + E_sun)/π with E_sky from an independent quadrature.
        let (nz, na) = (200, 400);
        let mut e_sky = Rgb::ZERO;
        for i in 0..nz {
            let z = (i as f64 + 0.5) * 90.0 / nz as f64;
            let w = z.to_radians().cos()
                * z.to_radians().sin()
                * (90.0 / nz as f64).to_radians()
                * (360.0 / na as f64).to_radians();
            for j in 0..na {
                e_sky += s.radiance(direction_from_alt_az(
                    90.0 - z,
                    (j as f64 + 0.5) * 360.0 / na as f64,
                )) * w;
            }
        }
        let expected = (e_sky + n * sun_dir.z) * (0.2 / std::f64::consts::PI);
        assert!(
            ((s.ground_radiance - expected) / expected)
                .abs()
                .max_element()
                < 2e-3,
            "{:?} vs {expected:?}",
            s.ground_radiance
        );
        // A clear sky is bluish.
        let zen = s.radiance(DVec3::Z);
        assert!(zen.z > zen.x, "{zen:?}");
    }

    #[test]
    fn turbidity_is_clamped_with_warning_and_nan_rejected() {
        let sun = direction_from_alt_az(5.0, 90.0);
        let s = sky(15.0, sun, 0.2).unwrap();
        assert_eq!(s.warnings.len(), 1);
        assert!(s.warnings[0].contains("15"));
        let s10 = sky(10.0, sun, 0.2).unwrap();
        assert_eq!(s.radiance(DVec3::Z), s10.radiance(DVec3::Z));
        assert!(lux(s.radiance(DVec3::Z)) > 0.0);
        assert_eq!(sky(1.0, sun, 0.2).unwrap().warnings.len(), 1);
        assert!(sky(f64::NAN, sun, 0.2).is_err());
        assert!(sky(3.0, sun, 2.0).is_err());
        assert!(sky(3.0, DVec3::ZERO, 0.2).is_err());
    }

    #[test]
    fn sun_below_horizon_is_dark() {
        let s = sky(3.0, direction_from_alt_az(-1.0, 90.0), 0.2).unwrap();
        assert!(s.distribution.is_none() && s.sun.is_none());
        assert_eq!(s.ground_radiance, Rgb::ZERO);
        assert!(s.warnings.iter().any(|w| w.contains("horizon")));
    }

    #[test]
    fn low_sun_values_are_finite_and_non_negative() {
        for t in [2.0, 6.0, 10.0] {
            let s = sky(t, direction_from_alt_az(0.2, 270.0), 0.2).unwrap();
            for alt in [0.05, 2.0, 30.0, 89.9] {
                for az in [0.0, 90.0, 270.0] {
                    let l = s.radiance(direction_from_alt_az(alt, az));
                    assert!(l.is_finite() && l.min_element() >= 0.0, "{l:?}");
                }
            }
            assert!(s.ground_radiance.is_finite());
        }
    }
}
