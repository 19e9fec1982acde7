//! One timestep, written once: every command (`instant`, `annual`, `df`, `convergence`)
//! runs its timesteps through [`Engine::step`], an instant being a sequence of one step.
//!
//! The pipeline, in order (paper §3–6):
//! 1. solar position and sky ([`super::sky`]);
//! 2. sources: the adaptive sky and ground nodes and the snapped sun;
//! 3. directions: each source's LDI projection and sensor responses, cached by direction
//!    ([`super::directions`]);
//! 4. direct transfer onto the interreflection mesh ([`super::direct`]);
//! 5. interreflection: a solve of the global-line operator warm-started from the previous
//!    step, or daylight coefficients ([`crate::radiosity`]);
//! 6. sensors: direct light from the responses, one level coarser for the error, and the
//!    indirect gather;
//! 7. the stated error ([`super::estimate`]).
//!
//! What a run reuses across its steps (directions, the operator, per-direction mesh
//! weights) lives in the [`Engine`]; what one step produces is a [`Step`].

use super::coefficients::{Coefficients, CutBatch};
use super::config::{Quality, SkySpec};
use super::direct::{sensors_from_responses, MeshMemo};
use super::directions::{DirectionData, Directions};
use super::estimate::{SensorValue, ERROR_MODEL};
use super::report::{Report, StageTimes, SunReport};
use super::sky::{build_sky, sources_for, SkySources};
use super::surfaces::SurfaceMap;
use crate::cache::Store;
use crate::error::Result;
use crate::memory::StagePeaks;
use crate::photometry::Rgb;
use crate::radiosity::TransportState;
use crate::radiosity::{Transport, TransportSensor};
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sky::Sky;
use crate::sources::Source;
use crate::trace::Tracer;
use chrono::Datelike;
use notes::note_errors;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

mod notes; // what a step's report says: counts, skipped work, the largest errors
mod by_coefficients; // stages 3–7 of several steps at once by daylight coefficients
mod direct_pass; // stages 3–4 of a forward step, a block of directions at a time
mod sun; // the sensors' direct sun from the snapped sun's cached responses

pub use super::step_types::{EngineOptions, Step, StepTime};

/// What stage 5 yields: the sensors' interreflected light, the solution for the next
/// step's warm start (forward solves), and the surface output when asked.
#[derive(Default)]
struct Interreflected {
    sensors: Vec<TransportSensor>,
    /// Relative error the iterative solve left (0 without interreflection).
    iteration_error: f64,
    state: Option<TransportState>,
    surfaces: Vec<f64>,
    mesh_direct: Vec<Rgb>,
}

/// What a run keeps across its steps: the per-direction data (fine, and one level
/// coarser for the error estimate), the interreflection operator, and per-direction mesh
/// weights and daylight coefficients.
pub struct Engine<'a> {
    scene: &'a Scene,
    dirs: Directions<'a>,
    coarse: Directions<'a>,
    operator: Option<Transport>,
    operator_from_cache: bool,
    /// The operator is wanted but not read yet ([`EngineOptions::defer_operator`]).
    operator_deferred: bool,
    setup: StageTimes,
    surfaces: Option<SurfaceMap>,
    mesh_memo: MeshMemo,
    tracer: Arc<Tracer>,
    store: &'a Store,
    opts: EngineOptions,
    /// Daylight coefficients and the sun cells' sensor responses ([`Engine::prepare`]).
    coefficients: Option<(Coefficients, Directions<'a>)>,
    /// Skies [`Engine::prepare`] built, each taken by its step.
    skies: Mutex<HashMap<SkyKey, Sky>>,
    /// Peak resident memory of the set-up's stages (and of the caller's, [`Engine::peaks`]).
    peaks: StagePeaks,
}

/// A step's time and sky parameters, exactly.
type SkyKey = (i64, u32, [u64; 3]);

fn sky_key(at: &StepTime, spec: &SkySpec) -> SkyKey {
    let (a, b, c) = match *spec {
        SkySpec::Perez {
            dni,
            dhi,
            dew_point_c,
        } => (dni, dhi, dew_point_c.unwrap_or(f64::NAN)),
        _ => return (i64::MIN, 0, [0; 3]),
    };
    (
        at.utc.timestamp(),
        at.utc.timestamp_subsec_nanos(),
        [a.to_bits(), b.to_bits(), c.to_bits()],
    )
}

/// Whether `scene` reflects or emits anything (otherwise there is no interreflection).
pub fn needs_interreflection(scene: &Scene) -> bool {
    scene.triangles.iter().any(|t| {
        let m = &scene.materials[t.material as usize];
        m.reflectance().max_element() > 0.0 || m.is_emitter()
    })
}

impl<'a> Engine<'a> {
    /// Prepares the steps of `scene` at `quality`, reading and writing cached directions
    /// and the operator through `store`. The operator is built (or read) here, when the
    /// scene reflects and its sensors or the surface output need it.
    pub fn new(
        scene: &'a Scene,
        quality: &Quality,
        store: &'a Store,
        opts: &EngineOptions,
    ) -> Engine<'a> {
        let mut setup = StageTimes::default();
        let peaks = StagePeaks::default();
        // One BVH per run, shared by the sensor responses and the operator's lines.
        let tracer =
            Arc::new(peaks.measure("tracer", || setup.time("tracer", || Tracer::new(scene))));
        // The surface output needs the operator's mesh (its columns) even in a black scene.
        let wanted = (needs_interreflection(scene)
            && (!scene.sensors.is_empty() || opts.mesh_solution))
            || opts.surfaces;
        let defer = wanted && opts.defer_operator && !opts.surfaces && !opts.mesh_solution;
        let (operator, operator_from_cache) = if wanted && !defer {
            let (t, cached) = peaks.measure("operator", || {
                setup.time("operator", || {
                    super::operator::transport(scene, &quality.transport, store, &tracer)
                })
            });
            (Some(t), cached)
        } else {
            (None, false)
        };
        let surfaces = match (&operator, opts.surfaces) {
            (Some(op), true) => Some(SurfaceMap::new(scene, op)),
            _ => None,
        };
        Engine {
            scene,
            dirs: Directions::new(scene, quality, store, tracer.clone()),
            coarse: Directions::sensors_only(scene, &quality.coarser(), store, tracer.clone()),
            operator,
            operator_from_cache,
            operator_deferred: defer,
            setup,
            surfaces,
            mesh_memo: MeshMemo::default(),
            tracer,
            store,
            opts: *opts,
            coefficients: None,
            skies: Mutex::new(HashMap::new()),
            peaks,
        }
    }

    /// Switches the steps to daylight coefficients ([`super::coefficients`]) for the
    /// steps `steps` (each step's time and sky; a later step with a sky node or sun
    /// direction none of these had panics). Declined (returns false, steps keep the
    /// forward solve) when the scene has no interreflection, when surface output needs
    /// each step's mesh solution, or when something emits. `progress(done, total)` counts
    /// the direction passes of the coefficients that are computed (none when all are
    /// cached); `stop` ends them early.
    ///
    /// # Errors
    /// [`crate::Error::Interrupted`] when `stop` was set while they were computed.
    /// The coefficients cannot fit [`EngineOptions::max_memory_bytes`] ([`crate::Error::Input`]
    /// naming `--max-memory` and the smallest cap that fits), found before they are computed.
    pub fn prepare(
        &mut self,
        steps: &[(StepTime, SkySpec)],
        progress: &(dyn Fn(usize, usize) + Sync),
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<bool> {
        if self.operator.is_none() && !self.operator_deferred {
            return Ok(false);
        }
        let emits = self.scene.materials.iter().any(|m| m.is_emitter());
        if self.surfaces.is_some()
            || emits
            || self.scene.sensors.is_empty()
            || self.opts.mesh_solution
        {
            self.load_operator();
            return Ok(false);
        }
        let (scene, store, tracer) = (self.scene, self.store, &self.tracer);
        let params = self.dirs.quality().transport;
        let (setup, from_cache) = (&mut self.setup, &mut self.operator_from_cache);
        let peaks = &self.peaks;
        let load = || {
            let (t, cached) = peaks.measure("operator", || {
                setup.time("operator", || {
                    super::operator::transport(scene, &params, store, tracer)
                })
            });
            // The build's line lists are freed; the coefficients' blocks come next.
            crate::allocator::give_back_freed();
            *from_cache = cached;
            t
        };
        let (c, skies) = peaks.measure("daylight_coefficients", || {
            Coefficients::prepare(
                scene,
                &self.dirs,
                &mut self.operator,
                load,
                steps,
                &self.opts,
                &super::coefficients::Watch { progress, stop },
            )
        })?;
        // The steps sum coefficients and never read the operator again: it is the run's
        // largest holding (about half a gigabyte on the generated building), so it goes,
        // with what the coefficients' solves freed.
        self.operator = None;
        crate::allocator::give_back_freed();
        self.operator_deferred = true;
        self.setup.add("daylight_coefficients", c.stats.seconds);
        let mut memo = self.skies.lock().expect("sky memo");
        for ((at, spec), sky) in steps.iter().zip(skies) {
            if let Some(sky) = sky {
                memo.insert(sky_key(at, spec), sky);
            }
        }
        drop(memo);
        let sun = Directions::sensors_only(
            self.scene,
            self.dirs.quality(),
            self.store,
            self.tracer.clone(),
        );
        self.coefficients = Some((c, sun));
        Ok(true)
    }

    /// Reads (or builds) a deferred operator: what forward steps need.
    fn load_operator(&mut self) {
        if self.operator_deferred && self.operator.is_none() {
            let (scene, store, tracer) = (self.scene, self.store, &self.tracer);
            let params = self.dirs.quality().transport;
            let setup = &mut self.setup;
            let (t, cached) = self.peaks.measure("operator", || {
                setup.time("operator", || {
                    super::operator::transport(scene, &params, store, tracer)
                })
            });
            self.operator = Some(t);
            self.operator_from_cache = cached;
        }
        self.operator_deferred = false;
    }

    /// What preparing the daylight coefficients did, when the steps use them.
    pub fn coefficient_stats(&self) -> Option<super::coefficients::CoefficientStats> {
        self.coefficients.as_ref().map(|c| c.0.stats)
    }

    /// The per-direction data at the run's quality (counters, cache store).
    pub fn directions(&self) -> &Directions<'a> {
        &self.dirs
    }

    /// The run's ray tracer (one BVH per geometry, shared by every stage).
    pub fn tracer(&self) -> &Tracer {
        &self.tracer
    }

    /// The interreflection operator, when the scene needs one.
    pub fn operator(&self) -> Option<&Transport> {
        self.operator.as_ref()
    }

    /// The operator, giving up the engine.
    pub fn into_operator(self) -> Option<Transport> {
        self.operator
    }

    /// Whether the operator was read from the cache.
    pub fn operator_from_cache(&self) -> bool {
        self.operator_from_cache
    }

    /// Peak resident memory per stage: the set-up's (tracer, operator, daylight
    /// coefficients), and any the caller measures through it.
    pub fn peaks(&self) -> &StagePeaks {
        &self.peaks
    }

    /// Wall time of the run's set-up (the operator; adjoint responses), seconds.
    pub fn setup_times(&self) -> &StageTimes {
        &self.setup
    }

    /// Gauss–Seidel sweeps of the daylight coefficients' adjoint solves (0 without them).
    pub fn response_sweeps(&self) -> u64 {
        self.coefficient_stats().map_or(0, |s| s.sweeps)
    }

    /// The surface map, when the run asked for surface output.
    pub fn surfaces(&self) -> Option<&SurfaceMap> {
        self.surfaces.as_ref()
    }

    /// How the steps' interreflection is computed: "daylight coefficients", "forward" or
    /// "none".
    pub fn interreflection(&self) -> &'static str {
        match (&self.operator, &self.coefficients) {
            (_, Some(_)) => "daylight coefficients",
            (None, None) => "none",
            (Some(_), None) => "forward",
        }
    }

    /// Counts a day summed by daylight coefficients, which now and then gives back the
    /// pages of those read in place from the cache ([`Coefficients::day_done`]); nothing
    /// without them. Values never depend on it.
    pub fn coefficient_day_done(&self) {
        if let Some((c, _)) = &self.coefficients {
            c.day_done();
        }
    }

    /// Whether steps are independent (daylight coefficients) rather than warm-started.
    pub fn steps_are_independent(&self) -> bool {
        self.coefficients.is_some()
    }

    /// One timestep at `at` under the sky `spec`, warm-started from `previous` (the last
    /// step's [`Step::state`]) when given. With `detail` the step also returns the refined
    /// element hierarchy and its direct irradiance (a transfer of every source at once).
    ///
    /// # Errors
    /// Bad sky parameters ([`crate::Error::Input`]).
    pub fn step(
        &self,
        at: &StepTime,
        spec: &SkySpec,
        previous: Option<&TransportState>,
        detail: bool,
    ) -> Result<Step> {
        let (sky, report) = self.sky(at, spec)?;
        let mut step = self.step_sky(&sky, previous, detail, report, spec.irradiance());
        step.sky = Some(sky);
        Ok(step)
    }

    /// Stage 1 of [`Self::step`]: the sun's position and the step's sky (the one
    /// [`Self::prepare`] built, else built now), with the step's report begun.
    ///
    /// # Errors
    /// Bad sky parameters ([`crate::Error::Input`]).
    pub fn sky(&self, at: &StepTime, spec: &SkySpec) -> Result<(Sky, Report)> {
        let mut times = StageTimes::default();
        let sun = times.time("solar_position", || {
            solar_position(at.utc, &self.scene.site)
        });
        let prepared = self.take_sky(at, spec);
        let sky = times.time("sky", || {
            if let Some(s) = prepared {
                return Ok(s);
            }
            build_sky(
                spec,
                &sun,
                at.local.ordinal(),
                self.scene.ground_reflectance,
            )
        })?;
        let mut report = Report {
            sun: SunReport {
                altitude_deg: sun.altitude_deg(),
                azimuth_deg: sun.azimuth_deg,
                ..SunReport::default()
            },
            sky: sky.description.clone(),
            stage_seconds: times,
            ..Report::default()
        };
        if sky.sun.is_none() && !matches!(spec, SkySpec::CieOvercast { .. } | SkySpec::None) {
            report.skipped.push(format!(
                "sun: not a source (altitude {:.2}°, or zero direct irradiance)",
                sun.altitude_deg()
            ));
        }
        Ok((sky, report))
    }

    /// The sensor values of the steps of `batch` from daylight coefficients prepared with
    /// [`EngineOptions::values_only`], node by node
    /// ([`Coefficients::evaluate_values_batch`]); `None` when the steps do not use
    /// coefficients (use [`Self::step_sources`]). The same bits as one step at a time.
    pub(super) fn values_batch(&self, batch: &CutBatch) -> Option<Vec<Vec<SensorValue>>> {
        let (c, sun_dirs) = self.coefficients.as_ref()?;
        if !self.opts.values_only {
            return None;
        }
        let cuts: Vec<&[_]> = batch.suns.iter().map(|s| s.as_slice()).collect();
        let sun = self.sun_lux_many(sun_dirs, &cuts);
        Some(c.evaluate_values_batch(batch, &sun))
    }

    /// The sky [`Self::prepare`] built for the step at `at` under `spec`, handed over once
    /// (`None`: not built there, or already taken).
    pub fn take_sky(&self, at: &StepTime, spec: &SkySpec) -> Option<Sky> {
        let key = sky_key(at, spec);
        if key.0 == i64::MIN {
            return None;
        }
        self.skies.lock().expect("sky memo").remove(&key)
    }

    /// [`Self::step`] for a sky already built (stages 2–7). `report` carries what the
    /// caller knows of the step (sun position, sky, stage times so far); `dni_dhi` (W/m²)
    /// scales the surface output to the weather record.
    pub fn step_sky(
        &self,
        sky: &Sky,
        previous: Option<&TransportState>,
        detail: bool,
        mut report: Report,
        dni_dhi: Option<(f64, f64)>,
    ) -> Step {
        // 2. Sources.
        let s = report
            .stage_seconds
            .time("sources", || self.cut(sky, detail));
        self.step_sources(sky, &s, previous, detail, report, dni_dhi)
    }

    /// The cut of `sky` a step at this engine's quality needs (`detail`: with the
    /// solution, as [`Self::step_sky`]): with daylight coefficients and an error estimate,
    /// the coarser level's cut too, in the same walk.
    pub fn cut(&self, sky: &Sky, detail: bool) -> SkySources {
        let q = self.dirs.quality();
        if self.coefficients.is_some() && !detail && !self.opts.values_only {
            super::sky::sources_with_coarse(sky, q, self.coarse.quality())
        } else {
            sources_for(sky, q)
        }
    }

    /// [`Self::step_sky`] for sources already cut from `sky` at this engine's quality
    /// (stages 3–7): runs that share a sky, such as the light paths of `annual --leed`,
    /// cut it once.
    pub fn step_sources(
        &self,
        sky: &Sky,
        s: &SkySources,
        previous: Option<&TransportState>,
        detail: bool,
        mut report: Report,
        dni_dhi: Option<(f64, f64)>,
    ) -> Step {
        if self.coefficients.is_some() && !detail {
            // 3–7 by daylight coefficients.
            let s = SkySources {
                sources: s.sources.clone(),
                coarse: s.coarse.clone(),
                ..*s
            };
            let mut one = self.steps_by_coefficients(vec![(sky, s, report)]);
            return one.pop().expect("one step");
        }
        let mut times = std::mem::take(&mut report.stage_seconds);
        self.note_sources(s, &mut report);
        let sources = s.sources.clone();
        // 3–4. Directions (projections and sensor responses, cached) and the direct
        // transfer onto the mesh, streamed; the refined elements when asked.
        let pass = self.direct_pass(&sources, detail, &mut times, &mut report);
        // 5. Interreflection.
        let light = self.interreflect(
            &sources,
            pass.mesh,
            previous,
            dni_dhi,
            &mut times,
            &mut report,
        );
        // 6–7. Sensors and their stated error.
        let sensors =
            self.sensor_values(sky, &sources, &pass.data, &light, &mut times, &mut report);
        report.warnings.extend(sky.warnings.iter().cloned());
        let dc = self.dirs.counts();
        report.counts.ldis_built = dc.built as usize;
        report.counts.ldis_reused = (dc.from_cache + dc.reused) as usize;
        report.stage_seconds = times;
        Step {
            sensors,
            state: light.state,
            surfaces: light.surfaces,
            sky: None,
            sources,
            elements: pass.elements,
            sun_interpolation_err: Vec::new(),
            mesh_direct: light.mesh_direct,
            report,
        }
    }

    /// Stage 5: the interreflected light at the sensors, by daylight coefficients or by a
    /// solve warm-started from `previous` (with the surface output when asked).
    fn interreflect(
        &self,
        sources: &[Source],
        mesh: Option<(Vec<Rgb>, Option<Vec<Rgb>>)>,
        previous: Option<&TransportState>,
        dni_dhi: Option<(f64, f64)>,
        times: &mut StageTimes,
        report: &mut Report,
    ) -> Interreflected {
        let scene = self.scene;
        let mut out = Interreflected::default();
        match &self.operator {
            Some(op) => {
                let (e, et) = mesh.expect("the mesh's direct light where there is an operator");
                let (next, rep) = times.time("interreflection", || op.solve(&e, previous));
                if let (Some(m), Some(et)) = (&self.surfaces, et) {
                    let sin_alt = report.sun.altitude_deg.to_radians().sin();
                    let k = dni_dhi.map_or(1.0, |(dni, dhi)| {
                        SurfaceMap::solar_scale(sources, dni, dhi, sin_alt)
                    });
                    out.surfaces = m.values(op, Some(&next), &e, &et, k);
                }
                out.sensors = times.time("indirect_gather", || op.sensors(&next));
                report.transport = Some(op.stats);
                report.transport_solve = Some(rep);
                out.iteration_error = rep.iteration_error;
                out.state = Some(next);
                if self.opts.mesh_solution {
                    out.mesh_direct = e;
                }
            }
            None => {
                report.skipped.push(if needs_interreflection(scene) {
                    "interreflection: no sensors and no surface output need it".into()
                } else {
                    "interreflection: every surface is black and nothing emits".into()
                });
                out.sensors = vec![TransportSensor::default(); scene.sensors.len()];
            }
        }
        out
    }

    /// Stages 6–7: each sensor's direct light from its responses, the same one level
    /// coarser, the interreflected `light`, and the stated error.
    fn sensor_values(
        &self,
        sky: &Sky,
        sources: &[Source],
        data: &[Arc<DirectionData>],
        light: &Interreflected,
        times: &mut StageTimes,
        report: &mut Report,
    ) -> Vec<SensorValue> {
        report.error_model = ERROR_MODEL.into();
        if self.scene.sensors.is_empty() {
            report
                .skipped
                .push("sensor gather: the scene has no sensors".into());
            return Vec::new();
        }
        let fine = times.time("sensors", || {
            sensors_from_responses(&self.dirs, sources, data)
        });
        let coarse = times.time("error_estimate", || {
            let cs = sources_for(sky, self.coarse.quality()).sources;
            let cdata = self.coarse.get_all(&cs);
            sensors_from_responses(&self.coarse, &cs, &cdata)
        });
        let values: Vec<SensorValue> = fine
            .iter()
            .zip(&coarse)
            .zip(&light.sensors)
            .map(|((f, c), i)| {
                report.counts.sensor_rays += f.rays + c.rays;
                SensorValue::estimate(f, c, i, light.iteration_error)
            })
            .collect();
        note_errors(&values, report);
        values
    }
}
