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

/// An HDR image sky ([`crate::sky::image`]) from `path` (OpenEXR `.exr`, or Radiance
/// `.hdr`/`.pic`) in `mapping`, turned `rotate_deg` clockwise. With `dni` (W/m²) the
/// image's saturated pixels become a sun of that direct-normal irradiance; without, the
/// sun is whatever the image holds. The ground glow is ρ·E_h/π of the image's (and the
/// sun's) horizontal irradiance, as for every sky.
///
/// # Errors
/// An unreadable or unknown file, a pixel that is negative or not finite, a DNI that is
/// not finite and ≥ 0 ([`crate::Error::Input`] naming the file and value).
pub fn image_sky(
    path: &std::path::Path,
    mapping: sky::image::Mapping,
    rotate_deg: f64,
    dni: Option<f64>,
    ground_reflectance: f64,
) -> Result<Sky> {
    use crate::error::Error;
    use crate::photometry::Rgb;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let image = match ext.as_deref() {
        Some("exr") => crate::render::exr::read_exr(path)?,
        Some("hdr" | "pic") => crate::render::rgbe::read_hdr(path)?.0,
        _ => {
            return Err(Error::input(
                path,
                None,
                ext.as_deref(),
                "an image sky must be OpenEXR (.exr) or Radiance HDR (.hdr, .pic)",
            ))
        }
    };
    if let Some((i, v)) = image
        .rgb
        .iter()
        .enumerate()
        .find(|(_, v)| !v.is_finite() || v.min_element() < 0.0)
    {
        return Err(Error::input(
            path,
            None,
            Some(&format!("{v}")),
            format!(
                "pixel ({}, {}) is not a finite, non-negative radiance",
                i % image.width.max(1),
                i / image.width.max(1)
            ),
        ));
    }
    if image.width == 0 || image.height == 0 {
        return Err(Error::input(path, None, None, "the image has no pixels"));
    }
    let (w, h) = (image.width, image.height);
    let mut img =
        sky::image::ImageSky::try_new(w, h, image.rgb, mapping, rotate_deg).ok_or_else(|| {
            Error::input(
                path,
                None,
                Some(&format!("{w} x {h}")),
                "not enough memory to index this sky image (about 400 bytes a pixel); \
                 use a smaller picture",
            )
        })?;
    let mut warnings = Vec::new();
    let sun = match dni {
        Some(d) if !(d.is_finite() && d >= 0.0) => {
            return Err(Error::arg("--dni", d, "must be finite and ≥ 0 W/m²"));
        }
        Some(d) if d > 0.0 => match img.extract_sun() {
            Some(dir) if dir.z > 0.0 => Some(sky::Sun {
                direction: dir,
                normal_irradiance: Rgb::splat(d),
            }),
            _ => {
                warnings.push("image sky: no saturated pixel above the horizon, no sun".into());
                None
            }
        },
        _ => None,
    };
    let e_h = img.horizontal_irradiance()
        + sun.map_or(Rgb::ZERO, |s| s.normal_irradiance * s.direction.z);
    Ok(Sky {
        description: format!(
            "image {} ({}, rotated {rotate_deg}°{})",
            path.display(),
            match mapping {
                sky::image::Mapping::Equirect => "equirect",
                sky::image::Mapping::Angular => "angular",
            },
            dni.map_or(String::new(), |d| format!(
                ", sun from saturated pixels at DNI {d} W/m²"
            ))
        ),
        distribution: Some(Box::new(img)),
        sun,
        ground_radiance: sky::ground_radiance(ground_reflectance, e_h),
        warnings,
    })
}
