//! Tests of the Radiance RGBE reader and writer (`super`).

use super::*;
use glam::DVec3;

fn gradient(w: usize, h: usize) -> Image {
    let mut im = Image::new(w, h, Quantity::Radiance);
    for r in 0..h {
        for c in 0..w {
            // Runs (constant left part) and literals, over six decades.
            let v = if c < w / 3 {
                2.5
            } else {
                10f64.powf(-2.0 + 6.0 * (r * w + c) as f64 / (w * h) as f64)
            };
            im.rgb[r * w + c] = DVec3::new(v, 0.5 * v, 0.9 * v);
        }
    }
    im
}

fn close(a: Rgb, b: Rgb) -> bool {
    // RGBE keeps 8 bits of mantissa relative to the largest component.
    (a - b).abs().max_element() <= 0.01 * b.max_element()
}

#[test]
fn round_trip_within_rgbe_precision_with_view_and_layout() {
    let d = tempfile::tempdir().unwrap();
    let view = View::default()
        .with_options("-vta -vd 0 1 0 -vh 180 -vv 180", Path::new("t"), None)
        .unwrap();
    for (w, h) in [(40, 7), (5, 3)] {
        let im = gradient(w, h);
        let p = d.path().join(format!("g{w}.hdr"));
        write_hdr(&p, &im, Some(&view)).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes[..80]);
        assert!(text.starts_with("#?RADIANCE\n"), "{text}");
        let (back, v) = read_hdr(&p).unwrap();
        assert_eq!((back.width, back.height), (w, h));
        let back_view = View::default()
            .with_options(&v.unwrap(), Path::new("t"), None)
            .unwrap();
        assert_eq!(back_view, view);
        for (a, b) in back.rgb.iter().zip(&im.rgb) {
            assert!(close(*a, *b), "{a} vs {b}");
        }
    }
}

#[test]
fn rgbe_encoding_matches_radiance_rule() {
    // 1.0 = 0.5 · 2^1: mantissa 128, exponent byte 129; decoded (128.5)/128.
    assert_eq!(to_rgbe(DVec3::ONE), [128, 128, 128, 129]);
    assert!((from_rgbe([128, 128, 128, 129]).x - 128.5 / 128.0).abs() < 1e-15);
    assert_eq!(to_rgbe(DVec3::ZERO), [0; 4]);
    assert_eq!(from_rgbe([10, 20, 30, 0]), DVec3::ZERO);
}

fn header(extra: &str, res: &str) -> Vec<u8> {
    format!("#?RADIANCE\n{extra}FORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes()
}

#[test]
fn decodes_a_hand_built_rle_scanline_and_honours_exposure() {
    // Width 10: red plane a run of 10 × 64; green literals; blue a run of 6 then
    // 4 literals; exponent a run of 10 × 129 (values (m + 0.5)/128).
    let mut b = header("EXPOSURE=2\nEXPOSURE=0.25\n", "-Y 1 +X 10");
    b.extend_from_slice(&[2, 2, 0, 10]);
    b.extend_from_slice(&[128 + 10, 64]);
    b.push(10);
    b.extend_from_slice(&[0, 10, 20, 30, 40, 50, 60, 70, 80, 90]);
    b.extend_from_slice(&[128 + 6, 7, 4, 1, 2, 3, 4]);
    b.extend_from_slice(&[128 + 10, 129]);
    let (im, view) = decode_hdr(&b, Path::new("hand.hdr")).unwrap();
    assert_eq!(view, None);
    let blue = [7, 7, 7, 7, 7, 7, 1, 2, 3, 4];
    for (k, b) in blue.iter().enumerate() {
        // Stored = true × 0.5, so true = stored / 0.5.
        let want = DVec3::new(64.5, (10 * k) as f64 + 0.5, *b as f64 + 0.5) / 128.0 / 0.5;
        assert!((im.rgb[k] - want).abs().max_element() < 1e-12, "{k}");
    }
}

#[test]
fn reads_flat_old_runs_and_bottom_up_layouts() {
    // +Y: the first scanline is the bottom row; old-style 1 1 1 2 repeats twice.
    let mut b = header("", "+Y 2 +X 3");
    b.extend_from_slice(&[128, 0, 0, 129, 1, 1, 1, 2]);
    b.extend_from_slice(&[0, 128, 0, 129, 0, 0, 128, 129, 0, 0, 128, 129]);
    let (im, _) = decode_hdr(&b, Path::new("old.hdr")).unwrap();
    let r = 128.5 / 128.0;
    let h = 0.5 / 128.0;
    assert_eq!(im.rgb[im.index(2, 1)], DVec3::new(r, h, h), "bottom row");
    assert_eq!(im.rgb[im.index(0, 0)], DVec3::new(h, r, h), "top row");
    assert_eq!(im.rgb[im.index(2, 0)], DVec3::new(h, h, r));
}

#[test]
fn bad_headers_and_data_name_the_file() {
    let e = decode_hdr(b"P6\n1 1\n", Path::new("x.ppm"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.ppm") && e.contains("#?RADIANCE"), "{e}");
    let b = b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0".to_vec();
    let e = decode_hdr(&b, Path::new("xyz.hdr"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("xyz.hdr:2") && e.contains("xyze"), "{e}");
    let e = decode_hdr(&header("EXPOSURE=abc\n", "-Y 1 +X 1"), Path::new("e.hdr"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("e.hdr:2") && e.contains("abc"), "{e}");
    let e = decode_hdr(&header("", "-Y 1 +Q 1"), Path::new("r.hdr"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("r.hdr:4") && e.contains("+Q"), "{e}");
    let mut b = header("", "-Y 2 +X 8");
    b.extend_from_slice(&[2, 2, 0, 8, 128 + 8, 1]);
    // Long enough for two scanlines of 8 pixels (8 bytes each at least): the run-length
    // code 0 of the second byte plane is what is wrong.
    b.resize(b.len() + 10, 0);
    let e = decode_hdr(&b, Path::new("t.hdr")).unwrap_err().to_string();
    assert!(e.contains("t.hdr") && e.contains("scanline 1 of 2"), "{e}");
    let e = decode_hdr(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", Path::new("h.hdr"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("h.hdr") && e.contains("header"), "{e}");
}

#[test]
fn a_64_byte_picture_claiming_65536_squared_pixels_is_refused_before_allocating() {
    // As filed: each side within Radiance's limits, the product 2^32 pixels (103 GB as
    // an image), allocated before any pixel was read.
    let mut b = header("", "-Y 65536 +X 65536");
    b.resize(64, 2);
    let path = Path::new("dir/big.hdr");
    let (shown, p, _, value) = crate::error::input_parts(decode_hdr(&b, path).unwrap_err());
    assert_eq!(p, path);
    assert_eq!(value.as_deref(), Some("65536 x 65536"));
    assert!(
        shown.contains("65536 x 65536 pixels is more than daystep reads (2^28 pixels)"),
        "{shown}"
    );
}

#[test]
fn a_picture_shorter_than_its_declared_size_is_refused_before_allocating() {
    // 4096 × 4096 is within the limit, but 4096 scanlines of 4096 pixels take at least
    // 12 bytes each; the file holds one flat scanline's worth of old-style runs.
    let mut b = header("", "-Y 4096 +X 4096");
    b.extend_from_slice(&[128, 128, 128, 129, 1, 1, 1, 255, 1, 1, 1, 15]);
    let path = Path::new("short.hdr");
    let e = decode_hdr(&b, path).unwrap_err().to_string();
    assert!(
        e.contains("short.hdr")
            && e.contains("4096 x 4096 pixels need at least 49152 bytes of scanlines")
            && e.contains("the file holds 12"),
        "{e}"
    );
    // Long enough, but its scanlines run out: refused (naming the scanline), with no
    // image allocated first.
    let mut b = header("", "-Y 4096 +X 4096");
    b.resize(b.len() + 4096 * 12, 0);
    let e = decode_hdr(&b, path).unwrap_err().to_string();
    assert!(
        e.contains("scanline 4 of 4096") && e.contains("ends early"),
        "{e}"
    );
}

/// The shortest old-style scanline of `len` pixels: the first pixel, then repeat records
/// holding the base-256 digits of `len - 1`, least significant first.
fn shortest_scanline(len: usize) -> Vec<u8> {
    let mut out = vec![100, 50, 25, 130];
    let mut rest = len - 1;
    while rest > 0 {
        out.extend_from_slice(&[1, 1, 1, (rest & 0xff) as u8]);
        rest >>= 8;
    }
    out
}

#[test]
fn the_scanline_lower_bound_is_met_by_the_shortest_old_style_runs() {
    // The bound must not refuse a valid picture: the shortest encoding meets it exactly
    // and decodes to the full scanline, and no encoding can be shorter (one byte less
    // is a truncated scanline).
    for len in [1, 2, 255, 256, 257, 4096, 65535, 65536] {
        let line = shortest_scanline(len);
        assert_eq!(line.len(), min_scanline_bytes(len), "{len}");
        let mut scan = vec![[0u8; 4]; len];
        let mut data = &line[..];
        read_scanline(&mut data, &mut scan).unwrap();
        assert!(data.is_empty() && scan.iter().all(|p| *p == [100, 50, 25, 130]));
        let mut cut = &line[..line.len() - 1];
        assert!(read_scanline(&mut cut, &mut scan).is_err(), "{len}");
    }
    // New-style runs (what write_hdr writes) never undercut it.
    for w in [8, 127, 128, 1000, 32767] {
        let mut out = Vec::new();
        encode_scanline(&vec![[7, 7, 7, 130]; w], &mut out);
        assert!(out.len() >= min_scanline_bytes(w), "{w}");
    }
    // A whole 16 384 × 16 384 picture (the pixel limit) of 12-byte scanlines passes the
    // file-size check.
    let mut b = header("", "-Y 2 +X 16384");
    b.extend(shortest_scanline(16384).repeat(2));
    let (im, _) = decode_hdr(&b, Path::new("long.hdr")).unwrap();
    assert_eq!((im.width, im.height, im.rgb.len()), (16384, 2, 32768));
}

#[test]
fn old_style_repeats_of_zero_do_not_overflow_the_run_shift() {
    // Each repeat record shifts the next count by 8 more bits; nine records of zero
    // used to shift by 64 (a panic on overflow checks). Zero repeats add nothing; a
    // non-zero one past 32 bits overruns any scanline.
    let mut b = header("", "-Y 1 +X 3");
    b.extend_from_slice(&[10, 20, 30, 130]);
    for _ in 0..9 {
        b.extend_from_slice(&[1, 1, 1, 0]);
    }
    b.extend_from_slice(&[40, 50, 60, 130, 70, 80, 90, 130]);
    let (im, _) = decode_hdr(&b, Path::new("zeros.hdr")).unwrap();
    assert_eq!(im.rgb[2], from_rgbe([70, 80, 90, 130]));
    let mut b = header("", "-Y 1 +X 3");
    b.extend_from_slice(&[10, 20, 30, 130]);
    for n in [0, 0, 0, 0, 1] {
        b.extend_from_slice(&[1, 1, 1, n]);
    }
    b.extend_from_slice(&[0; 8]);
    let e = decode_hdr(&b, Path::new("zeros.hdr"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("overruns"), "{e}");
}
