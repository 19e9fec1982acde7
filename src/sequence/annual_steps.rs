//! One step of an annual run ([`super::annual`]): what a weather record asks of it
//! (night, missing, daylight), its time and Perez sky, and the run's steps a day at a
//! time: the sky built and cut once for the run and its light paths, then the sums or the
//! warm-started solve.

use super::config::SkySpec;
use super::day_cuts;
use super::path_pass::{PathValues, Paths};
use super::report::{Report, StageTimes};
use super::sky::{sources_for, SkySources};
use super::step::{Engine, StepTime};
use super::step_types::Step;
use crate::cache::RecordKey;
use crate::error::{Error, Result};
use crate::radiosity::TransportState;
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sky::Sky;
use crate::sources::Source;
use crate::weather::{Weather, WeatherRecord};
use chrono::{Datelike, NaiveDate, NaiveDateTime};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// One planned timestep.
pub(super) struct Planned<'w> {
    pub record: &'w WeatherRecord,
    pub time: NaiveDateTime,
    /// What the record asks of the step ([`classify`]).
    pub kind: Kind,
}

impl Planned<'_> {
    /// Whether the step has daylight.
    fn lit(&self) -> bool {
        matches!(self.kind, Kind::Day { .. })
    }
}

/// The result of one step: total and sun-only illuminance per sensor, lux.
#[derive(Clone, Default)]
pub(super) struct StepOut {
    pub total: Vec<f64>,
    pub sun: Vec<f64>,
    pub surfaces: Vec<f64>,
    pub rel_err: Vec<f32>,
    pub sweeps: u32,
    /// The light paths' values of a lit step (`annual --leed` with aperture groups).
    pub paths: Option<PathValues>,
    /// The lit step's cut, when the paths evaluate a batch of steps at once
    /// ([`Paths::batched`]).
    pub path_cut: Option<Vec<Source>>,
}

/// What a step needs.
#[derive(Clone, Copy)]
pub(super) enum Kind {
    Missing,
    Night,
    Day { sun: bool },
}

/// Night: no diffuse light, and no beam or no sun above the horizon (every sequence
/// over a weather file skips such records).
pub(super) fn is_night(r: &WeatherRecord, sun_altitude_deg: f64) -> bool {
    r.dhi <= 0.0 && (r.dni <= 0.0 || sun_altitude_deg <= 0.0)
}

/// What the weather record `r` asks of a step of `scene`.
pub(super) fn classify(scene: &Scene, r: &WeatherRecord) -> Kind {
    if r.missing {
        return Kind::Missing;
    }
    let sun = solar_position(r.utc(&scene.site), &scene.site);
    if is_night(r, sun.altitude_deg()) {
        return Kind::Night;
    }
    Kind::Day {
        sun: sun.altitude_deg() > 0.0 && r.dni > 0.0,
    }
}

/// When the step of weather record `r` is, at `scene`'s site.
pub(super) fn step_time(scene: &Scene, r: &WeatherRecord) -> StepTime {
    StepTime {
        utc: r.utc(&scene.site),
        local: r.time,
    }
}

/// The Perez sky of a weather record.
pub(super) fn perez(r: &WeatherRecord) -> SkySpec {
    SkySpec::Perez {
        dni: r.dni,
        dhi: r.dhi,
        dew_point_c: r.dew_point_c,
    }
}

/// What a run's steps share.
pub(super) struct Ctx<'a> {
    pub scene: &'a Scene,
    pub weather: &'a Weather,
    pub engine: &'a Engine<'a>,
    pub stages: Mutex<StageTimes>,
    /// LEED's light paths, evaluated on each lit step's sky and cut.
    pub paths: Option<&'a Paths<'a>>,
    /// Days whose cuts came from the cache ([`day_cuts`]).
    pub cut_days_from_cache: AtomicUsize,
    /// The first day this run computes (its cached cuts are always checked).
    pub first_day: Option<NaiveDate>,
}

impl Ctx<'_> {
    /// One day's steps: independent (in parallel) with daylight coefficients, otherwise a
    /// chain warm-started from the day's first lit step.
    pub fn run_day(&self, day: &[Planned]) -> Result<Vec<StepOut>> {
        if self.engine.steps_are_independent() && self.paths.is_none() {
            return self.sum_day(day);
        }
        if self.engine.steps_are_independent() {
            return day
                .par_iter()
                .map(|s| self.run_step(s, &mut None))
                .collect();
        }
        let mut state: Option<TransportState> = None;
        day.iter().map(|s| self.run_step(s, &mut state)).collect()
    }

    /// A day's steps by daylight coefficients: the day's cuts from the cache, or its skies
    /// and cuts made in parallel (and stored), then the sums of all the day's lit steps
    /// at once ([`Engine::summed`]), which read each node's coefficients once for the day.
    fn sum_day(&self, day: &[Planned]) -> Result<Vec<StepOut>> {
        let lit: Vec<bool> = day.iter().map(Planned::lit).collect();
        let store = self.engine.store();
        let key = store.is_enabled().then(|| {
            let steps: Vec<Option<(StepTime, SkySpec)>> = day
                .iter()
                .zip(&lit)
                .map(|(s, &l)| l.then(|| (step_time(self.scene, s.record), perez(s.record))))
                .collect();
            let (fine, coarse) = self.engine.cut_qualities();
            day_cuts::record_key(self.scene, fine, coarse, &steps)
        });
        let t0 = Instant::now();
        let cached = key
            .as_ref()
            .and_then(|k| store.get(k))
            .and_then(|r| day_cuts::decode(&r, &lit));
        let cuts: Vec<(SkySources, Report, Vec<String>)> = match cached {
            Some(c) if !self.checks(day) || self.day_holds(day, &c)? => {
                self.cut_days_from_cache.fetch_add(1, Ordering::Relaxed);
                for (s, _) in day.iter().zip(&lit).filter(|(_, l)| **l) {
                    // Skies made for these steps by the union are not needed.
                    self.engine
                        .take_sky(&step_time(self.scene, s.record), &perez(s.record));
                }
                let share = t0.elapsed().as_secs_f64() / lit.len().max(1) as f64;
                c.into_iter()
                    .flatten()
                    .map(|cut| {
                        let mut report = Report::default();
                        report.stage_seconds.add("sources", share);
                        (cut, report, Vec::new())
                    })
                    .collect()
            }
            _ => self.cut_day(day, &lit, key.as_ref())?,
        };
        let mut steps = self.engine.summed(cuts).into_iter();
        // Now and then the coefficients read go back to the page cache: a year's steps
        // would otherwise keep every node they met resident.
        self.engine.coefficient_day_done();
        Ok(lit
            .into_iter()
            .map(|lit| match lit {
                false => self.dark(),
                true => self.step_out(steps.next().expect("a step per lit record"), None, None),
            })
            .collect())
    }

    /// The cuts of a day's lit steps (`lit`) from their skies, in parallel, stored under
    /// `key` in [`day_cuts::canonical`] form; each with its begun report and its sky's
    /// warnings.
    fn cut_day(
        &self,
        day: &[Planned],
        lit: &[bool],
        key: Option<&RecordKey>,
    ) -> Result<Vec<(SkySources, Report, Vec<String>)>> {
        let made: Vec<Option<(SkySources, Report, Vec<String>)>> = day
            .par_iter()
            .zip(lit)
            .map(|(s, &lit)| {
                if !lit {
                    return Ok(None);
                }
                let (sky, report, mut cut) = self.sky_and_cut(s)?;
                day_cuts::canonical(&mut cut);
                Ok(Some((cut, report, sky.warnings)))
            })
            .collect::<Result<_>>()?;
        if let Some(k) = key {
            let refs: Vec<Option<&SkySources>> =
                made.iter().map(|m| m.as_ref().map(|m| &m.0)).collect();
            if let Some(bytes) = day_cuts::encode(k, &refs) {
                self.engine.store().put(k, &bytes);
            }
        }
        Ok(made.into_iter().flatten().collect())
    }

    /// A step's sky, begun report and cut at the engine's qualities.
    fn sky_and_cut(&self, s: &Planned) -> Result<(Sky, Report, SkySources)> {
        let at = step_time(self.scene, s.record);
        let (sky, mut report) = self.sky(s, &at, &perez(s.record))?;
        let cut = report
            .stage_seconds
            .time("sources", || self.engine.cut(&sky, false));
        Ok((sky, report, cut))
    }

    /// Whether a day's cached cuts are checked ([`Self::day_holds`]): every fourth day of
    /// the year and the run's first day. Checking every day was a twentieth of a warm
    /// year; a record made stale by a change to the sky models without a version bump is
    /// stale on every day, and a damaged one fails its checksums.
    fn checks(&self, day: &[Planned]) -> bool {
        day.first()
            .is_none_or(|s| s.time.ordinal0() % 4 == 0 || Some(s.time.date()) == self.first_day)
    }

    /// Whether cached cuts `c` of `day` hold: one lit step's (the middle one) cut made
    /// again must be the same, to the bit.
    fn day_holds(&self, day: &[Planned], c: &[Option<SkySources>]) -> Result<bool> {
        let lit: Vec<usize> = (0..day.len()).filter(|&i| c[i].is_some()).collect();
        let Some(&i) = lit.get(lit.len() / 2) else {
            return Ok(true);
        };
        let (_, _, mut cut) = self.sky_and_cut(&day[i])?;
        day_cuts::canonical(&mut cut);
        Ok(c[i].as_ref() == Some(&cut))
    }

    /// The zeros of a step without daylight.
    fn dark(&self) -> StepOut {
        let n = self.scene.sensors.len();
        StepOut {
            total: vec![0.0; n],
            sun: vec![0.0; n],
            surfaces: vec![0.0; self.engine.surfaces().map_or(0, |m| m.columns())],
            ..StepOut::default()
        }
    }

    /// What the run keeps of a computed step (its stage times merged into the run's).
    fn step_out(
        &self,
        step: Step,
        paths: Option<PathValues>,
        path_cut: Option<Vec<Source>>,
    ) -> StepOut {
        self.stages
            .lock()
            .expect("stages lock")
            .merge(&step.report.stage_seconds);
        StepOut {
            total: step.sensors.iter().map(|v| v.lux).collect(),
            sun: step.sensors.iter().map(|v| v.lux_sun).collect(),
            surfaces: step.surfaces,
            rel_err: step
                .sensors
                .iter()
                .filter_map(|v| v.relative_error(10.0).map(|e| e as f32))
                .collect(),
            sweeps: step.report.transport_solve.map_or(0, |t| t.sweeps),
            paths,
            path_cut,
        }
    }

    fn run_step(&self, s: &Planned, state: &mut Option<TransportState>) -> Result<StepOut> {
        if !s.lit() {
            return Ok(self.dark());
        }
        let r = s.record;
        let at = step_time(self.scene, s.record);
        let spec = perez(r);
        let (sky, mut report) = self.sky(s, &at, &spec)?;
        let (mut paths, mut path_cut) = (None, None);
        let mut step = match self.paths {
            None => self
                .engine
                .step_sky(&sky, state.as_ref(), false, report, spec.irradiance()),
            Some(p) => {
                // One cut of the sky for the run and every light path.
                let cut = report
                    .stage_seconds
                    .time("sources", || self.engine.cut(&sky, false));
                let batched = p.batched();
                if batched {
                    p.forget_sky(&at, &spec);
                } else {
                    paths = Some(p.values(&at, &spec, &sky, &cut));
                }
                let step = self.engine.step_sources(
                    &sky,
                    &cut,
                    state.as_ref(),
                    false,
                    report,
                    spec.irradiance(),
                );
                if batched {
                    path_cut = Some(cut.sources);
                }
                step
            }
        };
        if step.state.is_some() {
            *state = step.state.take();
        }
        Ok(self.step_out(step, paths, path_cut))
    }

    /// The step's sky and begun report ([`Engine::sky`]), its error naming the record.
    fn sky(&self, s: &Planned, at: &StepTime, spec: &SkySpec) -> Result<(Sky, Report)> {
        let r = s.record;
        self.engine.sky(at, spec).map_err(|e| {
            Error::input(
                &self.weather.path,
                Some(r.line),
                Some(&format!("DNI {} DHI {}", r.dni, r.dhi)),
                format!("cannot build the Perez sky: {e}"),
            )
        })
    }

    /// Only the light paths' values of a step (`None` without daylight): the rows of
    /// resumed days, whose run values are already written.
    pub fn path_step(&self, s: &Planned) -> Result<Option<PathValues>> {
        let Some(p) = self.paths else {
            return Ok(None);
        };
        if !s.lit() {
            return Ok(None);
        }
        let at = step_time(self.scene, s.record);
        let spec = perez(s.record);
        let (sky, _) = self.sky(s, &at, &spec)?;
        let cut = sources_for(&sky, self.engine.directions().quality());
        Ok(Some(p.values(&at, &spec, &sky, &cut)))
    }
}
