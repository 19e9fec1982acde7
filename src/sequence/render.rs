//! Renders (`daystep render`): steps whose output is images. Each step is the one
//! [`Engine::step`], solved forward so its mesh solution exists
//! ([`EngineOptions::mesh_solution`]); the camera's primary hits and gather rays are a
//! [`ViewGeometry`] traced once per run and gathered at every step.

use super::config::{Quality, SkySpec};
use super::report::Report;
use super::step::{Engine, EngineOptions, Step, StepTime};
use crate::cache::{RecordKey, Store};
use crate::error::{Error, Result};
use crate::photometry::EFFICACY_LM_PER_W;
use crate::render::exr::write_exr;
use crate::render::falsecolor::{write_falsecolor_png, Falsecolor};
use crate::render::glare::{glare, GlareOptions};
use crate::render::rgbe::write_hdr;
use crate::render::tonemap::{write_png, Exposure};
use crate::render::{Image, Provenance, Quantity, RenderOptions, Solution, ViewGeometry};
use crate::scene::view::View;
use crate::scene::view::ViewType;
use crate::scene::Scene;
use crate::sky::Sky;
use crate::weather::Weather;
use chrono::NaiveDate;
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::time::Instant;

use super::render_frames::{finished_frames, write_frames_csv};
pub use super::render_frames::{frame_fingerprint, plan_weather, FramePlan, FrameRow};

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
    /// Seconds spent tracing (or reading) the camera's geometry.
    pub geometry_seconds: f64,
    /// Whether the camera's geometry was read from the cache.
    pub geometry_from_cache: bool,
}

/// An engine whose steps keep their mesh solution (renders and glTF frames).
fn mesh_engine<'a>(scene: &'a Scene, quality: &Quality, store: &'a Store) -> Engine<'a> {
    Engine::new(
        scene,
        quality,
        store,
        &EngineOptions {
            mesh_solution: true,
            values_only: false,
            ..EngineOptions::default()
        },
    )
}

/// Version of the camera geometry records: bump when what they hold changes.
// 2: pixels whose samples meet several planes got 4× the gather rays (issue 29).
const VIEW_VERSION: u32 = 2;

/// The cache key of a camera's geometry: the operator's key (geometry, glazing, sensors
/// and the mesh the gather rows index), or the scene's hash without an operator, with the
/// view and every render option that changes the rays.
fn view_key(scene: &Scene, quality: &Quality, camera: &Camera, with_mesh: bool) -> RecordKey {
    let base = if with_mesh {
        super::operator::key(scene, &quality.transport)
            .to_bytes()
            .to_vec()
    } else {
        crate::cache::scene_hash(scene, &Default::default(), b"view without mesh")
            .0
            .to_vec()
    };
    let o = &camera.options;
    let mut h = blake3::Hasher::new();
    h.update(b"daystep view geometry\0");
    h.update(&VIEW_VERSION.to_le_bytes());
    h.update(&base);
    h.update(camera.scene_view(scene).options().as_bytes());
    for x in [
        o.width as u64,
        o.height as u64,
        u64::from(o.samples),
        u64::from(o.gather_rays),
        o.seed,
    ] {
        h.update(&x.to_le_bytes());
    }
    RecordKey {
        scene: crate::cache::SceneHash(*h.finalize().as_bytes()),
        kind: crate::cache::KIND_VIEW,
        direction: 0,
        resolution: o.width as u32,
    }
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
        let engine = mesh_engine(scene, quality, store);
        let t0 = Instant::now();
        let view = camera.scene_view(scene);
        let mesh = engine.operator().map(|t| &t.mesh);
        let key = view_key(scene, quality, camera, mesh.is_some());
        let rows = engine.operator().map_or(0, |t| t.rows());
        let cached = store
            .get(&key)
            .and_then(|r| ViewGeometry::decode(&r, &camera.options, scene.triangles.len(), rows));
        let geometry_from_cache = cached.is_some();
        let geometry = cached.unwrap_or_else(|| {
            let g = ViewGeometry::new(engine.tracer(), &view, mesh, &camera.options);
            if store.is_enabled() {
                store.put(&key, &g.encode(&key));
            }
            g
        });
        Renderer {
            geometry_seconds: t0.elapsed().as_secs_f64(),
            geometry_from_cache,
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

/// What a render run writes besides each frame's EXR.
#[derive(Clone, Debug, Default)]
pub struct RenderOutputs {
    /// Tone-mapped PNG per frame, with this exposure.
    pub png: Option<Exposure>,
    /// Falsecolor PNG per frame (`{frame}_falsecolor.png`).
    pub falsecolor: Option<Falsecolor>,
    /// Radiance HDR picture per frame (`{frame}.hdr`, for rpict/evalglare users).
    pub hdr: bool,
    /// Glare (DGP, vertical eye illuminance) per frame: angular fisheye views only.
    pub glare: Option<GlareOptions>,
    /// The solution mesh with one frame per rendered frame, as glTF binary.
    pub gltf: Option<std::path::PathBuf>,
    /// The command line, for the files' provenance.
    pub command: String,
    /// The memory cap the run was given (reported; `None`: none).
    pub max_memory: Option<crate::memory::MemoryCap>,
}

/// What a render run did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderReport {
    /// daystep version.
    pub version: String,
    /// Scene file.
    pub scene: String,
    /// The view, Radiance options (model frame).
    pub view: String,
    /// Image size, pixels.
    pub width: usize,
    /// Image size, pixels.
    pub height: usize,
    /// Primary rays per pixel.
    pub samples: u32,
    /// Gather rays per pixel.
    pub gather_rays: u32,
    /// What the pixels hold: "radiance" or "irradiance".
    pub quantity: String,
    /// Quality preset.
    pub quality: String,
    /// Frames planned.
    pub frames: usize,
    /// Frames rendered by this run.
    pub computed: usize,
    /// Frames a previous run of the folder had finished.
    pub resumed: usize,
    /// Stopped by the caller before the end.
    pub interrupted: bool,
    /// Rays traced for the camera's geometry (primary, mirror and gather rays).
    pub geometry_rays: u64,
    /// Bytes the camera's geometry holds.
    pub geometry_bytes: usize,
    /// Seconds tracing (or reading) it.
    pub geometry_seconds: f64,
    /// Whether it was read from the cache.
    pub geometry_from_cache: bool,
    /// Seconds of the engine's set-up (operator).
    pub setup_seconds: f64,
    /// Per rendered frame: wall time of the step, s (median).
    pub median_step_seconds: f64,
    /// Per rendered frame: wall time of the gather, s (median).
    pub median_gather_seconds: f64,
    /// Total wall time, s.
    pub total_seconds: f64,
    /// What was left out and why.
    pub skipped: Vec<String>,
    /// Non-fatal remarks.
    pub warnings: Vec<String>,
    /// How each pixel's `err` is estimated.
    pub error_model: String,
    /// The memory cap and the peak resident memory.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<super::report::MemoryReport>,
}

/// How a pixel's stated error is made (`report.json`).
pub const PIXEL_ERROR_MODEL: &str = "err = 1-sigma of the pixel's gathered light (over its \
    antialiasing samples and the solution's independent parts; filtered pixels: of the local \
    linear fit over their plane) + |gathered interreflection - the same on the mesh one level \
    coarser| / 3 (Richardson, second order) + the solve's relative iteration error x \
    gathered interreflection";

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Renders `frames` into `out`: per frame `{name}.exr` (and the PNGs, HDR and glare
/// asked for in `outputs`), `frames.csv` after every frame, and for sequences a playable
/// `preview.png` (animated) and `preview.html`. A rerun into the same folder skips the
/// frames `frames.csv` lists; frames are independent, so the files are the same.
///
/// # Errors
/// A glare evaluation asked of a view that is not an angular fisheye, bad sky values,
/// unwritable files.
#[allow(clippy::too_many_arguments)]
pub fn run_render(
    scene: &Scene,
    quality: &Quality,
    store: &Store,
    camera: &Camera,
    frames: &[FramePlan],
    out: &Path,
    outputs: &RenderOutputs,
    control: &super::annual::RunControl,
) -> Result<RenderReport> {
    let t0 = Instant::now();
    if outputs.glare.is_some() && camera.view.kind != ViewType::Angular {
        return Err(Error::arg(
            "--glare",
            camera.view.options(),
            "glare needs an angular fisheye view (-vta, e.g. -vh 180 -vv 180)",
        ));
    }
    crate::files::check_output_dir("--out", out)?;
    if let Some(g) = &outputs.gltf {
        crate::files::check_output_file("--gltf", g)?;
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let fingerprints: Vec<String> = frames
        .iter()
        .map(|f| frame_fingerprint(scene, quality, camera, outputs, f))
        .collect();
    let done = finished_frames(out)?;
    // A frame is resumed only when a previous run finished it from the same inputs and
    // its image is still there; any other row is rendered again and replaced.
    let mut changed = 0;
    let mut rows: Vec<(String, String)> = Vec::new();
    for d in done {
        let Some(k) = frames.iter().position(|f| f.name == d.name) else {
            continue;
        };
        if d.inputs != fingerprints[k] {
            changed += 1;
        } else if out.join(format!("{}.exr", d.name)).exists() {
            rows.push((d.name, d.line));
        }
    }
    let mut report = RenderReport {
        version: env!("CARGO_PKG_VERSION").into(),
        scene: scene.path.display().to_string(),
        view: camera.view.options(),
        width: camera.options.width,
        height: camera.options.height,
        samples: camera.options.samples,
        gather_rays: camera.options.gather_rays,
        quantity: match camera.options.quantity {
            Quantity::Radiance => "radiance".into(),
            Quantity::Irradiance => "irradiance".into(),
        },
        quality: quality.name.into(),
        frames: frames.len(),
        error_model: PIXEL_ERROR_MODEL.into(),
        warnings: scene.warnings.clone(),
        ..RenderReport::default()
    };
    if changed > 0 {
        report.warnings.push(format!(
            "{}: {changed} frames were rendered before with other inputs (scene, view, size, \
             sky, quality, seed or outputs) and are rendered again",
            out.display()
        ));
    }
    let todo: Vec<(&FramePlan, &String)> = frames
        .iter()
        .zip(&fingerprints)
        .filter(|(f, _)| !rows.iter().any(|(n, _)| *n == f.name))
        .collect();
    report.resumed = frames.len() - todo.len();
    (control.progress)(report.resumed, frames.len());
    let renderer = (!todo.is_empty()).then(|| Renderer::new(scene, quality, store, camera));
    if let Some(r) = &renderer {
        report.geometry_rays = r.geometry().rays;
        report.geometry_bytes = r.geometry().bytes();
        report.geometry_seconds = r.geometry_seconds;
        report.geometry_from_cache = r.geometry_from_cache;
        report.setup_seconds = r.engine().setup_times().total();
        report
            .warnings
            .extend(r.engine().directions().store().warnings());
    }
    let (mut step_s, mut gather_s) = (Vec::new(), Vec::new());
    let mut gltf_frames = Vec::new();
    for (plan, inputs) in todo {
        if control.stop.load(Ordering::SeqCst) {
            report.interrupted = true;
            break;
        }
        let renderer = renderer.as_ref().expect("made when frames remain");
        let t = Instant::now();
        let mut frame = match &plan.sky {
            Some(sky) => {
                let report = Report {
                    sky: sky.description.clone(),
                    ..Report::default()
                };
                renderer.frame_sky(sky, report)
            }
            None => renderer.frame(&plan.at, &plan.spec)?,
        };
        step_s.push(frame.step.report.stage_seconds.total());
        gather_s.push(frame.gather_seconds);
        for w in &frame.step.report.warnings {
            if !report.warnings.contains(w) {
                report.warnings.push(w.clone());
            }
        }
        for s in &frame.step.report.skipped {
            if !report.skipped.contains(s) {
                report.skipped.push(s.clone());
            }
        }
        frame.image.provenance = Provenance {
            command: outputs.command.clone(),
            view: camera.view.options(),
            time: format!(
                "{} (local standard time), {} UTC",
                plan.label,
                plan.at.utc.to_rfc3339()
            ),
            sky: frame.step.report.sky.clone(),
            software: format!("daystep {}", env!("CARGO_PKG_VERSION")),
        };
        let mut row = write_frame(out, plan, &frame.image, outputs)?;
        if outputs.hdr {
            write_hdr(
                &out.join(format!("{}.hdr", plan.name)),
                &frame.image,
                Some(&camera.view),
            )?;
        }
        if let Some(g) = &outputs.glare {
            let r = glare(&frame.image, &camera.scene_view(scene), g)?;
            row.dgp = r.dgp;
            row.ev_lux = r.ev_lux;
        }
        row.sky = frame.step.report.sky.clone();
        row.seconds = t.elapsed().as_secs_f64();
        row.inputs = inputs.clone();
        if outputs.gltf.is_some() {
            if let (Some(op), Some(st)) = (renderer.engine().operator(), frame.step.state.as_ref())
            {
                let lux = frame.step.sensors.iter().map(|v| v.lux).collect();
                gltf_frames.push(crate::export::gltf::frame_of(
                    op,
                    st,
                    &frame.step.mesh_direct,
                    plan.label.clone(),
                    lux,
                ));
            }
        }
        rows.push((plan.name.clone(), row.csv()));
        write_frames_csv(out, frames, &rows)?;
        report.computed += 1;
        (control.progress)(report.resumed + report.computed, frames.len());
    }
    if frames.len() > 1 && !report.interrupted {
        write_previews(out, frames, outputs)?;
    }
    if let (Some(path), Some(r)) = (&outputs.gltf, &renderer) {
        match r.engine().operator() {
            Some(op) if !gltf_frames.is_empty() => {
                if report.resumed > 0 {
                    report.warnings.push(format!(
                        "{}: holds the {} frames this run rendered, not the {} resumed ones",
                        path.display(),
                        gltf_frames.len(),
                        report.resumed
                    ));
                }
                let sensors: Vec<_> = scene.sensors.iter().map(|s| s.position).collect();
                crate::export::gltf::geometry_of(scene, op).write(path, &gltf_frames, &sensors)?;
            }
            _ => report
                .skipped
                .push("glTF: the scene has no interreflection mesh (every surface black)".into()),
        }
    }
    report.median_step_seconds = median(step_s);
    report.median_gather_seconds = median(gather_s);
    report.total_seconds = t0.elapsed().as_secs_f64();
    report.memory = Some(super::report::MemoryReport::of(
        outputs.max_memory.as_ref().map_or(0, |c| c.bytes),
        outputs.max_memory.as_ref().map_or("none", |c| &c.from),
        None,
    ));
    let json = serde_json::to_string_pretty(&report)
        .map_err(|e| Error::Internal(format!("report serialisation: {e}")))?;
    crate::files::write_atomic(&out.join("report.json"), json.as_bytes())?;
    Ok(report)
}

/// Writes one frame's files (EXR always; PNG, falsecolor as asked) and returns its row.
fn write_frame(
    out: &Path,
    plan: &FramePlan,
    image: &Image,
    outputs: &RenderOutputs,
) -> Result<FrameRow> {
    write_exr(&out.join(format!("{}.exr", plan.name)), image)?;
    if let Some(e) = outputs.png {
        write_png(&out.join(format!("{}.png", plan.name)), image, e)?;
    }
    if let Some(f) = &outputs.falsecolor {
        write_falsecolor_png(&out.join(format!("{}_falsecolor.png", plan.name)), image, f)?;
    }
    let (mut sum, mut err, mut n) = (0.0, 0.0, 0.0);
    for i in 0..image.rgb.len() {
        if image.valid[i] {
            sum += image.photometric(i);
            err += EFFICACY_LM_PER_W * image.err[i];
            n += 1.0;
        }
    }
    let n = f64::max(n, 1.0);
    Ok(FrameRow {
        name: plan.name.clone(),
        time_local: plan.label.clone(),
        time_utc: plan.at.utc.to_rfc3339(),
        mean: sum / n,
        mean_err: err / n,
        dgp: f64::NAN,
        ev_lux: f64::NAN,
        ..FrameRow::default()
    })
}

/// The preview of a sequence, what a person can play: `preview.png` (animated PNG) and
/// `preview.html` (time slider), from each frame's falsecolor map when asked, else its
/// tone-mapped PNG, read back from the folder (so resumed frames take part).
fn write_previews(out: &Path, frames: &[FramePlan], outputs: &RenderOutputs) -> Result<()> {
    let suffix = match (&outputs.falsecolor, outputs.png) {
        (Some(_), _) => "_falsecolor.png",
        (None, Some(_)) => ".png",
        (None, None) => return Ok(()),
    };
    let (mut pages, mut rgba, mut size) = (Vec::new(), Vec::new(), None);
    for f in frames {
        let path = out.join(format!("{}{suffix}", f.name));
        let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
        let (w, h, px) = decode_rgba(&path, &bytes)?;
        if *size.get_or_insert((w, h)) != (w, h) {
            return Err(Error::input(&path, None, None, "frames differ in size"));
        }
        rgba.push(px);
        pages.push((f.label.clone(), bytes));
    }
    let (w, h) = size.unwrap_or((0, 0));
    crate::render::preview::write_apng(
        &out.join("preview.png"),
        w,
        h,
        &rgba,
        std::time::Duration::from_millis(500),
    )?;
    crate::render::preview::write_html(&out.join("preview.html"), &pages, "daystep render")
}

/// The 8-bit RGBA pixels of a PNG daystep wrote.
fn decode_rgba(path: &Path, bytes: &[u8]) -> Result<(usize, usize, Vec<u8>)> {
    let bad =
        |e: String| Error::input(path, None, None, format!("cannot read the frame back: {e}"));
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .map_err(|e| bad(e.to_string()))?;
    let mut buf = vec![0; reader.output_buffer_size().unwrap_or(0)];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    buf.truncate(info.buffer_size());
    let (w, h) = (info.width as usize, info.height as usize);
    let px = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf
            .chunks(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        t => return Err(bad(format!("colour type {t:?}"))),
    };
    Ok((w, h, px))
}

/// The solution mesh of `days` of `weather` as glTF binary at `path`: every lit step of
/// those days solved forward (warm-started within each day) and written as one frame
/// (what `annual --gltf` writes beside its tables). Returns the frames written.
///
/// # Errors
/// Bad weather values, an unwritable file; a black scene has no mesh (an input error
/// naming `path`).
pub fn write_days_gltf(
    scene: &Scene,
    weather: &Weather,
    quality: &Quality,
    store: &Store,
    days: &[NaiveDate],
    path: &Path,
) -> Result<usize> {
    let engine = mesh_engine(scene, quality, store);
    let Some(op) = engine.operator() else {
        return Err(Error::input(
            path,
            None,
            None,
            "glTF: every surface is black, so there is no solution mesh to write",
        ));
    };
    let mut frames = Vec::new();
    for &d in days {
        let (plans, _, _) = plan_weather(scene, weather, Some(d), Some(d));
        let mut state = None;
        for p in plans {
            let step = engine.step(&p.at, &p.spec, state.as_ref(), false)?;
            if let Some(st) = &step.state {
                let lux = step.sensors.iter().map(|v| v.lux).collect();
                frames.push(crate::export::gltf::frame_of(
                    op,
                    st,
                    &step.mesh_direct,
                    p.label.clone(),
                    lux,
                ));
            }
            state = step.state;
        }
    }
    if frames.is_empty() {
        return Err(Error::input(
            path,
            None,
            None,
            "glTF: the chosen days have no lit step in the weather file",
        ));
    }
    let sensors: Vec<_> = scene.sensors.iter().map(|s| s.position).collect();
    crate::export::gltf::geometry_of(scene, op).write(path, &frames, &sensors)?;
    Ok(frames.len())
}
