//! The projection cache end to end: store round trips, every kind of bad file rebuilt and
//! never trusted, read-only folders, LRU eviction, threads and processes sharing one
//! folder, and the `daystep cache` commands.

use crate::util::daystep;
use daystep::cache::{
    self, decode_direction, encode_direction, RecordKey, SceneHash, Section, Store,
    DEFAULT_MAX_BYTES, FIRST_USER_TAG, KIND_SKY_NODE,
};
use daystep::hierarchy::ElementKey;
use daystep::projection::{DirectionRecord, LeafWeight, ProjectionStats};
use glam::DVec3;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

const VISIBILITY: u32 = FIRST_USER_TAG;

fn key(direction: u64) -> RecordKey {
    RecordKey {
        scene: SceneHash(*blake3::hash(b"cache integration test").as_bytes()),
        kind: KIND_SKY_NODE,
        direction,
        resolution: 128,
    }
}

/// A deterministic direction record of `n` leaves, different for every `seed`.
fn direction_record(seed: u64, n: usize) -> DirectionRecord {
    let x = |i: u64| ((seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ i) % 1000) as f64 / 997.0;
    DirectionRecord {
        leaves: (0..n as u64)
            .map(|i| LeafWeight {
                key: ElementKey {
                    tri: i as u32,
                    path: 1 + (i % 5),
                },
                weight: DVec3::new(x(i), x(i + 1) * 0.5, x(i + 2) / 3.0),
            })
            .collect(),
        stats: ProjectionStats {
            width: 128,
            height: 96,
            pixel_m: 0.03125,
            fragments: 1234 + seed,
            elements_tested: 77,
            elements_split: 11,
            lit_leaves: n as u64,
        },
    }
}

fn sensor_visibility(seed: u64) -> Vec<f64> {
    (0..16).map(|i| ((seed + i) % 7) as f64 / 6.0).collect()
}

fn encoded(seed: u64, n: usize) -> Vec<u8> {
    let vis = sensor_visibility(seed);
    encode_direction(
        &key(seed),
        &direction_record(seed, n),
        &[Section::f64s(VISIBILITY, &vis)],
    )
}

#[test]
fn put_then_get_returns_the_record_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    let bytes = encoded(5, 300);
    store.put(&key(5), &bytes);
    let mapped = store.get(&key(5)).expect("a hit");
    // Read into memory below the read limit, mapped above it.
    assert_eq!(
        mapped.is_mapped(),
        bytes.len() as u64 > daystep::cache::READ_MAX_BYTES
    );
    assert_eq!(mapped.bytes(), &bytes[..]);
    let back = decode_direction(&mapped).unwrap();
    let want = direction_record(5, 300);
    assert_eq!(back, want);
    for (a, b) in back.leaves.iter().zip(&want.leaves) {
        assert_eq!(
            a.weight.to_array().map(f64::to_bits),
            b.weight.to_array().map(f64::to_bits)
        );
    }
    assert_eq!(mapped.f64s(VISIBILITY).unwrap(), &sensor_visibility(5)[..]);
    let s = store.stats();
    assert_eq!(
        (s.hits, s.misses, s.rebuilds, s.writes, s.write_failures),
        (1, 0, 0, 1, 0)
    );
    assert!(cache::verify(dir.path()).unwrap().is_clean());
}

#[test]
fn records_written_section_by_section_read_back_as_encoded_ones() {
    // Odd lengths (padding) and several sections: the streamed file is the encoded
    // record byte for byte, and validates.
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    let a: Vec<f64> = (0..1001).map(|i| i as f64 * 0.25).collect();
    let b: Vec<u32> = (0..7).collect();
    let c: Vec<u8> = (0..13).collect();
    let sections = [
        Section::f64s(FIRST_USER_TAG, &a),
        Section::u32s(FIRST_USER_TAG + 1, &b),
        Section::of(FIRST_USER_TAG + 2, &c),
    ];
    store.put_sections(&key(9), &sections);
    let mapped = store.get(&key(9)).expect("a hit");
    assert_eq!(mapped.bytes(), &cache::encode(&key(9), &sections)[..]);
    assert_eq!(mapped.f64s(FIRST_USER_TAG).unwrap(), &a[..]);
    assert_eq!(mapped.u32s(FIRST_USER_TAG + 1).unwrap(), &b[..]);
    assert_eq!(store.stats().writes, 1);
    assert!(cache::verify(dir.path()).unwrap().is_clean());
}

/// Writes `bytes` directly under the file name of `k`, as a crash or a foreign tool might.
fn plant(dir: &Path, k: &RecordKey, bytes: &[u8]) -> PathBuf {
    let p = dir.join(k.file_name());
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn every_kind_of_bad_file_is_rebuilt_never_trusted() {
    let good = encoded(1, 50);
    let n = good.len();
    let mut cases: Vec<(&str, Vec<u8>)> = Vec::new();
    cases.push(("truncated", good[..n - 13].to_vec()));
    let mut c = good.clone();
    c[n - 100] ^= 0x04;
    cases.push(("payload bit", c));
    let mut c = good.clone();
    c[50] ^= 0x01; // the direction field of the key
    cases.push(("header bit", c));
    let mut c = good.clone();
    c[8..12].copy_from_slice(&99u32.to_le_bytes());
    cases.push(("other version", c));
    cases.push(("record of another key", encoded(2, 50)));
    let mut random = vec![0u8; 4096];
    blake3::Hasher::new()
        .update(b"random")
        .finalize_xof()
        .fill(&mut random);
    cases.push(("random bytes", random));
    cases.push((
        "text file",
        b"# not a record\nsome notes someone saved as .dsr\n".repeat(10),
    ));
    cases.push(("empty file", Vec::new()));

    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    for (i, (what, bytes)) in cases.iter().enumerate() {
        let k = key(1);
        let p = plant(dir.path(), &k, bytes);
        let report = cache::verify(dir.path()).unwrap();
        assert_eq!(report.invalid.len(), 1, "{what}: verify missed it");
        assert!(store.get(&k).is_none(), "{what}: trusted");
        assert!(!p.exists(), "{what}: not removed");
        assert_eq!(store.stats().rebuilds, i as u64 + 1, "{what}");
        // The rebuilt record is then served normally.
        store.put(&k, &good);
        assert!(store.get(&k).is_some(), "{what}: not rebuilt");
        std::fs::remove_file(&p).unwrap();
    }
    let s = store.stats();
    assert_eq!(s.hits, cases.len() as u64);
    assert_eq!(s.misses, 0);
    let w = store.warnings();
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(
        w[0].contains(&key(1).file_name()) && w[0].contains("truncated"),
        "{w:?}"
    );
    assert!(w[1].contains(&format!("{} more", cases.len() - 1)), "{w:?}");
}

#[test]
fn a_folder_that_cannot_be_written_gives_a_disabled_store_and_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    // Under a regular file: cannot be created, even as root.
    let file = dir.path().join("plain");
    std::fs::write(&file, "x").unwrap();
    let store = Store::open(&file.join("cache"), DEFAULT_MAX_BYTES);
    assert!(!store.is_enabled());
    assert_eq!(store.warnings().len(), 1);
    assert!(store.warnings()[0].contains("cache disabled"));
    store.put(&key(1), &encoded(1, 3));
    assert!(store.get(&key(1)).is_none());
    assert_eq!(store.stats().write_failures, 0);

    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let ro = dir.path().join("ro");
        std::fs::create_dir(&ro).unwrap();
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
        if std::fs::write(ro.join("probe"), "x").is_ok() {
            eprintln!("skipped the read-only case: running as root, 0o555 is writable");
        } else {
            let store = Store::open(&ro, DEFAULT_MAX_BYTES);
            assert!(!store.is_enabled());
            let w = store.warnings();
            assert!(
                w.len() == 1 && w[0].contains(&ro.display().to_string()),
                "{w:?}"
            );
        }
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
}

#[test]
fn eviction_keeps_the_most_recently_used_records() {
    let dir = tempfile::tempdir().unwrap();
    let size = encoded(0, 100).len() as u64;
    // Room for four and a half records; eviction trims to 90 % of that (four).
    let store = Store::open(dir.path(), 4 * size + size / 2);
    let path = |d: u64| dir.path().join(key(d).file_name());
    let mtime = |d: u64| std::fs::metadata(path(d)).unwrap().modified().unwrap();
    let now = std::time::SystemTime::now();
    // Written an hour ago, 50, 40 and 30 minutes ago.
    for d in 0..4 {
        store.put(&key(d), &encoded(d, 100));
        let age = Duration::from_secs(60 * (60 - 10 * d));
        let f = std::fs::File::options().write(true).open(path(d)).unwrap();
        f.set_modified(now - age).unwrap();
    }
    assert!(store.get(&key(0)).is_some()); // 0 becomes the most recently used
    assert!(mtime(0) >= now);
    store.put(&key(4), &encoded(4, 100));
    let present: Vec<u64> = (0..5).filter(|&d| path(d).exists()).collect();
    assert_eq!(present, vec![0, 2, 3, 4]);
    assert_eq!(store.stats().evictions, 1);
    // A record used minutes ago is not touched again (a warm run reading what its cold
    // run wrote): the last use is kept to within a quarter of an hour.
    let written = mtime(4);
    std::thread::sleep(Duration::from_millis(20));
    assert!(store.get(&key(4)).is_some());
    assert_eq!(mtime(4), written);
    let s = cache::dir_stats(dir.path()).unwrap();
    assert_eq!((s.files, s.bytes), (4, 4 * size));
    assert!(s.oldest.unwrap() <= s.newest.unwrap());
}

const CHILD_ENV: &str = "DAYSTEP_CACHE_TEST_CHILD_DIR";
/// A folder beside the cache where children say they are ready and wait for `go`.
const SYNC_ENV: &str = "DAYSTEP_CACHE_TEST_SYNC_DIR";
/// Rounds over the keys; odd rounds rewrite every shared key.
const ROUNDS: u64 = 6;
/// Keys every worker reads and writes.
const SHARED_KEYS: u64 = 12;
/// Keys only one worker writes: worker `w` owns `own_key(w, 0..OWN_KEYS)`.
const OWN_KEYS: u64 = 6;
/// Workers: 0..4 are threads of the test, 4..8 child processes.
const WORKERS: u64 = 8;
/// Leaves per record (40 bytes each: about 80 KB a record, so a write takes a while).
const LEAVES: usize = 2000;

fn own_key(worker: u64, j: u64) -> u64 {
    1000 + 100 * worker + j
}

/// Waits until `path` exists, at most a minute.
fn wait_for(path: &Path) {
    let t = std::time::Instant::now();
    while !path.exists() {
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "no {} within a minute",
            path.display()
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// Every worker, [`ROUNDS`] rounds: look each shared key up; a hit must be the expected
/// record byte for byte; on a miss, write it and check that it is then served. In odd
/// rounds every shared key is written again whatever the lookup found, so renames replace
/// records while other workers read them. Shared keys are visited in a worker-specific
/// order. The worker also writes its own keys (round 0) and reads them back (every round).
fn share_keys(store: &Store, worker: u64) {
    for round in 0..ROUNDS {
        for i in 0..SHARED_KEYS {
            let d = (i * (2 * worker + 1) + round) % SHARED_KEYS;
            let want = encoded(d, LEAVES);
            let got = match store.get(&key(d)) {
                Some(hit) if round % 2 == 0 => hit,
                _ => {
                    store.put(&key(d), &want);
                    store.get(&key(d)).expect("served right after writing")
                }
            };
            assert!(
                got.bytes() == &want[..],
                "worker {worker}: key {d} read back other bytes"
            );
        }
        for j in 0..OWN_KEYS {
            let d = own_key(worker, j);
            let want = encoded(d, LEAVES);
            if round == 0 {
                store.put(&key(d), &want);
            }
            let got = store.get(&key(d)).expect("an own key is served");
            assert!(
                got.bytes() == &want[..],
                "worker {worker}: own key {d} read back other bytes"
            );
        }
    }
    let s = store.stats();
    assert_eq!(
        (s.rebuilds, s.write_failures),
        (0, 0),
        "{:?}",
        store.warnings()
    );
}

/// Child-process half of the concurrency test; does nothing unless started by it.
#[test]
fn child_process_worker() {
    let Ok(dir) = std::env::var(CHILD_ENV) else {
        return;
    };
    let worker: u64 = std::env::var("DAYSTEP_CACHE_TEST_WORKER")
        .unwrap()
        .parse()
        .unwrap();
    let sync = PathBuf::from(std::env::var(SYNC_ENV).unwrap());
    std::fs::write(sync.join(format!("ready-{worker}")), "").unwrap();
    wait_for(&sync.join("go"));
    share_keys(&Store::open(Path::new(&dir), DEFAULT_MAX_BYTES), worker);
}

/// Four threads and four processes write overlapping keys (all of them the shared ones,
/// rewriting them while others read) and disjoint keys (their own) into one folder at
/// once. Afterwards nothing is lost (every key written is there and reads back bit for
/// bit), nothing is duplicated (the folder holds exactly one file per key: no temporary
/// file, no second name), and `verify` finds nothing invalid. During the run no reader saw
/// a partial or foreign record (no rebuild) and no write failed. All eight start together,
/// once the children are up.
#[test]
fn threads_and_processes_share_one_folder() {
    let dir = tempfile::tempdir().unwrap();
    let sync = tempfile::tempdir().unwrap();
    let exe = std::env::current_exe().unwrap();
    let children: Vec<_> = (4..WORKERS)
        .map(|w| {
            Command::new(&exe)
                .args([
                    "--exact",
                    "cache::child_process_worker",
                    "--test-threads=1",
                    "--nocapture",
                ])
                .env(CHILD_ENV, dir.path())
                .env(SYNC_ENV, sync.path())
                .env("DAYSTEP_CACHE_TEST_WORKER", w.to_string())
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    for w in 4..WORKERS {
        wait_for(&sync.path().join(format!("ready-{w}")));
    }
    std::fs::write(sync.path().join("go"), "").unwrap();
    std::thread::scope(|s| {
        for w in 0..4 {
            let store = &store;
            s.spawn(move || share_keys(store, w));
        }
    });
    for child in children {
        let out = child.wait_with_output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "child failed:\n{text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(text.contains("1 passed"), "the child ran no test:\n{text}");
    }
    // Exactly one file per key written, and nothing else.
    let written: Vec<u64> = (0..SHARED_KEYS)
        .chain((0..WORKERS).flat_map(|w| (0..OWN_KEYS).map(move |j| own_key(w, j))))
        .collect();
    let expected: BTreeSet<String> = written.iter().map(|&d| key(d).file_name()).collect();
    assert_eq!(expected.len(), written.len(), "two keys share a file name");
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let listed: BTreeSet<String> = names.iter().cloned().collect();
    let missing: Vec<_> = expected.difference(&listed).collect();
    let extra: Vec<_> = listed.difference(&expected).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "lost: {missing:?}; not one file per key: {extra:?}"
    );
    assert_eq!(names.len(), expected.len());
    // Every key reads back bit for bit, from the file and through a fresh store.
    let fresh = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    for &d in &written {
        let want = encoded(d, LEAVES);
        let on_disk = std::fs::read(dir.path().join(key(d).file_name())).unwrap();
        assert!(on_disk == want, "key {d}: the file holds other bytes");
        let hit = fresh.get(&key(d)).expect("a hit");
        assert!(hit.bytes() == &want[..], "key {d}: served other bytes");
    }
    assert_eq!(fresh.stats().rebuilds, 0);
    let report = cache::verify(dir.path()).unwrap();
    assert!(report.is_clean(), "{:?}", report.invalid);
    assert_eq!(report.ok, written.len());
    assert_eq!(report.temp_files, 0);
    assert!(report.foreign.is_empty(), "{:?}", report.foreign);
}

#[test]
fn cache_commands_report_verify_fix_and_clear() {
    let dir = tempfile::tempdir().unwrap();
    let c = dir.path().join("cache");
    let store = Store::open(&c, DEFAULT_MAX_BYTES);
    store.put(&key(1), &encoded(1, 10));
    store.put(&key(2), &encoded(2, 10));
    std::fs::write(c.join("README.md"), "notes").unwrap();
    let bad = plant(&c, &key(3), &encoded(3, 10)[..100]);
    let cs = c.to_str().unwrap();
    let stdout = |o: &Output| String::from_utf8_lossy(&o.stdout).into_owned();

    let o = daystep(&["cache", "stats", "--cache", cs]);
    assert!(o.status.success());
    assert!(stdout(&o).contains("3 records"), "{}", stdout(&o));

    let o = daystep(&["cache", "verify", "--cache", cs]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stdout(&o).contains(&key(3).file_name()), "{}", stdout(&o));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--fix"));
    assert!(bad.exists(), "verify without --fix changed the folder");

    let o = daystep(&["cache", "verify", "--fix", "--cache", cs]);
    assert!(o.status.success(), "{}", stdout(&o));
    assert!(!bad.exists());
    let o = daystep(&["cache", "verify", "--cache", cs]);
    assert!(o.status.success(), "{}", stdout(&o));
    assert!(stdout(&o).contains("2 valid, 0 invalid"), "{}", stdout(&o));

    let o = daystep(&["cache", "clear", "--cache", cs]);
    assert!(o.status.success());
    assert!(stdout(&o).contains("removed 2 files"), "{}", stdout(&o));
    assert!(c.join("README.md").exists() && c.join(".gitignore").exists());
    assert_eq!(cache::dir_stats(&c).unwrap().files, 0);

    // The default folder is `cache` in the current directory; a missing one is empty.
    let o = Command::new(env!("CARGO_BIN_EXE_daystep"))
        .args(["cache", "stats"])
        .current_dir(dir.path().join("cache"))
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(stdout(&o).starts_with("cache: 0 records"), "{}", stdout(&o));
}
