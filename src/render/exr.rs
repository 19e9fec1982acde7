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
use crate::render::image::{check_size, no_memory, Image, Provenance, Quantity, MAX_PIXELS};
use ::exr::meta::{BlockDescription, MetaData};
use ::exr::prelude::{
    AnyChannel, AnyChannels, AttributeValue, Compression, Encoding, FlatSamples, ImageAttributes,
    Layer, LayerAttributes, ReadChannels, ReadLayers, SmallVec, Text, WritableImage,
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

/// Reads an OpenEXR file written by [`write_exr`] (or any file with `R`, `G`, `B` channels
/// in its first part, scan lines or tiles, any compression) back into an [`Image`]: rgb in
/// the file's unit, `err` from the `err` channel (0 when absent), provenance and quantity
/// from the `daystep.*` attributes (radiance when absent). Every pixel reads as valid: the
/// file does not keep the mask.
///
/// The header is read and checked before any pixel memory is allocated (see
/// [`check_parts`]): every part's size against [`MAX_PIXELS`](crate::render::image::MAX_PIXELS),
/// the file's length against its offset tables and uncompressed data, each chunk's place in
/// the file; then the decoder's memory is reserved fallibly once, so a size this machine
/// cannot hold is an error rather than an abort.
///
/// # Errors
/// [`Error::Io`] when the file cannot be read; [`Error::Input`] naming the file when it
/// is not OpenEXR, declares more than daystep reads or more than the file holds, lacks a
/// colour channel, names an unknown quantity, or needs more memory than there is.
pub fn read_exr(path: &Path) -> Result<Image> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_exr(&bytes, path)
}

/// [`read_exr`] on bytes already in memory; `path` names them in errors.
///
/// # Errors
/// As [`read_exr`].
pub fn decode_exr(bytes: &[u8], path: &Path) -> Result<Image> {
    let bad = |message: String| Error::input(path, None, None, message);
    let unreadable = |e: ::exr::error::Error| bad(format!("not a readable OpenEXR file: {e}"));
    // As the crate's own reader: headers read leniently, then validated.
    let mut cursor = Cursor::new(bytes);
    let meta =
        guarded(path, || MetaData::read_from_buffered(&mut cursor, true))?.map_err(unreadable)?;
    MetaData::validate(&meta.headers, false).map_err(unreadable)?;
    let header_end = cursor.position() as usize;
    let decoder_bytes = check_parts(path, bytes, &meta, header_end)?;
    let first = &meta.headers[0];
    let (w, h) = (first.layer_size.0, first.layer_size.1);
    let image_bytes = w * h * (std::mem::size_of::<Rgb>() + std::mem::size_of::<f64>() + 1);
    // The decoder allocates its channels infallibly: what it and the image will need is
    // reserved (and given back) first, so a size this machine cannot hold stops here.
    let need = decoder_bytes.saturating_add(image_bytes);
    if Vec::<u8>::new().try_reserve_exact(need).is_err() {
        return Err(no_memory(path, w, h, need));
    }
    let file = guarded(path, || {
        ::exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            // On this thread, so that a panic of the decoder is caught below (in a
            // thread pool it would abort the program).
            .non_parallel()
            .from_buffered(Cursor::new(bytes))
    })?
    .map_err(unreadable)?;
    let layer = &file.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let mut image = Image::try_new(width, height, Quantity::Radiance, path)?;
    let n = width * height;
    let channel = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .map(|c| &c.sample_data)
    };
    for (k, name) in ["R", "G", "B"].into_iter().enumerate() {
        let samples = channel(name).ok_or_else(|| bad(format!("no {name} channel")))?;
        if samples.len() != n {
            return Err(bad(format!(
                "channel {name} holds {} values for {width} x {height} pixels",
                samples.len()
            )));
        }
        for (p, v) in image.rgb.iter_mut().zip(samples.values_as_f32()) {
            p[k] = f64::from(v);
        }
    }
    if let Some(samples) = channel("err").filter(|s| s.len() == n) {
        for (e, v) in image.err.iter_mut().zip(samples.values_as_f32()) {
            *e = f64::from(v);
        }
    }
    let attrs = header_texts(&file.attributes, &layer.attributes);
    let attr = |key: &str| attrs.get(key).cloned().unwrap_or_default();
    image.quantity = match attrs.get(QUANTITY).map(String::as_str) {
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
    image.provenance = Provenance {
        command: attr(COMMAND),
        view: attr(VIEW),
        time: attr(TIME),
        sky: attr(SKY),
        software: attr(SOFTWARE),
    };
    Ok(image)
}

/// Runs `decode` (the exr crate on a file's bytes), turning a panic into an input error
/// naming `path`: the crate has arithmetic that overflows on corrupt data (its B44 decoder,
/// with overflow checks on), and a corrupt picture must be refused, not crash the program.
fn guarded<T>(path: &Path, decode: impl FnOnce() -> T) -> Result<T> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(decode)).map_err(|payload| {
        let why = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Error::input(
            path,
            None,
            None,
            format!("not a readable OpenEXR file: the decoder failed ({why})"),
        )
    })
}

/// Checks an OpenEXR file's parts against what daystep reads and what the file holds,
/// before any pixel memory is allocated; `header_end` is where the headers end (and the
/// offset tables begin). Returns the bytes the decoder will allocate for the first part's
/// channels (the part read).
///
/// Every part (scan lines or tiles, any compression) must declare at most
/// [`MAX_PIXELS`](crate::render::image::MAX_PIXELS) pixels and
/// [`MAX_SAMPLES`](crate::render::image::MAX_SAMPLES) values (data window × channels) and
/// tiles of at most `MAX_PIXELS` pixels. The file must hold, after its headers, every
/// part's offset table (8 bytes a chunk: a scan-line block of 1, 16, 32 or 256 lines by
/// the compression, or a tile of each level), each chunk's own header (part number in
/// multi-part files, then 8 bytes for a scan-line block or 20 for a tile) and, for an
/// uncompressed part, exactly its pixels' bytes (all levels). Each chunk the tables name
/// must lie inside the file with its stated data size.
fn check_parts(path: &Path, bytes: &[u8], meta: &MetaData, header_end: usize) -> Result<usize> {
    let multi_part = meta.requirements.is_multilayer();
    let mut need = header_end;
    let mut tables = Vec::with_capacity(meta.headers.len());
    for (i, header) in meta.headers.iter().enumerate() {
        let (w, h) = (header.layer_size.0, header.layer_size.1);
        let size = format!("{w} x {h}");
        let part = |message: String| {
            let message = if meta.headers.len() > 1 {
                format!("part {}: {message}", i + 1)
            } else {
                message
            };
            Error::input(path, None, Some(&size), message)
        };
        check_size(path, w, h, header.channels.list.len()).map_err(|e| match e {
            Error::Input { message, .. } => part(message),
            other => other,
        })?;
        let chunk_header = match header.blocks {
            BlockDescription::ScanLines => 8,
            BlockDescription::Tiles(t) => {
                let (tw, th) = (t.tile_size.0, t.tile_size.1);
                if tw.checked_mul(th).is_none_or(|n| n > MAX_PIXELS) {
                    return Err(part(format!(
                        "tiles of {tw} x {th} pixels are more than daystep reads (2^28 pixels)"
                    )));
                }
                20
            }
        } + if multi_part { 4 } else { 0 };
        let chunks = header.chunk_count;
        let pixels = if header.compression == Compression::Uncompressed {
            // Bounded by the size check above (at most 2^30 values of 4 bytes, 4/3 of that
            // with mip levels and 4 times with rip levels).
            header.total_pixel_bytes()
        } else {
            0
        };
        need = chunks
            .checked_mul(8 + chunk_header)
            .and_then(|n| n.checked_add(pixels))
            .and_then(|n| n.checked_add(need))
            .unwrap_or(usize::MAX);
        if bytes.len() < need {
            let what = if pixels > 0 {
                format!("{chunks} chunks and {pixels} bytes of uncompressed pixels")
            } else {
                format!("an offset table of {chunks} chunks")
            };
            return Err(part(format!(
                "{size} pixels need at least {need} bytes ({what}), the file holds {} \
                 (truncated or corrupt file)",
                bytes.len()
            )));
        }
        tables.push((chunks, chunk_header));
    }
    // The tables follow one another after the headers; `need` covered them all.
    let mut at = header_end;
    for (i, header) in meta.headers.iter().enumerate() {
        let (chunks, chunk_header) = tables[i];
        for k in 0..chunks {
            let word: [u8; 8] = bytes[at..at + 8].try_into().expect("8 bytes");
            at += 8;
            let offset = u64::from_le_bytes(word);
            let inside = usize::try_from(offset)
                .ok()
                .filter(|&o| {
                    o.checked_add(chunk_header)
                        .is_some_and(|e| e <= bytes.len())
                })
                .and_then(|o| {
                    let field = o + chunk_header - 4;
                    let size = i32::from_le_bytes(bytes[field..o + chunk_header].try_into().ok()?);
                    let end = usize::try_from(size).ok()?.checked_add(o + chunk_header)?;
                    (end <= bytes.len()).then_some(())
                });
            if inside.is_none() {
                let (w, h) = (header.layer_size.0, header.layer_size.1);
                return Err(Error::input(
                    path,
                    None,
                    Some(&offset.to_string()),
                    format!(
                        "{w} x {h} pixels: chunk {} of {chunks}{} does not lie inside the file \
                         ({} bytes; truncated or corrupt file)",
                        k + 1,
                        if meta.headers.len() > 1 {
                            format!(" of part {}", i + 1)
                        } else {
                            String::new()
                        },
                        bytes.len()
                    ),
                ));
            }
        }
    }
    let first = &meta.headers[0];
    Ok(first
        .channels
        .list
        .iter()
        .map(|c| {
            c.subsampled_resolution(first.layer_size).area() * c.sample_type.bytes_per_sample()
        })
        .sum())
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
#[path = "exr_tests.rs"]
mod tests;
