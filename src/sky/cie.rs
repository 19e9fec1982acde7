//! CIE skies: the 15 ISO 15469:2004 / CIE S 011/E:2003 general skies and the traditional
//! CIE overcast sky (Moon & Spencer 1942), normalised to a diffuse horizontal irradiance.
//!
//! Relative luminance of the general skies (the 1997 form, with e^{dχ} − e^{dπ/2}):
//! L(Z, α)/L_z = f(χ)·φ(Z) / (f(Z_s)·φ(0)), φ(Z) = 1 + a·exp(b/cos Z),
//! f(χ) = 1 + c[exp(dχ) − exp(dπ/2)] + e·cos²χ, χ the angle between view and sun.
//! Absolute level: the sky's horizontal illuminance is 179 lm/W × DHI, i.e. its horizontal
//! irradiance in Radiance units equals DHI (as gensky -B). Colour: white (equal RGB).

use super::{
    check_ground_reflectance, check_irradiance, check_sun_direction, ground_radiance,
    horizontal_irradiance, Sky, SkyDistribution, Sun, MIN_COS_ZENITH,
};
use crate::photometry::Rgb;
use crate::{Error, Result};
use glam::DVec3;
use std::f64::consts::FRAC_PI_2;

/// Which CIE sky.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CieSkyType {
    /// ISO 15469 / CIE S 011 general sky type 1..=15 (1 = overcast steep gradation,
    /// 5 = uniform, 12 = CIE standard clear, 15 = white-blue turbid).
    General(u8),
    /// Traditional CIE overcast sky (Moon–Spencer): L = L_z (1 + 2 cos Z)/3.
    TraditionalOvercast,
}

/// Gradation (a, b) and indicatrix (c, d, e) parameters of the 15 general skies,
/// ISO 15469:2004 table 1.
const PARAMS: [[f64; 5]; 15] = [
    [4.0, -0.70, 0.0, -1.0, 0.00],
    [4.0, -0.70, 2.0, -1.5, 0.15],
    [1.1, -0.8, 0.0, -1.0, 0.00],
    [1.1, -0.8, 2.0, -1.5, 0.15],
    [0.0, -1.0, 0.0, -1.0, 0.00],
    [0.0, -1.0, 2.0, -1.5, 0.15],
    [0.0, -1.0, 5.0, -2.5, 0.30],
    [0.0, -1.0, 10.0, -3.0, 0.45],
    [-1.0, -0.55, 2.0, -1.5, 0.15],
    [-1.0, -0.55, 5.0, -2.5, 0.30],
    [-1.0, -0.55, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 24.0, -2.8, 0.15],
];

impl CieSkyType {
    /// The (a, b, c, d, e) parameters of a general sky; `None` for the traditional overcast
    /// sky or an out-of-range type number.
    pub fn parameters(self) -> Option<[f64; 5]> {
        match self {
            CieSkyType::General(n @ 1..=15) => Some(PARAMS[usize::from(n) - 1]),
            _ => None,
        }
    }

    /// Rejects general sky numbers outside 1..=15.
    fn check(self) -> Result<Self> {
        match self {
            CieSkyType::General(n) if !(1..=15).contains(&n) => Err(Error::arg(
                "cie_type",
                n,
                "CIE general sky type must be between 1 and 15",
            )),
            _ => Ok(self),
        }
    }

    /// Short name for descriptions: `type=12` or `overcast`.
    fn label(self) -> String {
        match self {
            CieSkyType::General(n) => format!("type={n}"),
            CieSkyType::TraditionalOvercast => "overcast".into(),
        }
    }
}

/// Gradation function φ(Z) = 1 + a·exp(b / cos Z) for cos Z = `cos_z`.
fn gradation(a: f64, b: f64, cos_z: f64) -> f64 {
    1.0 + a * (b / cos_z.max(MIN_COS_ZENITH)).exp()
}

/// Scattering indicatrix f(χ) = 1 + c[exp(dχ) − exp(dπ/2)] + e·cos²χ, χ in radians.
fn indicatrix(c: f64, d: f64, e: f64, chi: f64) -> f64 {
    let cos_chi = chi.cos();
    1.0 + c * ((d * chi).exp() - (d * FRAC_PI_2).exp()) + e * cos_chi * cos_chi
}

/// Relative luminance L/L_z (dimensionless) of sky `kind` at view zenith angle
/// `zenith_rad`, azimuth difference view − sun `azimuth_diff_rad` and sun zenith angle
/// `sun_zenith_rad` (all radians). Returns NaN for a general type outside 1..=15.
pub fn relative_luminance(
    kind: CieSkyType,
    zenith_rad: f64,
    azimuth_diff_rad: f64,
    sun_zenith_rad: f64,
) -> f64 {
    match kind {
        CieSkyType::TraditionalOvercast => (1.0 + 2.0 * zenith_rad.cos()) / 3.0,
        CieSkyType::General(_) => {
            let Some([a, b, c, d, e]) = kind.parameters() else {
                return f64::NAN;
            };
            let cos_chi = sun_zenith_rad.cos() * zenith_rad.cos()
                + sun_zenith_rad.sin() * zenith_rad.sin() * azimuth_diff_rad.cos();
            let chi = cos_chi.clamp(-1.0, 1.0).acos();
            indicatrix(c, d, e, chi) * gradation(a, b, zenith_rad.cos())
                / (indicatrix(c, d, e, sun_zenith_rad) * gradation(a, b, 1.0))
        }
    }
}

/// A CIE sky distribution: white radiance `scale` × (relative luminance) with the
/// L_z-independent factors folded into `scale`.
struct CieDistribution {
    kind: CieSkyType,
    sun_dir: DVec3,
    /// W·sr⁻¹·m⁻² per unit of f(χ)·φ(Z) (general) or of (1 + 2 cos Z) (overcast).
    scale: f64,
}

impl CieDistribution {
    /// Unnormalised luminance shape at `dir`: f(χ)·φ(Z) or 1 + 2 cos Z.
    fn shape(&self, dir: DVec3) -> f64 {
        match self.kind.parameters() {
            None => 1.0 + 2.0 * dir.z,
            Some([a, b, c, d, e]) => {
                let chi = dir.dot(self.sun_dir).clamp(-1.0, 1.0).acos();
                (indicatrix(c, d, e, chi) * gradation(a, b, dir.z)).max(0.0)
            }
        }
    }
}

impl SkyDistribution for CieDistribution {
    fn radiance(&self, dir: DVec3) -> Rgb {
        Rgb::splat(self.scale * self.shape(dir))
    }
}

/// CIE sky `kind` whose horizontal irradiance equals `dhi_w_m2` (W/m², i.e. illuminance
/// 179·DHI lux), plus a white sun of normal irradiance `dni_w_m2` (W/m²) towards `sun_dir`
/// (scene frame, need not be normalised) when the sun is above the horizon.
/// `ground_reflectance` ∈ [0, 1] sets the ground glow ρ(DHI + DNI·sin α_s)/π.
///
/// The sky shape uses the actual sun position even when the sun is below the horizon (the
/// formula stays defined); DHI = 0 gives a dark sky, DNI = 0 no sun. Errors: type outside
/// 1..=15, negative or non-finite irradiance, bad direction or reflectance.
pub fn sky(
    kind: CieSkyType,
    dhi_w_m2: f64,
    dni_w_m2: f64,
    sun_dir: DVec3,
    ground_reflectance: f64,
) -> Result<Sky> {
    let kind = kind.check()?;
    let dhi = check_irradiance("dhi", dhi_w_m2)?;
    let dni = check_irradiance("dni", dni_w_m2)?;
    let sun_dir = check_sun_direction(sun_dir)?;
    let rho = check_ground_reflectance(ground_reflectance)?;
    let mut warnings = Vec::new();

    let distribution: Option<Box<dyn SkyDistribution>> = if dhi > 0.0 {
        let mut dist = CieDistribution {
            kind,
            sun_dir,
            scale: 1.0,
        };
        // Normalise numerically so that ∫ L cos θ dω = DHI exactly for this quadrature;
        // the shape is strictly positive (φ ≥ 1 + a ≥ 0 only at the horizon), so the
        // integral is > 0.
        let e_unit = horizontal_irradiance(&dist).x;
        if !(e_unit.is_finite() && e_unit > 0.0) {
            return Err(Error::Numerical(format!(
                "CIE sky {kind:?}: horizontal integral {e_unit}"
            )));
        }
        dist.scale = dhi / e_unit;
        Some(Box::new(dist))
    } else {
        None
    };

    let sin_alt = sun_dir.z;
    let sun = if sin_alt > 0.0 && dni > 0.0 {
        Some(Sun {
            direction: sun_dir,
            normal_irradiance: Rgb::splat(dni),
        })
    } else {
        if dni > 0.0 {
            warnings.push(format!(
                "sun below the horizon (altitude {:.2}°): direct irradiance {dni} W/m² ignored",
                sin_alt.clamp(-1.0, 1.0).asin().to_degrees()
            ));
        }
        None
    };
    let e_sun = sun.map_or(0.0, |s| s.normal_irradiance.x * sin_alt);
    let e_sky = if distribution.is_some() { dhi } else { 0.0 };
    Ok(Sky {
        distribution,
        sun,
        ground_radiance: ground_radiance(rho, Rgb::splat(e_sky + e_sun)),
        description: format!("cie {} dhi={dhi} dni={dni}", kind.label()),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::lux;
    use crate::site::direction_from_alt_az;
    use std::f64::consts::PI;

    /// E_h/L_z (sr) by an independent midpoint rule in (Z, azimuth) as docs/derivations.md
    /// describes, using only `relative_luminance`.
    fn eh_over_lz(kind: CieSkyType, sun_zenith: f64) -> f64 {
        let (nz, na) = (300, 600);
        let (dz, da) = (FRAC_PI_2 / nz as f64, 2.0 * PI / na as f64);
        let mut sum = 0.0;
        for i in 0..nz {
            let z = (i as f64 + 0.5) * dz;
            let w = z.cos() * z.sin() * dz * da;
            for j in 0..na {
                let az = (j as f64 + 0.5) * da;
                sum += relative_luminance(kind, z, az, sun_zenith) * w;
            }
        }
        sum
    }

    /// docs/derivations.md, "CIE standard general skies": E_h/L_z for sun altitudes 15°, 30°, 45°, 60°.
    #[allow(clippy::approx_constant)] // 3.1416 = π·L_z is a tabulated value
    const TABLE: [[f64; 4]; 15] = [
        [2.4496, 2.4496, 2.4496, 2.4496],
        [2.6615, 2.5566, 2.3635, 2.0860],
        [2.7700, 2.7700, 2.7700, 2.7700],
        [3.0298, 2.8902, 2.6467, 2.3154],
        [3.1416, 3.1416, 3.1416, 3.1416],
        [3.4558, 3.2778, 2.9775, 2.5842],
        [3.9021, 3.6731, 3.1431, 2.4212],
        [4.4211, 4.1231, 3.3388, 2.3284],
        [4.8653, 4.5528, 4.0587, 3.4593],
        [5.5937, 5.1449, 4.2534, 3.1703],
        [6.4517, 5.8177, 4.4854, 2.9891],
        [7.2049, 6.3941, 4.8485, 3.1906],
        [8.0730, 6.9952, 4.9827, 3.0259],
        [9.1177, 7.7082, 5.3753, 3.2170],
        [10.3381, 8.1161, 5.2712, 3.0159],
    ];

    #[test]
    fn general_skies_match_tabulated_eh_over_lz() {
        for (t, row) in TABLE.iter().enumerate() {
            for (k, &expected) in row.iter().enumerate() {
                let alt = 15.0 * (k + 1) as f64;
                let got = eh_over_lz(CieSkyType::General(t as u8 + 1), (90.0 - alt).to_radians());
                assert!(
                    ((got - expected) / expected).abs() < 2e-3,
                    "type {} alt {alt}: {got} vs {expected}",
                    t + 1
                );
            }
        }
    }

    #[test]
    fn traditional_overcast_is_seven_pi_over_nine() {
        let got = eh_over_lz(CieSkyType::TraditionalOvercast, 0.3);
        assert!((got - 7.0 * PI / 9.0).abs() < 1e-5, "{got}");
    }

    #[test]
    fn relative_luminance_is_one_at_zenith() {
        for n in 1..=15 {
            let r = relative_luminance(CieSkyType::General(n), 0.0, 1.0, 0.7);
            assert!((r - 1.0).abs() < 1e-12);
        }
        assert!(relative_luminance(CieSkyType::General(16), 0.0, 0.0, 0.0).is_nan());
    }

    /// Independent horizontal integral of a sky's radiance (midpoint in Z × azimuth).
    fn integrate_sky(sky: &Sky) -> f64 {
        let (nz, na) = (200, 400);
        let (dz, da) = (90.0 / nz as f64, 360.0 / na as f64);
        let mut sum = 0.0;
        for i in 0..nz {
            let z = (i as f64 + 0.5) * dz;
            let w = z.to_radians().cos() * z.to_radians().sin() * dz.to_radians() * da.to_radians();
            for j in 0..na {
                let d = direction_from_alt_az(90.0 - z, (j as f64 + 0.5) * da);
                sum += lux(sky.radiance(d)) * w;
            }
        }
        sum
    }

    #[test]
    fn sky_is_normalised_to_dhi_and_sun_and_ground_are_set() {
        let sun = direction_from_alt_az(40.0, 135.0);
        for kind in [
            CieSkyType::General(1),
            CieSkyType::General(7),
            CieSkyType::General(12),
            CieSkyType::General(15),
            CieSkyType::TraditionalOvercast,
        ] {
            let s = sky(kind, 120.0, 600.0, sun, 0.2).unwrap();
            let e = integrate_sky(&s);
            assert!((e / (179.0 * 120.0) - 1.0).abs() < 1e-3, "{kind:?}: {e}");
            let sun_src = s.sun.unwrap();
            assert_eq!(sun_src.normal_irradiance, Rgb::splat(600.0));
            let eh = 120.0 + 600.0 * 40f64.to_radians().sin();
            assert!((s.ground_radiance.x - 0.2 * eh / PI).abs() < 1e-9);
            assert!(s.warnings.is_empty());
        }
    }

    #[test]
    fn absolute_zenith_luminance_of_overcast_sky() {
        // Traditional overcast: E_h = 7π/9 L_z, so L_z = 179·DHI·9/(7π).
        let s = sky(CieSkyType::TraditionalOvercast, 100.0, 0.0, DVec3::Z, 0.0).unwrap();
        let lz = lux(s.radiance(DVec3::Z));
        let expected = 179.0 * 100.0 * 9.0 / (7.0 * PI);
        assert!((lz / expected - 1.0).abs() < 1e-3, "{lz} vs {expected}");
        assert!(s.sun.is_none());
    }

    #[test]
    fn sun_below_horizon_keeps_sky_but_drops_sun() {
        let sun = direction_from_alt_az(-5.0, 200.0);
        let s = sky(CieSkyType::General(12), 50.0, 300.0, sun, 0.2).unwrap();
        assert!(s.sun.is_none());
        assert!(s.distribution.is_some());
        assert!(!s.warnings.is_empty());
        assert!((s.ground_radiance.x - 0.2 * 50.0 / PI).abs() < 1e-9);
        assert!(s.radiance(DVec3::new(0.0, 0.6, 0.8)).x.is_finite());
    }

    #[test]
    fn zero_dhi_is_dark_and_bad_input_errors() {
        let sun = direction_from_alt_az(30.0, 180.0);
        let s = sky(CieSkyType::General(12), 0.0, 500.0, sun, 0.2).unwrap();
        assert!(s.distribution.is_none());
        assert!(s.sun.is_some());
        assert!(sky(CieSkyType::General(0), 100.0, 0.0, sun, 0.2).is_err());
        assert!(sky(CieSkyType::General(16), 100.0, 0.0, sun, 0.2).is_err());
        assert!(sky(CieSkyType::General(5), -1.0, 0.0, sun, 0.2).is_err());
        assert!(sky(CieSkyType::General(5), 1.0, f64::NAN, sun, 0.2).is_err());
        assert!(sky(CieSkyType::General(5), 1.0, 0.0, sun, 1.5).is_err());
        assert!(sky(CieSkyType::General(5), 1.0, 0.0, DVec3::ZERO, 0.2).is_err());
    }

    #[test]
    fn description_names_type() {
        let s = sky(CieSkyType::General(12), 100.0, 700.0, DVec3::Z, 0.2).unwrap();
        assert_eq!(s.description, "cie type=12 dhi=100 dni=700");
    }
}
