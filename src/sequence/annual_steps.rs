//! One step of an annual run ([`super::annual`]): what a weather record asks of it
//! (night, missing, daylight), its time and Perez sky, and the run's steps a day at a
//! time: the sky built and cut once for the run and its light paths, then the sums or the
//! warm-started solve.

use super::config::SkySpec;
use super::path_pass::{PathValues, Paths};
use super::report::{Report, StageTimes};
use super::sky::{sources_for, SkySources};
use super::step::{Engine, StepTime};
use super::step_types::Step;
use crate::error::{Error, Result};
use crate::radiosity::TransportState;
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sky::Sky;
use crate::sources::Source;
use crate::weather::{Weather, WeatherRecord};
use chrono::NaiveDateTime;
use rayon::prelude::*;
use std::sync::Mutex;

/// One planned timestep.
pub(super) struct Planned<'w> {
    pub record: &'w WeatherRecord,
    pub time: NaiveDateTime,
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

    /// A day's steps by daylight coefficients: the skies and cuts in parallel, then the
    /// sums of all the day's lit steps at once ([`Engine::steps_by_coefficients`]), which
    /// read each node's coefficients once for the day.
    fn sum_day(&self, day: &[Planned]) -> Result<Vec<StepOut>> {
        let begun: Vec<Option<(Sky, Report, SkySources)>> = day
            .par_iter()
            .map(|s| {
                if !matches!(classify(self.scene, s.record), Kind::Day { .. }) {
                    return Ok(None);
                }
                let at = step_time(self.scene, s.record);
                let (sky, mut report) = self.sky(s, &at, &perez(s.record))?;
                let cut = report
                    .stage_seconds
                    .time("sources", || self.engine.cut(&sky, false));
                Ok(Some((sky, report, cut)))
            })
            .collect::<Result<_>>()?;
        let dark: Vec<bool> = begun.iter().map(Option::is_none).collect();
        let (skies, rest): (Vec<Sky>, Vec<(SkySources, Report)>) = begun
            .into_iter()
            .flatten()
            .map(|(sky, report, cut)| (sky, (cut, report)))
            .unzip();
        let lit = skies
            .iter()
            .zip(rest)
            .map(|(sky, (cut, report))| (sky, cut, report))
            .collect();
        let mut steps = self.engine.steps_by_coefficients(lit).into_iter();
        Ok(dark
            .into_iter()
            .map(|dark| match dark {
                true => self.dark(),
                false => self.step_out(steps.next().expect("a step per lit record"), None, None),
            })
            .collect())
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
        if !matches!(classify(self.scene, s.record), Kind::Day { .. }) {
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
        if !matches!(classify(self.scene, s.record), Kind::Day { .. }) {
            return Ok(None);
        }
        let at = step_time(self.scene, s.record);
        let spec = perez(s.record);
        let (sky, _) = self.sky(s, &at, &spec)?;
        let cut = sources_for(&sky, self.engine.directions().quality());
        Ok(Some(p.values(&at, &spec, &sky, &cut)))
    }
}
