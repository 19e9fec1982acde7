//! Daylight factor (`daystep df`): the sensors' illuminance under the traditional CIE
//! overcast sky (Moon–Spencer, no sun) as a percentage of the horizontal illuminance of the
//! same sky, unobstructed and without ground.
//!
//! DF = 100 × E_inside / E_outside, where E_inside is a sensor's total illuminance (direct
//! sky + ground glow + interreflection, as [`super::instant`] computes it) and E_outside is
//! the sky's horizontal illuminance alone (the upper hemisphere's radiance integrated
//! against cos θ; no ground glow, no sun). Being a ratio, DF does not depend on the sky's
//! absolute level, so the run uses a fixed [`DF_DHI_W_M2`]; nor on the date and time,
//! since the overcast sky has no sun and a shape that does not depend on the sun's
//! position, so it uses a fixed instant ([`DF_TIME_LOCAL`]), whatever the sun's altitude
//! there.

use super::config::{Quality, SkySpec};
use super::instant::{run_instant_with_sky, SensorValue};
use super::report::Report;
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::photometry::lux;
use crate::scene::Scene;
use serde::Serialize;
use std::path::Path;

/// Diffuse horizontal irradiance of the overcast sky of a DF run, W/m² (its horizontal
/// illuminance is 179 lm/W × this, 17 900 lx). Any positive value gives the same DF.
pub const DF_DHI_W_M2: f64 = 100.0;

/// Local standard time of the site at which a DF run evaluates the sky (the overcast sky
/// does not depend on it; the sun may be below the horizon there).
pub const DF_TIME_LOCAL: &str = "2021-03-21T12:00";

/// DF threshold of the summary's `fraction_at_least_threshold`, percent.
pub const DF_THRESHOLD_PERCENT: f64 = 2.0;

/// Daylight factor at one sensor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SensorDf {
    /// Daylight factor, percent: 100 × lux / E_outside.
    pub df: f64,
    /// Estimated absolute error of `df`, percent (the instant's `lux_err` scaled the same
    /// way).
    pub df_err: f64,
}

/// Summary statistics over the sensors (each sensor counts once; no area weighting).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct DfSummary {
    /// Number of sensors.
    pub sensors: usize,
    /// Mean DF, percent.
    pub mean_df: f64,
    /// Smallest DF, percent.
    pub min_df: f64,
    /// Largest DF, percent.
    pub max_df: f64,
    /// The threshold of `fraction_at_least_threshold`, percent ([`DF_THRESHOLD_PERCENT`]).
    pub threshold_df: f64,
    /// Fraction of sensors (0–1) with DF ≥ `threshold_df`.
    pub fraction_at_least_threshold: f64,
    /// Uniformity: min DF / mean DF (dimensionless, 0–1; NaN, written as null, when the mean
    /// is 0).
    pub uniformity: f64,
    /// Mean `df_err`, percent.
    pub mean_df_err: f64,
    /// Largest `df_err`, percent.
    pub max_df_err: f64,
}

impl DfSummary {
    /// Statistics of `values`; all NaN (counts zero) when there are none.
    pub fn of(values: &[SensorDf]) -> DfSummary {
        let n = values.len();
        if n == 0 {
            return DfSummary {
                threshold_df: DF_THRESHOLD_PERCENT,
                mean_df: f64::NAN,
                min_df: f64::NAN,
                max_df: f64::NAN,
                fraction_at_least_threshold: f64::NAN,
                uniformity: f64::NAN,
                mean_df_err: f64::NAN,
                max_df_err: f64::NAN,
                sensors: 0,
            };
        }
        let mean = |f: fn(&SensorDf) -> f64| values.iter().map(f).sum::<f64>() / n as f64;
        let mean_df = mean(|v| v.df);
        let min_df = values.iter().map(|v| v.df).fold(f64::INFINITY, f64::min);
        DfSummary {
            sensors: n,
            mean_df,
            min_df,
            max_df: values
                .iter()
                .map(|v| v.df)
                .fold(f64::NEG_INFINITY, f64::max),
            threshold_df: DF_THRESHOLD_PERCENT,
            fraction_at_least_threshold: values
                .iter()
                .filter(|v| v.df >= DF_THRESHOLD_PERCENT)
                .count() as f64
                / n as f64,
            uniformity: if mean_df > 0.0 {
                min_df / mean_df
            } else {
                f64::NAN
            },
            mean_df_err: mean(|v| v.df_err),
            max_df_err: values.iter().map(|v| v.df_err).fold(0.0, f64::max),
        }
    }
}

/// `report.json` of a DF run: the instant's report (its fields at the top level) plus the
/// outside illuminance and the summary.
#[derive(Clone, Debug, Default, Serialize)]
pub struct DfReport {
    /// The report of the overcast instant the DF comes from (`command` = `df`).
    #[serde(flatten)]
    pub instant: Report,
    /// Diffuse horizontal irradiance of the overcast sky used, W/m².
    pub sky_dhi_w_m2: f64,
    /// E_outside, lux: horizontal illuminance of the unobstructed sky alone (no ground, no
    /// sun), integrated from the same sky object the sensors saw.
    pub outside_illuminance_lux: f64,
    /// What E_outside and DF are, in words.
    pub df_definition: String,
    /// Statistics over the sensors.
    pub df_summary: DfSummary,
}

/// Everything a DF run produces.
#[derive(Clone, Debug)]
pub struct DfResult {
    /// Daylight factor per sensor, in .pts order, percent.
    pub sensors: Vec<SensorDf>,
    /// The sensors' illuminance under the overcast sky of the run (E_inside and its parts),
    /// lux, in .pts order.
    pub inside: Vec<SensorValue>,
    /// E_outside, lux (also in the report).
    pub outside_lux: f64,
    /// The report (with the summary).
    pub report: DfReport,
}

/// Daylight factor at every sensor of `scene`: one instant under the traditional CIE
/// overcast sky of [`DF_DHI_W_M2`] at [`DF_TIME_LOCAL`], divided by that sky's
/// unobstructed horizontal illuminance. Projections, sensor responses and the
/// interreflection operator go through `store` as in an instant.
///
/// # Errors
/// [`Error::Input`] naming the scene file when it has no sensors; any error of the instant.
pub fn run_df(scene: &Scene, quality: &Quality, store: &Store) -> Result<DfResult> {
    if scene.sensors.is_empty() {
        return Err(Error::input(
            &scene.path,
            None,
            None,
            "the scene has no sensors: a daylight factor needs a `sensors` file (.pts) in the scene file",
        ));
    }
    let (utc, local) = crate::site::parse_time(DF_TIME_LOCAL, scene.site.utc_offset_h)?;
    let spec = SkySpec::CieOvercast { dhi: DF_DHI_W_M2 };
    let (instant, sky) = run_instant_with_sky(scene, utc, local, &spec, quality, store)?;
    let outside_lux = sky
        .distribution
        .as_deref()
        .map_or(0.0, |d| lux(crate::sky::horizontal_irradiance(d)));
    if sky.sun.is_some() || !(outside_lux.is_finite() && outside_lux > 0.0) {
        return Err(Error::Internal(format!(
            "daylight factor: the overcast sky has a sun or no light (outside {outside_lux} lx)"
        )));
    }
    let sensors: Vec<SensorDf> = instant
        .sensors
        .iter()
        .map(|v| SensorDf {
            df: crate::metrics::daylight_factor(v.lux, outside_lux),
            df_err: crate::metrics::daylight_factor(v.lux_err, outside_lux),
        })
        .collect();
    let df_summary = DfSummary::of(&sensors);
    let mut report = instant.report;
    report.command = "df".into();
    let report = DfReport {
        instant: report,
        sky_dhi_w_m2: DF_DHI_W_M2,
        outside_illuminance_lux: outside_lux,
        df_definition: "df = 100 x lux / outside_illuminance_lux, percent; lux = the sensor's \
            total illuminance (direct sky + ground glow + interreflection) under the \
            traditional CIE overcast sky; outside_illuminance_lux = the horizontal \
            illuminance of the same sky unobstructed, without ground glow or sun; df_err = \
            100 x lux_err / outside_illuminance_lux"
            .into(),
        df_summary,
    };
    Ok(DfResult {
        sensors,
        inside: instant.sensors,
        outside_lux,
        report,
    })
}

/// Writes `df.csv` (`sensor,x,y,z,df,df_err`, percent, .pts order and coordinates) and
/// `report.json` into `out` (atomically, each).
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written.
pub fn write_df(scene: &Scene, result: &DfResult, out: &Path) -> Result<()> {
    let mut csv = String::from("sensor,x,y,z,df,df_err\n");
    for (k, (s, v)) in scene.sensors.iter().zip(&result.sensors).enumerate() {
        let p = s.input_position;
        csv.push_str(&format!(
            "{k},{},{},{},{:.6},{:.6}\n",
            p.x, p.y, p.z, v.df, v.df_err
        ));
    }
    crate::files::write_atomic(&out.join("df.csv"), csv.as_bytes())?;
    let json = serde_json::to_string_pretty(&result.report)
        .map_err(|e| Error::Internal(format!("report serialisation: {e}")))?;
    crate::files::write_atomic(&out.join("report.json"), json.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_statistics() {
        let v = [1.0, 2.0, 3.0, 6.0].map(|df| SensorDf {
            df,
            df_err: df / 10.0,
        });
        let s = DfSummary::of(&v);
        assert_eq!(s.sensors, 4);
        assert_eq!(s.mean_df, 3.0);
        assert_eq!((s.min_df, s.max_df), (1.0, 6.0));
        assert_eq!(s.fraction_at_least_threshold, 0.75); // 2.0 counts (≥)
        assert!((s.uniformity - 1.0 / 3.0).abs() < 1e-15);
        assert!((s.mean_df_err - 0.3).abs() < 1e-15);
        assert!((s.max_df_err - 0.6).abs() < 1e-15);
        let dark = DfSummary::of(&[SensorDf::default(); 2]);
        assert!(dark.uniformity.is_nan());
        assert_eq!(dark.fraction_at_least_threshold, 0.0);
        assert!(DfSummary::of(&[]).mean_df.is_nan());
    }

    #[test]
    fn report_keeps_the_instant_fields_at_the_top_level() {
        let r = DfReport {
            instant: Report {
                command: "df".into(),
                ..Report::default()
            },
            outside_illuminance_lux: 17_900.0,
            ..DfReport::default()
        };
        let v: serde_json::Value = serde_json::to_value(&r).unwrap();
        assert_eq!(v["command"], "df");
        assert!(v["counts"].is_object());
        assert_eq!(v["outside_illuminance_lux"], 17_900.0);
        assert!(v["df_summary"]["mean_df"].is_number());
    }

    #[test]
    fn scene_without_sensors_is_an_input_error_naming_the_file() {
        let scene = Scene::from_model(
            Path::new("room/scene.toml"),
            crate::scene::ModelInput::default(),
        )
        .unwrap();
        let e = run_df(&scene, &Quality::default(), &Store::disabled()).unwrap_err();
        let (shown, path, _, _) = crate::error::input_parts(e);
        assert_eq!(path, Path::new("room/scene.toml"));
        assert!(shown.contains("no sensors"), "{shown}");
    }
}
