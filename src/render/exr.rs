//! Linear HDR OpenEXR images: the [`Image`]'s RGB and its per-pixel stated error as 32-bit
//! float channels, with the image's provenance as text attributes in the header.
//!
//! Channels: `R`, `G`, `B` (radiance W·sr⁻¹·m⁻², or irradiance W/m² for `-i` images) and
//! `err` (the stated error of the pixel's grey value, same unit). Pixels outside a
//! fisheye's circle are written as 0 in every channel. Header attributes (text):
//! `daystep.command`, `daystep.view`, `daystep.time`, `daystep.sky`, `daystep.software`,
//! `daystep.quantity` (`radiance` | `irradiance`) and `daystep.unit` (the unit of the
//! channels, e.g. `W/(sr m2)`).

use crate::error::{Error, Result};
use crate::files;
use crate::photometry::Rgb;
use crate::render::image::{Image, Provenance, Quantity};
use ::exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, ImageAttributes, Layer,
    LayerAttributes, ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
};
use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

/// The header attribute holding the provenance, a string vector of `key=value` entries.
const PROVENANCE: &str = "daystep";
const COMMAND: &str = "daystep.command";
const VIEW: &str = "daystep.view";
const TIME: &str = "daystep.time";
const SKY: &str = "daystep.sky";
const SOFTWARE: &str = "daystep.software";
const QUANTITY: &str = "daystep.quantity";
const UNIT: &str = "daystep.unit";

/// The radiometric unit of an image's channels, as written in `daystep.unit`.
pub fn channel_unit(quantity: Quantity) -> &'static str {
    match quantity {
        Quantity::Radiance => "W/(sr m2)",
        Quantity::Irradiance => "W/m2",
    }
}

fn quantity_name(quantity: Quantity) -> &'static str {
    match quantity {
        Quantity::Radiance => "radiance",
        Quantity::Irradiance => "irradiance",
    }
}

// OpenEXR text is a byte string that OpenEXR's own library treats as UTF-8; the crate's
// `Text::from` would panic on anything beyond Latin-1, so the UTF-8 bytes go in as they are.
fn text(s: &str) -> Text {
    Text::from_slice_unchecked(s.as_bytes())
}

/// Encodes `image` as an OpenEXR file in memory (ZIP-compressed scan lines, f32 channels
/// `R`, `G`, `B`, `err` in the image's radiometric unit; invalid pixels 0).
///
/// # Errors
/// [`Error::Input`] when the image's buffers do not match its size;
/// [`Error::Internal`] when the encoder fails.
pub fn encode_exr(image: &Image) -> Result<Vec<u8>> {
    let n = image.width * image.height;
    if image.rgb.len() != n || image.err.len() != n || image.valid.len() != n {
        return Err(Error::Internal(format!(
            "image of {}×{} has {} colours, {} errors, {} validity flags",
            image.width,
            image.height,
            image.rgb.len(),
            image.err.len(),
            image.valid.len()
        )));
    }
    let channel = |f: &dyn Fn(usize) -> f64| -> Vec<f32> {
        (0..n)
            .map(|i| if image.valid[i] { f(i) as f32 } else { 0.0 })
            .collect()
    };
    let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::from_vec(vec![
        AnyChannel::new("R", FlatSamples::F32(channel(&|i| image.rgb[i].x))),
        AnyChannel::new("G", FlatSamples::F32(channel(&|i| image.rgb[i].y))),
        AnyChannel::new("B", FlatSamples::F32(channel(&|i| image.rgb[i].z))),
        AnyChannel::new("err", FlatSamples::F32(channel(&|i| image.err[i]))),
    ]);
    let p = &image.provenance;
    let mut attributes = LayerAttributes::default();
    // One string-vector attribute of `key=value` entries, in this order: the exr crate
    // keeps custom attributes in a HashMap, whose order (and so the file's bytes) would
    // change from run to run with one attribute per key.
    let mut entries = Vec::new();
    for (key, value) in [
        (COMMAND, p.command.as_str()),
        (VIEW, p.view.as_str()),
        (TIME, p.time.as_str()),
        (SKY, p.sky.as_str()),
        (SOFTWARE, p.software.as_str()),
        (QUANTITY, quantity_name(image.quantity)),
        (UNIT, channel_unit(image.quantity)),
    ] {
        entries.push(text(&format!("{key}={value}")));
    }
    attributes
        .other
        .insert(text(PROVENANCE), AttributeValue::TextVector(entries));
    let layer = Layer::new(
        (image.width, image.height),
        attributes,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let exr_image = ::exr::prelude::Image::from_layer(layer);
    let mut bytes = Vec::new();
    exr_image
        .write()
        .to_buffered(Cursor::new(&mut bytes))
        .map_err(|e| Error::Internal(format!("OpenEXR encoding failed: {e}")))?;
    Ok(bytes)
}

/// Writes `image` to `path` as OpenEXR (see the module documentation for channels and
/// attributes), atomically.
///
/// # Errors
/// [`Error::Io`] naming `path` when it cannot be written; errors of [`encode_exr`].
pub fn write_exr(path: &Path, image: &Image) -> Result<()> {
    files::write_atomic(path, &encode_exr(image)?)
}

/// Reads an OpenEXR file written by [`write_exr`] (or any single-part file with `R`, `G`,
/// `B` channels) back into an [`Image`]: rgb in the file's unit, `err` from the `err`
/// channel (0 when absent), provenance and quantity from the `daystep.*` attributes
/// (radiance when absent). Every pixel reads as valid: the file does not keep the mask.
///
/// # Errors
/// [`Error::Io`] when the file cannot be read; [`Error::Input`] naming the file when it
/// is not OpenEXR, lacks a colour channel, or names an unknown quantity.
pub fn read_exr(path: &Path) -> Result<Image> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let bad = |message: String| Error::input(path, None, None, message);
    let file = ::exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| bad(format!("not a readable OpenEXR file: {e}")))?;
    let layer = &file.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let n = width * height;
    let samples = |name: &str| -> Option<Vec<f64>> {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .map(|c| c.sample_data.values_as_f32().map(f64::from).collect())
    };
    let colour = |name: &str| samples(name).ok_or_else(|| bad(format!("no {name} channel")));
    let (r, g, b) = (colour("R")?, colour("G")?, colour("B")?);
    let err = samples("err").unwrap_or_else(|| vec![0.0; n]);
    let attrs = header_texts(&file.attributes, &layer.attributes);
    let attr = |key: &str| attrs.get(key).cloned().unwrap_or_default();
    let quantity = match attrs.get(QUANTITY).map(String::as_str) {
        None | Some("radiance") => Quantity::Radiance,
        Some("irradiance") => Quantity::Irradiance,
        Some(other) => {
            return Err(Error::input(
                path,
                None,
                Some(other),
                format!("{QUANTITY} must be radiance or irradiance"),
            ))
        }
    };
    Ok(Image {
        width,
        height,
        quantity,
        rgb: (0..n).map(|i| Rgb::new(r[i], g[i], b[i])).collect(),
        err,
        valid: vec![true; n],
        provenance: Provenance {
            command: attr(COMMAND),
            view: attr(VIEW),
            time: attr(TIME),
            sky: attr(SKY),
            software: attr(SOFTWARE),
        },
    })
}

// The crate sorts unknown header attributes into the image's or the layer's set depending on
// the name, so both are searched.
fn header_texts(image: &ImageAttributes, layer: &LayerAttributes) -> HashMap<String, String> {
    image
        .other
        .iter()
        .chain(layer.other.iter())
        .flat_map(|(k, v)| match v {
            AttributeValue::Text(t) => vec![(
                String::from_utf8_lossy(k.bytes()).into_owned(),
                String::from_utf8_lossy(t.bytes()).into_owned(),
            )],
            AttributeValue::TextVector(list) if k.eq(PROVENANCE) => list
                .iter()
                .filter_map(|t| {
                    let e = String::from_utf8_lossy(t.bytes()).into_owned();
                    e.split_once('=')
                        .map(|(a, b)| (a.to_string(), b.to_string()))
                })
                .collect(),
            _ => Vec::new(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Image {
        let mut im = Image::new(5, 3, Quantity::Irradiance);
        for i in 0..15 {
            let f = i as f64;
            im.rgb[i] = Rgb::new(0.1 * f + 1e-3, 2.0 * f + 0.5, 1e4 / (f + 1.0));
            im.err[i] = 0.01 * f + 1.0 / 3.0;
        }
        im.valid[7] = false;
        im.provenance = Provenance {
            command: "daystep render --view a.vf".into(),
            view: "-vtv -vp 1 2 3 -vd 0 1 0".into(),
            time: "2024-06-21T12:00:00+01:00 (11:00Z)".into(),
            sky: "perez dni=700 dhi=100 — 45° sun".into(),
            software: "daystep 0.1.0".into(),
        };
        im
    }

    #[test]
    fn round_trip_keeps_values_to_f32_and_every_attribute() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out/im.exr");
        let im = sample();
        write_exr(&path, &im).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (5, 3));
        assert_eq!(back.quantity, Quantity::Irradiance);
        assert_eq!(back.provenance, im.provenance);
        for i in 0..15 {
            let f32s = |v: Rgb| [v.x as f32, v.y as f32, v.z as f32];
            if i == 7 {
                assert_eq!(f32s(back.rgb[i]), [0.0; 3]);
                assert_eq!(back.err[i], 0.0);
            } else {
                assert_eq!(f32s(back.rgb[i]), f32s(im.rgb[i]), "pixel {i}");
                assert_eq!(back.err[i] as f32, im.err[i] as f32, "pixel {i}");
            }
        }
    }

    #[test]
    fn header_names_the_quantity_and_unit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("im.exr");
        let mut im = sample();
        im.quantity = Quantity::Radiance;
        write_exr(&path, &im).unwrap();
        let meta = ::exr::meta::MetaData::read_from_file(&path, false).unwrap();
        let h = &meta.headers[0];
        let get = |k: &str| {
            h.own_attributes
                .other
                .get(&text(k))
                .or_else(|| h.shared_attributes.other.get(&text(k)))
                .cloned()
        };
        let Some(AttributeValue::TextVector(list)) = get(PROVENANCE) else {
            panic!("no {PROVENANCE} attribute");
        };
        let list: Vec<String> = list.iter().map(|t| t.to_string()).collect();
        assert!(list.contains(&format!("{QUANTITY}=radiance")), "{list:?}");
        assert!(list.contains(&format!("{UNIT}=W/(sr m2)")), "{list:?}");
        assert_eq!(read_exr(&path).unwrap().quantity, Quantity::Radiance);
    }

    #[test]
    fn a_file_that_is_not_exr_is_an_input_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("junk.exr");
        std::fs::write(&path, b"not an exr").unwrap();
        let (shown, p, _, _) = crate::error::input_parts(read_exr(&path).unwrap_err());
        assert_eq!(p, path);
        assert!(shown.contains("junk.exr"), "{shown}");
    }
}
