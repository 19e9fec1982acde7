//! Tests of the Perez all-weather sky (`super`).

use super::*;
use crate::photometry::lux;
use crate::site::direction_from_alt_az;
use std::f64::consts::PI;

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!((got - want).abs() <= tol, "{what}: {got} vs {want}");
}

struct Anchor {
    dni: f64,
    dhi: f64,
    z_deg: f64,
    doy: u32,
    td: f64,
    eps: f64,
    delta: f64,
    bin: usize,
    kd: f64,
    kb: Option<f64>,
    abcde: [f64; 5],
    m: f64,
    e0: f64,
}

/// docs/derivations.md, "Perez all-weather sky and efficacy": anchors computed from the published formulas.
const ANCHORS: [Anchor; 4] = [
    Anchor {
        dni: 700.0,
        dhi: 100.0,
        z_deg: 40.0,
        doy: 172,
        td: 10.0,
        eps: 6.16906,
        delta: 0.09858,
        bin: 7,
        kd: 137.152,
        kb: Some(103.330),
        abcde: [-0.97096, -0.20888, 15.50055, -3.92638, 0.64153],
        m: 1.30368,
        e0: 0.96744,
    },
    Anchor {
        dni: 50.0,
        dhi: 250.0,
        z_deg: 60.0,
        doy: 80,
        td: 12.0,
        eps: 1.09110,
        delta: 0.36158,
        bin: 2,
        kd: 114.005,
        kb: Some(92.740),
        abcde: [-1.10269, -1.23508, 9.44525, -2.71504, 0.09133],
        m: 1.99276,
        e0: 1.00790,
    },
    Anchor {
        dni: 0.0,
        dhi: 80.0,
        z_deg: 70.0,
        doy: 355,
        td: 2.0,
        eps: 1.0,
        delta: 0.16411,
        bin: 1,
        kd: 116.956,
        kb: None,
        abcde: [0.70560, -0.58189, 0.66446, -0.52306, -0.01121],
        m: 2.89995,
        e0: 1.03412,
    },
    Anchor {
        dni: 850.0,
        dhi: 60.0,
        z_deg: 25.0,
        doy: 196,
        td: 15.0,
        eps: 11.9,
        delta: 0.05004,
        bin: 8,
        kd: 136.030,
        kb: Some(104.864),
        abcde: [-1.00824, -0.23557, 23.63725, -6.37289, 1.32480],
        m: 1.10247,
        e0: 0.96709,
    },
];

#[test]
fn regression_anchors() {
    for (i, a) in ANCHORS.iter().enumerate() {
        let p = parameters(a.dni, a.dhi, a.z_deg.to_radians(), a.doy, a.td);
        let w = format!("anchor {i}");
        close(p.epsilon, a.eps, 1e-5, &format!("{w} eps"));
        close(p.delta, a.delta, 1e-5, &format!("{w} delta"));
        assert_eq!(p.bin, a.bin, "{w} bin");
        close(p.kd, a.kd, 1e-3, &format!("{w} kd"));
        if let Some(kb) = a.kb {
            close(p.kb, kb, 1e-3, &format!("{w} kb"));
        }
        let got = [p.a, p.b, p.c, p.d, p.e];
        for (k, (&g, &e)) in got.iter().zip(a.abcde.iter()).enumerate() {
            close(g, e, 1e-4, &format!("{w} param {k}"));
        }
        close(p.air_mass, a.m, 1e-5, &format!("{w} air mass"));
        close(p.e0, a.e0, 1e-5, &format!("{w} e0"));
    }
}

/// ∫ L cos θ dω (lux) by an independent midpoint rule in (zenith, azimuth).
fn integrate_sky(sky: &Sky) -> f64 {
    let (nz, na) = (300, 600);
    let (dz, da) = (90.0 / nz as f64, 360.0 / na as f64);
    let mut sum = 0.0;
    for i in 0..nz {
        let z = ((i as f64 + 0.5) * dz).to_radians();
        let w = z.cos() * z.sin() * dz.to_radians() * da.to_radians();
        for j in 0..na {
            let d = direction_from_alt_az(90.0 - z.to_degrees(), (j as f64 + 0.5) * da);
            sum += lux(sky.radiance(d)) * w;
        }
    }
    sum
}

#[test]
fn sky_is_normalised_to_diffuse_illuminance() {
    for a in &ANCHORS {
        let sun = direction_from_alt_az(90.0 - a.z_deg, 150.0);
        let s = sky(a.dni, a.dhi, sun, a.doy, a.td, 0.2).unwrap();
        let e_vd = a.kd * a.dhi;
        let e = integrate_sky(&s);
        assert!((e / e_vd - 1.0).abs() < 2e-3, "{e} vs {e_vd}");
        match a.kb {
            Some(kb) => {
                let sun_src = s.sun.unwrap();
                close(
                    lux(sun_src.normal_irradiance),
                    kb * a.dni,
                    1e-3 * a.dni,
                    "E_vb",
                );
                assert_eq!(sun_src.direction, sun);
            }
            None => assert!(s.sun.is_none()),
        }
        // Ground glow ρ(E_vd + E_vb cos Z)/(179π), white.
        let eh = e_vd + a.kb.unwrap_or(0.0) * a.dni * a.z_deg.to_radians().cos();
        close(
            s.ground_radiance.x,
            0.2 * eh / (179.0 * PI),
            1e-3 * s.ground_radiance.x,
            "ground",
        );
        assert_eq!(s.ground_radiance.x, s.ground_radiance.z);
    }
}

#[test]
fn per_ring_integral_matches_a_fine_quadrature() {
    // The timestep's normalisation (sun-aligned, half rings) against the generic rule at
    // 4× the resolution in each direction: within its 2e-4 share of the stated error.
    for (dni, dhi, alt, az) in [
        (800.0, 90.0, 40.0, 150.0),
        (100.0, 300.0, 5.0, 80.0),
        (0.0, 200.0, 70.0, 200.0),
        (600.0, 120.0, 3.0, 250.0),
        (30.0, 40.0, 0.5, 250.0),
    ] {
        let d = direction_from_alt_az(alt, az);
        let p = parameters(dni, dhi, d.z.acos(), 172, 10.0);
        let fine = crate::sky::integrate_horizontal(
            |v| Rgb::splat(p.relative_luminance(v.z, v.dot(d).clamp(-1.0, 1.0).acos())),
            512,
            1024,
        )
        .x;
        let fast = p.horizontal_integral(d);
        assert!(fine > 0.0, "{alt}°: a dark sky tests nothing");
        assert!((fast / fine - 1.0).abs() < 2e-4, "{alt}°: {fast} vs {fine}");
    }
}

#[test]
fn remembered_integrals_leave_in_a_list_and_come_back_from_one() {
    // Parameters no other test uses: the memo is the process's.
    let d = direction_from_alt_az(23.456, 123.0);
    let p = parameters(432.1, 98.7, d.z.acos(), 123, 7.0);
    let v = remembered_horizontal_integral(&p, d);
    let key = [p.a, p.b, p.c, p.d, p.e, d.x, d.y, d.z].map(f64::to_bits);
    let listed = remembered_integrals();
    let entry = listed
        .iter()
        .find(|e| e[..8] == key)
        .expect("the integral is listed");
    assert_eq!(entry[8], v.to_bits());
    assert!(listed.windows(2).all(|w| w[0] < w[1]), "sorted");
    // A list brings its entries back, as they are: a value only a list could give
    // (twice the integral) is what is remembered for a new key. A value that is not
    // finite and positive is not.
    let q = PerezParameters {
        e: p.e + 0.125,
        ..p
    };
    let qkey = [q.a, q.b, q.c, q.d, q.e, d.x, d.y, d.z].map(f64::to_bits);
    let mut bad = [0u64; 9];
    bad[..8].copy_from_slice(&qkey);
    bad[8] = f64::NAN.to_bits();
    remember_integrals(&[bad]);
    assert_eq!(
        remembered_horizontal_integral(&q, d).to_bits(),
        q.horizontal_integral(d).to_bits()
    );
    let r = PerezParameters { e: p.e + 0.25, ..p };
    let mut e = [0u64; 9];
    e[..8].copy_from_slice(&[r.a, r.b, r.c, r.d, r.e, d.x, d.y, d.z].map(f64::to_bits));
    e[8] = (2.0 * r.horizontal_integral(d)).to_bits();
    remember_integrals(&[e]);
    assert_eq!(remembered_horizontal_integral(&r, d).to_bits(), e[8]);
}

#[test]
fn the_remembered_horizontal_integral_is_the_integral() {
    let d = direction_from_alt_az(35.0, 200.0);
    let p = parameters(650.0, 110.0, d.z.acos(), 80, 4.0);
    let direct = p.horizontal_integral(d);
    for _ in 0..2 {
        assert_eq!(
            remembered_horizontal_integral(&p, d).to_bits(),
            direct.to_bits()
        );
    }
    let q = PerezParameters { c: p.c + 1.0, ..p };
    assert_eq!(
        remembered_horizontal_integral(&q, d).to_bits(),
        q.horizontal_integral(d).to_bits()
    );
}

#[test]
fn circumsolar_brighter_than_antisolar_on_clear_sky() {
    let sun = direction_from_alt_az(50.0, 180.0);
    let s = sky(700.0, 100.0, sun, 172, DEFAULT_DEW_POINT_C, 0.2).unwrap();
    let near = lux(s.radiance(direction_from_alt_az(45.0, 180.0)));
    let far = lux(s.radiance(direction_from_alt_az(45.0, 0.0)));
    assert!(near > 3.0 * far, "{near} {far}");
}

#[test]
fn zero_dhi_gives_dark_sky_but_a_sun() {
    let sun = direction_from_alt_az(40.0, 180.0);
    let s = sky(800.0, 0.0, sun, 100, 10.0, 0.2).unwrap();
    assert!(s.distribution.is_none());
    let sun_src = s.sun.unwrap();
    assert!(sun_src.normal_irradiance.x > 0.0 && sun_src.normal_irradiance.x.is_finite());
    assert!(s.ground_radiance.x > 0.0);
    let p = parameters(800.0, 0.0, 50f64.to_radians(), 100, 10.0);
    assert!(p.epsilon.is_finite() && p.kb.is_finite() && p.kd.is_finite());
    // Both zero: nothing at all, still not an error.
    let s = sky(0.0, 0.0, sun, 100, 10.0, 0.2).unwrap();
    assert!(s.distribution.is_none() && s.sun.is_none());
    assert_eq!(s.ground_radiance, Rgb::ZERO);
}

#[test]
fn low_sun_gives_finite_values() {
    let sun = direction_from_alt_az(0.1, 90.0);
    for (dni, dhi) in [(100.0, 20.0), (0.0, 30.0), (5.0, 300.0)] {
        let s = sky(dni, dhi, sun, 200, 10.0, 0.2).unwrap();
        let e = integrate_sky(&s);
        assert!(e.is_finite() && e > 0.0);
        for alt in [0.05, 1.0, 10.0, 89.0] {
            for az in [0.0, 90.0, 200.0] {
                let l = s.radiance(direction_from_alt_az(alt, az));
                assert!(l.is_finite() && l.min_element() >= 0.0);
            }
        }
        assert!(s.ground_radiance.is_finite());
    }
    // Clear and bright at a very low sun: Δ is large and b > 0; the sky stays finite,
    // normalised, and says so.
    let s = sky(800.0, 60.0, sun, 200, 10.0, 0.2).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("b =")),
        "{:?}",
        s.warnings
    );
    let p = parameters(800.0, 60.0, sun.z.acos(), 200, 10.0);
    assert!(p.b > 0.0);
    let e = integrate_sky(&s);
    assert!((e / (p.kd * 60.0) - 1.0).abs() < 0.05, "{e}");
}

#[test]
fn sun_below_horizon_is_dark_with_warning() {
    let sun = direction_from_alt_az(-2.0, 300.0);
    let s = sky(50.0, 20.0, sun, 200, 10.0, 0.2).unwrap();
    assert!(s.distribution.is_none() && s.sun.is_none());
    assert_eq!(s.ground_radiance, Rgb::ZERO);
    assert!(s.warnings.iter().any(|w| w.contains("horizon")));
    assert_eq!(s.description, "perez dni=50 dhi=20");
}

#[test]
fn bad_input_is_an_error() {
    let sun = DVec3::Z;
    assert!(sky(-1.0, 10.0, sun, 1, 10.0, 0.2).is_err());
    assert!(sky(1.0, f64::NAN, sun, 1, 10.0, 0.2).is_err());
    assert!(sky(1.0, 10.0, sun, 0, 10.0, 0.2).is_err());
    assert!(sky(1.0, 10.0, sun, 367, 10.0, 0.2).is_err());
    assert!(sky(1.0, 10.0, sun, 1, f64::NAN, 0.2).is_err());
    assert!(sky(1.0, 10.0, sun, 1, 10.0, -0.2).is_err());
}
