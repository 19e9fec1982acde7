//! `annual --leed` on a side-lit room with a south and an east window in two aperture
//! groups and a static north window: the light paths sum to the room with every window
//! open (each window open in one path only), the blinds close only what the
//! 2 % rule needs, sDA with blinds is at most sDA with blinds open, and with a shade
//! transmittance of 0 a closed group's light is gone from the DA count. EN 17037 refuses a
//! part of a year before any work.

use daystep::cache::Store;
use daystep::scene::imported::ApertureGroup;
use daystep::scene::synthetic::{Face, Opening, Rect, RoomMaterials, SceneBuilder};
use daystep::scene::Scene;
use daystep::sequence::annual::{run_annual, AnnualOptions, RunControl};
use daystep::sequence::Quality;
use daystep::weather::read_weather;
use glam::{DVec2, DVec3};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// A 6 × 4 × 3 m room with a south, an east and a north window, 24 sensors at 0.8 m, at
/// the sample office's site; the south and east windows' glazing materials are groups
/// "south" (shade τ 0) and "east", the north window is static (in no group).
fn room(weather_site: daystep::site::Site) -> Scene {
    let mut b = SceneBuilder::new();
    let m = RoomMaterials {
        floor: b.add_opaque("floor", 0.2),
        walls: b.add_opaque("wall", 0.5),
        ceiling: b.add_opaque("ceiling", 0.7),
    };
    let south = b.add_glazing("glass_s", 0.6);
    let east = b.add_glazing("glass_e", 0.6);
    let north = b.add_glazing("glass_n", 0.6);
    let openings = [
        Opening {
            face: Face::North,
            rect: Rect::new([2.0, 4.0], [1.2, 2.2]),
            glazing: Some(north),
        },
        Opening {
            face: Face::South,
            rect: Rect::new([1.0, 5.0], [0.9, 2.4]),
            glazing: Some(south),
        },
        Opening {
            face: Face::East,
            rect: Rect::new([1.0, 3.0], [0.9, 2.4]),
            glazing: Some(east),
        },
    ];
    b.add_room("room", DVec3::ZERO, DVec3::new(6.0, 4.0, 3.0), m, &openings);
    b.add_sensor_grid(DVec2::new(0.5, 0.5), DVec2::new(5.5, 3.5), 0.8, 1.0);
    b.set_site(weather_site);
    let mut scene = b.build("<two-window room>").unwrap();
    let group = |id: &str, mat: &str, t: Option<f64>| ApertureGroup {
        identifier: id.into(),
        members: vec!["room".into()],
        states: vec!["default".into(), "shade".into()],
        shade_transmittance: t,
        materials: vec![mat.into()],
    };
    scene.imported.aperture_groups = vec![
        group("south", "glass_s", Some(0.0)),
        group("east", "glass_e", None),
    ];
    scene
}

/// Rows of an illuminance-style CSV (time, then one value per column).
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut times = Vec::new();
    let mut rows = Vec::new();
    for l in text.lines().skip(1) {
        let mut f = l.split(',');
        times.push(f.next().unwrap().to_string());
        rows.push(f.map(|x| x.parse::<f64>().unwrap()).collect());
    }
    (times, rows)
}

#[test]
fn blinds_close_what_the_two_percent_rule_needs_and_paths_sum_to_the_room() {
    let d = tempfile::tempdir().unwrap();
    let office = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw");
    let weather = read_weather(&office).unwrap();
    let scene = room(weather.site);
    let q = Quality::preset("draft").unwrap();
    let store = Store::disabled();
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let date = |s| Some(chrono::NaiveDate::parse_from_str(s, "%Y-%m-%d").unwrap());
    // Low winter sun into the south window, morning sun into the east one.
    let opts = AnnualOptions {
        start: date("2021-12-17"),
        end: date("2021-12-21"),
        leed: true,
        ..AnnualOptions::default()
    };
    let out = d.path().join("out");
    let r = run_annual(&scene, &weather, &q, &store, &out, &opts, &control).unwrap();
    let c = r.compliance.expect("compliance report");
    assert_eq!(c.paths, ["__static_apertures__", "south", "east"]);
    assert!(c.paths_from_run.is_empty());

    let (times, main) = csv(&out.join("illuminance.csv"));
    let paths = ["__static_apertures__", "south", "east"];
    let total: Vec<Vec<Vec<f64>>> = paths
        .iter()
        .map(|p| csv(&out.join("paths").join(p).join("illuminance.csv")).1)
        .collect();
    let direct: Vec<Vec<Vec<f64>>> = paths
        .iter()
        .map(|p| csv(&out.join("paths").join(p).join("direct_sun.csv")).1)
        .collect();

    // The static path carries the north window's light.
    let static_max = total[0].iter().flatten().fold(0.0f64, |a, &b| a.max(b));
    assert!(
        static_max > 10.0,
        "static path reaches only {static_max} lx"
    );
    // The paths sum to the room with every window open: each window is open in one path
    // only (a group's path blacks the static window too, as honeybee's does). The runs
    // share their seed, so their Monte Carlo noise is mostly common; what differs is light
    // that meets another path's window (black in a path, specularly reflecting in the
    // room): a tenth of the stated error bounds it.
    let (mut num, mut den) = (0.0, 0.0);
    for (s, row) in main.iter().enumerate() {
        for (k, &m) in row.iter().enumerate() {
            let sum = total[0][s][k] + total[1][s][k] + total[2][s][k];
            num += (sum - m).powi(2);
            den += m * m;
        }
    }
    let rms = (num / den).sqrt();
    assert!(
        rms <= 0.1 * r.median_relative_err.max(0.05),
        "paths sum to the room within {rms:.4} RMS (stated median {:.4})",
        r.median_relative_err
    );

    let leed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("leed.json")).unwrap()).unwrap();
    let g = &leed["grids"][0];
    let sda = g["sda_pct"].as_f64().unwrap();
    assert!(sda <= g["sda_blinds_open_pct"].as_f64().unwrap() + 1e-9);

    // The schedule: at every occupied sun-up step it leaves compliant, at most 2 % of the
    // sensors see more than 1000 lx of direct sun through what stays open (south shaded
    // passes nothing, east shaded passes 5 %).
    let blinds = std::fs::read_to_string(out.join("leed_blinds.csv")).unwrap();
    let mut lines = blinds.lines();
    assert_eq!(lines.next(), Some("time,south,east"));
    let step_of: std::collections::HashMap<&str, usize> = times
        .iter()
        .enumerate()
        .map(|(i, t)| (t.as_str(), i))
        .collect();
    let sensors = main[0].len();
    let mut shaded_south = 0;
    let mut state = vec![None; times.len()];
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let s = step_of[f[0]];
        let (south, east) = (f[1] == "1", f[2] == "1");
        shaded_south += usize::from(south);
        state[s] = Some((south, east));
        let over = (0..sensors)
            .filter(|&k| {
                let e = direct[0][s][k]
                    + direct[1][s][k] * if south { 0.0 } else { 1.0 }
                    + direct[2][s][k] * if east { 0.05 } else { 1.0 };
                e > 1000.0
            })
            .count();
        assert!(
            over as f64 <= 0.02 * sensors as f64
                || g["hours_fail_to_comply"].as_f64().unwrap() > 0.0,
            "{}: {over} of {sensors} sensors over 1000 lx direct with the blinds as scheduled",
            f[0]
        );
    }
    assert!(
        shaded_south > 0,
        "December sun through the south window closes its blinds"
    );

    // DA per sensor from the paths and the schedule: a closed south window (τ 0) brings
    // nothing, a closed east one 5 %; the static path counts always.
    let occupied: Vec<usize> = times
        .iter()
        .enumerate()
        .filter(|(_, t)| {
            let h: u32 = t[11..13].parse().unwrap();
            (8..=17).contains(&h)
        })
        .map(|(i, _)| i)
        .collect();
    let (_, per) = {
        let text = std::fs::read_to_string(out.join("leed_sensors.csv")).unwrap();
        let rows: Vec<Vec<String>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect())
            .collect();
        ((), rows)
    };
    assert_eq!(per.len(), sensors);
    for (k, row) in per.iter().enumerate() {
        let da: f64 = row[2].parse().unwrap();
        let (mut lit, mut borderline) = (0, 0);
        for &s in &occupied {
            let (south, east) = state[s].unwrap_or((false, false));
            let e = total[0][s][k]
                + total[1][s][k] * if south { 0.0 } else { 1.0 }
                + total[2][s][k] * if east { 0.05 } else { 1.0 };
            lit += usize::from(e >= 300.0);
            borderline += usize::from((e - 300.0).abs() < 0.01);
        }
        let expect = lit as f64 / occupied.len() as f64 * 100.0;
        let step = 100.0 / occupied.len() as f64;
        assert!(
            (da - expect).abs() <= step * borderline as f64 + 1e-9,
            "sensor {k}: DA {da} against {expect} from the paths"
        );
    }
}

/// An interrupted `--leed` run, stopped while the light paths are prepared and again
/// after its first batch of days, resumes to the same bytes as one uninterrupted run:
/// the paths' rows of the resumed days are evaluated one step at a time, the others a
/// batch of steps at once, and both give the same bits.
#[test]
fn an_interrupted_leed_run_resumes_to_the_same_paths_and_numbers() {
    let d = tempfile::tempdir().unwrap();
    let office = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw");
    let weather = read_weather(&office).unwrap();
    let scene = room(weather.site);
    let q = Quality::preset("draft").unwrap();
    let store = Store::open(&d.path().join("cache"), daystep::cache::DEFAULT_MAX_BYTES);
    let date = |s| Some(chrono::NaiveDate::parse_from_str(s, "%Y-%m-%d").unwrap());
    // Twelve days: two batches of days.
    let opts = AnnualOptions {
        start: date("2021-12-10"),
        end: date("2021-12-21"),
        leed: true,
        ..AnnualOptions::default()
    };
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let one = d.path().join("one");
    let r = run_annual(&scene, &weather, &q, &store, &one, &opts, &control).unwrap();
    assert!(!r.interrupted);
    let stopped = d.path().join("stopped");
    // Progress reports count the paths while they are prepared (three, here), then the
    // run's 288 steps.
    for (stop_in_steps, resumed) in [(false, false), (true, false), (false, true)] {
        let stop = AtomicBool::new(false);
        let stop_at = |done: usize, total: usize| {
            if done > 0 && (total > 10) == stop_in_steps {
                stop.store(true, Ordering::SeqCst);
            }
        };
        let c = RunControl {
            stop: &stop,
            progress: &stop_at,
            coefficient_progress: &|_, _| {},
        };
        let control = if resumed { &control } else { &c };
        let r = run_annual(&scene, &weather, &q, &store, &stopped, &opts, control).unwrap();
        assert_eq!(r.interrupted, !resumed, "{r:?}");
        if stop_in_steps {
            assert!(r.computed > 0 && r.computed < 288, "{r:?}");
        }
        if resumed {
            assert!(r.resumed > 0, "{r:?}");
        }
    }
    for f in [
        "illuminance.csv",
        "leed.json",
        "leed_blinds.csv",
        "leed_sensors.csv",
        "paths/south/illuminance.csv",
        "paths/east/direct_sun.csv",
        "paths/__static_apertures__/illuminance.csv",
    ] {
        assert_eq!(
            std::fs::read(one.join(f)).unwrap(),
            std::fs::read(stopped.join(f)).unwrap(),
            "{f} after the resumes"
        );
    }
}

#[test]
fn en17037_on_part_of_a_year_is_refused_before_any_work() {
    let d = tempfile::tempdir().unwrap();
    let office = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw");
    let weather = read_weather(&office).unwrap();
    let scene = room(weather.site);
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let opts = AnnualOptions {
        start: Some(chrono::NaiveDate::from_ymd_opt(2021, 6, 1).unwrap()),
        en17037: true,
        ..AnnualOptions::default()
    };
    let out = d.path().join("out");
    let e = run_annual(
        &scene,
        &weather,
        &Quality::preset("draft").unwrap(),
        &Store::disabled(),
        &out,
        &opts,
        &control,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--en17037") && e.contains("8760"), "{e}");
    assert!(
        !out.join("illuminance.csv").exists(),
        "no work before the refusal"
    );
}

#[test]
fn the_binary_writes_the_contracts_files_and_runs_no_path_that_is_the_scene_itself() {
    // The office with its one glazing material as group "south": the south path is the
    // scene itself (taken from the run's own values), only the static path is run.
    let d = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    for f in ["office.obj", "office.mtl", "weather.epw"] {
        std::fs::copy(src.join(f), d.path().join(f)).unwrap();
    }
    // Every 33rd sensor (5): the files, not the numbers, are under test here.
    let pts = std::fs::read_to_string(src.join("office.pts")).unwrap();
    let few: String = pts.lines().step_by(33).map(|l| format!("{l}\n")).collect();
    std::fs::write(d.path().join("office.pts"), few).unwrap();
    let toml = std::fs::read_to_string(src.join("scene.toml")).unwrap()
        + "\n[aperture_groups.south]\nmaterials = [\"glass\"]\n";
    std::fs::write(d.path().join("scene.toml"), toml).unwrap();
    let out = d.path().join("out");
    let p = |f: &str| d.path().join(f).display().to_string();
    let o = crate::util::daystep(&[
        "annual",
        &p("scene.toml"),
        "--weather",
        &p("weather.epw"),
        "--start",
        "2021-06-21",
        "--end",
        "2021-06-21",
        "--quality",
        "draft",
        "--no-cache",
        "--leed",
        "--out",
        &out.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", crate::util::stderr(&o));
    let leed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("leed.json")).unwrap()).unwrap();
    for key in [
        "sda_pct",
        "ase_pct",
        "points",
        "hours_fail_to_comply",
        "grids",
    ] {
        assert!(leed.get(key).is_some(), "leed.json lacks {key}: {leed}");
    }
    assert_eq!(leed["grids"][0]["name"], "all sensors");
    let blinds = std::fs::read_to_string(out.join("leed_blinds.csv")).unwrap();
    assert_eq!(blinds.lines().next(), Some("time,south"));
    // 21 June: occupied 8:00-18:00, all sun-up: ten rows.
    assert_eq!(blinds.lines().count(), 1 + 10);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["compliance"]["paths_from_run"][0], "south");
    assert!(out
        .join("paths/__static_apertures__/illuminance.csv")
        .exists());
    assert!(!out.join("paths/south").exists());
}
