//! Compliance numbers of an annual run (`annual --leed --en17037`): LEED v4.1 Daylight
//! Option 1 with operable blinds and EN 17037 daylight provision, from the run's hourly
//! sensor values ([`crate::metrics::leed`], [`crate::metrics::en17037`]).
//!
//! * **Light paths.** With aperture groups, each group's light and the static apertures'
//!   light are their own scene variants ([`super::light_paths`]), evaluated beside the
//!   run's steps on the same skies and cuts (`sequence::path_pass`) and written under
//!   `paths/<name>/`; the shaded state of a group is its open
//!   light × the shade's transmittance (honeybee's default). Without groups, the run's own
//!   values are the one static path: no further run.
//! * **Steps.** The arrays hold the sun-up steps (sun above the horizon, record not
//!   missing), hour-major, as honeybee's matrices do; occupancy is LEED's fixed 8:00–18:00.
//! * **EN 17037** uses the run's own totals (every group open) over the 4380 daylight hours
//!   of the weather file, ranked by its diffuse horizontal illuminance (DHI irradiance where
//!   the file has no illuminance); it needs a whole hourly year.

use super::annual::AnnualOptions;
use super::light_paths::{PathVariant, STATIC_PATH};
use crate::error::{Error, Result};
use crate::export;
use crate::metrics::en17037::{self, En17037Grid, En17037Result};
use crate::metrics::leed::{self, LeedGrid, LeedPeriod, LeedResult, LightPath, Shade};
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::weather::{Weather, WeatherRecord};
use chrono::{NaiveDateTime, Timelike};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// First and last occupied hour of LEED's schedule (hour starting at, inclusive).
const LEED_HOURS: std::ops::RangeInclusive<u32> = 8..=17;

/// What the compliance stage did (`report.json` `compliance`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct ComplianceReport {
    /// Light paths in summing order (static first).
    pub paths: Vec<String>,
    /// Paths that are the scene itself (their glazing is all the glazing), taken from the
    /// run's own values instead of a run of their own.
    pub paths_from_run: Vec<String>,
    /// Sun-up steps the arrays hold.
    pub sun_up_steps: usize,
    /// Bytes of the hourly arrays held at once (grows linearly with the paths).
    pub array_bytes: u64,
    /// Wall time of reading the light paths' series back, s (they are evaluated beside
    /// the run's steps, in its `steps` time).
    pub path_seconds: f64,
    /// Wall time of the metrics, s.
    pub metric_seconds: f64,
}

/// The results, for the report page.
#[derive(Clone, Debug, Default)]
pub struct Compliance {
    /// LEED, when asked for.
    pub leed: Option<LeedResult>,
    /// Local times of the LEED steps (the sun-up steps).
    pub leed_times: Vec<NaiveDateTime>,
    /// EN 17037, when asked for.
    pub en17037: Option<En17037Result>,
    /// What was done.
    pub report: ComplianceReport,
}

/// One grid: name, the sensors (run order) and their cells' areas (m²) when the model
/// gives them.
struct Grid {
    name: String,
    sensors: Vec<usize>,
    areas: Option<Vec<f64>>,
}

fn grids_of(scene: &Scene) -> Vec<Grid> {
    let spans = export::grids::spans_of(scene);
    if spans.is_empty() {
        return vec![Grid {
            name: export::grids::ALL_SENSORS.into(),
            sensors: (0..scene.sensors.len()).collect(),
            areas: None,
        }];
    }
    spans
        .into_iter()
        .map(|s| {
            let areas = scene
                .imported
                .grids
                .iter()
                .find(|g| g.identifier == s.identifier)
                .and_then(|g| g.areas.clone())
                .filter(|a| a.len() == s.sensors.len());
            Grid {
                name: s.identifier,
                sensors: s.sensors,
                areas,
            }
        })
        .collect()
}

/// A path's hourly values over the sun-up steps, per grid, hour-major f32.
struct PathArrays {
    name: String,
    shade: Option<f64>,
    /// Per grid: (total, direct sun).
    grids: GridArrays,
}

/// Per grid: (total, direct sun) at the sun-up steps, hour-major f32 lux.
type GridArrays = Vec<(Vec<f32>, Vec<f32>)>;

/// The run's own values, read from `out` the first time they are needed (LEED's static or
/// scene-wide path and EN 17037 share one read).
fn own<'c>(
    cache: &'c mut Option<GridArrays>,
    out: &Path,
    grids: &[Grid],
    sun_up: &[usize],
    steps: usize,
) -> Result<&'c GridArrays> {
    if cache.is_none() {
        *cache = Some(read_path(out, grids, sun_up, steps)?);
    }
    Ok(cache.as_ref().expect("just read"))
}

/// Reads a run folder's total and sun-only values at the sun-up steps.
fn read_path(dir: &Path, grids: &[Grid], sun_up: &[usize], steps: usize) -> Result<GridArrays> {
    let read = |f: &str| -> Result<Vec<Vec<f64>>> {
        let p = dir.join(f);
        let (times, rows) = export::read_illuminance_csv(&p)?;
        if times.len() != steps {
            return Err(Error::input(
                &p,
                None,
                Some(&times.len().to_string()),
                format!("holds {} steps, the run has {steps}", times.len()),
            ));
        }
        Ok(rows)
    };
    let total = read("illuminance.csv")?;
    let sun = read("direct_sun.csv")?;
    let pick = |rows: &[Vec<f64>], g: &Grid| -> Vec<f32> {
        let mut v = Vec::with_capacity(sun_up.len() * g.sensors.len());
        for &s in sun_up {
            v.extend(g.sensors.iter().map(|&k| rows[s][k] as f32));
        }
        v
    };
    Ok(grids
        .iter()
        .map(|g| (pick(&total, g), pick(&sun, g)))
        .collect())
}

/// Everything the stage needs from the annual run.
pub(super) struct Run<'a> {
    pub scene: &'a Scene,
    pub weather: &'a Weather,
    pub out: &'a Path,
    pub opts: &'a AnnualOptions,
    /// The light paths ([`super::light_paths::variants`]), their series already written.
    pub paths: &'a [PathVariant],
    /// The run's steps, in order.
    pub plan: Vec<&'a WeatherRecord>,
}

/// Reads the light paths' series the run wrote (`run.paths`) and computes what `opts`
/// asks for, writing `leed.json`, `leed_blinds.csv`, `leed_sensors.csv` and
/// `en17037.json` into `out`.
///
/// # Errors
/// EN 17037 on other than a whole hourly year ([`Error::Arg`]); a path's series that
/// cannot be read or has the wrong number of steps; the metrics' input checks.
pub(super) fn compliance(run: &Run) -> Result<Compliance> {
    let (scene, out, opts) = (run.scene, run.out, run.opts);
    let mut c = Compliance::default();
    let grids = grids_of(scene);
    let steps = run.plan.len();
    let sun_up: Vec<usize> = run
        .plan
        .iter()
        .enumerate()
        .filter(|(_, r)| {
            !r.missing && solar_position(r.utc(&scene.site), &scene.site).altitude_deg() > 0.0
        })
        .map(|(i, _)| i)
        .collect();
    c.report.sun_up_steps = sun_up.len();
    let mut run_values: Option<GridArrays> = None;
    if opts.en17037 {
        let values = own(&mut run_values, out, &grids, &sun_up, steps)?;
        c.en17037 = Some(en_17037(run, &grids, &sun_up, values)?);
    }
    if !opts.leed {
        return Ok(c);
    }
    let t0 = Instant::now();
    let groups = &scene.imported.aperture_groups;
    let mut paths: Vec<PathArrays> = Vec::new();
    if groups.is_empty() {
        paths.push(PathArrays {
            name: STATIC_PATH.into(),
            shade: None,
            grids: own(&mut run_values, out, &grids, &sun_up, steps)?.clone(),
        });
    } else {
        // Each path's series was written beside the run's steps (paths/<folder>/); read
        // back in parallel, the values as written, so LEED sees what the files say.
        let mut read: Vec<Option<GridArrays>> = run
            .paths
            .par_iter()
            .map(|v| {
                v.scene
                    .as_ref()
                    .map(|_| read_path(&out.join("paths").join(&v.folder), &grids, &sun_up, steps))
                    .transpose()
            })
            .collect::<Result<_>>()?;
        for (v, r) in run.paths.iter().zip(&mut read) {
            let grids = match r.take() {
                Some(g) => g,
                None => {
                    // The scene itself: the run's own values.
                    c.report.paths_from_run.push(v.name.clone());
                    own(&mut run_values, out, &grids, &sun_up, steps)?.clone()
                }
            };
            paths.push(PathArrays {
                name: v.name.clone(),
                shade: v.shade,
                grids,
            });
        }
    }
    c.report.path_seconds = t0.elapsed().as_secs_f64();
    c.report.paths = paths.iter().map(|p| p.name.clone()).collect();
    c.report.array_bytes = paths
        .iter()
        .flat_map(|p| &p.grids)
        .map(|(t, d)| 4 * (t.len() + d.len()) as u64)
        .sum();
    let t1 = Instant::now();
    let occupied: Vec<bool> = sun_up
        .iter()
        .map(|&i| LEED_HOURS.contains(&run.plan[i].time.hour()))
        .collect();
    let total_occupied_steps = run
        .plan
        .iter()
        .filter(|r| LEED_HOURS.contains(&r.time.hour()))
        .count();
    let leed_grids: Vec<LeedGrid> = grids
        .iter()
        .enumerate()
        .map(|(gi, g)| LeedGrid {
            name: &g.name,
            sensors: g.sensors.len(),
            areas: g.areas.as_deref(),
            paths: paths
                .iter()
                .map(|p| LightPath {
                    name: &p.name,
                    total: &p.grids[gi].0,
                    direct: &p.grids[gi].1,
                    shade: p.shade.map_or(Shade::Static, Shade::Transmittance),
                })
                .collect(),
        })
        .collect();
    let period = LeedPeriod {
        occupied: &occupied,
        total_occupied_steps,
        hours_per_step: f64::from(run.weather.interval_minutes) / 60.0,
    };
    let result = leed::leed_option_one(&leed_grids, &period)?;
    let times: Vec<NaiveDateTime> = sun_up.iter().map(|&i| run.plan[i].time).collect();
    let labels: Vec<String> = times.iter().map(|t| export::format_time(*t)).collect();
    crate::files::write_atomic(
        &out.join("leed_blinds.csv"),
        result.blinds.csv(&labels, &occupied).as_bytes(),
    )?;
    let mut csv = String::from("sensor,grid,da_pct,ase_hours\n");
    let mut rows: Vec<(usize, String)> = Vec::new();
    for (g, r) in grids.iter().zip(&result.grids) {
        for (j, &k) in g.sensors.iter().enumerate() {
            rows.push((
                k,
                format!("{k},{},{},{}\n", g.name, r.da[j], r.ase_hours[j]),
            ));
        }
    }
    rows.sort_by_key(|r| r.0);
    rows.into_iter().for_each(|(_, r)| csv.push_str(&r));
    crate::files::write_atomic(&out.join("leed_sensors.csv"), csv.as_bytes())?;
    export::write_json(&out.join("leed.json"), &leed_json(&result, &paths))?;
    c.report.metric_seconds = t1.elapsed().as_secs_f64();
    c.leed = Some(result);
    c.leed_times = times;
    Ok(c)
}

/// `leed.json`: the result with the paths and shade transmittances it used.
fn leed_json(r: &LeedResult, paths: &[PathArrays]) -> serde_json::Value {
    let mut v = serde_json::to_value(r).unwrap_or_default();
    v["light_paths"] = paths
        .iter()
        .map(|p| {
            serde_json::json!({
                "name": p.name,
                "shade_transmittance": p.shade,
            })
        })
        .collect::<Vec<_>>()
        .into();
    v["occupancy"] = "08:00-18:00 every day (LEED v4.1, IES LM-83)".into();
    v
}

/// Checks, before any work, that a run can give what `opts` asks for: EN 17037 needs the
/// whole year of an hourly weather file (`steps` the run's steps).
///
/// # Errors
/// [`Error::Arg`] naming `--en17037` and what the run has.
pub(super) fn check(weather: &Weather, opts: &AnnualOptions, steps: usize) -> Result<()> {
    let whole = weather.interval_minutes == 60
        && weather.records.len() == 8760
        && steps == 8760
        && opts.shard.1 == 1;
    if opts.en17037 && !whole {
        return Err(Error::arg(
            "--en17037",
            format!("{steps} steps of {} min", weather.interval_minutes),
            "EN 17037's daylight hours are half of an hourly year: run the whole year of an \
             hourly weather file (8760 records), without --start/--end/--step/--shard",
        ));
    }
    Ok(())
}

/// EN 17037 daylight provision of the run's totals.
fn en_17037(
    run: &Run,
    grids: &[Grid],
    sun_up: &[usize],
    total: &GridArrays,
) -> Result<En17037Result> {
    let w = run.weather;
    check(w, run.opts, run.plan.len())?;
    let from_lux = w
        .records
        .iter()
        .all(|r| r.diffuse_illuminance_lux.is_some());
    let series: Vec<f64> = w
        .records
        .iter()
        .map(|r| match (from_lux, r.diffuse_illuminance_lux) {
            (true, Some(l)) => l,
            _ => r.dhi,
        })
        .collect();
    let daylight_all = en17037::daylight_hours(&series)?;
    let daylight: Vec<bool> = sun_up.iter().map(|&i| daylight_all[i]).collect();
    let en_grids: Vec<En17037Grid> = grids
        .iter()
        .zip(total)
        .map(|(g, (t, _))| En17037Grid {
            name: &g.name,
            sensors: g.sensors.len(),
            areas: g.areas.as_deref(),
            total: t,
        })
        .collect();
    let r = en17037::en17037(&en_grids, &daylight, en17037::DAYLIGHT_HOURS)?;
    let mut v = serde_json::to_value(&r).unwrap_or_default();
    v["daylight_hours_from"] = if from_lux {
        "diffuse horizontal illuminance"
    } else {
        "diffuse horizontal irradiance (the weather file has no illuminance)"
    }
    .into();
    export::write_json(&run.out.join("en17037.json"), &v)?;
    Ok(r)
}
