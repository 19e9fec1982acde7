//! Named sensor grids (HBJSON `sensor_grids`): which of a scene's sensors belong to which
//! grid and room, and the selection of grids a run is asked for (`--grids`).

use super::imported::Imported;
use super::Scene;
use crate::error::{Error, Result};

/// A named sensor grid of the model.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorGrid {
    /// The grid's identifier, as in the model.
    pub identifier: String,
    /// The room it belongs to, where the model says.
    pub room: Option<String>,
    /// Its sensors: an index range into [`Scene::sensors`].
    pub sensors: std::ops::Range<usize>,
}

/// The grids whose sensors a reader gave as the scene's sensors
/// ([`Imported::sensor_grid`]): each run of sensors of one grid, in order.
pub fn from_imported(imported: &Imported) -> Vec<SensorGrid> {
    let mut grids: Vec<SensorGrid> = Vec::new();
    for (i, &g) in imported.sensor_grid.iter().enumerate() {
        let info = &imported.grids[g as usize];
        match grids.last_mut() {
            Some(last) if last.identifier == info.identifier && last.sensors.end == i => {
                last.sensors.end = i + 1;
            }
            _ => grids.push(SensorGrid {
                identifier: info.identifier.clone(),
                room: info.room.clone(),
                sensors: i..i + 1,
            }),
        }
    }
    grids
}

/// Keeps only the sensors of the grids whose identifiers match one of `patterns`
/// (comma-separated identifiers or globs with `*`, `?` and `[…]`), in model order.
///
/// # Errors
/// [`Error::Input`] (named `--grids`) for a bad glob, for a scene without grids, or when a
/// pattern matches no grid (the message lists the grids there are).
pub fn select_grids(scene: &mut Scene, patterns: &str) -> Result<()> {
    let arg = |value: &str, message: String| Error::arg("--grids", value, message);
    if scene.grids.is_empty() {
        return Err(arg(
            patterns,
            "the scene has no sensor grids (only an HBJSON model brings them)".into(),
        ));
    }
    let mut keep = vec![false; scene.grids.len()];
    for p in patterns.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let pat = glob::Pattern::new(p).map_err(|e| arg(p, format!("not a glob: {e}")))?;
        let mut any = false;
        for (k, g) in scene.grids.iter().enumerate() {
            if pat.matches(&g.identifier) {
                keep[k] = true;
                any = true;
            }
        }
        if !any {
            let names: Vec<&str> = scene.grids.iter().map(|g| g.identifier.as_str()).collect();
            return Err(arg(
                p,
                format!(
                    "matches no sensor grid; the grids are: {}",
                    names.join(", ")
                ),
            ));
        }
    }
    let mut sensors = Vec::new();
    let mut grids = Vec::new();
    for (g, _) in scene.grids.iter().zip(&keep).filter(|(_, k)| **k) {
        let start = sensors.len();
        sensors.extend_from_slice(&scene.sensors[g.sensors.clone()]);
        grids.push(SensorGrid {
            sensors: start..sensors.len(),
            ..g.clone()
        });
    }
    scene.sensors = sensors;
    scene.grids = grids;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn office() -> Scene {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/scene.toml");
        Scene::load(&p).unwrap()
    }

    /// The sample office with its sensors split into three grids of 2, 3 and the rest.
    fn office_with_grids() -> Scene {
        let mut s = office();
        let n = s.sensors.len();
        let grid = |id: &str, room: &str, r: std::ops::Range<usize>| SensorGrid {
            identifier: id.into(),
            room: Some(room.into()),
            sensors: r,
        };
        s.grids = vec![
            grid("West_Grid", "West", 0..2),
            grid("East_Grid", "East", 2..5),
            grid("Core", "Core", 5..n),
        ];
        s
    }

    #[test]
    fn a_glob_keeps_the_matching_grids_in_model_order() {
        let full = office_with_grids();
        let mut s = full.clone();
        select_grids(&mut s, "Core, *_Grid").unwrap();
        // Model order (West, East, Core), not the order of the patterns.
        let ids: Vec<&str> = s.grids.iter().map(|g| g.identifier.as_str()).collect();
        assert_eq!(ids, ["West_Grid", "East_Grid", "Core"]);
        assert_eq!(s.sensors, full.sensors);
        let mut s = full.clone();
        select_grids(&mut s, "East_Grid").unwrap();
        assert_eq!(s.sensors, full.sensors[2..5]);
        assert_eq!(s.grids.len(), 1);
        assert_eq!(s.grids[0].sensors, 0..3);
    }

    #[test]
    fn patterns_that_match_nothing_or_no_grids_are_errors() {
        let mut s = office_with_grids();
        let e = select_grids(&mut s, "Nope*").unwrap_err().to_string();
        assert!(
            e.contains("--grids") && e.contains("West_Grid, East_Grid, Core"),
            "{e}"
        );
        let e = select_grids(&mut s, "[").unwrap_err().to_string();
        assert!(e.contains("not a glob"), "{e}");
        let mut plain = office();
        let e = select_grids(&mut plain, "*").unwrap_err().to_string();
        assert!(e.contains("no sensor grids"), "{e}");
    }
}
