//! Radiance HDR pictures (RGBE, `#?RADIANCE`, `FORMAT=32-bit_rle_rgbe`), the format
//! rpict writes and evalglare, pcomb, pfilt and ximage read.
//!
//! A file is a text header (`#?RADIANCE`, `NAME=value` lines such as `VIEW=`,
//! `EXPOSURE=`, `FORMAT=`, ended by an empty line), a resolution line (`-Y H +X W` for
//! rows from the top, each from the left) and the scanlines: four bytes per pixel, a
//! shared exponent `e` and three mantissas `m`, value `(m + 0.5) · 2^(e − 136)`.
//! Scanlines are flat, old-style run-length (a `1 1 1 n` pixel repeats the previous one)
//! or new-style run-length (`2 2 hi lo`, then each byte plane in runs); [`read_hdr`]
//! reads all three, [`write_hdr`] writes new-style runs (flat for widths Radiance does not
//! encode, below 8 or above 32767).
//!
//! Values are radiance W·sr⁻¹·m⁻² (or irradiance W/m² for `-i` pictures; the header does
//! not say which). `EXPOSURE=` lines mean the stored values are the true ones times the
//! product of the exposures, so the reader divides by it.

use crate::error::{Error, Result};
use crate::photometry::Rgb;
use crate::render::image::{check_size, Image, Quantity};
use crate::scene::view::View;
use std::path::Path;

/// Radiance's encoded format name for RGB pictures.
pub const FORMAT_RGBE: &str = "32-bit_rle_rgbe";

/// Scanline widths Radiance run-length encodes (shorter or longer ones are flat).
const RLE_WIDTHS: std::ops::RangeInclusive<usize> = 8..=0x7fff;

/// Encodes one RGB value (any unit) as Radiance's 4-byte RGBE (as its `setcolr`):
/// mantissas truncated, so decoding adds half a step back.
pub fn to_rgbe(c: Rgb) -> [u8; 4] {
    let d = c.x.max(c.y).max(c.z);
    if !d.is_finite() || d <= 1e-32 {
        return [0; 4];
    }
    let (m, e) = frexp(d);
    let s = m * 256.0 / d;
    let q = |v: f64| (v.max(0.0) * s).floor().min(255.0) as u8;
    [q(c.x), q(c.y), q(c.z), (e + 128).clamp(0, 255) as u8]
}

/// Decodes a 4-byte RGBE value (as Radiance's `colr_color`): `(m + 0.5) · 2^(e − 136)`,
/// zero when the exponent byte is zero.
pub fn from_rgbe(b: [u8; 4]) -> Rgb {
    if b[3] == 0 {
        return Rgb::ZERO;
    }
    let f = 2f64.powi(b[3] as i32 - (128 + 8));
    Rgb::new(
        (b[0] as f64 + 0.5) * f,
        (b[1] as f64 + 0.5) * f,
        (b[2] as f64 + 0.5) * f,
    )
}

/// `d = m · 2^e` with `m` in [0.5, 1), for finite positive `d`.
fn frexp(d: f64) -> (f64, i32) {
    let mut e = d.log2().floor() as i32 + 1;
    let mut m = d / 2f64.powi(e);
    // log2 can be off by one ulp at exact powers of two.
    if m >= 1.0 {
        m /= 2.0;
        e += 1;
    } else if m < 0.5 {
        m *= 2.0;
        e -= 1;
    }
    (m, e)
}

/// Writes `image` as a Radiance HDR picture at `path` (atomically): `#?RADIANCE`, the
/// command and software of its provenance, `VIEW=` from `view` when given,
/// `FORMAT=32-bit_rle_rgbe`, `-Y H +X W`, then new-style run-length scanlines from the
/// top row. Pixels outside the image's valid area are written black. Values are stored as
/// they are (no `EXPOSURE=`), W·sr⁻¹·m⁻² for radiance images.
///
/// # Errors
/// An image whose pixel count does not match its size, or the file cannot be written.
pub fn write_hdr(path: &Path, image: &Image, view: Option<&View>) -> Result<()> {
    let (w, h) = (image.width, image.height);
    if image.rgb.len() != w * h || (!image.valid.is_empty() && image.valid.len() != w * h) {
        return Err(Error::Internal(format!(
            "image of {w}×{h} holds {} values and {} flags",
            image.rgb.len(),
            image.valid.len()
        )));
    }
    let mut out = Vec::with_capacity(w * h * 4 / 2 + 256);
    out.extend_from_slice(b"#?RADIANCE\n");
    // Header lines must stay single lines, whatever the provenance holds.
    let one_line = |s: &str| s.replace(['\n', '\r'], " ");
    let p = &image.provenance;
    if !p.command.is_empty() {
        out.extend_from_slice(format!("{}\n", one_line(&p.command)).as_bytes());
    }
    if !p.software.is_empty() {
        out.extend_from_slice(format!("SOFTWARE= {}\n", one_line(&p.software)).as_bytes());
    }
    if let Some(v) = view {
        out.extend_from_slice(format!("VIEW= {}\n", v.options()).as_bytes());
    }
    out.extend_from_slice(format!("FORMAT={FORMAT_RGBE}\n\n-Y {h} +X {w}\n").as_bytes());
    let mut scan = vec![[0u8; 4]; w];
    for row in 0..h {
        for (col, s) in scan.iter_mut().enumerate() {
            let i = row * w + col;
            let ok = image.valid.get(i).copied().unwrap_or(true);
            *s = if ok { to_rgbe(image.rgb[i]) } else { [0; 4] };
        }
        encode_scanline(&scan, &mut out);
    }
    crate::files::write_atomic(path, &out)
}

/// Appends one scanline: new-style runs for widths Radiance encodes, flat otherwise.
fn encode_scanline(scan: &[[u8; 4]], out: &mut Vec<u8>) {
    let n = scan.len();
    if !RLE_WIDTHS.contains(&n) {
        for p in scan {
            out.extend_from_slice(p);
        }
        return;
    }
    out.extend_from_slice(&[2, 2, (n >> 8) as u8, (n & 0xff) as u8]);
    for c in 0..4 {
        let plane: Vec<u8> = scan.iter().map(|p| p[c]).collect();
        let mut j = 0;
        let mut lit_start = 0;
        while j < n {
            let mut run = 1;
            while j + run < n && run < 127 && plane[j + run] == plane[j] {
                run += 1;
            }
            // Runs shorter than 4 cost more than literals.
            if run >= 4 {
                flush_literals(&plane[lit_start..j], out);
                out.extend_from_slice(&[128 + run as u8, plane[j]]);
                j += run;
                lit_start = j;
            } else {
                j += 1;
            }
        }
        flush_literals(&plane[lit_start..n], out);
    }
}

fn flush_literals(bytes: &[u8], out: &mut Vec<u8>) {
    for chunk in bytes.chunks(128) {
        out.push(chunk.len() as u8);
        out.extend_from_slice(chunk);
    }
}

/// Reads a Radiance HDR picture: the image (values divided by the product of the header's
/// `EXPOSURE=` lines, so W·sr⁻¹·m⁻² for rpict radiance pictures; every pixel valid, zero
/// stated error; [`Quantity::Radiance`]) and the view options of its `VIEW=` lines (all of
/// them in order, later ones overriding earlier ones as Radiance reads them), if any.
/// Accepts the eight resolution-line orientations and flat, old-style and new-style
/// run-length scanlines.
///
/// # Errors
/// An unreadable file; a missing `#?` magic line, a `FORMAT=` other than
/// `32-bit_rle_rgbe`, a bad `EXPOSURE=` value or resolution line (naming the file and
/// header line); truncated or corrupt scanlines (naming the scanline).
pub fn read_hdr(path: &Path) -> Result<(Image, Option<String>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_hdr(&bytes, path)
}

/// [`read_hdr`] on bytes already in memory; `path` names them in errors.
///
/// # Errors
/// As [`read_hdr`].
pub fn decode_hdr(bytes: &[u8], path: &Path) -> Result<(Image, Option<String>)> {
    let bad = |line: Option<usize>, value: &str, msg: &str| {
        Error::input(path, line, Some(value).filter(|v| !v.is_empty()), msg)
    };
    let mut pos = 0;
    let next_line = |pos: &mut usize| -> Option<(usize, String)> {
        if *pos >= bytes.len() {
            return None;
        }
        let start = *pos;
        let end = bytes[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|k| start + k)
            .unwrap_or(bytes.len());
        *pos = (end + 1).min(bytes.len());
        Some((
            start,
            String::from_utf8_lossy(&bytes[start..end]).into_owned(),
        ))
    };
    let mut n = 0;
    let mut exposure = 1.0;
    let mut views: Vec<String> = Vec::new();
    loop {
        let Some((_, line)) = next_line(&mut pos) else {
            return Err(bad(
                Some(n),
                "",
                "Radiance picture ends inside its header (no empty line before the resolution)",
            ));
        };
        n += 1;
        let line = line.trim_end_matches('\r');
        if n == 1 {
            if !line.starts_with("#?") {
                return Err(bad(
                    Some(1),
                    &line.chars().take(40).collect::<String>(),
                    "not a Radiance picture: the first line must be #?RADIANCE",
                ));
            }
            continue;
        }
        if line.is_empty() {
            break;
        }
        if let Some(v) = line.strip_prefix("FORMAT=") {
            if v.trim() != FORMAT_RGBE {
                return Err(bad(
                    Some(n),
                    v.trim(),
                    "unsupported picture format (daystep reads 32-bit_rle_rgbe)",
                ));
            }
        } else if let Some(v) = line.strip_prefix("EXPOSURE=") {
            let e = v
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|e| e.is_finite() && *e > 0.0)
                .ok_or_else(|| bad(Some(n), v.trim(), "EXPOSURE must be a positive number"))?;
            exposure *= e;
        } else if let Some(v) = line.strip_prefix("VIEW=") {
            views.push(v.trim().to_owned());
        }
    }
    let res_no = n + 1;
    let (_, res) = next_line(&mut pos)
        .ok_or_else(|| bad(Some(res_no), "", "Radiance picture has no resolution line"))?;
    let res = res.trim_end_matches('\r');
    let layout = Layout::parse(res).ok_or_else(|| {
        bad(
            Some(res_no),
            res,
            "bad resolution line (expected e.g. -Y 480 +X 640)",
        )
    })?;
    let (w, h) = (layout.width(), layout.height());
    check_size(path, w, h, 3)?;
    let data = &bytes[pos..];
    // Refuses a file too short for its declared size before anything is allocated.
    let least = layout.len1.saturating_mul(min_scanline_bytes(layout.len2));
    if data.len() < least {
        return Err(Error::input(
            path,
            None,
            Some(&format!("{w} x {h}")),
            format!(
                "{w} x {h} pixels need at least {least} bytes of scanlines, the file holds {} \
                 (truncated or corrupt picture)",
                data.len()
            ),
        ));
    }
    let mut scan = vec![[0u8; 4]; layout.len2];
    let scanline_error = |s: usize, msg: String| {
        Error::input(
            path,
            None,
            Some(&format!("scanline {} of {}", s + 1, layout.len1)),
            msg,
        )
    };
    // Old-style runs can encode a scanline of 65 536 pixels in 12 bytes, so a small file may
    // still declare a large picture: every scanline is decoded once without being kept, and
    // the image is allocated only for a file that does hold all the pixels it declares.
    let mut rest = data;
    for s in 0..layout.len1 {
        read_scanline(&mut rest, &mut scan).map_err(|msg| scanline_error(s, msg))?;
    }
    let mut image = Image::try_new(w, h, Quantity::Radiance, path)?;
    let mut data = data;
    for s in 0..layout.len1 {
        read_scanline(&mut data, &mut scan).map_err(|msg| scanline_error(s, msg))?;
        for (k, p) in scan.iter().enumerate() {
            let (col, row) = layout.pixel(s, k);
            image.rgb[row * w + col] = from_rgbe(*p) / exposure;
        }
    }
    let view = (!views.is_empty()).then(|| views.join(" "));
    image.provenance.view = view.clone().unwrap_or_default();
    Ok((image, view))
}

/// A resolution line: `len1` scanlines of `len2` pixels; `y_major` when scanlines are
/// rows; the signs say which way each axis runs.
struct Layout {
    y_major: bool,
    /// First axis increasing (`+Y`: scanlines from the bottom; `+X`: from the left).
    inc1: bool,
    inc2: bool,
    len1: usize,
    len2: usize,
}

impl Layout {
    fn parse(line: &str) -> Option<Layout> {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.len() != 4 {
            return None;
        }
        let axis = |s: &str| -> Option<(bool, char)> {
            let mut c = s.chars();
            let sign = match c.next()? {
                '+' => true,
                '-' => false,
                _ => return None,
            };
            let a = c.next()?;
            (c.next().is_none() && (a == 'X' || a == 'Y')).then_some((sign, a))
        };
        let (inc1, a1) = axis(t[0])?;
        let (inc2, a2) = axis(t[2])?;
        let len1: usize = t[1].parse().ok().filter(|&v| v > 0)?;
        let len2: usize = t[3].parse().ok().filter(|&v| v > 0)?;
        // Guards the allocation against corrupt headers (Radiance's own limit is 2^15 for
        // encoding; pictures beyond 2^16 a side are not made by its tools).
        if a1 == a2 || len1 > 1 << 16 || len2 > 1 << 16 {
            return None;
        }
        Some(Layout {
            y_major: a1 == 'Y',
            inc1,
            inc2,
            len1,
            len2,
        })
    }

    fn width(&self) -> usize {
        if self.y_major {
            self.len2
        } else {
            self.len1
        }
    }

    fn height(&self) -> usize {
        if self.y_major {
            self.len1
        } else {
            self.len2
        }
    }

    /// (column from the left, row from the top) of pixel `k` of scanline `s`.
    fn pixel(&self, s: usize, k: usize) -> (usize, usize) {
        let along = |i: usize, len: usize, inc: bool| if inc { i } else { len - 1 - i };
        if self.y_major {
            // Y grows upwards, so -Y (decreasing) scanlines start at the top.
            (
                along(k, self.len2, self.inc2),
                along(s, self.len1, !self.inc1),
            )
        } else {
            (
                along(s, self.len1, self.inc1),
                along(k, self.len2, !self.inc2),
            )
        }
    }
}

/// The fewest bytes any scanline of `len` (≥ 1) pixels can take, whichever way it is
/// encoded, so that `len1 ×` this is a lower bound of the bytes after a picture's resolution
/// line:
///
/// - flat: 4 bytes a pixel, `4·len`;
/// - new-style runs: the 4-byte `2 2 hi lo` pixel, then each of the 4 byte planes in
///   records of a run (2 bytes for at most 127 pixels) or literals (`k + 1` bytes for `k` ≤
///   128 pixels, never fewer than the `2·⌈k/127⌉` bytes of runs), so `4 + 8·⌈len/127⌉`;
/// - old-style runs: the first pixel (4 bytes), then 4-byte records; `r` consecutive
///   `1 1 1 n` repeat records (counts shifted by 0, 8, 16, … bits) repeat at most
///   `256^r − 1` pixels and a literal in between only resets the shift, so `4·(1 + r)` with
///   `r` the number of base-256 digits of `len − 1`.
///
/// The least of the three is the old-style one (at most 12 bytes up to 65 536 pixels).
fn min_scanline_bytes(len: usize) -> usize {
    let mut rest = len.saturating_sub(1);
    let mut records = 0;
    while rest > 0 {
        records += 1;
        rest >>= 8;
    }
    4 * (1 + records)
}

/// Reads one scanline of `scan.len()` pixels from the front of `data` (advancing it).
fn read_scanline(data: &mut &[u8], scan: &mut [[u8; 4]]) -> std::result::Result<(), String> {
    let len = scan.len();
    let short = || "picture data ends early (truncated file?)".to_string();
    let mut take = |n: usize| -> std::result::Result<&[u8], String> {
        if data.len() < n {
            return Err(short());
        }
        let (a, b) = data.split_at(n);
        *data = b;
        Ok(a)
    };
    let first: [u8; 4] = take(4)?.try_into().expect("4 bytes");
    // As Radiance's freadcolrs: a 2 2 n pixel (n < 32768) starts a new-style line,
    // anything else is a flat or old-style line.
    let new_style = first[0] == 2 && first[1] == 2 && first[2] & 0x80 == 0;
    if !new_style {
        // Flat or old-style runs: a 1 1 1 n pixel repeats the previous one n times,
        // consecutive repeats shifting n by 8 bits more each.
        scan[0] = first;
        let mut j = 1;
        let mut shift = 0;
        while j < len {
            let p: [u8; 4] = take(4)?.try_into().expect("4 bytes");
            if p[0] == 1 && p[1] == 1 && p[2] == 1 {
                let count = u64::from(p[3]) << shift;
                if count > (len - j) as u64 {
                    return Err("old-style run overruns the scanline".into());
                }
                let count = count as usize;
                let prev = scan[j - 1];
                scan[j..j + count].fill(prev);
                j += count;
                // Repeats of zero keep shifting; held at 32 bits (any non-zero count then
                // overruns a scanline of at most 2^16 pixels), the shift cannot overflow.
                shift = (shift + 8).min(32);
            } else {
                scan[j] = p;
                j += 1;
                shift = 0;
            }
        }
        return Ok(());
    }
    let stated = (first[2] as usize) << 8 | first[3] as usize;
    if stated != len {
        return Err(format!(
            "run-length scanline states {stated} pixels, the picture {len}"
        ));
    }
    for c in 0..4 {
        let mut j = 0;
        while j < len {
            let code = take(1)?[0] as usize;
            if code > 128 {
                let n = code & 127;
                let v = take(1)?[0];
                if j + n > len {
                    return Err("run overruns the scanline".into());
                }
                for p in &mut scan[j..j + n] {
                    p[c] = v;
                }
                j += n;
            } else {
                if code == 0 || j + code > len {
                    return Err("bad run-length code in scanline".into());
                }
                let src = take(code)?;
                for (p, &v) in scan[j..j + code].iter_mut().zip(src) {
                    p[c] = v;
                }
                j += code;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
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
}
