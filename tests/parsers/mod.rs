//! Property-based tests of every parser: whatever the input, a parser returns `Ok` (with
//! finite, in-range contents) or an input error naming the file — and, for line-based
//! formats, a line of it — and it never panics, hangs or allocates in proportion to a count
//! it read rather than to the input's size.
//!
//! Inputs are arbitrary bytes and strings and, which finds far more, structured mutations of
//! valid samples (the bundled `scenes/office/` files, the EPW header with its first 48
//! records, a generated WEA): lines deleted, duplicated, swapped or inserted (format-specific
//! hostile lines such as the face `f 4294967295 1 2`), fields replaced by hostile values
//! (NaN, inf, 1e308, −0, empty, 9999, 20-digit integers, long strings, unicode, NUL, …), and
//! the result cut at a random byte. Cache records get random bit flips, truncation and bytes
//! appended (always an error: both checksums cover everything), and header fields set to
//! hostile integers with the checksums recomputed, which reaches the bounds checks behind
//! them. Every call is wrapped: a panic fails the property with its (shrunk) input, and so
//! does a call slower than 10 s; a call that has not returned after 2 minutes is a hang,
//! and a watchdog names the property and the input on stderr and aborts the binary.
//!
//! Cases per property (fixed seed, so CI is repeatable; `PROPTEST_RNG_SEED=n` explores other
//! inputs and `PROPTEST_CASES=n` runs n cases of every property). About 109,000 cases run in
//! all, in about 15 s on 2 busy cores:
//!
//! | parser | arbitrary input | structured mutations | other |
//! |---|---|---|---|
//! | scene.toml (`Scene::load`) | 1024 strings | 4096 | 2048 models near `f64::MAX` |
//! | OBJ (`scene::obj::load`) | 2048 bytes or OBJ-like text | 8192 | huge indices |
//! | MTL (through `obj::load`) | 2048 strings | 4096 | |
//! | .pts (`scene::sensors::load`) | 2048 bytes or .pts-like text | 4096 | 2048 through `Scene::load` |
//! | EPW (`weather::epw::parse`) | 2048 strings | 8192 | header claiming 60 rows/hour |
//! | WEA (`weather::wea::parse`) | 2048 strings | 8192 | |
//! | cache record (`MappedRecord::from_bytes`, `decode_direction`) | 4096 bytes | 4096 flips/cuts, 8192 re-signed fields | huge counts |
//! | cache folder (`Store::get`) | 1024 bytes | 1024 flips/cuts | |
//! | Radiance HDR (`render::rgbe::decode_hdr`) | 4096 bytes, or scanline bytes after any resolution line | 4096 | 256 round trips |
//! | OpenEXR (`render::exr::decode_exr`) | 6144 bytes, or bytes after the magic or after a header of any size and compression | 8192 header/table edits of 42 samples | the 42 samples (every layout) read |
//! | view options (`View::with_options`) | 2048 strings or option-like text | 4096 | 4096 round trips |
//! | view file (`View::read_file`) | 1024 strings | 4096 | |
//!
//! Pictures also must not allocate for the size they declare unless they are read: a refused
//! picture allocates at most 1 MiB + twice its length at once (an OpenEXR file whose header
//! is within daystep's limits, also what its decoder and image need, reserved before decoding).
//!
//! Allocation is measured by a counting global allocator that only counts on a thread that
//! asked it to ([`metered`]); every other test of this binary pays one thread-local read per
//! allocation.

use daystep::cache::{
    decode_direction, encode_direction, MappedRecord, RecordKey, SceneHash, Section, Store,
    DEFAULT_MAX_BYTES, FIRST_USER_TAG, KIND_SUN,
};
use daystep::error::Error;
use daystep::hierarchy::ElementKey;
use daystep::projection::{DirectionRecord, LeafWeight, ProjectionStats};
use daystep::render::image::{MAX_PIXELS, MAX_SAMPLES};
use daystep::render::{exr, rgbe, Image, Quantity};
use daystep::scene::view::{View, ViewType, MAX_COORDINATE_M, MAX_SHIFT};
use daystep::scene::{obj, sensors, Scene};
use daystep::weather::{epw, wea, Weather};
use glam::DVec3;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub(crate) type CaseResult = Result<(), TestCaseError>;

// The properties, one file per kind of input.
mod scene_files;
mod weather;
mod records;
mod pictures;
mod views;

mod meter; // the allocation meter
use meter::metered;

// ---------------------------------------------------------------------------------------
// Running properties

/// Seed of every property unless `PROPTEST_RNG_SEED` is set.
const SEED: u64 = 0x0064_6179_7374_6570; // "daystep" in ASCII

/// A call slower than this fails its property (a blow-up on an input of a few KiB).
const SLOW: Duration = Duration::from_secs(10);

/// A case still running after this is a hang. A hung call cannot be stopped, so the
/// watchdog names the property and the input on stderr and aborts the test binary.
const HANG: Duration = Duration::from_secs(120);

/// The case a property is running, for its watchdog: when it started and its input.
type Current = Arc<Mutex<(Instant, String)>>;

/// Runs `test` on `cases` inputs of `strategy` (no regression files, fixed seed) and fails
/// the test with the shrunk input when the property fails; a watchdog aborts on a hang.
pub(crate) fn check<S: Strategy>(cases: u32, strategy: S, test: impl Fn(S::Value) -> CaseResult) {
    let defaults = Config::default();
    let config = Config {
        cases: if std::env::var_os("PROPTEST_CASES").is_some() {
            defaults.cases
        } else {
            cases
        },
        failure_persistence: None,
        rng_seed: match defaults.rng_seed {
            RngSeed::Random => RngSeed::Fixed(SEED),
            seed => seed,
        },
        max_shrink_time: 60_000,
        ..defaults
    };
    let name = std::thread::current().name().unwrap_or("?").to_owned();
    let current: Current = Arc::new(Mutex::new((Instant::now(), String::new())));
    let done = Arc::new(AtomicBool::new(false));
    let watchdog = {
        let (current, done) = (Arc::clone(&current), Arc::clone(&done));
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::park_timeout(Duration::from_secs(1));
                let guard = current.lock().unwrap_or_else(|e| e.into_inner());
                if guard.0.elapsed() > HANG && !done.load(Ordering::Relaxed) {
                    eprintln!("{name}: hang: no answer within {HANG:?} for {}", guard.1);
                    std::process::abort();
                }
            }
        })
    };
    // Stops the watchdog however this function is left (a panic included).
    let _stop = Stop(done, watchdog.thread().clone());
    let result = TestRunner::new(config).run(&strategy, |value| {
        *current.lock().unwrap_or_else(|e| e.into_inner()) = (Instant::now(), format!("{value:?}"));
        test(value)
    });
    if let Err(e) = result {
        panic!("{e}");
    }
}

/// Tells a watchdog to stop when dropped.
struct Stop(Arc<AtomicBool>, std::thread::Thread);

impl Drop for Stop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
        self.1.unpark();
    }
}

/// Runs `f`: its value, or a failure naming a panic (with its message) or a call slower
/// than [`SLOW`].
pub(crate) fn guarded<T>(f: impl FnOnce() -> T) -> Result<T, TestCaseError> {
    let start = Instant::now();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    let took = start.elapsed();
    match result {
        Ok(_) if took > SLOW => Err(TestCaseError::fail(format!("slow: {took:?}"))),
        Ok(value) => Ok(value),
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(TestCaseError::fail(format!("panicked: {message}")))
        }
    }
}

// ---------------------------------------------------------------------------------------
// Samples and mutations

fn office(name: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/office")
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Values that break parsers: non-finite and extreme numbers, integers past every integer
/// type, empty and long strings, unicode, control characters and separators.
fn hostile_values() -> Vec<String> {
    let words = "NaN nan inf -inf +inf infinity 1e308 -1e308 1e309 1e-320 -0 0 -1 0.5 9999 99.9 \
                 24 60 13 29 4294967295 -4294967295 4294967296 9223372036854775807 \
                 -9223372036854775808 18446744073709551616 99999999999999999999 \
                 -99999999999999999999 0x10 1_000 1/2/3 // # , = \" [ é☃𝄞 \u{feff} \u{202e} \0";
    let mut v: Vec<String> = words.split(' ').map(String::from).collect();
    v.extend(["", "\t", "\r"].map(String::from));
    v.push("x".repeat(5000));
    v.push("9".repeat(400));
    v.push(format!("0.{}", "0".repeat(400)));
    v.push("ü".repeat(1000));
    v
}

/// How a format splits a line into fields.
#[derive(Clone, Copy)]
pub(crate) enum Sep {
    Whitespace,
    Comma,
}

/// One format's mutation material.
pub(crate) struct Format {
    sep: Sep,
    /// Field values to try: [`hostile_values`] and the format's own.
    values: Vec<String>,
    /// Whole lines to insert.
    lines: Vec<String>,
}

impl Format {
    /// `values`: the format's own values, separated by single spaces; `lines`: one per line.
    pub(crate) fn new(sep: Sep, values: &str, lines: &str) -> Format {
        let mut v = hostile_values();
        v.extend(values.split(' ').map(String::from));
        Format {
            sep,
            values: v,
            lines: lines.lines().map(String::from).collect(),
        }
    }
}

#[derive(Clone, Debug)]
pub(crate) enum Edit {
    Delete(Index),
    Duplicate(Index),
    Swap(Index, Index),
    /// Line, field, value (an index into [`Format::values`]).
    Field(Index, Index, Index),
    /// Position, line (an index into [`Format::lines`]).
    Insert(Index, Index),
}

/// One to four edits, then perhaps a cut at a random byte.
#[derive(Clone, Debug)]
pub(crate) struct Mutation {
    edits: Vec<Edit>,
    cut: Option<Index>,
}

pub(crate) fn mutations() -> impl Strategy<Value = Mutation> {
    let edit = prop_oneof![
        1 => any::<Index>().prop_map(Edit::Delete),
        1 => any::<Index>().prop_map(Edit::Duplicate),
        1 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Edit::Swap(a, b)),
        4 => (any::<Index>(), any::<Index>(), any::<Index>())
            .prop_map(|(l, f, v)| Edit::Field(l, f, v)),
        2 => (any::<Index>(), any::<Index>()).prop_map(|(at, l)| Edit::Insert(at, l)),
    ];
    (
        prop::collection::vec(edit, 1..=4),
        prop::option::weighted(0.2, any::<Index>()),
    )
        .prop_map(|(edits, cut)| Mutation { edits, cut })
}

/// `sample` with `m` applied (the cut may split a UTF-8 sequence).
fn mutate(sample: &str, m: &Mutation, f: &Format) -> Vec<u8> {
    let mut lines: Vec<String> = sample.lines().map(str::to_owned).collect();
    for e in &m.edits {
        let n = lines.len();
        match e {
            Edit::Insert(at, l) => {
                let line = f.lines[l.index(f.lines.len())].clone();
                lines.insert(at.index(n + 1), line);
            }
            _ if n == 0 => {}
            Edit::Delete(i) => {
                lines.remove(i.index(n));
            }
            Edit::Duplicate(i) => {
                let k = i.index(n);
                lines.insert(k, lines[k].clone());
            }
            Edit::Swap(a, b) => lines.swap(a.index(n), b.index(n)),
            Edit::Field(l, field, v) => {
                let line = &mut lines[l.index(n)];
                let value = f.values[v.index(f.values.len())].as_str();
                let mut fields: Vec<&str> = match f.sep {
                    Sep::Whitespace => line.split_whitespace().collect(),
                    Sep::Comma => line.split(',').collect(),
                };
                if fields.is_empty() {
                    fields.push(value);
                } else {
                    let k = field.index(fields.len());
                    fields[k] = value;
                }
                *line = fields.join(match f.sep {
                    Sep::Whitespace => " ",
                    Sep::Comma => ",",
                });
            }
        }
    }
    let mut bytes = (lines.join("\n") + "\n").into_bytes();
    if let Some(c) = &m.cut {
        bytes.truncate(c.index(bytes.len() + 1));
    }
    bytes
}

/// [`mutate`] for parsers of `&str`: the cut moves back to a character boundary.
pub(crate) fn mutate_text(sample: &str, m: &Mutation, f: &Format) -> String {
    let bytes = mutate(sample, m, f);
    match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => {
            let valid = e.utf8_error().valid_up_to();
            let mut b = e.into_bytes();
            b.truncate(valid);
            String::from_utf8(b).expect("valid prefix")
        }
    }
}

/// Arbitrary text: any characters, newlines included.
pub(crate) fn any_text() -> impl Strategy<Value = String> {
    "(?s).{0,600}"
}

/// Text matching `pattern` (a regular expression built at run time).
pub(crate) fn regex(pattern: &str) -> impl Strategy<Value = String> {
    prop::string::string_regex(pattern).expect("a valid pattern")
}

fn any_bytes() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(any::<u8>(), 0..2048)
}

// ---------------------------------------------------------------------------------------
// Checks

/// How an error may name its file.
pub(crate) struct Naming<'a> {
    /// The files the parser may blame (an error naming any other path fails).
    pub(crate) files: &'a [PathBuf],
    /// Messages of errors about a whole file, which need no line.
    pub(crate) whole_file: &'a [&'a str],
    /// True when a one-word value must appear on the named line (line-based formats whose
    /// values are quoted as written).
    pub(crate) value_on_line: bool,
}

/// Checks that `e` is an input or I/O error naming one of `n.files` and, unless it is about
/// a whole file, a line that exists (and, where asked, holds the quoted value).
pub(crate) fn check_error(e: &Error, n: &Naming<'_>) -> CaseResult {
    let shown = e.to_string();
    match e {
        Error::Input {
            path,
            line,
            value,
            message,
        } => {
            prop_assert!(n.files.contains(path), "names an unexpected file: {shown}");
            let named = path.display().to_string();
            prop_assert!(
                shown.starts_with(&named),
                "does not start with the file: {shown}"
            );
            let Some(l) = *line else {
                prop_assert!(
                    n.whole_file.iter().any(|m| message.contains(m)),
                    "no line number: {shown}"
                );
                return Ok(());
            };
            prop_assert!(
                shown.starts_with(&format!("{named}:{l}:")),
                "not `file:line:`: {shown}"
            );
            let bytes = std::fs::read(path).unwrap_or_default();
            let count = bytes.split(|&b| b == b'\n').count();
            prop_assert!((1..=count).contains(&l), "line {l} of {count}: {shown}");
            if let Some(v) = value.as_deref() {
                let word = !v.is_empty() && !v.contains(char::is_whitespace) && !v.contains(',');
                if n.value_on_line && word {
                    let text = bytes.split(|&b| b == b'\n').nth(l - 1).unwrap_or_default();
                    prop_assert!(
                        String::from_utf8_lossy(text).contains(v),
                        "value {v:?} is not on line {l}: {shown}"
                    );
                }
            }
            Ok(())
        }
        Error::Io { path, .. } => {
            prop_assert!(n.files.contains(path), "names an unexpected file: {shown}");
            Ok(())
        }
        other => Err(TestCaseError::fail(format!("not an input error: {other}"))),
    }
}

/// [`check_error`] for the text parsers, whose file is `path` holding `text`.
fn check_text_error(e: &Error, path: &Path, text: &str) -> CaseResult {
    let Error::Input {
        path: p,
        line,
        value,
        ..
    } = e
    else {
        return Err(TestCaseError::fail(format!("not an input error: {e}")));
    };
    let shown = e.to_string();
    prop_assert_eq!(p.as_path(), path, "{}", shown);
    let l = line.ok_or_else(|| TestCaseError::fail(format!("no line number: {shown}")))?;
    prop_assert!(
        shown.starts_with(&format!("{}:{l}:", path.display())),
        "not `file:line:`: {shown}"
    );
    let lines: Vec<&str> = text.split('\n').collect();
    prop_assert!(
        (1..=lines.len()).contains(&l),
        "line {l} of {}: {shown}",
        lines.len()
    );
    if let Some(v) = value.as_deref() {
        if !v.is_empty() && !v.contains(char::is_whitespace) && !v.contains(',') {
            prop_assert!(
                lines[l - 1].contains(v),
                "value {v:?} is not on line {l}: {shown}"
            );
        }
    }
    Ok(())
}

fn unit(v: DVec3) -> bool {
    v.is_finite() && (v.length() - 1.0).abs() < 1e-9
}

/// What a loaded scene promises: everything finite, indices in range, unit sensor normals.
fn check_scene(s: &Scene) -> CaseResult {
    prop_assert!(s.origin.is_finite(), "origin {}", s.origin);
    for t in &s.triangles {
        prop_assert!(t.v.iter().all(|v| v.is_finite()), "{:?}", t);
        prop_assert!(t.area() > 0.0 && t.area().is_finite(), "{:?}", t);
        prop_assert!(unit(t.normal()), "normal {} of {:?}", t.normal(), t);
        prop_assert!((t.material as usize) < s.materials.len());
        prop_assert!((t.group as usize) < s.groups.len());
    }
    for x in &s.sensors {
        prop_assert!(
            x.position.is_finite() && x.input_position.is_finite(),
            "{:?}",
            x
        );
        prop_assert!(
            unit(x.normal),
            "sensor normal {} is not a unit vector",
            x.normal
        );
    }
    check_materials(&s.materials)?;
    prop_assert!((0.0..1.0).contains(&s.ground_reflectance));
    prop_assert!(s.site.latitude.abs() <= 90.0 && s.site.longitude.abs() <= 180.0);
    prop_assert!(s.site.utc_offset_h.abs() <= 14.0 && s.site.elevation_m.is_finite());
    Ok(())
}

pub(crate) fn check_materials(materials: &[daystep::scene::Material]) -> CaseResult {
    for m in materials {
        let a = |v: DVec3| v.to_array();
        prop_assert!(a(m.kd).iter().all(|&x| (0.0..1.0).contains(&x)), "{:?}", m);
        prop_assert!(a(m.tf).iter().all(|&x| (0.0..=1.0).contains(&x)), "{:?}", m);
        prop_assert!(
            a(m.ke).iter().all(|&x| x.is_finite() && x >= 0.0),
            "{:?}",
            m
        );
    }
    Ok(())
}

/// What a read weather file promises: a valid site, times strictly increasing, finite
/// non-negative irradiance, lines of the file.
fn check_weather(w: &Weather, text: &str) -> CaseResult {
    let s = &w.site;
    prop_assert!(
        s.latitude.abs() <= 90.0 && s.longitude.abs() <= 180.0,
        "{:?}",
        s
    );
    prop_assert!(
        s.utc_offset_h.abs() <= 14.0 && s.elevation_m.is_finite(),
        "{:?}",
        s
    );
    prop_assert!(w.interval_minutes >= 1);
    let lines = text.split('\n').count();
    for r in &w.records {
        prop_assert!(r.dni.is_finite() && r.dni >= 0.0 && r.dhi.is_finite() && r.dhi >= 0.0);
        prop_assert!(r.dew_point_c.is_none_or(f64::is_finite));
        prop_assert!((1..=lines).contains(&r.line), "{:?}", r);
    }
    for p in w.records.windows(2) {
        prop_assert!(p[1].time > p[0].time, "{:?} then {:?}", p[0], p[1]);
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// A folder of scene files

/// A temporary copy of the office scene (scene.toml, office.obj, office.mtl, office.pts).
struct Folder {
    dir: tempfile::TempDir,
    files: Vec<PathBuf>,
}

const OFFICE_FILES: [&str; 4] = ["scene.toml", "office.obj", "office.mtl", "office.pts"];

impl Folder {
    fn office() -> Folder {
        let dir = tempfile::tempdir().expect("temporary folder");
        for name in OFFICE_FILES {
            std::fs::write(dir.path().join(name), office(name)).expect("write");
        }
        let files = OFFICE_FILES.iter().map(|n| dir.path().join(n)).collect();
        Folder { dir, files }
    }
    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
    /// Writes `bytes` as `name`, returning its path. The old file is removed first: on ext4
    /// a file truncated and rewritten is flushed to disk on close, one wait per case.
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.path(name);
        let _ = std::fs::remove_file(&p);
        std::fs::write(&p, bytes).expect("write");
        p
    }
}

/// Loads the folder's scene (guarded) and checks the outcome.
fn load_scene(f: &Folder) -> CaseResult {
    let p = f.path("scene.toml");
    match guarded(|| Scene::load(&p))? {
        Ok(s) => check_scene(&s),
        Err(e) => check_error(
            &e,
            &Naming {
                files: &f.files,
                whole_file: SCENE_WHOLE_FILE,
                value_on_line: false,
            },
        ),
    }
}

/// Loads the folder's OBJ (`name`, guarded) and checks the outcome.
fn load_obj(f: &Folder, name: &str, y_up: bool, value_on_line: bool) -> CaseResult {
    let p = f.path(name);
    let mut files = f.files.clone();
    files.push(p.clone());
    match guarded(|| obj::load(&p, y_up))? {
        Ok((triangles, materials, groups, _)) => {
            for t in &triangles {
                prop_assert!(t.v.iter().all(|v| v.is_finite()), "{:?}", t);
                prop_assert!((t.material as usize) < materials.len());
                prop_assert!((t.group as usize) < groups.len());
            }
            prop_assert!(!triangles.is_empty() || materials.is_empty());
            check_materials(&materials)
        }
        Err(e) => check_error(
            &e,
            &Naming {
                files: &files,
                whole_file: OBJ_WHOLE_FILE,
                value_on_line,
            },
        ),
    }
}

/// OBJ errors about the whole file (no line).
const OBJ_WHOLE_FILE: &[&str] = &["the OBJ file has no faces", "OBJ parser:"];

/// Scene errors about the whole file: a missing key, or a model problem found after all
/// files were read.
const SCENE_WHOLE_FILE: &[&str] = &[
    "the OBJ file has no faces",
    "OBJ parser:",
    "missing required key `geometry`",
    "non-finite vertex",
    "too far out to rotate",
    "too far from the geometry",
];

// ---------------------------------------------------------------------------------------
