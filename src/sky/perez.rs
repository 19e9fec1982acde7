//! Perez all-weather sky (Perez, Seals & Michalsky 1993, Solar Energy 50(3) and its erratum
//! 51(5)) driven by weather-file irradiances, as in Radiance's gendaymtx / gendaylit -W:
//! sky clearness ε and brightness Δ select one of 8 bins, whose coefficients give the
//! distribution parameters a..e; the Perez et al. (1990, Solar Energy 44(5)) luminous
//! efficacies turn DHI and DNI into diffuse and beam illuminance.
//!
//! Relative luminance lv(ζ, γ) = (1 + a·e^{b/cos ζ})(1 + c·e^{dγ} + e·cos²γ) (1993 form);
//! the distribution is normalised so that ∫ L cos ζ dω = E_vd (lux) and converted to
//! radiance at 179 lm/W as white RGB (gendaymtx's default sky colour tint is not applied).
//! The sun is white with normal irradiance E_vb/179.
//!
//! Differences from gendaymtx, on purpose: the sky is continuous (no Reinhart patches, so
//! no 87° altitude cap); ε is capped at 11.9 (gendaymtx would index past its table for
//! ε ≥ 12); Δ is floored at 0.01 before ln Δ (gendaymtx would take ln 0 for DHI → 0).

use super::{
    check_ground_reflectance, check_irradiance, check_sun_direction, ground_radiance, Sky,
    SkyDistribution, Sun, MIN_COS_ZENITH,
};
use crate::photometry::{Rgb, EFFICACY_LM_PER_W};
use crate::{Error, Result};
use glam::DVec3;

/// Surface dew point assumed by gendaymtx when the weather tape gives none, °C
/// (`double dew_point = 11.0;` in Radiance's src/gen/gendaymtx.c).
pub const DEFAULT_DEW_POINT_C: f64 = 11.0;

/// Solar constant used for Δ, W/m² (gendaymtx's DC_SolarConstantE).
const SOLAR_CONSTANT_W_M2: f64 = 1367.0;

/// Upper limit of ε (keeps it inside bin 8, whose upper bound is 12 in gendaymtx).
pub const EPSILON_MAX: f64 = 11.9;

/// Lower limit of Δ (avoids ln 0 in the diffuse efficacy).
pub const DELTA_MIN: f64 = 0.01;

/// Lower bounds of the ε bins 1..=8 (bin k covers [EPS_BINS[k-1], EPS_BINS[k])).
const EPS_BINS: [f64; 8] = [1.0, 1.065, 1.230, 1.500, 1.950, 2.800, 4.500, 6.200];

/// Perez 1993 table 1: per bin, a1..a4, b1..b4, c1..c4, d1..d4, e1..e4.
const COEFF: [[f64; 20]; 8] = [
    [
        1.3525, -0.2576, -0.2690, -1.4366, -0.7670, 0.0007, 1.2734, -0.1233, 2.8000, 0.6004,
        1.2375, 1.0000, 1.8734, 0.6297, 0.9738, 0.2809, 0.0356, -0.1246, -0.5718, 0.9938,
    ],
    [
        -1.2219, -0.7730, 1.4148, 1.1016, -0.2054, 0.0367, -3.9128, 0.9156, 6.9750, 0.1774, 6.4477,
        -0.1239, -1.5798, -0.5081, -1.7812, 0.1080, 0.2624, 0.0672, -0.2190, -0.4285,
    ],
    [
        -1.1000, -0.2515, 0.8952, 0.0156, 0.2782, -0.1812, -4.5000, 1.1766, 24.7219, -13.0812,
        -37.7000, 34.8438, -5.0000, 1.5218, 3.9229, -2.6204, -0.0156, 0.1597, 0.4199, -0.5562,
    ],
    [
        -0.5484, -0.6654, -0.2672, 0.7117, 0.7234, -0.6219, -5.6812, 2.6297, 33.3389, -18.3000,
        -62.2500, 52.0781, -3.5000, 0.0016, 1.1477, 0.1062, 0.4659, -0.3296, -0.0876, -0.0329,
    ],
    [
        -0.6000, -0.3566, -2.5000, 2.3250, 0.2937, 0.0496, -5.6812, 1.8415, 21.0000, -4.7656,
        -21.5906, 7.2492, -3.5000, -0.1554, 1.4062, 0.3988, 0.0032, 0.0766, -0.0656, -0.1294,
    ],
    [
        -1.0156, -0.3670, 1.0078, 1.4051, 0.2875, -0.5328, -3.8500, 3.3750, 14.0000, -0.9999,
        -7.1406, 7.5469, -3.4000, -0.1078, -1.0750, 1.5702, -0.0672, 0.4016, 0.3017, -0.4844,
    ],
    [
        -1.0000, 0.0211, 0.5025, -0.5119, -0.3000, 0.1922, 0.7023, -1.6317, 19.0000, -5.0000,
        1.2438, -1.9094, -4.0000, 0.0250, 0.3844, 0.2656, 1.0468, -0.3788, -2.4517, 1.4656,
    ],
    [
        -1.0500, 0.0289, 0.4260, 0.3590, -0.3250, 0.1156, 0.7781, 0.0025, 31.0625, -14.5000,
        -46.1148, 55.3750, -7.2312, 0.4050, 13.3500, 0.6234, 1.5000, -0.6426, 1.8564, 0.5636,
    ],
];

/// Perez 1990 table 4: diffuse luminous efficacy a, b, c, d per bin (eq. 7).
const DIFFUSE_EFFICACY: [[f64; 4]; 8] = [
    [97.24, -0.46, 12.00, -8.91],
    [107.22, 1.15, 0.59, -3.95],
    [104.97, 2.96, -5.53, -8.77],
    [102.39, 5.59, -13.95, -13.90],
    [100.71, 5.94, -22.75, -23.74],
    [106.42, 3.83, -36.15, -28.83],
    [141.88, 1.90, -53.24, -14.03],
    [152.23, 0.35, -45.27, -7.98],
];

/// Perez 1990 table 4: beam luminous efficacy a, b, c, d per bin (eq. 8).
const BEAM_EFFICACY: [[f64; 4]; 8] = [
    [57.20, -4.55, -2.98, 117.12],
    [98.99, -3.46, -1.21, 12.38],
    [109.83, -4.90, -1.71, -8.81],
    [110.34, -5.84, -1.99, -4.56],
    [106.36, -3.97, -1.75, -6.16],
    [107.19, -1.25, -1.51, -26.73],
    [105.75, 0.77, -1.26, -34.44],
    [101.18, 1.58, -1.10, -8.29],
];

/// Everything the Perez model derives from one weather record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerezParameters {
    /// Sky clearness ε (dimensionless, 1..=[`EPSILON_MAX`]; [`EPSILON_MAX`] when DHI = 0).
    pub epsilon: f64,
    /// Sky brightness Δ = DHI·m/(1367·E0) (dimensionless, ≥ [`DELTA_MIN`]).
    pub delta: f64,
    /// ε bin, 1-based (1 overcast … 8 clear).
    pub bin: usize,
    /// Relative optical air mass (Kasten 1966).
    pub air_mass: f64,
    /// Earth-orbit eccentricity correction factor (dimensionless).
    pub e0: f64,
    /// Diffuse luminous efficacy, lm/W.
    pub kd: f64,
    /// Beam luminous efficacy, lm/W (≥ 0).
    pub kb: f64,
    /// Distribution parameter a (horizon brightening).
    pub a: f64,
    /// Distribution parameter b (gradation width).
    pub b: f64,
    /// Distribution parameter c (circumsolar intensity).
    pub c: f64,
    /// Distribution parameter d (circumsolar width).
    pub d: f64,
    /// Distribution parameter e (backscatter).
    pub e: f64,
}

/// Perez parameters for direct normal irradiance `dni` and diffuse horizontal irradiance
/// `dhi` (W/m², ≥ 0), sun zenith angle `zenith_rad` (radians, < π/2), day of year
/// (1..=366) and surface dew point (°C). Inputs are assumed valid ([`sky`] checks them).
pub fn parameters(
    dni: f64,
    dhi: f64,
    zenith_rad: f64,
    day_of_year: u32,
    dew_point_c: f64,
) -> PerezParameters {
    let z = zenith_rad;
    let z3 = 1.041 * z.powi(3);
    // ε = ((DHI + DNI)/DHI + 1.041 Z³)/(1 + 1.041 Z³); undefined for DHI = 0, where its
    // limit is +∞: take the clearest bin.
    let epsilon = if dhi > 0.0 {
        (((dhi + dni) / dhi + z3) / (1.0 + z3)).min(EPSILON_MAX)
    } else {
        EPSILON_MAX
    };
    let bin = EPS_BINS.iter().rposition(|&lo| epsilon >= lo).unwrap_or(0) + 1;

    let gamma = std::f64::consts::TAU * (f64::from(day_of_year) - 1.0) / 365.0;
    let e0 = 1.00011
        + 0.034221 * gamma.cos()
        + 0.00128 * gamma.sin()
        + 0.000719 * (2.0 * gamma).cos()
        + 0.000077 * (2.0 * gamma).sin();
    let air_mass = 1.0 / (z.cos() + 0.15 * (93.885 - z.to_degrees()).powf(-1.253));
    let delta = (dhi * air_mass / (SOLAR_CONSTANT_W_M2 * e0)).max(DELTA_MIN);

    // Precipitable water (cm) from the dew point, Perez 1990 eq. 3.
    let w = (0.07 * dew_point_c - 0.075).exp();
    let [da, db, dc, dd] = DIFFUSE_EFFICACY[bin - 1];
    let kd = da + db * w + dc * z.cos() + dd * delta.ln();
    let [ba, bb, bc, bd] = BEAM_EFFICACY[bin - 1];
    let kb = (ba + bb * w + bc * (5.73 * z - 5.0).exp() + bd * delta).max(0.0);

    // Bins 2–5 are fitted only for Δ ≥ 0.2 (gendaymtx/gendaylit apply the same floor to
    // the distribution parameters but not to the efficacies).
    let dp = if (2..=5).contains(&bin) {
        delta.max(0.2)
    } else {
        delta
    };
    let k = &COEFF[bin - 1];
    let lin = |i: usize| k[4 * i] + k[4 * i + 1] * z + dp * (k[4 * i + 2] + k[4 * i + 3] * z);
    let (a, b, e) = (lin(0), lin(1), lin(4));
    let (c, d) = if bin == 1 {
        (
            (dp * (k[8] + k[9] * z)).powf(k[10]).exp() - k[11],
            -(dp * (k[12] + k[13] * z)).exp() + k[14] + dp * k[15],
        )
    } else {
        (lin(2), lin(3))
    };
    PerezParameters {
        epsilon,
        delta,
        bin,
        air_mass,
        e0,
        kd,
        kb,
        a,
        b,
        c,
        d,
        e,
    }
}

/// Cosine-of-zenith floor of the gradation term when b > 0: sin 6°, the altitude of the
/// lowest Tregenza/Reinhart patch centres at which gendaymtx and gendaylit sample the model.
/// With b > 0 (bright, low-sun skies with large Δ) exp(b / cos ζ) grows without bound
/// towards the horizon (e^{b/0.01} at perezlum.cal's 0.01 floor), which no quadrature or
/// sky subdivision resolves; holding the term constant below 6° reproduces what the
/// patch-based tools compute and keeps the sky integrable.
pub const POSITIVE_B_MIN_COS_ZENITH: f64 = 0.104_528_463_267_653_5;

impl PerezParameters {
    /// Relative luminance lv (dimensionless) at view zenith cosine `cos_zeta` and angle
    /// `gamma` (radians) from the sun, floored at 0 as in gendaymtx. cos ζ is floored at
    /// 0.01 (as Radiance's perezlum.cal), or at [`POSITIVE_B_MIN_COS_ZENITH`] when b > 0.
    pub fn relative_luminance(&self, cos_zeta: f64, gamma: f64) -> f64 {
        self.luminance(cos_zeta, gamma, gamma.cos())
    }

    /// [`Self::relative_luminance`] given cos γ as well, where the caller has it (the
    /// cosine of the arc cosine cost a twentieth of a warm annual run).
    fn luminance(&self, cos_zeta: f64, gamma: f64, cos_g: f64) -> f64 {
        let floor = if self.b > 0.0 {
            POSITIVE_B_MIN_COS_ZENITH
        } else {
            MIN_COS_ZENITH
        };
        let v = (1.0 + self.a * (self.b / cos_zeta.max(floor)).exp())
            * (1.0 + self.c * (self.d * gamma).exp() + self.e * cos_g * cos_g);
        v.max(0.0)
    }
}

impl PerezParameters {
    /// ∫ lv cos ζ dω over the upper hemisphere for the sun at unit `sun_dir` (sr), on the
    /// grid of [`crate::sky::HORIZONTAL_QUADRATURE`] with its azimuths counted from the
    /// sun's: the integrand is then mirror-symmetric in azimuth, so each ring evaluates
    /// half its cells, and the gradation factor is evaluated once per ring. The same rule
    /// as [`crate::sky::integrate_horizontal`] (rings uniform in zenith angle with exact
    /// projected-solid-angle weights), about 4× cheaper: this runs once per timestep.
    pub fn horizontal_integral(&self, sun_dir: DVec3) -> f64 {
        let (n_theta, n_phi) = crate::sky::HORIZONTAL_QUADRATURE;
        let half = n_phi / 2;
        let dphi = std::f64::consts::TAU / n_phi as f64;
        let cos_dphi: Vec<f64> = (0..half).map(|j| ((j as f64 + 0.5) * dphi).cos()).collect();
        let (czs, szs) = (sun_dir.z, (1.0 - sun_dir.z * sun_dir.z).max(0.0).sqrt());
        let floor = if self.b > 0.0 {
            POSITIVE_B_MIN_COS_ZENITH
        } else {
            MIN_COS_ZENITH
        };
        let dtheta = std::f64::consts::FRAC_PI_2 / n_theta as f64;
        let mut total = 0.0;
        for i in 0..n_theta {
            let (lo, hi) = (i as f64 * dtheta, (i + 1) as f64 * dtheta);
            let weight = 0.5 * (lo.cos().powi(2) - hi.cos().powi(2)) * dphi;
            let (sz, cz) = ((i as f64 + 0.5) * dtheta).sin_cos();
            let grad = 1.0 + self.a * (self.b / cz.max(floor)).exp();
            let (p, q) = (cz * czs, sz * szs);
            let mut ring = 0.0;
            for &cd in &cos_dphi {
                let cg = (p + q * cd).clamp(-1.0, 1.0);
                let v = grad * (1.0 + self.c * (self.d * cg.acos()).exp() + self.e * cg * cg);
                ring += v.max(0.0);
            }
            total += 2.0 * ring * weight;
        }
        total
    }
}

/// Skies whose horizontal integral a process keeps, at most: about 64 bytes each.
const REMEMBERED: usize = 1 << 16;

/// The process's remembered horizontal integrals, by the bits of the parameters and the
/// sun direction.
fn integral_memo() -> &'static std::sync::Mutex<std::collections::HashMap<[u64; 8], f64>> {
    static MEMO: std::sync::OnceLock<std::sync::Mutex<std::collections::HashMap<[u64; 8], f64>>> =
        std::sync::OnceLock::new();
    MEMO.get_or_init(Default::default)
}

/// [`PerezParameters::horizontal_integral`], remembered for the process: a LEED run builds
/// each step's sky once per light path, and this integral (128 × 128 evaluations of the
/// distribution) was a fifth of a warm path run. The value is the same bits either way;
/// the memo forgets everything when it holds [`REMEMBERED`] skies.
fn remembered_horizontal_integral(p: &PerezParameters, sun_dir: DVec3) -> f64 {
    let key = [p.a, p.b, p.c, p.d, p.e, sun_dir.x, sun_dir.y, sun_dir.z].map(f64::to_bits);
    let memo = integral_memo();
    if let Some(&v) = memo.lock().expect("memo").get(&key) {
        return v;
    }
    let v = p.horizontal_integral(sun_dir);
    let mut m = memo.lock().expect("memo");
    if m.len() >= REMEMBERED {
        m.clear();
    }
    m.insert(key, v);
    v
}

/// One remembered horizontal integral: the bits of the parameters a…e and the sun
/// direction's x, y, z, then the integral's bits.
pub type RememberedIntegral = [u64; 9];

/// Every horizontal integral this process remembers, sorted: what a cache record keeps so
/// that a warm run need not integrate its skies again ([`remember_integrals`]).
pub fn remembered_integrals() -> Vec<RememberedIntegral> {
    let memo = integral_memo().lock().expect("memo");
    let mut v: Vec<RememberedIntegral> = memo
        .iter()
        .map(|(k, v)| {
            let mut e = [0u64; 9];
            e[..8].copy_from_slice(k);
            e[8] = v.to_bits();
            e
        })
        .collect();
    v.sort_unstable();
    v
}

/// Remembers integrals [`remembered_integrals`] listed (from a checksummed record of the
/// same crate version: each is the value [`PerezParameters::horizontal_integral`] gives
/// its key). Entries whose value is not finite and positive are ignored.
pub fn remember_integrals(entries: &[RememberedIntegral]) {
    let mut m = integral_memo().lock().expect("memo");
    for e in entries {
        let v = f64::from_bits(e[8]);
        if !(v.is_finite() && v > 0.0) {
            continue;
        }
        if m.len() >= REMEMBERED {
            m.clear();
        }
        let mut k = [0u64; 8];
        k.copy_from_slice(&e[..8]);
        m.insert(k, v);
    }
}

/// The normalised Perez distribution.
struct PerezDistribution {
    params: PerezParameters,
    sun_dir: DVec3,
    /// Radiance (W·sr⁻¹·m⁻²) per unit of relative luminance.
    scale: f64,
}

impl SkyDistribution for PerezDistribution {
    fn radiance(&self, dir: DVec3) -> Rgb {
        let cos_g = dir.dot(self.sun_dir).clamp(-1.0, 1.0);
        Rgb::splat(self.scale * self.params.luminance(dir.z, cos_g.acos(), cos_g))
    }
}

/// Perez all-weather sky for direct normal irradiance `dni_w_m2` and diffuse horizontal
/// irradiance `dhi_w_m2` (W/m²), sun direction `sun_dir` (scene frame), day of year
/// (1..=366), surface dew point (°C; [`DEFAULT_DEW_POINT_C`] when the weather file has
/// none) and ground reflectance ∈ [0, 1].
///
/// Sun at or below the horizon → dark sky, no sun, a warning (gendaymtx skips such hours).
/// DHI = 0 → no sky distribution; DNI = 0 → no sun. Errors: negative or non-finite
/// irradiance, day out of range, non-finite dew point, bad direction or reflectance.
pub fn sky(
    dni_w_m2: f64,
    dhi_w_m2: f64,
    sun_dir: DVec3,
    day_of_year: u32,
    dew_point_c: f64,
    ground_reflectance: f64,
) -> Result<Sky> {
    let dni = check_irradiance("dni", dni_w_m2)?;
    let dhi = check_irradiance("dhi", dhi_w_m2)?;
    let sun_dir = check_sun_direction(sun_dir)?;
    let rho = check_ground_reflectance(ground_reflectance)?;
    if !(1..=366).contains(&day_of_year) {
        return Err(Error::arg(
            "day_of_year",
            day_of_year,
            "day of year must be between 1 and 366",
        ));
    }
    if !dew_point_c.is_finite() {
        return Err(Error::arg(
            "dew_point",
            dew_point_c,
            "dew point must be a finite temperature (°C)",
        ));
    }
    let description = format!("perez dni={dni} dhi={dhi}");

    if sun_dir.z <= 0.0 {
        let mut s = Sky::none();
        s.description = description;
        s.warnings.push(format!(
            "sun at or below the horizon (altitude {:.2}°): Perez sky is dark \
             (dni={dni}, dhi={dhi} ignored)",
            sun_dir.z.clamp(-1.0, 1.0).asin().to_degrees()
        ));
        return Ok(s);
    }

    let zenith = sun_dir.z.clamp(-1.0, 1.0).acos();
    let params = parameters(dni, dhi, zenith, day_of_year, dew_point_c);
    let mut warnings = Vec::new();

    let e_vd = params.kd * dhi; // lux
    if params.b > 0.0 && dhi > 0.0 {
        warnings.push(format!(
            "Perez gradation parameter b = {:.3} > 0 (horizon brightness diverges); \
             gradation held constant below 6° altitude",
            params.b
        ));
    }
    let distribution: Option<Box<dyn SkyDistribution>> = if dhi > 0.0 && e_vd > 0.0 {
        let mut dist = PerezDistribution {
            params,
            sun_dir,
            scale: 1.0,
        };
        let e_unit = remembered_horizontal_integral(&dist.params, sun_dir);
        if e_unit.is_finite() && e_unit > 0.0 {
            dist.scale = e_vd / EFFICACY_LM_PER_W / e_unit;
        } else {
            // Like gendaymtx, fall back to a uniform sky of the right illuminance when the
            // distribution integrates to ~0 (all lv clamped to 0).
            warnings.push(format!(
                "Perez distribution integrates to {e_unit}; using a uniform sky instead"
            ));
            dist.params = PerezParameters {
                a: 0.0,
                b: 0.0,
                c: 0.0,
                d: 0.0,
                e: 0.0,
                ..params
            };
            dist.scale = e_vd / EFFICACY_LM_PER_W / std::f64::consts::PI;
        }
        if !dist.scale.is_finite() {
            return Err(Error::Numerical(format!(
                "Perez sky scale {} for {description}",
                dist.scale
            )));
        }
        Some(Box::new(dist))
    } else {
        None
    };
    let e_sky = if distribution.is_some() {
        e_vd / EFFICACY_LM_PER_W
    } else {
        0.0
    };

    let e_vb = params.kb * dni; // lux, normal to the beam
    let sun = (e_vb > 0.0).then(|| Sun {
        direction: sun_dir,
        normal_irradiance: Rgb::splat(e_vb / EFFICACY_LM_PER_W),
    });
    let e_sun = sun.map_or(0.0, |s| s.normal_irradiance.x * sun_dir.z);

    Ok(Sky {
        distribution,
        sun,
        ground_radiance: ground_radiance(rho, Rgb::splat(e_sky + e_sun)),
        description,
        warnings,
    })
}

#[cfg(test)]
#[path = "perez_tests.rs"]
mod tests;
