//! The direction-keyed cache on the 10 000-triangle building (`cargo bench --bench cache`):
//! one instant from an empty cache and again from the warm cache; a clear June day of 96
//! fifteen-minute steps (the bundled hourly weather, interpolated) run twice on one cache,
//! end to end, with where the remaining time goes; cache bytes per direction record and
//! resident memory. Prints figures; asserts nothing about time. `-- --office` runs the
//! sample office instead.

use daystep::cache::{dir_stats, Store, DEFAULT_MAX_BYTES};
use daystep::scene::Scene;
use daystep::sequence::annual::{run_annual, AnnualOptions, AnnualReport, RunControl};
use daystep::sequence::instant::run_instant_cached;
use daystep::sequence::{Quality, SkySpec};
use daystep::site::parse_time;
use daystep::weather::{read_weather, resample};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

#[path = "../scenes/mod.rs"]
mod scenes;

fn status_mb(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with(key))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn instant(scene: &Scene, store: &Store) -> f64 {
    let (utc, local) = parse_time("2021-06-21T15:00", scene.site.utc_offset_h).unwrap();
    let spec = SkySpec::Perez {
        dni: 750.0,
        dhi: 110.0,
        dew_point_c: None,
    };
    let t0 = Instant::now();
    run_instant_cached(scene, utc, local, &spec, &Quality::default(), store).unwrap();
    t0.elapsed().as_secs_f64()
}

fn day(scene: &Scene, store: &Store, out: &Path) -> AnnualReport {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let w = read_weather(&root.join("scenes/office/weather.epw")).unwrap();
    let w = resample(&w, 15).unwrap();
    let d = chrono::NaiveDate::from_ymd_opt(2021, 6, 21);
    let opts = AnnualOptions {
        start: d,
        end: d,
        ..AnnualOptions::default()
    };
    let stop = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let c = RunControl {
        stop: &stop,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let _ = std::fs::remove_dir_all(out);
    run_annual(scene, &w, &Quality::default(), store, out, &opts, &c).unwrap()
}

fn show(label: &str, r: &AnnualReport) {
    let split: Vec<String> = r
        .stage_seconds
        .iter()
        .map(|(n, s)| format!("{n} {s:.2}"))
        .collect();
    println!(
        "| {label} | {} steps ({} sun) | {} built, {} from cache | {:.2} s | {} |",
        r.steps,
        r.sun_steps,
        r.directions.built,
        r.directions.from_cache,
        r.total_seconds,
        split.join(", ")
    );
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = if std::env::args().any(|a| a == "--office") {
        Scene::load(&root.join("scenes/office/scene.toml")).unwrap()
    } else {
        scenes::multi_storey_building(10_000)
    };
    println!(
        "scene: {} triangles, {} sensors, default quality",
        scene.triangles.len(),
        scene.sensors.len()
    );
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("cache");
    let store = Store::open(&dir, DEFAULT_MAX_BYTES);
    let cold = instant(&scene, &store);
    let store = Store::open(&dir, DEFAULT_MAX_BYTES);
    let mut warm: Vec<f64> = (0..3).map(|_| instant(&scene, &store)).collect();
    warm.sort_by(f64::total_cmp);
    println!(
        "instant: cold cache {cold:.2} s, warm cache {:.3} s (median of 3), ratio {:.0}",
        warm[1],
        cold / warm[1]
    );
    let s = dir_stats(&dir).unwrap();
    println!(
        "cache after the instant: {} records, {:.1} MB, {:.0} kB per record; RSS now {:.0} MB, peak {:.0} MB",
        s.files,
        s.bytes as f64 / 1e6,
        s.bytes as f64 / 1e3 / s.files.max(1) as f64,
        status_mb("VmRSS:"),
        status_mb("VmHWM:")
    );
    println!("| day run | steps | directions | end to end | stages (s, summed over threads) |\n|---|---|---|---|---|");
    let store = Store::open(&dir, DEFAULT_MAX_BYTES);
    let first = day(&scene, &store, &tmp.path().join("d1"));
    show("first", &first);
    let store = Store::open(&dir, DEFAULT_MAX_BYTES);
    let second = day(&scene, &store, &tmp.path().join("d2"));
    show("second", &second);
    let s = dir_stats(&dir).unwrap();
    println!(
        "day: first/second {:.1}×; cache {} records, {:.1} MB ({:.0} kB per record), {:.1} MB mapped by the second run; RSS now {:.0} MB, peak {:.0} MB",
        first.total_seconds / second.total_seconds,
        s.files,
        s.bytes as f64 / 1e6,
        s.bytes as f64 / 1e3 / s.files.max(1) as f64,
        second.cache.bytes_mapped as f64 / 1e6,
        status_mb("VmRSS:"),
        status_mb("VmHWM:")
    );
}
