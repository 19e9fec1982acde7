//! The first stage of a step: the sky of an instant (solar position, sky model) and its
//! parallel sources (the adaptive sky and ground nodes, and the snapped sun).

use super::config::{Quality, SkySpec};
use crate::error::Result;
use crate::site::solar_position::SolarPosition;
use crate::sky::{self, Sky};
use crate::sources::{self, Source};

/// Builds the sky of `spec` for the sun at `sun` on day `day_of_year` (1–366), with a
/// ground of reflectance `ground`.
///
/// # Errors
/// Bad sky parameters ([`crate::Error::Input`]).
pub fn build_sky(
    spec: &SkySpec,
    sun: &SolarPosition,
    day_of_year: u32,
    ground: f64,
) -> Result<Sky> {
    let d = sun.direction();
    match *spec {
        SkySpec::Perez {
            dni,
            dhi,
            dew_point_c,
        } => sky::perez::sky(
            dni,
            dhi,
            d,
            day_of_year,
            dew_point_c.unwrap_or(sky::perez::DEFAULT_DEW_POINT_C),
            ground,
        ),
        SkySpec::CieOvercast { dhi } => sky::cie::sky(
            sky::cie::CieSkyType::TraditionalOvercast,
            dhi,
            0.0,
            d,
            ground,
        ),
        SkySpec::Cie { sky_type, dhi, dni } => {
            sky::cie::sky(sky::cie::CieSkyType::General(sky_type), dhi, dni, d, ground)
        }
        SkySpec::Preetham { turbidity } => sky::preetham::sky(turbidity, d, ground),
        SkySpec::None => Ok(Sky::none()),
    }
}

/// The sources of `sky` at `quality`: sky and ground nodes, then the sun.
pub struct SkySources {
    /// Sources in order (the sun last, when it is one).
    pub sources: Vec<Source>,
    /// Sky nodes left out as negligible.
    pub negligible: usize,
    /// Angle between the true and the snapped sun, degrees, when the sun is a source.
    pub sun_snapping_deg: Option<f64>,
}

/// Subdivides `sky` into parallel sources at `quality`.
pub fn sources_for(sky: &Sky, quality: &Quality) -> SkySources {
    let s = sources::sky_sources(sky, &quality.sky);
    let mut list = s.sources;
    let mut snap = None;
    if let Some((sun, e)) = sources::sun_source(sky, quality.sun_spacing_deg) {
        list.push(sun);
        snap = Some(e);
    }
    SkySources {
        sources: list,
        negligible: s.negligible,
        sun_snapping_deg: snap,
    }
}
