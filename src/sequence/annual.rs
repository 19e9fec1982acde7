//! A time series over a weather file (`daystep annual`): per timestep the Perez sky of the
//! record, the sources, their cached projections and sensor responses, the direct
//! irradiance of the mesh, a warm-started global-line interreflection solve, and the
//! sensors. Night and missing-weather steps are skipped (written as zeros and counted).
//!
//! * **Chains of days.** Each day is one warm-started chain (its first step starts cold),
//!   so a day's results do not depend on which other days a run computes: shards, resumed
//!   runs and a single run give the same bytes. Days run in parallel in batches; each
//!   batch is appended in time order and checkpointed, so an interrupted run loses at most
//!   the batch in flight, and a rerun with the same `--out` continues after the last
//!   complete day.
//! * **Sharding.** `--shard k/n` computes the days d with d mod n = k − 1 (d counted from
//!   the first day of the run); `daystep merge` interleaves the shards' rows and computes
//!   the metrics.
//! * **Outputs.** `illuminance.csv` (total: direct + interreflected), `direct_sun.csv`
//!   (sun only, no interreflection: what ASE counts), `metrics.csv` and `summary.json`
//!   (unsharded runs and merges), `report.json`.

use super::config::{Quality, SkySpec};
use super::directions::Directions;
use super::instant::{build_sky, sensors_from_responses, sources_for, SKY_NORMALISATION_REL};
use super::surfaces::SurfaceMap;
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::export::{self, IlluminanceWriter};
use crate::hierarchy::Hierarchy;
use crate::metrics::{self, MetricParams};
use crate::photometry::{lux, Rgb};
use crate::radiosity::{DirectionResponse, SensorResponse, Transport, TransportState};
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sources::{Source, SourceKey};
use crate::weather::{Weather, WeatherRecord};
use chrono::{Datelike, NaiveDate, NaiveDateTime};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Days computed in parallel between checkpoints.
const DAYS_PER_BATCH: usize = 8;

/// Suggested memory for adjoint sensor responses when a caller opts in
/// ([`AnnualOptions::response_max_bytes`]); the default is 0, forward solves.
///
/// Why forward is the default: on the sample office (7 848 rows, 165 sensors) a week took
/// 23.3 s with adjoint responses against 7.9 s forward, both from a warm cache — each of
/// the ~1 400 distinct directions of the week costs a pass over rows × 3 × sensors × 8
/// response values (28 ms, memory-bound), more than the warm-started solves it replaces
/// (≈ 16 ms per step). The adjoint pays off only when few directions serve many steps.
pub const RESPONSE_MAX_BYTES: u64 = 512 << 20;

/// What an annual run is asked to do besides the defaults.
#[derive(Clone, Debug)]
pub struct AnnualOptions {
    /// First day included (local date), if not the file's first.
    pub start: Option<NaiveDate>,
    /// Last day included, if not the file's last.
    pub end: Option<NaiveDate>,
    /// Shard k of n (1-based k); (1, 1) for a whole run.
    pub shard: (u32, u32),
    /// Annual metric thresholds.
    pub metrics: MetricParams,
    /// Also write a Radiance/DAYSIM-style `illuminance.ill`.
    pub ill: bool,
    /// Memory allowed for adjoint sensor responses (daylight coefficients), bytes; 0 (the
    /// default, see [`RESPONSE_MAX_BYTES`] for why) makes every step a warm-started forward
    /// solve.
    pub response_max_bytes: u64,
    /// Also write `surfaces.csv` (per group: incident irradiance, transmitted solar power).
    pub surfaces: bool,
}

impl Default for AnnualOptions {
    fn default() -> Self {
        AnnualOptions {
            start: None,
            end: None,
            shard: (1, 1),
            metrics: MetricParams::default(),
            ill: false,
            response_max_bytes: 0,
            surfaces: false,
        }
    }
}

/// Counters and timings of an annual run (`report.json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct AnnualReport {
    /// daystep version.
    pub version: String,
    /// Scene file.
    pub scene: String,
    /// Weather file.
    pub weather: String,
    /// Quality preset.
    pub quality: String,
    /// Shard "k/n".
    pub shard: String,
    /// Timesteps in the run (this shard).
    pub steps: usize,
    /// Steps computed now (not resumed from an earlier run).
    pub computed: usize,
    /// Steps taken from the output of an interrupted earlier run.
    pub resumed: usize,
    /// Steps skipped because the sun was down and the sky dark.
    pub night: usize,
    /// Steps skipped because the weather record had missing irradiance.
    pub missing: usize,
    /// Steps with the sun above the horizon and direct-normal irradiance > 0.
    pub sun_steps: usize,
    /// Distinct directions: computed, read from the cache, reused in memory.
    pub directions: super::directions::DirectionCounts,
    /// Projection cache counters.
    pub cache: crate::cache::CacheStats,
    /// Whether the interreflection operator came from the cache.
    pub operator_from_cache: bool,
    /// How each step's interreflection was computed: "adjoint" (per-sensor responses,
    /// solved once, and per-direction daylight coefficients), "forward" (a warm-started
    /// solve per step, for scenes whose responses exceed [`RESPONSE_MAX_BYTES`]) or "none".
    pub interreflection: String,
    /// Gauss–Seidel sweeps over all steps, and of the cold first steps of the days.
    pub sweeps: u64,
    /// Wall time per stage, s (summed over threads where stages run in parallel).
    pub stage_seconds: Vec<(String, f64)>,
    /// Wall time, s.
    pub total_seconds: f64,
    /// Median over lit sensor-steps (> 10 lx) of the stated relative error.
    pub median_relative_err: f64,
    /// 95th percentile of the same.
    pub p95_relative_err: f64,
    /// What was left out and why.
    pub skipped: Vec<String>,
    /// Warnings.
    pub warnings: Vec<String>,
    /// Whether the run was stopped before its end (Ctrl-C); rerun to continue.
    pub interrupted: bool,
}

/// One planned timestep.
struct Step<'w> {
    record: &'w WeatherRecord,
    time: NaiveDateTime,
}

/// The result of one step: total and sun-only illuminance per sensor, lux.
#[derive(Clone, Default)]
struct StepOut {
    total: Vec<f64>,
    sun: Vec<f64>,
    surfaces: Vec<f64>,
    rel_err: Vec<f32>,
    sweeps: u32,
}

/// Per-direction mesh irradiance weights: row → weight (RGB); memoised per run.
type MeshWeights = Arc<Vec<(u32, Rgb)>>;

/// Memo of per-direction values, keyed by direction and LDI resolution.
type Memo<T> = Mutex<HashMap<(SourceKey, u32), T>>;

/// How a caller steers a long run: `stop` is polled between batches of days (set it from
/// a Ctrl-C handler); `progress(done, total)` is called after each batch.
pub struct RunControl<'a> {
    /// Set to stop after the batch in flight.
    pub stop: &'a AtomicBool,
    /// Called with (steps done, steps in the run).
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
}

/// Runs the time series of `weather` on `scene` into `out`.
///
/// # Errors
/// Bad weather values at a step ([`Error::Input`] naming the weather file and line), or
/// files that cannot be written.
pub fn run_annual(
    scene: &Scene,
    weather: &Weather,
    quality: &Quality,
    store: &Store,
    out: &Path,
    opts: &AnnualOptions,
    control: &RunControl,
) -> Result<AnnualReport> {
    let (stop, progress) = (control.stop, control.progress);
    let t0 = Instant::now();
    let (k, n) = opts.shard;
    let mut report = AnnualReport {
        version: env!("CARGO_PKG_VERSION").into(),
        scene: scene.path.display().to_string(),
        weather: weather.path.display().to_string(),
        quality: quality.name.into(),
        shard: format!("{k}/{n}"),
        warnings: weather.warnings.clone(),
        ..AnnualReport::default()
    };
    // Plan: records in the date range, grouped by day; this shard's days.
    let mut days: Vec<Vec<Step>> = Vec::new();
    let mut day_index = 0usize;
    let mut last: Option<NaiveDate> = None;
    for r in &weather.records {
        let d = r.time.date();
        if opts.start.is_some_and(|s| d < s) || opts.end.is_some_and(|e| d > e) {
            continue;
        }
        if last != Some(d) {
            if last.is_some() {
                day_index += 1;
            }
            last = Some(d);
            if day_index % n as usize == (k - 1) as usize {
                days.push(Vec::new());
            }
        }
        if day_index % n as usize == (k - 1) as usize {
            days.last_mut().expect("pushed above").push(Step {
                record: r,
                time: r.time,
            });
        }
    }
    let total_steps: usize = days.iter().map(|d| d.len()).sum();
    report.steps = total_steps;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let sensors = scene.sensors.len();
    let (mut w_total, done_times) =
        IlluminanceWriter::resume(&out.join("illuminance.csv"), sensors)?;
    let (mut w_sun, done_sun) = IlluminanceWriter::resume(&out.join("direct_sun.csv"), sensors)?;
    // The interreflection operator (geometry only, cached) is needed before resuming when
    // surfaces are asked for: its mesh defines their columns.
    let tracer = crate::trace::Tracer::new(scene);
    let dirs = Directions::new(scene, quality, store, &tracer);
    let needs_radiosity = scene.triangles.iter().any(|t| {
        let m = &scene.materials[t.material as usize];
        m.reflectance().max_element() > 0.0 || m.is_emitter()
    });
    let mut stage = Stages::default();
    let ts = Instant::now();
    let operator = if (needs_radiosity && !scene.sensors.is_empty()) || opts.surfaces {
        let (t, cached) = super::operator::transport(scene, &quality.transport, store, &tracer);
        report.operator_from_cache = cached;
        Some(t)
    } else {
        report.skipped.push(
            "interreflection: every surface is black and nothing emits, or no sensors".into(),
        );
        None
    };
    stage.add("operator", ts.elapsed().as_secs_f64());
    let surface_map = match (&operator, opts.surfaces) {
        (Some(op), true) => Some(SurfaceMap::new(scene, op)),
        _ => None,
    };
    let surfaces_path = out.join("surfaces.csv");
    let (mut w_surf, done_surf) = match &surface_map {
        Some(m) => {
            let (w, t) =
                IlluminanceWriter::resume_with_header(&surfaces_path, m.header(), m.columns())?;
            (Some(w), Some(t))
        }
        None => (None, None),
    };
    // Resume only whole days present in both files, in plan order.
    let mut resumed_days = 0;
    {
        let mut i = 0;
        for day in &days {
            let ok = day.iter().enumerate().all(|(j, s)| {
                let t = export::format_time(s.time);
                done_times.get(i + j) == Some(&t)
                    && done_sun.get(i + j) == Some(&t)
                    && done_surf.as_ref().is_none_or(|d| d.get(i + j) == Some(&t))
            });
            if !ok {
                break;
            }
            i += day.len();
            resumed_days += 1;
        }
        if i != done_times.len()
            || i != done_sun.len()
            || done_surf.as_ref().is_some_and(|d| d.len() != i)
        {
            // A cut batch: rewrite the kept prefix.
            let (_, tv) = export::read_illuminance_csv(&IlluminanceWriter::partial_path(
                &out.join("illuminance.csv"),
            ))?;
            let (_, sv) = export::read_illuminance_csv(&IlluminanceWriter::partial_path(
                &out.join("direct_sun.csv"),
            ))?;
            w_total = IlluminanceWriter::create(&out.join("illuminance.csv"), sensors)?;
            w_sun = IlluminanceWriter::create(&out.join("direct_sun.csv"), sensors)?;
            let times: Vec<NaiveDateTime> = days.iter().flatten().take(i).map(|s| s.time).collect();
            for (j, t) in times.iter().enumerate() {
                w_total.append(*t, &tv[j])?;
                w_sun.append(*t, &sv[j])?;
            }
            w_total.checkpoint()?;
            w_sun.checkpoint()?;
            if let Some(m) = &surface_map {
                let (_, fv) =
                    export::read_illuminance_csv(&IlluminanceWriter::partial_path(&surfaces_path))?;
                let mut w =
                    IlluminanceWriter::create_with_header(&surfaces_path, m.header(), m.columns())?;
                for (j, t) in times.iter().enumerate() {
                    w.append(*t, &fv[j])?;
                }
                w.checkpoint()?;
                w_surf = Some(w);
            }
        }
        report.resumed = i;
    }

    let ts = Instant::now();
    // Surfaces read the mesh solution, which only forward solves have.
    let response = operator
        .as_ref()
        .filter(|_| surface_map.is_none())
        .and_then(|op| op.response(opts.response_max_bytes));
    report.interreflection = match (&operator, &response) {
        (None, _) => "none",
        (Some(_), Some(_)) => "adjoint",
        (Some(_), None) => "forward",
    }
    .into();
    if let Some(r) = &response {
        stage.add("sensor_response", ts.elapsed().as_secs_f64());
        report.sweeps += r.sweeps;
    }
    let mesh_memo: Memo<MeshWeights> = Mutex::new(HashMap::new());
    let dc_memo: Memo<Arc<DirectionResponse>> = Mutex::new(HashMap::new());
    let ctx = Ctx {
        scene,
        weather,
        quality,
        dirs: &dirs,
        operator: operator.as_ref(),
        response: response.as_ref(),
        surfaces: surface_map.as_ref(),
        mesh_memo: &mesh_memo,
        dc_memo: &dc_memo,
        stages: Mutex::new(Stages::default()),
    };
    let mut done = report.resumed;
    progress(done, total_steps);
    let mut errs: Vec<f32> = Vec::new();
    let todo = &days[resumed_days..];
    for batch in todo.chunks(DAYS_PER_BATCH) {
        if stop.load(Ordering::SeqCst) {
            report.interrupted = true;
            break;
        }
        let results: Vec<Result<Vec<StepOut>>> =
            batch.par_iter().map(|day| ctx.run_day(day)).collect();
        for (day, res) in batch.iter().zip(results) {
            let outs = res?;
            for (s, o) in day.iter().zip(&outs) {
                w_total.append(s.time, &o.total)?;
                w_sun.append(s.time, &o.sun)?;
                if let Some(w) = &mut w_surf {
                    w.append(s.time, &o.surfaces)?;
                }
                report.sweeps += o.sweeps as u64;
                errs.extend_from_slice(&o.rel_err);
                if o.total.is_empty() {
                    continue;
                }
            }
            report.computed += day.len();
            done += day.len();
        }
        w_total.checkpoint()?;
        w_sun.checkpoint()?;
        if let Some(w) = &mut w_surf {
            w.checkpoint()?;
        }
        progress(done, total_steps);
    }
    // Step counts (the plan, so resumed runs report the same).
    for s in days.iter().flatten() {
        match classify(scene, s) {
            Kind::Missing => report.missing += 1,
            Kind::Night => report.night += 1,
            Kind::Day { sun } => report.sun_steps += usize::from(sun),
        }
    }
    if report.night > 0 {
        report.skipped.push(format!(
            "{} night steps (sun below the horizon, no diffuse light): written as 0",
            report.night
        ));
    }
    if report.missing > 0 {
        report.skipped.push(format!(
            "{} steps with missing irradiance in the weather file: written as 0",
            report.missing
        ));
    }
    errs.sort_by(f32::total_cmp);
    if !errs.is_empty() {
        report.median_relative_err = errs[errs.len() / 2] as f64;
        report.p95_relative_err = errs[errs.len() * 95 / 100] as f64;
    }
    report.directions = dirs.counts();
    report.cache = store.stats();
    report.warnings.extend(store.warnings());
    let mut st = ctx.stages.into_inner().expect("stages lock");
    st.merge(stage);
    report.stage_seconds = st.0;
    if !report.interrupted {
        w_total.finish()?;
        w_sun.finish()?;
        if let Some(w) = w_surf.take() {
            w.finish()?;
        }
        if n == 1 {
            let tm = Instant::now();
            write_metrics(out, weather.interval_minutes, &opts.metrics)?;
            if opts.ill {
                let (times, rows) = export::read_illuminance_csv(&out.join("illuminance.csv"))?;
                let times = parse_times(&times)?;
                export::write_ill(&out.join("illuminance.ill"), &times, &rows)?;
            }
            report
                .stage_seconds
                .push(("metrics".into(), tm.elapsed().as_secs_f64()));
        } else {
            report
                .skipped
                .push("metrics: a shard; `daystep merge` computes them".into());
        }
        if !opts.ill {
            report
                .skipped
                .push("illuminance.ill: not asked for (--ill)".into());
        }
        report.skipped.push("images: not asked for".into());
        if !opts.surfaces {
            report
                .skipped
                .push("surfaces.csv: not asked for (--surfaces)".into());
        } else if surface_map.is_none() {
            report
                .skipped
                .push("surfaces.csv: the scene has no surfaces to report".into());
        }
    }
    report.total_seconds = t0.elapsed().as_secs_f64();
    let json = serde_json::to_string_pretty(&report)
        .map_err(|e| Error::Internal(format!("report serialisation: {e}")))?;
    crate::files::write_atomic(&out.join("report.json"), json.as_bytes())?;
    Ok(report)
}

fn parse_times(times: &[String]) -> Result<Vec<NaiveDateTime>> {
    times
        .iter()
        .map(|t| {
            NaiveDateTime::parse_from_str(t, export::TIME_FORMAT)
                .map_err(|e| Error::Internal(format!("time {t}: {e}")))
        })
        .collect()
}

/// Computes `metrics.csv` and `summary.json` in `out` from its `illuminance.csv` and
/// `direct_sun.csv` (a finished run or a merge).
///
/// # Errors
/// Missing or malformed input files; files that cannot be written.
pub fn write_metrics(out: &Path, step_minutes: u32, params: &MetricParams) -> Result<()> {
    params.validate()?;
    let (times, total) = export::read_illuminance_csv(&out.join("illuminance.csv"))?;
    let (_, sun) = export::read_illuminance_csv(&out.join("direct_sun.csv"))?;
    let times = parse_times(&times)?;
    let occupied: Vec<bool> = times
        .iter()
        .map(|t| metrics::is_occupied(*t, step_minutes, params))
        .collect();
    let sensors = total.first().map_or(0, |r| r.len());
    // Night steps are written as 0 lx: counted dark whether flagged or not.
    let sun_up = vec![true; times.len()];
    let per: Vec<metrics::SensorMetrics> = (0..sensors)
        .map(|k| {
            let t: Vec<f64> = total.iter().map(|r| r[k]).collect();
            let s: Vec<f64> = sun.iter().map(|r| r[k]).collect();
            metrics::sensor_metrics(
                &t,
                &s,
                &occupied,
                &sun_up,
                step_minutes as f64 / 60.0,
                params,
            )
        })
        .collect();
    export::write_metrics_csv(&out.join("metrics.csv"), &per)?;
    let summary = metrics::summary(&per, None, params)?;
    export::write_summary_json(&out.join("summary.json"), &summary, params)
}

/// Merges shard folders into `out` (the same files a single run writes) and computes the
/// metrics.
///
/// # Errors
/// Shards that do not fit together (headers, duplicate or missing times), I/O.
pub fn merge(
    parts: &[std::path::PathBuf],
    out: &Path,
    step_minutes: u32,
    params: &MetricParams,
) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    for f in ["illuminance.csv", "direct_sun.csv", "surfaces.csv"] {
        let files: Vec<_> = parts.iter().map(|p| p.join(f)).collect();
        // surfaces.csv only when the shards were asked for it.
        if f == "surfaces.csv" && !files.iter().all(|p| p.exists()) {
            continue;
        }
        export::merge_illuminance(&files, &out.join(f))?;
    }
    write_metrics(out, step_minutes, params)
}

/// What a step needs.
enum Kind {
    Missing,
    Night,
    Day { sun: bool },
}

fn classify(scene: &Scene, s: &Step) -> Kind {
    if s.record.missing {
        return Kind::Missing;
    }
    let utc =
        (s.time - chrono::TimeDelta::seconds((scene.site.utc_offset_h * 3600.0) as i64)).and_utc();
    let sun = solar_position(utc, &scene.site);
    if s.record.dhi <= 0.0 && (s.record.dni <= 0.0 || sun.altitude_deg() <= 0.0) {
        return Kind::Night;
    }
    Kind::Day {
        sun: sun.altitude_deg() > 0.0 && s.record.dni > 0.0,
    }
}

/// Stage wall times.
#[derive(Default)]
struct Stages(Vec<(String, f64)>);

impl Stages {
    fn add(&mut self, name: &str, s: f64) {
        match self.0.iter_mut().find(|(n, _)| n == name) {
            Some((_, v)) => *v += s,
            None => self.0.push((name.into(), s)),
        }
    }
    fn merge(&mut self, o: Stages) {
        for (n, s) in o.0 {
            self.add(&n, s);
        }
    }
}

struct Ctx<'a> {
    scene: &'a Scene,
    weather: &'a Weather,
    quality: &'a Quality,
    dirs: &'a Directions<'a>,
    operator: Option<&'a Transport>,
    response: Option<&'a SensorResponse>,
    surfaces: Option<&'a SurfaceMap>,
    mesh_memo: &'a Memo<MeshWeights>,
    dc_memo: &'a Memo<Arc<DirectionResponse>>,
    stages: Mutex<Stages>,
}

impl Ctx<'_> {
    /// One day's steps: independent (in parallel) with adjoint responses, otherwise a
    /// chain warm-started from the day's first lit step.
    fn run_day(&self, day: &[Step]) -> Result<Vec<StepOut>> {
        if self.response.is_some() {
            return day
                .par_iter()
                .map(|s| {
                    let mut st = Stages::default();
                    let o = self.run_step(s, &mut None, &mut st);
                    self.stages.lock().expect("stages lock").merge(st);
                    o
                })
                .collect();
        }
        let mut state: Option<TransportState> = None;
        let mut st = Stages::default();
        let mut outs = Vec::with_capacity(day.len());
        for s in day {
            let o = self.run_step(s, &mut state, &mut st)?;
            outs.push(o);
        }
        self.stages.lock().expect("stages lock").merge(st);
        Ok(outs)
    }

    fn run_step(
        &self,
        s: &Step,
        state: &mut Option<TransportState>,
        st: &mut Stages,
    ) -> Result<StepOut> {
        let n = self.scene.sensors.len();
        let zeros = || StepOut {
            total: vec![0.0; n],
            sun: vec![0.0; n],
            surfaces: vec![0.0; self.surfaces.map_or(0, |m| m.columns())],
            ..StepOut::default()
        };
        if !matches!(classify(self.scene, s), Kind::Day { .. }) {
            return Ok(zeros());
        }
        let t = Instant::now();
        let r = s.record;
        let utc = (s.time
            - chrono::TimeDelta::seconds((self.scene.site.utc_offset_h * 3600.0) as i64))
        .and_utc();
        let sun = solar_position(utc, &self.scene.site);
        let spec = SkySpec::Perez {
            dni: r.dni,
            dhi: r.dhi,
            dew_point_c: r.dew_point_c,
        };
        let sky = build_sky(&spec, &sun, s.time.ordinal(), self.scene.ground_reflectance).map_err(
            |e| {
                Error::input(
                    &self.weather.path,
                    Some(r.line),
                    Some(&format!("DNI {} DHI {}", r.dni, r.dhi)),
                    format!("cannot build the Perez sky: {e}"),
                )
            },
        )?;
        let (sources, _, _) = sources_for(&sky, self.quality);
        st.add("sky", t.elapsed().as_secs_f64());
        let t = Instant::now();
        let data = self.dirs.get_all(&sources);
        st.add("directions", t.elapsed().as_secs_f64());
        let t = Instant::now();
        let direct = sensors_from_responses(self.dirs, &sources, &data);
        st.add("sensors_direct", t.elapsed().as_secs_f64());
        let mut out = StepOut {
            total: Vec::with_capacity(n),
            sun: Vec::with_capacity(n),
            surfaces: Vec::new(),
            rel_err: Vec::with_capacity(n),
            sweeps: 0,
        };
        let indirect = match (self.operator, self.response) {
            (Some(op), Some(resp)) => {
                let t = Instant::now();
                let mut acc = resp.start();
                for (src, d) in sources.iter().zip(&data) {
                    let dc = self.coefficients(op, resp, src, &d.record);
                    resp.add(&mut acc, src.normal_irradiance, &dc);
                }
                st.add("daylight_coefficients", t.elapsed().as_secs_f64());
                let t = Instant::now();
                let ind = resp.sensors_of(&acc);
                st.add("interreflection", t.elapsed().as_secs_f64());
                ind
            }
            (Some(op), None) => {
                let t = Instant::now();
                let mut e = vec![Rgb::ZERO; op.rows()];
                let mut et = vec![
                    Rgb::ZERO;
                    if self.surfaces.is_some() {
                        op.rows()
                    } else {
                        0
                    }
                ];
                for (src, d) in sources.iter().zip(&data) {
                    let res = self.quality.projection.resolution_for(src.is_sun());
                    let w = self.mesh_weights(op, src, res, &d.record);
                    for &(row, wt) in w.iter() {
                        e[row as usize] += src.normal_irradiance * wt;
                    }
                    if let Some(m) = self.surfaces {
                        m.add_transmitted(&mut et, src, &w, self.scene);
                    }
                }
                st.add("mesh_irradiance", t.elapsed().as_secs_f64());
                let t = Instant::now();
                let (next, rep) = op.solve(&e, state.as_ref());
                out.sweeps = rep.sweeps;
                let ind = op.sensors(&next);
                if let Some(m) = self.surfaces {
                    let sin_alt = sun.altitude_deg().to_radians().sin();
                    let k = SurfaceMap::solar_scale(&sources, r.dni, r.dhi, sin_alt);
                    out.surfaces = m.values(op, Some(&next), &e, &et, k);
                }
                *state = Some(next);
                st.add("interreflection", t.elapsed().as_secs_f64());
                ind
            }
            (None, _) => Vec::new(),
        };
        for (k, d) in direct.iter().enumerate() {
            let (i, ie) = indirect.get(k).map_or((0.0, 0.0), |x| {
                (lux(x.irradiance), lux(x.std_err) + lux(x.discretisation))
            });
            let total = lux(d.sun + d.sky) + i;
            let err = d.visibility_err_lux
                + lux(d.radiance_error).abs()
                + SKY_NORMALISATION_REL * total
                + ie;
            out.total.push(total);
            out.sun.push(lux(d.sun));
            if total > 10.0 {
                out.rel_err.push((err / total) as f32);
            }
        }
        Ok(out)
    }

    /// Daylight coefficients of one direction (memoised per run).
    fn coefficients(
        &self,
        op: &Transport,
        resp: &SensorResponse,
        src: &Source,
        record: &crate::projection::DirectionRecord,
    ) -> Arc<DirectionResponse> {
        let res = self.quality.projection.resolution_for(src.is_sun());
        let key = (src.key, res);
        if let Some(d) = self.dc_memo.lock().expect("dc memo").get(&key) {
            return d.clone();
        }
        let w = self.mesh_weights(op, src, res, record);
        let d = Arc::new(resp.direction(op, &w));
        self.dc_memo
            .lock()
            .expect("dc memo")
            .entry(key)
            .or_insert(d)
            .clone()
    }

    /// Row weights of one direction on the operator's mesh (its record's leaf weights,
    /// area-averaged onto the rows), computed once per direction and run.
    fn mesh_weights(
        &self,
        op: &Transport,
        src: &Source,
        res: u32,
        record: &crate::projection::DirectionRecord,
    ) -> MeshWeights {
        let key = (src.key, res);
        if let Some(w) = self.mesh_memo.lock().expect("mesh memo").get(&key) {
            return w.clone();
        }
        let mut h = Hierarchy::new(self.scene);
        let unit = Source {
            normal_irradiance: Rgb::ONE,
            ..*src
        };
        let d = crate::transfer::transfer(&mut h, std::slice::from_ref(&unit), &[record]);
        let e: Vec<Rgb> = d.sun.iter().zip(&d.sky).map(|(a, b)| *a + *b).collect();
        let rows = op.mesh.average_onto(&h, &e);
        let w: MeshWeights = Arc::new(
            rows.into_iter()
                .enumerate()
                .filter(|(_, v)| *v != Rgb::ZERO)
                .map(|(r, v)| (r as u32, v))
                .collect(),
        );
        self.mesh_memo
            .lock()
            .expect("mesh memo")
            .entry(key)
            .or_insert(w)
            .clone()
    }
}
