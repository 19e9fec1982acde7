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
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub(crate) type CaseResult = Result<(), TestCaseError>;

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
// Allocation meter

thread_local! {
    static METERING: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
    static TOTAL: Cell<usize> = const { Cell::new(0) };
}

/// The system allocator, counting the current thread's allocations while [`metered`] runs.
struct Meter;

fn note(size: usize) {
    // `try_with`: allocations during thread teardown are simply not counted.
    let _ = METERING.try_with(|on| {
        if on.get() {
            LARGEST.set(LARGEST.get().max(size));
            TOTAL.set(TOTAL.get().saturating_add(size));
        }
    });
}

// SAFETY: every call is forwarded unchanged to `System`; the bookkeeping touches only
// const-initialised thread-locals without destructors, which never allocate.
unsafe impl GlobalAlloc for Meter {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        System.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        System.alloc_zeroed(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static METER: Meter = Meter;

/// What `f` allocated on this thread: (its value, largest single allocation, total bytes
/// allocated, time taken).
fn metered<T>(f: impl FnOnce() -> T) -> (T, usize, usize, Duration) {
    LARGEST.set(0);
    TOTAL.set(0);
    METERING.set(true);
    let start = Instant::now();
    let value = f();
    let took = start.elapsed();
    METERING.set(false);
    (value, LARGEST.get(), TOTAL.get(), took)
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
// scene.toml

fn scene_format() -> Format {
    let mut f = Format::new(
        Sep::Whitespace,
        "\"office.obj\" \"office.pts\" \"office.mtl\" \"scene.toml\" \".\" \"\" \"Y\" \"x\" nan \
         -nan 1e400 90.0000001 -180 14 0.999999999 [] {} true 1979-05-27 ''' \"\"\"",
        "\
[site]
[site.site]
[[site]]
geometry = \"office.pts\"
geometry = \"office.mtl\"
geometry = \"office.obj\"
sensors = \"office.obj\"
sensors = \"scene.toml\"
north_deg = 1e308
north_deg = -1e308
north_deg = 45
up = \"y\"
ground_reflectance = -0.0
ground_reflectance = nan
latitude = -90
elevation_m = inf
unknown_key = 1
site.latitude = 0
\"\u{0}\" = 1",
    );
    // Deep nesting (a recursive parser without a limit would overflow the stack).
    f.values.push("[".repeat(5000));
    f.values.push("{a=".repeat(3000));
    f.lines.push(format!("north_deg = {}", "[".repeat(5000)));
    f
}

#[test]
fn scene_file_arbitrary_text() {
    let f = Folder::office();
    let keys = "geometry|sensors|up|north_deg|ground_reflectance|latitude|longitude|utc_offset_h";
    let toml_like = format!(
        "(({keys}) = ([-0-9.e]{{1,6}}|\"(office.obj|office.pts|y|z|)\"|nan|inf)\n|\\[site\\]\n){{0,12}}"
    );
    check(1024, prop_oneof![any_text(), regex(&toml_like)], |text| {
        f.write("scene.toml", text.as_bytes());
        load_scene(&f)
    });
}

#[test]
fn scene_file_mutations() {
    let f = Folder::office();
    let sample = office("scene.toml");
    Scene::load(&f.path("scene.toml")).expect("the bundled scene loads");
    let format = scene_format();
    check(4096, mutations(), |m| {
        f.write("scene.toml", &mutate(&sample, &m, &format));
        load_scene(&f)
    });
}

/// Coordinates that are finite but near the largest `f64`, with any north rotation, either
/// load as a finite scene or fail naming the file: rotating, centring and subtracting the
/// origin must not overflow into an infinite origin or sensor position.
#[test]
fn scene_with_huge_coordinates() {
    let f = Folder::office();
    let c = prop::sample::select(vec![
        0.0,
        1.0,
        -2.5,
        1e300,
        -1e300,
        9e307,
        -9e307,
        1e308,
        -1e308,
        1.7e308,
        -1.7e308,
        f64::MAX,
        f64::MIN,
    ]);
    let point = [c.clone(), c.clone(), c.clone()];
    let north = prop::sample::select(vec![0.0, 30.0, 45.0, 90.0, 180.0, -135.0, 1e300]);
    let input = (
        prop::collection::vec(point.clone(), 3..6),
        prop::collection::vec(point, 0..3),
        north,
        any::<bool>(),
    );
    check(2048, input, |(vertices, sensors, north, y_up)| {
        let mut obj = String::from("mtllib office.mtl\nusemtl wall\n");
        for v in &vertices {
            obj.push_str(&format!("v {:e} {:e} {:e}\n", v[0], v[1], v[2]));
        }
        obj.push_str("f -3 -2 -1\nf 1 2 3\n");
        f.write("office.obj", obj.as_bytes());
        let mut pts = String::new();
        for p in &sensors {
            pts.push_str(&format!("{:e} {:e} {:e} 0 0 1\n", p[0], p[1], p[2]));
        }
        f.write("office.pts", pts.as_bytes());
        let up = if y_up { "y" } else { "z" };
        let scene = format!(
            "geometry = \"office.obj\"\nsensors = \"office.pts\"\nup = \"{up}\"\n\
             north_deg = {north:e}\n"
        );
        f.write("scene.toml", scene.as_bytes());
        load_scene(&f)
    });
}

/// Regression (found by `scene_with_huge_coordinates`): finite coordinates near `f64::MAX`
/// loaded as a scene with an infinite origin (`(lo + hi) / 2` overflowed, or rotating by
/// `north_deg` did), every triangle dropped as degenerate and sensors at infinity. Now the
/// origin is finite and the triangle kept, and what still overflows is an error naming the
/// scene file and the value.
#[test]
fn coordinates_near_f64_max_give_a_finite_origin_or_an_error() {
    let f = Folder::office();
    let write = |vertices: &str, sensors: &str, north: f64| {
        let obj = format!("mtllib office.mtl\n{vertices}usemtl wall\nf 1 2 3\n");
        f.write("office.obj", obj.as_bytes());
        f.write("office.pts", sensors.as_bytes());
        let scene =
            format!("geometry = \"office.obj\"\nsensors = \"office.pts\"\nnorth_deg = {north:?}\n");
        f.write("scene.toml", scene.as_bytes())
    };
    // lo + hi overflowed: the origin was infinite and the triangle dropped.
    let far = "v 1.5e308 0 0\nv 1.5e308 1 0\nv 1.5e308 0 1\n";
    let p = write(far, "1.5e308 0.5 0.5 1 0 0\n", 0.0);
    let s = Scene::load(&p).unwrap();
    assert!(s.origin.is_finite(), "{}", s.origin);
    assert_eq!((s.input_triangles, s.dropped_degenerate), (1, 0));
    assert!(s.sensors[0].position.is_finite());
    // Rotating by north_deg overflows: an error naming the scene file and the vertex.
    let p = write("v 0 0 0\nv 9e307 1.7e308 0\nv 0 0 1\n", "", 30.0);
    let shown = Scene::load(&p).unwrap_err().to_string();
    assert!(shown.starts_with(&p.display().to_string()), "{shown}");
    assert!(
        shown.contains("too far out to rotate") && shown.contains("1.7e308"),
        "{shown}"
    );
    // A triangle whose area overflows (found by the same property with PROPTEST_RNG_SEED=2
    // and 5000 cases): it was kept, with an infinite area and a zero "unit" normal; now it
    // is dropped as degenerate, like a triangle of zero area.
    let p = write("v 0 1e300 0\nv 0 0 -1.7e308\nv 1 0 0\n", "", 0.0);
    let s = Scene::load(&p).unwrap();
    assert_eq!((s.triangles.len(), s.dropped_degenerate), (0, 1));
    // A sensor whose position overflows once the origin is subtracted.
    let p = write(far, "-1.7e308 0 0 0 0 1\n", 0.0);
    let shown = Scene::load(&p).unwrap_err().to_string();
    assert!(
        shown.contains("sensor 1 is too far from the geometry"),
        "{shown}"
    );
}

// ---------------------------------------------------------------------------------------
// OBJ

fn obj_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "v f vt vn g o usemtl mtllib 1/1 1//1 1/1/1 1/1/1/1 /1 -1 -99999 0 157 -157 office.mtl \
         glass wall",
        "\
f 4294967295 1 2
f -4294967295 1 2
f 1 2 9223372036854775807
f 1 2 -9223372036854775808
f 1 2 99999999999999999999
f 1/4294967295 2 3
f 1//4294967295 2 3
f -1 -2 -99999
f 1 1 1
f 1 2
f
f 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16
v 1e308 1e308 1e308
v -1e308 -1e308 -1e308
v 1e308 -1e308 1e308
v 1 1 1 1e-308
v 1 1 1 -0
v 1 1 1 0.5 0.5 0.5
v 1 2
v
vt 0 0
vn 0 0 1
o
g
g \u{0}
usemtl
usemtl glass
usemtl nothere
mtllib
mtllib office.mtl
mtllib office.mtl office.mtl
mtllib nothere.mtl
mtllib .
s off
l 1 2
p 1
curv 0 1 1 2
# comment",
    )
}

#[test]
fn obj_arbitrary_bytes_and_text() {
    let f = Folder::office();
    let obj_like =
        "mtllib office.mtl\n((v|vt|vn|f|g|o|usemtl wall|usemtl glass)( [-0-9./e]{1,6}){0,5}\n){0,60}";
    let input = prop_oneof![any_bytes(), obj_like.prop_map(String::into_bytes)];
    check(2048, (input, any::<bool>()), |(bytes, y_up)| {
        f.write("a.obj", &bytes);
        load_obj(&f, "a.obj", y_up, true)
    });
}

#[test]
fn obj_mutations() {
    let f = Folder::office();
    let sample = office("office.obj");
    obj::load(&f.path("office.obj"), false).expect("the bundled OBJ loads");
    let format = obj_format();
    check(8192, (mutations(), any::<bool>()), |(m, y_up)| {
        f.write("a.obj", &mutate(&sample, &m, &format));
        load_obj(&f, "a.obj", y_up, true)
    });
}

/// Face and vertex indices far beyond the vertex count fail fast, naming line and index,
/// without allocating anything like the index.
#[test]
fn obj_huge_indices_error_without_allocating() {
    let f = Folder::office();
    let head = "mtllib office.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl wall\n";
    for face in [
        "4294967295 1 2",
        "-4294967295 1 2",
        "1 2 9223372036854775807",
        "1 2 -9223372036854775808",
        "1/4294967295 2 3",
        "1//18446744073709551615 2 3",
    ] {
        let p = f.write("big.obj", format!("{head}f {face}\n").as_bytes());
        let (r, largest, total, took) = metered(|| obj::load(&p, false));
        let e = r.expect_err(face);
        let shown = e.to_string();
        assert!(shown.contains("big.obj:6:"), "{shown}");
        assert!(matches!(e, Error::Input { value: Some(_), .. }), "{shown}");
        assert!(
            largest < 64 << 10 && total < 1 << 20,
            "{face}: {largest} B, {total} B"
        );
        assert!(took < Duration::from_secs(2), "{face}: {took:?}");
    }
}

// ---------------------------------------------------------------------------------------
// MTL (read through the OBJ that names it)

fn mtl_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "Kd kd KD Tf Ke newmtl d Tr map_Kd 0.999999 1.0",
        "\
Kd NaN
Kd 1e308 0 0
Kd -0 -0 -0
Kd 1
Kd 0.5 0.5
Kd 0.1 0.2 0.3 0.4
Kd
Kd spectral x.rfl
Tf 1 1 1
Tf 1.0000001
Ke inf
Ke 1e308 1e308 1e308
newmtl
newmtl wall
newmtl glass
newmtl \u{0}
d 0.5
Tr 0.5
d
map_Kd x.png
illum 99999999999999999999
Pr 0.5
# comment",
    )
}

#[test]
fn mtl_arbitrary_text() {
    let f = Folder::office();
    let names = "floor|wall|ceiling|exterior|ground|obstruction|glass";
    let mtl_like =
        format!("((newmtl ({names})|Kd|Tf|Ke|d|Tr|kd|Ns)( [-0-9.e]{{1,6}}){{0,4}}\n){{0,30}}");
    check(2048, prop_oneof![any_text(), regex(&mtl_like)], |text| {
        f.write("office.mtl", text.as_bytes());
        load_obj(&f, "office.obj", false, true)
    });
}

#[test]
fn mtl_mutations() {
    let f = Folder::office();
    let sample = office("office.mtl");
    let format = mtl_format();
    check(4096, mutations(), |m| {
        f.write("office.mtl", &mutate(&sample, &m, &format));
        load_obj(&f, "office.obj", false, true)
    });
}

// ---------------------------------------------------------------------------------------
// Radiance .pts

fn pts_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "3e-162 1e-200 1e154 1e155",
        // The last line is empty.
        "\
0 0 0 0 0 0
0 0 0 -0 -0 -0
1e308 1e308 1e308 1e308 1e308 1e308
0 0 0 1e-200 1e-200 1e-200
0 0 0 3e-162 0 0
0 0 0 1e-160 0 0
0 0 0 1e200 1e200 0
1 2 3 0 0 1 # comment
1 2 3 0 0 1 7
1 2 3 0 0
#

",
    )
}

fn load_pts(p: PathBuf, y_up: bool) -> CaseResult {
    let files = [p.clone()];
    match guarded(|| sensors::load(&p, y_up))? {
        Ok(list) => {
            for (pos, dir) in list {
                prop_assert!(pos.is_finite() && dir.is_finite(), "{pos} {dir}");
                prop_assert!(dir.length_squared() > 0.0, "{pos} {dir}");
            }
            Ok(())
        }
        Err(e) => check_error(
            &e,
            &Naming {
                files: &files,
                whole_file: &[],
                value_on_line: true,
            },
        ),
    }
}

#[test]
fn pts_arbitrary_bytes() {
    let f = Folder::office();
    let pts_like = "([-0-9.e]{1,6}( [-0-9.e#]{1,6}){0,7}\n){0,20}".prop_map(String::into_bytes);
    let input = prop_oneof![any_bytes(), pts_like];
    check(2048, (input, any::<bool>()), |(bytes, y_up)| {
        load_pts(f.write("a.pts", &bytes), y_up)
    });
}

#[test]
fn pts_mutations() {
    let f = Folder::office();
    let sample = office("office.pts");
    sensors::load(&f.path("office.pts"), false).expect("the bundled sensors load");
    let format = pts_format();
    check(4096, (mutations(), any::<bool>()), |(m, y_up)| {
        load_pts(f.write("a.pts", &mutate(&sample, &m, &format)), y_up)
    });
}

/// The office scene with each sensor file mutation loaded end to end: sensor normals come
/// out unit length (a direction whose squared length is subnormal normalises badly).
#[test]
fn pts_mutations_through_the_scene() {
    let f = Folder::office();
    let sample = office("office.pts");
    let format = pts_format();
    check(2048, mutations(), |m| {
        f.write("office.pts", &mutate(&sample, &m, &format));
        load_scene(&f)
    });
}

/// Regression (found by `pts_mutations_through_the_scene`): the sensor line
/// `0 0 0 3e-162 0 0` has a direction whose squared length is subnormal; it was accepted
/// and became a sensor normal of length 0.954. It is now an error naming line and value,
/// while a small direction whose squared length is still a normal number loads as a unit
/// normal.
#[test]
fn pts_direction_with_subnormal_squared_length_is_an_error() {
    let f = Folder::office();
    for d in ["3e-162 0 0", "0 1e-160 0", "1e-200 1e-200 1e-200"] {
        let p = f.write("a.pts", format!("1 2 3 0 0 1\n0 0 0 {d}\n").as_bytes());
        let e = sensors::load(&p, false).unwrap_err();
        let shown = e.to_string();
        assert!(shown.contains("a.pts:2:") && shown.contains(d), "{shown}");
    }
    f.write(
        "office.pts",
        b"0.5 0.5 0.8 1e-150 0 0\n0.5 0.5 0.8 0 -2e-154 0\n",
    );
    let s = Scene::load(&f.path("scene.toml")).unwrap();
    assert!(s.sensors.iter().all(|x| unit(x.normal)), "{:?}", s.sensors);
}

// ---------------------------------------------------------------------------------------
// EPW

/// The bundled EPW's header (its data period cut to 1–2 January) and its first 48 records.
fn epw_sample() -> String {
    let full = office("weather.epw");
    let mut out = String::new();
    for (i, line) in full.lines().take(8 + 48).enumerate() {
        if i == 7 {
            out.push_str("DATA PERIODS,1,1,Data,Sunday, 1/ 1, 1/ 2");
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

fn epw_format() -> Format {
    Format::new(
        Sep::Comma,
        // `_` stands for a space inside a value.
        "LOCATION DATA_PERIODS 1/1 12/31 2/29 2/30 13/1 0/0 1/_2 2020 2021 -9999 1988 2 61 \
         -90.0001 180.5 -12 99.9"
            .replace('_', " ")
            .as_str(),
        // The second-last line is empty.
        "\
DATA PERIODS,1,60,Data,Sunday,1/1,12/31
DATA PERIODS,1,0,Data,Sunday,1/1,1/2
DATA PERIODS,1,7,Data,Sunday,1/1,1/2
DATA PERIODS,2,1,Data,Sunday,1/1,1/2
DATA PERIODS,1,1,Data,Sunday,2/28,3/1
DATA PERIODS,1,1
LOCATION,x,x,x,x,0,NaN,0,0,0
LOCATION,x,x,x,x,0,0,0,0
2020,2,29,1,60,x,0,0,0,0,0,0,0,0,0,0,0
2021,2,29,1,60,x,0,0,0,0,0,0,0,0,0,0,0
1988,1,1,1,60,x,0,0,0,0,0,0,0,0,9999,9999,0
1988,1,1,1,60,x,0,,0,0,0,0,0,0,,,0
1988,1,1,1
1988,1,1,25,60,x,0,0,0,0,0,0,0,0,0,0,0

,,,,,,,,,,,,,,,,",
    )
}

fn parse_epw(text: String) -> CaseResult {
    let path = Path::new("fuzz/weather.epw");
    match guarded(|| epw::parse(path, &text))? {
        Ok(w) => {
            prop_assert!(!w.records.is_empty());
            check_weather(&w, &text)
        }
        Err(e) => check_text_error(&e, path, &text),
    }
}

#[test]
fn epw_arbitrary_text() {
    let header = epw_sample().lines().take(8).collect::<Vec<_>>().join("\n") + "\n";
    // Arbitrary text, and arbitrary rows (then rows of numbers) after a valid header.
    let h = header.clone();
    let rows = "([-0-9.,]{0,40}\n){0,30}".prop_map(move |r| format!("{h}{r}"));
    let numbers = "(1988,1,[0-9]{1,2},[0-9]{1,2},60,x(,[-0-9.]{0,5}){10,14}\n){0,30}"
        .prop_map(move |r| format!("{header}{r}"));
    check(2048, prop_oneof![any_text(), rows, numbers], parse_epw);
}

#[test]
fn epw_mutations() {
    let sample = epw_sample();
    let w = epw::parse(Path::new("sample.epw"), &sample).expect("the sample parses");
    assert_eq!(w.records.len(), 48);
    let format = epw_format();
    check(8192, mutations(), |m| {
        parse_epw(mutate_text(&sample, &m, &format))
    });
}

/// A header claiming 60 rows an hour for a whole year, followed by three rows: the file is
/// reported truncated at its last line, quickly, and the rows are not allocated for what the
/// header claims (525,600 rows) but for what the file holds.
#[test]
fn epw_header_claiming_a_huge_period_does_not_allocate_for_it() {
    let sample = epw_sample();
    // Three rows of hour 1: in sequence for 60 rows an hour.
    let mut lines: Vec<&str> = sample.lines().take(8).collect();
    lines[7] = "DATA PERIODS,1,60,Data,Sunday,1/1,12/31";
    let first_row = sample.lines().nth(8).expect("a record");
    lines.extend([first_row; 3]);
    let text = lines.join("\n") + "\n";
    let path = Path::new("claims.epw");
    let (r, largest, total, took) = metered(|| epw::parse(path, &text));
    let shown = r.expect_err("truncated").to_string();
    assert!(shown.starts_with("claims.epw:11:"), "{shown}");
    assert!(shown.contains("3 of the 525600 rows"), "{shown}");
    assert!(
        largest < 64 << 10 && total < 1 << 20,
        "largest allocation {largest} B, {total} B in all for a {} B file",
        text.len()
    );
    assert!(took < Duration::from_secs(2), "{took:?}");
    // A count that is not a divisor of 60 (or not a number at all) is named at line 8.
    for n in ["99999999999999999999", "7", "0", "-60"] {
        let text = text.replace("DATA PERIODS,1,60,", &format!("DATA PERIODS,1,{n},"));
        let shown = epw::parse(path, &text).unwrap_err().to_string();
        assert!(shown.starts_with("claims.epw:8:"), "{shown}");
    }
}

// ---------------------------------------------------------------------------------------
// WEA

/// A valid two-day hourly WEA (San Francisco header, readings at the half hours).
fn wea_sample() -> String {
    let mut s = String::from(
        "place San_Francisco\nlatitude 37.62\nlongitude 122.4\ntime_zone 120\n\
         site_elevation 2.0\nweather_data_file_units 1\n",
    );
    for day in 1..=2 {
        for h in 0..24 {
            let sun = (12.0 - (h as f64 + 0.5 - 12.0).abs()).max(0.0);
            s.push_str(&format!(
                "1 {day} {}.5 {} {}\n",
                h,
                (sun * 70.0).round(),
                (sun * 12.0).round()
            ));
        }
    }
    s
}

fn wea_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "place latitude longitude time_zone site_elevation weather_data_file_units 23.99999 \
         23.9998 -210 180.0001",
        "\
latitude NaN
latitude
longitude 99999999999999999999
time_zone -inf
site_elevation 1e308
weather_data_file_units 2
weather_data_file_units
place
place \u{0}
2 29 12 0 0
2 30 12 0 0
1 32 12 0 0
12 31 23.99999 0 0
12 31 23.9998 0 0
1 1 -0 0 0
1 1 1e-308 0 0
1 2 12 9999 9999
1 2 12 1e308 1e308
1 2 12 0
1 2 12 0 0 0",
    )
}

fn parse_wea(text: String) -> CaseResult {
    let path = Path::new("fuzz/weather.wea");
    match guarded(|| wea::parse(path, &text))? {
        Ok(w) => check_weather(&w, &text),
        Err(e) => check_text_error(&e, path, &text),
    }
}

#[test]
fn wea_arbitrary_text() {
    let head = wea_sample().lines().take(6).collect::<Vec<_>>().join("\n") + "\n";
    let rows = "([-0-9. e]{0,30}\n){0,30}".prop_map(move |r| format!("{head}{r}"));
    check(2048, prop_oneof![any_text(), rows], parse_wea);
}

#[test]
fn wea_mutations() {
    let sample = wea_sample();
    let w = wea::parse(Path::new("sample.wea"), &sample).expect("the sample parses");
    assert_eq!(w.records.len(), 48);
    let format = wea_format();
    check(8192, mutations(), |m| {
        parse_wea(mutate_text(&sample, &m, &format))
    });
}

// ---------------------------------------------------------------------------------------
// Cache records

const VISIBILITY: u32 = FIRST_USER_TAG;

fn record_key(direction: u64) -> RecordKey {
    RecordKey {
        scene: SceneHash(*blake3::hash(b"parser properties").as_bytes()),
        kind: KIND_SUN,
        direction,
        resolution: 64,
    }
}

/// A valid record: 7 leaves, the stats and a visibility section of 5 sensors.
fn record_sample() -> Vec<u8> {
    let record = DirectionRecord {
        leaves: (0..7u32)
            .map(|i| LeafWeight {
                key: ElementKey {
                    tri: i,
                    path: 1 + u64::from(i % 4),
                },
                weight: DVec3::new(0.1 * f64::from(i), 0.2, 0.3),
            })
            .collect(),
        stats: ProjectionStats {
            width: 64,
            height: 48,
            pixel_m: 0.05,
            fragments: 100,
            elements_tested: 20,
            elements_split: 3,
            lit_leaves: 7,
        },
    };
    encode_direction(
        &record_key(1),
        &record,
        &[Section::f64s(VISIBILITY, &[0.0, 0.25, 0.5, 0.75, 1.0])],
    )
}

/// Decodes `bytes` as a record of `key` (guarded); on success also decodes the
/// direction and reads the visibility section, which must stay inside the bytes.
fn decode(bytes: Vec<u8>, key: RecordKey) -> Result<bool, TestCaseError> {
    guarded(|| match MappedRecord::from_bytes(&bytes, &key) {
        Ok(r) => {
            let _ = decode_direction(&r);
            let _ = r.f64s(VISIBILITY);
            for s in r.sections() {
                let end = s.offset.checked_add(s.byte_len());
                assert!(end.is_some_and(|e| e <= bytes.len() as u64), "{s:?}");
            }
            true
        }
        Err(_) => false,
    })
}

/// Damage that both checksums catch: bits flipped, the record cut or bytes appended.
#[derive(Clone, Debug)]
struct Damage {
    flips: Vec<(Index, u8)>,
    cut: Option<Index>,
    append: Vec<u8>,
}

fn damage() -> impl Strategy<Value = Damage> {
    (
        prop::collection::vec((any::<Index>(), 0..8u8), 0..6),
        prop::option::weighted(0.3, any::<Index>()),
        prop::collection::vec(any::<u8>(), 0..3),
    )
        .prop_map(|(flips, cut, append)| Damage { flips, cut, append })
}

fn damaged(sample: &[u8], d: &Damage) -> Vec<u8> {
    let mut b = sample.to_vec();
    for (i, bit) in &d.flips {
        let k = i.index(b.len());
        b[k] ^= 1 << bit;
    }
    if let Some(c) = &d.cut {
        b.truncate(c.index(b.len()));
    }
    b.extend_from_slice(&d.append);
    b
}

#[test]
fn cache_record_arbitrary_bytes() {
    // Arbitrary bytes, and arbitrary bytes behind a valid magic and version.
    let mut head = b"DAYSTEP\0".to_vec();
    head.extend_from_slice(&daystep::cache::FORMAT_VERSION.to_le_bytes());
    let framed = any_bytes().prop_map(move |b| [head.clone(), b].concat());
    check(4096, prop_oneof![any_bytes(), framed], |bytes| {
        prop_assert!(!decode(bytes, record_key(1))?, "arbitrary bytes accepted");
        Ok(())
    });
}

#[test]
fn cache_record_bit_flips_and_cuts_are_rejected() {
    let sample = record_sample();
    assert!(decode(sample.clone(), record_key(1)).unwrap());
    check(4096, damage(), |d| {
        let bytes = damaged(&sample, &d);
        let same = bytes == sample;
        prop_assert_eq!(decode(bytes, record_key(1))?, same);
        Ok(())
    });
}

/// Header fields (and section-table fields) set to hostile integers with both checksums
/// recomputed, so the checks behind the checksums see them: never a panic, and a record
/// accepted anyway has every section inside its bytes.
#[test]
fn cache_record_resigned_header_fields() {
    let sample = record_sample();
    let n = 3usize;
    // (offset, width) of every integer field of the header and the section table.
    let mut fields: Vec<(usize, usize)> = vec![(8, 4), (12, 4), (64, 1), (65, 1), (68, 4), (72, 8)];
    for s in 0..n {
        let e = 112 + 24 * s;
        fields.extend([(e, 4), (e + 4, 4), (e + 8, 8), (e + 16, 8)]);
    }
    let values: Vec<u64> = vec![
        0,
        1,
        2,
        7,
        8,
        24,
        40,
        48,
        u64::from(u32::MAX),
        u64::from(u32::MAX) + 1,
        1 << 40,
        1 << 63,
        u64::MAX,
        u64::MAX - 7,
        u64::MAX / 24,
        u64::MAX / 40 + 1,
        1024,
        1025,
        sample.len() as u64,
        sample.len() as u64 + 8,
        216,
        144 + 24 * 1024,
    ];
    let edit = (any::<Index>(), any::<Index>(), any::<u64>());
    let edits = prop::collection::vec(edit, 1..=3);
    check(8192, (edits, any::<bool>()), |(edits, resign_payload)| {
        let mut b = sample.clone();
        for (field, value, random) in &edits {
            let (at, width) = fields[field.index(fields.len())];
            let v = if random & 1 == 0 {
                values[value.index(values.len())]
            } else {
                *random
            };
            b[at..at + width].copy_from_slice(&v.to_le_bytes()[..width]);
        }
        resign(&mut b, resign_payload);
        decode(b, record_key(1))?;
        Ok(())
    });
}

/// Recomputes the checksums of a record whose header may be damaged: the payload checksum
/// (when asked) over everything after the header its section count implies, then the header
/// checksum.
fn resign(b: &mut [u8], payload: bool) {
    let n = u32::from_le_bytes(b[68..72].try_into().unwrap()) as usize;
    let h = 144 + 24 * n;
    if h > b.len() {
        return;
    }
    if payload {
        let sum = *blake3::hash(&b[h..]).as_bytes();
        b[80..112].copy_from_slice(&sum);
    }
    let sum = *blake3::hash(&b[..h - 32]).as_bytes();
    b[h - 32..h].copy_from_slice(&sum);
}

/// A re-signed header claiming 1024 sections of `u64::MAX` elements, or a payload of
/// `u64::MAX` bytes, is rejected quickly without allocating for the claim.
#[test]
fn cache_record_claiming_huge_sizes_does_not_allocate_for_them() {
    let sample = record_sample();
    let mut claims = Vec::new();
    // A payload length of u64::MAX.
    let mut b = sample.clone();
    b[72..80].copy_from_slice(&u64::MAX.to_le_bytes());
    resign(&mut b, false);
    claims.push(b);
    // Every section u64::MAX elements long.
    let mut b = sample.clone();
    for s in 0..3 {
        let e = 112 + 24 * s + 8;
        b[e..e + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    }
    resign(&mut b, true);
    claims.push(b);
    // 1024 sections, each claiming 2⁶⁰ 8-byte elements, in a file of 24 KiB.
    let n = 1024usize;
    let h = 144 + 24 * n;
    let mut b = vec![0u8; h];
    b[..80].copy_from_slice(&sample[..80]);
    b[12..16].copy_from_slice(&(h as u32).to_le_bytes());
    b[68..72].copy_from_slice(&(n as u32).to_le_bytes());
    b[72..80].copy_from_slice(&0u64.to_le_bytes());
    for s in 0..n {
        let e = 112 + 24 * s;
        b[e..e + 4].copy_from_slice(&(s as u32).to_le_bytes());
        b[e + 4..e + 8].copy_from_slice(&8u32.to_le_bytes());
        b[e + 8..e + 16].copy_from_slice(&(1u64 << 60).to_le_bytes());
        b[e + 16..e + 24].copy_from_slice(&(h as u64).to_le_bytes());
    }
    resign(&mut b, true);
    claims.push(b);
    for (k, bytes) in claims.iter().enumerate() {
        let (r, largest, total, took) =
            metered(|| MappedRecord::from_bytes(bytes, &record_key(1)).map(|_| ()));
        assert!(r.is_err(), "claim {k} accepted");
        let bound = bytes.len() + (64 << 10);
        assert!(
            largest <= bound && total <= 2 * bound,
            "claim {k}: {largest} B, {total} B"
        );
        assert!(took < Duration::from_secs(2), "claim {k}: {took:?}");
    }
}

// ---------------------------------------------------------------------------------------
// The cache folder

/// `Store::get` on a record file holding `bytes`: a miss when the file is invalid, counted
/// as a rebuild, and the file removed.
fn store_get_rejects(store: &Store, bytes: Vec<u8>, key: RecordKey) -> CaseResult {
    let dir = store.dir().expect("enabled").to_path_buf();
    let path = dir.join(key.file_name());
    std::fs::write(&path, &bytes).expect("write");
    let before = store.stats();
    let hit = guarded(|| store.get(&key).is_some())?;
    let after = store.stats();
    prop_assert!(!hit, "an invalid record was returned");
    prop_assert_eq!(after.rebuilds, before.rebuilds + 1);
    prop_assert_eq!((after.hits, after.misses), (before.hits, before.misses));
    prop_assert!(!path.exists(), "the invalid record was kept");
    Ok(())
}

#[test]
fn store_get_arbitrary_bytes() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    check(1024, any_bytes(), |bytes| {
        store_get_rejects(&store, bytes, record_key(2))
    });
}

#[test]
fn store_get_damaged_records() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    let sample = record_sample();
    // A valid record filed under another key's name is rebuilt too.
    store_get_rejects(&store, sample.clone(), record_key(3)).unwrap();
    check(1024, damage(), |d| {
        let bytes = damaged(&sample, &d);
        if bytes == sample {
            return Ok(());
        }
        store_get_rejects(&store, bytes, record_key(1))
    });
    // The counters saw every rebuild, and nothing was left behind.
    assert_eq!(store.stats().hits, 0);
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name() != ".gitignore")
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

// ---------------------------------------------------------------------------------------
// Pictures: Radiance RGBE (`render::rgbe::decode_hdr`) and OpenEXR (`render::exr::decode_exr`)

/// What a refused picture may allocate at most in one piece, besides twice its own length:
/// the header's strings, one scanline (at most 2^16 pixels of 4 bytes), offset tables.
const PICTURE_SLACK: usize = 1 << 20;

/// Decodes `bytes` with `decode` (guarded and metered) and checks the outcome: an image
/// whose buffers match its size, at most `MAX_PIXELS`, or an input error naming `path`;
/// and no allocation beyond [`PICTURE_SLACK`] + 2 × the input + `allowance(result)` (what the
/// outcome may hold). Returns whether the picture was read.
fn read_picture<T>(
    bytes: &[u8],
    path: &Path,
    decode: impl FnOnce(&[u8], &Path) -> daystep::Result<T>,
    image: impl Fn(&T) -> &Image,
    allowance: impl Fn(Option<&Image>) -> usize,
) -> Result<bool, TestCaseError> {
    quiet_decoder_panics();
    let (r, largest, _, _) = metered(|| guarded(|| decode(bytes, path)));
    let r = r?;
    let read = r.as_ref().ok().map(&image);
    let bound = PICTURE_SLACK + 2 * bytes.len() + allowance(read);
    prop_assert!(
        largest <= bound,
        "allocated {largest} B at once (bound {bound} B) for {} bytes: {:?}",
        bytes.len(),
        r.as_ref().map(|_| "read").map_err(|e| e.to_string())
    );
    match (&r, read) {
        (Ok(_), Some(im)) => {
            let n = im.width * im.height;
            prop_assert!(n > 0 && n <= MAX_PIXELS, "{} x {}", im.width, im.height);
            prop_assert_eq!((im.rgb.len(), im.err.len(), im.valid.len()), (n, n, n));
            Ok(true)
        }
        (Err(e), _) => {
            let shown = e.to_string();
            match e {
                Error::Input { path: p, .. } => {
                    prop_assert_eq!(p.as_path(), path, "{}", shown);
                    prop_assert!(shown.starts_with(&path.display().to_string()), "{shown}");
                }
                other => return Err(TestCaseError::fail(format!("not an input error: {other}"))),
            }
            Ok(false)
        }
        _ => unreachable!("read is Some exactly when r is Ok"),
    }
}

/// Prints the panics of the exr crate (which `decode_exr` turns into input errors: its B44
/// decoder overflows on corrupt blocks when overflow checks are on) as one line, without
/// the backtrace `RUST_BACKTRACE` asks for: symbolising one costs seconds on a busy machine,
/// enough to fail a case as slow. Every other panic is printed as before.
fn quiet_decoder_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            match info.location().filter(|l| l.file().contains("/exr-")) {
                Some(l) => eprintln!("exr crate panicked at {l} (caught by decode_exr)"),
                None => default(info),
            }
        }));
    });
}

/// The largest buffer a read image holds: its colours, 24 bytes a pixel.
fn image_allowance(im: Option<&Image>) -> usize {
    im.map_or(0, |im| 24 * im.width * im.height)
}

fn read_hdr_bytes(bytes: &[u8]) -> Result<bool, TestCaseError> {
    read_picture(
        bytes,
        Path::new("dir/picture.hdr"),
        rgbe::decode_hdr,
        |(im, _)| im,
        image_allowance,
    )
}

/// Small images over six decades, with runs (a constant left part) and literals.
fn small_images() -> impl Strategy<Value = Image> {
    (
        1..48usize,
        1..6usize,
        prop::collection::vec(-3.0..3.0f64, 1..64),
    )
        .prop_map(|(w, h, logs)| {
            let mut im = Image::new(w, h, Quantity::Radiance);
            for (i, p) in im.rgb.iter_mut().enumerate() {
                let v = if i % w < w / 3 {
                    2.5
                } else {
                    10f64.powf(logs[i % logs.len()])
                };
                *p = DVec3::new(v, 0.5 * v, 0.9 * v);
            }
            im
        })
}

fn hdr_bytes(im: &Image) -> Vec<u8> {
    let dir = tempfile::tempdir().expect("temporary folder");
    let p = dir.path().join("p.hdr");
    rgbe::write_hdr(&p, im, None).expect("write_hdr");
    std::fs::read(&p).expect("read back")
}

/// Resolution lines: both axes, both signs, sizes from 0 to past every integer type.
fn resolution_lines() -> impl Strategy<Value = String> {
    let size = prop_oneof![
        1..70usize,
        Just(1 << 15),
        Just(1 << 16),
        Just((1 << 16) + 1),
        Just(1 << 28),
        Just(usize::MAX),
        any::<usize>(),
    ]
    .prop_map(|n| n.to_string());
    let axis = prop::sample::select(vec!["-Y", "+Y", "-X", "+X", "Y", "-Z", "--Y"]);
    (axis.clone(), size.clone(), axis, size).prop_map(|(a, n, b, m)| format!("{a} {n} {b} {m}"))
}

#[test]
fn hdr_arbitrary_bytes_and_resolution_lines() {
    // Arbitrary bytes; and arbitrary scanline bytes after a valid header with any
    // resolution line.
    let framed = (resolution_lines(), any_bytes()).prop_map(|(res, data)| {
        let mut b = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes();
        b.extend(data);
        b
    });
    check(4096, prop_oneof![any_bytes(), framed], |bytes| {
        read_hdr_bytes(&bytes)?;
        Ok(())
    });
}

/// A valid picture's bytes edited: its resolution line replaced, bytes of the scanlines
/// set to run-length markers (`2 2`, `1 1 1 n`, run codes) or arbitrary values, the
/// picture cut or extended.
#[test]
fn hdr_mutations() {
    // Writing is slow (each file is synced): 64 samples, mutated in turn.
    let samples: Vec<Vec<u8>> = {
        let mut runner = TestRunner::new(Config {
            rng_seed: RngSeed::Fixed(SEED),
            ..Config::default()
        });
        (0..64)
            .map(|_| {
                use proptest::strategy::ValueTree;
                hdr_bytes(&small_images().new_tree(&mut runner).unwrap().current())
            })
            .collect()
    };
    let edit = (
        any::<Index>(),
        prop::sample::select(vec![0u8, 1, 2, 127, 128, 129, 255]),
    );
    let strategy = (
        any::<Index>(),
        prop::option::weighted(0.5, resolution_lines()),
        prop::collection::vec(edit, 0..6),
        prop::option::weighted(0.3, any::<Index>()),
        prop::collection::vec(any::<u8>(), 0..8),
    );
    check(4096, strategy, |(which, res, edits, cut, append)| {
        let mut b = samples[which.index(samples.len())].clone();
        let data_at = b.windows(2).position(|w| w == b"\n\n").expect("header end") + 2;
        if let Some(res) = res {
            let line_end = data_at + b[data_at..].iter().position(|&c| c == b'\n').unwrap();
            b.splice(data_at..line_end, res.into_bytes());
        }
        for (at, v) in &edits {
            let k = at.index(b.len());
            if k >= data_at {
                b[k] = *v;
            }
        }
        if let Some(c) = cut {
            b.truncate(c.index(b.len() + 1));
        }
        b.extend(append);
        read_hdr_bytes(&b)?;
        Ok(())
    });
}

#[test]
fn hdr_valid_pictures_round_trip() {
    check(256, small_images(), |im| {
        let b = hdr_bytes(&im);
        let (back, _) = rgbe::decode_hdr(&b, Path::new("p.hdr"))
            .map_err(|e| TestCaseError::fail(format!("a valid picture is refused: {e}")))?;
        prop_assert_eq!((back.width, back.height), (im.width, im.height));
        for (a, b) in back.rgb.iter().zip(&im.rgb) {
            // RGBE keeps 8 bits of mantissa relative to the largest component.
            prop_assert!(
                (*a - *b).abs().max_element() <= 0.01 * b.max_element(),
                "{a} vs {b}"
            );
        }
        Ok(())
    });
}

/// The largest buffer the OpenEXR reader may allocate for `bytes`: when the first part's
/// declared size is within daystep's limits, what the decoder's channels (4 bytes a value)
/// and the image (33 bytes a pixel) need together (reserved at once before decoding);
/// nothing otherwise.
fn exr_allowance(bytes: &[u8]) -> usize {
    let Ok(meta) = std::panic::catch_unwind(|| {
        ::exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), true)
    }) else {
        return 0;
    };
    let Some(first) = meta.ok().and_then(|m| m.headers.first().cloned()) else {
        return 0;
    };
    let (w, h, c) = (
        first.layer_size.0,
        first.layer_size.1,
        first.channels.list.len(),
    );
    match w.checked_mul(h) {
        Some(n) if n <= MAX_PIXELS && n.saturating_mul(c) <= MAX_SAMPLES => n * (4 * c + 33),
        _ => 0,
    }
}

fn read_exr_bytes(bytes: &[u8]) -> Result<bool, TestCaseError> {
    let allowance = exr_allowance(bytes);
    read_picture(
        bytes,
        Path::new("dir/picture.exr"),
        exr::decode_exr,
        |im| im,
        |_| allowance,
    )
}

/// Sample OpenEXR files of every layout the reader accepts: daystep's own (ZIP scan
/// lines, four channels), and R, G, B written by the exr crate as scan lines or tiles (one
/// level or mip-maps), uncompressed or RLE, ZIP, PIZ, PXR24 or B44 compressed, in one or
/// two parts.
fn exr_samples() -> Vec<(String, Vec<u8>, Image)> {
    use ::exr::prelude::{
        AnyChannel, AnyChannels, Blocks, Compression, Encoding, FlatSamples, ImageAttributes,
        IntegerBounds, Layer, LayerAttributes, Levels, LineOrder, SmallVec, WritableImage,
    };
    let mut out = Vec::new();
    let mut im = Image::new(13, 7, Quantity::Radiance);
    for (i, p) in im.rgb.iter_mut().enumerate() {
        let v = 10f64.powf(i as f64 / 30.0 - 1.0);
        *p = DVec3::new(v, 2.0 * v, 0.5 * v);
    }
    for (i, e) in im.err.iter_mut().enumerate() {
        *e = 0.01 * i as f64;
    }
    out.push((
        "daystep".to_string(),
        exr::encode_exr(&im).unwrap(),
        im.clone(),
    ));
    let (w, h) = (im.width, im.height);
    let levels = |k: usize| -> Levels<FlatSamples> {
        let full: Vec<f32> = im.rgb.iter().map(|p| p[k] as f32).collect();
        Levels::Singular(FlatSamples::F32(full))
    };
    let mip = |k: usize| -> Levels<FlatSamples> {
        let round = ::exr::math::RoundingMode::Down;
        let level_data = ::exr::meta::mip_map_levels(round, ::exr::math::Vec2(w, h))
            .map(|(_, size)| {
                FlatSamples::F32(
                    (0..size.area())
                        .map(|i| if i < w * h { im.rgb[i][k] as f32 } else { 0.0 })
                        .collect(),
                )
            })
            .collect();
        Levels::Mip {
            rounding_mode: round,
            level_data,
        }
    };
    let layer = |name: &str, encoding: Encoding, mipped: bool| {
        let channels: SmallVec<[AnyChannel<Levels<FlatSamples>>; 4]> = ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(k, c)| AnyChannel::new(*c, if mipped { mip(k) } else { levels(k) }))
            .collect();
        Layer::new(
            (w, h),
            LayerAttributes::named(name),
            encoding,
            AnyChannels::sort(channels),
        )
    };
    let compressions = [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP1,
        Compression::ZIP16,
        Compression::PIZ,
        Compression::PXR24,
        Compression::B44,
    ];
    for compression in compressions {
        for (blocks, mipped) in [
            (Blocks::ScanLines, false),
            (Blocks::Tiles(::exr::math::Vec2(4, 4)), false),
            (Blocks::Tiles(::exr::math::Vec2(8, 2)), true),
        ] {
            let encoding = Encoding {
                compression,
                blocks,
                line_order: LineOrder::Increasing,
            };
            let name = format!("{compression:?} {blocks:?} mip-mapped {mipped}");
            let file = ::exr::prelude::Image::from_layer(layer("one", encoding, mipped));
            let mut bytes = Vec::new();
            file.write()
                .to_buffered(std::io::Cursor::new(&mut bytes))
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            out.push((name.clone(), bytes, im.clone()));
            let two = ::exr::prelude::Image::from_layers(
                ImageAttributes::new(IntegerBounds::from_dimensions((w, h))),
                vec![
                    layer("first", encoding, mipped),
                    layer("second", encoding, false),
                ],
            );
            let mut bytes = Vec::new();
            two.write()
                .to_buffered(std::io::Cursor::new(&mut bytes))
                .unwrap_or_else(|e| panic!("{name}, two parts: {e}"));
            out.push((format!("{name}, two parts"), bytes, im.clone()));
        }
    }
    out
}

#[test]
fn exr_samples_of_every_layout_are_read() {
    for (name, bytes, im) in exr_samples() {
        assert!(read_exr_bytes(&bytes).unwrap(), "{name}");
        let back = exr::decode_exr(&bytes, Path::new("s.exr")).unwrap();
        assert_eq!((back.width, back.height), (im.width, im.height), "{name}");
        // PXR24 keeps 24 of 32 bits and B44 stores f32 as it is; the others are lossless.
        let tolerance = if name.contains("PXR24") { 1e-4 } else { 0.0 };
        for (a, b) in back.rgb.iter().zip(&im.rgb) {
            let b32 = DVec3::new(b.x as f32 as f64, b.y as f32 as f64, b.z as f32 as f64);
            assert!(
                (*a - b32).abs().max_element() <= tolerance * b32.max_element(),
                "{name}: {a} vs {b32}"
            );
        }
    }
}

#[test]
fn exr_arbitrary_bytes() {
    // Arbitrary bytes; arbitrary bytes after the magic number and version 2; and arbitrary
    // offset tables and chunks after a valid scan-line header of any size and compression.
    let framed = any_bytes().prop_map(|b| [vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0], b].concat());
    let sizes = 0..EXR_SIZES.len();
    let headed = (sizes.clone(), sizes, 0..10u8, any_bytes()).prop_map(|(w, h, c, data)| {
        let (w, h) = (EXR_SIZES[w], EXR_SIZES[h]);
        [crate::pictures::exr_header(w, h, c, &["B", "G", "R"]), data].concat()
    });
    check(6144, prop_oneof![any_bytes(), framed, headed], |bytes| {
        read_exr_bytes(&bytes)?;
        Ok(())
    });
}

/// Integers that break OpenEXR headers and tables: window corners, tile sizes, counts,
/// offsets and chunk sizes near every limit.
fn exr_hostile_integers() -> Vec<i64> {
    let mut v = vec![
        0,
        1,
        -1,
        2,
        3,
        4,
        7,
        15,
        16,
        255,
        256,
        1 << 14,
        16383,
        65535,
        65536,
        99_999,
        (1 << 24) - 1,
        1 << 28,
        (1 << 30) - 2,
        (1 << 30) - 1,
        i32::MAX as i64,
        i32::MIN as i64,
        u32::MAX as i64,
        1 << 40,
        i64::MAX,
    ];
    v.extend(v.clone().iter().map(|x| -x));
    v
}

/// Where a mutation writes: a byte or 4-byte or 8-byte little-endian integer at a random
/// place, or at the value of a named header attribute (`dataWindow`, `tiles`, …), or in
/// the offset table.
#[derive(Clone, Debug)]
enum ExrEdit {
    Int(Index, u8, Index),
    Attribute(Index, Index, Index),
    Byte(Index, u8),
    /// A data window set to a size from [`EXR_SIZES`] each way (which window, width, height).
    Window(Index, Index, Index),
}

/// Data-window sides: small, at the pixel limit and past it.
const EXR_SIZES: [i32; 12] = [
    1,
    2,
    13,
    100,
    4096,
    16384,
    65535,
    100_000,
    (1 << 24) - 1,
    1 << 24,
    1 << 28,
    (1 << 30) - 2,
];

fn exr_edits() -> impl Strategy<Value = Vec<ExrEdit>> {
    let edit = prop_oneof![
        2 => (any::<Index>(), prop::sample::select(vec![1u8, 4, 8]), any::<Index>())
            .prop_map(|(at, w, v)| ExrEdit::Int(at, w, v)),
        4 => (any::<Index>(), any::<Index>(), any::<Index>())
            .prop_map(|(a, k, v)| ExrEdit::Attribute(a, k, v)),
        1 => (any::<Index>(), any::<u8>()).prop_map(|(at, v)| ExrEdit::Byte(at, v)),
        2 => (any::<Index>(), any::<Index>(), any::<Index>())
            .prop_map(|(which, w, h)| ExrEdit::Window(which, w, h)),
    ];
    prop::collection::vec(edit, 1..=4)
}

/// The byte ranges of the values of every attribute in the headers of `b` (name, then
/// type, then a 4-byte size): found by their names, which are not ambiguous in samples.
/// (Size fields are reached by [`ExrEdit::Int`].)
fn attribute_values(b: &[u8]) -> Vec<(usize, usize)> {
    let names: [&[u8]; 9] = [
        b"channels\0chlist\0",
        b"compression\0compression\0",
        b"dataWindow\0box2i\0",
        b"displayWindow\0box2i\0",
        b"lineOrder\0lineOrder\0",
        b"tiles\0tiledesc\0",
        b"chunkCount\0int\0",
        b"type\0string\0",
        b"name\0string\0",
    ];
    let mut out = Vec::new();
    for name in names {
        let mut from = 0;
        while let Some(k) = b[from..].windows(name.len()).position(|w| w == name) {
            let at = from + k + name.len();
            if at + 4 <= b.len() {
                let size = i32::from_le_bytes(b[at..at + 4].try_into().unwrap());
                let start = at + 4;
                let end = (start + size.max(0) as usize).min(b.len());
                out.push((start, end));
            }
            from = at;
        }
    }
    out
}

/// Where the values of every attribute `name_and_type` (`name\0type\0`) begin, past its
/// 4-byte size.
fn find_all(b: &[u8], name_and_type: &[u8]) -> Vec<usize> {
    (0..b.len().saturating_sub(name_and_type.len()))
        .filter(|&k| &b[k..k + name_and_type.len()] == name_and_type)
        .map(|k| k + name_and_type.len() + 4)
        .collect()
}

/// Sets the data window of part `part` of `b` (a copy of the valid `sample`) to `w × h`
/// pixels from its corner, and keeps a multi-part file's `chunkCount` of that part
/// consistent with it, so that the new size reaches daystep's own checks.
fn set_window(b: &mut [u8], sample: &[u8], part: usize, w: i32, h: i32) {
    let at = find_all(sample, b"dataWindow\0box2i\0")[part];
    let x_min = i32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let y_min = i32::from_le_bytes(b[at + 4..at + 8].try_into().unwrap());
    let x_max = x_min.saturating_add(w - 1);
    let y_max = y_min.saturating_add(h - 1);
    b[at + 8..at + 12].copy_from_slice(&x_max.to_le_bytes());
    b[at + 12..at + 16].copy_from_slice(&y_max.to_le_bytes());
    if let Some(&c) = find_all(sample, b"chunkCount\0int\0").get(part) {
        let header = &::exr::meta::MetaData::read_from_buffered(sample, true)
            .expect("a valid sample")
            .headers[part];
        let size = ::exr::math::Vec2(
            (i64::from(x_max) - i64::from(x_min) + 1) as usize,
            (i64::from(y_max) - i64::from(y_min) + 1) as usize,
        );
        let n = ::exr::meta::compute_chunk_count(header.compression, size, header.blocks);
        let n = i32::try_from(n).unwrap_or(i32::MAX);
        b[c..c + 4].copy_from_slice(&n.to_le_bytes());
    }
}

fn mutate_exr(sample: &[u8], edits: &[ExrEdit]) -> Vec<u8> {
    let mut b = sample.to_vec();
    let values = exr_hostile_integers();
    let fields = attribute_values(sample);
    let windows = find_all(sample, b"dataWindow\0box2i\0");
    for e in edits {
        if let ExrEdit::Window(which, w, h) = e {
            let size = |i: &Index| EXR_SIZES[i.index(EXR_SIZES.len())];
            set_window(&mut b, sample, which.index(windows.len()), size(w), size(h));
            continue;
        }
        let (at, width, value) = match e {
            ExrEdit::Int(at, width, v) => (
                at.index(b.len()),
                *width as usize,
                values[v.index(values.len())],
            ),
            ExrEdit::Attribute(a, k, v) => {
                let (start, end) = fields[a.index(fields.len())];
                let width = if end - start >= 4 { 4 } else { 1 };
                let slots = ((end - start) / width).max(1);
                (
                    start + k.index(slots) * width,
                    width,
                    values[v.index(values.len())],
                )
            }
            ExrEdit::Byte(at, v) => (at.index(b.len()), 1, i64::from(*v)),
            ExrEdit::Window(..) => unreachable!("handled above"),
        };
        let end = (at + width).min(b.len());
        let bytes = value.to_le_bytes();
        b[at..end].copy_from_slice(&bytes[..end - at]);
    }
    b
}

#[test]
fn exr_header_and_table_mutations() {
    let samples = exr_samples();
    let strategy = (
        any::<Index>(),
        exr_edits(),
        prop::option::weighted(0.2, any::<Index>()),
    );
    check(8192, strategy, |(which, edits, cut)| {
        let (_, sample, _) = &samples[which.index(samples.len())];
        let mut b = mutate_exr(sample, &edits);
        if let Some(c) = cut {
            b.truncate(c.index(b.len() + 1));
        }
        read_exr_bytes(&b)?;
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------
// Views: `--view` option strings and `.vf` files

/// A view file as rvu saves it, with a comment and a second line overriding the first.
const VF_SAMPLE: &str = "\
# saved by rvu
rvu -vtv -vp 2.5 3 1.2 -vd 0 -1 0 -vu 0 0 1 -vh 60 -vv 45 -vo 0 -va 0 -vs 0 -vl 0
-vta -vh 180 -vv 180 -vd 0 0 1 -vu 0 1 0
";

fn view_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "-vtv -vta -vth -vtl -vtc -vt -vp -vd -vu -vh -vv -vs -vl -vo -va -vf -v rvu rpict \
         VIEW= 180 179.99999999 360 360.0000001 1e9 1000000001 1000 -1000 1000.5 1e-320 \
         -1e-320 1e300 -1e300 2e9 0.0 -0.0",
        "\
rvu
-vtl -vh 1e9 -vv 1e9 -vp 1e9 -1e9 1e9
-vth -vh 180 -vv 180
-vtv -vh 179.99999999999997
-vd 0 0 0
-vd 1e308 1e308 1e308 -vu -1e308 1e308 0
-vd 1e-320 0 0 -vu 0 1e-320 0
-vu 0 -1 0
-vs 1000 -vl -1000
-vo 1
-va 0
-vtx
# only a comment
VIEW= -vta -vh 360 -vv 360",
    )
}

/// What a parsed view promises: finite numbers within their ranges, unit `vd` and `vu`
/// not along each other, and a finite ray with a unit direction (or none, outside a
/// fisheye's circle) through every image position.
fn check_view(v: &View) -> CaseResult {
    let finite = |x: f64| x.is_finite();
    prop_assert!(
        v.vp.is_finite() && v.vp.abs().max_element() <= MAX_COORDINATE_M,
        "{v:?}"
    );
    prop_assert!(unit(v.vd) && unit(v.vu), "{v:?}");
    prop_assert!(v.vd.cross(v.vu).length() >= 1e-9, "{v:?}");
    let max = match v.kind {
        ViewType::Perspective => 180.0,
        ViewType::Angular => 360.0,
        ViewType::Hemispherical => 180.0,
        ViewType::Parallel => MAX_COORDINATE_M,
    };
    for s in [v.vh, v.vv] {
        prop_assert!(finite(s) && s > 0.0 && s <= max, "{v:?}");
        if v.kind == ViewType::Perspective {
            prop_assert!(s < 180.0, "{v:?}");
        }
    }
    for s in [v.vs, v.vl] {
        prop_assert!(finite(s) && s.abs() <= MAX_SHIFT, "{v:?}");
    }
    for i in 0..=4 {
        for j in 0..=4 {
            let (x, y) = (f64::from(i) / 4.0, f64::from(j) / 4.0);
            if let Some((o, d)) = guarded(|| v.ray(x, y))? {
                prop_assert!(o.is_finite() && unit(d), "ray ({x}, {y}) of {v:?}: {o} {d}");
            }
        }
    }
    // What the view says of itself reads back as the same view.
    let back = View::default().with_options(&v.options(), Path::new("<options>"), None);
    prop_assert_eq!(back.ok(), Some(*v));
    Ok(())
}

/// Parses `text` as `--view` options (guarded) and checks the outcome.
fn parse_view(text: &str) -> CaseResult {
    let source = Path::new("<view>");
    match guarded(|| View::default().with_options(text, source, None))? {
        Ok(v) => check_view(&v),
        Err(Error::Input { path, message, .. }) => {
            prop_assert_eq!(path.as_path(), source);
            prop_assert!(!message.is_empty());
            Ok(())
        }
        Err(e) => Err(TestCaseError::fail(format!("not an input error: {e}"))),
    }
}

/// Reads `text` as a `.vf` file (guarded) and checks the outcome.
fn read_view_file(f: &Folder, text: &str) -> CaseResult {
    let p = f.write("view.vf", text.as_bytes());
    match guarded(|| View::read_file(&p))? {
        Ok(v) => check_view(&v),
        Err(e) => check_error(
            &e,
            &Naming {
                files: std::slice::from_ref(&p),
                whole_file: &["bad view file"],
                value_on_line: true,
            },
        ),
    }
}

/// Option-like text: view options with numbers of every size, other options and words.
fn view_like() -> impl Strategy<Value = String> {
    regex(
        "((-vt[vahlcs]?|-v[pdu]( [-+]?[0-9.e]{1,5}| nan| inf){0,3}|-v[hvslaof]( [-+]?[0-9.e]{1,5}\
         | nan| 1e400)?|rvu|-x [0-9]{1,3}|[a-z=]{1,4}) ){0,10}",
    )
}

#[test]
fn view_options_arbitrary_text() {
    check(2048, prop_oneof![any_text(), view_like()], |text| {
        parse_view(&text)
    });
}

#[test]
fn view_option_mutations() {
    let sample = VF_SAMPLE.lines().nth(1).expect("the rvu line");
    parse_view(sample).expect("the sample parses");
    let format = view_format();
    check(4096, mutations(), |m| {
        // One line: the mutations' inserted lines become more options.
        parse_view(&mutate_text(sample, &m, &format).replace('\n', " "))
    });
}

#[test]
fn view_file_arbitrary_text() {
    let f = Folder::office();
    check(1024, prop_oneof![any_text(), view_like()], |text| {
        read_view_file(&f, &text)
    });
}

#[test]
fn view_file_mutations() {
    let f = Folder::office();
    read_view_file(&f, VF_SAMPLE).expect("the sample reads");
    let format = view_format();
    check(4096, mutations(), |m| {
        read_view_file(&f, &mutate_text(VF_SAMPLE, &m, &format))
    });
}

/// Views of every type with numbers across their whole range (and past it), written as
/// options: a view that parses reads back from [`View::options`] as exactly itself.
#[test]
fn view_options_round_trip() {
    let number = prop_oneof![
        8 => -2.0..2.0f64,
        4 => -1e3..1e3f64,
        1 => -2e9..2e9f64,
        1 => any::<f64>(),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(180.0),
        1 => Just(360.0),
    ];
    let kind = prop::sample::select(vec!["v", "a", "h", "l"]);
    let view = (kind, prop::collection::vec(number, 13));
    let parsed = std::sync::atomic::AtomicUsize::new(0);
    check(4096, view, |(t, n)| {
        let text = format!(
            "-vt{t} -vp {} {} {} -vd {} {} {} -vu {} {} {} -vh {} -vv {} -vs {} -vl {}",
            n[0],
            n[1],
            n[2],
            n[3],
            n[4],
            n[5],
            n[6],
            n[7],
            n[8],
            n[9].abs(),
            n[10].abs(),
            n[11],
            n[12]
        );
        if View::default()
            .with_options(&text, Path::new("<view>"), None)
            .is_ok()
        {
            parsed.fetch_add(1, Ordering::Relaxed);
        }
        parse_view(&text)
    });
    // Enough of them are views for the round trip to mean something.
    let parsed = parsed.into_inner();
    assert!(parsed >= 400, "only {parsed} of 4096 parsed");
}
