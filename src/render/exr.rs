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

    /// One part of a hand-built OpenEXR header.
    struct Part {
        size: (u32, u32),
        /// OpenEXR's compression code: 0 none, 1 RLE, 2 ZIPS, 3 ZIP, 4 PIZ, …
        compression: u8,
        /// Tile width, height and level mode (0 one level, 1 mip-map, 2 rip-map).
        tiles: Option<(u32, u32, u8)>,
        /// Channel names, f32 each.
        channels: Vec<String>,
    }

    impl Part {
        fn scanlines(w: u32, h: u32, compression: u8) -> Part {
            Part {
                size: (w, h),
                compression,
                tiles: None,
                channels: ["B", "G", "R"].map(String::from).to_vec(),
            }
        }
    }

    fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
        for s in [name, kind] {
            out.extend_from_slice(s.as_bytes());
            out.push(0);
        }
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(value);
    }

    /// The headers of `parts`, written byte by byte as the OpenEXR file layout says (magic,
    /// version and flags, each part's attributes ended by a null byte, a null byte after
    /// the last part of a multi-part file); no offset table.
    fn headers(parts: &[Part]) -> Vec<u8> {
        let multi = parts.len() > 1;
        let tiled = parts[0].tiles.is_some() && !multi;
        let flags = 2u32 | if tiled { 0x200 } else { 0 } | if multi { 0x1000 } else { 0 };
        let mut out = vec![0x76, 0x2f, 0x31, 0x01];
        out.extend_from_slice(&flags.to_le_bytes());
        for (i, p) in parts.iter().enumerate() {
            let mut ch = Vec::new();
            for c in &p.channels {
                ch.extend_from_slice(c.as_bytes());
                ch.push(0);
                for v in [2i32, 0, 1, 1] {
                    ch.extend_from_slice(&v.to_le_bytes());
                }
            }
            ch.push(0);
            attribute(&mut out, "channels", "chlist", &ch);
            attribute(&mut out, "compression", "compression", &[p.compression]);
            let mut window = Vec::new();
            for v in [0, 0, p.size.0 as i32 - 1, p.size.1 as i32 - 1] {
                window.extend_from_slice(&v.to_le_bytes());
            }
            attribute(&mut out, "dataWindow", "box2i", &window);
            attribute(&mut out, "displayWindow", "box2i", &window);
            attribute(&mut out, "lineOrder", "lineOrder", &[0]);
            attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
            attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
            attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
            if let Some((tw, th, mode)) = p.tiles {
                let mut t = tw.to_le_bytes().to_vec();
                t.extend_from_slice(&th.to_le_bytes());
                t.push(mode);
                attribute(&mut out, "tiles", "tiledesc", &t);
            }
            if multi {
                attribute(&mut out, "name", "string", format!("part{i}").as_bytes());
                let kind = if p.tiles.is_some() {
                    "tiledimage"
                } else {
                    "scanlineimage"
                };
                attribute(&mut out, "type", "string", kind.as_bytes());
            }
            out.push(0);
        }
        if multi {
            out.push(0);
        }
        out
    }

    /// `headers` followed by `entries` offset-table entries, each pointing at the table's
    /// end.
    fn with_table(headers: &[u8], entries: usize) -> Vec<u8> {
        let mut out = headers.to_vec();
        let end = (headers.len() + 8 * entries) as u64;
        for _ in 0..entries {
            out.extend_from_slice(&end.to_le_bytes());
        }
        out
    }

    fn refusal(bytes: &[u8]) -> String {
        let path = Path::new("dir/big.exr");
        let (shown, p, _, _) = crate::error::input_parts(decode_exr(bytes, path).unwrap_err());
        assert_eq!(p, path, "{shown}");
        shown
    }

    #[test]
    fn a_small_exr_claiming_100000_squared_pixels_is_refused_before_allocating() {
        // As filed: uncompressed scan lines, 100 000 × 100 000, a short offset table. The
        // decoder used to allocate 40 GB a channel for it.
        let b = with_table(&headers(&[Part::scanlines(100_000, 100_000, 0)]), 4);
        assert!(b.len() < 400);
        let e = refusal(&b);
        assert!(
            e.contains("100000 x 100000 pixels is more than daystep reads (2^28 pixels)"),
            "{e}"
        );
    }

    #[test]
    fn every_exr_layout_is_held_to_the_pixel_limit() {
        let tiled = |compression, mode| Part {
            tiles: Some((64, 64, mode)),
            ..Part::scanlines(70_000, 70_000, compression)
        };
        let small = Part::scanlines(8, 8, 3);
        let layouts = vec![
            ("RLE scan lines", vec![Part::scanlines(70_000, 70_000, 1)]),
            ("ZIP scan lines", vec![Part::scanlines(70_000, 70_000, 3)]),
            ("PIZ scan lines", vec![Part::scanlines(70_000, 70_000, 4)]),
            ("one-level ZIP tiles", vec![tiled(3, 0)]),
            ("mip-mapped PIZ tiles", vec![tiled(4, 1)]),
            ("rip-mapped tiles", vec![tiled(0, 2)]),
            (
                "a second part",
                vec![small, Part::scanlines(70_000, 70_000, 3)],
            ),
        ];
        for (what, parts) in layouts {
            let e = refusal(&with_table(&headers(&parts), 16));
            assert!(
                e.contains("70000 x 70000 pixels is more than"),
                "{what}: {e}"
            );
        }
        // Within the pixel limit, but with channels enough for 20 GB of floats.
        let mut many = Part::scanlines(8192, 8192, 3);
        many.channels = (0..80).map(|i| format!("c{i:02}")).collect();
        let e = refusal(&with_table(&headers(&[many]), 16));
        assert!(e.contains("8192 x 8192 pixels of 80 channels"), "{e}");
        // Tiles beyond the limit, on a small picture.
        let huge_tiles = Part {
            tiles: Some((1 << 29, 1 << 29, 0)),
            ..Part::scanlines(16, 16, 3)
        };
        let e = refusal(&with_table(&headers(&[huge_tiles]), 1));
        assert!(e.contains("tiles of 536870912 x 536870912 pixels"), "{e}");
    }

    #[test]
    fn an_exr_shorter_than_its_offset_table_is_refused_before_allocating() {
        // ZIP blocks of 16 lines: 16 384 lines need 1024 offsets (8 KiB); ten are given.
        let b = with_table(&headers(&[Part::scanlines(16384, 16384, 3)]), 10);
        let e = refusal(&b);
        assert!(
            e.contains("16384 x 16384 pixels need at least")
                && e.contains("1024 chunks")
                && e.contains(&format!("the file holds {}", b.len())),
            "{e}"
        );
    }

    #[test]
    fn an_uncompressed_exr_shorter_than_its_pixels_is_refused_before_allocating() {
        // 4096 lines of one block each, all in the table, each chunk's header present but
        // its 4096 × 3 × 4 bytes of pixels missing.
        let head = headers(&[Part::scanlines(4096, 4096, 0)]);
        let mut b = with_table(&head, 4096);
        for y in 0..4096i32 {
            b.extend_from_slice(&y.to_le_bytes());
            b.extend_from_slice(&0i32.to_le_bytes());
        }
        let e = refusal(&b);
        let need = head.len() + 4096 * 16 + 4096 * 4096 * 12;
        assert!(
            e.contains(&format!("need at least {need} bytes")) && e.contains("uncompressed"),
            "{e}"
        );
    }

    #[test]
    fn an_exr_chunk_outside_the_file_is_refused_before_allocating() {
        // 64 lines of ZIP: 4 chunks, each present except the second, which points past the
        // end of the file.
        let head = headers(&[Part::scanlines(64, 64, 3)]);
        let mut b = head.clone();
        let first = (head.len() + 4 * 8) as u64;
        let chunk = 8 + 4;
        let offsets = [first, 1 << 40, first + 2 * chunk, first + 3 * chunk];
        for o in offsets {
            b.extend_from_slice(&o.to_le_bytes());
        }
        for k in 0..4i32 {
            b.extend_from_slice(&(16 * k).to_le_bytes());
            b.extend_from_slice(&4i32.to_le_bytes());
            b.extend_from_slice(&[0; 4]);
        }
        let e = refusal(&b);
        assert!(
            e.contains("chunk 2 of 4 does not lie inside the file") && e.contains("1099511627776"),
            "{e}"
        );
        // A chunk whose stated size runs past the end.
        let mut b2 = b.clone();
        let at = head.len() + 8;
        b2[at..at + 8].copy_from_slice(&(first + chunk).to_le_bytes());
        let size_at = (first + chunk) as usize + 4;
        b2[size_at..size_at + 4].copy_from_slice(&i32::MAX.to_le_bytes());
        let e = refusal(&b2);
        assert!(
            e.contains("chunk 2 of 4 does not lie inside the file"),
            "{e}"
        );
    }
}
