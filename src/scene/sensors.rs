//! Radiance `.pts` sensor files: `x y z dx dy dz` per line (metres, model frame), blank lines
//! and `#` comments skipped.

use super::y_up_to_z_up;
use crate::error::{Error, Result};
use crate::files;
use glam::DVec3;
use std::path::Path;

/// Loads a `.pts` file as (position, direction) pairs in the model frame (Z up, metres).
///
/// With `y_up` the file is read as Y-up and both positions and directions are converted
/// with [`y_up_to_z_up`]. Directions are returned as written (not normalised).
///
/// # Errors
/// [`Error::Input`] naming the file, 1-based line and offending value for a line that does
/// not hold exactly six numbers, a non-finite number or a zero direction; [`Error::Io`] when
/// the file cannot be read.
pub fn load(path: &Path, y_up: bool) -> Result<Vec<(DVec3, DVec3)>> {
    let text = files::read_text(path)?;
    parse(path, &text, y_up)
}

/// Parses `.pts` text; `path` only names the source in errors.
fn parse(path: &Path, text: &str, y_up: bool) -> Result<Vec<(DVec3, DVec3)>> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        // Trailing `# …` comments are skipped too; anything else beyond six numbers is an
        // error rather than silently ignored (rtrace would misread such a file).
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.len() != 6 {
            return Err(Error::input(
                path,
                Some(line_no),
                Some(line),
                format!(
                    "a sensor line needs 6 numbers `x y z dx dy dz`, found {}",
                    words.len()
                ),
            ));
        }
        let mut v = [0.0; 6];
        for (slot, w) in v.iter_mut().zip(&words) {
            let x: f64 = w
                .parse()
                .map_err(|_| Error::input(path, Some(line_no), Some(w), "not a number"))?;
            if !x.is_finite() {
                return Err(Error::input(
                    path,
                    Some(line_no),
                    Some(w),
                    "sensor coordinates must be finite",
                ));
            }
            *slot = x;
        }
        let mut p = DVec3::new(v[0], v[1], v[2]);
        let mut d = DVec3::new(v[3], v[4], v[5]);
        // A squared length that is zero, subnormal or infinite cannot be normalised exactly
        // (3e-162 0 0 would become a normal of length 0.95).
        if !d.length_squared().is_normal() {
            return Err(Error::input(
                path,
                Some(line_no),
                Some(&words[3..].join(" ")),
                "sensor direction must be non-zero (and not so small or so large that its \
                 squared length under- or overflows)",
            ));
        }
        if y_up {
            p = y_up_to_z_up(p);
            d = y_up_to_z_up(d);
        }
        out.push((p, d));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn input_error(e: Error) -> (String, Option<usize>, Option<String>) {
        let (shown, _, line, value) = crate::error::input_parts(e);
        (shown, line, value)
    }

    #[test]
    fn reads_sensors_skipping_comments_and_blanks() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "a.pts",
            "# header\n\n1 2 3 0 0 1\n  4 5 6 0 1 0  # trailing\r\n",
        );
        let s = load(&p, false).unwrap();
        assert_eq!(
            s,
            vec![
                (DVec3::new(1.0, 2.0, 3.0), DVec3::Z),
                (DVec3::new(4.0, 5.0, 6.0), DVec3::Y)
            ]
        );
    }

    #[test]
    fn y_up_converts_positions_and_directions() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "a.pts", "1 2 3 0 1 0\n");
        let s = load(&p, true).unwrap();
        assert_eq!(s, vec![(DVec3::new(1.0, -3.0, 2.0), DVec3::Z)]);
    }

    #[test]
    fn malformed_lines_name_file_line_and_value() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            ("0 0 0 0 0 1\n1 2 3 0 0\n", 2, "1 2 3 0 0"),
            ("\n\n0 0 x 0 0 1\n", 3, "x"),
            ("0 0 NaN 0 0 1\n", 1, "NaN"),
            ("0 0 0 inf 0 1\n", 1, "inf"),
            ("#\n0 0 0 0 0 0\n", 2, "0 0 0"),
            ("0 0 0 0 0 1 7\n", 1, "0 0 0 0 0 1 7"),
        ];
        for (text, line, value) in cases {
            let p = write(dir.path(), "bad.pts", text);
            let (shown, l, v) = input_error(load(&p, false).unwrap_err());
            assert_eq!(l, Some(line), "{shown}");
            assert_eq!(v.as_deref(), Some(value), "{shown}");
            assert!(shown.contains("bad.pts") && shown.contains(&format!(":{line}:")));
        }
    }

    #[test]
    fn missing_file_is_an_io_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let e = load(&dir.path().join("none.pts"), false).unwrap_err();
        assert!(matches!(e, Error::Io { .. }) && e.to_string().contains("none.pts"));
    }
}
