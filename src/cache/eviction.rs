//! Size-limited least-recently-used eviction of a cache folder: one pass over the folder
//! that removes the records used longest ago (a hit or a write sets a record's
//! modification time) until the rest fits, plus temporary files left by crashed writers.
//! [`super::Store`] decides when to run it and keeps the counters.

use super::maintenance::{classify, FileKind};
use std::fs;
use std::path::Path;
use std::time::{Duration, SystemTime};

/// Temporary files older than this are leftovers of a crashed writer and may be removed.
const STALE_TEMP: Duration = Duration::from_secs(3600);

/// What one eviction pass did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Trimmed {
    /// Records removed.
    pub removed: u64,
    /// Total size of the records left in the folder, bytes.
    pub remaining_bytes: u64,
}

/// Removes least-recently-used records of `dir` (oldest modification time first) until the
/// records take at most 90 % of `max_bytes` (the margin keeps every put from rescanning
/// the folder), and temporary files older than an hour. Nothing is removed while the
/// records fit in `max_bytes`. `None` when the folder cannot be listed.
pub(super) fn trim(dir: &Path, max_bytes: u64) -> Option<Trimmed> {
    let entries = fs::read_dir(dir).ok()?;
    let now = SystemTime::now();
    let mut records = Vec::new();
    let mut total = 0u64;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Ok(meta) = e.metadata() else { continue };
        let mtime = meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
        match classify(&name) {
            FileKind::Record if meta.is_file() => {
                total += meta.len();
                records.push((mtime, name, meta.len()));
            }
            FileKind::Temp if now.duration_since(mtime).is_ok_and(|age| age > STALE_TEMP) => {
                let _ = fs::remove_file(e.path());
            }
            _ => {}
        }
    }
    let mut removed = 0;
    let low_water = max_bytes - max_bytes / 10;
    if total > max_bytes {
        records.sort();
        for (_, name, len) in records {
            if total <= low_water {
                break;
            }
            if fs::remove_file(dir.join(&name)).is_ok() {
                removed += 1;
            }
            total = total.saturating_sub(len);
        }
    }
    Some(Trimmed {
        removed,
        remaining_bytes: total,
    })
}
