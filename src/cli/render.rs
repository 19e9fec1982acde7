//! `daystep render`: images from the solution, one instant or a weather file's sequence.

use super::args::{RenderArgs, SkyArg};
use super::config;
use super::messages::{note, warnings};
use crate::error::{Error, Result};
use crate::render::falsecolor::Falsecolor;
use crate::render::glare::{GlareOptions, Threshold};
use crate::render::{Quantity, RenderOptions};
use crate::scene::view::View;
use crate::scene::Scene;
use crate::sequence::annual::RunControl;
use crate::sequence::render::{plan_weather, run_render, Camera, FramePlan, RenderOutputs};
use crate::sequence::StepTime;
use std::path::Path;

/// The camera of the arguments: the scene's view `--view-name`, then `--vf`, then `--view`
/// over it. Each must set a view option (a view file that sets none is refused, as rpict
/// refuses a "bad view file").
fn view(a: &RenderArgs, scene: Option<&Scene>) -> Result<View> {
    let mut v = View::default();
    if let (Some(name), Some(scene)) = (&a.view_name, scene) {
        let views = &scene.imported.views;
        v = match views.iter().find(|v| &v.identifier == name) {
            Some(named) => named.view,
            None => {
                let names: Vec<&str> = views.iter().map(|v| v.identifier.as_str()).collect();
                return Err(Error::arg(
                    "--view-name",
                    name,
                    if names.is_empty() {
                        "the scene has no named views (only an HBJSON model brings them)"
                            .to_string()
                    } else {
                        format!("no such view; the model's views are: {}", names.join(", "))
                    },
                ));
            }
        };
    }
    if let Some(f) = &a.vf {
        v = View::read_file(f)?;
    }
    if let Some(text) = &a.view {
        v = v.with_options(text, Path::new("<argument --view>"), None)?;
    }
    if a.vf.is_none() && a.view.is_none() && a.view_name.is_none() {
        return Err(Error::arg(
            "--view",
            "",
            "give the camera with --view \"-vtv -vp … -vd …\", --vf FILE.vf or --view-name \
             NAME",
        ));
    }
    Ok(v)
}

/// Runs `daystep render` into `--out`; a rerun with the same folder continues.
///
/// # Errors
/// Bad arguments, view, scene or weather ([`Error::Input`]), unwritable output;
/// [`Error::Interrupted`] after Ctrl-C, once the finished frames are written.
pub fn run(a: RenderArgs, limits: &config::Limits) -> Result<()> {
    let q = config::quality(&a.run.quality, a.run.seed)?;
    // Every number of the flags was checked when they were parsed; the image's area and
    // the camera are checked here, before the scene is read (a named view once it is).
    let (width, height) = config::image_size(a.width, a.height)?;
    let early = view(&a, None)?;
    let mut scene = config::load_scene(&a.scene, &a.run)?;
    let mut camera = Camera {
        view: early,
        options: RenderOptions {
            width,
            height,
            samples: a.samples,
            gather_rays: a.gather,
            quantity: if a.irradiance {
                Quantity::Irradiance
            } else {
                Quantity::Radiance
            },
            seed: q.transport.seed,
            ..RenderOptions::default()
        },
    };
    if a.view_name.is_some() {
        camera.view = view(&a, Some(&scene))?;
    }
    let mut skipped = Vec::new();
    let frames: Vec<FramePlan> = match (&a.weather, &a.time) {
        (Some(path), _) => {
            let mut weather = crate::weather::read_weather(path)?;
            scene.take_site_if_missing(weather.site, &path.display().to_string());
            warnings(&scene.warnings);
            if let Some(step) = a.step {
                weather = crate::weather::resample(&weather, step)?;
            }
            warnings(&weather.warnings);
            let day = |flag: &str, v: &Option<String>| -> Result<_> {
                v.as_deref()
                    .map(|v| config::date(flag, v).map(|d| weather.same_day_in_file_year(d)))
                    .transpose()
            };
            let (frames, night, missing) = plan_weather(
                &scene,
                &weather,
                day("--start", &a.start)?,
                day("--end", &a.end)?,
            );
            if night > 0 {
                skipped.push(format!("{night} night steps"));
            }
            if missing > 0 {
                skipped.push(format!("{missing} records with missing irradiance"));
            }
            frames
        }
        (None, Some(t)) => {
            warnings(&scene.warnings);
            let sky = a
                .sky
                .ok_or_else(|| Error::arg("--sky", "", "--time needs --sky"))?;
            let (utc, local) = crate::site::parse_time(t, scene.site.utc_offset_h)?;
            if sky == SkyArg::Image {
                let built = config::image_sky(&a.params, scene.ground_reflectance)?;
                let mut plan =
                    FramePlan::new(StepTime { utc, local }, crate::sequence::SkySpec::None);
                plan.sky = Some(std::sync::Arc::new(built));
                // The image's content, not its name, decides whether a frame can resume.
                let image = a.params.image.as_deref().unwrap_or(Path::new(""));
                let bytes = std::fs::read(image).map_err(|e| Error::io(image, e))?;
                plan.sky_inputs = format!(
                    "image {} {:?} {:?} {:?}",
                    blake3::hash(&bytes).to_hex(),
                    a.params.mapping,
                    a.params.rotate,
                    a.params.dni
                );
                vec![plan]
            } else {
                let spec = config::sky_spec(sky, &a.params)?;
                vec![FramePlan::new(StepTime { utc, local }, spec)]
            }
        }
        (None, None) => {
            return Err(Error::arg(
                "--time",
                "",
                "give --time T --sky … for one frame, or --weather FILE for a sequence",
            ))
        }
    };
    let outputs = RenderOutputs {
        max_memory: Some(limits.cap.clone()),
        png: Some(a.exposure),
        falsecolor: a.falsecolor.then(|| Falsecolor {
            scale_max: a.scale,
            steps: a.steps,
            log_decades: a.log,
            ..Falsecolor::default()
        }),
        hdr: a.hdr,
        gltf: a.gltf.clone(),
        glare: a.glare.then(|| GlareOptions {
            threshold: match a.glare_threshold {
                Some(t) if t > 100.0 => Threshold::Absolute(t),
                Some(t) => Threshold::TaskFactor(t),
                None => Threshold::TaskFactor(5.0),
            },
            ..GlareOptions::default()
        }),
        command: std::env::args().collect::<Vec<_>>().join(" "),
    };
    super::check_outputs(&a.out, a.gltf.as_deref())?;
    let store = config::store(&a.run.cache, a.run.no_cache, limits.cache_bytes);
    let stop = super::annual::stop_on_ctrl_c();
    let shown = super::progress::Progress::new("frames");
    let progress = |done: usize, total: usize| shown.show(done, total);
    let control = RunControl {
        stop: &stop,
        progress: &progress,
        coefficient_progress: &|_, _| {},
    };
    let r = run_render(
        &scene, &q, &store, &camera, &frames, &a.out, &outputs, &control,
    )?;
    shown.finish();
    warnings(&r.warnings);
    if r.interrupted {
        note!(
            "daystep render: interrupted after {} of {} frames; finished frames are kept in {}. To continue, run the same command again.",
            r.resumed + r.computed,
            r.frames,
            a.out.display()
        );
        return Err(Error::Interrupted);
    }
    let skipped = if skipped.is_empty() {
        String::new()
    } else {
        format!(" ({} skipped)", skipped.join(", "))
    };
    note!(
        "daystep render: {} frames{} ({} rendered, {} resumed), {}×{}, {:.1} s; camera {:.1} s, median step {:.2} s, gather {:.2} s; wrote {}",
        r.frames,
        skipped,
        r.computed,
        r.resumed,
        r.width,
        r.height,
        r.total_seconds,
        r.geometry_seconds,
        r.median_step_seconds,
        r.median_gather_seconds,
        a.out.display()
    );
    Ok(())
}
