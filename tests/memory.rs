//! The memory cap (`--max-memory`): a cap too small for the daylight coefficients stops
//! the run before they are computed, naming the smallest cap; at that cap the run
//! completes in the smallest adjoint blocks (the later ones reading the first one's
//! source terms from its scratch file) and writes the same bytes as an uncapped run;
//! the binary reads the flag, refuses a bad size with exit 1, and reports the cap and the
//! peak in `report.json`.

use crate::util::{daystep, office, stderr};
use daystep::cache::Store;
use daystep::memory::MemoryCap;
use daystep::scene::Scene;
use daystep::sequence::annual::{run_annual, AnnualOptions, RunControl};
use daystep::sequence::Quality;
use daystep::weather::read_weather;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// The office with every second sensor (83: three adjoint blocks of at most 32).
fn half_office(dir: &Path) -> Scene {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    for f in ["scene.toml", "office.obj", "office.mtl"] {
        std::fs::copy(src.join(f), dir.join(f)).unwrap();
    }
    let pts = std::fs::read_to_string(src.join("office.pts")).unwrap();
    let half: String = pts.lines().step_by(2).map(|l| format!("{l}\n")).collect();
    std::fs::write(dir.join("office.pts"), half).unwrap();
    Scene::load(&dir.join("scene.toml")).unwrap()
}

#[test]
fn a_capped_year_stops_before_the_work_or_writes_the_uncapped_bytes() {
    let d = tempfile::tempdir().unwrap();
    let scene = half_office(d.path());
    assert_eq!(scene.sensors.len(), 83);
    let weather =
        read_weather(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw"))
            .unwrap();
    let q = Quality::preset("draft").unwrap();
    let day = chrono::NaiveDate::from_ymd_opt(2021, 6, 15);
    let go = AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let run = |name: &str, cap: Option<MemoryCap>| {
        let o = AnnualOptions {
            start: day,
            end: day,
            max_memory: cap,
            ..AnnualOptions::default()
        };
        let out = d.path().join(name);
        // No cache: each run computes its coefficients.
        let r = run_annual(&scene, &weather, &q, &Store::disabled(), &out, &o, &control);
        (r, out)
    };

    // 1 MiB: refused before the coefficients, naming the smallest cap.
    let (r, out) = run("tiny", Some(MemoryCap::parse("1M").unwrap()));
    let msg = r
        .expect_err("1 MiB cannot hold the office's coefficients")
        .to_string();
    assert!(msg.contains("--max-memory"), "{msg}");
    let smallest = msg
        .split("give --max-memory ")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .unwrap_or_else(|| panic!("no smallest cap named: {msg}"));
    let rows = std::fs::read_to_string(out.join("illuminance.csv")).unwrap_or_default();
    assert!(
        rows.lines().count() <= 1,
        "no step before the refusal: {rows}"
    );

    // At the smallest cap: the smallest blocks, the same bytes as without a cap.
    let (capped, capped_out) = run("capped", Some(MemoryCap::parse(smallest).unwrap()));
    let capped = capped.unwrap();
    let (free, free_out) = run("free", None);
    let free = free.unwrap();
    let blocks = |r: &daystep::sequence::annual::AnnualReport| {
        r.coefficients.expect("daylight coefficients").block_sensors
    };
    assert_eq!(blocks(&capped), 32, "{smallest}");
    assert_eq!(blocks(&free), 83);
    // The later blocks read the first block's source terms back from the scratch file.
    let spilled = |r: &daystep::sequence::annual::AnnualReport| {
        r.coefficients.expect("daylight coefficients").spilled_bytes
    };
    assert!(spilled(&capped) > 0, "three blocks share their terms");
    assert_eq!(spilled(&free), 0, "one block has nothing to share");
    for f in ["illuminance.csv", "direct_sun.csv", "metrics.csv"] {
        assert!(
            std::fs::read(capped_out.join(f)).unwrap() == std::fs::read(free_out.join(f)).unwrap(),
            "{f} differs under --max-memory {smallest}"
        );
    }
    assert_eq!(
        capped.memory.max_memory_bytes,
        MemoryCap::parse(smallest).unwrap().bytes
    );
    assert_eq!(free.memory.max_memory_bytes, 0);
}

/// Under a cap the user gives, the daylight coefficients are read in place from the cache
/// (mapped, their pages given back every few days); the outputs, cold and warm, are the
/// bytes of a run that holds them.
#[test]
fn coefficients_read_in_place_give_the_bytes_of_coefficients_held() {
    let d = tempfile::tempdir().unwrap();
    let scene = half_office(d.path());
    let weather =
        read_weather(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw"))
            .unwrap();
    let q = Quality::preset("draft").unwrap();
    let go = AtomicBool::new(false);
    let control = RunControl {
        stop: &go,
        progress: &|_, _| {},
        coefficient_progress: &|_, _| {},
    };
    // Three weeks: the pages are given back more than once.
    let run = |name: &str, cache: &str, cap: Option<MemoryCap>| {
        let o = AnnualOptions {
            start: chrono::NaiveDate::from_ymd_opt(2021, 3, 1),
            end: chrono::NaiveDate::from_ymd_opt(2021, 3, 21),
            max_memory: cap,
            ..AnnualOptions::default()
        };
        let store = Store::open(&d.path().join(cache), daystep::cache::DEFAULT_MAX_BYTES);
        let out = d.path().join(name);
        let r = run_annual(&scene, &weather, &q, &store, &out, &o, &control).unwrap();
        (r.coefficients.expect("daylight coefficients"), out)
    };
    let cap = || Some(MemoryCap::parse("8G").unwrap());
    let (held, held_out) = run("held", "cache-held", None);
    assert!(!held.in_place, "a few megabytes of coefficients are held");
    for (name, computed) in [("cold", true), ("warm", false)] {
        let (c, out) = run(name, "cache-mapped", cap());
        assert!(
            c.in_place,
            "{name}: under a given cap they are read in place"
        );
        assert_eq!(c.computed > 0, computed, "{name}");
        for f in ["illuminance.csv", "direct_sun.csv", "metrics.csv"] {
            assert!(
                std::fs::read(out.join(f)).unwrap() == std::fs::read(held_out.join(f)).unwrap(),
                "{name}: {f} differs when the coefficients are read in place"
            );
        }
    }
}

#[test]
fn the_binary_reads_the_cap_refuses_a_bad_one_and_reports_it() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let o = office();
    let args = |cap: &str| {
        vec![
            "--max-memory".to_string(),
            cap.to_string(),
            "instant".into(),
            o.display().to_string(),
            "--time".into(),
            "2021-06-15T12:30".into(),
            "--sky".into(),
            "cie-overcast".into(),
            "--dhi".into(),
            "100".into(),
            "--quality".into(),
            "draft".into(),
            "--no-cache".into(),
            "--out".into(),
            out.display().to_string(),
        ]
    };
    for bad in ["banana", "512K", "-1G"] {
        let a = args(bad);
        let r = daystep(&a.iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(r.status.code(), Some(1), "{bad}: {}", stderr(&r));
        assert!(stderr(&r).contains("--max-memory"), "{bad}: {}", stderr(&r));
        assert!(
            !out.join("report.json").exists(),
            "{bad}: refused before any work"
        );
    }
    let a = args("1.5G");
    let r = daystep(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let m = &report["memory"];
    assert_eq!(m["max_memory_bytes"].as_u64(), Some(3 << 29), "{m}");
    assert_eq!(
        m["max_memory_from"].as_str(),
        Some("--max-memory 1.5G"),
        "{m}"
    );
    if cfg!(target_os = "linux") {
        assert!(m["peak_bytes"].as_u64().unwrap() > 1 << 20, "{m}");
    }
}

/// `--cache-size`: a bad value is refused before any work, naming the flag; a run whose
/// records outgrow the limit warns, on standard error and in its report.
#[test]
fn the_cache_size_is_read_refused_when_bad_and_outgrowing_it_warns() {
    let d = tempfile::tempdir().unwrap();
    let o = office();
    let run = |size: &str, out: &str| {
        let (cache, out) = (d.path().join("cache"), d.path().join(out));
        let a = [
            "--cache-size",
            size,
            "instant",
            o.to_str().unwrap(),
            "--time",
            "2021-06-15T12:30",
            "--sky",
            "cie-overcast",
            "--dhi",
            "100",
            "--quality",
            "draft",
            "--cache",
            cache.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        (daystep(&a), out)
    };
    for bad in ["banana", "512K"] {
        let (r, out) = run(bad, "bad");
        assert_eq!(r.status.code(), Some(1), "{bad}: {}", stderr(&r));
        assert!(stderr(&r).contains("--cache-size"), "{bad}: {}", stderr(&r));
        assert!(!out.exists(), "{bad}: refused before any work");
    }
    let (r, out) = run("2G", "roomy");
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    assert!(!stderr(&r).contains("--cache-size"), "{}", stderr(&r));
    // The draft office writes tens of MiB of records: 1 MiB keeps few of them.
    std::fs::remove_dir_all(d.path().join("cache")).unwrap();
    let (r, out_small) = run("1M", "small");
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    assert!(stderr(&r).contains("--cache-size"), "{}", stderr(&r));
    let report = std::fs::read_to_string(out_small.join("report.json")).unwrap();
    assert!(report.contains("--cache-size"), "{report}");
    // The limit changes what is kept, never what is computed.
    assert_eq!(
        std::fs::read(out.join("sensors.csv")).unwrap(),
        std::fs::read(out_small.join("sensors.csv")).unwrap()
    );
}
