//! The projection cache in whole runs: warm = cold bit for bit; reflectance, site and
//! weather changes reuse every record and equal a cold run of the changed scene; moving a
//! vertex misses; damaged records are rebuilt with the result unchanged; four processes
//! fill one empty folder together.

use daystep::cache::{self, Store};
use daystep::scene::Scene;
use daystep::sequence::instant::{run_instant_cached, write_instant};
use daystep::sequence::{Quality, SkySpec};
use daystep::site::parse_time;
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

#[test]
fn warm_equals_cold_and_colour_site_weather_changes_all_hit() {
    let d = tempfile::tempdir().unwrap();
    let (sd, cd) = (d.path().join("scene"), d.path().join("cache"));
    std::fs::create_dir(&sd).unwrap();
    let scene = office_copy(&sd, |_, t| t);
    let store = Store::open(&cd, cache::DEFAULT_MAX_BYTES);
    let (cold, s1) = run(&scene, &sky(700.0), &store);
    assert!(s1.misses > 0 && s1.hits == 0, "{s1:?}");
    let (warm, s2) = run(&scene, &sky(700.0), &store);
    assert_eq!(s2.misses, 0, "{s2:?}");
    assert!(s2.hits > 0);
    assert_eq!(cold, warm, "a warm cache changes nothing");
    let (nocache, _) = run(&scene, &sky(700.0), &Store::disabled());
    assert_eq!(cold, nocache);

    // Wall colour: all hits, and equal to a cold run of the recoloured scene.
    let kd = |f: &str, t: String| {
        if f == "office.mtl" {
            t.replace("newmtl wall\nKd 0.5 0.5 0.5", "newmtl wall\nKd 0.7 0.6 0.5")
        } else {
            t
        }
    };
    let sd2 = d.path().join("recoloured");
    std::fs::create_dir(&sd2).unwrap();
    let scene2 = office_copy(&sd2, kd);
    let (recoloured, s3) = run(&scene2, &sky(700.0), &store);
    assert_eq!(s3.misses, 0, "Kd is not in the key: {s3:?}");
    assert_ne!(recoloured, cold);
    assert_eq!(recoloured, run(&scene2, &sky(700.0), &Store::disabled()).0);

    // Another weather (same instant): all hits where the directions recur.
    let (_, s4) = run(&scene, &sky(300.0), &store);
    assert_eq!(s4.rebuilds, 0);
    assert!(s4.hits > 0, "{s4:?}");

    // Another site: the sun moves (new sun key) but every sky node is a hit.
    let sd3 = d.path().join("moved_site");
    std::fs::create_dir(&sd3).unwrap();
    let scene3 = office_copy(&sd3, |f, t| {
        if f == "scene.toml" {
            t.replace("latitude = 36.1", "latitude = 40.0")
        } else {
            t
        }
    });
    let (moved, s5) = run(&scene3, &sky(700.0), &store);
    assert!(s5.hits > 0);
    assert_eq!(moved, run(&scene3, &sky(700.0), &Store::disabled()).0);

    // Moving one vertex: a new geometry, every lookup misses.
    let sd4 = d.path().join("moved_vertex");
    std::fs::create_dir(&sd4).unwrap();
    let scene4 = office_copy(&sd4, |f, t| {
        if f == "office.obj" {
            t.replacen("v 0 8 3\n", "v 0 8 3.01\n", 1)
        } else {
            t
        }
    });
    let (_, s6) = run(&scene4, &sky(700.0), &store);
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
