//! `daystep merge`: the shards of `annual --shard k/n` assembled into one run's files.

use super::args::MergeArgs;
use super::config;
use super::messages::note;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Runs `daystep merge` into `--out`.
///
/// # Errors
/// Shards that do not belong together or cannot be read ([`crate::Error::Input`]),
/// unwritable output.
pub fn run(a: MergeArgs) -> Result<()> {
    let params = config::metric_params(&a.metrics)?;
    super::check_outputs(&a.out, None)?;
    let per = crate::sequence::annual::merge(&a.parts, &a.out, a.step, &params)?;
    match report_scene(&a)? {
        Some(scene) if scene.sensors.len() == per.len() => {
            // The title one run gives, so that the page is the one run's page.
            let title = match shard_report(&a.parts[0]) {
                Some((s, Some(w))) => format!("daystep annual: {s}, {w}"),
                _ => format!(
                    "daystep merge: {}, {} shards",
                    scene.path.display(),
                    a.parts.len()
                ),
            };
            crate::sequence::annual::write_report_page(&a.out, &scene, &per, &params, title)?;
        }
        Some(scene) => note!(
            "report.html not written: {} has {} sensors, the runs {}",
            scene.path.display(),
            scene.sensors.len(),
            per.len()
        ),
        None => note!("report.html not written: give the runs' scene with --scene"),
    }
    note!(
        "daystep merge: {} shards → {}",
        a.parts.len(),
        a.out.display()
    );
    Ok(())
}

/// The scene of the runs: `--scene`, else the one the first shard's `report.json` names
/// when that file exists; narrowed to the grids of the merged `grids.json` (the runs'
/// `--grids`).
fn report_scene(a: &MergeArgs) -> Result<Option<crate::scene::Scene>> {
    let path = match &a.scene {
        Some(p) => p.clone(),
        None => match shard_report(&a.parts[0]).map(|r| PathBuf::from(r.0)) {
            Some(p) if p.exists() => p,
            _ => return Ok(None),
        },
    };
    let mut scene = crate::scene::Scene::load(&path)?;
    let grids_file = a.out.join(crate::export::grids::GRIDS_JSON);
    if grids_file.exists() && !scene.grids.is_empty() {
        let doc: serde_json::Value =
            serde_json::from_str(&crate::files::read_text(&grids_file)?)
                .map_err(|e| Error::input(&grids_file, Some(e.line()), None, e.to_string()))?;
        let ids: Vec<&str> = doc["grids"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|g| g["identifier"].as_str())
            .collect();
        // Identifiers are letters, digits, '_', '-', '.': no glob characters.
        crate::scene::grids::select_grids(&mut scene, &ids.join(","))?;
    }
    Ok(Some(scene))
}

/// The `scene` and `weather` a shard folder's `report.json` names.
fn shard_report(dir: &Path) -> Option<(String, Option<String>)> {
    let text = std::fs::read_to_string(dir.join("report.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    let s = v.get("scene")?.as_str()?.to_owned();
    Some((
        s,
        v.get("weather").and_then(|w| w.as_str()).map(str::to_owned),
    ))
}
