//! Closed-form daylight cases (docs/derivations.md): every expected value here comes
//! from a formula or a published table, never from daystep's own earlier output.

use crate::util::*;
use daystep::photometry::Rgb;
use daystep::sequence::Quality;
use daystep::sky::Sun;
use glam::DVec3;
use std::f64::consts::PI;

fn open_sensors() -> daystep::scene::Scene {
    let mut b = Builder::new();
    b.sensor(DVec3::ZERO, DVec3::Z); // horizontal, facing up
    b.sensor(DVec3::ZERO, DVec3::X); // vertical, facing east
    b.sensor(DVec3::ZERO, DVec3::new(0.0, -1.0, 1.0)); // tilted 45°, facing south
    b.build()
}

#[test]
fn uniform_sky_gives_pi_l_and_half_for_vertical() {
    let (l, lg) = (10.0, 3.0);
    let scene = open_sensors();
    let r = run(
        &scene,
        &sky_of(Some(Box::new(Uniform(l))), None, lg),
        &Quality::default(),
    );
    let s = &r.sensors;
    // Horizontal: π L. Vertical: half the sky and half the ground, π/2 each.
    assert_close(
        "horizontal",
        s[0].lux,
        lux_of(PI * l),
        1e-9 * lux_of(PI * l),
    );
    let vert = lux_of(PI / 2.0 * (l + lg));
    assert_close("vertical", s[1].lux, vert, 1e-9 * vert);
    // Tilted β = 45°: sky view (1 + cos β)/2, ground view (1 − cos β)/2 of π.
    let c = 0.5f64.sqrt();
    let tilt = lux_of(PI * (l * (1.0 + c) / 2.0 + lg * (1.0 - c) / 2.0));
    assert_close("tilted", s[2].lux, tilt, 1e-9 * tilt);
}

#[test]
fn moon_spencer_overcast_gives_seven_ninths_pi_lz() {
    let lz = 20.0;
    let scene = open_sensors();
    let r = run(
        &scene,
        &sky_of(Some(Box::new(MoonSpencer(lz))), None, 0.0),
        &Quality::default(),
    );
    let expected = lux_of(7.0 / 9.0 * PI * lz);
    let got = r.sensors[0];
    assert_close("overcast horizontal", got.lux, expected, 0.01 * expected);
    assert!(
        got.lux_err >= (got.lux - expected).abs(),
        "lux_err {} does not cover {}",
        got.lux_err,
        (got.lux - expected).abs()
    );
    // An inflated bar covers any answer: the sky's discretisation error bar must stay
    // within 5× the 1 % accuracy this test demands.
    assert!(
        got.lux_err <= 0.05 * expected,
        "lux_err {} of {expected}",
        got.lux_err
    );
}

/// The CIE general sky, written here from ISO 15469's published coefficients so the test
/// does not share code with the library.
fn cie_relative(t: usize, z: f64, az: f64, zs: f64, azs: f64) -> f64 {
    const P: [[f64; 5]; 15] = [
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
    let [a, b, c, d, e] = P[t - 1];
    let phi = |z: f64| {
        if z.cos() <= 1e-12 {
            1.0
        } else {
            1.0 + a * (b / z.cos()).exp()
        }
    };
    let f = |chi: f64| 1.0 + c * ((d * chi).exp() - (d * PI / 2.0).exp()) + e * chi.cos().powi(2);
    let chi = (zs.cos() * z.cos() + zs.sin() * z.sin() * (az - azs).cos())
        .clamp(-1.0, 1.0)
        .acos();
    f(chi) * phi(z) / (f(zs) * phi(0.0))
}

/// Published E_h/L_z (docs/derivations.md, "CIE standard general skies") at sun altitudes 15, 30, 45, 60°.
/// (Type 5 is the published 3.1416, i.e. π to the table's precision.)
#[allow(clippy::approx_constant)]
const EH_OVER_LZ: [[f64; 4]; 15] = [
    [2.4496; 4],
    [2.6615, 2.5566, 2.3635, 2.0860],
    [2.7700; 4],
    [3.0298, 2.8902, 2.6467, 2.3154],
    [3.1416; 4],
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
fn cie_general_skies_against_independent_quadrature() {
    use daystep::sky::cie::{sky, CieSkyType};
    let scene = open_sensors();
    let dhi = 100.0;
    let rho_g = 0.2;
    let q = Quality::default();
    let mut worst: f64 = 0.0;
    let (mut cases, mut uncovered, mut worst_ratio) = (0usize, 0usize, 0.0f64);
    for t in 1..=15usize {
        for (k, alt) in [15.0f64, 30.0, 45.0, 60.0].into_iter().enumerate() {
            let az_s: f64 = 160.0;
            let sun = daystep::site::direction_from_alt_az(alt, az_s);
            let s = sky(CieSkyType::General(t as u8), dhi, 0.0, sun, rho_g).unwrap();
            // The published E_h/L_z fixes the zenith radiance of a sky normalised to DHI.
            let lz = s.radiance(DVec3::Z).x;
            assert_close(
                &format!("type {t} alt {alt}: L_z·E_h/L_z"),
                lz * EH_OVER_LZ[t - 1][k],
                dhi,
                2e-3 * dhi,
            );
            // Independent midpoint quadrature of the test's own formula, normalised to DHI.
            let (zs, azs) = ((90.0 - alt).to_radians(), az_s.to_radians());
            let (nz, na) = (300, 600);
            let normals = [DVec3::Z, DVec3::X, DVec3::new(0.0, -1.0, 1.0).normalize()];
            let mut e = [0.0; 3];
            for i in 0..nz {
                let z = (i as f64 + 0.5) * (PI / 2.0) / nz as f64;
                for j in 0..na {
                    let az = (j as f64 + 0.5) * 2.0 * PI / na as f64;
                    let w = DVec3::new(z.sin() * az.sin(), z.sin() * az.cos(), z.cos());
                    let l = cie_relative(t, z, az, zs, azs);
                    let dw = z.sin() * (PI / 2.0 / nz as f64) * (2.0 * PI / na as f64);
                    for (m, n) in normals.iter().enumerate() {
                        e[m] += l * n.dot(w).max(0.0) * dw;
                    }
                }
            }
            let scale = dhi / e[0];
            let lg = rho_g * dhi / PI;
            let ground_view = [0.0, 0.5, (1.0 - 0.5f64.sqrt()) / 2.0];
            let r = run(&scene, &s, &q);
            for m in 0..3 {
                let expected = lux_of(e[m] * scale + lg * PI * ground_view[m]);
                let got = r.sensors[m];
                let err = (got.lux - expected).abs();
                worst = worst.max(err / expected);
                assert!(
                    err <= 0.01 * expected,
                    "type {t} alt {alt} sensor {m}: {} vs {expected}",
                    got.lux
                );
                // The reference quadrature itself is good to about 1e-5.
                let covered = got.lux_err + 1e-5 * expected >= err;
                // Capped at 5× the 1 % accuracy demanded above.
                assert!(
                    got.lux_err <= 0.05 * expected,
                    "type {t} alt {alt} sensor {m}: lux_err {} of {expected}",
                    got.lux_err
                );
                uncovered += usize::from(!covered);
                if !covered {
                    eprintln!("not covered: type {t} alt {alt} sensor {m}: lux {:.2} expected {expected:.2} lux_err {:.2}", got.lux, got.lux_err);
                }
                cases += 1;
                worst_ratio = worst_ratio.max(err / (got.lux_err + 1e-5 * expected));
            }
        }
    }
    eprintln!(
        "worst relative error over CIE skies: {worst:.2e}; lux_err covers {}/{cases}; worst error/lux_err {worst_ratio:.2}",
        cases - uncovered
    );
    // The stated error must cover the actual error at 90 % of points or more (issue 6's
    // bar) and never be off by more than a factor of 2.
    assert!(
        uncovered * 10 <= cases,
        "{uncovered} of {cases} not covered"
    );
    assert!(worst_ratio <= 2.0, "worst error / lux_err = {worst_ratio}");
}

/// A black 10 × 10 × 3 m room whose only opening is a hole in the roof centred above (5, 5).
pub(crate) fn roof_opening_room(hole: f64, glazing: Option<f64>) -> daystep::scene::Scene {
    let mut b = Builder::new();
    let black = b.material("black", 0.0, 0.0);
    b.hrect(0.0, 10.0, 0.0, 10.0, 0.0, true, black);
    let h = hole / 2.0;
    b.hrect_with_hole(
        (0.0, 10.0, 0.0, 10.0),
        (5.0 - h, 5.0 + h, 5.0 - h, 5.0 + h),
        3.0,
        false,
        black,
    );
    b.walls_inward(0.0, 10.0, 0.0, 10.0, 0.0, 3.0, black);
    if let Some(tf) = glazing {
        let g = b.material("glass", 0.0, tf);
        b.hrect(5.0 - h, 5.0 + h, 5.0 - h, 5.0 + h, 3.0, true, g);
    }
    b.sensor(DVec3::new(5.0, 5.0, 0.0), DVec3::Z);
    b.build()
}

#[test]
fn sky_component_under_roof_opening() {
    let scene = roof_opening_room(1.0, None);
    let q = Quality::default();
    // Uniform sky: SC = F = 4·F(0.5, 0.5, 3) = 0.0341068.
    let f = 4.0 * f_parallel(0.5, 0.5, 3.0);
    assert_close("closed-form F", f, 0.0341068, 1e-6);
    let check = |what: &str, sky: Box<dyn daystep::sky::SkyDistribution>, expected: f64| {
        let got = run(&scene, &sky_of(Some(sky), None, 0.0), &q).sensors[0];
        assert_close(what, got.lux, expected, 0.02 * expected);
        let err = (got.lux - expected).abs();
        assert!(
            got.lux_err >= err,
            "{what}: lux_err {} vs error {err}",
            got.lux_err
        );
        // Capped at 5× the 2 % accuracy demanded above, so an inflated bar fails.
        assert!(
            got.lux_err <= 0.1 * expected,
            "{what}: lux_err {} of {expected}",
            got.lux_err
        );
    };
    check(
        "uniform sky through 1x1 m opening",
        Box::new(Uniform(10.0)),
        lux_of(PI * 10.0 * f),
    );
    // Moon–Spencer overcast: E/L_z = 0.1065100 (docs/derivations.md, "Overcast sky through the roof opening").
    check(
        "overcast through 1x1 m opening",
        Box::new(MoonSpencer(10.0)),
        lux_of(0.1065100 * 10.0),
    );
}

fn sun_only(alt: f64, az: f64, dni: f64) -> daystep::sky::Sky {
    sky_of(
        None,
        Some(Sun {
            direction: daystep::site::direction_from_alt_az(alt, az),
            normal_irradiance: Rgb::splat(dni),
        }),
        0.0,
    )
}

#[test]
fn sun_through_roof_opening_lights_its_footprint_and_refines_its_edge() {
    let hole = 2.0;
    let mut scene = roof_opening_room(hole, None);
    scene.sensors.clear();
    // Sensors on a 0.25 m grid at 0.8 m.
    for i in 0..39 {
        for j in 0..39 {
            let p = DVec3::new(0.25 * (i + 1) as f64, 0.25 * (j + 1) as f64, 0.8);
            scene.sensors.push(daystep::scene::Sensor {
                position: p - scene.origin,
                normal: DVec3::Z,
                input_position: p,
            });
        }
    }
    let (alt, az, dni) = (55.0, 200.0, 800.0);
    let q = Quality::default();
    let r = run(&scene, &sun_only(alt, az, dni), &q);
    let sun = r
        .sources
        .iter()
        .find(|s| s.is_sun())
        .expect("sun is a source");
    let d = sun.direction; // snapped: visibility follows it
    let cos_true = daystep::site::direction_from_alt_az(alt, az).z;
    let h = hole / 2.0;
    let in_hole = |p: DVec3| {
        let q = p + d * ((3.0 - p.z) / d.z);
        let dx = (q.x - 5.0).abs() - h;
        let dy = (q.y - 5.0).abs() - h;
        dx.max(dy) // < 0 inside
    };
    let mut lit = 0;
    for (k, s) in scene.sensors.iter().enumerate() {
        let p = s.input_position;
        let m = in_hole(p);
        if m.abs() < 1e-6 {
            continue; // on the footprint edge exactly
        }
        let expected = if m < 0.0 { lux_of(dni * cos_true) } else { 0.0 };
        lit += usize::from(m < 0.0);
        assert_close(
            &format!("sensor {k} at {p}"),
            r.sensors[k].lux,
            expected,
            1e-9 * lux_of(dni),
        );
    }
    // The footprint is hole² / 0.0625 m² per sensor ≈ 64 sensors.
    assert!((50..80).contains(&lit), "{lit} lit sensors");

    // Floor elements: triangles 0 and 1. Count leaves near the footprint edge and away.
    let mut near = (0usize, 0.0f64);
    let mut far = (0usize, 0.0f64);
    for i in r.hierarchy.leaves() {
        let e = &r.hierarchy.elements[i as usize];
        if e.key.tri > 1 {
            continue;
        }
        let c = (e.vertices[0] + e.vertices[1] + e.vertices[2]) / 3.0 + scene.origin;
        let m = in_hole(c).abs();
        if m < 0.15 {
            near.0 += 1;
            near.1 += e.area;
        } else if m > 1.0 {
            far.0 += 1;
            far.1 += e.area;
        }
        // Irradiance: full inside, zero outside, for leaves clear of the edge.
        let span = (e.vertices[1] - e.vertices[0])
            .length()
            .max((e.vertices[2] - e.vertices[0]).length());
        let e_sun = r.direct.sun[i as usize].x;
        if in_hole(c) < -span {
            assert_close("lit leaf", e_sun, dni * d.z, 1e-6 * dni);
        } else if in_hole(c) > span {
            assert_close("shadowed leaf", e_sun, 0.0, 1e-9);
        }
    }
    let density_near = near.0 as f64 / near.1;
    let density_far = far.0 as f64 / far.1;
    eprintln!(
        "leaves near edge {} ({density_near:.0}/m²), far {} ({density_far:.2}/m²)",
        near.0, far.0
    );
    assert!(
        near.0 > 100,
        "refinement along the shadow edge: {} leaves",
        near.0
    );
    assert!(
        density_near > 100.0 * density_far,
        "{density_near} vs {density_far}"
    );
}

#[test]
fn glazing_transmittance_follows_the_glass_formula() {
    // Published Radiance-glass transmittance for T_n = 0.88 (docs/derivations.md, "Glazing transmittance").
    let table = [
        (0.0, 0.8800),
        (30.0, 0.8755),
        (60.0, 0.7999),
        (80.0, 0.4235),
    ];
    let mut b = Builder::new();
    let g = b.material("glass", 0.0, 0.88);
    b.hrect(-50.0, 50.0, -50.0, 50.0, 1.0, true, g);
    b.sensor(DVec3::ZERO, DVec3::Z);
    let scene = b.build();
    let dni = 500.0;
    for (zenith, tau) in table {
        let r = run(
            &scene,
            &sun_only(90.0 - zenith, 135.0, dni),
            &Quality::default(),
        );
        let cos = zenith.to_radians().cos();
        let expected = lux_of(dni * cos * tau);
        // Table rounding (5e-5 in τ) is the tolerance.
        assert_close(
            &format!("glazing at {zenith}°"),
            r.sensors[0].lux,
            expected,
            lux_of(dni * cos * 6e-5),
        );
    }
}

/// A patch much larger than the light that reaches it (VR below `v_min`) must not spread
/// that light over itself: interreflection starts from these leaves, and a 0.4 × 0.4 m sun
/// patch laid evenly over a 50 m² floor triangle lights the whole floor at 0.3 % (the
/// office's back floor got 300–700 lx of sun this way).
#[test]
fn sun_through_a_small_opening_stays_in_its_footprint() {
    let hole = 0.4;
    let mut scene = roof_opening_room(hole, None);
    scene.sensors.clear();
    let (alt, az, dni) = (55.0, 200.0, 800.0);
    let r = run(&scene, &sun_only(alt, az, dni), &Quality::default());
    let d = r
        .sources
        .iter()
        .find(|s| s.is_sun())
        .expect("sun")
        .direction;
    let h = hole / 2.0;
    let outside = |p: DVec3| {
        let q = p + d * ((3.0 - p.z) / d.z);
        ((q.x - 5.0).abs() - h).max((q.y - 5.0).abs() - h)
    };
    // All the beam through the opening lands on the floor (hole² · DNI · cos at the snapped
    // sun), up to the LDI's pixel-edge error: 1024 px over a 15 m diagonal put ≈ 4 % of the
    // 0.16 m² footprint in the pixels along its edge.
    let power: f64 = r
        .hierarchy
        .leaves()
        .filter(|&i| r.hierarchy.elements[i as usize].key.tri <= 1) // the floor
        .map(|i| r.direct.sun[i as usize].x * r.hierarchy.elements[i as usize].area)
        .sum();
    let expected = hole * hole * dni * d.z;
    assert_close(
        "beam power on the floor, W",
        power,
        expected,
        0.04 * expected,
    );
    // The leaf under each point of a 0.1 m grid on the floor more than 1 m (two elements of
    // the interreflection mesh) outside the footprint receives nothing.
    let mut checked = 0;
    for i in 0..100 {
        for j in 0..100 {
            let p = DVec3::new(0.05 + 0.1 * i as f64, 0.05 + 0.1 * j as f64, 0.0);
            if outside(p) < 1.0 {
                continue;
            }
            let e = leaf_value(&r.hierarchy, &r.direct.sun, &scene, p - scene.origin);
            assert!(
                e.x == 0.0,
                "{} W/m² of sun at {p}, {:.2} m outside",
                e.x,
                outside(p)
            );
            checked += 1;
        }
    }
    assert!(checked > 9000, "{checked} points");
}

/// The value of the floor leaf (triangle 0 or 1) containing `p` (scene frame).
fn leaf_value(
    h: &daystep::hierarchy::Hierarchy,
    v: &[Rgb],
    scene: &daystep::scene::Scene,
    p: DVec3,
) -> Rgb {
    for tri in 0..2u32 {
        let t = scene.triangles[tri as usize].v;
        // The floor lies in z = const: 2-D barycentrics, unclamped, to pick the triangle.
        let (a, b, c) = (t[0].truncate(), t[1].truncate(), t[2].truncate());
        let q = p.truncate();
        let den = (b - a).perp_dot(c - a);
        let b1 = (q - a).perp_dot(c - a) / den;
        let b2 = (b - a).perp_dot(q - a) / den;
        let b = [1.0 - b1 - b2, b1, b2];
        if b.iter().any(|&x| x < -1e-9) {
            continue;
        }
        let (mut i, mut b) = (tri, b);
        while let Some(fc) = h.elements[i as usize].first_child {
            i = fc + daystep::hierarchy::child_of(&mut b) as u32;
        }
        return v[i as usize];
    }
    panic!("{p} is not on the floor");
}

/// Regression (c9c6915): a few samples of a wide sky node all missed a thin band of sky
/// (between an obstruction and a window head), and the band's light was lost. A black
/// closed room with a 0.1 m × 9 m slit 3 m above the floor sensors (1.9° wide, 112° long)
/// under a uniform sky, which keeps the sky's nodes large: E = π L F(point → slit).
#[test]
fn a_thin_band_of_sky_is_not_missed() {
    let (w, l) = (0.1, 10.0);
    let (x0, x1, y0, y1) = (5.0 - w / 2.0, 5.0 + w / 2.0, 0.5, 9.5);
    let mut b = Builder::new();
    let black = b.material("black", 0.0, 0.0);
    b.hrect(0.0, 10.0, 0.0, 10.0, 0.0, true, black);
    b.hrect_with_hole((0.0, 10.0, 0.0, 10.0), (x0, x1, y0, y1), 3.0, false, black);
    b.walls_inward(0.0, 10.0, 0.0, 10.0, 0.0, 3.0, black);
    let points = [DVec3::new(5.0, 5.0, 0.0), DVec3::new(5.3, 3.0, 0.0)];
    for p in points {
        b.sensor(p, DVec3::Z);
    }
    let scene = b.build();
    let r = run(
        &scene,
        &sky_of(Some(Box::new(Uniform(l))), None, 0.0),
        &Quality::default(),
    );
    for (got, p) in r.sensors.iter().zip(points) {
        // The slit by superposition of corner rectangles, signed by side.
        let corner = |x: f64, y: f64| x.signum() * y.signum() * f_parallel(x.abs(), y.abs(), 3.0);
        let (a0, a1, b0, b1) = (x0 - p.x, x1 - p.x, y0 - p.y, y1 - p.y);
        let f = corner(a1, b1) - corner(a0, b1) - corner(a1, b0) + corner(a0, b0);
        let expected = lux_of(PI * l * f);
        assert_close(
            &format!("slit above {p}"),
            got.lux,
            expected,
            0.02 * expected,
        );
        let err = (got.lux - expected).abs();
        assert!(got.lux_err >= err, "lux_err {} vs error {err}", got.lux_err);
    }
}
