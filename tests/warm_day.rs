//! Warm-started interreflection over a whole clear day on the sample office: every
//! warm-started step (global-line operator, each step started from the previous one)
//! agrees with a cold solve of the same step on an independent operator (other line
//! directions, other sensor rays, twice the directions) within their stated errors, with
//! no drift over 96 fifteen-minute steps; and the warm steps sweep less than cold ones.

use daystep::cache::Store;
use daystep::photometry::{lux, Rgb};
use daystep::radiosity::{Transport, TransportParams, TransportState};
use daystep::scene::Scene;
use daystep::sequence::{Engine, EngineOptions, Quality, Report};
use daystep::site::solar_position::solar_position;
use daystep::sky::{cie, Sky};
use std::path::Path;

/// A clear day: CIE type 12 with irradiances that grow with the sun's altitude.
fn clear_sky(scene: &Scene, minutes: i64) -> Sky {
    let local = chrono::NaiveDate::from_ymd_opt(2024, 6, 21)
        .unwrap()
        .and_hms_opt(0, 0, 0)
        .unwrap()
        + chrono::TimeDelta::minutes(minutes);
    let utc =
        (local - chrono::TimeDelta::minutes((scene.site.utc_offset_h * 60.0) as i64)).and_utc();
    let sun = solar_position(utc, &scene.site);
    let s = sun.altitude_deg().to_radians().sin();
    if s <= 0.0 {
        return Sky::none();
    }
    cie::sky(
        cie::CieSkyType::General(12),
        20.0 + 100.0 * s,
        900.0 * s.powf(0.3),
        sun.direction(),
        0.2,
    )
    .unwrap()
}

fn sum(d: &daystep::transfer::DirectIrradiance) -> Vec<Rgb> {
    d.sun.iter().zip(&d.sky).map(|(a, b)| *a + *b).collect()
}

#[test]
fn warm_started_day_stays_within_stated_error_of_cold_solves() {
    let scene =
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/scene.toml"))
            .unwrap();
    let q = Quality::preset("draft").unwrap();
    let warm_p = TransportParams {
        directions: 512,
        resolution: 256,
        ..TransportParams::default()
    };
    let cold_p = TransportParams {
        directions: 1024,
        seed: 77,
        ..warm_p
    };
    let (tw, tc) = (
        Transport::build(&scene, &scene.sensors, &warm_p),
        Transport::build(&scene, &scene.sensors, &cold_p),
    );
    // The run's own steps give each step's direct light on the refined elements.
    let store = Store::disabled();
    let engine = Engine::new(&scene, &q, &store, &EngineOptions::default());
    let mut state: Option<TransportState> = None;
    let (mut compared, mut within, mut worst) = (0usize, 0usize, 0.0f64);
    let (mut warm_sweeps, mut cold_sweeps, mut steps) = (0u32, 0u32, 0usize);
    for step in 0..96 {
        let sky = clear_sky(&scene, 15 * step);
        if sky.sun.is_none() && sky.distribution.is_none() {
            continue; // night: nothing to solve (the annual loop skips it too)
        }
        let step = engine.step_sky(&sky, None, true, Report::default(), None);
        let (hierarchy, direct) = step.elements.expect("asked for");
        let e = sum(&direct);
        let (warm, rw) = tw.solve(&tw.mesh.average_onto(&hierarchy, &e), state.as_ref());
        let (cold, rc) = tc.solve(&tc.mesh.average_onto(&hierarchy, &e), None);
        if rw.warm {
            warm_sweeps += rw.sweeps;
            // The same step cold on the warm operator, for the sweep count only.
            cold_sweeps += tw
                .solve(&tw.mesh.average_onto(&hierarchy, &e), None)
                .1
                .sweeps;
            steps += 1;
        }
        assert!(rw.iteration_error <= warm_p.tolerance && rc.iteration_error <= cold_p.tolerance);
        for (a, b) in tw.sensors(&warm).iter().zip(&tc.sensors(&cold)) {
            let (x, y) = (lux(a.irradiance), lux(b.irradiance));
            if y < 1.0 {
                continue;
            }
            // Stated errors: 1σ noise of each plus each one's discretisation estimate.
            let sigma = (lux(a.std_err).powi(2) + lux(b.std_err).powi(2)).sqrt();
            let allowed = 3.0 * sigma + lux(a.discretisation) + lux(b.discretisation);
            compared += 1;
            within += usize::from((x - y).abs() <= allowed);
            worst = worst.max((x - y).abs() / allowed.max(1e-9));
        }
        state = Some(warm);
    }
    eprintln!(
        "warm day: {steps} warm steps, {compared} sensor comparisons, {within} within 3σ + discretisation, worst {worst:.2}× the allowance; sweeps warm {warm_sweeps} vs cold {cold_sweeps}"
    );
    assert!(steps >= 40, "a June day has more than 10 h of daylight");
    // 3σ of a t-distribution with 3 degrees of freedom covers about 94 %.
    assert!(
        within as f64 >= 0.9 * compared as f64,
        "{within}/{compared}"
    );
    assert!(worst < 3.0, "no step drifts far: worst {worst}");
    assert!(warm_sweeps < cold_sweeps);
}
