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
//!   (sun only, no interreflection: what ASE counts), `metrics.csv`, `summary.json` and
//!   `report.html` (unsharded runs and merges), `report.json`.

pub(super) use super::annual_steps::{classify, is_night, perez, step_time, Kind};
use super::annual_steps::{Ctx, Planned, StepOut};
use super::config::{Quality, SkySpec};
use super::day_feed;
use super::merge::parse_times;
use super::path_pass::{PathValues, Paths};
use super::step::{Engine, EngineOptions, StepTime};
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::export::{self, IlluminanceWriter};
// Where callers found them before the tables moved to `merge`.
pub use super::annual_options::{AnnualOptions, AnnualReport, RunControl};
use super::merge::MetricTables;
pub use super::merge::{merge, write_metrics, write_report_page};
use crate::scene::Scene;
use crate::sources::Source;
use crate::weather::Weather;
use chrono::{NaiveDate, NaiveDateTime};
use rayon::prelude::*;
use std::path::Path;
use std::sync::Mutex;
use std::time::Instant;

/// Days between checkpoints, for `sensors` sensors and a run of `days` days: as many as
/// keep a batch's results (about 24 steps × 20 bytes a sensor a day) near 32 MB and an
/// interrupted run's loss under an eighth of it, from 1 to 32. The workers do not wait
/// at a batch's end ([`day_feed`]), so short runs can checkpoint every day or so.
fn days_per_batch(sensors: usize, days: usize) -> usize {
    (32_000_000 / (24 * 20 * sensors.max(1)))
        .min(days / 8)
        .clamp(1, 32)
}

/// A batch of days computed and not yet written.
struct Computed<'b, 'w> {
    batch: &'b [Vec<Planned<'w>>],
    results: Vec<Vec<StepOut>>,
    /// The batched light paths' rows, one per lit step in order.
    path_rows: Vec<PathValues>,
}

impl Computed<'_, '_> {
    /// Appends the batch's rows to the series and checkpoints them.
    fn write(
        self,
        w_total: &mut IlluminanceWriter,
        w_sun: &mut IlluminanceWriter,
        w_surf: &mut Option<IlluminanceWriter>,
        paths: Option<&Paths>,
        tables: &mut Option<MetricTables>,
    ) -> Result<()> {
        let mut path_rows = self.path_rows.into_iter();
        for (day, outs) in self.batch.iter().zip(&self.results) {
            for (s, o) in day.iter().zip(outs) {
                w_total.append(s.time, &o.total)?;
                w_sun.append(s.time, &o.sun)?;
                if let Some(t) = tables {
                    let read = |v: &[f64]| -> Vec<f64> {
                        v.iter().map(|&x| export::written_value(x)).collect()
                    };
                    t.row(s.time, &read(&o.total), &read(&o.sun));
                }
                if let Some(w) = w_surf {
                    w.append(s.time, &o.surfaces)?;
                }
                if let Some(p) = paths {
                    let row = match o.path_cut {
                        Some(_) => path_rows.next(),
                        None => None,
                    };
                    p.append(s.time, row.as_ref().or(o.paths.as_ref()))?;
                }
            }
        }
        w_total.checkpoint()?;
        w_sun.checkpoint()?;
        if let Some(w) = w_surf {
            w.checkpoint()?;
        }
        Ok(())
    }
}

/// Runs the time series of `weather` on `scene` into `out`.
///
/// # Errors
/// Bad weather values at a step ([`Error::Input`] naming the weather file and line), or
/// files that cannot be written. A stop ([`RunControl::stop`]) is not an error: the
/// report says `interrupted`, also when it came while the daylight coefficients were
/// computed (polled between their batches of directions).
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
        model: super::report::ModelReport::of(scene),
        ..AnnualReport::default()
    };
    report
        .warnings
        .extend(weather.site_mismatch_warning(&scene.site));
    // Plan: records in the date range, grouped by day; this shard's days.
    let mut days: Vec<Vec<Planned>> = Vec::new();
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
            days.last_mut().expect("pushed above").push(Planned {
                record: r,
                time: r.time,
                // Classified below, in parallel.
                kind: Kind::Missing,
            });
        }
    }
    let total_steps: usize = days.iter().map(|d| d.len()).sum();
    report.steps = total_steps;
    super::compliance::check(weather, opts, total_steps)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let sensors = scene.sensors.len();
    // Which columns belong to which grid, for the metrics, merges and per-grid .ill files.
    export::grids::write_grids_json(out, &export::grids::spans_of(scene))?;
    let (mut w_total, done_times) =
        IlluminanceWriter::resume(&out.join("illuminance.csv"), sensors)?;
    let (mut w_sun, done_sun) = IlluminanceWriter::resume(&out.join("direct_sun.csv"), sensors)?;
    // The interreflection operator (geometry only, cached) is needed before resuming when
    // surfaces are asked for: its mesh defines their columns.
    let mut engine = Engine::new(
        scene,
        quality,
        store,
        &EngineOptions {
            surfaces: opts.surfaces,
            max_memory_bytes: opts.max_memory.as_ref().map_or(0, |c| c.bytes),
            max_memory_given: opts.max_memory.as_ref().is_some_and(|c| c.given),
            defer_operator: opts.daylight_coefficients,
            mesh_solution: false,
            values_only: false,
            count_elements_only: false,
        },
    );
    // Every lit step's sky, so the coefficients of all its sources are computed (or read)
    // together before the steps run.
    // What each planned step needs (a solar position each: in parallel).
    days.par_iter_mut()
        .flatten()
        .for_each(|s| s.kind = classify(scene, s.record));
    let planned: Vec<&Planned> = days.iter().flatten().collect();
    let kinds: Vec<Kind> = planned.iter().map(|s| s.kind).collect();
    let lit: Vec<(StepTime, SkySpec)> = planned
        .iter()
        .zip(&kinds)
        .filter(|(_, k)| matches!(k, Kind::Day { .. }))
        .map(|(s, _)| (step_time(scene, s.record), perez(s.record)))
        .collect();
    if opts.daylight_coefficients && !opts.surfaces {
        match engine.prepare(&lit, control.coefficient_progress, stop) {
            // Stopped before the first step: the run ends as after a batch of days.
            Err(Error::Interrupted) => report.interrupted = true,
            r => {
                r?;
            }
        }
    }
    // LEED's light paths, evaluated beside the steps (an unsharded run: shards skip LEED).
    let variants = if opts.leed && n == 1 {
        super::light_paths::variants(scene)
    } else {
        Vec::new()
    };
    report.coefficients = engine.coefficient_stats();
    report.operator_from_cache = engine.operator_from_cache();
    if engine.interreflection() == "none" {
        report.skipped.push(
            "interreflection: every surface is black and nothing emits, or no sensors".into(),
        );
    }
    let surface_map = engine.surfaces();
    let surfaces_path = out.join("surfaces.csv");
    let (mut w_surf, done_surf) = match surface_map {
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
            if let Some(m) = surface_map {
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

    report.interreflection = engine.interreflection().into();
    report.sweeps += engine.response_sweeps();
    let paths = Paths::new(
        &variants,
        out,
        quality,
        store,
        &lit,
        opts.max_memory.as_ref(),
        control,
    )?;
    if paths.is_none() && variants.iter().any(|v| v.scene.is_some()) {
        // Stopped while the paths were prepared.
        report.interrupted = true;
    }
    let ctx = Ctx {
        scene,
        weather,
        engine: &engine,
        stages: Mutex::new(engine.setup_times().clone()),
        paths: paths.as_ref(),
        cut_days_from_cache: Default::default(),
        first_day: days
            .get(resumed_days)
            .and_then(|d| d.first())
            .map(|s| s.time.date()),
    };
    let per_batch = days_per_batch(scene.sensors.len(), days.len());
    if let Some(p) = &paths {
        // The paths' series start at the first step: the resumed days' rows again.
        for batch in days[..resumed_days].chunks(per_batch) {
            let rows: Vec<Result<Vec<Option<PathValues>>>> = batch
                .par_iter()
                .map(|day| day.par_iter().map(|s| ctx.path_step(s)).collect())
                .collect();
            for (day, r) in batch.iter().zip(rows) {
                for (s, v) in day.iter().zip(r?) {
                    p.append(s.time, v.as_ref())?;
                }
            }
        }
    }
    let mut done = report.resumed;
    progress(done, total_steps);
    let mut errs: Vec<f32> = Vec::new();
    let todo = &days[resumed_days..];
    // The metrics taken from the rows as they are written, so that a run that resumed
    // nothing does not read its tables again (a run that resumed reads them whole).
    let mut tables = (report.resumed == 0 && n == 1)
        .then(|| MetricTables::new(sensors, weather.interval_minutes, &opts.metrics));
    // Each batch's rows are written while later days are computed.
    let mut hand_on = |batch: &[Vec<Planned>], results: Vec<Vec<StepOut>>| -> Result<()> {
        // Batched light paths: every lit step's cut of the batch at once.
        let path_rows = match &paths {
            Some(p) if p.batched() => {
                let cuts: Vec<&[Source]> = results
                    .iter()
                    .flatten()
                    .filter_map(|o| o.path_cut.as_deref())
                    .collect();
                p.values_of_cuts(&cuts)
            }
            _ => Vec::new(),
        };
        for (day, outs) in batch.iter().zip(&results) {
            for o in outs {
                report.sweeps += o.sweeps as u64;
                errs.extend_from_slice(&o.rel_err);
            }
            report.computed += day.len();
            done += day.len();
        }
        Computed {
            batch,
            results,
            path_rows,
        }
        .write(
            &mut w_total,
            &mut w_sun,
            &mut w_surf,
            paths.as_ref(),
            &mut tables,
        )?;
        progress(done, total_steps);
        Ok(())
    };
    if !report.interrupted {
        let stopped = engine.peaks().measure("steps", || {
            day_feed::run_batches(todo, per_batch, stop, |day| ctx.run_day(day), &mut hand_on)
        })?;
        report.interrupted = stopped;
    }
    // Step counts (the plan, so resumed runs report the same).
    for k in &kinds {
        match *k {
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
    // Order statistics by selection, not a sort of every step's sensors (a tenth of a
    // second on a year, with the workers idle).
    for (percent, out) in [
        (50, &mut report.median_relative_err),
        (95, &mut report.p95_relative_err),
    ] {
        if !errs.is_empty() {
            let k = errs.len() * percent / 100;
            *out = *errs.select_nth_unstable_by(k, f32::total_cmp).1 as f64;
        }
    }
    report.directions = engine.directions().counts();
    report.cache = store.stats();
    report.warnings.extend(store.warnings());
    if let Some(c) = report.coefficients.as_mut() {
        c.cut_days_from_cache = ctx.cut_days_from_cache.into_inner();
    }
    report.stage_seconds = ctx.stages.into_inner().expect("stages lock").0;
    if !report.interrupted {
        w_total.finish()?;
        w_sun.finish()?;
        if let Some(w) = w_surf.take() {
            w.finish()?;
        }
        if let Some(p) = paths {
            p.finish()?;
        }
        let mut compliance: Option<super::compliance::Compliance> = None;
        if n == 1 {
            let tm = Instant::now();
            let per = match tables {
                Some(t) => t.write(out)?,
                None => write_metrics(out, weather.interval_minutes, &opts.metrics)?,
            };
            if opts.ill {
                let (times, rows) = export::read_illuminance_csv(&out.join("illuminance.csv"))?;
                let times = parse_times(&times)?;
                export::write_ill(&out.join("illuminance.ill"), &times, &rows)?;
                let grids = export::grids::spans_of(scene);
                if !grids.is_empty() {
                    export::grids::write_grid_ills(out, &grids, &times, &rows)?;
                }
            }
            report
                .stage_seconds
                .push(("metrics".into(), tm.elapsed().as_secs_f64()));
            if opts.leed || opts.en17037 {
                let run = super::compliance::Run {
                    scene,
                    weather,
                    out,
                    opts,
                    plan: days.iter().flatten().map(|s| s.record).collect(),
                    paths: &variants,
                };
                let c = super::compliance::compliance(&run)?;
                report.compliance = Some(c.report.clone());
                compliance = Some(c);
            }
            if !report.interrupted {
                // After the compliance numbers: the page shows them.
                let c = compliance.as_ref();
                export::report_page::write_report_html(
                    &out.join("report.html"),
                    &export::report_page::ReportInputs {
                        title: format!("daystep annual: {}, {}", report.scene, report.weather),
                        scene,
                        metrics: &per,
                        params: &opts.metrics,
                        leed: c.and_then(|c| c.leed.as_ref()),
                        leed_times: c.map_or(&[], |c| &c.leed_times),
                        en17037: c.and_then(|c| c.en17037.as_ref()),
                    },
                )?;
            }
        } else {
            report
                .skipped
                .push("metrics, report.html: a shard; `daystep merge` writes them".into());
            if opts.leed || opts.en17037 {
                report.skipped.push(
                    "--leed/--en17037: a shard; run them unsharded (the cache makes it cheap)"
                        .into(),
                );
            }
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
    report.memory = super::report::MemoryReport::of(
        opts.max_memory.as_ref().map_or(0, |c| c.bytes),
        opts.max_memory.as_ref().map_or("none", |c| &c.from),
        Some(engine.peaks()),
    );
    let json = serde_json::to_string_pretty(&report)
        .map_err(|e| Error::Internal(format!("report serialisation: {e}")))?;
    crate::files::write_atomic(&out.join("report.json"), json.as_bytes())?;
    Ok(report)
}
