//! Tone-mapped 8-bit sRGB images for people to look at: an exposure multiplier on the
//! linear values, clamping to [0, 1], and the sRGB transfer curve.
//!
//! The exposure means what Radiance's `pfilt -e` and the picture header's `EXPOSURE` mean:
//! a plain multiplier on the pixel values (radiance W·sr⁻¹·m⁻², or irradiance W/m²), after
//! which 1.0 is display white. So `Exposure::Given(1.0)` shows 1 W·sr⁻¹·m⁻² (179 cd/m²) as
//! white.

use crate::error::{Error, Result};
use crate::files;
use crate::photometry::{Rgb, EFFICACY_LM_PER_W};
use crate::render::image::Image;
use std::path::Path;

/// How bright a tone-mapped image is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exposure {
    /// Scale so that the log-average (geometric mean) photometric value of the valid,
    /// non-black pixels becomes linear 18 % grey (0.18 before the sRGB curve, sRGB 8-bit
    /// 118): the multiplier is `0.18 × 179 / exp(mean(ln L))` with `L` = 179 × grey in
    /// cd/m² or lux. Black, non-finite and invalid pixels are left out of the mean; an
    /// image with no such pixel gets the multiplier 1.
    Auto,
    /// A multiplier on the linear values (radiance W·sr⁻¹·m⁻² or irradiance W/m²), as
    /// Radiance's `pfilt -e` takes it (not in stops): 2.0 doubles every value.
    Given(f64),
}

/// The linear multiplier that `exposure` applies to `image` (see [`Exposure`]).
pub fn multiplier(image: &Image, exposure: Exposure) -> f64 {
    match exposure {
        Exposure::Given(m) => m,
        Exposure::Auto => {
            let (mut sum, mut count) = (0.0, 0usize);
            for i in 0..image.rgb.len() {
                let l = image.photometric(i);
                if image.valid[i] && l.is_finite() && l > 0.0 {
                    sum += l.ln();
                    count += 1;
                }
            }
            if count == 0 {
                1.0
            } else {
                0.18 * EFFICACY_LM_PER_W / (sum / count as f64).exp()
            }
        }
    }
}

/// The sRGB transfer curve (IEC 61966-2-1) from linear [0, 1] to encoded [0, 1]; values
/// outside [0, 1] are clamped first.
pub fn srgb_encode(linear: f64) -> f64 {
    let c = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// An sRGB-encoded 8-bit value of a linear display value (clamped to [0, 1]).
pub fn srgb8(linear: f64) -> u8 {
    (srgb_encode(linear) * 255.0).round() as u8
}

/// Linear display values (1.0 = white, not yet clamped) of every pixel after `exposure`;
/// invalid pixels are 0.
pub fn exposed(image: &Image, exposure: Exposure) -> Vec<Rgb> {
    let m = multiplier(image, exposure);
    image
        .rgb
        .iter()
        .zip(&image.valid)
        .map(|(&c, &ok)| if ok { c * m } else { Rgb::ZERO })
        .collect()
}

/// The tone-mapped image as 8-bit sRGB RGBA, row-major from the top-left pixel, alpha 255
/// everywhere; invalid pixels black.
pub fn to_rgba8(image: &Image, exposure: Exposure) -> Vec<u8> {
    exposed(image, exposure)
        .into_iter()
        .flat_map(|c| [srgb8(c.x), srgb8(c.y), srgb8(c.z), 255])
        .collect()
}

/// Encodes 8-bit RGBA pixels (row-major from the top-left, `width × height × 4` bytes) as
/// a PNG marked sRGB, with `text` as (keyword, UTF-8 value) `iTXt` chunks.
///
/// # Errors
/// [`Error::Internal`] when the buffer does not match the size or the encoder fails.
pub fn encode_png(
    width: usize,
    height: usize,
    rgba: &[u8],
    text: &[(&str, &str)],
) -> Result<Vec<u8>> {
    if rgba.len() != width * height * 4 {
        return Err(Error::Internal(format!(
            "{} bytes of RGBA for a {width}×{height} image",
            rgba.len()
        )));
    }
    let fail = |e: png::EncodingError| Error::Internal(format!("PNG encoding failed: {e}"));
    let (w, h) = dims(width, height)?;
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, w, h);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    for (k, v) in text {
        encoder
            .add_itxt_chunk((*k).to_owned(), (*v).to_owned())
            .map_err(fail)?;
    }
    let mut writer = encoder.write_header().map_err(fail)?;
    writer.write_image_data(rgba).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(bytes)
}

/// PNG's `u32` dimensions of an image, refusing sizes it cannot hold.
pub(crate) fn dims(width: usize, height: usize) -> Result<(u32, u32)> {
    match (u32::try_from(width), u32::try_from(height)) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(Error::Internal(format!(
            "a PNG cannot be {width}×{height} pixels"
        ))),
    }
}

/// The provenance of `image` as PNG text chunks.
pub(crate) fn provenance_text(image: &Image) -> Vec<(&'static str, &str)> {
    let p = &image.provenance;
    [
        ("daystep.command", p.command.as_str()),
        ("daystep.view", p.view.as_str()),
        ("daystep.time", p.time.as_str()),
        ("daystep.sky", p.sky.as_str()),
        ("Software", p.software.as_str()),
    ]
    .into_iter()
    .filter(|(_, v)| !v.is_empty())
    .collect()
}

/// Writes the tone-mapped `image` (see [`to_rgba8`]) to `path` as an 8-bit sRGB PNG with
/// the provenance as text chunks, atomically.
///
/// # Errors
/// [`Error::Io`] naming `path` when it cannot be written; errors of [`encode_png`].
pub fn write_png(path: &Path, image: &Image, exposure: Exposure) -> Result<()> {
    let rgba = to_rgba8(image, exposure);
    let bytes = encode_png(image.width, image.height, &rgba, &provenance_text(image))?;
    files::write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::image::Quantity;

    fn ramp() -> Image {
        let mut im = Image::new(16, 1, Quantity::Radiance);
        for (i, c) in im.rgb.iter_mut().enumerate() {
            *c = Rgb::splat(0.01 * 1.5f64.powi(i as i32));
        }
        im
    }

    #[test]
    fn brighter_pixels_never_come_out_darker() {
        let im = ramp();
        for exposure in [Exposure::Auto, Exposure::Given(1.0), Exposure::Given(0.3)] {
            let out = to_rgba8(&im, exposure);
            let g: Vec<u8> = out.chunks(4).map(|p| p[1]).collect();
            assert!(g.windows(2).all(|w| w[0] <= w[1]), "{exposure:?}: {g:?}");
            assert!(g[0] < g[15], "{exposure:?}: {g:?}");
        }
    }

    #[test]
    fn a_given_exposure_doubles_a_mid_value_before_the_curve() {
        let mut im = Image::new(1, 1, Quantity::Radiance);
        im.rgb[0] = Rgb::new(0.2, 0.15, 0.1);
        let one = exposed(&im, Exposure::Given(1.0))[0];
        let two = exposed(&im, Exposure::Given(2.0))[0];
        assert_eq!(two, one * 2.0);
        // The encoded byte, decoded with the inverse sRGB curve, is doubled too.
        let decode = |b: u8| {
            let e = f64::from(b) / 255.0;
            if e <= 0.04045 {
                e / 12.92
            } else {
                ((e + 0.055) / 1.055).powf(2.4)
            }
        };
        let (a, b) = (
            to_rgba8(&im, Exposure::Given(1.0))[0],
            to_rgba8(&im, Exposure::Given(2.0))[0],
        );
        let ratio = decode(b) / decode(a);
        assert!((ratio - 2.0).abs() < 0.02, "{a} {b} {ratio}");
    }

    #[test]
    fn auto_makes_a_uniform_image_eighteen_percent_grey() {
        let expected = (255.0 * (1.055 * 0.18f64.powf(1.0 / 2.4) - 0.055)).round() as u8;
        assert_eq!(expected, 118);
        for level in [1e-3, 0.5, 300.0] {
            let mut im = Image::new(4, 4, Quantity::Irradiance);
            im.rgb.fill(Rgb::splat(level));
            // Invalid and black pixels do not pull the average.
            im.valid[0] = false;
            im.rgb[0] = Rgb::splat(1e6);
            im.rgb[1] = Rgb::ZERO;
            let out = to_rgba8(&im, Exposure::Auto);
            assert_eq!(&out[0..4], &[0, 0, 0, 255]);
            assert_eq!(&out[4..8], &[0, 0, 0, 255]);
            for p in out.chunks(4).skip(2) {
                assert_eq!(p, [expected, expected, expected, 255], "level {level}");
            }
        }
    }

    #[test]
    fn values_clamp_and_the_png_decodes_to_the_same_pixels() {
        let mut im = ramp();
        im.rgb[3] = Rgb::new(-1.0, f64::NAN, 1e9);
        let rgba = to_rgba8(&im, Exposure::Given(1.0));
        assert_eq!(&rgba[12..16], &[0, 0, 255, 255]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("im.png");
        im.provenance.sky = "perez".into();
        write_png(&path, &im, Exposure::Given(1.0)).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (16, 1));
        assert_eq!(&buf[..info.buffer_size()], &rgba[..]);
        let texts = &reader.info().utf8_text;
        assert!(texts.iter().any(|t| t.keyword == "daystep.sky"));
    }
}
