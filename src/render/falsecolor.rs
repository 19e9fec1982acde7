//! Falsecolor maps as Radiance's `falsecolor` makes them: each pixel's photometric value
//! (luminance cd/m² or illuminance lux, 179 × grey) is mapped to `v` in [0, 1] on a linear
//! scale up to `-s` or a logarithmic one over `-log N` decades, and `v` to a colour of the
//! default palette (`-pal def`); a legend strip on the left shows the palette as a
//! continuous ramp filling the picture's height below the unit, with `-n` labels at the
//! middle of each band, in DejaVu Sans (embedded, `assets/fonts`; [`super::text`]).
//!
//! The palette's linear colours are written to 8-bit PNG through the sRGB curve, as a
//! Radiance picture of them looks on a display.

use crate::error::Result;
use crate::files;
use crate::photometry::Rgb;
use crate::render::image::{Image, Quantity};
use crate::render::text;
use crate::render::tonemap::{encode_png, provenance_text, srgb8};
use std::path::Path;

// Knots of Radiance's `def` palette (falsecolor.cal `def_redp`, `def_grnp`, `def_blup`):
// 23 linear RGB values at v = k/22, interpolated linearly between them.
const KNOTS: [[f64; 3]; 23] = [
    [0.18848, 0.0009766, 0.2666],
    [0.05468174, 2.35501e-05, 0.3638662],
    [0.00103547, 0.0008966244, 0.4770437],
    [8.311144e-08, 0.0264977, 0.5131397],
    [7.449763e-06, 0.1256843, 0.5363797],
    [0.0004390987, 0.2865799, 0.5193677],
    [0.001367254, 0.4247083, 0.4085123],
    [0.003076, 0.4739468, 0.1702815],
    [0.01376382, 0.4402732, 0.05314236],
    [0.06170773, 0.3671876, 0.05194055],
    [0.1739422, 0.2629843, 0.08564082],
    [0.2881156, 0.1725325, 0.09881395],
    [0.3299725, 0.1206819, 0.08324373],
    [0.3552663, 0.07316644, 0.06072902],
    [0.372552, 0.03761026, 0.0391076],
    [0.3921184, 0.01612362, 0.02315354],
    [0.4363976, 0.004773749, 0.01284458],
    [0.6102754, 6.830967e-06, 0.005184709],
    [0.7757267, 0.00803605, 0.001691774],
    [0.9087369, 0.1008085, 2.432735e-05],
    [1.0, 0.3106831, 1.212949e-05],
    [1.0, 0.6447838, 0.006659406],
    [0.9863, 0.9707, 0.02539],
];

/// The linear RGB colour (each in [0, 1]) of Radiance's default falsecolor palette at `v`:
/// linear interpolation between 23 knots at `v = k/22`; `v ≤ 0` (and NaN) gives the
/// bottom colour, `v ≥ 1` the top one. (`falsecolor.cal` spaces the knots by 0.0454545
/// rather than 1/22: a difference below 1e-6 in `v`.)
pub fn palette(v: f64) -> Rgb {
    let x = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) } * 22.0;
    let k = (x.floor() as usize).min(21);
    let t = x - k as f64;
    let (a, b) = (Rgb::from_array(KNOTS[k]), Rgb::from_array(KNOTS[k + 1]));
    (a * (1.0 - t) + b * t).clamp(Rgb::ZERO, Rgb::ONE)
}

/// Options of a falsecolor map, after Radiance's `falsecolor` options.
#[derive(Clone, Debug, PartialEq)]
pub struct Falsecolor {
    /// Top of the scale (`-s`), cd/m² for radiance images or lux for irradiance images:
    /// values at or above it take the palette's top colour. Radiance's default is 1000.
    pub scale_max: f64,
    /// Number of legend bands and labels (`-n`), default 8; also the number of contour
    /// levels.
    pub steps: u32,
    /// Logarithmic scale over this many decades below `scale_max` (`-log N`):
    /// `scale_max / 10^N` and below map to the bottom colour. `None`: linear from 0.
    pub log_decades: Option<u32>,
    /// Contour lines only (`-cl`): pixels where the band index `floor(steps·v + ½)`
    /// changes to a horizontal or vertical neighbour are coloured, the rest black.
    pub contour_lines: bool,
    /// Legend width in pixels (`-lw`, default 100); the legend is left out when this is
    /// ≤ 20 or `legend_height` ≤ 40, as `falsecolor` does.
    pub legend_width: usize,
    /// Least legend height in pixels (`-lh`, default 200) of the colour ramp; the unit
    /// label sits above it, and the ramp grows to fill the picture's height below it.
    pub legend_height: usize,
}

impl Default for Falsecolor {
    fn default() -> Self {
        Falsecolor {
            scale_max: 1000.0,
            steps: 8,
            log_decades: None,
            contour_lines: false,
            legend_width: 100,
            legend_height: 200,
        }
    }
}

/// 8-bit RGBA pixels, row-major from the top-left, alpha 255.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgba8 {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// `width × height × 4` bytes.
    pub data: Vec<u8>,
}

impl Rgba8 {
    pub(super) fn new(width: usize, height: usize) -> Rgba8 {
        let mut data = vec![0; width * height * 4];
        data.chunks_mut(4).for_each(|p| p[3] = 255);
        Rgba8 {
            width,
            height,
            data,
        }
    }

    fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        let i = 4 * (y * self.width + x);
        self.data[i..i + 3].copy_from_slice(&c);
    }

    /// Mixes colour `c` into pixel (`x`, `y`) by `coverage` in [0, 1]; outside: nothing.
    pub(super) fn blend(&mut self, x: i64, y: i64, c: [u8; 3], coverage: f32) {
        if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
            return;
        }
        let i = 4 * (y as usize * self.width + x as usize);
        let a = coverage.clamp(0.0, 1.0);
        for (d, s) in self.data[i..i + 3].iter_mut().zip(c) {
            *d = (f32::from(*d) * (1.0 - a) + f32::from(s) * a).round() as u8;
        }
    }

    /// The RGB bytes of pixel (`x` from the left, `y` from the top).
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = 4 * (y * self.width + x);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
}

fn encoded(c: Rgb) -> [u8; 3] {
    [srgb8(c.x), srgb8(c.y), srgb8(c.z)]
}

impl Falsecolor {
    /// Position `v` on the scale of a photometric `value` (cd/m² or lux): `value /
    /// scale_max`, or with `log_decades = N`, `log10(value / scale_max) / N + 1` (0 at and
    /// below `scale_max / 10^N`). Not clamped: above 1 is over the scale.
    pub fn position(&self, value: f64) -> f64 {
        let x = value / self.scale_max;
        match self.log_decades {
            Some(n) if n > 0 => {
                if x > 10f64.powi(-(n as i32)) {
                    x.log10() / f64::from(n) + 1.0
                } else {
                    0.0
                }
            }
            _ => x,
        }
    }

    /// The legend's text, top to bottom: the unit (`cd/m2` or `lux`), then one value per
    /// band from the top, each the value (cd/m² or lux) at the middle of its band, written
    /// as `falsecolor` writes it (15 significant digits, cut — not rounded — to at most 3
    /// decimals).
    pub fn legend_labels(&self, quantity: Quantity) -> Vec<String> {
        let n = self.steps.max(1);
        let mut labels = vec![quantity.unit().to_owned()];
        for i in 0..n {
            let imap = (f64::from(n) - 0.5 - f64::from(i)) / f64::from(n);
            let value = match self.log_decades {
                Some(d) if d > 0 => self.scale_max * 10f64.powf((imap - 1.0) * f64::from(d)),
                _ => self.scale_max * imap,
            };
            labels.push(cut_decimals(&perl_number(value)));
        }
        labels
    }

    fn band(&self, v: f64) -> f64 {
        (f64::from(self.steps.max(1)) * v + 0.5).floor()
    }

    fn on_scale(v: f64) -> bool {
        (0.0..1.0).contains(&v)
    }

    /// The falsecolor map of `image` with its legend on the left, as 8-bit sRGB RGBA. The
    /// image sits right of the legend; both are aligned to the bottom edge (as `pcompos`
    /// places them) and the rest is black, as are pixels outside a fisheye's circle.
    pub fn to_rgba8(&self, image: &Image) -> Rgba8 {
        let steps = self.steps.max(1) as usize;
        let legend = self.legend_width > 20 && self.legend_height > 40;
        let (lw, lh) = if legend {
            (self.legend_width, self.legend_height)
        } else {
            (0, 0)
        };
        // The unit's line on top, then the ramp down to the bottom edge, at least `lh` tall
        // and as tall as the image allows.
        let unit_line = if legend {
            ((lh as f64 / steps as f64) + 0.5).floor().clamp(16.0, 40.0) as usize
        } else {
            0
        };
        let height = image.height.max(lh + unit_line);
        let ramp = height - unit_line;
        let mut out = Rgba8::new(lw + image.width, height);

        let vs: Vec<f64> = (0..image.rgb.len())
            .map(|i| self.position(image.photometric(i)))
            .collect();
        let top = height - image.height;
        for y in 0..image.height {
            for x in 0..image.width {
                let i = image.index(x, y);
                if !image.valid[i] {
                    continue;
                }
                let v = vs[i];
                if self.contour_lines {
                    // Outside a fisheye's circle is no contour: an invalid neighbour counts as
                    // the pixel itself.
                    let at = |xx: usize, yy: usize| {
                        let j = image.index(xx, yy);
                        if image.valid[j] {
                            vs[j]
                        } else {
                            v
                        }
                    };
                    let (l, r) = (
                        at(x.saturating_sub(1), y),
                        at((x + 1).min(image.width - 1), y),
                    );
                    let (a, b) = (
                        at(x, y.saturating_sub(1)),
                        at(x, (y + 1).min(image.height - 1)),
                    );
                    let edge = self.band(l) != self.band(r) || self.band(a) != self.band(b);
                    if !(Self::on_scale(v) && edge) {
                        continue;
                    }
                }
                out.set(lw + x, top + y, encoded(palette(v)));
            }
        }

        if legend {
            for yb in 0..ramp {
                let v = (yb as f64 + 0.5) / ramp as f64;
                if self.contour_lines {
                    let below = (yb as f64 - 0.5) / ramp as f64;
                    let above = (yb as f64 + 1.5) / ramp as f64;
                    if self.band(below) == self.band(above) {
                        continue;
                    }
                }
                let c = encoded(palette(v));
                for x in 0..lw {
                    out.set(x, height - 1 - yb, c);
                }
            }
            let labels = self.legend_labels(image.quantity);
            let band = ramp as f64 / steps as f64;
            // One size for all labels: as large as the band and the strip's width allow,
            // within 11 to 24 pixels.
            let widest = labels
                .iter()
                .map(|t| text::width(t, 1.0))
                .fold(0.0, f64::max)
                .max(1e-9);
            let size = (0.6 * band)
                .min(0.8 * unit_line as f64)
                .min((lw as f64 - 8.0) / widest)
                .clamp(11.0, 24.0);
            for (j, label) in labels.iter().enumerate() {
                // The unit (j = 0) in the top line, band labels at their band's middle.
                let centre = if j == 0 {
                    unit_line as f64 / 2.0
                } else {
                    unit_line as f64 + (j as f64 - 0.5) * band
                };
                // A dark shadow one pixel right and down keeps light bands readable.
                text::draw(&mut out, 5.0, centre + 1.0, size, label, [0, 0, 0]);
                text::draw(&mut out, 4.0, centre, size, label, [255, 255, 255]);
            }
        }
        out
    }
}

// A number as Perl prints it (`%.15g`).
fn perl_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v.is_nan() {
            "NaN".into()
        } else if v == 0.0 {
            "0".into()
        } else {
            format!("{v}")
        };
    }
    let e = v.abs().log10().floor() as i32;
    let strip = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            s
        }
    };
    if (-5..15).contains(&e) {
        let decimals = (14 - e).max(0) as usize;
        strip(format!("{v:.decimals$}"))
    } else {
        let s = format!("{v:.14e}");
        let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
        let exp: i32 = exp.parse().unwrap_or(0);
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{}e{sign}{:02}", strip(mantissa.to_owned()), exp.abs())
    }
}

// `falsecolor`'s `s/(\.[0-9]{3})[0-9]*/$1/`: the first point followed by three digits keeps
// those three and loses the digits after them.
fn cut_decimals(s: &str) -> String {
    let b = s.as_bytes();
    for p in 0..b.len() {
        if b[p] == b'.' && b.len() >= p + 4 && b[p + 1..p + 4].iter().all(u8::is_ascii_digit) {
            let mut end = p + 4;
            while end < b.len() && b[end].is_ascii_digit() {
                end += 1;
            }
            return format!("{}{}", &s[..p + 4], &s[end..]);
        }
    }
    s.to_owned()
}

/// Writes the falsecolor map of `image` with its legend (see [`Falsecolor::to_rgba8`]) to
/// `path` as an 8-bit sRGB PNG with the provenance as text chunks, atomically.
///
/// # Errors
/// [`crate::error::Error::Io`] naming `path` when it cannot be written;
/// [`crate::error::Error::Internal`] when encoding fails.
pub fn write_falsecolor_png(path: &Path, image: &Image, options: &Falsecolor) -> Result<()> {
    let map = options.to_rgba8(image);
    let bytes = encode_png(map.width, map.height, &map.data, &provenance_text(image))?;
    files::write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::EFFICACY_LM_PER_W;

    fn close(a: Rgb, b: [f64; 3]) -> bool {
        (a - Rgb::from_array(b)).abs().max_element() < 1e-9
    }

    #[test]
    fn palette_follows_the_def_knots() {
        // Values of falsecolor.cal's def_redp/def_grnp/def_blup, knots 1, 11, 12 and 23.
        assert!(close(palette(0.0), [0.18848, 0.0009766, 0.2666]));
        assert!(close(palette(1.0), [0.9863, 0.9707, 0.02539]));
        assert!(close(
            palette(10.0 / 22.0),
            [0.1739422, 0.2629843, 0.08564082]
        ));
        let mid = [
            0.5 * (0.1739422 + 0.2881156),
            0.5 * (0.2629843 + 0.1725325),
            0.5 * (0.08564082 + 0.09881395),
        ];
        assert!(close(palette(10.5 / 22.0), mid));
        // A quarter of the way from knot 20 to knot 21 (v = 19.25/22).
        let q = [
            0.75 * 0.9087369 + 0.25 * 1.0,
            0.75 * 0.1008085 + 0.25 * 0.3106831,
            0.75 * 2.432735e-05 + 0.25 * 1.212949e-05,
        ];
        assert!(close(palette(19.25 / 22.0), q));
        assert!(close(palette(-3.0), [0.18848, 0.0009766, 0.2666]));
        assert!(close(palette(f64::NAN), [0.18848, 0.0009766, 0.2666]));
    }

    fn image_of(values: &[f64], quantity: Quantity) -> Image {
        let mut im = Image::new(values.len(), 1, quantity);
        for (c, &l) in im.rgb.iter_mut().zip(values) {
            *c = Rgb::splat(l / EFFICACY_LM_PER_W);
        }
        im
    }

    fn no_legend() -> Falsecolor {
        Falsecolor {
            legend_width: 0,
            ..Falsecolor::default()
        }
    }

    #[test]
    fn values_over_the_scale_saturate() {
        let opts = no_legend();
        let map = opts.to_rgba8(&image_of(&[1000.0, 2500.0, 1e7, 500.0], Quantity::Radiance));
        let top = encoded(palette(1.0));
        assert_eq!(map.pixel(0, 0), top);
        assert_eq!(map.pixel(1, 0), top);
        assert_eq!(map.pixel(2, 0), top);
        assert_eq!(map.pixel(3, 0), encoded(palette(0.5)));
        assert_ne!(map.pixel(3, 0), top);
    }

    #[test]
    fn log_scale_puts_scale_over_ten_to_the_n_at_the_bottom() {
        let opts = Falsecolor {
            scale_max: 2000.0,
            log_decades: Some(3),
            ..no_legend()
        };
        assert!((opts.position(2.0)).abs() < 1e-12);
        assert!((opts.position(20.0) - 1.0 / 3.0).abs() < 1e-12);
        assert!((opts.position(2000.0) - 1.0).abs() < 1e-12);
        assert_eq!(opts.position(0.5), 0.0);
        let map = opts.to_rgba8(&image_of(&[2.0, 0.1, 2000.0, 200.0], Quantity::Radiance));
        let bottom = encoded(palette(0.0));
        assert_eq!(map.pixel(0, 0), bottom);
        assert_eq!(map.pixel(1, 0), bottom);
        assert_eq!(map.pixel(2, 0), encoded(palette(1.0)));
        assert_eq!(map.pixel(3, 0), encoded(palette(2.0 / 3.0)));
    }

    #[test]
    fn legend_labels_are_mid_band_values_as_falsecolor_writes_them() {
        let opts = Falsecolor::default();
        assert_eq!(
            opts.legend_labels(Quantity::Radiance),
            ["cd/m2", "937.5", "812.5", "687.5", "562.5", "437.5", "312.5", "187.5", "62.5"]
        );
        let log = Falsecolor {
            steps: 4,
            log_decades: Some(2),
            ..Falsecolor::default()
        };
        // 1000·10^(-0.25) = 562.3413…, 10^(-0.75) → 177.8279…, cut, not rounded.
        assert_eq!(
            log.legend_labels(Quantity::Irradiance),
            ["lux", "562.341", "177.827", "56.234", "17.782"]
        );
        let third = Falsecolor {
            scale_max: 0.1 + 0.2,
            steps: 1,
            ..Falsecolor::default()
        };
        assert_eq!(third.legend_labels(Quantity::Radiance)[1], "0.15");
    }

    #[test]
    fn the_legend_ramp_sits_left_with_white_labels_and_the_image_right() {
        let opts = Falsecolor::default();
        let mut im = image_of(&[100.0; 64 * 8], Quantity::Radiance);
        im.width = 64;
        im.height = 8;
        im.valid[0] = false;
        let map = opts.to_rgba8(&im);
        // 200 rows of ramp and one 25-row line for the unit above it.
        assert_eq!((map.width, map.height), (164, 225));
        // The ramp at the right edge of the legend, bottom and top rows.
        assert_eq!(map.pixel(99, 224), encoded(palette(0.5 / 200.0)));
        assert_eq!(map.pixel(99, 25), encoded(palette(199.5 / 200.0)));
        // The image is bottom-aligned; above it is black; its invalid pixel too.
        assert_eq!(map.pixel(100 + 5, 224), encoded(palette(0.1)));
        assert_eq!(map.pixel(100 + 5, 100), [0, 0, 0]);
        assert_eq!(map.pixel(100, 217), [0, 0, 0]);
        // Some white text is drawn in the unit's line and in the top band's line.
        let white_in = |rows: std::ops::Range<usize>| {
            rows.flat_map(|y| (0..100).map(move |x| (x, y)))
                .any(|(x, y)| map.pixel(x, y) == [255, 255, 255])
        };
        assert!(white_in(0..25));
        assert!(white_in(25..50));
    }

    #[test]
    fn the_ramp_fills_a_tall_picture_and_every_label_is_drawn_in_its_band() {
        let opts = Falsecolor::default();
        let mut im = image_of(&[100.0; 64 * 480], Quantity::Radiance);
        im.width = 64;
        im.height = 480;
        let map = opts.to_rgba8(&im);
        assert_eq!((map.width, map.height), (164, 480));
        // The unit's line is 25 rows (200 / 8); the ramp fills the 455 rows below it.
        let ramp = 455.0;
        assert_eq!(map.pixel(99, 479), encoded(palette(0.5 / ramp)));
        assert_eq!(map.pixel(99, 25), encoded(palette((ramp - 0.5) / ramp)));
        // Each of the 8 bands' labels puts white pixels near its band's middle, and the
        // text is of a readable size: at least 8 rows of white in the top band.
        for j in 0..8 {
            let mid = 25.0 + (j as f64 + 0.5) * ramp / 8.0;
            let rows: Vec<usize> = (0..map.height)
                .filter(|&y| (0..100).any(|x| map.pixel(x, y) == [255, 255, 255]))
                .filter(|&y| (y as f64 - mid).abs() < ramp / 16.0)
                .collect();
            assert!(
                rows.len() >= 8,
                "band {j}: {} rows with white text",
                rows.len()
            );
        }
    }

    #[test]
    fn contour_lines_colour_only_band_edges() {
        let opts = Falsecolor {
            contour_lines: true,
            steps: 4,
            ..no_legend()
        };
        // A ramp 0…1000 over 40 pixels: band index floor(4v + ½) changes at v = 1/8, 3/8, …
        let values: Vec<f64> = (0..40).map(|i| 25.0 * i as f64).collect();
        let map = opts.to_rgba8(&image_of(&values, Quantity::Radiance));
        let lit: Vec<usize> = (0..40).filter(|&x| map.pixel(x, 0) != [0, 0, 0]).collect();
        assert!(!lit.is_empty() && lit.len() < 12, "{lit:?}");
        for x in lit {
            let v = values[x] / 1000.0;
            let nearest = ((4.0 * v - 0.5).round() + 0.5) / 4.0;
            assert!((v - nearest).abs() <= 0.026, "pixel {x} at v = {v}");
        }
    }

    #[test]
    fn the_png_has_the_map_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fc.png");
        let im = image_of(&[10.0, 900.0], Quantity::Irradiance);
        write_falsecolor_png(&path, &im, &Falsecolor::default()).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (102, 225));
    }
}
