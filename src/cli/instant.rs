//! `daystep instant`: one instant's illuminance at every sensor.

use super::args::{InstantArgs, SkyArg};
use super::config;
use super::messages::{note, warnings};
use crate::error::Result;
use crate::sequence;

/// Runs `daystep instant`: writes `sensors.csv` and `report.json` into `--out` and
/// summarises the run on standard error.
///
/// # Errors
/// Bad arguments or scene ([`crate::Error::Input`]), unwritable output.
pub fn run(a: InstantArgs, limits: &config::Limits) -> Result<()> {
    let q = config::quality(&a.run.quality, a.run.seed)?;
    // The sky's flags are checked before the scene is read (an image sky reads its file
    // once the scene's ground reflectance is known).
    let spec = (a.sky != SkyArg::Image)
        .then(|| config::sky_spec(a.sky, &a.params))
        .transpose()?;
    let scene = config::load_scene(&a.scene, &a.run)?;
    warnings(&scene.warnings);
    let (utc, local) = crate::site::parse_time(&a.time, scene.site.utc_offset_h)?;
    super::check_outputs(&a.out, a.gltf.as_deref())?;
    let store = config::store(&a.run.cache, a.run.no_cache, limits.cache_bytes);
    let opts = sequence::EngineOptions {
        mesh_solution: a.gltf.is_some(),
        max_memory_bytes: limits.cap.bytes,
        max_memory_given: limits.cap.given,
        count_elements_only: true,
        ..sequence::EngineOptions::default()
    };
    let mut result = if a.sky == SkyArg::Image {
        let sky = config::image_sky(&a.params, scene.ground_reflectance)?;
        let mut report = sequence::Report {
            version: env!("CARGO_PKG_VERSION").into(),
            command: "instant".into(),
            scene: scene.path.display().to_string(),
            time_local: local.format("%Y-%m-%dT%H:%M:%S").to_string(),
            time_utc: utc.to_rfc3339(),
            quality: q.name.into(),
            sky: sky.description.clone(),
            warnings: scene.warnings.clone(),
            ..sequence::Report::default()
        };
        let t0 = std::time::Instant::now();
        let mut r = sequence::instant::run_sky_cached(&scene, &sky, &q, &store, &opts, &mut report);
        r.report.cache = Some(store.stats());
        r.report.total_seconds = t0.elapsed().as_secs_f64();
        r
    } else {
        let spec = spec.expect("checked above for every sky but an image");
        sequence::instant::run_instant_with(&scene, utc, local, &spec, &q, &store, &opts)?.0
    };
    if let Some(path) = &a.gltf {
        if !sequence::instant::write_instant_gltf(&scene, &result, &a.time, path)? {
            warnings(&[
                "glTF: every surface is black, so there is no solution mesh to write".into(),
            ]);
        }
    }
    result.report.memory = Some(sequence::report::MemoryReport::of(
        limits.cap.bytes,
        &limits.cap.from,
        None,
    ));
    sequence::write_instant(&scene, &result, &a.out)?;
    let r = &result.report;
    warnings(&r.warnings);
    note!(
        "daystep instant: {} sensors, {} sources ({} sky, {} ground, {} sun), {} → {} elements, {:.3} s; max lux_err {:.1} lx; wrote {}",
        r.counts.sensors,
        r.counts.sky_sources + r.counts.ground_sources + r.counts.sun_sources,
        r.counts.sky_sources,
        r.counts.ground_sources,
        r.counts.sun_sources,
        r.counts.elements_before,
        r.counts.elements_after,
        r.total_seconds,
        r.max_lux_err,
        a.out.display()
    );
    Ok(())
}
