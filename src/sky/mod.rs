//! L2 sky models: radiance arriving from any direction for one instant, plus the sun as a
//! parallel source. Units are Radiance's: RGB radiance in W·sr⁻¹·m⁻², illuminance =
//! 179 lm/W × (0.265 R + 0.670 G + 0.065 B). Below the horizon every sky shows a uniform
//! ground glow of luminance ρ_g·E_h/π, E_h the global horizontal irradiance (sky + sun).

pub mod cie;
pub mod image;
pub mod perez;
pub mod preetham;

use crate::photometry::Rgb;
use glam::DVec3;

/// Radiance distribution of the sky above the horizon.
pub trait SkyDistribution: Send + Sync {
    /// RGB radiance (W·sr⁻¹·m⁻²) arriving from unit direction `dir` with `dir.z > 0`
    /// (scene frame: x east, y north, z up; `dir` points towards the sky).
    fn radiance(&self, dir: DVec3) -> Rgb;

    /// Mean radiance over the spherical triangle `v` (unit vertices, above the horizon),
    /// when the distribution can integrate it exactly (image skies); `None`: the sky tree
    /// samples [`Self::radiance`] instead.
    fn mean_over(&self, _v: &[DVec3; 3]) -> Option<Rgb> {
        None
    }

    /// Whether [`Self::mean_over`] can answer: the sky tree then asks it, and otherwise
    /// does not build the triangles to ask about.
    fn integrates(&self) -> bool {
        false
    }
}

/// The sun as a parallel source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector towards the sun's centre, scene frame.
    pub direction: DVec3,
    /// Irradiance on a plane normal to the sun's direction (RGB, W/m²).
    pub normal_irradiance: Rgb,
}

/// The whole sky for one instant.
pub struct Sky {
    /// Radiance above the horizon; `None` for a dark sky.
    pub distribution: Option<Box<dyn SkyDistribution>>,
    /// The sun, when above the horizon and with non-zero irradiance.
    pub sun: Option<Sun>,
    /// Uniform radiance below the horizon (RGB, W·sr⁻¹·m⁻²).
    pub ground_radiance: Rgb,
    /// Short description, e.g. `perez dni=700 dhi=100`.
    pub description: String,
    /// Non-fatal remarks (clamped turbidity, sun below horizon, …).
    pub warnings: Vec<String>,
}

impl Sky {
    /// A sky that emits nothing.
    pub fn none() -> Sky {
        Sky {
            distribution: None,
            sun: None,
            ground_radiance: Rgb::ZERO,
            description: "none".into(),
            warnings: Vec::new(),
        }
    }

    /// RGB radiance from unit direction `dir`: the sky above the horizon, ground glow below.
    pub fn radiance(&self, dir: DVec3) -> Rgb {
        if dir.z > 0.0 {
            self.distribution
                .as_ref()
                .map_or(Rgb::ZERO, |d| d.radiance(dir))
        } else {
            self.ground_radiance
        }
    }
}

/// Default resolution of [`horizontal_irradiance`]: zenith-angle rings × azimuth steps.
/// 128 × 256 cells (0.7° × 1.4°) integrate every sky model here to well below 10⁻³
/// relative while costing a few milliseconds per sky.
pub const HORIZONTAL_QUADRATURE: (usize, usize) = (128, 256);

/// ∫ f(ω) cos θ dω over the upper hemisphere (the horizontal irradiance of a radiance
/// function `f`, in f's unit × sr): `n_theta` rings uniform in zenith angle θ, each sampled
/// at its mid-angle and weighted by its exact projected solid angle
/// (cos²θ_lo − cos²θ_hi)/2 · Δφ, × `n_phi` azimuth midpoints. Uniform in θ (not in cos²θ)
/// because sky radiance is smooth in θ but has a √ singularity in cos²θ at the horizon;
/// exact ring weights make a uniform radiance L integrate to exactly πL.
pub fn integrate_horizontal(mut f: impl FnMut(DVec3) -> Rgb, n_theta: usize, n_phi: usize) -> Rgb {
    let n_theta = n_theta.max(1);
    let n_phi = n_phi.max(1);
    // Azimuth sines/cosines are shared by all rings.
    let dphi = std::f64::consts::TAU / n_phi as f64;
    let trig: Vec<(f64, f64)> = (0..n_phi)
        .map(|j| ((j as f64 + 0.5) * dphi).sin_cos())
        .collect();
    let dtheta = std::f64::consts::FRAC_PI_2 / n_theta as f64;
    let mut total = Rgb::ZERO;
    for i in 0..n_theta {
        let (lo, hi) = (i as f64 * dtheta, (i + 1) as f64 * dtheta);
        let weight = 0.5 * (lo.cos().powi(2) - hi.cos().powi(2)) * dphi;
        let (r, z) = ((i as f64 + 0.5) * dtheta).sin_cos();
        let mut ring = Rgb::ZERO;
        for &(sin_phi, cos_phi) in &trig {
            ring += f(DVec3::new(r * sin_phi, r * cos_phi, z));
        }
        total += ring * weight;
    }
    total
}

/// Horizontal irradiance (RGB, W/m²) of a sky distribution, with [`HORIZONTAL_QUADRATURE`].
pub fn horizontal_irradiance(distribution: &dyn SkyDistribution) -> Rgb {
    let (n_s, n_phi) = HORIZONTAL_QUADRATURE;
    integrate_horizontal(|d| distribution.radiance(d), n_s, n_phi)
}

/// Ground-glow radiance (RGB, W·sr⁻¹·m⁻²) of a Lambertian ground of reflectance
/// `reflectance` under global horizontal irradiance `global_horizontal` (RGB, W/m²):
/// ρ·E_h/π.
pub fn ground_radiance(reflectance: f64, global_horizontal: Rgb) -> Rgb {
    global_horizontal * (reflectance / std::f64::consts::PI)
}

/// Checks a ground reflectance (finite, within [0, 1]).
pub(crate) fn check_ground_reflectance(rho: f64) -> crate::Result<f64> {
    if rho.is_finite() && (0.0..=1.0).contains(&rho) {
        Ok(rho)
    } else {
        Err(crate::Error::arg(
            "ground_reflectance",
            rho,
            "ground reflectance must be a number between 0 and 1",
        ))
    }
}

/// Checks and normalises a sun direction (finite, non-zero).
pub(crate) fn check_sun_direction(dir: DVec3) -> crate::Result<DVec3> {
    let len = dir.length();
    if dir.is_finite() && len > 1e-12 {
        Ok(dir / len)
    } else {
        Err(crate::Error::arg(
            "sun_dir",
            format!("{dir:?}"),
            "sun direction must be a finite, non-zero vector",
        ))
    }
}

/// Checks an irradiance input (finite, ≥ 0), W/m².
pub(crate) fn check_irradiance(name: &str, value: f64) -> crate::Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(crate::Error::arg(
            name,
            value,
            "irradiance must be a finite, non-negative number (W/m²)",
        ))
    }
}

/// Cosine-of-zenith floor used in the gradation term exp(b / cos θ) of the Perez-type
/// models: with b > 0 (possible for some Perez overcast parameter sets) the term would
/// diverge at the horizon. 0.01 is 0.57° altitude; for the usual b < 0 the term is already
/// below e⁻³⁰ there, so the floor changes nothing else.
pub(crate) const MIN_COS_ZENITH: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadrature_is_exact_for_uniform_and_cosine_skies() {
        let e = integrate_horizontal(|_| Rgb::ONE, 7, 5);
        assert!((e - Rgb::splat(std::f64::consts::PI)).abs().max_element() < 1e-12);
        // L = cos θ: ∫ cos² θ dω = 2π/3.
        let e = integrate_horizontal(|d| Rgb::splat(d.z), 200, 8);
        assert!((e.x / (std::f64::consts::TAU / 3.0) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn ground_radiance_is_rho_e_over_pi() {
        let g = ground_radiance(0.2, Rgb::splat(100.0));
        assert!((g.x - 20.0 / std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn checks_reject_bad_input() {
        assert!(check_ground_reflectance(f64::NAN).is_err());
        assert!(check_ground_reflectance(-0.1).is_err());
        assert!(check_ground_reflectance(0.2).is_ok());
        assert!(check_sun_direction(DVec3::ZERO).is_err());
        assert!(check_sun_direction(DVec3::new(f64::NAN, 0.0, 1.0)).is_err());
        assert!((check_sun_direction(DVec3::new(0.0, 0.0, 2.0)).unwrap().z - 1.0).abs() < 1e-15);
        assert!(check_irradiance("dni", -1.0).is_err());
        assert!(check_irradiance("dni", f64::INFINITY).is_err());
    }
}
