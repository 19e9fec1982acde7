//! The cache folder as a [`Store`]: validated, memory-mapped reads; atomic, lock-free
//! writes; counters and warnings. Keeping the folder under its size limit is the job of the
//! private sibling module `eviction`; listing, verifying and clearing a folder is
//! [`super::maintenance`]'s (its public items are re-exported here, their historical home).
//!
//! Folder contents: `<64 hex>.dsr` records, temporary files `.<record name>.<pid>-<n>-<salt>.tmp`
//! while a write is in flight, and a `.gitignore` written when the store creates the
//! folder. Anything else is left alone.

use super::eviction;
use super::record::{header_len, Invalid, MappedRecord};
use super::RecordKey;
use memmap2::Mmap;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::Mutex;
use std::time::{Duration, SystemTime};

pub use super::maintenance::{clear, dir_stats, verify, DirStats, VerifyReport};

/// Default size limit of a cache folder: 2 GiB.
pub const DEFAULT_MAX_BYTES: u64 = 2 << 30;

/// Records up to this size are read into memory rather than mapped, bytes. Mapping pays
/// off for large records read in part (a projection's leaves); for small ones (daylight
/// coefficients, a few kilobytes) the unmapping's TLB shoot-down across threads cost more
/// than the copy: about a tenth of a warm `annual --leed` run's time with four groups.
pub const READ_MAX_BYTES: u64 = 1 << 20;

/// A hit refreshes its record's modification time (the eviction's last use) only when
/// it is older than this.
const TOUCH_AFTER: Duration = Duration::from_secs(15 * 60);

/// Counters of one [`Store`] since it was opened. Every [`Store::get`] counts as exactly
/// one of `hits`, `misses` (no file, or no usable folder) or `rebuilds` (an invalid file
/// was found and removed; the caller recomputes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CacheStats {
    /// Valid records returned.
    pub hits: u64,
    /// Lookups that found no record.
    pub misses: u64,
    /// Invalid records found (truncated, corrupt, other version or key, foreign), removed.
    pub rebuilds: u64,
    /// Records written.
    pub writes: u64,
    /// Writes that failed (the run goes on without caching that record).
    pub write_failures: u64,
    /// Records removed by the size limit.
    pub evictions: u64,
    /// Bytes of records read or mapped by hits.
    pub bytes_mapped: u64,
    /// Bytes of records written.
    pub bytes_written: u64,
}

/// The on-disk cache: a folder of records. `Sync`: share one `&Store` between rayon tasks.
/// No method returns an error or panics on bad files; failures become counters and
/// warnings ([`Store::warnings`]).
#[derive(Debug)]
pub struct Store {
    dir: Option<PathBuf>,
    max_bytes: u64,
    hits: AtomicU64,
    misses: AtomicU64,
    rebuilds: AtomicU64,
    writes: AtomicU64,
    write_failures: AtomicU64,
    evictions: AtomicU64,
    bytes_mapped: AtomicU64,
    bytes_written: AtomicU64,
    /// This process's estimate of the folder size, bytes (exact after each eviction scan).
    tracked_bytes: AtomicU64,
    temp_seq: AtomicU64,
    temp_salt: u64,
    warnings: Mutex<Vec<String>>,
    warned_invalid: AtomicBool,
    warned_read: AtomicBool,
    warned_write: AtomicBool,
    evicting: Mutex<()>,
    /// The folder's size, scanned (and trimmed to the limit when over it) beside the run's
    /// start since [`Store::open`]: records left and records removed. Taken into
    /// `tracked_bytes` before the first write, and into the counters by [`Store::stats`].
    /// Scanning 20 000 records took a twentieth of a warm office year, with the run waiting.
    size_scan: Mutex<Option<std::thread::JoinHandle<(u64, u64)>>>,
}

/// Maps `file` read-only. One of the two `unsafe` places of daystep (the other calls the
/// AVX2 build of the coefficient sums on a CPU that has AVX2).
#[allow(unsafe_code)]
fn map_readonly(file: &File) -> std::io::Result<Mmap> {
    // SAFETY: `Mmap::map` is unsafe because the mapped bytes could change (or vanish, if the
    // file is truncated) while the map is alive, which Rust's `&[u8]` does not allow for.
    // Why this is sound enough here:
    // - daystep never modifies a record file in place: records are written to a unique
    //   temporary file and renamed over the final name; a rename or an unlink (eviction,
    //   `clear`, removal of invalid records) leaves this mapping's inode untouched;
    // - the map is private to the returned `Mmap` and is only read after
    //   `Record::validate` has checked lengths, bounds and both checksums of these bytes;
    // - the documented remaining risk is a foreign process writing into or truncating a
    //   record file in place while it is mapped: that can show changed bytes or raise
    //   SIGBUS. Users are told not to edit cache files; `daystep cache clear` removes them
    //   by unlinking, which is safe.
    unsafe { Mmap::map(file) }
}

fn random_salt() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0),
    );
    h.finish()
}

impl Drop for Store {
    /// Waits for the size scan begun at open, so that a trim it started completes.
    fn drop(&mut self) {
        self.settle_size();
    }
}

impl Store {
    fn with_dir(dir: Option<PathBuf>, max_bytes: u64) -> Store {
        Store {
            dir,
            max_bytes,
            hits: AtomicU64::new(0),
            misses: AtomicU64::new(0),
            rebuilds: AtomicU64::new(0),
            writes: AtomicU64::new(0),
            write_failures: AtomicU64::new(0),
            evictions: AtomicU64::new(0),
            bytes_mapped: AtomicU64::new(0),
            bytes_written: AtomicU64::new(0),
            tracked_bytes: AtomicU64::new(0),
            temp_seq: AtomicU64::new(0),
            temp_salt: random_salt(),
            warnings: Mutex::new(Vec::new()),
            warned_invalid: AtomicBool::new(false),
            warned_read: AtomicBool::new(false),
            warned_write: AtomicBool::new(false),
            evicting: Mutex::new(()),
            size_scan: Mutex::new(None),
        }
    }

    /// A store that caches nothing (`--no-cache`): every `get` is a miss, `put` does nothing.
    pub fn disabled() -> Store {
        Self::with_dir(None, 0)
    }

    /// Opens the cache folder `dir`, limited to `max_bytes` of records (e.g.
    /// [`DEFAULT_MAX_BYTES`]). Never fails: a missing folder is created (with a
    /// `.gitignore` of `*`); a folder that cannot be created or written (read-only, full)
    /// gives a disabled store and one warning. A folder already over the limit is trimmed.
    pub fn open(dir: &Path, max_bytes: u64) -> Store {
        let mut store = Self::with_dir(None, max_bytes);
        let existed = dir.is_dir();
        if let Err(e) = fs::create_dir_all(dir) {
            store.warn(format!(
                "cache disabled: cannot create {}: {e}",
                dir.display()
            ));
            return store;
        }
        if !existed {
            let _ = fs::write(dir.join(".gitignore"), "*\n");
        }
        // Probe with a few KiB so that a full disk is noticed, not just a read-only folder.
        let probe = dir.join(store.temp_name("probe.dsr"));
        let probed = (|| {
            let mut f = OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&probe)?;
            f.write_all(&[0u8; 4096])?;
            f.flush()
        })();
        let _ = fs::remove_file(&probe);
        if let Err(e) = probed {
            store.warn(format!(
                "cache disabled: cannot write to {}: {e}",
                dir.display()
            ));
            return store;
        }
        store.dir = Some(dir.to_path_buf());
        let folder = dir.to_path_buf();
        let scan = move || {
            let bytes = dir_stats(&folder).map(|s| s.bytes).unwrap_or(0);
            let trimmed = (bytes > max_bytes)
                .then(|| eviction::trim(&folder, max_bytes))
                .flatten();
            trimmed.map_or((bytes, 0), |t| (t.remaining_bytes, t.removed))
        };
        let spawned = std::thread::Builder::new()
            .name("cache size".into())
            .spawn(scan);
        *store.size_scan.get_mut().expect("size scan") = spawned.ok();
        store
    }

    /// Takes the size scan begun at open into the counters, waiting for it if it runs.
    fn settle_size(&self) {
        let scan = self.size_scan.lock().expect("size scan").take();
        if let Some(h) = scan {
            let (bytes, removed) = h.join().unwrap_or((0, 0));
            self.tracked_bytes.fetch_add(bytes, Relaxed);
            self.evictions.fetch_add(removed, Relaxed);
        }
    }

    /// The folder, or `None` when disabled.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// True when records are read and written.
    pub fn is_enabled(&self) -> bool {
        self.dir.is_some()
    }

    /// Size limit of the folder's records, bytes.
    pub fn max_bytes(&self) -> u64 {
        self.max_bytes
    }

    /// The record of `key`, validated and memory-mapped, or `None` (a miss). An invalid
    /// file (truncated, corrupt, another version or key, not a record) is removed, counted
    /// in `rebuilds` and named in a warning (the first one per store; later ones are
    /// summarised). A hit marks the file as recently used for eviction. Never panics.
    pub fn get(&self, key: &RecordKey) -> Option<MappedRecord> {
        self.read(key, true, false)
    }

    /// As [`Self::get`], but, where `map_small`, memory-mapped whatever its size: for
    /// records a run keeps until it ends and reads now and then (a year's daylight
    /// coefficients, a hundred kilobytes each), whose pages can then go back to the kernel
    /// between reads ([`MappedRecord::release`]).
    pub fn get_mapped(&self, key: &RecordKey, map_small: bool) -> Option<MappedRecord> {
        self.read(key, true, map_small)
    }

    /// The record this store has just written for `key` ([`Self::put`]), read back
    /// (memory-mapped when large) to be used in place of the copy it was written from;
    /// validated as [`Self::get`] does, but counted neither as a hit nor as a miss: a cold
    /// run's counters stay all misses. `None` when it is gone or invalid.
    pub fn read_back(&self, key: &RecordKey) -> Option<MappedRecord> {
        self.read(key, false, false)
    }

    /// As [`Self::read_back`], mapped whatever its size ([`Self::get_mapped`]).
    pub fn read_back_mapped(&self, key: &RecordKey) -> Option<MappedRecord> {
        self.read(key, false, true)
    }

    fn read(&self, key: &RecordKey, count: bool, map_small: bool) -> Option<MappedRecord> {
        let miss = || {
            if count {
                self.misses.fetch_add(1, Relaxed);
            }
        };
        let Some(dir) = &self.dir else {
            miss();
            return None;
        };
        let path = dir.join(key.file_name());
        let mut file = match File::open(&path) {
            Ok(f) => f,
            Err(e) => {
                if e.kind() != std::io::ErrorKind::NotFound {
                    self.warn_once(&self.warned_read, || {
                        format!("cache: cannot read {}: {e}", path.display())
                    });
                }
                miss();
                return None;
            }
        };
        let (len, modified) = match file.metadata() {
            Ok(m) => (m.len(), m.modified().ok()),
            Err(e) => return self.invalid(&path, Invalid::Unreadable(e.to_string())),
        };
        // Too short to hold a header: rejected without mapping (empty files cannot be mapped
        // on every platform).
        if len < header_len(0) as u64 {
            return self.invalid(
                &path,
                Invalid::Truncated {
                    len,
                    needed: header_len(0) as u64,
                },
            );
        }
        let record = if len <= READ_MAX_BYTES && !map_small {
            MappedRecord::read_from(&mut file, len as usize, key)
        } else {
            let map = match map_readonly(&file) {
                Ok(m) => m,
                Err(e) => {
                    self.warn_once(&self.warned_read, || {
                        format!("cache: cannot map {}: {e}", path.display())
                    });
                    miss();
                    return None;
                }
            };
            MappedRecord::from_map(map, key)
        };
        match record {
            Ok(r) if !count => Some(r),
            Ok(r) => {
                self.hits.fetch_add(1, Relaxed);
                self.bytes_mapped.fetch_add(len, Relaxed);
                // Least-recently-used bookkeeping, to within TOUCH_AFTER: a warm run read
                // the same records its cold run had just written, and touching each again
                // was a syscall and an inode write a record. A file we may not touch
                // (another user's) is simply evicted earlier.
                let now = SystemTime::now();
                if modified.is_none_or(|t| now.duration_since(t).map_or(true, |a| a > TOUCH_AFTER))
                {
                    let _ = file.set_modified(now);
                }
                Some(r)
            }
            Err(reason) => self.invalid(&path, reason),
        }
    }

    fn invalid(&self, path: &Path, reason: Invalid) -> Option<MappedRecord> {
        self.rebuilds.fetch_add(1, Relaxed);
        // Another process may have replaced it with a valid record meanwhile; removing that
        // costs one rebuild, never a wrong result.
        let _ = fs::remove_file(path);
        self.warn_once(&self.warned_invalid, || {
            format!(
                "cache: removed invalid record {} ({reason}); it will be rebuilt",
                path.display()
            )
        });
        None
    }

    /// Stores `bytes` (from [`super::encode`] or [`super::encode_direction`] with the same
    /// key) as the record of `key`: written to a unique temporary file in the folder, then
    /// renamed over the record's name. Concurrent writers of one key all complete; the last
    /// rename wins and readers see one complete record or the other. Failures become a
    /// warning and a `write_failures` count, never an error. Not synced to disk: a record
    /// cut short by a power failure fails validation and is rebuilt. May evict old records.
    pub fn put(&self, key: &RecordKey, bytes: &[u8]) {
        self.put_with(key, |f| f.write_all(bytes).map(|()| bytes.len() as u64));
    }

    /// As [`Self::put`] for a record given as its sections, written to the file as they
    /// lie ([`super::record::write_record`]) rather than encoded in memory first: what a
    /// record of hundreds of megabytes (the interreflection operator) needs. Returns
    /// whether the record was written (a failure is counted and warned of, as by `put`).
    pub fn put_sections(&self, key: &RecordKey, sections: &[super::record::Section<'_>]) -> bool {
        self.put_with(key, |f| {
            let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
            let n = super::record::write_record(&mut w, key, sections)?;
            w.flush()?;
            Ok(n)
        })
    }

    /// Writes a record through `write` (which returns the bytes it wrote) to a temporary
    /// file, then renames it into place; whether it did.
    fn put_with(
        &self,
        key: &RecordKey,
        write: impl FnOnce(&mut fs::File) -> std::io::Result<u64>,
    ) -> bool {
        let Some(dir) = &self.dir else { return false };
        let name = key.file_name();
        let tmp = dir.join(self.temp_name(&name));
        let result = (|| {
            let mut f = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
            let n = write(&mut f)?;
            f.set_modified(SystemTime::now())?;
            drop(f);
            fs::rename(&tmp, dir.join(&name))?;
            Ok::<u64, std::io::Error>(n)
        })();
        match result {
            Ok(n) => {
                self.settle_size();
                self.writes.fetch_add(1, Relaxed);
                self.bytes_written.fetch_add(n, Relaxed);
                if self.tracked_bytes.fetch_add(n, Relaxed) + n > self.max_bytes {
                    self.evict();
                }
                true
            }
            Err(e) => {
                let _ = fs::remove_file(&tmp);
                self.write_failures.fetch_add(1, Relaxed);
                self.warn_once(&self.warned_write, || {
                    format!("cache: cannot write {}: {e}", dir.join(&name).display())
                });
                false
            }
        }
    }

    /// Unique temporary name for `final_name`: process id, a per-store counter and a
    /// random salt (two stores in one process, or a reused pid, never collide).
    fn temp_name(&self, final_name: &str) -> String {
        format!(
            ".{final_name}.{}-{}-{:016x}.tmp",
            std::process::id(),
            self.temp_seq.fetch_add(1, Relaxed),
            self.temp_salt
        )
    }

    /// Removes least-recently-used records (oldest modification time first) until the
    /// records take at most 90 % of `max_bytes` (the margin keeps every put from rescanning
    /// the folder), and temporary files left by crashed writers. One thread at a time.
    fn evict(&self) {
        let Some(dir) = &self.dir else { return };
        let Ok(_guard) = self.evicting.try_lock() else {
            return; // another thread of this store is evicting right now
        };
        if let Some(trimmed) = eviction::trim(dir, self.max_bytes) {
            self.evictions.fetch_add(trimmed.removed, Relaxed);
            self.tracked_bytes.store(trimmed.remaining_bytes, Relaxed);
        }
    }

    /// A snapshot of the counters.
    pub fn stats(&self) -> CacheStats {
        self.settle_size();
        CacheStats {
            hits: self.hits.load(Relaxed),
            misses: self.misses.load(Relaxed),
            rebuilds: self.rebuilds.load(Relaxed),
            writes: self.writes.load(Relaxed),
            write_failures: self.write_failures.load(Relaxed),
            evictions: self.evictions.load(Relaxed),
            bytes_mapped: self.bytes_mapped.load(Relaxed),
            bytes_written: self.bytes_written.load(Relaxed),
        }
    }

    /// Warnings for the run report: disabled cache, the first invalid record, the first
    /// failed read and write, and a count of further invalid records and failed writes.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = self.warnings.lock().map(|w| w.clone()).unwrap_or_default();
        let more_invalid = self.rebuilds.load(Relaxed).saturating_sub(1);
        if more_invalid > 0 {
            w.push(format!(
                "cache: {more_invalid} more invalid records removed and rebuilt"
            ));
        }
        let more_failed = self.write_failures.load(Relaxed).saturating_sub(1);
        if more_failed > 0 {
            w.push(format!("cache: {more_failed} more record writes failed"));
        }
        // Eviction keeps the folder at 90 % of the limit: a run that writes more than that
        // removed some of its own records, which it (or its next block, or the next run)
        // computes again.
        let written = self.bytes_written.load(Relaxed);
        let evicted = self.evictions.load(Relaxed);
        if evicted > 0 && written > self.max_bytes - self.max_bytes / 10 {
            let size = |b: u64| match b as f64 / (1u64 << 20) as f64 {
                m if m < 1024.0 => format!("{m:.1} MiB"),
                m => format!("{:.2} GiB", m / 1024.0),
            };
            w.push(format!(
                "cache: this run wrote {} of records, more than the folder's limit ({}) \
                 keeps, and {evicted} records were removed; some may be computed again: a \
                 larger --cache-size keeps them",
                size(written),
                size(self.max_bytes)
            ));
        }
        w
    }

    fn warn(&self, message: String) {
        if let Ok(mut w) = self.warnings.lock() {
            w.push(message);
        }
    }

    fn warn_once(&self, flag: &AtomicBool, message: impl FnOnce() -> String) {
        if !flag.swap(true, Relaxed) {
            self.warn(message());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cache::key::{SceneHash, KIND_SKY_NODE};
    use crate::cache::record::{encode, Section};

    fn key(d: u64) -> RecordKey {
        RecordKey {
            scene: SceneHash([9; 32]),
            kind: KIND_SKY_NODE,
            direction: d,
            resolution: 64,
        }
    }

    /// A record of the same size for every direction `d`.
    fn bytes(d: u64) -> Vec<u8> {
        encode(&key(d), &[Section::f64s(300, &[d as f64; 64])])
    }

    /// A record above [`READ_MAX_BYTES`] is mapped; giving its pages back leaves its
    /// bytes as they were (read again from the file).
    #[test]
    fn a_mapped_record_reads_the_same_after_its_pages_are_given_back() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
        let values: Vec<f64> = (0..(READ_MAX_BYTES as usize / 4))
            .map(|i| i as f64)
            .collect();
        store.put(&key(1), &encode(&key(1), &[Section::f64s(300, &values)]));
        let r = store.get(&key(1)).unwrap();
        assert!(r.is_mapped());
        assert_eq!(r.f64s(300).unwrap(), &values[..]);
        r.release();
        assert_eq!(r.f64s(300).unwrap(), &values[..]);
        r.release();
        r.release();
        assert_eq!(
            r.f64s(300).unwrap()[values.len() - 1],
            values[values.len() - 1]
        );
        // Part of it, at ranges that start and end inside pages, empty or beyond its end
        // (ignored), as a pass over an array read in place gives back what it has read.
        let n = r.bytes().len();
        for range in [0..1, 100..5000, 4095..4097, n / 2..n, 7..7, n - 3..n + 10] {
            r.release_range(range);
            assert_eq!(r.f64s(300).unwrap(), &values[..]);
        }
    }

    #[test]
    fn a_run_that_outgrows_the_limit_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let c = dir.path().join("c");
        let size = bytes(0).len() as u64;
        let roomy = Store::open(&c, 10 * size);
        for d in 0..5 {
            roomy.put(&key(d), &bytes(d));
        }
        assert!(roomy.warnings().is_empty(), "{:?}", roomy.warnings());
        drop(roomy);
        let small = Store::open(&c, 4 * size);
        for d in 10..15 {
            small.put(&key(d), &bytes(d));
        }
        let w = small.warnings();
        assert!(small.stats().evictions > 0);
        assert!(w.iter().any(|w| w.contains("--cache-size")), "{w:?}");
    }

    #[test]
    fn a_folder_over_the_limit_at_open_is_trimmed_and_counted() {
        // The size scan runs beside the caller since open; its trim and its count must
        // still be there: in the folder once the store is dropped, and in the counters
        // and the size the next write adds to.
        let dir = tempfile::tempdir().unwrap();
        let c = dir.path().join("c");
        let size = bytes(0).len() as u64;
        let big = Store::open(&c, DEFAULT_MAX_BYTES);
        for d in 0..6 {
            big.put(&key(d), &bytes(d));
        }
        drop(big);
        let store = Store::open(&c, 3 * size);
        assert_eq!(
            store.stats().evictions,
            4,
            "trimmed to 90 % of the limit: two left"
        );
        store.put(&key(9), &bytes(9));
        let s = dir_stats(&c).unwrap();
        assert_eq!((s.files, s.bytes), (3, 3 * size));
        assert_eq!(store.stats().evictions, 4, "three records fit the limit");
        drop(store);
        let reopened = Store::open(&c, 2 * size);
        drop(reopened);
        assert_eq!(
            dir_stats(&c).unwrap().files,
            1,
            "trimmed by a store dropped at once"
        );
    }

    #[test]
    fn put_get_and_counters() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(&dir.path().join("c"), DEFAULT_MAX_BYTES);
        assert!(store.is_enabled(), "{:?}", store.warnings());
        assert!(dir.path().join("c/.gitignore").is_file());
        assert!(store.get(&key(1)).is_none());
        let vals = [1.0, 2.0];
        let bytes = encode(&key(1), &[Section::f64s(300, &vals)]);
        store.put(&key(1), &bytes);
        let r = store.get(&key(1)).unwrap();
        // Small: read, not mapped (READ_MAX_BYTES).
        assert!(!r.is_mapped());
        assert_eq!(r.bytes(), &bytes[..]);
        assert_eq!(r.f64s(300).unwrap(), &vals);
        let s = store.stats();
        assert_eq!((s.hits, s.misses, s.writes, s.rebuilds), (1, 1, 1, 0));
        assert_eq!(s.bytes_written, bytes.len() as u64);
        assert_eq!(s.bytes_mapped, bytes.len() as u64);
        assert!(store.warnings().is_empty());
        let d = dir_stats(&dir.path().join("c")).unwrap();
        assert_eq!((d.files, d.bytes, d.temp_files), (1, bytes.len() as u64, 0));
    }

    #[test]
    fn records_above_the_read_limit_are_mapped_and_read_the_same() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(&dir.path().join("c"), DEFAULT_MAX_BYTES);
        let n = (READ_MAX_BYTES as usize) / 8 + 1;
        let vals: Vec<f64> = (0..n).map(|i| i as f64 * 0.5).collect();
        let bytes = encode(&key(2), &[Section::f64s(300, &vals)]);
        assert!(bytes.len() as u64 > READ_MAX_BYTES);
        store.put(&key(2), &bytes);
        let r = store.get(&key(2)).unwrap();
        assert!(r.is_mapped());
        assert_eq!(r.bytes(), &bytes[..]);
        assert_eq!(r.f64s(300).unwrap(), &vals[..]);
    }

    #[test]
    fn disabled_store_caches_nothing() {
        let store = Store::disabled();
        store.put(&key(1), &encode(&key(1), &[]));
        assert!(store.get(&key(1)).is_none());
        assert_eq!(store.stats().writes, 0);
        assert!(!store.is_enabled());
    }
}
