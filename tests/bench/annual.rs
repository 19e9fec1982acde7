//! Annual runs (`cargo bench --bench annual`, issue 14): daystep's cost against Radiance's
//! 2-phase daylight coefficients on the same scenes and weather. Prints markdown tables;
//! nothing here asserts a time.
//!
//! Modes (arguments after `--`):
//!
//! * default: (a) the sample office (`scenes/office`, 165 sensors) and (b) the generated
//!   10 000-triangle building (`scenes::multi_storey_building(10_000)`, 1 620 sensors,
//!   written as OBJ/MTL/.pts with `scenes::write_obj` to `target/bench-annual/scenes`), each
//!   over the whole TMY year of `scenes/office/weather.epw` at default quality: daystep
//!   from an empty cache (cold) and again from that cache (warm), then Radiance's 2-phase
//!   (`epw2wea`, `gendaymtx -m 1`, `rfluxmtx -ab 5 -ad 10000 -lw 1e-5`, `dctimestep`,
//!   `rmtxop` to photopic illuminance; `tests/bench/radiance/validate.py --two-phase-only`
//!   converts the scene and runs it). Tables: wall times and their ratios, peak memory,
//!   DA300 / sDA300/50 % / UDI100-3000 from both tools with the same occupancy (8:00–17:59
//!   every day) and the hour-by-hour difference, Radiance's stages, daystep's stages.
//! * `--office-only`: only the office.
//! * `--no-radiance`: daystep only. Radiance runs when `target/radiance-venv/bin/python`
//!   imports pyradiance (`tests/bench/radiance/run.sh` makes it once, downloading the wheel
//!   from PyPI); otherwise the bench says so and runs daystep only.
//! * `--scaling`: daystep only, cold and warm, over one week (15–21 June): sensors
//!   ≈ 100 → 1 000 → 10 000 on the 10 000-triangle building (a regular grid at 0.8 m on
//!   every floor instead of its own 2.4 m grid), and triangles 1 000 → 10 000 → 100 000
//!   (`multi_storey_building(n)`) with ≈ 1 000 sensors each. Prints a table and writes a
//!   log–log plot to `target/bench-annual-scaling.svg`.
//!
//! Options for short trials (not needed for the real bench): `--days N` (N days from 15
//! June instead of the year or the week), `--start YYYY-MM-DD` / `--end YYYY-MM-DD`,
//! `--radiance-nproc N` (rfluxmtx `-n`; default: every core, as daystep uses),
//! `--radiance-opts "…"` (rfluxmtx settings instead of `-ab 5 -ad 10000 -lw 1e-5`), and
//! for `--scaling` `--max-sensors N` / `--max-triangles N` (skip larger sweep points) and
//! `--point TRIANGLES:SENSORS` (repeatable: only these sweep points, e.g. `10000:10000`).
//! `--point 100000:10000` also selects the large point that the sweep leaves out unless
//! asked (issue 28: 100 000 triangles, 10 000 sensors); `--max-memory SIZE` passes the
//! cap to every daystep run (as `daystep annual --max-memory`), `--cache-size SIZE` the
//! cache folder's limit (as `daystep --cache-size`; the large points outgrow 2 GiB).
//!
//! Every daystep run is a child process (this binary again, `--child …`) so that its peak
//! resident memory (VmHWM, read by the child at its end) and wall time are its own; the
//! child loads the scene file and weather, calls `daystep::sequence::annual::run_annual`
//! and writes `summary.json` as `daystep annual` does. "daystep s" is the child's wall
//! time (scene and weather reading included); Radiance's is the sum of its stages'
//! programs (the Python scene conversion is listed apart). Scratch files go to
//! `target/bench-annual`; daystep's caches and outputs to a temporary folder in it.

use chrono::{Datelike, NaiveDate, NaiveDateTime, Timelike};
use daystep::cache::{Store, DEFAULT_MAX_BYTES};
use daystep::scene::{Scene, Sensor};
use daystep::sequence::annual::{run_annual, AnnualOptions, RunControl};
use daystep::sequence::Quality;
use daystep::weather::read_weather;
use glam::DVec3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

#[path = "../scenes/mod.rs"]
mod scenes;

#[path = "annual_scaling.rs"]
mod scaling; // `--scaling`: cold and warm over sensors and triangles, and its plot
#[path = "annual_print.rs"]
mod print; // the tables: times, peaks, metrics, stages, beside Radiance
use print::{print_results, SceneResult};
#[path = "annual_radiance.rs"]
mod radiance; // Radiance 2-phase on the same scene and weather, through validate.py
use radiance::{hourly, radiance, radiance_python, RadRun};

/// The bench's rfluxmtx settings (BENCH_DC_OPTS in validate.py).
const RADIANCE_OPTS: &str = "-ab 5 -ad 10000 -lw 1e-5";
/// First day of `--days` and of the scaling week.
const JUNE_15: (i32, u32, u32) = (2021, 6, 15);

// ---------------------------------------------------------------------------------------
// Options
// ---------------------------------------------------------------------------------------

#[derive(Debug)]
struct Opts {
    office_only: bool,
    no_radiance: bool,
    scaling: bool,
    days: Option<u32>,
    start: Option<NaiveDate>,
    end: Option<NaiveDate>,
    radiance_nproc: usize,
    radiance_opts: Option<String>,
    max_sensors: usize,
    max_triangles: usize,
    /// `--point T:S`: only these (triangles, sensors) points of the scaling sweep.
    points: Vec<(usize, usize)>,
    /// `--max-memory SIZE`: daystep's memory cap, bytes (None: the machine's default).
    max_memory: Option<u64>,
    /// `--cache-size SIZE`: the cache folder's limit, bytes (None: `DEFAULT_MAX_BYTES`).
    cache_bytes: Option<u64>,
}

fn parse_opts(args: &[String]) -> Opts {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut o = Opts {
        office_only: false,
        no_radiance: false,
        scaling: false,
        days: None,
        start: None,
        end: None,
        radiance_nproc: cores,
        radiance_opts: None,
        max_sensors: usize::MAX,
        max_triangles: usize::MAX,
        points: Vec::new(),
        max_memory: None,
        cache_bytes: None,
    };
    let date = |s: &str| {
        NaiveDate::parse_from_str(s, "%Y-%m-%d")
            .unwrap_or_else(|e| panic!("bad date {s:?} (want YYYY-MM-DD): {e}"))
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .unwrap_or_else(|| panic!("{a} needs a value"))
                .clone()
        };
        let num = |v: String| -> usize {
            v.parse()
                .unwrap_or_else(|e| panic!("{a}: bad number {v:?}: {e}"))
        };
        match a.as_str() {
            "--bench" => {} // cargo bench passes it
            "--office-only" => o.office_only = true,
            "--no-radiance" => o.no_radiance = true,
            "--scaling" => o.scaling = true,
            "--days" => o.days = Some(num(value()) as u32),
            "--start" => o.start = Some(date(&value())),
            "--end" => o.end = Some(date(&value())),
            "--radiance-nproc" => o.radiance_nproc = num(value()),
            "--radiance-opts" => o.radiance_opts = Some(value()),
            "--max-sensors" => o.max_sensors = num(value()),
            "--max-triangles" => o.max_triangles = num(value()),
            "--max-memory" => {
                let v = value();
                let cap = daystep::memory::MemoryCap::parse(&v)
                    .unwrap_or_else(|e| panic!("--max-memory: {e}"));
                o.max_memory = Some(cap.bytes);
            }
            "--cache-size" => {
                let v = value();
                let b = daystep::memory::parse_size_flag("--cache-size", &v)
                    .unwrap_or_else(|e| panic!("{e}"));
                o.cache_bytes = Some(b);
            }
            "--point" => {
                let v = value();
                let (t, s) = v
                    .split_once(':')
                    .unwrap_or_else(|| panic!("--point wants TRIANGLES:SENSORS, not {v:?}"));
                o.points.push((num(t.into()), num(s.into())));
            }
            other => panic!(
                "unknown argument {other:?}; modes: --office-only, --no-radiance, --scaling \
                 (trial options: --days N, --start/--end YYYY-MM-DD, --radiance-nproc N, \
                 --radiance-opts \"…\", --max-sensors N, --max-triangles N, \
                 --point TRIANGLES:SENSORS, --max-memory SIZE, --cache-size SIZE)"
            ),
        }
    }
    o
}

/// The period of the runs (`None` ends are the weather file's) and daystep's memory cap.
#[derive(Clone, Copy, Debug)]
struct Period {
    start: Option<NaiveDate>,
    end: Option<NaiveDate>,
    /// Bytes; `None`: the machine's default.
    max_memory: Option<u64>,
    /// The cache folder's limit, bytes; `None`: `DEFAULT_MAX_BYTES`.
    cache_bytes: Option<u64>,
}

impl Period {
    fn resolve(o: &Opts) -> Period {
        let june15 = NaiveDate::from_ymd_opt(JUNE_15.0, JUNE_15.1, JUNE_15.2).expect("date");
        let given = Period {
            start: o.start,
            end: o.end,
            max_memory: o.max_memory,
            cache_bytes: o.cache_bytes,
        };
        if let Some(n) = o.days {
            let s = o.start.unwrap_or(june15);
            return Period {
                start: Some(s),
                end: Some(s + chrono::Days::new(u64::from(n.max(1) - 1))),
                ..given
            };
        }
        if o.scaling && o.start.is_none() && o.end.is_none() {
            return Period {
                start: Some(june15),
                end: Some(june15 + chrono::Days::new(6)),
                ..given
            };
        }
        given
    }

    fn label(&self) -> String {
        match (self.start, self.end) {
            (None, None) => "year".into(),
            (s, e) => format!(
                "{} – {}",
                s.map_or("start".into(), |d| d.format("%d %b").to_string()),
                e.map_or("end".into(), |d| d.format("%d %b").to_string())
            ),
        }
    }

    fn child_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(s) = self.start {
            v.extend(["--start".into(), s.to_string()]);
        }
        if let Some(e) = self.end {
            v.extend(["--end".into(), e.to_string()]);
        }
        if let Some(b) = self.max_memory {
            v.extend(["--max-memory".into(), b.to_string()]);
        }
        if let Some(b) = self.cache_bytes {
            v.extend(["--cache-size".into(), b.to_string()]);
        }
        v
    }

    /// validate.py's `--start MM-DD --end MM-DD`.
    fn radiance_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(s) = self.start {
            v.extend(["--start".into(), s.format("%m-%d").to_string()]);
        }
        if let Some(e) = self.end {
            v.extend(["--end".into(), e.format("%m-%d").to_string()]);
        }
        v
    }
}

// ---------------------------------------------------------------------------------------
// The child: one measured daystep run
// ---------------------------------------------------------------------------------------

fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// `--child SCENE.toml WEATHER CACHE OUT RESULT.json [--start D] [--end D]`: loads the
/// scene and weather, runs the year (or period) into OUT with the cache CACHE, writes the
/// report, the peak memory and the thread count to RESULT.json.
fn child(args: &[String]) {
    let [scene, weather, cache, out, result] = [0, 1, 2, 3, 4].map(|i| PathBuf::from(&args[i]));
    let o = parse_opts(&args[5..]);
    // As the CLI does first.
    daystep::allocator::keep_freed_memory();
    let t0 = Instant::now();
    let scene = Scene::load(&scene).unwrap();
    let w = read_weather(&weather).unwrap();
    let load_s = t0.elapsed().as_secs_f64();
    let store = Store::open(&cache, o.cache_bytes.unwrap_or(DEFAULT_MAX_BYTES));
    let stop = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let opts = AnnualOptions {
        start: o.start,
        end: o.end,
        max_memory: o.max_memory.map(|b| daystep::memory::MemoryCap {
            bytes: b,
            from: format!("--max-memory {b}"),
            given: true,
        }),
        ..AnnualOptions::default()
    };
    let c = RunControl {
        stop: &stop,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let _ = std::fs::remove_dir_all(&out);
    let report = run_annual(&scene, &w, &Quality::default(), &store, &out, &opts, &c).unwrap();
    let v = json!({
        "report": report,
        "load_seconds": load_s,
        "peak_rss_mb": peak_rss_mb(),
        "threads": rayon::current_num_threads(),
        "triangles": scene.input_triangles,
        "sensors": scene.sensors.len(),
    });
    std::fs::write(result, serde_json::to_string_pretty(&v).unwrap()).unwrap();
}

/// One daystep run as measured by the parent.
struct DsRun {
    /// Child wall time, s.
    wall_s: f64,
    /// The child's result (report, peak memory, …).
    v: Value,
    /// `summary.json`.
    summary: Value,
    out: PathBuf,
}

impl DsRun {
    fn f(&self, key: &str) -> f64 {
        self.v[key].as_f64().unwrap_or(f64::NAN)
    }
    fn report(&self, key: &str) -> f64 {
        self.v["report"][key].as_f64().unwrap_or(f64::NAN)
    }
    fn metric(&self, key: &str) -> f64 {
        self.summary["summary"][key].as_f64().unwrap_or(f64::NAN)
    }
}

fn daystep(scene: &Path, weather: &Path, period: Period, cache: &Path, out: &Path) -> DsRun {
    let result = out.with_extension("result.json");
    let exe = std::env::current_exe().unwrap();
    let t0 = Instant::now();
    let status = Command::new(exe)
        .arg("--child")
        .args([scene, weather, cache, out, &result])
        .args(period.child_args())
        .stdin(Stdio::null())
        .status()
        .unwrap();
    let wall_s = t0.elapsed().as_secs_f64();
    assert!(status.success(), "daystep child failed: {status}");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&result).unwrap()).unwrap();
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok())
        .unwrap_or(Value::Null);
    DsRun {
        wall_s,
        v,
        summary,
        out: out.to_path_buf(),
    }
}

/// A cold year of the scene `name` into the empty `cache`, then a warm one from it, each
/// into its own folder under `tmp`.
fn cold_and_warm(
    name: &str,
    scene: &Path,
    weather: &Path,
    period: Period,
    cache: &Path,
    tmp: &Path,
) -> (DsRun, DsRun) {
    let run = |kind: &str| {
        daystep(
            scene,
            weather,
            period,
            cache,
            &tmp.join(format!("{name}-{kind}")),
        )
    };
    eprintln!("{name}: daystep cold …");
    let cold = run("cold");
    eprintln!("{name}: daystep cold {:.1} s; warm …", cold.wall_s);
    let warm = run("warm");
    eprintln!("{name}: daystep warm {:.1} s", warm.wall_s);
    (cold, warm)
}

// ---------------------------------------------------------------------------------------
// Scenes
// ---------------------------------------------------------------------------------------

/// Writes `scene` as a scene folder (`scene.toml`, OBJ, MTL, .pts) and returns its
/// scene file.
fn write_scene(scene: &Scene, dir: &Path, stem: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    scenes::write_obj(scene, dir, stem).unwrap();
    dir.join("scene.toml")
}

/// The building's sensors replaced by a regular grid of about `target` upward sensors at
/// its own sensor height on every floor (the plan is the `rooms` group's bounds), none
/// inside a partition.
fn with_sensor_grid(mut scene: Scene, target: usize) -> Scene {
    let mut zs: Vec<f64> = scene.sensors.iter().map(|s| s.position.z).collect();
    zs.sort_by(f64::total_cmp);
    zs.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let tris = &scene.triangles[..scene.input_triangles];
    let group = |name: &str| {
        scene
            .groups
            .iter()
            .position(|g| g == name)
            .map(|i| i as u32)
    };
    let rooms = group("rooms").expect("the building has a rooms group");
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for t in tris.iter().filter(|t| t.group == rooms) {
        for v in t.v {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    // Partition faces across x: (x, y range, z range).
    let walls: Vec<(f64, [f64; 2], [f64; 2])> = match group("partitions") {
        Some(p) => tris
            .iter()
            .filter(|t| t.group == p && t.cross().normalize().x.abs() > 0.9)
            .map(|t| {
                let ys = t.v.map(|v| v.y);
                let zs = t.v.map(|v| v.z);
                let r = |a: [f64; 3]| [a[0].min(a[1]).min(a[2]), a[0].max(a[1]).max(a[2])];
                (t.v[0].x, r(ys), r(zs))
            })
            .collect(),
        None => Vec::new(),
    };
    let (w, d) = (hi.x - lo.x, hi.y - lo.y);
    let floors = zs.len().max(1);
    let mut best = (f64::INFINITY, 1usize, 1usize);
    for nx in 1..=400usize {
        for ny in 1..=400usize {
            let n = (nx * ny * floors) as f64;
            let score = (n / target as f64 - 1.0).abs()
                + 0.05 * ((nx as f64 / ny as f64) / (w / d)).ln().abs();
            if score < best.0 {
                best = (score, nx, ny);
            }
        }
    }
    let (_, nx, ny) = best;
    let origin = scene.origin;
    scene.sensors.clear();
    for &z in &zs {
        for j in 0..ny {
            for i in 0..nx {
                let p = DVec3::new(
                    lo.x + (i as f64 + 0.5) * w / nx as f64,
                    lo.y + (j as f64 + 0.5) * d / ny as f64,
                    z,
                );
                let inside = walls.iter().any(|(x, yr, zr)| {
                    (p.x - x).abs() < 0.1
                        && (yr[0] - 0.01..=yr[1] + 0.01).contains(&p.y)
                        && (zr[0]..=zr[1]).contains(&p.z)
                });
                if !inside {
                    scene.sensors.push(Sensor {
                        position: p,
                        normal: DVec3::Z,
                        input_position: p + origin,
                    });
                }
            }
        }
    }
    scene
}

// ---------------------------------------------------------------------------------------
// Modes
// ---------------------------------------------------------------------------------------

fn compare(root: &Path, o: &Opts, work: &Path, tmp: &Path) {
    let period = Period::resolve(o);
    let epw = root.join("scenes/office/weather.epw");
    let mut list: Vec<(String, PathBuf)> =
        vec![("office".into(), root.join("scenes/office/scene.toml"))];
    if !o.office_only {
        let b = scenes::multi_storey_building(10_000);
        list.push((
            "building-10k".into(),
            write_scene(&b, &work.join("scenes/building-10k"), "building"),
        ));
    }
    let py = if o.no_radiance {
        None
    } else {
        radiance_python(root)
    };
    let rad_note = if o.no_radiance {
        "Radiance skipped (--no-radiance)".to_string()
    } else if py.is_none() {
        let m = "Radiance not installed: run tests/bench/radiance/run.sh once (it makes \
                 target/radiance-venv with pyradiance from PyPI); daystep only";
        eprintln!("{m}");
        m.to_string()
    } else {
        format!(
            "Radiance from {}",
            root.join("target/radiance-venv").display()
        )
    };
    let mut results = Vec::new();
    for (name, toml) in &list {
        let cache = tmp.join(format!("cache-{name}"));
        let _ = std::fs::remove_dir_all(&cache);
        let (cold, warm) = cold_and_warm(name, toml, &epw, period, &cache, tmp);
        let rad = py.as_ref().map(|py| {
            eprintln!("{name}: Radiance 2-phase …");
            radiance(
                py,
                root,
                o,
                toml,
                &epw,
                period,
                &work.join("radiance").join(name),
            )
        });
        results.push(SceneResult {
            name: name.clone(),
            triangles: cold.v["triangles"].as_u64().unwrap_or(0),
            sensors: cold.v["sensors"].as_u64().unwrap_or(0),
            steps: cold.v["report"]["steps"].as_u64().unwrap_or(0),
            cold,
            warm,
            rad,
        });
    }
    print_results(&results, period, o, &rad_note);
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().is_some_and(|a| a == "--child") {
        child(&args[1..]);
        return;
    }
    let o = parse_opts(&args);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let work = root.join("target/bench-annual");
    std::fs::create_dir_all(&work).unwrap();
    let tmp = tempfile::Builder::new()
        .prefix("runs-")
        .tempdir_in(&work)
        .unwrap();
    let t0 = Instant::now();
    if o.scaling {
        scaling::scaling(root, &o, &work, tmp.path());
    } else {
        compare(root, &o, &work, tmp.path());
    }
    println!(
        "\nbench wall time {:.0} s; load average at the end {}",
        t0.elapsed().as_secs_f64(),
        std::fs::read_to_string("/proc/loadavg")
            .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(", "))
            .unwrap_or_default()
    );
}
