//! File helpers: atomic writes (temporary file in the same folder, then rename), so a crash
//! or a concurrent writer never leaves a half-written output that looks complete.

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically: a temporary sibling is written, flushed to disk and
/// renamed over `path`. Creates the parent folder if needed.
///
/// # Errors
/// [`Error::Io`] naming the path that failed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let name = path
        .file_name()
        .ok_or_else(|| Error::Internal(format!("not a file path: {}", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// Reads a whole text file, naming the path in the error.
///
/// # Errors
/// [`Error::Io`] when the file cannot be read, [`Error::Input`] when it is not UTF-8.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    String::from_utf8(bytes).map_err(|e| {
        let upto = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = upto.iter().filter(|&&b| b == b'\n').count() + 1;
        Error::input(path, Some(line), None, "file is not valid UTF-8 text")
    })
}

/// Checks, before any work, that the output folder `dir` given by flag `flag` can take new
/// files, without creating anything: an existing folder must take a probe file (written
/// and removed at once); a missing one needs its nearest existing ancestor to be a folder
/// that takes one, so that the run can create it. A run that would fail on its first
/// write fails here instead, with nothing computed and nothing left behind.
///
/// # Errors
/// [`Error::Input`] naming the flag and the path (exit 1): the path or an ancestor is a
/// file, or the folder that would hold the output cannot be written.
pub fn check_output_dir(flag: &str, dir: &Path) -> Result<()> {
    let refuse = |why: String| Error::arg(flag, dir.display(), why);
    if dir.exists() && !dir.is_dir() {
        return Err(refuse("exists and is not a folder".into()));
    }
    writable_ancestor(dir).map_err(refuse)
}

/// Checks, before any work, that the output file `path` given by flag `flag` can be
/// written: it is not a folder, and its folder exists and takes new files, or can be
/// created (see [`check_output_dir`]). Nothing is created and the file is not touched, so
/// an existing one is only replaced by the run.
///
/// # Errors
/// [`Error::Input`] naming the flag and the path (exit 1).
pub fn check_output_file(flag: &str, path: &Path) -> Result<()> {
    let refuse = |why: String| Error::arg(flag, path.display(), why);
    if path.is_dir() {
        return Err(refuse(
            "is a folder; give a file name (e.g. solution.glb)".into(),
        ));
    }
    if path.file_name().is_none() {
        return Err(refuse("is not a file name".into()));
    }
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    writable_ancestor(dir).map_err(refuse)
}

/// `Ok` when `dir` is a writable folder, or is missing and its nearest existing ancestor
/// is one; otherwise why not.
fn writable_ancestor(dir: &Path) -> std::result::Result<(), String> {
    let mut at = dir;
    loop {
        if at.is_dir() {
            return probe(at).map_err(|e| format!("cannot write in {}: {e}", at.display()));
        }
        if at.exists() {
            return Err(format!("{} is not a folder", at.display()));
        }
        at = match at.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            // A relative path's top: the working folder, unless that is where we are.
            _ if at != Path::new(".") => Path::new("."),
            _ => return Err("the working folder is gone".into()),
        };
    }
}

/// Writes and removes a small file in `dir`: the only portable test of write permission
/// (mode bits say nothing about read-only mounts, ACLs or root).
fn probe(dir: &Path) -> std::io::Result<()> {
    let p = dir.join(format!(".daystep-probe.{}", std::process::id()));
    std::fs::File::create(&p)?.write_all(b"probe")?;
    std::fs::remove_file(&p)
}

/// `text` with `&`, `<`, `>`, `"` and `'` escaped for HTML text and attributes (the report
/// page, its maps and the render preview).
pub fn html_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Writes all of `buf` at byte `at` of `f`.
///
/// # Errors
/// The write's I/O error.
#[cfg(unix)]
pub fn write_at(f: &std::fs::File, buf: &[u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::write_all_at(f, buf, at)
}

/// Fills `buf` from byte `at` of `f`.
///
/// # Errors
/// The read's I/O error (a file too short included).
#[cfg(unix)]
pub fn read_at(f: &std::fs::File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    std::os::unix::fs::FileExt::read_exact_at(f, buf, at)
}

#[cfg(not(unix))]
#[allow(missing_docs)]
pub fn write_at(f: &std::fs::File, buf: &[u8], at: u64) -> std::io::Result<()> {
    use std::io::{Seek, SeekFrom, Write};
    let mut f = f;
    f.seek(SeekFrom::Start(at))?;
    f.write_all(buf)
}

#[cfg(not(unix))]
#[allow(missing_docs)]
pub fn read_at(f: &std::fs::File, buf: &mut [u8], at: u64) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = f;
    f.seek(SeekFrom::Start(at))?;
    f.read_exact(buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/out.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(p.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn output_checks_refuse_folders_and_files_in_the_way_naming_the_flag() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.txt");
        std::fs::write(&file, b"x").unwrap();
        // A folder where a file is wanted, a file where a folder is wanted, a file as parent.
        for e in [
            check_output_file("--gltf", dir.path()).unwrap_err(),
            check_output_dir("--out", &file).unwrap_err(),
            check_output_file("--gltf", &file.join("x.glb")).unwrap_err(),
            check_output_dir("--out", &file.join("sub")).unwrap_err(),
        ] {
            assert_eq!(e.exit_code(), 1, "{e}");
            let (shown, path, _, _) = crate::error::input_parts(e);
            assert!(
                path.to_string_lossy().starts_with("<argument --"),
                "{shown}"
            );
        }
        // What is fine passes, creates nothing and leaves no probe behind.
        check_output_dir("--out", &dir.path().join("new/out")).unwrap();
        check_output_file("--gltf", &dir.path().join("g/x.glb")).unwrap();
        check_output_file("--gltf", &file).unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), b"x");
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, [std::ffi::OsString::from("a.txt")]);
    }
}
