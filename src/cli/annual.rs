//! `daystep annual`: a time series over a weather file, resumable, with progress on
//! standard error and a Ctrl-C that stops after the days in flight.

use super::args::AnnualArgs;
use super::config;
use super::messages::{note, warnings};
use super::progress::Progress;
use crate::error::{Error, Result};
use crate::sequence::annual::{AnnualOptions, RunControl};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// A flag set by the first Ctrl-C; a second one kills the process (exit 130) while the
/// batch in flight finishes.
pub(super) fn stop_on_ctrl_c() -> Arc<AtomicBool> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
        note!("\nstopping after the work in flight (Ctrl-C again to abort)…");
    });
    stop
}

/// Runs `daystep annual` into `--out`; a rerun with the same folder continues.
///
/// # Errors
/// Bad arguments, scene or weather file ([`Error::Input`]), unwritable output;
/// [`Error::Interrupted`] after Ctrl-C, once the finished days are written.
pub fn run(a: AnnualArgs, limits: &config::Limits) -> Result<()> {
    let q = config::quality(&a.quality, a.seed)?;
    let shard = config::shard(a.shard.as_deref())?;
    let mut scene = crate::scene::Scene::load(&a.scene)?;
    if let Some(g) = &a.grids {
        crate::scene::grids::select_grids(&mut scene, g)?;
    }
    let mut weather = crate::weather::read_weather(&a.weather)?;
    scene.take_site_if_missing(weather.site, &a.weather.display().to_string());
    warnings(&scene.warnings);
    if let Some(step) = a.step {
        weather = crate::weather::resample(&weather, step)?;
    }
    let day = |flag: &str, v: &Option<String>| -> Result<_> {
        v.as_deref()
            .map(|v| config::date(flag, v).map(|d| weather.same_day_in_file_year(d)))
            .transpose()
    };
    let opts = AnnualOptions {
        start: day("--start", &a.start)?,
        end: day("--end", &a.end)?,
        shard,
        metrics: config::metric_params(&a.metrics)?,
        ill: a.ill,
        surfaces: a.surfaces,
        leed: a.leed,
        en17037: a.en17037,
        daylight_coefficients: !a.forward,
        max_memory: Some(limits.cap.clone()),
    };
    opts.metrics.validate()?;
    super::check_outputs(&a.out, a.gltf.as_deref())?;
    warnings(&weather.warnings);
    let store = config::store(&a.cache, a.no_cache, limits.cache_bytes);
    let stop = stop_on_ctrl_c();
    // The coefficients' passes come before the first step; the steps' count ends them.
    let coefficients = Mutex::new(Some(Progress::new(
        "direction passes of the daylight coefficients",
    )));
    let end_coefficients = || {
        if let Some(p) = coefficients.lock().ok().and_then(|mut p| p.take()) {
            p.finish();
        }
    };
    let coefficient_progress = |done: usize, total: usize| {
        if let Some(p) = coefficients.lock().ok().as_deref().and_then(Option::as_ref) {
            p.show(done, total);
        }
    };
    let shown = Progress::new("steps");
    let progress = |done: usize, total: usize| {
        end_coefficients();
        shown.show(done, total);
    };
    let control = RunControl {
        stop: &stop,
        progress: &progress,
        coefficient_progress: &coefficient_progress,
    };
    let r =
        crate::sequence::annual::run_annual(&scene, &weather, &q, &store, &a.out, &opts, &control);
    end_coefficients();
    let r = r?;
    shown.finish();
    warnings(&r.warnings);
    if r.interrupted {
        note!(
            "daystep annual: interrupted after {} of {} steps; finished days are kept in {}. To continue, run the same command again.",
            r.resumed + r.computed,
            r.steps,
            a.out.display()
        );
        return Err(Error::Interrupted);
    }
    if let Some(path) = &a.gltf {
        let days = a
            .gltf_day
            .iter()
            .map(|d| config::date("--gltf-day", d).map(|d| weather.same_day_in_file_year(d)))
            .collect::<Result<Vec<_>>>()?;
        let n =
            crate::sequence::render::write_days_gltf(&scene, &weather, &q, &store, &days, path)?;
        note!("daystep annual: wrote {} ({n} frames)", path.display());
    }
    note!(
        "daystep annual: {} steps ({} computed, {} resumed; {} night, {} missing skipped), {} directions built, {} from cache, {:.1} s; median stated error {:.2} %; wrote {}",
        r.steps,
        r.computed,
        r.resumed,
        r.night,
        r.missing,
        r.directions.built,
        r.directions.from_cache,
        r.total_seconds,
        100.0 * r.median_relative_err,
        a.out.display()
    );
    Ok(())
}
