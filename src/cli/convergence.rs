//! `daystep convergence`: error against run time of every quality knob on one instant of
//! the user's scene, the instant given as for `instant` or as a weather file's sunniest
//! record.

use super::args::ConvergenceArgs;
use super::config;
use super::messages::{note, say};
use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::sequence::convergence;
use crate::sequence::SkySpec;
use chrono::{DateTime, NaiveDateTime, Utc};

/// The instant studied: UTC, local standard time, sky, and its description for the
/// terminal and `report.json`.
type Studied = (DateTime<Utc>, NaiveDateTime, SkySpec, String);

/// The instant of `--weather FILE` (its sunniest record under a Perez sky) or of `--time`
/// with `--sky`.
fn instant(a: &ConvergenceArgs, scene: &Scene) -> Result<Studied> {
    match (&a.weather, &a.time, a.sky) {
        (Some(w), _, _) => {
            let weather = crate::weather::read_weather(w)?;
            let r = weather
                .sunniest_record(&scene.site)
                .ok_or_else(|| Error::input(w, None, None::<&str>, "no usable weather record"))?;
            let spec = SkySpec::Perez {
                dni: r.dni,
                dhi: r.dhi,
                dew_point_c: r.dew_point_c,
            };
            let what = format!(
                "{} line {}: {} (DNI {} W/m², DHI {} W/m²)",
                w.display(),
                r.line,
                r.time,
                r.dni,
                r.dhi
            );
            Ok((r.utc(&scene.site), r.time, spec, what))
        }
        (None, Some(t), Some(sky)) => {
            let spec = config::sky_spec(sky, &a.params)?;
            let (utc, local) = crate::site::parse_time(t, scene.site.utc_offset_h)?;
            let what = format!("{t}, {spec:?}");
            Ok((utc, local, spec, what))
        }
        _ => Err(Error::arg(
            "--time/--sky",
            "(missing)",
            "give --time and --sky (as for `instant`), or --weather FILE",
        )),
    }
}

/// Runs `daystep convergence`: progress on standard error, `convergence.csv`,
/// `convergence.svg` and `report.json` into `--out`, the recommendation on standard
/// output.
///
/// # Errors
/// Bad arguments, scene or weather file ([`Error::Input`]), unwritable output.
pub fn run(a: ConvergenceArgs) -> Result<()> {
    let base = config::quality(&a.quality, a.seed)?;
    let target = config::target(a.target)?;
    let scene = Scene::load(&a.scene)?;
    if scene.sensors.is_empty() {
        return Err(Error::input(
            &a.scene,
            None,
            None::<&str>,
            "the scene has no sensors: convergence measures sensor illuminance",
        ));
    }
    let (utc, local, spec, what) = instant(&a, &scene)?;
    note!("daystep convergence: {what}");
    let ladders = config::knobs(convergence::ladders(&base), a.knobs.as_deref())?;
    super::check_outputs(&a.out, None)?;
    let show = |done: usize, total: usize, knob: &str, setting: &str| {
        if !knob.is_empty() {
            note!("  [{:>3}/{total}] {knob}: {setting}", done + 1);
        }
    };
    let rungs = convergence::run_convergence(
        &scene,
        utc,
        local,
        &spec,
        &ladders,
        a.repeats as usize,
        &show,
    )?;
    let advice = convergence::write_convergence(&a.out, &a.scene, &what, &base, target, &rungs)?;
    say!("{advice}")?;
    note!("wrote {}", a.out.display());
    Ok(())
}
