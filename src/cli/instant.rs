//! `daystep instant`: one instant's illuminance at every sensor.

use super::args::InstantArgs;
use super::config;
use super::messages::{note, warnings};
use crate::error::Result;
use crate::scene::Scene;
use crate::sequence;

/// Runs `daystep instant`: writes `sensors.csv` and `report.json` into `--out` and
/// summarises the run on standard error.
///
/// # Errors
/// Bad arguments or scene ([`crate::Error::Input`]), unwritable output.
pub fn run(a: InstantArgs) -> Result<()> {
    let q = config::quality(&a.run.quality, a.run.seed)?;
    let spec = config::sky_spec(a.sky, &a.params)?;
    let scene = Scene::load(&a.scene)?;
    warnings(&scene.warnings);
    let (utc, local) = crate::site::parse_time(&a.time, scene.site.utc_offset_h)?;
    let store = config::store(&a.run.cache, a.run.no_cache);
    let result = sequence::instant::run_instant_cached(&scene, utc, local, &spec, &q, &store)?;
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
