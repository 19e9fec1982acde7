//! Annual runs (`cargo bench --bench annual`): the sample office over its bundled TMY year
//! at default quality, from an empty cache and again from the warm cache, with the
//! per-stage split; the 10 000-triangle building (1 620 sensors) over one week, cold and
//! warm. Prints only; `-- --office-only` skips the building.

use daystep::cache::{Store, DEFAULT_MAX_BYTES};
use daystep::scene::Scene;
use daystep::sequence::annual::{run_annual, AnnualOptions, AnnualReport, RunControl};
use daystep::sequence::Quality;
use daystep::weather::read_weather;
use std::path::Path;
use std::sync::atomic::AtomicBool;

#[path = "../scenes/mod.rs"]
mod scenes;

fn run(
    scene: &Scene,
    weather: &Path,
    days: Option<(&str, &str)>,
    cache: &Path,
    out: &Path,
) -> AnnualReport {
    let w = read_weather(weather).unwrap();
    let store = Store::open(cache, DEFAULT_MAX_BYTES);
    let stop = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let d = |s: &str| Some(chrono::NaiveDate::parse_from_str(s, "%Y-%m-%d").unwrap());
    let opts = AnnualOptions {
        start: days.and_then(|x| d(x.0)),
        end: days.and_then(|x| d(x.1)),
        ..AnnualOptions::default()
    };
    let c = RunControl {
        stop: &stop,
        progress: &quiet,
    };
    let _ = std::fs::remove_dir_all(out);
    run_annual(scene, &w, &Quality::default(), &store, out, &opts, &c).unwrap()
}

fn show(label: &str, r: &AnnualReport) {
    println!(
        "| {label} | {} | {} | {} | {} built, {} from cache, {} reused | {:.1} | {:.2} % / {:.2} % |",
        r.steps, r.computed, r.sun_steps, r.directions.built, r.directions.from_cache, r.directions.reused,
        r.total_seconds, 100.0 * r.median_relative_err, 100.0 * r.p95_relative_err
    );
    let split: Vec<String> = r
        .stage_seconds
        .iter()
        .map(|(n, s)| format!("{n} {s:.2}"))
        .collect();
    println!(
        "|   stages (s, summed over threads) | {} |",
        split.join(", ")
    );
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    let office = Scene::load(&root.join("scenes/office/scene.toml")).unwrap();
    let epw = root.join("scenes/office/weather.epw");
    println!("| run | steps | computed | sun steps | directions | s | stated error median / p95 |\n|---|---|---|---|---|---|---|");
    let cache = tmp.path().join("cache");
    let cold = run(&office, &epw, None, &cache, &tmp.path().join("o1"));
    show("office, year, cold cache", &cold);
    let warm = run(&office, &epw, None, &cache, &tmp.path().join("o2"));
    show("office, year, warm cache", &warm);
    println!(
        "cold/warm ratio {:.1}",
        cold.total_seconds / warm.total_seconds
    );
    if std::env::args().any(|a| a == "--office-only") {
        return;
    }
    let building = scenes::multi_storey_building(10_000);
    let cache = tmp.path().join("cache_b");
    let week = Some(("2021-06-15", "2021-06-21"));
    let cold = run(&building, &epw, week, &cache, &tmp.path().join("b1"));
    show("building, one week, cold cache", &cold);
    let warm = run(&building, &epw, week, &cache, &tmp.path().join("b2"));
    show("building, one week, warm cache", &warm);
}
