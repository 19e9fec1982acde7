//! The frames of a render run: their plan (times and skies, night and missing records
//! left out), the rows of `frames.csv`, and the fingerprint of a frame's inputs by which a
//! rerun of the same folder resumes only the frames that nothing changed.

use super::config::{Quality, SkySpec};
use super::render::{Camera, RenderOutputs};
use super::step::StepTime;
use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sky::Sky;
use crate::weather::Weather;
use chrono::NaiveDate;
use serde::Serialize;
use std::path::Path;

/// One frame to render: when, under which sky, and its name.
#[derive(Clone)]
pub struct FramePlan {
    /// The instant.
    pub at: StepTime,
    /// The sky's parameters (unused when `sky` is given).
    pub spec: SkySpec,
    /// A sky built by the caller (an image sky), used instead of `spec`.
    pub sky: Option<std::sync::Arc<Sky>>,
    /// What determines `sky` when it is given (e.g. the image file's content hash, its
    /// mapping and rotation): part of the frame's resume fingerprint.
    pub sky_inputs: String,
    /// Local standard time, `YYYY-MM-DDTHH:MM` (labels, frames.csv).
    pub label: String,
    /// File stem, by local time: `YYYYMMDD_HHMM`.
    pub name: String,
}

impl std::fmt::Debug for FramePlan {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FramePlan")
            .field("label", &self.label)
            .field("spec", &self.spec)
            .field("sky", &self.sky.as_ref().map(|s| s.description.clone()))
            .finish()
    }
}

impl FramePlan {
    /// The frame at `at` under `spec`, named by its local time.
    pub fn new(at: StepTime, spec: SkySpec) -> FramePlan {
        FramePlan {
            label: at.local.format("%Y-%m-%dT%H:%M").to_string(),
            name: at.local.format("%Y%m%d_%H%M").to_string(),
            at,
            spec,
            sky: None,
            sky_inputs: String::new(),
        }
    }
}

/// The frames of a weather file between two dates (inclusive, `None`: open), with what
/// was left out: (frames, night steps skipped, missing records skipped). Night is a step
/// with no diffuse light and no sun above the horizon, as in annual runs.
pub fn plan_weather(
    scene: &Scene,
    weather: &Weather,
    start: Option<NaiveDate>,
    end: Option<NaiveDate>,
) -> (Vec<FramePlan>, usize, usize) {
    let (mut frames, mut night, mut missing) = (Vec::new(), 0, 0);
    for r in &weather.records {
        let d = r.time.date();
        if start.is_some_and(|s| d < s) || end.is_some_and(|e| d > e) {
            continue;
        }
        if r.missing {
            missing += 1;
            continue;
        }
        let utc = r.utc(&scene.site);
        let sun = solar_position(utc, &scene.site);
        if super::annual::is_night(r, sun.altitude_deg()) {
            night += 1;
            continue;
        }
        let spec = super::annual::perez(r);
        frames.push(FramePlan::new(StepTime { utc, local: r.time }, spec));
    }
    (frames, night, missing)
}

/// One written frame, as `frames.csv` lists it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameRow {
    /// File stem.
    pub name: String,
    /// Local standard time.
    pub time_local: String,
    /// UTC, RFC 3339.
    pub time_utc: String,
    /// Sky description.
    pub sky: String,
    /// Mean photometric value over valid pixels (cd/m² or lux).
    pub mean: f64,
    /// Mean stated error over valid pixels, same unit.
    pub mean_err: f64,
    /// Daylight glare probability (angular fisheye renders with glare asked), else NaN.
    pub dgp: f64,
    /// Vertical eye illuminance of the glare evaluation, lux (else NaN).
    pub ev_lux: f64,
    /// Wall time of the frame (step + gather + files), s.
    pub seconds: f64,
    /// Fingerprint of everything that determined the frame's files
    /// ([`frame_fingerprint`]): a rerun resumes the frame only when it is unchanged.
    pub inputs: String,
}

const FRAMES_HEADER: &str = "frame,time_local,time_utc,sky,mean,mean_err,dgp,ev_lux,inputs,seconds";

/// The header of `frames.csv` before frames carried their inputs' fingerprint: such rows
/// are never resumed, since what made them is unknown.
const FRAMES_HEADER_V1: &str = "frame,time_local,time_utc,sky,mean,mean_err,dgp,ev_lux,seconds";

impl FrameRow {
    pub(super) fn csv(&self) -> String {
        format!(
            "{},{},{},\"{}\",{:.6},{:.6},{:.4},{:.3},{},{:.3}",
            self.name,
            self.time_local,
            self.time_utc,
            self.sky.replace('"', "'"),
            self.mean,
            self.mean_err,
            self.dgp,
            self.ev_lux,
            self.inputs,
            self.seconds
        )
    }
}

/// A frame a previous run of the folder finished, as `frames.csv` lists it.
pub(super) struct Finished {
    /// File stem.
    pub(super) name: String,
    /// Its inputs' fingerprint (empty for rows written before fingerprints).
    pub(super) inputs: String,
    /// The whole row.
    pub(super) line: String,
}

/// Reads the frames a previous run of the same folder finished (`frames.csv`), by name.
pub(super) fn finished_frames(out: &Path) -> Result<Vec<Finished>> {
    let path = out.join("frames.csv");
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text = crate::files::read_text(&path)?;
    let mut lines = text.lines();
    let fingerprinted = match lines.next() {
        Some(FRAMES_HEADER) => true,
        Some(FRAMES_HEADER_V1) => false,
        _ => {
            return Err(Error::input(
                &path,
                Some(1),
                None,
                "not a daystep frames.csv (header differs): use another --out folder",
            ))
        }
    };
    Ok(lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| Finished {
            name: l.split(',').next().unwrap_or("").to_string(),
            // The fingerprint is the last field but one; the quoted sky column before it may
            // hold commas, so count from the right.
            inputs: if fingerprinted {
                l.rsplit(',').nth(1).unwrap_or("").to_string()
            } else {
                String::new()
            },
            line: l.to_string(),
        })
        .collect())
}

/// Version of [`frame_fingerprint`]: bump when what a frame's files depend on changes.
const FRAME_INPUTS_VERSION: u32 = 1;

/// Fingerprint (32 hex digits of BLAKE3) of everything that determines one frame's files:
/// the scene's content (geometry, materials, sensors, faces, site, ground, frame), the
/// view and render options, quality and seed, the frame's time and sky (or the inputs of
/// a caller's sky), and the outputs asked for (PNG exposure, falsecolor, HDR, glare).
/// The command line is left out: it is provenance only, and a rerun with another
/// `--threads` or `--cache` must still resume.
pub fn frame_fingerprint(
    scene: &Scene,
    quality: &Quality,
    camera: &Camera,
    outputs: &RenderOutputs,
    plan: &FramePlan,
) -> String {
    let mut h = blake3::Hasher::new();
    h.update(b"daystep render frame\0");
    h.update(&FRAME_INPUTS_VERSION.to_le_bytes());
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(&crate::cache::scene_hash(scene, &Default::default(), b"render frame").0);
    // Debug output prints every f64 exactly (shortest round-trip), so equal text means
    // equal values.
    let text = format!(
        "{:?}|{:?}|{:?}|{}|{:?}|{:?}|{}|{}|{:?}|{:?}|{:?}|{:?}|{}|{:?}|{}|{}",
        scene.materials,
        scene.faces,
        scene.site,
        scene.ground_reflectance,
        scene.origin,
        scene.north_deg,
        scene.y_up,
        scene.input_triangles,
        quality,
        camera.view,
        camera.options,
        plan.spec,
        plan.at.utc.to_rfc3339(),
        (outputs.png, &outputs.falsecolor, outputs.glare),
        outputs.hdr,
        plan.sky_inputs,
    );
    h.update(&(text.len() as u64).to_le_bytes());
    h.update(text.as_bytes());
    h.update(&[u8::from(plan.sky.is_some())]);
    let hex = h.finalize().to_hex();
    hex.as_str()[..32].to_string()
}

/// `frames.csv`, rows in plan order (finished frames only).
pub(super) fn write_frames_csv(
    out: &Path,
    frames: &[FramePlan],
    rows: &[(String, String)],
) -> Result<()> {
    let mut text = String::from(FRAMES_HEADER);
    text.push('\n');
    for f in frames {
        if let Some((_, line)) = rows.iter().find(|(n, _)| *n == f.name) {
            text.push_str(line);
            text.push('\n');
        }
    }
    crate::files::write_atomic(&out.join("frames.csv"), text.as_bytes())
}
