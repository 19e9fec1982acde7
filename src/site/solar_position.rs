//! Solar position for an instant and site: the NREL Solar Position Algorithm (SPA, Reda &
//! Andreas 2004, Solar Energy 76(5):577–589; NREL/TP-560-34302 rev. 2008), uncertainty
//! ±0.0003° for years −2000…6000.
//!
//! The full SPA is used rather than a short almanac formula (Michalsky/PSA, ~0.01°) because
//! it is the reference those shorter algorithms are checked against: our test against the
//! SPA paper's example then checks the implementation, not the algorithm's accuracy budget.
//! The periodic-term tables are the published tables A4.2 (Earth heliocentric longitude L,
//! latitude B, radius R; truncated VSOP87) and A4.3 (nutation) of the paper; they live in
//! the private sibling module `spa_tables`, so this file holds only the algorithm.
//!
//! Output is the apparent (refracted) topocentric zenith and the azimuth clockwise from
//! north. ΔT (TT − UT) is estimated from the Espenak & Meeus polynomials (NASA eclipse
//! pages); ΔUT1 is taken as 0. A ΔT error of a minute moves the sun by under 0.001°, so the
//! estimate is immaterial for daylighting.

use super::spa_tables::{
    B0, B1, L0, L1, L2, L3, L4, L5, NUTATION_ABCD, NUTATION_Y, R0, R1, R2, R3, R4,
};
use super::Site;
use chrono::{DateTime, Datelike, Utc};
use glam::DVec3;

/// The sun's apparent position seen from a site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolarPosition {
    /// Topocentric zenith angle including refraction, degrees.
    pub zenith_deg: f64,
    /// Azimuth, degrees clockwise from north (east = 90°).
    pub azimuth_deg: f64,
}

impl SolarPosition {
    /// Apparent altitude, degrees (90 − zenith).
    pub fn altitude_deg(&self) -> f64 {
        90.0 - self.zenith_deg
    }
    /// Unit vector to the sun, scene frame (x east, y north, z up).
    pub fn direction(&self) -> DVec3 {
        super::direction_from_alt_az(self.altitude_deg(), self.azimuth_deg)
    }
}

/// Temperature assumed by [`solar_position`] for refraction, °C.
pub const DEFAULT_TEMPERATURE_C: f64 = 10.0;

/// Pressure of the ICAO standard atmosphere at `elevation_m` metres above sea level, mbar
/// (hPa): 1013.25 × (1 − 2.25577·10⁻⁵ h)^5.25588.
pub fn standard_pressure_mbar(elevation_m: f64) -> f64 {
    // Clamp the base so absurd elevations cannot produce NaN; refraction just vanishes.
    1013.25 * (1.0 - 2.25577e-5 * elevation_m).max(0.0).powf(5.25588)
}

/// Apparent sun position at `instant` from `site`, with refraction for the standard
/// atmosphere at the site's elevation ([`standard_pressure_mbar`]) and
/// [`DEFAULT_TEMPERATURE_C`].
pub fn solar_position(instant: DateTime<Utc>, site: &Site) -> SolarPosition {
    solar_position_with(
        instant,
        site,
        standard_pressure_mbar(site.elevation_m),
        DEFAULT_TEMPERATURE_C,
    )
}

/// Apparent sun position at `instant` from `site` with refraction computed for the given
/// local pressure (mbar = hPa) and air temperature (°C), as in the SPA.
pub fn solar_position_with(
    instant: DateTime<Utc>,
    site: &Site,
    pressure_mbar: f64,
    temperature_c: f64,
) -> SolarPosition {
    let jd = julian_day(instant);
    let year = instant.year() as f64 + (instant.ordinal0() as f64 + 0.5) / 365.25;
    spa(
        jd,
        delta_t_seconds(year),
        site,
        pressure_mbar,
        temperature_c,
    )
}

/// Julian day (UT) of an instant: the Unix epoch is JD 2440587.5.
fn julian_day(instant: DateTime<Utc>) -> f64 {
    let secs = instant.timestamp() as f64 + f64::from(instant.timestamp_subsec_nanos()) * 1e-9;
    2_440_587.5 + secs / 86_400.0
}

/// ΔT = TT − UT in seconds for a decimal year (Espenak & Meeus 2006 polynomials for
/// 1986–2150, the long-term parabola −20 + 32u², u = (y − 1820)/100, elsewhere).
fn delta_t_seconds(year: f64) -> f64 {
    if (1986.0..2005.0).contains(&year) {
        let t = year - 2000.0;
        63.86 + 0.3345 * t - 0.060374 * t * t
            + 0.0017275 * t.powi(3)
            + 0.000651814 * t.powi(4)
            + 0.00002373599 * t.powi(5)
    } else if (2005.0..2050.0).contains(&year) {
        let t = year - 2000.0;
        62.92 + 0.32217 * t + 0.005589 * t * t
    } else if (2050.0..2150.0).contains(&year) {
        let u = (year - 1820.0) / 100.0;
        -20.0 + 32.0 * u * u - 0.5628 * (2150.0 - year)
    } else {
        let u = (year - 1820.0) / 100.0;
        -20.0 + 32.0 * u * u
    }
}

/// Sum of one periodic-term table: Σ A·cos(B + C·τ).
fn series(terms: &[[f64; 3]], tau: f64) -> f64 {
    terms.iter().map(|t| t[0] * (t[1] + t[2] * tau).cos()).sum()
}

/// Polynomial in τ of the sums of several tables, divided by 10⁸ (radians or AU).
fn earth_series(tables: &[&[[f64; 3]]], jme: f64) -> f64 {
    let mut total = 0.0;
    let mut p = 1.0;
    for table in tables {
        total += series(table, jme) * p;
        p *= jme;
    }
    total / 1e8
}

/// Reduce an angle in degrees to [0, 360).
fn wrap360(deg: f64) -> f64 {
    deg.rem_euclid(360.0)
}

/// Atmospheric refraction at the horizon assumed by the SPA's switch-off test, degrees.
const HORIZON_REFRACTION_DEG: f64 = 0.5667;
/// Apparent solar radius used by the same test, degrees.
const SUN_RADIUS_DEG: f64 = 0.26667;

/// The SPA proper for Julian day `jd` (UT) and ΔT in seconds (ΔUT1 = 0).
fn spa(
    jd: f64,
    delta_t: f64,
    site: &Site,
    pressure_mbar: f64,
    temperature_c: f64,
) -> SolarPosition {
    let jde = jd + delta_t / 86_400.0;
    let jc = (jd - 2_451_545.0) / 36_525.0;
    let jce = (jde - 2_451_545.0) / 36_525.0;
    let jme = jce / 10.0;

    // Earth heliocentric coordinates (§3.2).
    let l_deg = wrap360(earth_series(&[&L0, &L1, &L2, &L3, &L4, &L5], jme).to_degrees());
    let b_deg = earth_series(&[&B0, &B1], jme).to_degrees();
    let r_au = earth_series(&[&R0, &R1, &R2, &R3, &R4], jme);

    // Geocentric (§3.3).
    let theta = wrap360(l_deg + 180.0);
    let beta = -b_deg;

    // Nutation (§3.4): arguments in degrees.
    let x = [
        297.85036 + 445_267.111_480 * jce - 0.001_914_2 * jce * jce + jce.powi(3) / 189_474.0,
        357.52772 + 35_999.050_340 * jce - 0.000_160_3 * jce * jce - jce.powi(3) / 300_000.0,
        134.96298 + 477_198.867_398 * jce + 0.008_697_2 * jce * jce + jce.powi(3) / 56_250.0,
        93.27191 + 483_202.017_538 * jce - 0.003_682_5 * jce * jce + jce.powi(3) / 327_270.0,
        125.04452 - 1_934.136_261 * jce + 0.002_070_8 * jce * jce + jce.powi(3) / 450_000.0,
    ];
    let (mut dpsi, mut deps) = (0.0, 0.0);
    for (y, abcd) in NUTATION_Y.iter().zip(NUTATION_ABCD.iter()) {
        let arg: f64 = y
            .iter()
            .zip(x.iter())
            .map(|(&yi, &xi)| f64::from(yi) * xi)
            .sum::<f64>()
            .to_radians();
        dpsi += (abcd[0] + abcd[1] * jce) * arg.sin();
        deps += (abcd[2] + abcd[3] * jce) * arg.cos();
    }
    // Table units are 0.0001 arcsec.
    let dpsi = dpsi / 36_000_000.0;
    let deps = deps / 36_000_000.0;

    // Obliquity (§3.5), arcsec polynomial in U = JME/10.
    let u = jme / 10.0;
    let eps0 = [
        84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12, 27.87, 5.79, 2.45,
    ]
    .iter()
    .rev()
    .fold(0.0, |acc, c| acc * u + c);
    let eps = eps0 / 3600.0 + deps;
    let eps_r = eps.to_radians();

    // Aberration and apparent longitude (§3.6–3.7).
    let dtau = -20.4898 / (3600.0 * r_au);
    let lambda_r = (theta + dpsi + dtau).to_radians();
    let beta_r = beta.to_radians();

    // Apparent sidereal time at Greenwich (§3.8).
    let nu0 = wrap360(
        280.460_618_37 + 360.985_647_366_29 * (jd - 2_451_545.0) + 0.000_387_933 * jc * jc
            - jc.powi(3) / 38_710_000.0,
    );
    let nu = nu0 + dpsi * eps_r.cos();

    // Geocentric right ascension and declination (§3.9–3.10).
    let alpha = wrap360(
        (lambda_r.sin() * eps_r.cos() - beta_r.tan() * eps_r.sin())
            .atan2(lambda_r.cos())
            .to_degrees(),
    );
    let delta_r = (beta_r.sin() * eps_r.cos() + beta_r.cos() * eps_r.sin() * lambda_r.sin()).asin();

    // Observer local hour angle (§3.11), longitude east positive.
    let h_r = wrap360(nu + site.longitude - alpha).to_radians();

    // Topocentric parallax (§3.12).
    let xi_r = (8.794 / (3600.0 * r_au)).to_radians();
    let phi_r = site.latitude.to_radians();
    let uu = (0.996_647_19 * phi_r.tan()).atan();
    let xx = uu.cos() + site.elevation_m / 6_378_140.0 * phi_r.cos();
    let yy = 0.996_647_19 * uu.sin() + site.elevation_m / 6_378_140.0 * phi_r.sin();
    let denom = delta_r.cos() - xx * xi_r.sin() * h_r.cos();
    let dalpha_r = (-xx * xi_r.sin() * h_r.sin()).atan2(denom);
    let delta_p_r = ((delta_r.sin() - yy * xi_r.sin()) * dalpha_r.cos()).atan2(denom);
    let h_p_r = h_r - dalpha_r;

    // Topocentric elevation without and with refraction (§3.13–3.14).
    let e0 = (phi_r.sin() * delta_p_r.sin() + phi_r.cos() * delta_p_r.cos() * h_p_r.cos())
        .clamp(-1.0, 1.0)
        .asin()
        .to_degrees();
    let de = if e0 >= -(SUN_RADIUS_DEG + HORIZON_REFRACTION_DEG) {
        (pressure_mbar / 1010.0) * (283.0 / (273.0 + temperature_c)) * 1.02
            / (60.0 * (e0 + 10.3 / (e0 + 5.11)).to_radians().tan())
    } else {
        0.0
    };
    let e = e0 + de;

    // Azimuth (§3.15): astronomers' azimuth is from south, westward.
    let gamma = h_p_r
        .sin()
        .atan2(h_p_r.cos() * phi_r.sin() - delta_p_r.tan() * phi_r.cos())
        .to_degrees();
    SolarPosition {
        zenith_deg: 90.0 - e,
        azimuth_deg: wrap360(gamma + 180.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use chrono::{FixedOffset, NaiveDate, TimeZone};

    fn utc(y: i32, mo: u32, d: u32, h: u32, mi: u32, s: u32, offset_h: i32) -> DateTime<Utc> {
        FixedOffset::east_opt(offset_h * 3600)
            .unwrap()
            .from_local_datetime(
                &NaiveDate::from_ymd_opt(y, mo, d)
                    .unwrap()
                    .and_hms_opt(h, mi, s)
                    .unwrap(),
            )
            .unwrap()
            .with_timezone(&Utc)
    }

    fn spa_example_site() -> Site {
        Site {
            latitude: 39.742476,
            longitude: -105.1786,
            utc_offset_h: -7.0,
            elevation_m: 1830.14,
        }
    }

    /// The SPA paper's worked example (Reda & Andreas 2004, table A5.1).
    #[test]
    fn spa_paper_example() {
        let t = utc(2003, 10, 17, 12, 30, 30, -7);
        let site = spa_example_site();
        // JD as printed in the paper.
        assert!((julian_day(t) - 2452930.312847).abs() < 1e-6);
        // With the paper's ΔT = 67 s the implementation must reproduce the SPA itself.
        let exact = spa(julian_day(t), 67.0, &site, 820.0, 11.0);
        assert!((exact.zenith_deg - 50.111622).abs() < 1e-5, "{exact:?}");
        assert!((exact.azimuth_deg - 194.340241).abs() < 1e-5, "{exact:?}");
        // The public entry point estimates ΔT itself; the brief's bound is 0.01°.
        let p = solar_position_with(t, &site, 820.0, 11.0);
        assert!((p.zenith_deg - 50.111622).abs() <= 0.01, "{p:?}");
        assert!((p.azimuth_deg - 194.340241).abs() <= 0.01, "{p:?}");
        // The standard-atmosphere default differs only by refraction (≈ 0.016° here).
        let q = solar_position(t, &site);
        assert!((q.zenith_deg - 50.111622).abs() <= 0.01, "{q:?}");
    }

    #[test]
    fn delta_t_is_plausible() {
        // Observed ΔT: ~64.5 s in 2003, ~69 s in 2020 (IERS).
        assert!((delta_t_seconds(2003.8) - 64.5).abs() < 3.0);
        assert!((delta_t_seconds(2020.0) - 69.4).abs() < 3.0);
    }

    #[test]
    fn standard_pressure() {
        assert!((standard_pressure_mbar(0.0) - 1013.25).abs() < 1e-9);
        // ICAO table: 1500 m → 845.6 hPa.
        assert!((standard_pressure_mbar(1500.0) - 845.6).abs() < 0.5);
    }

    /// Svalbard, 78.2°N, on the 15°E meridian of its standard zone (UTC+1).
    fn svalbard() -> Site {
        Site {
            latitude: 78.2,
            longitude: 15.0,
            utc_offset_h: 1.0,
            elevation_m: 0.0,
        }
    }

    /// Obliquity of the ecliptic, ≈ the solstice declination, degrees.
    const SOLSTICE_DECLINATION: f64 = 23.44;

    #[test]
    fn midnight_sun_at_svalbard() {
        // Local midnight ≈ lower culmination: altitude = δ − (90° − φ) (+ refraction ≈ 0.1°).
        let p = solar_position(utc(2021, 6, 21, 0, 0, 0, 1), &svalbard());
        let expected = SOLSTICE_DECLINATION - (90.0 - 78.2);
        assert!(p.altitude_deg() > 0.0);
        assert!(
            (p.altitude_deg() - expected).abs() < 0.3,
            "{p:?} vs {expected}"
        );
        // The sun is due north at lower culmination (equation of time ≈ −1.5 min → < 1°).
        let az = p.azimuth_deg;
        assert!(!(1.0..=359.0).contains(&az), "{p:?}");
    }

    #[test]
    fn polar_night_at_svalbard() {
        // Local noon ≈ upper culmination: altitude = 90° − φ + δ with δ = −23.44°.
        let p = solar_position(utc(2021, 12, 21, 12, 0, 0, 1), &svalbard());
        let expected = 90.0 - 78.2 - SOLSTICE_DECLINATION;
        assert!(p.altitude_deg() < 0.0);
        assert!(
            (p.altitude_deg() - expected).abs() < 0.3,
            "{p:?} vs {expected}"
        );
        assert!((p.azimuth_deg - 180.0).abs() < 1.0, "{p:?}");
    }

    #[test]
    fn equinox_noon_at_equator() {
        // March equinox 2024 was 03:06 UTC on 20 March (δ ≈ +0.09° at noon); the equation
        // of time that day is ≈ −7.5 min, so apparent noon on the Greenwich meridian is
        // ≈ 12:07:30 UTC and the sun is within a few tenths of a degree of the zenith.
        let site = Site {
            latitude: 0.0,
            longitude: 0.0,
            utc_offset_h: 0.0,
            elevation_m: 0.0,
        };
        let p = solar_position(utc(2024, 3, 20, 12, 7, 30, 0), &site);
        assert!(p.zenith_deg < 0.4, "{p:?}");
        // An hour later the hour angle is 15°: zenith ≈ 15°, sun in the west.
        let p = solar_position(utc(2024, 3, 20, 13, 7, 30, 0), &site);
        assert!((p.zenith_deg - 15.0).abs() < 0.5, "{p:?}");
        assert!((p.azimuth_deg - 270.0).abs() < 1.0, "{p:?}");
    }

    #[test]
    fn azimuth_conventions() {
        let north = Site {
            latitude: 45.0,
            longitude: 0.0,
            utc_offset_h: 0.0,
            elevation_m: 0.0,
        };
        let south = Site {
            latitude: -35.0,
            ..north
        };
        // Northern hemisphere: morning sun east of south, afternoon west, noon south.
        let am = solar_position(utc(2022, 6, 21, 8, 0, 0, 0), &north);
        let noon = solar_position(utc(2022, 6, 21, 12, 2, 0, 0), &north);
        let pm = solar_position(utc(2022, 6, 21, 16, 0, 0, 0), &north);
        assert!(am.azimuth_deg > 60.0 && am.azimuth_deg < 180.0, "{am:?}");
        assert!((noon.azimuth_deg - 180.0).abs() < 2.0, "{noon:?}");
        assert!(pm.azimuth_deg > 180.0 && pm.azimuth_deg < 300.0, "{pm:?}");
        // Noon altitude at the solstice = 90 − φ + δ.
        assert!((noon.altitude_deg() - (45.0 + SOLSTICE_DECLINATION)).abs() < 0.2);
        // Southern hemisphere: morning sun east of north, noon sun due north (az ≈ 0/360).
        let am = solar_position(utc(2022, 6, 21, 9, 0, 0, 0), &south);
        let noon = solar_position(utc(2022, 6, 21, 12, 2, 0, 0), &south);
        assert!(am.azimuth_deg > 0.0 && am.azimuth_deg < 90.0, "{am:?}");
        assert!(!(2.0..=358.0).contains(&noon.azimuth_deg), "{noon:?}");
        // Direction vector agrees with the angles: morning sun in the north-hemisphere
        // site has a positive east (x) component.
        let d = solar_position(utc(2022, 6, 21, 8, 0, 0, 0), &north).direction();
        assert!(d.x > 0.0 && (d.length() - 1.0).abs() < 1e-12);
    }
}
