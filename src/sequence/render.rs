//! Renders (`daystep render`): steps whose output is images. Each step is the one
//! [`Engine::step`], solved forward so its mesh solution exists
//! ([`EngineOptions::mesh_solution`]); the camera's primary hits and gather rays are a
//! [`ViewGeometry`] traced once per run and gathered at every step.

use super::config::{Quality, SkySpec};
use super::report::Report;
use super::step::{Engine, EngineOptions, Step, StepTime};
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::render::{Image, RenderOptions, Solution, ViewGeometry};
use crate::scene::view::View;
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sky::Sky;
use crate::weather::Weather;
use chrono::NaiveDate;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// A camera and how finely to render it. The view is in the model's frame, as the user
/// wrote it (the scene's `up`, `north_deg` and origin are applied here).
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// The view, model frame.
    pub view: View,
    /// Size, samples, gather rays, quantity, seed.
    pub options: RenderOptions,
}

impl Camera {
    /// The view in the scene frame.
    pub fn scene_view(&self, scene: &Scene) -> View {
        let v = self.view;
        View {
            vp: scene.point_from_model(v.vp),
            vd: scene.direction_from_model(v.vd).normalize(),
            vu: scene.direction_from_model(v.vu),
            ..v
        }
    }
}

/// A run of renders: the engine of its steps and the camera's geometry, traced once.
pub struct Renderer<'a> {
    engine: Engine<'a>,

    geometry: ViewGeometry,
    /// Seconds spent tracing the camera's geometry.
    pub geometry_seconds: f64,
}

/// One rendered step.
pub struct Frame {
    /// The image.
    pub image: Image,
    /// The step (sensor values, report) it came from.
    pub step: Step,
    /// Seconds of the gather alone.
    pub gather_seconds: f64,
}

impl<'a> Renderer<'a> {
    /// Prepares the engine (the operator, read from or written to `store`) and traces the
    /// camera.
    pub fn new(scene: &'a Scene, quality: &Quality, store: &'a Store, camera: &Camera) -> Self {
        let engine = Engine::new(
            scene,
            quality,
            store,
            &EngineOptions {
                mesh_solution: true,
                ..EngineOptions::default()
            },
        );
        let t0 = Instant::now();
        let view = camera.scene_view(scene);
        let mesh = engine.operator().map(|t| &t.mesh);
        let geometry = ViewGeometry::new(engine.tracer(), &view, mesh, &camera.options);
        Renderer {
            geometry_seconds: t0.elapsed().as_secs_f64(),
            engine,
            geometry,
        }
    }

    /// The engine of the steps.
    pub fn engine(&self) -> &Engine<'a> {
        &self.engine
    }

    /// The camera's geometry.
    pub fn geometry(&self) -> &ViewGeometry {
        &self.geometry
    }

    /// Renders the step at `at` under `spec`. Each frame solves cold: frames are then
    /// independent, so a resumed sequence writes the same bytes as an uninterrupted one
    /// (a warm start changes a solution within its iteration tolerance).
    ///
    /// # Errors
    /// Bad sky parameters ([`crate::Error::Input`]).
    pub fn frame(&self, at: &StepTime, spec: &SkySpec) -> Result<Frame> {
        let mut step = self.engine.step(at, spec, None, false)?;
        let sky = step.sky.take().expect("a step builds its sky");
        let mut frame = self.gather(step, &sky);
        frame.step.sky = Some(sky);
        Ok(frame)
    }

    /// Renders a sky already built (tests, and skies given in code).
    pub fn frame_sky(&self, sky: &Sky, report: Report) -> Frame {
        let step = self.engine.step_sky(sky, None, false, report, None);
        self.gather(step, sky)
    }

    fn gather(&self, step: Step, sky: &Sky) -> Frame {
        let t0 = Instant::now();
        let solution = Solution {
            sky,
            transport: self.engine.operator().zip(step.state.as_ref()),
            iteration_error: step
                .report
                .transport_solve
                .map_or(0.0, |r| r.iteration_error),
        };
        let image = self.geometry.frame(self.engine.tracer(), &solution);
        Frame {
            image,
            step,
            gather_seconds: t0.elapsed().as_secs_f64(),
        }
    }
}

/// One frame to render: when, under which sky, and its name.
#[derive(Clone, Debug)]
pub struct FramePlan {
    /// The instant.
    pub at: StepTime,
    /// The sky.
    pub spec: SkySpec,
    /// Local standard time, `YYYY-MM-DDTHH:MM` (labels, frames.csv).
    pub label: String,
    /// File stem, by local time: `YYYYMMDD_HHMM`.
    pub name: String,
}

impl FramePlan {
    /// The frame at `at` under `spec`, named by its local time.
    pub fn new(at: StepTime, spec: SkySpec) -> FramePlan {
        FramePlan {
            label: at.local.format("%Y-%m-%dT%H:%M").to_string(),
            name: at.local.format("%Y%m%d_%H%M").to_string(),
            at,
            spec,
        }
    }
}

/// The frames of a weather file between two dates (inclusive, `None`: open), with what
/// was left out: (frames, night steps skipped, missing records skipped). Night is a step
/// with no diffuse light and no sun above the horizon, as in annual runs.
pub fn plan_weather(
    scene: &Scene,
    weather: &Weather,
    start: Option<NaiveDate>,
    end: Option<NaiveDate>,
) -> (Vec<FramePlan>, usize, usize) {
    let (mut frames, mut night, mut missing) = (Vec::new(), 0, 0);
    for r in &weather.records {
        let d = r.time.date();
        if start.is_some_and(|s| d < s) || end.is_some_and(|e| d > e) {
            continue;
        }
        if r.missing {
            missing += 1;
            continue;
        }
        let utc = r.utc(&scene.site);
        let sun = solar_position(utc, &scene.site);
        if r.dhi <= 0.0 && (r.dni <= 0.0 || sun.altitude_deg() <= 0.0) {
            night += 1;
            continue;
        }
        let spec = SkySpec::Perez {
            dni: r.dni,
            dhi: r.dhi,
            dew_point_c: r.dew_point_c,
        };
        frames.push(FramePlan::new(StepTime { utc, local: r.time }, spec));
    }
    (frames, night, missing)
}

/// One written frame, as `frames.csv` lists it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameRow {
    /// File stem.
    pub name: String,
    /// Local standard time.
    pub time_local: String,
    /// UTC, RFC 3339.
    pub time_utc: String,
    /// Sky description.
    pub sky: String,
    /// Mean photometric value over valid pixels (cd/m² or lux).
    pub mean: f64,
    /// Mean stated error over valid pixels, same unit.
    pub mean_err: f64,
    /// Daylight glare probability (angular fisheye renders with glare asked), else NaN.
    pub dgp: f64,
    /// Vertical eye illuminance of the glare evaluation, lux (else NaN).
    pub ev_lux: f64,
    /// Wall time of the frame (step + gather + files), s.
    pub seconds: f64,
}

#[allow(dead_code)] // used by the runner (next commit)
const FRAMES_HEADER: &str = "frame,time_local,time_utc,sky,mean,mean_err,dgp,ev_lux,seconds";

impl FrameRow {
    #[allow(dead_code)] // used by the runner (next commit)
    fn csv(&self) -> String {
        format!(
            "{},{},{},\"{}\",{:.6},{:.6},{:.4},{:.3},{:.3}",
            self.name,
            self.time_local,
            self.time_utc,
            self.sky.replace('"', "'"),
            self.mean,
            self.mean_err,
            self.dgp,
            self.ev_lux,
            self.seconds
        )
    }
}

/// Reads the frames a previous run of the same folder finished (`frames.csv`), by name.
#[allow(dead_code)] // used by the runner (next commit)
fn finished_frames(out: &Path) -> Result<Vec<(String, String)>> {
    let path = out.join("frames.csv");
    if !path.exists() {
        return Ok(Vec::new());
    }
    let text = crate::files::read_text(&path)?;
    let mut lines = text.lines();
    if lines.next() != Some(FRAMES_HEADER) {
        return Err(Error::input(
            &path,
            Some(1),
            None,
            "not a daystep frames.csv (header differs): use another --out folder",
        ));
    }
    Ok(lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let name = l.split(',').next().unwrap_or("").to_string();
            (name, l.to_string())
        })
        .collect())
}
