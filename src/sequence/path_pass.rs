//! The light paths of `annual --leed` ([`super::light_paths`]) evaluated beside the run's
//! own steps. The paths differ from the scene only in which glazing is black, so they
//! share each step's sky, its adaptive cut and its sun: the run builds and cuts each sky
//! once and every path sums its own daylight coefficients over that cut
//! ([`Engine::step_sources`]). A run per path repeated the year's skies and cuts once per
//! path: on the sample office with four groups, most of those runs' time.
//!
//! Each path keeps its own engine, so its coefficients are its own cache records (an
//! interrupted cold run resumes from them). Only the values are computed, from
//! values-only coefficients summed node by node for a batch of steps
//! ([`super::coefficients::Coefficients::evaluate_values_batch`]): the run itself states
//! the error. A path whose scene emits light takes independent forward steps (no warm
//! start), which daylight coefficients cannot carry. Each path's series is written as the
//! run writes its own, row by row in step order, to `paths/<name>/`.

use super::annual::RunControl;
use super::coefficients::CutBatch;
use super::config::{Quality, SkySpec};
use super::estimate::SensorValue;
use super::light_paths::PathVariant;
use super::report::Report;
use super::sky::SkySources;
use super::step::{Engine, EngineOptions, StepTime};
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::export::IlluminanceWriter;
use crate::scene::Scene;
use crate::sky::Sky;
use crate::sources::Source;
use chrono::NaiveDateTime;
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Mutex;

/// One step of every path: (total, direct sun) lux per sensor, in path order.
pub(super) type PathValues = Vec<(Vec<f64>, Vec<f64>)>;

/// The path engines of a run and their series' writers.
pub(super) struct Paths<'a> {
    engines: Vec<Engine<'a>>,
    writers: Mutex<Vec<(IlluminanceWriter, IlluminanceWriter)>>,
    sensors: usize,
}

impl<'a> Paths<'a> {
    /// Prepares the daylight coefficients of every path of `variants` that needs its own
    /// values (those with a scene) for the lit steps `steps`, and starts their series in
    /// `out/paths/<folder>/`. `None` when `control.stop` interrupted it, or when no path
    /// needs values of its own.
    ///
    /// # Errors
    /// The coefficients' memory cap, output I/O.
    pub fn new(
        variants: &'a [PathVariant],
        out: &Path,
        quality: &Quality,
        store: &'a Store,
        steps: &[(StepTime, SkySpec)],
        cap: Option<&crate::memory::MemoryCap>,
        control: &RunControl,
    ) -> Result<Option<Paths<'a>>> {
        let opts = EngineOptions {
            max_memory_bytes: cap.map_or(0, |c| c.bytes),
            max_memory_given: cap.is_some_and(|c| c.given),
            defer_operator: true,
            values_only: true,
            ..EngineOptions::default()
        };
        let scenes: Vec<(&Scene, &str)> = variants
            .iter()
            .filter_map(|v| v.scene.as_ref().map(|s| (s, v.folder.as_str())))
            .collect();
        let Some(&(first, _)) = scenes.first() else {
            return Ok(None);
        };
        let mut engines = Vec::with_capacity(scenes.len());
        let mut writers = Vec::with_capacity(scenes.len());
        for (k, &(scene, folder)) in scenes.iter().enumerate() {
            if control.stop.load(Ordering::SeqCst) {
                return Ok(None);
            }
            (control.progress)(k, scenes.len());
            let mut e = Engine::new(scene, quality, store, &opts);
            // The run's own coefficients were counted; the paths' are a fraction of them.
            e.prepare(steps, &|_, _| {}, control.stop)?;
            engines.push(e);
            let dir = out.join("paths").join(folder);
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            let n = scene.sensors.len();
            writers.push((
                IlluminanceWriter::create(&dir.join("illuminance.csv"), n)?,
                IlluminanceWriter::create(&dir.join("direct_sun.csv"), n)?,
            ));
        }
        Ok(Some(Paths {
            engines,
            writers: Mutex::new(writers),
            sensors: first.sensors.len(),
        }))
    }

    /// Every path's values under `sky`, cut into `cut` at the run's quality; `at` and
    /// `spec` name the step (what a path's preparation built for it is dropped).
    pub fn values(&self, at: &StepTime, spec: &SkySpec, sky: &Sky, cut: &SkySources) -> PathValues {
        self.engines
            .iter()
            .map(|e| {
                drop(e.take_sky(at, spec));
                let step = e.step_sources(sky, cut, None, false, Report::default(), None);
                (
                    step.sensors.iter().map(|v| v.lux).collect(),
                    step.sensors.iter().map(|v| v.lux_sun).collect(),
                )
            })
            .collect()
    }

    /// Whether every path sums daylight coefficients: then the run hands over its steps'
    /// cuts ([`Self::values_of_cuts`]) and the paths evaluate a batch of steps at once.
    pub fn batched(&self) -> bool {
        self.engines.iter().all(|e| e.steps_are_independent())
    }

    /// Drops what the paths' preparation built for the step at `at` under `spec`.
    pub fn forget_sky(&self, at: &StepTime, spec: &SkySpec) {
        for e in &self.engines {
            drop(e.take_sky(at, spec));
        }
    }

    /// Every path's values at each of the steps whose cuts are `cuts` (one per step, at
    /// the run's quality), the paths in parallel; [`Self::batched`] paths only. The same
    /// bits as [`Self::values`] step by step.
    pub fn values_of_cuts(&self, cuts: &[&[Source]]) -> Vec<PathValues> {
        let batch = CutBatch::new(cuts);
        let per_path: Vec<Vec<Vec<SensorValue>>> = self
            .engines
            .par_iter()
            .map(|e| {
                e.values_batch(&batch)
                    .expect("paths sum daylight coefficients")
            })
            .collect();
        (0..cuts.len())
            .map(|j| {
                per_path
                    .iter()
                    .map(|p| {
                        (
                            p[j].iter().map(|v| v.lux).collect(),
                            p[j].iter().map(|v| v.lux_sun).collect(),
                        )
                    })
                    .collect()
            })
            .collect()
    }

    /// Appends one step's row to every path's series: `values` from [`Self::values`], or
    /// `None` for a step without daylight (zeros, as the run writes it).
    ///
    /// # Errors
    /// Output I/O; a non-finite value.
    pub fn append(&self, time: NaiveDateTime, values: Option<&PathValues>) -> Result<()> {
        let zeros = vec![0.0; self.sensors];
        let mut writers = self.writers.lock().expect("path writers");
        for (k, (total, sun)) in writers.iter_mut().enumerate() {
            match values {
                Some(v) => {
                    total.append(time, &v[k].0)?;
                    sun.append(time, &v[k].1)?;
                }
                None => {
                    total.append(time, &zeros)?;
                    sun.append(time, &zeros)?;
                }
            }
        }
        Ok(())
    }

    /// Completes every path's series (renamed into place).
    ///
    /// # Errors
    /// Output I/O.
    pub fn finish(self) -> Result<()> {
        for (total, sun) in self.writers.into_inner().expect("path writers") {
            total.finish()?;
            sun.finish()?;
        }
        Ok(())
    }
}
