//! Benchmark of one instant (`cargo bench --bench instant`): per-stage times (medians of
//! several runs), peak memory, and error against run time for each quality preset against
//! the `reference` preset, on the sample office, the same office on a 1 km ground and in a
//! ring of context blocks (issue 13: the room must not pay for the site's extent), and a
//! generated 10 000-triangle building.
//! It prints figures; nothing here asserts a time.

use daystep::scene::Scene;
use daystep::sequence::{run_instant, InstantResult, Quality, SkySpec};
use daystep::site::parse_time;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

#[path = "../scenes/mod.rs"]
mod scenes;

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

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn once(scene: &Scene, spec: &SkySpec, q: &Quality) -> (InstantResult, f64) {
    let (utc, local) = parse_time("2024-06-21T15:00", scene.site.utc_offset_h).unwrap();
    let t0 = Instant::now();
    let r = run_instant(scene, utc, local, spec, q).unwrap();
    (r, t0.elapsed().as_secs_f64())
}

fn bench_scene(name: &str, scene: &Scene, runs: usize, args: &Args) {
    let spec = SkySpec::Perez {
        dni: 750.0,
        dhi: 110.0,
        dew_point_c: None,
    };
    println!(
        "\n## {name}: {} triangles ({} back faces), {} sensors",
        scene.input_triangles,
        scene.triangles.len() - scene.input_triangles,
        scene.sensors.len()
    );
    // Reset the peak-RSS mark (Linux: "5" → clear_refs) so the figure is this scene's.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let q = Quality::default();
    let mut stages: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut totals = Vec::new();
    let mut last = None;
    for _ in 0..runs {
        let (r, t) = once(scene, &spec, &q);
        for (k, v) in &r.report.stage_seconds.0 {
            stages.entry(k.clone()).or_default().push(*v);
        }
        totals.push(t);
        last = Some(r);
    }
    let r = last.unwrap();
    let c = &r.report.counts;
    println!(
        "default quality, median of {runs}: total {:.3} s; sources {} sky + {} ground + {} sun; LDI pixels {} fragments {} (largest {}x{}); elements {} -> {} (sun alone {}); sensor rays {}",
        median(totals), c.sky_sources, c.ground_sources, c.sun_sources, c.ldi_pixels, c.ldi_fragments,
        c.ldi_max_size.0, c.ldi_max_size.1, c.elements_before, c.elements_after, c.elements_after_sun, c.sensor_rays
    );
    println!("| stage | median s |\n|---|---|");
    for (k, v) in stages {
        println!("| {k} | {:.4} |", median(v));
    }
    let shoot: f64 = ["sources", "projection", "transfer"]
        .iter()
        .filter_map(|s| {
            r.report
                .stage_seconds
                .0
                .iter()
                .find(|(k, _)| k == s)
                .map(|(_, t)| *t)
        })
        .sum();
    println!(
        "sun + sky shoot (sources + projection + transfer), last run: {shoot:.3} s; peak RSS of these default runs {:.0} MB",
        peak_rss_mb()
    );
    if !args.no_ladder {
        ladder(name, scene, &spec);
    }
}

/// Error against time: each preset against `reference`, on at most ~170 sensors (the
/// ladder's reference run is slow on the large building).
fn ladder(name: &str, scene: &Scene, spec: &SkySpec) {
    let mut scene = scene.clone();
    let stride = scene.sensors.len().div_ceil(170).max(1);
    scene.sensors = scene.sensors.iter().step_by(stride).cloned().collect();
    let scene = &scene;
    println!(
        "\n{name}: error against time on {} sensors",
        scene.sensors.len()
    );

    // Error against time: each preset against `reference`.
    let (reference, t_ref) = once(scene, spec, &Quality::preset("reference").unwrap());
    println!("\n| preset | seconds | mean |err| vs reference (lux) | mean rel. err | max rel. err | mean stated lux_err | stated covers actual |\n|---|---|---|---|---|---|---|");
    for p in ["draft", "default", "high"] {
        let (r, t) = once(scene, spec, &Quality::preset(p).unwrap());
        let mut abs = 0.0;
        let mut rel = Vec::new();
        let mut stated = 0.0;
        let mut covered = 0;
        for (a, b) in r.sensors.iter().zip(&reference.sensors) {
            let e = (a.lux - b.lux).abs();
            abs += e;
            stated += a.lux_err;
            covered += usize::from(a.lux_err + b.lux_err >= e);
            if b.lux > 10.0 {
                rel.push(e / b.lux);
            }
        }
        let n = r.sensors.len().max(1) as f64;
        let max_rel = rel.iter().cloned().fold(0.0, f64::max);
        let mean_rel = rel.iter().sum::<f64>() / rel.len().max(1) as f64;
        println!(
            "| {p} | {t:.3} | {:.1} | {:.3}% | {:.2}% | {:.1} | {:.0}% |",
            abs / n,
            100.0 * mean_rel,
            100.0 * max_rel,
            stated / n,
            100.0 * covered as f64 / n
        );
    }
    println!(
        "| reference | {t_ref:.3} | 0 | 0 | 0 | {:.1} | - |",
        reference.sensors.iter().map(|s| s.lux_err).sum::<f64>()
            / reference.sensors.len().max(1) as f64
    );
}

/// Command-line choices: `--no-ladder` skips the presets' error-against-time runs, and
/// `--only TEXT` (repeatable) runs only the scenes whose name contains one of the texts.
struct Args {
    no_ladder: bool,
    only: Vec<String>,
}

impl Args {
    fn parse() -> Args {
        let mut args = Args {
            no_ladder: false,
            only: Vec::new(),
        };
        let mut it = std::env::args().skip(1);
        while let Some(a) = it.next() {
            match a.as_str() {
                "--no-ladder" => args.no_ladder = true,
                "--only" => args.only.extend(it.next()),
                _ => {} // cargo bench passes `--bench`
            }
        }
        args
    }

    fn wants(&self, name: &str) -> bool {
        self.only.is_empty() || self.only.iter().any(|o| name.contains(o.as_str()))
    }
}

fn main() {
    let args = Args::parse();
    let threads = rayon::current_num_threads();
    println!("# daystep instant benchmark ({threads} threads)");
    if args.wants("sample office") {
        let office =
            Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/scene.toml"))
                .unwrap();
        bench_scene("sample office", &office, 5, &args);
    }
    for (name, site) in [
        (
            "office on a 1 km ground",
            scenes::OfficeSite::KilometreGround,
        ),
        (
            "office in a ring of context blocks",
            scenes::OfficeSite::ContextRing,
        ),
    ] {
        if args.wants(name) {
            let scene = scenes::office_on_site(site).build(name).unwrap();
            bench_scene(name, &scene, 3, &args);
        }
    }
    if args.wants("generated building") {
        let building = scenes::multi_storey_building(10_000);
        bench_scene("generated building", &building, 3, &args);
    }
    println!("\npeak RSS of the whole benchmark: {:.0} MB", peak_rss_mb());
}
