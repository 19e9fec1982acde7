//! Sensor grids in the outputs: which sensors belong to which named grid (and room), kept
//! in `DIR/grids.json` beside the results, so that metrics, merges of shards and later
//! tools can split a run per grid without the scene. Honeybee's annual results layout
//! keeps one `.ill` per grid; [`write_grid_ills`] writes `DIR/grids/<identifier>.ill`.

use crate::error::{Error, Result};
use crate::files;
use chrono::NaiveDateTime;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One named sensor grid of a run's outputs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridSpan {
    /// The grid's identifier, as in the model (a safe file name: letters, digits, `_`, `-`,
    /// `.`; not starting with `.`).
    pub identifier: String,
    /// The room the grid belongs to, where the model says.
    pub room: Option<String>,
    /// Indices of the grid's sensors in the run's sensor order (columns of
    /// `illuminance.csv`), ascending.
    pub sensors: Vec<usize>,
}

/// Name of the one grid a scene without sensor grids (OBJ, `.rad`) is treated as, in the
/// report page and the compliance results.
pub const ALL_SENSORS: &str = "all sensors";

/// The scene's sensor grids as output spans (sensor indices of the run's order).
pub fn spans_of(scene: &crate::scene::Scene) -> Vec<GridSpan> {
    scene
        .grids
        .iter()
        .map(|g| GridSpan {
            identifier: g.identifier.clone(),
            room: g.room.clone(),
            sensors: g.sensors.clone().collect(),
        })
        .collect()
}

/// File name of the grid list in an output folder.
pub const GRIDS_JSON: &str = "grids.json";

/// True when `id` can name a file on every system without quoting: what honeybee allows
/// in identifiers (letters, digits, `_`, `-`, `.`), not empty, not starting with `.`.
pub fn is_safe_identifier(id: &str) -> bool {
    !id.is_empty()
        && !id.starts_with('.')
        && id.len() <= 100
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

/// Checks a grid list against a run of `n_sensors`: safe, distinct identifiers, sensor
/// indices in range, ascending, each sensor in at most one grid.
///
/// # Errors
/// [`Error::Input`] naming `path` and the grid.
pub fn check(path: &Path, grids: &[GridSpan], n_sensors: usize) -> Result<()> {
    let mut owner = vec![false; n_sensors];
    let mut ids = std::collections::HashSet::new();
    for g in grids {
        let bad = |msg: String| Err(Error::input(path, None, Some(&g.identifier), msg));
        if !is_safe_identifier(&g.identifier) {
            return bad(
                "a grid identifier must be letters, digits, '_', '-' or '.' (at most \
                        100, not starting with '.')"
                    .into(),
            );
        }
        if !ids.insert(g.identifier.as_str()) {
            return bad("two grids have this identifier".into());
        }
        if g.sensors.windows(2).any(|w| w[0] >= w[1]) {
            return bad("the grid's sensor indices are not ascending".into());
        }
        for &k in &g.sensors {
            match owner.get_mut(k) {
                None => return bad(format!("sensor {k} is out of range ({n_sensors} sensors)")),
                Some(true) => return bad(format!("sensor {k} is in two grids")),
                Some(o) => *o = true,
            }
        }
    }
    Ok(())
}

/// Writes `out/grids.json` atomically (nothing when `grids` is empty).
///
/// # Errors
/// [`Error::Io`]; [`Error::Internal`] if serialisation fails.
pub fn write_grids_json(out: &Path, grids: &[GridSpan]) -> Result<()> {
    if grids.is_empty() {
        return Ok(());
    }
    let mut text = serde_json::to_string_pretty(&serde_json::json!({ "grids": grids }))
        .map_err(|e| Error::Internal(format!("{GRIDS_JSON}: {e}")))?;
    text.push('\n');
    files::write_atomic(&out.join(GRIDS_JSON), text.as_bytes())
}

/// Reads `out/grids.json`: `None` when the run had no grids (no file).
///
/// # Errors
/// [`Error::Input`] naming the file when it is not a grid list or fails [`check`] against
/// `n_sensors`; [`Error::Io`] when it exists but cannot be read.
pub fn read_grids_json(out: &Path, n_sensors: usize) -> Result<Option<Vec<GridSpan>>> {
    let path = out.join(GRIDS_JSON);
    if !path.exists() {
        return Ok(None);
    }
    #[derive(Deserialize)]
    struct Doc {
        grids: Vec<GridSpan>,
    }
    let text = files::read_text(&path)?;
    let doc: Doc = serde_json::from_str(&text)
        .map_err(|e| Error::input(&path, Some(e.line()), None, format!("not a grid list: {e}")))?;
    check(&path, &doc.grids, n_sensors)?;
    Ok(Some(doc.grids))
}

/// Each sensor's grid identifier (`None` for a sensor in no grid), for a `grid` column.
pub fn grid_column(grids: &[GridSpan], n_sensors: usize) -> Vec<Option<&str>> {
    let mut col = vec![None; n_sensors];
    for g in grids {
        for &k in &g.sensors {
            if let Some(c) = col.get_mut(k) {
                *c = Some(g.identifier.as_str());
            }
        }
    }
    col
}

/// The rooms of a grid list in order of first appearance, each with the union of its
/// grids' sensors (ascending). Grids without a room are left out.
pub fn rooms(grids: &[GridSpan]) -> Vec<(String, Vec<usize>)> {
    let mut out: Vec<(String, Vec<usize>)> = Vec::new();
    for g in grids {
        let Some(room) = &g.room else { continue };
        match out.iter_mut().find(|(r, _)| r == room) {
            Some((_, s)) => s.extend(&g.sensors),
            None => out.push((room.clone(), g.sensors.clone())),
        }
    }
    for (_, s) in &mut out {
        s.sort_unstable();
    }
    out
}

/// Writes one Radiance/DAYSIM `.ill` per grid, `out/grids/<identifier>.ill`, each with its
/// grid's columns of `rows` (one row per time, one value per sensor of the run, lux).
///
/// # Errors
/// As [`super::write_ill`].
pub fn write_grid_ills(
    out: &Path,
    grids: &[GridSpan],
    times: &[NaiveDateTime],
    rows: &[Vec<f64>],
) -> Result<Vec<PathBuf>> {
    let dir = out.join("grids");
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut written = Vec::new();
    for g in grids {
        let sub: Vec<Vec<f64>> = rows
            .iter()
            .map(|r| g.sensors.iter().map(|&k| r[k]).collect())
            .collect();
        let path = dir.join(format!("{}.ill", g.identifier));
        super::write_ill(&path, times, &sub)?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(id: &str, room: Option<&str>, s: &[usize]) -> GridSpan {
        GridSpan {
            identifier: id.into(),
            room: room.map(Into::into),
            sensors: s.to_vec(),
        }
    }

    #[test]
    fn identifiers_that_could_escape_the_folder_are_refused() {
        for bad in ["", "..", ".hidden", "a/b", "a\\b", "a b", "é"] {
            assert!(!is_safe_identifier(bad), "{bad:?}");
        }
        for good in ["Room_1_Grid", "grid-2.south", "A"] {
            assert!(is_safe_identifier(good), "{good:?}");
        }
    }

    #[test]
    fn check_finds_overlaps_range_and_order() {
        let p = Path::new("grids.json");
        assert!(check(p, &[span("a", None, &[0, 1]), span("b", None, &[2])], 3).is_ok());
        for (grids, n) in [
            (vec![span("a", None, &[0, 1]), span("b", None, &[1])], 3),
            (vec![span("a", None, &[0, 3])], 3),
            (vec![span("a", None, &[1, 0])], 3),
            (vec![span("a", None, &[0]), span("a", None, &[1])], 3),
            (vec![span("../x", None, &[0])], 3),
        ] {
            let e = check(p, &grids, n).unwrap_err().to_string();
            assert!(e.starts_with("grids.json"), "{e}");
        }
    }

    #[test]
    fn round_trip_and_columns() {
        let d = tempfile::tempdir().unwrap();
        assert_eq!(read_grids_json(d.path(), 4).unwrap(), None);
        let g = vec![span("w", Some("R1"), &[0, 1]), span("e", Some("R1"), &[3])];
        write_grids_json(d.path(), &g).unwrap();
        assert_eq!(read_grids_json(d.path(), 4).unwrap(), Some(g.clone()));
        assert!(read_grids_json(d.path(), 3).is_err());
        assert_eq!(
            grid_column(&g, 4),
            vec![Some("w"), Some("w"), None, Some("e")]
        );
        assert_eq!(rooms(&g), vec![("R1".to_string(), vec![0, 1, 3])]);
    }

    #[test]
    fn one_ill_per_grid_holds_its_columns() {
        let d = tempfile::tempdir().unwrap();
        let t = chrono::NaiveDate::from_ymd_opt(2024, 3, 21)
            .unwrap()
            .and_hms_opt(12, 0, 0)
            .unwrap();
        let g = vec![span("a", None, &[1]), span("b", None, &[0, 2])];
        write_grid_ills(d.path(), &g, &[t], &[vec![10.0, 20.0, 30.0]]).unwrap();
        let a = std::fs::read_to_string(d.path().join("grids/a.ill")).unwrap();
        let b = std::fs::read_to_string(d.path().join("grids/b.ill")).unwrap();
        let vals = |t: &str| -> Vec<f64> {
            t.split_whitespace()
                .skip(3)
                .map(|v| v.parse().unwrap())
                .collect()
        };
        assert_eq!(vals(&a), [20.0]);
        assert_eq!(vals(&b), [10.0, 30.0]);
    }
}
