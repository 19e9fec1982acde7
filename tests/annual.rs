//! `daystep annual` end to end on the sample office (five sensors, draft quality): an
//! interrupted and resumed run (and one cut mid-line) writes the same bytes as an
//! uninterrupted one; three shards merged equal one run, and so do four shard processes
//! running at once over one cache folder; a day's steps agree with independent cold
//! instants within their stated errors.

use crate::util::DRAFT_STATED_ERROR_CAP;
use daystep::cache::{Store, DEFAULT_MAX_BYTES};
use daystep::scene::Scene;
use daystep::sequence::annual::{merge, run_annual, AnnualOptions, RunControl};
use daystep::sequence::instant::run_instant_cached;
use daystep::sequence::{Quality, SkySpec};
use daystep::weather::read_weather;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// The office with every 33rd sensor (5 sensors), written into `dir`.
fn small_office(dir: &Path) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    for f in ["scene.toml", "office.obj", "office.mtl", "weather.epw"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    let pts = std::fs::read_to_string(src.join("office.pts")).unwrap();
    let few: String = pts.lines().step_by(33).map(|l| format!("{l}\n")).collect();
    std::fs::write(dir.join("office.pts"), few).unwrap();
    dir.join("scene.toml")
}

fn date(s: &str) -> Option<chrono::NaiveDate> {
    Some(chrono::NaiveDate::parse_from_str(s, "%Y-%m-%d").unwrap())
}

fn opts(days: (&str, &str), shard: (u32, u32)) -> AnnualOptions {
    AnnualOptions {
        start: date(days.0),
        end: date(days.1),
        shard,
        ..AnnualOptions::default()
    }
}

fn read(dir: &Path, f: &str) -> Vec<u8> {
    std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(f).display()))
}

/// The office, its weather, the draft preset and a cache, all in `dir`.
fn setup(dir: &Path) -> (Scene, daystep::weather::Weather, Quality, Store) {
    let scene = Scene::load(&small_office(dir)).unwrap();
    let weather = read_weather(&dir.join("weather.epw")).unwrap();
    let store = Store::open(&dir.join("cache"), DEFAULT_MAX_BYTES);
    (scene, weather, Quality::preset("draft").unwrap(), store)
}

const OUTPUTS: [&str; 4] = [
    "illuminance.csv",
    "direct_sun.csv",
    "metrics.csv",
    "summary.json",
];

#[test]
fn resumed_and_sharded_runs_equal_one_run() {
    let d = tempfile::tempdir().unwrap();
    let (scene, weather, q, store) = setup(d.path());
    // The weather file's times are in 2021 (a TMY file without 29 February).
    let days = ("2021-06-01", "2021-06-10");
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let one = d.path().join("one");
    let r = run_annual(
        &scene,
        &weather,
        &q,
        &store,
        &one,
        &opts(days, (1, 1)),
        &control,
    )
    .unwrap();
    assert_eq!(r.steps, 240);
    assert!(r.night > 0 && r.sun_steps > 0);

    // Interrupted once two days are written (the stop flag, as Ctrl-C sets it; batches
    // are a day each on ten days), so that the kill inside the last row below leaves a
    // whole day to resume: a stop after the first day could leave that day alone, when
    // no worker had taken a second ...
    let stopped = d.path().join("stopped");
    let stop = AtomicBool::new(false);
    let stop_after_two_days = |done: usize, _: usize| {
        if done >= 48 {
            stop.store(true, Ordering::SeqCst);
        }
    };
    let c = RunControl {
        stop: &stop,
        progress: &stop_after_two_days,
        coefficient_progress: &|_, _| {},
    };
    let r1 = run_annual(
        &scene,
        &weather,
        &q,
        &store,
        &stopped,
        &opts(days, (1, 1)),
        &c,
    )
    .unwrap();
    assert!(r1.interrupted && r1.computed < 240, "{r1:?}");
    assert!(!stopped.join("illuminance.csv").exists());
    // ... and killed mid-line: cut the partial file inside its last row.
    let partial = stopped.join("illuminance.csv.partial");
    let bytes = std::fs::read(&partial).unwrap();
    std::fs::write(&partial, &bytes[..bytes.len() - 7]).unwrap();
    let r2 = run_annual(
        &scene,
        &weather,
        &q,
        &store,
        &stopped,
        &opts(days, (1, 1)),
        &control,
    )
    .unwrap();
    assert!(
        r2.resumed > 0 && r2.resumed < 240 && !r2.interrupted,
        "{r2:?}"
    );
    for f in OUTPUTS {
        assert_eq!(read(&one, f), read(&stopped, f), "{f} after resume");
    }

    // Three shards, merged.
    let shards: Vec<PathBuf> = (1..=3)
        .map(|k| {
            let out = d.path().join(format!("shard{k}"));
            run_annual(
                &scene,
                &weather,
                &q,
                &store,
                &out,
                &opts(days, (k, 3)),
                &control,
            )
            .unwrap();
            out
        })
        .collect();
    let merged = d.path().join("merged");
    merge(&shards, &merged, 60, &Default::default()).unwrap();
    // A missing shard is an error naming it, not a shorter series.
    let e = merge(
        &shards[1..],
        &d.path().join("short"),
        60,
        &Default::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("shard 1/3 is missing"), "{e}");
    for f in OUTPUTS {
        assert_eq!(read(&one, f), read(&merged, f), "{f} after merge");
    }

    // Stopped while the daylight coefficients are computed (a fresh cache, so they are),
    // before any step: an interrupted run with nothing written, which a rerun completes.
    let early = d.path().join("early");
    let fresh = Store::open(&d.path().join("cache-early"), DEFAULT_MAX_BYTES);
    let stop = AtomicBool::new(false);
    let passes = std::sync::Mutex::new(Vec::new());
    let stop_in_coefficients = |done: usize, total: usize| {
        passes.lock().unwrap().push((done, total));
        stop.store(true, Ordering::SeqCst);
    };
    let c = RunControl {
        stop: &stop,
        progress: &quiet,
        coefficient_progress: &stop_in_coefficients,
    };
    let run = |c: &RunControl| {
        let o = opts(days, (1, 1));
        run_annual(&scene, &weather, &q, &fresh, &early, &o, c).unwrap()
    };
    let r = run(&c);
    assert!(r.interrupted && r.computed == 0, "{r:?}");
    // It stopped inside the coefficients, not after them.
    let passes = passes.into_inner().unwrap();
    assert!(passes.iter().all(|&(d, t)| d < t), "{passes:?}");
    let r = run(&control);
    assert!(!r.interrupted && r.resumed == 0, "{r:?}");
    for f in OUTPUTS {
        assert_eq!(
            read(&one, f),
            read(&early, f),
            "{f} after a stop in the coefficients"
        );
    }
}

/// The cache counters of a run's `report.json`: (rebuilds, write failures, writes).
fn cache_counters(out: &Path) -> (u64, u64, u64) {
    let report: serde_json::Value = serde_json::from_slice(&read(out, "report.json")).unwrap();
    let c = &report["cache"];
    let n = |f: &str| {
        c[f].as_u64()
            .unwrap_or_else(|| panic!("cache.{f} in {report}"))
    };
    (n("rebuilds"), n("write_failures"), n("writes"))
}

/// The record files of a cache folder.
/// The record files in `cache`: (the cuts' unions, every other record). A cut union lists
/// the nodes of one run's steps, so each shard stores its own (`sequence::cuts`).
fn record_names(
    cache: &Path,
) -> (
    std::collections::BTreeSet<String>,
    std::collections::BTreeSet<String>,
) {
    std::fs::read_dir(cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".dsr"))
        .partition(|n| {
            let bytes = std::fs::read(cache.join(n)).unwrap();
            daystep::cache::Record::parse(&bytes)
                .is_ok_and(|r| r.key().kind == daystep::cache::KIND_CUTS)
        })
}

#[test]
fn four_concurrent_shard_processes_merge_to_one_run() {
    // What docs/cluster.md promises of a job array: four `annual --shard k/4` processes
    // started at once over one empty cache folder, merged with `daystep merge`, write the
    // bytes of one unsharded run that had a cache folder of its own.
    use std::process::{Command, Stdio};
    let t0 = std::time::Instant::now();
    let d = tempfile::tempdir().unwrap();
    let scene = small_office(d.path());
    let weather = d.path().join("weather.epw");
    let shared = d.path().join("shared-cache");
    let own = d.path().join("own-cache");
    // Five days: shard 1 gets the first and the fifth, shards 2 to 4 one each.
    let annual = |out: &Path, cache: &Path, shard: Option<String>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_daystep"));
        c.args(["--threads", "1", "annual"])
            .arg(&scene)
            .arg("--weather")
            .arg(&weather)
            .arg("--out")
            .arg(out)
            .arg("--cache")
            .arg(cache)
            .args([
                "--quality",
                "draft",
                "--start",
                "2021-06-01",
                "--end",
                "2021-06-05",
            ])
            .current_dir(d.path())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        if let Some(s) = shard {
            c.args(["--shard", &s]);
        }
        c.spawn().unwrap()
    };
    let shards: Vec<PathBuf> = (1..=4)
        .map(|k| d.path().join(format!("shard{k}")))
        .collect();
    let mut children: Vec<_> = shards
        .iter()
        .enumerate()
        .map(|(i, out)| annual(out, &shared, Some(format!("{}/4", i + 1))))
        .collect();
    let one = d.path().join("one");
    children.push(annual(&one, &own, None));
    for c in children {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let computed = t0.elapsed();
    let merged = d.path().join("merged");
    let mut args = vec!["merge".to_owned()];
    args.extend(shards.iter().map(|p| p.display().to_string()));
    args.extend(["--out".to_owned(), merged.display().to_string()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = crate::util::daystep(&args);
    assert!(o.status.success(), "{}", crate::util::stderr(&o));
    // The merge finds the scene through the shards' report.json: the one run's page.
    for f in OUTPUTS.iter().chain(&["report.html"]) {
        let (want, got) = (read(&one, f), read(&merged, f));
        if want != got {
            let (w, g) = (
                String::from_utf8_lossy(&want),
                String::from_utf8_lossy(&got),
            );
            let line = w.lines().zip(g.lines()).position(|(a, b)| a != b);
            let show = |t: &str| line.and_then(|i| t.lines().nth(i)).unwrap_or("").to_owned();
            panic!(
                "{f}: the merged shards differ from the one run at line {:?}: {:?} against {:?}",
                line.map(|i| i + 1),
                show(&g),
                show(&w)
            );
        }
    }
    // No shard ever read a partial record of another (a rebuild) or failed a write; the
    // shards together stored exactly the records the one run stored, byte for byte, all
    // valid, with no temporary file left.
    let mut writes = 0;
    for s in &shards {
        let (rebuilds, failures, w) = cache_counters(s);
        assert_eq!((rebuilds, failures), (0, 0), "{}", s.display());
        writes += w;
    }
    let v = daystep::cache::verify(&shared).unwrap();
    assert!(v.is_clean() && v.temp_files == 0, "{v:?}");
    let (shard_cuts, names) = record_names(&shared);
    let (own_cuts, own_names) = record_names(&own);
    assert_eq!(names, own_names);
    assert_eq!(
        (shard_cuts.len(), own_cuts.len()),
        (4, 1),
        "one cut union per run"
    );
    for n in &names {
        // Whichever shard's rename won, the record is the one the one run computed.
        assert!(read(&shared, n) == read(&own, n), "record {n} differs");
    }
    eprintln!(
        "4 shards + 1 run: {:.1} s, merge and checks {:.1} s; {} records, {writes} written by the shards",
        computed.as_secs_f64(),
        (t0.elapsed() - computed).as_secs_f64(),
        v.ok
    );
}

#[test]
fn a_day_agrees_with_independent_cold_instants() {
    let d = tempfile::tempdir().unwrap();
    let (scene, weather, q, store) = setup(d.path());
    let out = d.path().join("day");
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let days = ("2021-06-21", "2021-06-21");
    run_annual(
        &scene,
        &weather,
        &q,
        &store,
        &out,
        &opts(days, (1, 1)),
        &control,
    )
    .unwrap();
    let text = std::fs::read_to_string(out.join("illuminance.csv")).unwrap();
    // Independent instants: another seed (other line directions and sensor rays).
    let qi = q.with_seed(4242);
    let (mut compared, mut within) = (0, 0);
    for line in text.lines().skip(1) {
        let mut f = line.split(',');
        let time = f.next().unwrap();
        let values: Vec<f64> = f.map(|v| v.parse().unwrap()).collect();
        let rec = weather
            .records
            .iter()
            .find(|r| daystep::export::format_time(r.time) == time)
            .unwrap();
        if rec.dni + rec.dhi <= 0.0 {
            continue;
        }
        let utc = (rec.time - chrono::TimeDelta::hours(scene.site.utc_offset_h as i64)).and_utc();
        let spec = SkySpec::Perez {
            dni: rec.dni,
            dhi: rec.dhi,
            dew_point_c: rec.dew_point_c,
        };
        let r = run_instant_cached(&scene, utc, rec.time, &spec, &qi, &store).unwrap();
        for (a, s) in values.iter().zip(&r.sensors) {
            if s.lux < 10.0 {
                continue;
            }
            compared += 1;
            // The instant's stated error (noise + discretisation) covers both solves'
            // noise at about 1σ each: allow twice it. An inflated error bar would pass
            // that, so the bar itself is capped (see `DRAFT_STATED_ERROR_CAP`).
            assert!(
                s.lux_err <= DRAFT_STATED_ERROR_CAP * s.lux,
                "{time}: stated error {} lx of {} lx exceeds {DRAFT_STATED_ERROR_CAP}",
                s.lux_err,
                s.lux
            );
            within += usize::from((a - s.lux).abs() <= 2.0 * s.lux_err);
        }
    }
    eprintln!("day vs cold instants: {within}/{compared} within 2 × lux_err");
    assert!(compared >= 40, "{compared}");
    assert!(
        within as f64 >= 0.9 * compared as f64,
        "{within}/{compared}"
    );
}

#[test]
fn daylight_coefficients_agree_with_forward_solves_over_two_days() {
    // The same two days with per-step forward solves and with daylight coefficients (the
    // default): the sky part is the same linear system read in another order, the sun's
    // interreflection is interpolated on the sun grid (4° at draft). Whole annual runs, so
    // this also checks the planning of every step's nodes before the steps run.
    let d = tempfile::tempdir().unwrap();
    let (scene, weather, q, store) = setup(d.path());
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let run = |name: &str, coefficients: bool| {
        let out = d.path().join(name);
        let o = AnnualOptions {
            daylight_coefficients: coefficients,
            ..opts(("2021-03-20", "2021-03-21"), (1, 1))
        };
        let r = run_annual(&scene, &weather, &q, &store, &out, &o, &control).unwrap();
        let (_, rows) =
            daystep::export::read_illuminance_csv(&out.join("illuminance.csv")).unwrap();
        (r, rows)
    };
    let (rf, forward) = run("forward", false);
    let (rc, coefficients) = run("coefficients", true);
    assert_eq!(
        (rf.interreflection.as_str(), rc.interreflection.as_str()),
        ("forward", "daylight coefficients")
    );
    let c = rc.coefficients.expect("coefficient counters");
    assert!(c.nodes > 0 && c.sun_grid_vertices > 0);
    // Every node and vertex solved, but those taking an ancestor's interreflection; the
    // ancestors and their siblings besides.
    assert!(c.computed >= c.nodes - c.indirect_from_ancestors + c.sun_grid_vertices);
    assert!(c.operator_needed);
    // Again from the warm cache: every coefficient read, the operator never needed, the
    // same bytes.
    let (rw, warm) = run("warm", true);
    let w = rw.coefficients.expect("coefficient counters");
    assert_eq!(
        (w.computed, w.from_cache, w.operator_needed),
        (0, c.computed, false)
    );
    assert_eq!(warm, coefficients);
    let mut rel: Vec<f64> = Vec::new();
    for (a, f) in coefficients.iter().zip(&forward) {
        for (x, y) in a.iter().zip(f) {
            if *y > 10.0 {
                rel.push((x - y).abs() / y);
            } else {
                assert!((x - y).abs() < 1.0, "{x} vs {y}");
            }
        }
    }
    rel.sort_by(f64::total_cmp);
    let (med, worst) = (rel[rel.len() / 2], rel[rel.len() - 1]);
    eprintln!(
        "coefficients vs forward: {} lit sensor-steps, median {med:.2e}, worst {worst:.2e}",
        rel.len()
    );
    assert!(rel.len() > 50);
    assert!(med < 5e-3 && worst < 0.1, "median {med}, worst {worst}");
}

#[test]
fn surfaces_report_incident_and_transmitted_solar_per_group() {
    // An opaque black plate and a clear pane (Tf 0.85), both facing up, 1 m above nothing,
    // at Greenwich on 21 June: the plate's incident irradiance is the file's global
    // horizontal irradiance DNI·sin(alt) + DHI (it sees the whole sky and nothing else);
    // the pane transmits τ(θ_sun) of the beam and, of the sky, a τ between its
    // hemispherical value (uniform sky) and τ(θ_sun) (all light circumsolar).
    use daystep::scene::material::glass_transmittance;
    let d = tempfile::tempdir().unwrap();
    let mut b = crate::util::Builder::new();
    let plate = b.material("plate", 0.0, 0.0);
    let pane = b.material("pane", 0.0, 0.85);
    b.hrect(0.0, 2.0, 0.0, 2.0, 1.0, true, plate);
    b.hrect(10.0, 11.0, 0.0, 1.5, 1.0, true, pane);
    for t in &mut b.input.triangles {
        t.group = t.material;
    }
    b.input.groups = vec!["plate".into(), "pane".into()];
    b.sensor(glam::DVec3::new(1.0, 1.0, 1.5), glam::DVec3::Z);
    // A sensor under the plate, so its back has something to see and gets a back face.
    b.sensor(glam::DVec3::new(1.0, 1.0, 0.5), -glam::DVec3::Z);
    let scene = b.build();
    let wea = "place Greenwich\nlatitude 51.4769\nlongitude 0\ntime_zone 0\nsite_elevation 0\n\
               weather_data_file_units 1\n6 21 9.5 0 150\n6 21 12.5 700 120\n6 21 23.5 0 0\n";
    std::fs::write(d.path().join("w.wea"), wea).unwrap();
    let weather = read_weather(&d.path().join("w.wea")).unwrap();
    let store = Store::disabled();
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let out = d.path().join("out");
    let o = AnnualOptions {
        surfaces: true,
        ..AnnualOptions::default()
    };
    let q = Quality::preset("draft").unwrap();
    run_annual(&scene, &weather, &q, &store, &out, &o, &control).unwrap();
    let text = std::fs::read_to_string(out.join("surfaces.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time,plate:irradiance_w_m2,pane:irradiance_w_m2,pane:transmitted_w,\
         plate (back):irradiance_w_m2"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').skip(1).map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 3);
    let site = scene.site;
    let tau_dif = {
        let n = 2000;
        (0..n)
            .map(|i| glass_transmittance(0.85, ((i as f64 + 0.5) / n as f64).sqrt()))
            .sum::<f64>()
            / n as f64
    };
    for (row, (hour, dni, dhi)) in
        rows.iter()
            .zip([(9.5, 0.0, 150.0), (12.5, 700.0, 120.0), (23.5, 0.0, 0.0)])
    {
        let local = chrono::NaiveDate::from_ymd_opt(2021, 6, 21)
            .unwrap()
            .and_hms_opt(0, 0, 0)
            .unwrap()
            + chrono::TimeDelta::seconds((hour * 3600.0) as i64);
        let sun = daystep::site::solar_position::solar_position(local.and_utc(), &site);
        let sin_alt = sun.altitude_deg().to_radians().sin().max(0.0);
        let ghi = dni * sin_alt + dhi;
        let tau_sun = glass_transmittance(0.85, sin_alt);
        let beam = 1.5 * tau_sun * dni * sin_alt;
        let (lo, hi) = (
            beam + 1.5 * dhi * tau_dif.min(tau_sun),
            beam + 1.5 * dhi * tau_dif.max(tau_sun),
        );
        eprintln!(
            "{hour}: plate {:.2} pane {:.2} (GHI {ghi:.2}); transmitted {:.2} in [{lo:.2}, {hi:.2}]",
            row[0], row[1], row[2]
        );
        // The plate's back face looks down at a black ground (the builder's ground
        // reflectance is 0): nothing arrives on its side, whatever the sky.
        assert_eq!(row[3], 0.0, "plate (back)");
        if ghi == 0.0 {
            assert_eq!(row, &vec![0.0; 4]);
            continue;
        }
        // The sky's discretisation into sources: 1 % (the stated error of the draft sky).
        assert!(
            (row[0] - ghi).abs() <= 0.01 * ghi,
            "plate {} vs {ghi}",
            row[0]
        );
        assert!(
            (row[1] - ghi).abs() <= 0.01 * ghi,
            "pane {} vs {ghi}",
            row[1]
        );
        assert!(
            row[2] >= 0.99 * lo && row[2] <= 1.01 * hi,
            "{} not in [{lo}, {hi}]",
            row[2]
        );
    }
}

#[test]
fn a_run_cut_between_its_final_renames_resumes() {
    // Killed after `illuminance.csv` was renamed into place and before `direct_sun.csv`
    // was: the rerun must not fail on the partial file it has just started.
    let d = tempfile::tempdir().unwrap();
    let (scene, weather, q, store) = setup(d.path());
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let out = d.path().join("run");
    let o = opts(("2021-03-20", "2021-03-20"), (1, 1));
    run_annual(&scene, &weather, &q, &store, &out, &o, &control).unwrap();
    let want = read(&out, "direct_sun.csv");
    std::fs::rename(
        out.join("direct_sun.csv"),
        out.join("direct_sun.csv.partial"),
    )
    .unwrap();
    run_annual(&scene, &weather, &q, &store, &out, &o, &control).unwrap();
    assert_eq!(read(&out, "direct_sun.csv"), want);
}
