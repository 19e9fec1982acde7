//! Tests of the OpenEXR writer and reader: round trips, provenance, and the size and
//! file-length checks that keep a picture from exhausting memory.

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
