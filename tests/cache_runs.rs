//! The projection cache in whole runs: warm = cold bit for bit; reflectance, site and
//! weather changes reuse every record the cache holds for them (all of them when the
//! directions stay) and equal an uncached run of the changed inputs; moving a vertex misses; damaged records are rebuilt with the result unchanged; four processes
//! fill one empty folder together.

use daystep::cache::{self, Store};
use daystep::scene::Scene;
use daystep::sequence::instant::{run_instant_cached, write_instant};
use daystep::sequence::{Quality, SkySpec};
use daystep::site::parse_time;
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A copy of the sample office in `dir`, with `edit` applied to (file name, text).
fn office_copy(dir: &Path, edit: impl Fn(&str, String) -> String) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    for f in ["scene.toml", "office.obj", "office.mtl", "office.pts"] {
        let text = std::fs::read_to_string(src.join(f)).unwrap();
        std::fs::write(dir.join(f), edit(f, text)).unwrap();
    }
    dir.join("scene.toml")
}

fn sky(dni: f64) -> SkySpec {
    SkySpec::Perez {
        dni,
        dhi: 110.0,
        dew_point_c: None,
    }
}

/// Runs the draft instant and returns (sensors.csv text, cache stats).
fn run(scene: &Path, spec: &SkySpec, store: &Store) -> (String, cache::CacheStats) {
    let scene = Scene::load(scene).unwrap();
    let (utc, local) = parse_time("2024-03-21T10:30", scene.site.utc_offset_h).unwrap();
    let q = Quality::preset("draft").unwrap();
    let before = store.stats();
    let r = run_instant_cached(&scene, utc, local, spec, &q, store).unwrap();
    let out = tempfile::tempdir().unwrap();
    write_instant(&scene, &r, out.path()).unwrap();
    let after = store.stats();
    let delta = cache::CacheStats {
        hits: after.hits - before.hits,
        misses: after.misses - before.misses,
        rebuilds: after.rebuilds - before.rebuilds,
        ..after
    };
    (
        std::fs::read_to_string(out.path().join("sensors.csv")).unwrap(),
        delta,
    )
}

/// The record files in a cache folder.
fn records(dir: &Path) -> BTreeSet<OsString> {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.map(|e| e.unwrap().file_name())
                .filter(|n| Path::new(n).extension().is_some_and(|x| x == "dsr"))
                .collect()
        })
        .unwrap_or_default()
}

/// Runs changed inputs against the shared cache in `cache_dir` and checks the two things a
/// cached run promises: its output equals an uncached run of the same inputs bit for bit,
/// and it reuses everything the cache holds for it: each record these inputs need (what a
/// cold run into the empty folder `fresh` writes) that earlier runs stored is a hit,
/// directions and the interreflection operator alike, and only the others miss. Returns
/// the output and the misses.
fn changed_run(
    scene: &Path,
    spec: &SkySpec,
    store: &Store,
    cache_dir: &Path,
    fresh: &Path,
) -> (String, u64) {
    let held = records(cache_dir);
    let (out, s) = run(scene, spec, store);
    let (uncached, _) = run(scene, spec, &Store::disabled());
    assert_eq!(out, uncached, "a cached run equals an uncached one");
    let (cold, _) = run(scene, spec, &Store::open(fresh, cache::DEFAULT_MAX_BYTES));
    assert_eq!(cold, uncached);
    let needed = records(fresh);
    assert!(!needed.is_empty());
    let reusable = needed.intersection(&held).count() as u64;
    let new = needed.len() as u64 - reusable;
    assert_eq!(s.rebuilds, 0, "{s:?}");
    assert_eq!(
        (s.hits, s.misses),
        (reusable, new),
        "(hits, misses) against the records the cache held for these inputs: {s:?}"
    );
    (out, s.misses)
}

#[test]
fn warm_equals_cold_and_colour_site_weather_changes_reuse_every_record() {
    let d = tempfile::tempdir().unwrap();
    let (sd, cd) = (d.path().join("scene"), d.path().join("cache"));
    std::fs::create_dir(&sd).unwrap();
    let scene = office_copy(&sd, |_, t| t);
    let store = Store::open(&cd, cache::DEFAULT_MAX_BYTES);
    let (cold, s1) = run(&scene, &sky(700.0), &store);
    assert!(s1.misses > 0 && s1.hits == 0, "{s1:?}");
    let (warm, s2) = run(&scene, &sky(700.0), &store);
    assert_eq!(s2.misses, 0, "{s2:?}");
    assert_eq!(s2.hits, s1.misses);
    assert_eq!(cold, warm, "a warm cache changes nothing");
    let (nocache, _) = run(&scene, &sky(700.0), &Store::disabled());
    assert_eq!(cold, nocache);
    let mut k = 0;
    let mut fresh = || {
        k += 1;
        d.path().join(format!("fresh{k}"))
    };
    let copy = |name: &str, file: &'static str, from: &'static str, to: &'static str| {
        let dir = d.path().join(name);
        std::fs::create_dir(&dir).unwrap();
        office_copy(&dir, |f, t| {
            if f == file {
                assert!(t.contains(from), "{f} has no {from:?}");
                t.replace(from, to)
            } else {
                t
            }
        })
    };

    // Changes that leave every direction as it was: none may miss. Kd, the site and the
    // weather are not in any key; each change still changes the result.
    let recoloured = copy(
        "recoloured",
        "office.mtl",
        "newmtl wall\nKd 0.5 0.5 0.5",
        "newmtl wall\nKd 0.7 0.6 0.5",
    );
    // 15° east and one time zone later: the same solar time, so the sun moves only by an
    // hour's change of declination (0.02°) and stays on its grid point.
    let moved_east = copy(
        "moved_east",
        "scene.toml",
        "longitude = -79.95\nutc_offset_h = -5.0",
        "longitude = -64.95\nutc_offset_h = -4.0",
    );
    let dew = SkySpec::Perez {
        dni: 700.0,
        dhi: 110.0,
        dew_point_c: Some(15.0), // the luminous efficacy changes, not the sky's shape
    };
    for (what, scene, spec) in [
        ("wall colour", &recoloured, sky(700.0)),
        ("site", &moved_east, sky(700.0)),
        ("dew point", &scene, dew),
    ] {
        let (out, misses) = changed_run(scene, &spec, &store, &cd, &fresh());
        assert_eq!(misses, 0, "{what}: every record is reused");
        assert_ne!(out, cold, "{what} changes the result");
    }

    // Changes that need some new directions: the dimmer sky subdivides differently, and at
    // 40° N the sun is on another grid point. Everything else is reused.
    let moved_north = copy(
        "moved_north",
        "scene.toml",
        "latitude = 36.1",
        "latitude = 40.0",
    );
    for (what, scene, spec) in [
        ("DNI 300 W/m²", &scene, sky(300.0)),
        ("latitude 40°", &moved_north, sky(700.0)),
    ] {
        let (out, misses) = changed_run(scene, &spec, &store, &cd, &fresh());
        eprintln!("{what}: {misses} of {} records new", s1.misses);
        assert!(misses < s1.misses / 4, "{what}: {misses} misses");
        assert_ne!(out, cold, "{what} changes the result");
    }

    // Moving one vertex: a new geometry, every lookup misses.
    let moved_vertex = copy("moved_vertex", "office.obj", "v 0 8 3\n", "v 0 8 3.01\n");
    let (_, s6) = run(&moved_vertex, &sky(700.0), &store);
    assert_eq!(s6.hits, 0, "{s6:?}");
    assert!(s6.misses > 0);
}

#[test]
fn damaged_records_are_rebuilt_and_change_nothing() {
    let d = tempfile::tempdir().unwrap();
    let (sd, cd) = (d.path().join("scene"), d.path().join("cache"));
    std::fs::create_dir(&sd).unwrap();
    let scene = office_copy(&sd, |_, t| t);
    let (cold, _) = run(
        &scene,
        &sky(700.0),
        &Store::open(&cd, cache::DEFAULT_MAX_BYTES),
    );
    let mut files: Vec<PathBuf> = std::fs::read_dir(&cd)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "dsr"))
        .collect();
    files.sort();
    assert!(files.len() > 8);
    // Truncate one, flip a payload bit in another, zero a third's version, empty a fourth.
    let b = std::fs::read(&files[0]).unwrap();
    std::fs::write(&files[0], &b[..b.len() / 2]).unwrap();
    let mut b = std::fs::read(&files[1]).unwrap();
    let n = b.len();
    b[n - 5] ^= 0x10;
    std::fs::write(&files[1], b).unwrap();
    let mut b = std::fs::read(&files[2]).unwrap();
    b[8..12].copy_from_slice(&999u32.to_le_bytes());
    std::fs::write(&files[2], b).unwrap();
    std::fs::write(&files[3], b"").unwrap();
    std::fs::write(cd.join("notes.dsr"), b"not a record").unwrap();
    let store = Store::open(&cd, cache::DEFAULT_MAX_BYTES);
    let (again, s) = run(&scene, &sky(700.0), &store);
    assert_eq!(again, cold);
    assert!(s.rebuilds >= 4, "{s:?}");
    assert!(!store.warnings().is_empty());
    let v = cache::verify(&cd).unwrap();
    assert!(
        v.invalid.len() <= 1,
        "only the foreign file may remain: {:?}",
        v.invalid
    );
}

#[test]
fn four_processes_share_one_empty_cache_folder() {
    let d = tempfile::tempdir().unwrap();
    let cd = d.path().join("cache");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/scene.toml");
    let children: Vec<_> = (0..4)
        .map(|k| {
            let out = d.path().join(format!("out{k}"));
            let child = Command::new(env!("CARGO_BIN_EXE_daystep"))
                .args([
                    "instant",
                    scene.to_str().unwrap(),
                    "--time",
                    "2024-03-21T10:30",
                ])
                .args(["--sky", "perez", "--dni", "700", "--dhi", "110"])
                .args(["--quality", "draft", "--threads", "1"])
                .args([
                    "--cache",
                    cd.to_str().unwrap(),
                    "--out",
                    out.to_str().unwrap(),
                ])
                .spawn()
                .unwrap();
            (child, out)
        })
        .collect();
    let mut outputs = Vec::new();
    for (mut c, out) in children {
        assert!(c.wait().unwrap().success());
        outputs.push(std::fs::read_to_string(out.join("sensors.csv")).unwrap());
    }
    assert!(outputs.windows(2).all(|w| w[0] == w[1]));
    let v = cache::verify(&cd).unwrap();
    assert!(v.is_clean() && v.ok > 0, "{v:?}");
}

/// The union of an annual run's sky cuts (which nodes its steps use) is a cache record: a
/// warm run reads it instead of cutting every step's sky twice and writes the same bytes;
/// a record that lacks nodes the steps need is found out and made again.
#[test]
fn a_warm_annual_run_reads_its_cuts_and_a_short_record_is_made_again() {
    use daystep::sequence::annual::{run_annual, AnnualOptions, RunControl};
    let d = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office");
    let scene = Scene::load(&src.join("scene.toml")).unwrap();
    let weather = daystep::weather::read_weather(&src.join("weather.epw")).unwrap();
    let store = Store::open(&d.path().join("cache"), cache::DEFAULT_MAX_BYTES);
    let go = std::sync::atomic::AtomicBool::new(false);
    let quiet = |_: usize, _: usize| {};
    let control = RunControl {
        stop: &go,
        progress: &quiet,
        coefficient_progress: &|_, _| {},
    };
    let day = chrono::NaiveDate::from_ymd_opt(2021, 6, 21);
    let opts = AnnualOptions {
        start: day,
        end: day,
        ..AnnualOptions::default()
    };
    let q = Quality::preset("draft").unwrap();
    let run = |name: &str| {
        let out = d.path().join(name);
        let r = run_annual(&scene, &weather, &q, &store, &out, &opts, &control).unwrap();
        let ill = std::fs::read(out.join("illuminance.csv")).unwrap();
        let c = r.coefficients.expect("annual by coefficients");
        (c.cuts_from_cache, ill, c.cut_days_from_cache)
    };
    let (cold_cached, cold, cold_days) = run("cold");
    assert!(!cold_cached, "an empty cache holds no cuts");
    assert_eq!(cold_days, 0, "nor a day's cuts");
    let (warm_cached, warm, warm_days) = run("warm");
    assert!(warm_cached, "the second run reads the cuts");
    assert_eq!(warm_days, 1, "and the day's cuts");
    assert_eq!(warm, cold, "the same bytes from the cached cuts");

    // The day's cuts record rewritten, valid in every byte, with every node's radiance 1 %
    // higher: the day's sky disagrees, so the record is made again.
    let record_of = |kind: u8| {
        std::fs::read_dir(d.path().join("cache"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| {
                std::fs::read(p)
                    .ok()
                    .is_some_and(|b| cache::Record::parse(&b).is_ok_and(|r| r.key().kind == kind))
            })
            .expect("a record of the kind")
    };
    let day = record_of(cache::KIND_DAY_CUTS);
    let bytes = std::fs::read(&day).unwrap();
    let r = cache::Record::parse(&bytes).unwrap();
    // The sections as `sequence::day_cuts` writes them: heads, ids, node radiances, suns,
    // snapping angles, ground lists, their lengths, ground radiances.
    assert_eq!(
        r.sections().len(),
        8,
        "the day record's layout changed: update this test"
    );
    let t = |i: u32| cache::FIRST_USER_TAG + i;
    let up: Vec<[f32; 5]> = r
        .section::<[f32; 5]>(t(2))
        .unwrap()
        .iter()
        .map(|n| n.map(|x| x * 1.01))
        .collect();
    let ground_up: Vec<f32> = r
        .section::<f32>(t(7))
        .unwrap()
        .iter()
        .map(|x| x * 1.01)
        .collect();
    assert!(!up.is_empty() && !ground_up.is_empty());
    let forged = cache::encode(
        &r.key(),
        &[
            cache::Section::of(t(0), r.section::<[u64; 6]>(t(0)).unwrap()),
            cache::Section::of(t(1), r.section::<u64>(t(1)).unwrap()),
            cache::Section::of(t(2), &up),
            cache::Section::of(t(3), r.section::<[u64; 9]>(t(3)).unwrap()),
            cache::Section::of(t(4), r.section::<f64>(t(4)).unwrap()),
            cache::Section::of(t(5), r.section::<u64>(t(5)).unwrap()),
            cache::Section::of(t(6), r.section::<u64>(t(6)).unwrap()),
            cache::Section::of(t(7), &ground_up),
        ],
    );
    std::fs::write(&day, forged).unwrap();
    let (_, again, forged_days) = run("forged");
    assert_eq!(
        forged_days, 0,
        "a day's cuts that disagree with its sky are not trusted"
    );
    assert_eq!(again, cold);
    let (_, again, rewritten_days) = run("rewritten");
    assert_eq!(rewritten_days, 1, "and the record is made again");
    assert_eq!(again, cold);

    // Rewrite the cuts record, valid in every byte, with its first node only.
    let cuts = std::fs::read_dir(d.path().join("cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            std::fs::read(p).ok().is_some_and(|b| {
                cache::Record::parse(&b).is_ok_and(|r| r.key().kind == cache::KIND_CUTS)
            })
        })
        .expect("a cuts record");
    let bytes = std::fs::read(&cuts).unwrap();
    let r = cache::Record::parse(&bytes).unwrap();
    let key = r.key();
    let tag = r.sections()[0].tag;
    let first: Vec<[u64; 3]> = r.section::<[u64; 3]>(tag).unwrap()[..1].to_vec();
    std::fs::write(
        &cuts,
        cache::encode(&key, &[cache::Section::of(tag, &first)]),
    )
    .unwrap();
    let (short_cached, again, _) = run("short");
    assert!(
        !short_cached,
        "a record missing the steps' nodes is not trusted"
    );
    assert_eq!(again, cold);
}
