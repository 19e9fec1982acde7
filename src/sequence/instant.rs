//! One instant: sky → sources → projections (LDI, VR refinement) → direct transfer →
//! sensors, with a discretisation-error estimate from one coarser level.

use super::config::{Quality, SkySpec};
use super::directions::{DirectionData, Directions};
use super::report::{Counts, Report, StageTimes, SunReport};
use crate::error::{Error, Result};
use crate::hierarchy::Hierarchy;
use crate::photometry::lux;
use crate::projection::{self, DirectionRecord, ProjectionScene};
use crate::radiosity::{Transport, TransportSensor, TransportState};
use crate::scene::Scene;
use crate::sensors::SensorDirect;
use crate::site::solar_position::{solar_position, SolarPosition};
use crate::sky::{self, Sky};
use crate::sources::{self, Source, SourceKey};
use crate::transfer::{self, DirectIrradiance};
use chrono::{DateTime, Datelike, NaiveDateTime, Utc};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Relative accuracy of the sky models' normalisation quadrature (`sky::integrate_horizontal`
/// against fine grids: about 1e-4); part of every stated error.
pub const SKY_NORMALISATION_REL: f64 = 2e-4;

/// Illuminance at one sensor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorValue {
    /// Total direct illuminance (sun + sky + ground glow), lux.
    pub lux: f64,
    /// Estimated absolute error of `lux`, lux.
    pub lux_err: f64,
    /// From the sun, lux.
    pub lux_sun: f64,
    /// From the sky and ground glow, lux.
    pub lux_sky: f64,
    /// Reflected by the scene's surfaces (and emitted by `Ke` surfaces), lux.
    pub lux_indirect: f64,
}

/// Everything one instant produces.
pub struct InstantResult {
    /// Per sensor, in .pts order.
    pub sensors: Vec<SensorValue>,
    /// The refined element hierarchy.
    pub hierarchy: Hierarchy,
    /// Direct irradiance per element.
    pub direct: DirectIrradiance,
    /// The global-line operator and its solution, when that solver ran.
    pub transport: Option<(Transport, TransportState)>,
    /// The sources used.
    pub sources: Vec<Source>,
    /// The report.
    pub report: Report,
}

/// Builds the sky of `spec` for the sun at `sun`.
///
/// # Errors
/// Bad sky parameters ([`Error::Input`]).
pub fn build_sky(
    spec: &SkySpec,
    sun: &SolarPosition,
    day_of_year: u32,
    ground: f64,
) -> Result<Sky> {
    let d = sun.direction();
    match *spec {
        SkySpec::Perez {
            dni,
            dhi,
            dew_point_c,
        } => sky::perez::sky(
            dni,
            dhi,
            d,
            day_of_year,
            dew_point_c.unwrap_or(sky::perez::DEFAULT_DEW_POINT_C),
            ground,
        ),
        SkySpec::CieOvercast { dhi } => sky::cie::sky(
            sky::cie::CieSkyType::TraditionalOvercast,
            dhi,
            0.0,
            d,
            ground,
        ),
        SkySpec::Cie { sky_type, dhi, dni } => {
            sky::cie::sky(sky::cie::CieSkyType::General(sky_type), dhi, dni, d, ground)
        }
        SkySpec::Preetham { turbidity } => sky::preetham::sky(turbidity, d, ground),
        SkySpec::None => Ok(Sky::none()),
    }
}

pub(crate) fn sources_for(sky: &Sky, q: &Quality) -> (Vec<Source>, usize, Option<f64>) {
    let s = sources::sky_sources(sky, &q.sky);
    let mut list = s.sources;
    let mut err = None;
    if let Some((sun, e)) = sources::sun_source(sky, q.sun_spacing_deg) {
        list.push(sun);
        err = Some(e);
    }
    (list, s.negligible, err)
}

/// One LDI projection and VR refinement per source, in parallel; records in source order.
pub fn project_sources(
    scene: &Scene,
    sources: &[Source],
    quality: &Quality,
) -> Vec<DirectionRecord> {
    if scene.triangles.is_empty() {
        return vec![DirectionRecord::default(); sources.len()];
    }
    let pscene = ProjectionScene::new(scene);
    sources
        .par_iter()
        .map(|s| {
            let res = quality.projection.resolution_for(s.is_sun());
            projection::project(&pscene, s.direction, res, &quality.projection)
        })
        .collect()
}

/// The sun and sky shoot alone (paper §4–5): sources, projections and direct transfer.
/// Returns the sources, the refined hierarchy and each element's direct irradiance — what
/// a time-step loop feeds to [`Transport::solve`] (after averaging onto its mesh).
pub fn direct_light(
    scene: &Scene,
    sky: &Sky,
    quality: &Quality,
) -> (Vec<Source>, Hierarchy, DirectIrradiance) {
    let (sources, _, _) = sources_for(sky, quality);
    let records = project_sources(scene, &sources, quality);
    let mut hierarchy = Hierarchy::new(scene);
    let refs: Vec<&DirectionRecord> = records.iter().collect();
    let direct = transfer::transfer(&mut hierarchy, &sources, &refs);
    (sources, hierarchy, direct)
}

/// Runs one instant on `scene` for the sky `sky` (already built for the instant), without
/// a disk cache.
pub fn run_sky(scene: &Scene, sky: &Sky, quality: &Quality, report: &mut Report) -> InstantResult {
    let store = crate::cache::Store::disabled();
    let tracer = crate::trace::Tracer::new(scene);
    let dirs = Directions::new(scene, quality, &store, &tracer);
    let coarse = Directions::new(scene, &quality.coarser(), &store, &tracer);
    run_sky_with(scene, sky, &dirs, &coarse, report)
}

/// Direct irradiance of every sensor from the sources' cached responses: sky and ground
/// nodes as Σ_children L_c ⊙ response_c, the sun as E_n ⊙ transmission × cos θ (true sun
/// direction), with the visibility uncertainty and the per-child-vs-node radiance
/// difference as error terms.
pub fn sensors_from_responses(
    dirs: &Directions,
    sources: &[Source],
    data: &[std::sync::Arc<DirectionData>],
) -> Vec<SensorDirect> {
    let scene = dirs.scene();
    (0..scene.sensors.len())
        .map(|k| {
            let n = scene.sensors[k].normal;
            let mut out = SensorDirect::default();
            for (s, d) in sources.iter().zip(data) {
                let r = &d.sensors[k];
                out.rays += d.rays / scene.sensors.len().max(1) as u64;
                if s.vertices.is_none() {
                    let cos = n.dot(s.true_direction);
                    if cos > 0.0 {
                        out.sun += s.normal_irradiance * dirs.sun_transmission(k, s, r) * cos;
                    }
                    continue;
                }
                for c in 0..4 {
                    let fine = s.child_radiance[c] * r.child[c];
                    out.sky += fine;
                    out.radiance_error += fine - s.radiance * r.child[c];
                    out.visibility_err_lux += lux(s.child_radiance[c]) * r.uncertainty[c];
                }
            }
            out
        })
        .collect()
}

/// [`run_sky`] through per-direction data `dirs` (the run's quality and cache) and
/// `coarse` (the same one level coarser, for the error estimate).
pub fn run_sky_with(
    scene: &Scene,
    sky: &Sky,
    dirs: &Directions,
    coarse_dirs: &Directions,
    report: &mut Report,
) -> InstantResult {
    let quality = dirs.quality();
    let mut times = std::mem::take(&mut report.stage_seconds);
    let (sources, negligible, snap_err) = times.time("sources", || sources_for(sky, quality));
    let mut counts = Counts {
        negligible_sources: negligible,
        elements_before: scene.triangles.len(),
        sensors: scene.sensors.len(),
        degenerate_triangles_dropped: scene.dropped_degenerate,
        ..Counts::default()
    };
    for s in &sources {
        match s.key {
            SourceKey::Sky(_) => counts.sky_sources += 1,
            SourceKey::Ground(_) => counts.ground_sources += 1,
            SourceKey::Sun(_) => counts.sun_sources += 1,
        }
    }
    if sources.is_empty() {
        report
            .skipped
            .push("all projections: the sky emits nothing at this instant".into());
    }
    if !scene.has_glazing() {
        report
            .skipped
            .push("glazing transmission: the scene has no glazing".into());
    }
    let (lo, hi) = scene.bounds();
    let diagonal = if scene.triangles.is_empty() {
        0.0
    } else {
        (hi - lo).length()
    };
    if let Some(e) = snap_err {
        report.sun.used = true;
        report.sun.snapping_error_deg = e;
        report.sun.max_shadow_shift_m = diagonal * e.to_radians();
    }

    let data = times.time("directions", || dirs.get_all(&sources));
    let records: Vec<&DirectionRecord> = data.iter().map(|d| &d.record).collect();
    if scene.triangles.is_empty() {
        report
            .skipped
            .push("projections: the scene has no geometry".into());
    }
    for (s, r) in sources.iter().zip(&records) {
        counts.ldi_pixels += r.stats.width as u64 * r.stats.height as u64;
        counts.ldi_fragments += r.stats.fragments;
        counts.splits += r.stats.elements_split;
        if r.stats.width as u64 * r.stats.height as u64
            > counts.ldi_max_size.0 as u64 * counts.ldi_max_size.1 as u64
        {
            counts.ldi_max_size = (r.stats.width, r.stats.height);
        }
        if s.is_sun() {
            let mut h = Hierarchy::new(scene);
            for l in &r.leaves {
                h.insert(l.key);
            }
            counts.elements_after_sun = h.leaf_count();
        }
    }
    let mut hierarchy = Hierarchy::new(scene);
    let direct = times.time("transfer", || {
        transfer::transfer(&mut hierarchy, &sources, &records)
    });
    counts.elements_after = hierarchy.leaf_count();

    // Interreflection, unless every surface is black and nothing emits.
    let needs_radiosity = scene.triangles.iter().any(|t| {
        let m = &scene.materials[t.material as usize];
        m.reflectance().max_element() > 0.0 || m.is_emitter()
    });
    let mut global = None;
    if needs_radiosity {
        let (t, cached) = times.time("transport_build", || {
            super::operator::transport(scene, &quality.transport, dirs.store(), dirs.tracer())
        });
        if cached {
            counts.operators_reused += 1;
        }
        let total: Vec<crate::photometry::Rgb> = direct
            .sun
            .iter()
            .zip(&direct.sky)
            .map(|(a, b)| *a + *b)
            .collect();
        let (st, rep) = times.time("transport_solve", || {
            t.solve(&t.mesh.average_onto(&hierarchy, &total), None)
        });
        report.transport = Some(t.stats);
        report.transport_solve = Some(rep);
        global = Some((t, st));
    } else {
        report
            .skipped
            .push("interreflection: every surface is black and nothing emits".into());
    }

    // Sensors, and the same gather one level coarser for the error estimate.
    let mut values = vec![SensorValue::default(); scene.sensors.len()];
    if scene.sensors.is_empty() {
        report
            .skipped
            .push("sensor gather: the scene has no sensors".into());
    } else {
        let fine: Vec<SensorDirect> =
            times.time("sensors", || sensors_from_responses(dirs, &sources, &data));
        let coarse: Vec<SensorDirect> = times.time("error_estimate", || {
            let (cs, _, _) = sources_for(sky, coarse_dirs.quality());
            let cdata = coarse_dirs.get_all(&cs);
            sensors_from_responses(coarse_dirs, &cs, &cdata)
        });
        let indirect: Vec<TransportSensor> = match &global {
            Some((t, st)) => times.time("indirect_gather", || t.sensors(st)),
            None => vec![TransportSensor::default(); scene.sensors.len()],
        };
        for (k, (f, c)) in fine.iter().zip(&coarse).enumerate() {
            counts.sensor_rays += f.rays + c.rays;
            let total = lux(f.sun + f.sky);
            let diff = (total - lux(c.sun + c.sky)).abs();
            let ind = &indirect[k];
            values[k] = SensorValue {
                lux: total + lux(ind.irradiance),
                // One coarser level bounds the error of a method converging at least
                // linearly; partly visible nodes add their visibility range.
                lux_err: diff
                    + lux(f.radiance_error).abs()
                    + f.visibility_err_lux
                    + SKY_NORMALISATION_REL * total.abs()
                    + lux(ind.std_err)
                    + (lux(ind.irradiance) - lux(ind.irradiance + ind.discretisation)).abs(),
                lux_sun: lux(f.sun),
                lux_sky: lux(f.sky),
                lux_indirect: lux(ind.irradiance),
            };
        }
    }
    report.error_model = "lux_err = |lux - lux at one coarser level| (sky subdivision depth and \
        thresholds, sun grid spacing x2, visibility depth -1) + |difference between per-child and \
        per-node sky radiance| + sum of the visibility \
        range of partly visible nodes at the deepest split + 2e-4 x lux (sky normalisation \
        quadrature) + the indirect part's 1-sigma noise (global lines: standard error of the mean \
        over independent line sets and sensor rays; local lines: gather and batch spread) + its \
        discretisation (global lines: |indirect - indirect on the mesh one level coarser|; local \
        lines: |indirect - indirect of an independent solve with a quarter of the lines per step|)"
        .into();
    report.max_lux_err = values.iter().map(|v| v.lux_err).fold(0.0, f64::max);
    report.max_relative_err = values
        .iter()
        .filter(|v| v.lux > 1.0)
        .map(|v| v.lux_err / v.lux)
        .fold(0.0, f64::max);
    report.warnings.extend(sky.warnings.iter().cloned());
    let dc = dirs.counts();
    counts.ldis_built = dc.built as usize;
    counts.ldis_reused = (dc.from_cache + dc.reused) as usize;
    report.counts = counts;
    report.stage_seconds = times;
    InstantResult {
        sensors: values,
        hierarchy,
        direct,
        transport: global,
        sources,
        report: std::mem::take(report),
    }
}

/// Runs one instant: `time` is local standard time of the scene's site (see
/// [`crate::site::parse_time`]).
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
    let store = crate::cache::Store::disabled();
    run_instant_cached(scene, instant_utc, local, spec, quality, &store)
}

/// [`run_instant`] with projections and sensor responses read from and written to `store`.
///
/// # Errors
/// Bad time or sky parameters ([`Error::Input`]).
pub fn run_instant_cached(
    scene: &Scene,
    instant_utc: DateTime<Utc>,
    local: NaiveDateTime,
    spec: &SkySpec,
    quality: &Quality,
    store: &crate::cache::Store,
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
    store: &crate::cache::Store,
) -> Result<(InstantResult, Sky)> {
    let t0 = Instant::now();
    let mut report = Report {
        version: env!("CARGO_PKG_VERSION").into(),
        command: "instant".into(),
        scene: scene.path.display().to_string(),
        time_local: local.format("%Y-%m-%dT%H:%M:%S").to_string(),
        time_utc: instant_utc.to_rfc3339(),
        quality: quality.name.into(),
        warnings: scene.warnings.clone(),
        ..Report::default()
    };
    let mut times = StageTimes::default();
    let sun = times.time("solar_position", || {
        solar_position(instant_utc, &scene.site)
    });
    report.sun = SunReport {
        altitude_deg: sun.altitude_deg(),
        azimuth_deg: sun.azimuth_deg,
        ..SunReport::default()
    };
    let sky = times.time("sky", || {
        build_sky(spec, &sun, local.ordinal(), scene.ground_reflectance)
    })?;
    if sky.sun.is_none() && !matches!(spec, SkySpec::CieOvercast { .. } | SkySpec::None) {
        report.skipped.push(format!(
            "sun: not a source (altitude {:.2}°, or zero direct irradiance)",
            sun.altitude_deg()
        ));
    }
    report.sky = sky.description.clone();
    report.stage_seconds = times;
    let tracer = crate::trace::Tracer::new(scene);
    let dirs = Directions::new(scene, quality, store, &tracer);
    let coarse = Directions::new(scene, &quality.coarser(), store, &tracer);
    let mut result = run_sky_with(scene, &sky, &dirs, &coarse, &mut report);
    result.report.cache = Some(store.stats());
    result.report.warnings.extend(store.warnings());
    result.report.total_seconds = t0.elapsed().as_secs_f64();
    Ok((result, sky))
}

/// Writes `sensors.csv` and `report.json` into `out` (atomically, each).
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written.
pub fn write_instant(scene: &Scene, result: &InstantResult, out: &Path) -> Result<()> {
    let mut csv = String::from("sensor,x,y,z,lux,lux_err,lux_sun,lux_sky,lux_indirect\n");
    for (k, (s, v)) in scene.sensors.iter().zip(&result.sensors).enumerate() {
        let p = s.input_position;
        csv.push_str(&format!(
            "{k},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            p.x, p.y, p.z, v.lux, v.lux_err, v.lux_sun, v.lux_sky, v.lux_indirect
        ));
    }
    crate::files::write_atomic(&out.join("sensors.csv"), csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&result.report)
        .map_err(|e| Error::Internal(format!("report serialisation: {e}")))?;
    crate::files::write_atomic(&out.join("report.json"), json.as_bytes())?;
    Ok(())
}
