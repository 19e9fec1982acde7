//! Reading the illuminance tables (`illuminance.csv`, `direct_sun.csv`, `surfaces.csv`):
//! whole, or one row at a time for a year of a large grid. Every refusal names the file,
//! the 1-based line and the value.

use super::TIME_FORMAT;
use crate::error::{Error, Result};
use crate::files;
use chrono::NaiveDateTime;
use std::fs::File;
use std::path::{Path, PathBuf};

/// Parses illuminance-style CSV text: (times as written, rows of values).
pub(super) fn parse_csv(path: &Path, text: &str) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let mut lines = text.lines();
    let columns = parse_header(path, lines.next().unwrap_or(""))?;
    let (mut times, mut rows) = (Vec::new(), Vec::new());
    for (i, line) in lines.enumerate() {
        let mut values = Vec::new();
        let time = parse_row(path, i + 2, line, columns, &mut values)?;
        times.push(time.to_owned());
        rows.push(values);
    }
    Ok((times, rows))
}

/// The number of value columns of a `time,s0,s1,…` header (line 1 of `path`).
fn parse_header(path: &Path, header: &str) -> Result<usize> {
    let mut cols = header.split(',');
    if cols.next() != Some("time") {
        return Err(Error::input(
            path,
            Some(1),
            Some(header),
            "expected a header `time,s0,s1,…`",
        ));
    }
    Ok(cols.count())
}

/// Parses line `n` of `path` (a row of `columns` values) into `values`; returns its time
/// as written.
fn parse_row<'l>(
    path: &Path,
    n: usize,
    line: &'l str,
    columns: usize,
    values: &mut Vec<f64>,
) -> Result<&'l str> {
    values.clear();
    let found = line.split(',').count();
    if found != columns + 1 {
        return Err(row_width(path, n, line, columns, found));
    }
    let mut fields = line.split(',');
    let time = fields.next().unwrap_or("");
    if NaiveDateTime::parse_from_str(time, TIME_FORMAT).is_err() {
        return Err(Error::input(
            path,
            Some(n),
            Some(time),
            "time must be YYYY-MM-DDTHH:MM:SS",
        ));
    }
    for f in fields {
        let v = f
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| Error::input(path, Some(n), Some(f), "not a finite number"))?;
        values.push(v);
    }
    Ok(time)
}

fn row_width(path: &Path, n: usize, line: &str, columns: usize, found: usize) -> Error {
    Error::input(
        path,
        Some(n),
        Some(line),
        format!(
            "a row needs {} fields (time and {columns} values), found {found}",
            columns + 1
        ),
    )
}

/// An illuminance-style CSV read one row at a time (what a year of a large grid needs:
/// the metrics never hold the whole table).
pub struct IlluminanceRows {
    path: PathBuf,
    lines: std::io::Lines<std::io::BufReader<File>>,
    columns: usize,
    line: usize,
}

impl IlluminanceRows {
    /// Opens `path` and reads its header.
    ///
    /// # Errors
    /// [`Error::Io`]; [`Error::Input`] for a header that is not `time,…`.
    pub fn open(path: &Path) -> Result<IlluminanceRows> {
        use std::io::BufRead;
        let f = File::open(path).map_err(|e| Error::io(path, e))?;
        let mut lines = std::io::BufReader::with_capacity(1 << 20, f).lines();
        let header = lines
            .next()
            .transpose()
            .map_err(|e| Error::io(path, e))?
            .unwrap_or_default();
        let columns = parse_header(path, &header)?;
        Ok(IlluminanceRows {
            path: path.to_owned(),
            lines,
            columns,
            line: 1,
        })
    }

    /// Value columns per row.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// The next row's values into `values`, and its time as written; `None` at the end.
    ///
    /// # Errors
    /// As [`read_illuminance_csv`], naming the line.
    pub fn next_row(&mut self, values: &mut Vec<f64>) -> Result<Option<String>> {
        let Some(line) = self.lines.next() else {
            return Ok(None);
        };
        let line = line.map_err(|e| Error::io(&self.path, e))?;
        self.line += 1;
        let time = parse_row(&self.path, self.line, &line, self.columns, values)?;
        Ok(Some(time.to_owned()))
    }
}

/// Reads an `illuminance.csv`: the `time` column as written and one row of values per line.
///
/// # Errors
/// [`Error::Input`] naming the file, 1-based line and value for a bad header, a row with the
/// wrong number of fields, a malformed time or a non-finite value; [`Error::Io`].
pub fn read_illuminance_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    parse_csv(path, &files::read_text(path)?)
}
