//! Parser properties ([`super`]): pictures: Radiance RGBE and OpenEXR.

use super::*;

// Pictures: Radiance RGBE (`render::rgbe::decode_hdr`) and OpenEXR (`render::exr::decode_exr`)

/// What a refused picture may allocate at most in one piece, besides twice its own length:
/// the header's strings, one scanline (at most 2^16 pixels of 4 bytes), offset tables.
const PICTURE_SLACK: usize = 1 << 20;

/// Decodes `bytes` with `decode` (guarded and metered) and checks the outcome: an image
/// whose buffers match its size, at most `MAX_PIXELS`, or an input error naming `path`;
/// and no allocation beyond [`PICTURE_SLACK`] + 2 × the input + `allowance(result)` (what the
/// outcome may hold). Returns whether the picture was read.
fn read_picture<T>(
    bytes: &[u8],
    path: &Path,
    decode: impl FnOnce(&[u8], &Path) -> daystep::Result<T>,
    image: impl Fn(&T) -> &Image,
    allowance: impl Fn(Option<&Image>) -> usize,
) -> Result<bool, TestCaseError> {
    quiet_decoder_panics();
    let (r, largest, _, _) = metered(|| guarded(|| decode(bytes, path)));
    let r = r?;
    let read = r.as_ref().ok().map(&image);
    let bound = PICTURE_SLACK + 2 * bytes.len() + allowance(read);
    prop_assert!(
        largest <= bound,
        "allocated {largest} B at once (bound {bound} B) for {} bytes: {:?}",
        bytes.len(),
        r.as_ref().map(|_| "read").map_err(|e| e.to_string())
    );
    match (&r, read) {
        (Ok(_), Some(im)) => {
            let n = im.width * im.height;
            prop_assert!(n > 0 && n <= MAX_PIXELS, "{} x {}", im.width, im.height);
            prop_assert_eq!((im.rgb.len(), im.err.len(), im.valid.len()), (n, n, n));
            Ok(true)
        }
        (Err(e), _) => {
            let shown = e.to_string();
            match e {
                Error::Input { path: p, .. } => {
                    prop_assert_eq!(p.as_path(), path, "{}", shown);
                    prop_assert!(shown.starts_with(&path.display().to_string()), "{shown}");
                }
                other => return Err(TestCaseError::fail(format!("not an input error: {other}"))),
            }
            Ok(false)
        }
        _ => unreachable!("read is Some exactly when r is Ok"),
    }
}

/// Prints the panics of the exr crate (which `decode_exr` turns into input errors: its B44
/// decoder overflows on corrupt blocks when overflow checks are on) as one line, without
/// the backtrace `RUST_BACKTRACE` asks for: symbolising one costs seconds on a busy machine,
/// enough to fail a case as slow. Every other panic is printed as before.
fn quiet_decoder_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            match info.location().filter(|l| l.file().contains("/exr-")) {
                Some(l) => eprintln!("exr crate panicked at {l} (caught by decode_exr)"),
                None => default(info),
            }
        }));
    });
}

/// The largest buffer a read image holds: its colours, 24 bytes a pixel.
fn image_allowance(im: Option<&Image>) -> usize {
    im.map_or(0, |im| 24 * im.width * im.height)
}

fn read_hdr_bytes(bytes: &[u8]) -> Result<bool, TestCaseError> {
    read_picture(
        bytes,
        Path::new("dir/picture.hdr"),
        rgbe::decode_hdr,
        |(im, _)| im,
        image_allowance,
    )
}

/// Small images over six decades, with runs (a constant left part) and literals.
fn small_images() -> impl Strategy<Value = Image> {
    (
        1..48usize,
        1..6usize,
        prop::collection::vec(-3.0..3.0f64, 1..64),
    )
        .prop_map(|(w, h, logs)| {
            let mut im = Image::new(w, h, Quantity::Radiance);
            for (i, p) in im.rgb.iter_mut().enumerate() {
                let v = if i % w < w / 3 {
                    2.5
                } else {
                    10f64.powf(logs[i % logs.len()])
                };
                *p = DVec3::new(v, 0.5 * v, 0.9 * v);
            }
            im
        })
}

fn hdr_bytes(im: &Image) -> Vec<u8> {
    let dir = tempfile::tempdir().expect("temporary folder");
    let p = dir.path().join("p.hdr");
    rgbe::write_hdr(&p, im, None).expect("write_hdr");
    std::fs::read(&p).expect("read back")
}

/// Resolution lines: both axes, both signs, sizes from 0 to past every integer type.
fn resolution_lines() -> impl Strategy<Value = String> {
    let size = prop_oneof![
        1..70usize,
        Just(1 << 15),
        Just(1 << 16),
        Just((1 << 16) + 1),
        Just(1 << 28),
        Just(usize::MAX),
        any::<usize>(),
    ]
    .prop_map(|n| n.to_string());
    let axis = prop::sample::select(vec!["-Y", "+Y", "-X", "+X", "Y", "-Z", "--Y"]);
    (axis.clone(), size.clone(), axis, size).prop_map(|(a, n, b, m)| format!("{a} {n} {b} {m}"))
}

#[test]
fn hdr_arbitrary_bytes_and_resolution_lines() {
    // Arbitrary bytes; and arbitrary scanline bytes after a valid header with any
    // resolution line.
    let framed = (resolution_lines(), any_bytes()).prop_map(|(res, data)| {
        let mut b = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes();
        b.extend(data);
        b
    });
    check(4096, prop_oneof![any_bytes(), framed], |bytes| {
        read_hdr_bytes(&bytes)?;
        Ok(())
    });
}

/// A valid picture's bytes edited: its resolution line replaced, bytes of the scanlines
/// set to run-length markers (`2 2`, `1 1 1 n`, run codes) or arbitrary values, the
/// picture cut or extended.
#[test]
fn hdr_mutations() {
    // Writing is slow (each file is synced): 64 samples, mutated in turn.
    let samples: Vec<Vec<u8>> = {
        let mut runner = TestRunner::new(Config {
            rng_seed: RngSeed::Fixed(SEED),
            ..Config::default()
        });
        (0..64)
            .map(|_| {
                use proptest::strategy::ValueTree;
                hdr_bytes(&small_images().new_tree(&mut runner).unwrap().current())
            })
            .collect()
    };
    let edit = (
        any::<Index>(),
        prop::sample::select(vec![0u8, 1, 2, 127, 128, 129, 255]),
    );
    let strategy = (
        any::<Index>(),
        prop::option::weighted(0.5, resolution_lines()),
        prop::collection::vec(edit, 0..6),
        prop::option::weighted(0.3, any::<Index>()),
        prop::collection::vec(any::<u8>(), 0..8),
    );
    check(4096, strategy, |(which, res, edits, cut, append)| {
        let mut b = samples[which.index(samples.len())].clone();
        let data_at = b.windows(2).position(|w| w == b"\n\n").expect("header end") + 2;
        if let Some(res) = res {
            let line_end = data_at + b[data_at..].iter().position(|&c| c == b'\n').unwrap();
            b.splice(data_at..line_end, res.into_bytes());
        }
        for (at, v) in &edits {
            let k = at.index(b.len());
            if k >= data_at {
                b[k] = *v;
            }
        }
        if let Some(c) = cut {
            b.truncate(c.index(b.len() + 1));
        }
        b.extend(append);
        read_hdr_bytes(&b)?;
        Ok(())
    });
}

#[test]
fn hdr_valid_pictures_round_trip() {
    check(256, small_images(), |im| {
        let b = hdr_bytes(&im);
        let (back, _) = rgbe::decode_hdr(&b, Path::new("p.hdr"))
            .map_err(|e| TestCaseError::fail(format!("a valid picture is refused: {e}")))?;
        prop_assert_eq!((back.width, back.height), (im.width, im.height));
        for (a, b) in back.rgb.iter().zip(&im.rgb) {
            // RGBE keeps 8 bits of mantissa relative to the largest component.
            prop_assert!(
                (*a - *b).abs().max_element() <= 0.01 * b.max_element(),
                "{a} vs {b}"
            );
        }
        Ok(())
    });
}

/// The largest buffer the OpenEXR reader may allocate for `bytes`: when the first part's
/// declared size is within daystep's limits, what the decoder's channels (4 bytes a value)
/// and the image (33 bytes a pixel) need together (reserved at once before decoding);
/// nothing otherwise.
fn exr_allowance(bytes: &[u8]) -> usize {
    let Ok(meta) = std::panic::catch_unwind(|| {
        ::exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), true)
    }) else {
        return 0;
    };
    let Some(first) = meta.ok().and_then(|m| m.headers.first().cloned()) else {
        return 0;
    };
    let (w, h, c) = (
        first.layer_size.0,
        first.layer_size.1,
        first.channels.list.len(),
    );
    match w.checked_mul(h) {
        Some(n) if n <= MAX_PIXELS && n.saturating_mul(c) <= MAX_SAMPLES => n * (4 * c + 33),
        _ => 0,
    }
}

fn read_exr_bytes(bytes: &[u8]) -> Result<bool, TestCaseError> {
    let allowance = exr_allowance(bytes);
    read_picture(
        bytes,
        Path::new("dir/picture.exr"),
        exr::decode_exr,
        |im| im,
        |_| allowance,
    )
}

/// Sample OpenEXR files of every layout the reader accepts: daystep's own (ZIP scan
/// lines, four channels), and R, G, B written by the exr crate as scan lines or tiles (one
/// level or mip-maps), uncompressed or RLE, ZIP, PIZ, PXR24 or B44 compressed, in one or
/// two parts.
fn exr_samples() -> Vec<(String, Vec<u8>, Image)> {
    use ::exr::prelude::{
        AnyChannel, AnyChannels, Blocks, Compression, Encoding, FlatSamples, ImageAttributes,
        IntegerBounds, Layer, LayerAttributes, Levels, LineOrder, SmallVec, WritableImage,
    };
    let mut out = Vec::new();
    let mut im = Image::new(13, 7, Quantity::Radiance);
    for (i, p) in im.rgb.iter_mut().enumerate() {
        let v = 10f64.powf(i as f64 / 30.0 - 1.0);
        *p = DVec3::new(v, 2.0 * v, 0.5 * v);
    }
    for (i, e) in im.err.iter_mut().enumerate() {
        *e = 0.01 * i as f64;
    }
    out.push((
        "daystep".to_string(),
        exr::encode_exr(&im).unwrap(),
        im.clone(),
    ));
    let (w, h) = (im.width, im.height);
    let levels = |k: usize| -> Levels<FlatSamples> {
        let full: Vec<f32> = im.rgb.iter().map(|p| p[k] as f32).collect();
        Levels::Singular(FlatSamples::F32(full))
    };
    let mip = |k: usize| -> Levels<FlatSamples> {
        let round = ::exr::math::RoundingMode::Down;
        let level_data = ::exr::meta::mip_map_levels(round, ::exr::math::Vec2(w, h))
            .map(|(_, size)| {
                FlatSamples::F32(
                    (0..size.area())
                        .map(|i| if i < w * h { im.rgb[i][k] as f32 } else { 0.0 })
                        .collect(),
                )
            })
            .collect();
        Levels::Mip {
            rounding_mode: round,
            level_data,
        }
    };
    let layer = |name: &str, encoding: Encoding, mipped: bool| {
        let channels: SmallVec<[AnyChannel<Levels<FlatSamples>>; 4]> = ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(k, c)| AnyChannel::new(*c, if mipped { mip(k) } else { levels(k) }))
            .collect();
        Layer::new(
            (w, h),
            LayerAttributes::named(name),
            encoding,
            AnyChannels::sort(channels),
        )
    };
    let compressions = [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP1,
        Compression::ZIP16,
        Compression::PIZ,
        Compression::PXR24,
        Compression::B44,
    ];
    for compression in compressions {
        for (blocks, mipped) in [
            (Blocks::ScanLines, false),
            (Blocks::Tiles(::exr::math::Vec2(4, 4)), false),
            (Blocks::Tiles(::exr::math::Vec2(8, 2)), true),
        ] {
            let encoding = Encoding {
                compression,
                blocks,
                line_order: LineOrder::Increasing,
            };
            let name = format!("{compression:?} {blocks:?} mip-mapped {mipped}");
            let file = ::exr::prelude::Image::from_layer(layer("one", encoding, mipped));
            let mut bytes = Vec::new();
            file.write()
                .to_buffered(std::io::Cursor::new(&mut bytes))
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            out.push((name.clone(), bytes, im.clone()));
            let two = ::exr::prelude::Image::from_layers(
                ImageAttributes::new(IntegerBounds::from_dimensions((w, h))),
                vec![
                    layer("first", encoding, mipped),
                    layer("second", encoding, false),
                ],
            );
            let mut bytes = Vec::new();
            two.write()
                .to_buffered(std::io::Cursor::new(&mut bytes))
                .unwrap_or_else(|e| panic!("{name}, two parts: {e}"));
            out.push((format!("{name}, two parts"), bytes, im.clone()));
        }
    }
    out
}

#[test]
fn exr_samples_of_every_layout_are_read() {
    for (name, bytes, im) in exr_samples() {
        assert!(read_exr_bytes(&bytes).unwrap(), "{name}");
        let back = exr::decode_exr(&bytes, Path::new("s.exr")).unwrap();
        assert_eq!((back.width, back.height), (im.width, im.height), "{name}");
        // PXR24 keeps 24 of 32 bits and B44 stores f32 as it is; the others are lossless.
        let tolerance = if name.contains("PXR24") { 1e-4 } else { 0.0 };
        for (a, b) in back.rgb.iter().zip(&im.rgb) {
            let b32 = DVec3::new(b.x as f32 as f64, b.y as f32 as f64, b.z as f32 as f64);
            assert!(
                (*a - b32).abs().max_element() <= tolerance * b32.max_element(),
                "{name}: {a} vs {b32}"
            );
        }
    }
}

#[test]
fn exr_arbitrary_bytes() {
    // Arbitrary bytes; arbitrary bytes after the magic number and version 2; and arbitrary
    // offset tables and chunks after a valid scan-line header of any size and compression.
    let framed = any_bytes().prop_map(|b| [vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0], b].concat());
    let sizes = 0..EXR_SIZES.len();
    let headed = (sizes.clone(), sizes, 0..10u8, any_bytes()).prop_map(|(w, h, c, data)| {
        let (w, h) = (EXR_SIZES[w], EXR_SIZES[h]);
        [crate::pictures::exr_header(w, h, c, &["B", "G", "R"]), data].concat()
    });
    check(6144, prop_oneof![any_bytes(), framed, headed], |bytes| {
        read_exr_bytes(&bytes)?;
        Ok(())
    });
}

/// Integers that break OpenEXR headers and tables: window corners, tile sizes, counts,
/// offsets and chunk sizes near every limit.
fn exr_hostile_integers() -> Vec<i64> {
    let mut v = vec![
        0,
        1,
        -1,
        2,
        3,
        4,
        7,
        15,
        16,
        255,
        256,
        1 << 14,
        16383,
        65535,
        65536,
        99_999,
        (1 << 24) - 1,
        1 << 28,
        (1 << 30) - 2,
        (1 << 30) - 1,
        i32::MAX as i64,
        i32::MIN as i64,
        u32::MAX as i64,
        1 << 40,
        i64::MAX,
    ];
    v.extend(v.clone().iter().map(|x| -x));
    v
}

/// Where a mutation writes: a byte or 4-byte or 8-byte little-endian integer at a random
/// place, or at the value of a named header attribute (`dataWindow`, `tiles`, …), or in
/// the offset table.
#[derive(Clone, Debug)]
enum ExrEdit {
    Int(Index, u8, Index),
    Attribute(Index, Index, Index),
    Byte(Index, u8),
    /// A data window set to a size from [`EXR_SIZES`] each way (which window, width, height).
    Window(Index, Index, Index),
}

/// Data-window sides: small, at the pixel limit and past it.
const EXR_SIZES: [i32; 12] = [
    1,
    2,
    13,
    100,
    4096,
    16384,
    65535,
    100_000,
    (1 << 24) - 1,
    1 << 24,
    1 << 28,
    (1 << 30) - 2,
];

fn exr_edits() -> impl Strategy<Value = Vec<ExrEdit>> {
    let edit = prop_oneof![
        2 => (any::<Index>(), prop::sample::select(vec![1u8, 4, 8]), any::<Index>())
            .prop_map(|(at, w, v)| ExrEdit::Int(at, w, v)),
        4 => (any::<Index>(), any::<Index>(), any::<Index>())
            .prop_map(|(a, k, v)| ExrEdit::Attribute(a, k, v)),
        1 => (any::<Index>(), any::<u8>()).prop_map(|(at, v)| ExrEdit::Byte(at, v)),
        2 => (any::<Index>(), any::<Index>(), any::<Index>())
            .prop_map(|(which, w, h)| ExrEdit::Window(which, w, h)),
    ];
    prop::collection::vec(edit, 1..=4)
}

/// The byte ranges of the values of every attribute in the headers of `b` (name, then
/// type, then a 4-byte size): found by their names, which are not ambiguous in samples.
/// (Size fields are reached by [`ExrEdit::Int`].)
fn attribute_values(b: &[u8]) -> Vec<(usize, usize)> {
    let names: [&[u8]; 9] = [
        b"channels\0chlist\0",
        b"compression\0compression\0",
        b"dataWindow\0box2i\0",
        b"displayWindow\0box2i\0",
        b"lineOrder\0lineOrder\0",
        b"tiles\0tiledesc\0",
        b"chunkCount\0int\0",
        b"type\0string\0",
        b"name\0string\0",
    ];
    let mut out = Vec::new();
    for name in names {
        let mut from = 0;
        while let Some(k) = b[from..].windows(name.len()).position(|w| w == name) {
            let at = from + k + name.len();
            if at + 4 <= b.len() {
                let size = i32::from_le_bytes(b[at..at + 4].try_into().unwrap());
                let start = at + 4;
                let end = (start + size.max(0) as usize).min(b.len());
                out.push((start, end));
            }
            from = at;
        }
    }
    out
}

/// Where the values of every attribute `name_and_type` (`name\0type\0`) begin, past its
/// 4-byte size.
fn find_all(b: &[u8], name_and_type: &[u8]) -> Vec<usize> {
    (0..b.len().saturating_sub(name_and_type.len()))
        .filter(|&k| &b[k..k + name_and_type.len()] == name_and_type)
        .map(|k| k + name_and_type.len() + 4)
        .collect()
}

/// Sets the data window of part `part` of `b` (a copy of the valid `sample`) to `w × h`
/// pixels from its corner, and keeps a multi-part file's `chunkCount` of that part
/// consistent with it, so that the new size reaches daystep's own checks.
fn set_window(b: &mut [u8], sample: &[u8], part: usize, w: i32, h: i32) {
    let at = find_all(sample, b"dataWindow\0box2i\0")[part];
    let x_min = i32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let y_min = i32::from_le_bytes(b[at + 4..at + 8].try_into().unwrap());
    let x_max = x_min.saturating_add(w - 1);
    let y_max = y_min.saturating_add(h - 1);
    b[at + 8..at + 12].copy_from_slice(&x_max.to_le_bytes());
    b[at + 12..at + 16].copy_from_slice(&y_max.to_le_bytes());
    if let Some(&c) = find_all(sample, b"chunkCount\0int\0").get(part) {
        let header = &::exr::meta::MetaData::read_from_buffered(sample, true)
            .expect("a valid sample")
            .headers[part];
        let size = ::exr::math::Vec2(
            (i64::from(x_max) - i64::from(x_min) + 1) as usize,
            (i64::from(y_max) - i64::from(y_min) + 1) as usize,
        );
        let n = ::exr::meta::compute_chunk_count(header.compression, size, header.blocks);
        let n = i32::try_from(n).unwrap_or(i32::MAX);
        b[c..c + 4].copy_from_slice(&n.to_le_bytes());
    }
}

fn mutate_exr(sample: &[u8], edits: &[ExrEdit]) -> Vec<u8> {
    let mut b = sample.to_vec();
    let values = exr_hostile_integers();
    let fields = attribute_values(sample);
    let windows = find_all(sample, b"dataWindow\0box2i\0");
    for e in edits {
        if let ExrEdit::Window(which, w, h) = e {
            let size = |i: &Index| EXR_SIZES[i.index(EXR_SIZES.len())];
            set_window(&mut b, sample, which.index(windows.len()), size(w), size(h));
            continue;
        }
        let (at, width, value) = match e {
            ExrEdit::Int(at, width, v) => (
                at.index(b.len()),
                *width as usize,
                values[v.index(values.len())],
            ),
            ExrEdit::Attribute(a, k, v) => {
                let (start, end) = fields[a.index(fields.len())];
                let width = if end - start >= 4 { 4 } else { 1 };
                let slots = ((end - start) / width).max(1);
                (
                    start + k.index(slots) * width,
                    width,
                    values[v.index(values.len())],
                )
            }
            ExrEdit::Byte(at, v) => (at.index(b.len()), 1, i64::from(*v)),
            ExrEdit::Window(..) => unreachable!("handled above"),
        };
        let end = (at + width).min(b.len());
        let bytes = value.to_le_bytes();
        b[at..end].copy_from_slice(&bytes[..end - at]);
    }
    b
}

#[test]
fn exr_header_and_table_mutations() {
    let samples = exr_samples();
    let strategy = (
        any::<Index>(),
        exr_edits(),
        prop::option::weighted(0.2, any::<Index>()),
    );
    check(8192, strategy, |(which, edits, cut)| {
        let (_, sample, _) = &samples[which.index(samples.len())];
        let mut b = mutate_exr(sample, &edits);
        if let Some(c) = cut {
            b.truncate(c.index(b.len() + 1));
        }
        read_exr_bytes(&b)?;
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------
