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
#[path = "rgbe_tests.rs"]
mod tests;
