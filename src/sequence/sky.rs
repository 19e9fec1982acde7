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
#[derive(Debug, PartialEq)]
pub struct SkySources {
    /// Sources in order (the sun last, when it is one).
    pub sources: Vec<Source>,
    /// Sky nodes left out as negligible.
    pub negligible: usize,
    /// Angle between the true and the snapped sun, degrees, when the sun is a source.
    pub sun_snapping_deg: Option<f64>,
    /// The sources at the coarser quality of the error estimate (sun last), when they were
    /// cut in the same walk ([`sources_with_coarse`]); the same as [`sources_for`] there.
    pub coarse: Option<Vec<Source>>,
}

/// Subdivides `sky` into parallel sources at `quality`.
pub fn sources_for(sky: &Sky, quality: &Quality) -> SkySources {
    cut(sky, quality, None)
}

/// [`sources_for`] at `quality` with [`SkySources::coarse`] at `coarse` (the error
/// estimate's level), both in one walk of the sky: a step of an annual run needs both,
/// and the coarser cut visits only nodes the finer one evaluates.
pub fn sources_with_coarse(sky: &Sky, quality: &Quality, coarse: &Quality) -> SkySources {
    cut(sky, quality, Some(coarse))
}

fn cut(sky: &Sky, quality: &Quality, coarse: Option<&Quality>) -> SkySources {
    let levels: Vec<sources::SkyParams> = std::iter::once(quality.sky)
        .chain(coarse.map(|c| c.sky))
        .collect();
    let mut cuts = sources::sky_sources_levels(sky, &levels);
    let coarse = coarse.map(|c| {
        let mut list = cuts.pop().expect("the coarse cut").sources;
        list.extend(sources::sun_source(sky, c.sun_spacing_deg).map(|(sun, _)| sun));
        list
    });
    let s = cuts.pop().expect("the cut");
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
        coarse,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::site::direction_from_alt_az;

    #[test]
    fn one_walk_cuts_both_levels_as_two_walks_do() {
        // A clear sky with a low sun (steep gradients at the horizon and around the sun),
        // an overcast one, and a dark one, at every preset: the coarse cut made in the
        // fine cut's walk must be the same sources, bit for bit and in order.
        let skies = [
            crate::sky::perez::sky(
                850.0,
                90.0,
                direction_from_alt_az(8.0, 120.0),
                172,
                5.0,
                0.2,
            ),
            crate::sky::perez::sky(0.0, 300.0, direction_from_alt_az(40.0, 200.0), 80, 2.0, 0.2),
            crate::sky::perez::sky(0.0, 0.0, direction_from_alt_az(20.0, 90.0), 10, 0.0, 0.2),
        ];
        for sky in skies {
            let sky = sky.expect("valid sky");
            for name in ["draft", "default", "high", "reference"] {
                let q = Quality::preset(name).expect("preset");
                let c = q.coarser();
                let both = sources_with_coarse(&sky, &q, &c);
                let (fine, coarse) = (sources_for(&sky, &q), sources_for(&sky, &c));
                assert_eq!(both.sources, fine.sources, "{name}");
                assert_eq!(both.negligible, fine.negligible, "{name}");
                assert_eq!(both.sun_snapping_deg, fine.sun_snapping_deg, "{name}");
                assert_eq!(both.coarse.as_ref(), Some(&coarse.sources), "{name}");
                assert!(fine.coarse.is_none());
            }
        }
    }
}
