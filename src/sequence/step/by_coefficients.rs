//! Stages 3–7 of steps by daylight coefficients ([`super::Engine`]): sums over each
//! step's cut, no projection, no solve; several steps at once, so that each node's
//! coefficients are read once for all of them.

use super::super::coefficients::{CutBatch, StepCuts};
use super::super::config::Quality;
use super::super::day_cuts::canonical;
use super::super::estimate::ERROR_MODEL;
use super::super::report::Report;
use super::super::sky::{sources_for, SkySources};
use super::super::step_types::Step;
use super::notes::note_errors;
use super::Engine;
use crate::cache::Store;
use crate::sky::Sky;
use std::time::Instant;

impl Engine<'_> {
    /// Stages 3–7 of `steps` by daylight coefficients, each step its sky, its cut at
    /// this engine's quality ([`Engine::cut`]) and its begun report. The same values,
    /// to the bit, as one step at a time. Each step's report carries an equal share of
    /// the sums' time (stage `coefficients`).
    ///
    /// # Panics
    /// When this engine has no daylight coefficients ([`Engine::steps_are_independent`]).
    pub fn steps_by_coefficients(&self, steps: Vec<(&Sky, SkySources, Report)>) -> Vec<Step> {
        let steps = steps
            .into_iter()
            .map(|(sky, mut s, report)| {
                if s.coarse.is_none() && !self.opts.values_only {
                    s.coarse = Some(sources_for(sky, self.coarse.quality()).sources);
                }
                canonical(&mut s);
                (s, report, sky.warnings.clone())
            })
            .collect();
        self.summed(steps)
    }

    /// The qualities of the cuts [`Self::summed`] reads: the run's, and the error
    /// estimate's coarser one unless the engine makes values only.
    pub(in crate::sequence) fn cut_qualities(&self) -> (&Quality, Option<&Quality>) {
        let coarse = (!self.opts.values_only).then(|| self.coarse.quality());
        (self.dirs.quality(), coarse)
    }

    /// The cache the engine reads and writes.
    pub(in crate::sequence) fn store(&self) -> &Store {
        self.store
    }

    /// [`Self::steps_by_coefficients`] for cuts that carry their coarse level (unless the
    /// engine makes values only), each with its sky's warnings. Each cut must be in
    /// [`canonical`] form, as a day's cuts record holds it (making it so again here, for
    /// cuts read from the record, was 4 % of a warm year).
    pub(in crate::sequence) fn summed(
        &self,
        steps: Vec<(SkySources, Report, Vec<String>)>,
    ) -> Vec<Step> {
        let (c, sun_dirs) = self
            .coefficients
            .as_ref()
            .expect("steps by daylight coefficients need coefficients");
        let t0 = Instant::now();
        let fine_cuts: Vec<&[_]> = steps.iter().map(|(s, _, _)| &s.sources[..]).collect();
        let sun_fine = self.sun_lux_many(sun_dirs, &fine_cuts);
        let values: Vec<_> = if self.opts.values_only {
            let batch = CutBatch::new(&fine_cuts);
            c.evaluate_values_batch(&batch, &sun_fine)
                .into_iter()
                .map(|v| (v, Vec::new()))
                .collect()
        } else {
            let coarse: Vec<&[_]> = steps
                .iter()
                .map(|(s, _, _)| s.coarse.as_deref().expect("a coarse cut"))
                .collect();
            let sun_coarse = self.sun_lux_many(&self.coarse, &coarse);
            let cuts: Vec<StepCuts> = steps
                .iter()
                .enumerate()
                .map(|(j, (s, _, _))| StepCuts {
                    fine: &s.sources,
                    coarse: coarse[j],
                    sun_fine: &sun_fine[j],
                    sun_coarse: &sun_coarse[j],
                })
                .collect();
            // The solves' stopping error and the held responses' rounding (both relative).
            let rel = self.dirs.quality().transport.tolerance
                + crate::radiosity::coefficients::RESPONSE_ROUNDOFF;
            c.evaluate(&cuts, &self.coarse, rel)
        };
        let share = t0.elapsed().as_secs_f64() / steps.len().max(1) as f64;
        steps
            .into_iter()
            .zip(values)
            .map(|((s, mut report, warnings), (sensors, interp))| {
                let mut times = std::mem::take(&mut report.stage_seconds);
                times.add("coefficients", share);
                self.note_sources(&s, &mut report);
                report.error_model = ERROR_MODEL.into();
                note_errors(&sensors, &mut report);
                report.warnings.extend(warnings);
                report.stage_seconds = times;
                Step {
                    sensors,
                    state: None,
                    surfaces: Vec::new(),
                    sky: None,
                    sources: s.sources,
                    elements: None,
                    sun_interpolation_err: interp,
                    mesh_direct: Vec::new(),
                    report,
                }
            })
            .collect()
    }
}
