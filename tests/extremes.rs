//! Stiff and extreme inputs, each with a defined, tested behaviour.

use crate::util::*;
use daystep::photometry::Rgb;
use daystep::scene::Scene;
use daystep::sequence::{run_instant, Quality, SkySpec};
use daystep::site::{direction_from_alt_az, parse_time, Site};
use daystep::sky::{cie, preetham, Sky};
use glam::DVec3;

fn open_point() -> Scene {
    let mut b = Builder::new();
    b.sensor(DVec3::ZERO, DVec3::Z);
    b.build()
}

#[test]
fn sun_a_tenth_of_a_degree_above_and_below_the_horizon() {
    let scene = open_point();
    let (dhi, dni) = (20.0, 300.0);
    let up = cie::sky(
        cie::CieSkyType::General(12),
        dhi,
        dni,
        direction_from_alt_az(0.1, 90.0),
        0.2,
    )
    .unwrap();
    let r = run(&scene, &up, &Quality::default());
    let s = r.sensors[0];
    // Horizontal sun illuminance: E_n · sin(altitude), 179 lm/W for CIE skies.
    let expected = lux_of(dni * 0.1f64.to_radians().sin());
    assert_close("sun at +0.1°", s.lux_sun, expected, 1e-6 * expected);
    assert!(s.lux.is_finite() && s.lux_err.is_finite());
    let down = cie::sky(
        cie::CieSkyType::General(12),
        dhi,
        dni,
        direction_from_alt_az(-0.1, 90.0),
        0.2,
    )
    .unwrap();
    assert!(
        down.sun.is_none(),
        "a sun below the horizon is not a source"
    );
    let r = run(&scene, &down, &Quality::default());
    assert_eq!(r.sensors[0].lux_sun, 0.0);
    assert!(r.sources.iter().all(|s| !s.is_sun()));
    // The sky itself stays normalised to DHI.
    assert_close(
        "sky at -0.1°",
        r.sensors[0].lux_sky,
        lux_of(dhi),
        0.01 * lux_of(dhi),
    );
}

fn polar_scene() -> Scene {
    let mut s = open_point();
    s.site = Site {
        latitude: 78.22,
        longitude: 15.65,
        utc_offset_h: 1.0,
        elevation_m: 0.0,
    };
    s
}

#[test]
fn polar_day_has_a_midnight_sun_and_polar_night_is_skipped() {
    let scene = polar_scene();
    let spec = SkySpec::Perez {
        dni: 300.0,
        dhi: 60.0,
        dew_point_c: None,
    };
    let q = Quality::default();
    let (utc, local) = parse_time("2024-06-21T00:00", 1.0).unwrap();
    let r = run_instant(&scene, utc, local, &spec, &q).unwrap();
    // Midnight sun at 78.2°N: altitude ≈ δ − (90° − φ) = 23.44 − 11.78 ≈ 11.7°.
    assert!(
        (r.report.sun.altitude_deg - 11.7).abs() < 0.5,
        "{}",
        r.report.sun.altitude_deg
    );
    assert!(r.report.sun.used && r.sensors[0].lux_sun > 0.0);
    let (utc, local) = parse_time("2024-12-21T12:00", 1.0).unwrap();
    let r = run_instant(&scene, utc, local, &spec, &q).unwrap();
    assert!(r.report.sun.altitude_deg < -10.0);
    assert_eq!(r.sensors[0].lux, 0.0);
    assert_eq!(r.sensors[0].lux_err, 0.0);
    assert!(
        r.report.skipped.iter().any(|s| s.contains("sun")),
        "{:?}",
        r.report.skipped
    );
}

#[test]
fn turbidity_outside_the_fit_is_clamped_with_a_warning() {
    let scene = open_point();
    let sun = direction_from_alt_az(40.0, 180.0);
    for (t, clamp) in [(1.5, 2.0), (12.0, 10.0)] {
        let s = preetham::sky(t, sun, 0.2).unwrap();
        assert!(
            s.warnings
                .iter()
                .any(|w| w.to_lowercase().contains("turbidity")),
            "T={t}: {:?}",
            s.warnings
        );
        let c = preetham::sky(clamp, sun, 0.2).unwrap();
        let (a, b) = (
            run(&scene, &s, &Quality::default()),
            run(&scene, &c, &Quality::default()),
        );
        assert!(a.sensors[0].lux.is_finite() && a.sensors[0].lux > 0.0);
        assert_eq!(
            a.sensors[0].lux, b.sensors[0].lux,
            "T={t} equals the clamped T={clamp}"
        );
    }
    assert!(preetham::sky(f64::NAN, sun, 0.2).is_err());
}

#[test]
fn zero_irradiance_and_empty_sky_give_exact_zeros() {
    let scene = open_point();
    let (utc, local) = parse_time("2024-06-21T12:00", 0.0).unwrap();
    let r = run_instant(
        &scene,
        utc,
        local,
        &SkySpec::Perez {
            dni: 0.0,
            dhi: 0.0,
            dew_point_c: None,
        },
        &Quality::default(),
    )
    .unwrap();
    assert_eq!((r.sensors[0].lux, r.sensors[0].lux_err), (0.0, 0.0));
    let r = run(&scene, &Sky::none(), &Quality::default());
    assert_eq!(r.sensors[0].lux, 0.0);
    assert!(r.sources.is_empty());
    assert!(r.report.skipped.iter().any(|s| s.contains("emits nothing")));
}

#[test]
fn a_sliver_triangle_changes_nothing_measurable() {
    let build = |sliver: bool| {
        let mut b = Builder::new();
        let m = b.material("grey", 0.5, 0.0);
        b.hrect(-1.0, 1.0, 2.0, 3.0, 2.0, false, m); // a small overhang to the north
        if sliver {
            // 1e-10 m²: base 1 m, height 2e-10 m, right above the sensor.
            b.input.triangles.push(daystep::scene::Triangle {
                v: [
                    DVec3::new(-0.5, 0.0, 1.0),
                    DVec3::new(0.5, 0.0, 1.0),
                    DVec3::new(0.0, 2e-10, 1.0),
                ],
                material: m,
                group: 0,
            });
        }
        b.sensor(DVec3::ZERO, DVec3::Z);
        b.build()
    };
    let sky = sky_of(Some(Box::new(Uniform(10.0))), None, 1.0);
    let (with, without) = (build(true), build(false));
    assert!((with.triangles.last().unwrap().area() - 1e-10).abs() < 1e-12);
    let (a, b) = (
        run(&with, &sky, &Quality::default()),
        run(&without, &sky, &Quality::default()),
    );
    let (la, lb) = (a.sensors[0].lux, b.sensors[0].lux);
    assert!(
        la.is_finite() && (la - lb).abs() <= 1e-6 * lb + a.sensors[0].lux_err,
        "{la} vs {lb}"
    );
    assert!(a.direct.sky.iter().all(|e| e.is_finite()));
}

#[test]
fn a_scene_a_million_metres_from_the_origin_gives_the_same_answer() {
    let build = |offset: DVec3| {
        let mut b = Builder::new();
        let m = b.material("black", 0.0, 0.0);
        let o = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) + offset;
        b.quad(
            [
                o(0.0, 0.0, 3.0),
                o(0.0, 4.0, 3.0),
                o(4.0, 4.0, 3.0),
                o(4.0, 0.0, 3.0),
            ],
            m,
        ); // roof, facing down
        b.quad(
            [
                o(0.0, 0.0, 0.0),
                o(0.0, 0.0, 3.0),
                o(4.0, 0.0, 3.0),
                o(4.0, 0.0, 0.0),
            ],
            m,
        ); // south wall
        b.sensor(o(2.0, 2.0, 0.8), DVec3::Z);
        b.sensor(o(2.0, -0.5, 0.8), DVec3::new(0.0, -1.0, 0.0));
        b.build()
    };
    let sky = cie::sky(
        cie::CieSkyType::General(12),
        100.0,
        600.0,
        direction_from_alt_az(35.0, 150.0),
        0.2,
    )
    .unwrap();
    let near = run(&build(DVec3::ZERO), &sky, &Quality::default());
    let far = run(
        &build(DVec3::new(1e6, -1e6, 0.0)),
        &sky,
        &Quality::default(),
    );
    for (a, b) in near.sensors.iter().zip(&far.sensors) {
        assert!(
            (a.lux - b.lux).abs() <= 1e-6 * a.lux.max(1.0),
            "{} vs {}",
            a.lux,
            b.lux
        );
    }
    assert_eq!(
        near.report.counts.elements_after,
        far.report.counts.elements_after
    );
}

#[test]
fn non_finite_geometry_is_an_input_error() {
    let mut b = Builder::new();
    let m = b.material("grey", 0.5, 0.0);
    b.input.triangles.push(daystep::scene::Triangle {
        v: [DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y],
        material: m,
        group: 0,
    });
    let e = Scene::from_model(std::path::Path::new("x.obj"), b.input).unwrap_err();
    assert!(
        matches!(e, daystep::Error::Input { .. }) && e.to_string().contains("x.obj"),
        "{e}"
    );
    let _ = Rgb::ZERO;
}
