//! `daystep df`: the daylight factor at every sensor.

use super::args::DfArgs;
use super::config;
use super::messages::{note, warnings};
use crate::error::Result;
use crate::sequence;

/// Runs `daystep df`: writes `df.csv` and `report.json` into `--out` and summarises the
/// daylight factors (percent) on standard error.
///
/// # Errors
/// Bad arguments or scene ([`crate::Error::Input`]), unwritable output.
pub fn run(a: DfArgs, limits: &config::Limits) -> Result<()> {
    let q = config::quality(&a.run.quality, a.run.seed)?;
    let scene = config::load_scene(&a.scene, &a.run)?;
    warnings(&scene.warnings);
    super::check_outputs(&a.out, None)?;
    let store = config::store(&a.run.cache, a.run.no_cache, limits.cache_bytes);
    let mut result = sequence::df::run_df(&scene, &q, &store)?;
    result.report.instant.memory = Some(sequence::report::MemoryReport::of(
        limits.cap.bytes,
        &limits.cap.from,
        None,
    ));
    sequence::df::write_df(&scene, &result, &a.out)?;
    let r = &result.report;
    warnings(&r.instant.warnings);
    let s = &r.df_summary;
    note!(
        "daystep df: {} sensors, outside {:.0} lx (CIE overcast, unobstructed, no ground); DF mean {:.2} %, min {:.2} %, max {:.2} %, {:.0} % of sensors >= {} %, uniformity {:.2}; max df_err {:.2} %; {:.3} s; wrote {}",
        s.sensors,
        result.outside_lux,
        s.mean_df,
        s.min_df,
        s.max_df,
        100.0 * s.fraction_at_least_threshold,
        s.threshold_df,
        s.uniformity,
        s.max_df_err,
        r.instant.total_seconds,
        a.out.display()
    );
    Ok(())
}
