//! Maintenance of a cache folder, outside any [`super::Store`]: which names are records,
//! temporary files or ours to keep (`classify`, shared with eviction); the folder's size
//! and age ([`dir_stats`]); checking every record ([`verify`]); and removing them
//! ([`clear`]). Its public items are also re-exported from [`super::store`].

use super::record::{Invalid, Record};
use super::RECORD_EXTENSION;
use crate::error::{Error, Result};
use std::fs;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// Files in a cache folder that are ours but not records; kept by [`clear`].
const KEPT_NAMES: &[&str] = &[".gitignore", "README.md", "CACHEDIR.TAG"];

/// What a name in a cache folder is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum FileKind {
    /// `*.dsr`.
    Record,
    /// A temporary file of an in-flight (or crashed) write.
    Temp,
    /// `.gitignore` and the like: ours to keep.
    Kept,
    /// Anything else.
    Foreign,
}

/// Classifies a file name of a cache folder.
pub(super) fn classify(name: &str) -> FileKind {
    if KEPT_NAMES.contains(&name) {
        FileKind::Kept
    } else if name.starts_with('.') && name.ends_with(".tmp") && name.contains(".dsr.") {
        FileKind::Temp
    } else if name
        .strip_suffix(RECORD_EXTENSION)
        .is_some_and(|s| s.ends_with('.'))
    {
        FileKind::Record
    } else {
        FileKind::Foreign
    }
}

/// Lists `dir` as (path, name, kind, metadata); a missing folder is empty.
fn scan(dir: &Path) -> Result<Vec<(PathBuf, String, FileKind, fs::Metadata)>> {
    let mut out = entries(dir)?.collect::<Result<Vec<_>>>()?;
    out.sort_by(|a, b| a.1.cmp(&b.1));
    Ok(out)
}

/// The entries of `dir` in the order the file system lists them, each with its name, kind
/// and metadata (an entry removed meanwhile is skipped); none for a missing folder.
fn entries(
    dir: &Path,
) -> Result<impl Iterator<Item = Result<(PathBuf, String, FileKind, fs::Metadata)>> + '_> {
    let listed = match fs::read_dir(dir) {
        Ok(e) => Some(e),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(Error::io(dir, e)),
    };
    Ok(listed.into_iter().flatten().filter_map(move |e| {
        let e = match e {
            Ok(e) => e,
            Err(err) => return Some(Err(Error::io(dir, err))),
        };
        let meta = e.metadata().ok()?; // removed meanwhile
        let name = e.file_name().to_string_lossy().into_owned();
        let kind = if meta.is_file() {
            classify(&name)
        } else {
            FileKind::Foreign
        };
        Some(Ok((e.path(), name, kind, meta)))
    }))
}

/// Size and age of a cache folder's records.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct DirStats {
    /// Record files (`*.dsr`).
    pub files: u64,
    /// Their total size, bytes.
    pub bytes: u64,
    /// Temporary files (writes in flight, or left by a crash).
    pub temp_files: u64,
    /// Modification (= last use) time of the least recently used record.
    pub oldest: Option<SystemTime>,
    /// Modification (= last use) time of the most recently used record.
    pub newest: Option<SystemTime>,
}

/// Counts the records of `dir` (a missing folder has none).
///
/// # Errors
/// [`Error::Io`] when the folder cannot be listed.
pub fn dir_stats(dir: &Path) -> Result<DirStats> {
    let mut s = DirStats::default();
    // Streamed, not listed: a store opening a folder of tens of thousands of records
    // sums them beside the run (`Store::open`), and a list of them was 17 MB of its peak.
    for entry in entries(dir)? {
        let (_, _, kind, meta) = entry?;
        match kind {
            FileKind::Record => {
                s.files += 1;
                s.bytes += meta.len();
                if let Ok(t) = meta.modified() {
                    s.oldest = Some(s.oldest.map_or(t, |o| o.min(t)));
                    s.newest = Some(s.newest.map_or(t, |o| o.max(t)));
                }
            }
            FileKind::Temp => s.temp_files += 1,
            _ => {}
        }
    }
    Ok(s)
}

/// Result of [`verify`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VerifyReport {
    /// Valid records.
    pub ok: usize,
    /// Invalid record files with the reason (a record whose embedded key does not give its
    /// file name is [`Invalid::OtherKey`]).
    pub invalid: Vec<(PathBuf, Invalid)>,
    /// Files and folders that are not ours (left alone).
    pub foreign: Vec<PathBuf>,
    /// Temporary files (writes in flight, or left by a crash).
    pub temp_files: usize,
}

impl VerifyReport {
    /// True when no invalid record was found.
    pub fn is_clean(&self) -> bool {
        self.invalid.is_empty()
    }

    /// Removes the invalid files; returns how many were removed.
    pub fn remove_invalid(&self) -> usize {
        self.invalid
            .iter()
            .filter(|(p, _)| fs::remove_file(p).is_ok())
            .count()
    }
}

/// Validates every record of `dir` (header, lengths, bounds, both checksums) and checks
/// that its embedded key gives its file name. Reads files, does not map them, changes
/// nothing. A missing folder is clean.
///
/// # Errors
/// [`Error::Io`] when the folder cannot be listed.
pub fn verify(dir: &Path) -> Result<VerifyReport> {
    let mut report = VerifyReport::default();
    for (path, name, kind, _) in scan(dir)? {
        match kind {
            FileKind::Record => {
                let outcome = match fs::read(&path) {
                    Ok(bytes) => Record::parse(&bytes).and_then(|r| {
                        if r.key().file_name() == name {
                            Ok(())
                        } else {
                            Err(Invalid::OtherKey)
                        }
                    }),
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                    Err(e) => Err(Invalid::Unreadable(e.to_string())),
                };
                match outcome {
                    Ok(()) => report.ok += 1,
                    Err(reason) => report.invalid.push((path, reason)),
                }
            }
            FileKind::Temp => report.temp_files += 1,
            FileKind::Kept => {}
            FileKind::Foreign => report.foreign.push(path),
        }
    }
    Ok(report)
}

/// Removes the records (`*.dsr`) and temporary files of `dir`; keeps everything else
/// (`.gitignore`, `README.md`, foreign files). Returns the number of files removed; a
/// missing folder gives 0.
///
/// # Errors
/// [`Error::Io`] when the folder cannot be listed or a file cannot be removed.
pub fn clear(dir: &Path) -> Result<usize> {
    let mut n = 0;
    for (path, _, kind, _) in scan(dir)? {
        if matches!(kind, FileKind::Record | FileKind::Temp) {
            match fs::remove_file(&path) {
                Ok(()) => n += 1,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(Error::io(&path, e)),
            }
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_classified() {
        assert_eq!(classify("ab.dsr"), FileKind::Record);
        assert_eq!(classify(".ab.dsr.12-0-00ff.tmp"), FileKind::Temp);
        assert_eq!(classify(".gitignore"), FileKind::Kept);
        assert_eq!(classify("README.md"), FileKind::Kept);
        assert_eq!(classify("notes.txt"), FileKind::Foreign);
        assert_eq!(classify("dsr"), FileKind::Foreign);
    }
}
