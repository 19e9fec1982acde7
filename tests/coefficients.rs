//! Daylight coefficients against per-step forward solves, on two clear and two overcast
//! days of the bundled weather file, hourly and at 15-minute steps: the sky part (sky and
//! ground nodes, direct and interreflected) is the same linear system read in another
//! order, so equal within 1e-4 relative once both solve tightly (and the interreflected
//! part within the rounding of the held responses, `RESPONSE_ROUNDOFF`); the sun's interreflected
//! part is interpolated on the sun grid, and the stated interpolation error must cover
//! its difference from the forward solve at its snapped sun; the stated error of whole
//! steps must cover the difference at ≥ 95 % of lit sensor-steps. The exact comparisons
//! solve every sky node (`indirect_depth` beyond the cut's); the preset's coefficients,
//! whose deep nodes take their ancestors' interreflected rows, must be covered by their
//! stated error, sky part and whole steps alike.
//!
//! `DAYSTEP_COEFFICIENTS_FULL=1` runs it on every sensor of the office at `default`
//! (minutes; for the closing figures), and with `DAYSTEP_COEFFICIENTS_SCENE=scene.toml`
//! on another scene; CI runs every 11th sensor of the office at `draft`.

use chrono::{Datelike, Duration, NaiveDate};
use daystep::cache::Store;
use daystep::radiosity::coefficients::RESPONSE_ROUNDOFF;
use daystep::scene::Scene;
use daystep::sequence::sky::build_sky;
use daystep::sequence::{Engine, EngineOptions, Quality, Report, SkySpec, StepTime};
use daystep::site::solar_position::solar_position;
use daystep::sky::Sky;
use daystep::weather::{read_weather, WeatherRecord};
use std::path::Path;
use std::sync::atomic::AtomicBool;

fn office(dir: &Path, every: usize) -> Scene {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    for f in ["scene.toml", "office.obj", "office.mtl"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    let pts = std::fs::read_to_string(src.join("office.pts")).unwrap();
    let few: String = pts
        .lines()
        .step_by(every)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.join("office.pts"), few).unwrap();
    Scene::load(&dir.join("scene.toml")).unwrap()
}

/// The two days with the most and the two with the least direct-normal energy (among days
/// with daylight), in date order.
fn days(records: &[WeatherRecord]) -> Vec<NaiveDate> {
    let mut by: std::collections::BTreeMap<NaiveDate, (f64, f64)> = Default::default();
    for r in records {
        let e = by.entry(r.time.date()).or_default();
        e.0 += r.dni;
        e.1 += r.dhi;
    }
    let mut v: Vec<(NaiveDate, f64)> = by
        .into_iter()
        .filter(|(_, (_, dhi))| *dhi > 500.0)
        .map(|(d, (dni, _))| (d, dni))
        .collect();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let mut out = vec![v[0].0, v[1].0, v[v.len() - 1].0, v[v.len() - 2].0];
    out.sort();
    out
}

/// The sky of `spec` at `at`, split into its sky part (sky and ground glow, no sun) and
/// its sun part (the sun alone).
fn split_sky(scene: &Scene, at: &StepTime, spec: &SkySpec) -> (Sky, Sky) {
    let sun = solar_position(at.utc, &scene.site);
    let mut sky = build_sky(spec, &sun, at.local.ordinal(), scene.ground_reflectance).unwrap();
    let mut sun_only = Sky::none();
    sun_only.sun = sky.sun.take();
    (sky, sun_only)
}

#[test]
fn daylight_coefficients_equal_forward_solves_within_their_stated_errors() {
    let full = std::env::var_os("DAYSTEP_COEFFICIENTS_FULL").is_some();
    let d = tempfile::tempdir().unwrap();
    let every = std::env::var("DAYSTEP_COEFFICIENTS_EVERY")
        .ok()
        .and_then(|v| v.parse().ok());
    // `DAYSTEP_COEFFICIENTS_SCENE=scene.toml`: another scene (all its sensors).
    let scene = match std::env::var_os("DAYSTEP_COEFFICIENTS_SCENE") {
        Some(p) => Scene::load(Path::new(&p)).unwrap(),
        None => office(d.path(), every.unwrap_or(if full { 1 } else { 11 })),
    };
    let weather =
        read_weather(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw"))
            .unwrap();
    let mut q = Quality::preset(if full { "default" } else { "draft" }).unwrap();
    // `draft` solves every node: its sky at `default`'s depths, so that deep nodes take
    // their ancestors' interreflection as `default` does.
    let def = Quality::default();
    q.sky = def.sky;
    q.indirect_depth = def.indirect_depth;
    if let Some(g) = std::env::var("DAYSTEP_SUN_GRID")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        q.sun_grid_deg = g;
    }
    // Both sides solve far below the 1e-4 the comparison allows.
    q.transport.tolerance = 1e-7;
    q.transport.max_sweeps = 5000;
    let chosen = days(&weather.records);
    // Hourly records, and each hour again at 15-minute steps (the record's irradiance).
    let mut steps: Vec<(StepTime, SkySpec)> = Vec::new();
    for r in weather
        .records
        .iter()
        .filter(|r| chosen.contains(&r.time.date()))
    {
        if r.dhi <= 0.0 && r.dni <= 0.0 {
            continue;
        }
        let spec = SkySpec::Perez {
            dni: r.dni,
            dhi: r.dhi,
            dew_point_c: r.dew_point_c,
        };
        for m in [0, 15, 30, 45, 60] {
            let utc = r.utc(&scene.site) - Duration::minutes(m);
            if solar_position(utc, &scene.site).altitude_deg() <= 0.0 {
                continue;
            }
            let at = StepTime {
                utc,
                local: r.time - Duration::minutes(m),
            };
            steps.push((at, spec.clone()));
        }
    }
    let store = Store::disabled();
    let opts = EngineOptions::default();
    let forward = Engine::new(&scene, &q, &store, &opts);
    let every_node = Quality {
        indirect_depth: u32::MAX,
        ..q
    };
    let mut dc = Engine::new(&scene, &every_node, &store, &opts);
    let seen = std::sync::Mutex::new(Vec::new());
    assert!(
        dc.prepare(
            &steps,
            &|d, t| seen.lock().unwrap().push((d, t)),
            &AtomicBool::new(false),
        )
        .unwrap(),
        "the office takes daylight coefficients"
    );
    // Progress counts every direction in every sensor block, from 0 to all, never back.
    let seen = seen.into_inner().unwrap();
    let st = dc.coefficient_stats().unwrap();
    let passes = st.computed * scene.sensors.len().div_ceil(st.block_sensors);
    assert!(passes > 0);
    assert_eq!(seen.first(), Some(&(0, passes)));
    assert_eq!(seen.last(), Some(&(passes, passes)));
    assert!(seen
        .windows(2)
        .all(|w| w[0].0 <= w[1].0 && w[1].1 == passes));
    let mut inherit = Engine::new(&scene, &q, &store, &opts);
    assert!(inherit
        .prepare(&steps, &|_, _| {}, &AtomicBool::new(false))
        .unwrap());
    let inherited = inherit.coefficient_stats().unwrap().indirect_from_ancestors;
    assert!(
        inherited > 0,
        "some nodes are deeper than {}",
        q.indirect_depth
    );
    assert_eq!(forward.interreflection(), "forward");
    assert_eq!(dc.interreflection(), "daylight coefficients");

    let (mut sky_worst, mut sky_n) = (0.0f64, 0);
    let (mut sun_n, mut sun_covered, mut sun_worst_ratio) = (0, 0, 0.0f64);
    let (mut all_n, mut all_covered) = (0, 0);
    let (mut anc_n, mut anc_covered) = (0, 0);
    let mut anc_rel: Vec<f64> = Vec::new();
    let mut interp_rel: Vec<f64> = Vec::new();
    let mut ratios: Vec<f64> = Vec::new();
    for (at, spec) in &steps {
        let (sky, sun) = split_sky(&scene, at, spec);
        let f = forward.step_sky(&sky, None, false, Report::default(), None);
        let c = dc.step_sky(&sky, None, false, Report::default(), None);
        let h = inherit.step_sky(&sky, None, false, Report::default(), None);
        for ((a, b), i) in c.sensors.iter().zip(&f.sensors).zip(&h.sensors) {
            assert_eq!(a.lux_sky, i.lux_sky, "the direct light is every node's own");
            if b.lux > 10.0 {
                anc_n += 1;
                if (i.lux - b.lux).abs() <= i.lux_err {
                    anc_covered += 1;
                }
                anc_rel.push((i.lux - b.lux).abs() / b.lux);
            }
            assert!((a.lux_sky - b.lux_sky).abs() <= 1e-5 * b.lux_sky.abs() + 1e-9);
            if b.lux > 1.0 {
                sky_n += 1;
                // Beyond the responses' rounding, which the stated error carries.
                let beyond = ((a.lux - b.lux).abs() - RESPONSE_ROUNDOFF * b.lux_indirect).max(0.0);
                sky_worst = sky_worst.max(beyond / b.lux);
            }
        }
        if sun.sun.is_some() {
            let f = forward.step_sky(&sun, None, false, Report::default(), None);
            let c = dc.step_sky(&sun, None, false, Report::default(), None);
            for ((a, b), e) in c
                .sensors
                .iter()
                .zip(&f.sensors)
                .zip(&c.sun_interpolation_err)
            {
                // Direct sun: the same computation, summed in another order.
                assert!(
                    (a.lux_sun - b.lux_sun).abs() <= 1e-9 * b.lux_sun.abs(),
                    "{} vs {}",
                    a.lux_sun,
                    b.lux_sun
                );
                if b.lux_indirect > 1.0 {
                    sun_n += 1;
                    let diff = (a.lux_indirect - b.lux_indirect).abs();
                    // 1e-4: the solves' own difference; then the responses' rounding.
                    let slack = (1e-4 + RESPONSE_ROUNDOFF) * b.lux_indirect;
                    if diff <= e + slack {
                        sun_covered += 1;
                    }
                    sun_worst_ratio = sun_worst_ratio.max(diff / (e + slack));
                    interp_rel.push(diff / b.lux_indirect);
                    ratios.push(diff / e.max(1e-12));
                }
            }
        }
        // Whole steps at the run's tolerance: the stated error covers the difference.
        let spec_sky = {
            let sun = solar_position(at.utc, &scene.site);
            build_sky(spec, &sun, at.local.ordinal(), scene.ground_reflectance).unwrap()
        };
        let f = forward.step_sky(&spec_sky, None, false, Report::default(), None);
        let c = inherit.step_sky(&spec_sky, None, false, Report::default(), None);
        for (a, b) in c.sensors.iter().zip(&f.sensors) {
            if b.lux > 10.0 {
                all_n += 1;
                if (a.lux - b.lux).abs() <= a.lux_err {
                    all_covered += 1;
                }
            }
        }
    }
    interp_rel.sort_by(f64::total_cmp);
    anc_rel.sort_by(f64::total_cmp);
    ratios.sort_by(f64::total_cmp);
    let pct = |v: &[f64], p: f64| {
        v.get(((v.len() as f64 * p) as usize).min(v.len().max(1) - 1))
            .copied()
            .unwrap_or(0.0)
    };
    eprintln!(
        "{} steps on {:?}: sky part worst relative difference {sky_worst:.2e} over {sky_n} sensor-steps; \
         sun interreflection: {sun_covered}/{sun_n} within the stated interpolation error (worst {sun_worst_ratio:.2} of it), \
         relative difference median {:.2e} p95 {:.2e} max {:.2e}, difference / stated p50 {:.2} p90 {:.2} p95 {:.2} p99 {:.2}; whole steps: lux_err covers {all_covered}/{all_n}",
        steps.len(),
        chosen,
        pct(&interp_rel, 0.5),
        pct(&interp_rel, 0.95),
        interp_rel.last().copied().unwrap_or(0.0),
        pct(&ratios, 0.5),
        pct(&ratios, 0.9),
        pct(&ratios, 0.95),
        pct(&ratios, 0.99),
    );
    eprintln!(
        "sky part with {inherited} nodes' interreflection from ancestors: relative difference \
         median {:.2e} p95 {:.2e} max {:.2e}; lux_err covers {anc_covered}/{anc_n}",
        pct(&anc_rel, 0.5),
        pct(&anc_rel, 0.95),
        anc_rel.last().copied().unwrap_or(0.0),
    );
    assert!(
        anc_covered as f64 >= 0.95 * anc_n as f64,
        "ancestors: {anc_covered}/{anc_n}"
    );
    assert!(sky_n > 100 && sun_n > 50 && all_n > 100);
    assert!(sky_worst <= 1e-4, "sky part {sky_worst:.2e}");
    assert!(
        sun_covered as f64 >= 0.95 * sun_n as f64,
        "{sun_covered}/{sun_n}"
    );
    assert!(
        all_covered as f64 >= 0.95 * all_n as f64,
        "{all_covered}/{all_n}"
    );
}

#[test]
fn steps_summed_together_equal_steps_summed_alone() {
    // A day's steps by daylight coefficients in one call, in two orders, and one at a
    // time: each node's rows are read once for all the steps that use them, and a step's
    // values must not depend on which steps share its call (bit for bit).
    let d = tempfile::tempdir().unwrap();
    let scene = office(d.path(), 11);
    let weather =
        read_weather(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw"))
            .unwrap();
    let q = Quality::preset("draft").unwrap();
    let day = days(&weather.records)[3];
    let steps: Vec<(StepTime, SkySpec)> = weather
        .records
        .iter()
        .filter(|r| r.time.date() == day && r.dhi > 0.0)
        .map(|r| {
            let at = StepTime {
                utc: r.utc(&scene.site),
                local: r.time,
            };
            let spec = SkySpec::Perez {
                dni: r.dni,
                dhi: r.dhi,
                dew_point_c: r.dew_point_c,
            };
            (at, spec)
        })
        .filter(|(at, _)| solar_position(at.utc, &scene.site).altitude_deg() > 0.0)
        .collect();
    assert!(steps.len() >= 6, "a sunny day has daylight steps");
    let store = Store::disabled();
    let opts = EngineOptions::default();
    let mut dc = Engine::new(&scene, &q, &store, &opts);
    assert!(dc
        .prepare(&steps, &|_, _| {}, &AtomicBool::new(false))
        .unwrap());
    let skies: Vec<Sky> = steps
        .iter()
        .map(|(at, spec)| {
            let sun = solar_position(at.utc, &scene.site);
            build_sky(spec, &sun, at.local.ordinal(), scene.ground_reflectance).unwrap()
        })
        .collect();
    let bits = |s: &daystep::sequence::Step| -> Vec<(u64, u64)> {
        s.sensors
            .iter()
            .map(|v| (v.lux.to_bits(), v.lux_err.to_bits()))
            .collect()
    };
    let together = |order: &[usize]| -> Vec<Vec<(u64, u64)>> {
        let batch = order
            .iter()
            .map(|&i| (&skies[i], dc.cut(&skies[i], false), Report::default()))
            .collect();
        let mut out = vec![Vec::new(); skies.len()];
        for (&i, s) in order.iter().zip(dc.steps_by_coefficients(batch)) {
            out[i] = bits(&s);
        }
        out
    };
    let forward: Vec<usize> = (0..skies.len()).collect();
    let backward: Vec<usize> = forward.iter().rev().copied().collect();
    let alone: Vec<Vec<(u64, u64)>> = forward.iter().map(|&i| together(&[i])[i].clone()).collect();
    assert_eq!(together(&forward), alone);
    assert_eq!(together(&backward), alone);
    assert!(alone
        .iter()
        .flatten()
        .any(|(lux, _)| f64::from_bits(*lux) > 100.0));
}
