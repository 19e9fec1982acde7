//! `daystep cache stats | verify | clear`: inspecting and maintaining a projection cache
//! folder. The reports go to standard output, one line each, for scripts.

use super::args::CacheAction;
use super::messages::say;
use crate::error::{Error, Result};

/// A file time as local `YYYY-MM-DD HH:MM:SS`, or `-` when unknown.
fn format_time(t: Option<std::time::SystemTime>) -> String {
    t.map(|t| {
        chrono::DateTime::<chrono::Local>::from(t)
            .format("%Y-%m-%d %H:%M:%S")
            .to_string()
    })
    .unwrap_or_else(|| "-".into())
}

/// Runs one `daystep cache` action.
///
/// # Errors
/// An unreadable folder; for `verify` without `--fix`, [`Error::Input`] when any record
/// is invalid (exit code 1).
pub fn run(action: CacheAction) -> Result<()> {
    match action {
        CacheAction::Stats { cache } => {
            let s = crate::cache::dir_stats(&cache.dir)?;
            say!(
                "{}: {} records, {} bytes ({:.1} MiB), {} temporary files, least recently used {}, most recently used {}",
                cache.dir.display(),
                s.files,
                s.bytes,
                s.bytes as f64 / (1u64 << 20) as f64,
                s.temp_files,
                format_time(s.oldest),
                format_time(s.newest)
            )
        }
        CacheAction::Verify { cache, fix } => {
            let r = crate::cache::verify(&cache.dir)?;
            for (path, reason) in &r.invalid {
                say!("invalid: {}: {reason}", path.display())?;
            }
            for path in &r.foreign {
                say!("not a cache file (left alone): {}", path.display())?;
            }
            let removed = if fix { r.remove_invalid() } else { 0 };
            say!(
                "{}: {} valid, {} invalid{}, {} temporary, {} foreign",
                cache.dir.display(),
                r.ok,
                r.invalid.len(),
                if fix {
                    format!(" ({removed} removed)")
                } else {
                    String::new()
                },
                r.temp_files,
                r.foreign.len()
            )?;
            if r.is_clean() || fix {
                Ok(())
            } else {
                Err(Error::input(
                    &cache.dir,
                    None,
                    None,
                    format!(
                        "{} invalid cache records (run `daystep cache verify --fix` to remove them)",
                        r.invalid.len()
                    ),
                ))
            }
        }
        CacheAction::Clear { cache } => {
            let n = crate::cache::clear(&cache.dir)?;
            say!("{}: removed {n} files", cache.dir.display())
        }
    }
}
