//! One instant (`daystep instant`): a sequence of one [`Engine::step`], with its report and
//! outputs (`sensors.csv`, `report.json`).

use super::config::{Quality, SkySpec};
use super::report::Report;
use super::step::{Engine, EngineOptions, Step, StepTime};
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::radiosity::{Transport, TransportState};
use crate::scene::Scene;
use crate::sky::Sky;
use crate::sources::Source;
use crate::transfer::DirectIrradiance;
use chrono::{DateTime, NaiveDateTime, Utc};
use std::path::Path;
use std::time::Instant;

pub use super::estimate::{SensorValue, SKY_NORMALISATION_REL};
pub use super::sky::build_sky;

/// Everything one instant produces.
pub struct InstantResult {
    /// Per sensor, in .pts order.
    pub sensors: Vec<SensorValue>,
    /// The refined element hierarchy (empty with [`EngineOptions::count_elements_only`]).
    pub hierarchy: Hierarchy,
    /// Direct irradiance per element (empty with [`EngineOptions::count_elements_only`]).
    pub direct: DirectIrradiance,
    /// The global-line operator and its solution, when the scene needed interreflection.
    pub transport: Option<(Transport, TransportState)>,
    /// The sources used.
    pub sources: Vec<Source>,
    /// The report.
    pub report: Report,
    /// Per mesh row, the direct irradiance the solve started from (RGB W/m²), when the
    /// run asked for the mesh solution ([`EngineOptions::mesh_solution`]; else empty).
    pub mesh_direct: Vec<crate::photometry::Rgb>,
}

impl InstantResult {
    fn of(engine: Engine, step: Step) -> InstantResult {
        // None when the engine only counted them (`count_elements_only`).
        let (hierarchy, direct) = step.elements.unwrap_or_default();
        InstantResult {
            sensors: step.sensors,
            hierarchy,
            direct,
            transport: engine.into_operator().zip(step.state),
            sources: step.sources,
            report: step.report,
            mesh_direct: step.mesh_direct,
        }
    }
}

/// Runs one instant on `scene` for the sky `sky` (already built for the instant: stages 2–7
/// of the step), without a disk cache. `report` carries what the caller knows (sun, sky).
pub fn run_sky(scene: &Scene, sky: &Sky, quality: &Quality, report: &mut Report) -> InstantResult {
    run_sky_cached(
        scene,
        sky,
        quality,
        &Store::disabled(),
        &EngineOptions::default(),
        report,
    )
}

/// [`run_sky`] through the cache `store` with the engine's options (an image sky, or any
/// sky built by the caller).
pub fn run_sky_cached(
    scene: &Scene,
    sky: &Sky,
    quality: &Quality,
    store: &Store,
    opts: &EngineOptions,
    report: &mut Report,
) -> InstantResult {
    let engine = Engine::new(scene, quality, store, opts);
    let mut r = std::mem::take(report);
    r.warnings.extend(engine.directions().store().warnings());
    let step = engine.step_sky(sky, None, true, r, None);
    InstantResult::of(engine, step)
}

/// Runs one instant: `local` is local standard time of the scene's site and `instant_utc`
/// the same instant in UTC (see [`crate::site::parse_time`]).
///
/// # Errors
/// Bad time or sky parameters ([`Error::Input`]).
pub fn run_instant(
    scene: &Scene,
    instant_utc: DateTime<Utc>,
    local: NaiveDateTime,
    spec: &SkySpec,
    quality: &Quality,
) -> Result<InstantResult> {
    run_instant_cached(scene, instant_utc, local, spec, quality, &Store::disabled())
}

/// [`run_instant`] with projections, sensor responses and the operator read from and
/// written to `store`.
///
/// # Errors
/// Bad time or sky parameters ([`Error::Input`]).
pub fn run_instant_cached(
    scene: &Scene,
    instant_utc: DateTime<Utc>,
    local: NaiveDateTime,
    spec: &SkySpec,
    quality: &Quality,
    store: &Store,
) -> Result<InstantResult> {
    run_instant_with_sky(scene, instant_utc, local, spec, quality, store).map(|(r, _)| r)
}

/// [`run_instant_cached`], returning also the sky it built for the instant (for quantities
/// of the sky itself, such as its unobstructed horizontal illuminance).
///
/// # Errors
/// Bad time or sky parameters ([`Error::Input`]).
pub fn run_instant_with_sky(
    scene: &Scene,
    instant_utc: DateTime<Utc>,
    local: NaiveDateTime,
    spec: &SkySpec,
    quality: &Quality,
    store: &Store,
) -> Result<(InstantResult, Sky)> {
    run_instant_with(
        scene,
        instant_utc,
        local,
        spec,
        quality,
        store,
        &EngineOptions::default(),
    )
}

/// [`run_instant_with_sky`] with the engine's options (`mesh_solution` for a glTF of the
/// solution).
///
/// # Errors
/// Bad time or sky parameters ([`Error::Input`]).
pub fn run_instant_with(
    scene: &Scene,
    instant_utc: DateTime<Utc>,
    local: NaiveDateTime,
    spec: &SkySpec,
    quality: &Quality,
    store: &Store,
    opts: &EngineOptions,
) -> Result<(InstantResult, Sky)> {
    let t0 = Instant::now();
    let engine = Engine::new(scene, quality, store, opts);
    let at = StepTime {
        utc: instant_utc,
        local,
    };
    let mut step = engine.step(&at, spec, None, true)?;
    let sky = step.sky.take().expect("a step builds its sky");
    let mut report = std::mem::take(&mut step.report);
    report.stage_seconds.merge(engine.setup_times());
    report = Report {
        version: env!("CARGO_PKG_VERSION").into(),
        command: "instant".into(),
        scene: scene.path.display().to_string(),
        time_local: local.format("%Y-%m-%dT%H:%M:%S").to_string(),
        time_utc: instant_utc.to_rfc3339(),
        quality: quality.name.into(),
        warnings: scene
            .warnings
            .iter()
            .chain(&report.warnings)
            .cloned()
            .collect(),
        ..report
    };
    report.cache = Some(store.stats());
    report.warnings.extend(store.warnings());
    report.model = super::report::ModelReport::of(scene);
    report.total_seconds = t0.elapsed().as_secs_f64();
    step.report = report;
    Ok((InstantResult::of(engine, step), sky))
}

/// Writes the instant's solution mesh to `path` as glTF binary (one frame, labelled
/// `label`); a black scene has no mesh and writes nothing (returns false).
///
/// # Errors
/// [`Error::Io`] naming the file.
pub fn write_instant_gltf(
    scene: &Scene,
    result: &InstantResult,
    label: &str,
    path: &Path,
) -> Result<bool> {
    let Some((op, state)) = &result.transport else {
        return Ok(false);
    };
    let lux = result.sensors.iter().map(|v| v.lux).collect();
    let frame =
        crate::export::gltf::frame_of(op, state, &result.mesh_direct, label.to_string(), lux);
    let sensors: Vec<_> = scene.sensors.iter().map(|s| s.position).collect();
    crate::export::gltf::geometry_of(scene, op).write(path, &[frame], &sensors)?;
    Ok(true)
}

/// Writes `sensors.csv` and `report.json` into `out` (atomically, each).
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written.
pub fn write_instant(scene: &Scene, result: &InstantResult, out: &Path) -> Result<()> {
    // With sensor grids, a last column names each sensor's grid.
    let spans = crate::export::grids::spans_of(scene);
    let grid =
        (!spans.is_empty()).then(|| crate::export::grids::grid_column(&spans, scene.sensors.len()));
    let mut csv = String::from("sensor,x,y,z,lux,lux_err,lux_sun,lux_sky,lux_indirect");
    csv.push_str(if grid.is_some() { ",grid\n" } else { "\n" });
    for (k, (s, v)) in scene.sensors.iter().zip(&result.sensors).enumerate() {
        let p = s.input_position;
        csv.push_str(&format!(
            "{k},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6}",
            p.x, p.y, p.z, v.lux, v.lux_err, v.lux_sun, v.lux_sky, v.lux_indirect
        ));
        if let Some(g) = &grid {
            csv.push(',');
            csv.push_str(g[k].unwrap_or(""));
        }
        csv.push('\n');
    }
    crate::files::write_atomic(&out.join("sensors.csv"), csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&result.report)
        .map_err(|e| Error::Internal(format!("report serialisation: {e}")))?;
    crate::files::write_atomic(&out.join("report.json"), json.as_bytes())?;
    Ok(())
}
