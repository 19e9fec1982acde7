//! The last stage of a step: each sensor's value and its stated error, computed in one
//! place for every command.
//!
//! `lux_err` is the sum of: the difference to the direct light one level coarser (sky
//! subdivision, sun grid, sensor visibility; [`super::config::Quality::coarser`]); the
//! difference between per-child and per-node sky radiance; the visibility range of partly
//! visible nodes; [`SKY_NORMALISATION_REL`] of the direct light; the indirect part's 1σ
//! noise (standard error over independent operators); its discretisation (the
//! difference to the indirect light on the mesh one level coarser); and what the iterative
//! solve left (its extrapolated relative iteration error, which grows as ρ/(1 − ρ) near
//! ρ = 1, times the indirect light).

use crate::photometry::lux;
use crate::radiosity::TransportSensor;
use crate::sensors::SensorDirect;

/// Relative accuracy of the sky models' normalisation quadrature (`sky::integrate_horizontal`
/// against fine grids: about 1e-4); part of every stated error.
pub const SKY_NORMALISATION_REL: f64 = 2e-4;

/// How `lux_err` is estimated, in words (`report.json` `error_model`).
pub const ERROR_MODEL: &str = "lux_err = |lux - lux at one coarser level| (sky subdivision \
    depth and thresholds, sun grid spacing x2, visibility depth -1) + |difference between \
    per-child and per-node sky radiance| + sum of the visibility range of partly visible nodes \
    at the deepest split + 2e-4 x lux (sky normalisation quadrature) + the indirect part's \
    1-sigma noise (standard error of the mean over independent line sets and sensor rays) + its \
    discretisation (|indirect - indirect on the mesh one level coarser|) + the solve's \
    extrapolated relative iteration error x indirect";

/// Illuminance at one sensor, lux.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorValue {
    /// Total illuminance: direct (sun + sky + ground glow) + indirect, lux.
    pub lux: f64,
    /// Estimated absolute error of `lux`, lux.
    pub lux_err: f64,
    /// From the sun, lux.
    pub lux_sun: f64,
    /// From the sky and ground glow, lux.
    pub lux_sky: f64,
    /// Reflected by the scene's surfaces (and emitted by `Ke` surfaces), lux.
    pub lux_indirect: f64,
}

impl SensorValue {
    /// A sensor's value from its direct light at the run's quality (`fine`) and one level
    /// coarser (`coarse`), and its interreflected light `indirect` from a solve whose
    /// relative iteration error is `iteration_rel` (dimensionless).
    pub fn estimate(
        fine: &SensorDirect,
        coarse: &SensorDirect,
        indirect: &TransportSensor,
        iteration_rel: f64,
    ) -> SensorValue {
        let direct = lux(fine.sun + fine.sky);
        let diff = (direct - lux(coarse.sun + coarse.sky)).abs();
        let ind = lux(indirect.irradiance);
        SensorValue {
            lux: direct + ind,
            // One coarser level bounds the error of a method converging at least
            // linearly; partly visible nodes add their visibility range.
            lux_err: diff
                + lux(fine.radiance_error).abs()
                + fine.visibility_err_lux
                + SKY_NORMALISATION_REL * direct.abs()
                + lux(indirect.std_err)
                + (ind - lux(indirect.irradiance + indirect.discretisation)).abs()
                + iteration_rel * ind.abs(),
            lux_sun: lux(fine.sun),
            lux_sky: lux(fine.sky),
            lux_indirect: ind,
        }
    }

    /// `lux_err / lux` where the sensor is lit above `floor_lux`, else `None`.
    pub fn relative_error(&self, floor_lux: f64) -> Option<f64> {
        (self.lux > floor_lux).then(|| self.lux_err / self.lux)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::Rgb;

    #[test]
    fn every_error_term_adds_to_the_stated_error() {
        // Grey values: lux(Rgb::splat(x)) = 179 x.
        let fine = SensorDirect {
            sun: Rgb::splat(2.0),
            sky: Rgb::splat(1.0),
            radiance_error: Rgb::splat(-0.01),
            visibility_err_lux: 3.0,
            ..SensorDirect::default()
        };
        let coarse = SensorDirect {
            sun: Rgb::splat(2.0),
            sky: Rgb::splat(0.9),
            ..SensorDirect::default()
        };
        let ind = TransportSensor {
            irradiance: Rgb::splat(0.5),
            std_err: Rgb::splat(0.02),
            discretisation: Rgb::splat(0.03),
        };
        let v = SensorValue::estimate(&fine, &coarse, &ind, 0.01);
        let k = 179.0;
        assert!((v.lux - 3.5 * k).abs() < 1e-9);
        let expect =
            0.1 * k + 0.01 * k + 3.0 + 2e-4 * 3.0 * k + 0.02 * k + 0.03 * k + 0.01 * 0.5 * k;
        assert!(
            (v.lux_err - expect).abs() < 1e-9,
            "{} vs {expect}",
            v.lux_err
        );
        assert_eq!(v.relative_error(1e9), None);
    }
}
