//! Radiance views, as users already write them (`rpict`/`rvu` options, and the `.vf` files
//! rvu saves): `-vtv` perspective, `-vta` angular fisheye, `-vth` hemispherical fisheye,
//! `-vtl` parallel, with `-vp` (eye, m), `-vd` (direction), `-vu` (up), `-vh`/`-vv`
//! (horizontal and vertical size: degrees, or metres for `-vtl`) and `-vs`/`-vl` (view
//! shift and lift, fractions of the image). Defaults are Radiance's (`-vtv -vp 0 0 0 -vd 0
//! 1 0 -vu 0 0 1 -vh 45 -vv 45`). Later options override earlier ones, as in Radiance, so
//! a view file followed by command-line options works as users expect.
//!
//! [`View::ray`] maps an image position to a primary ray the way Radiance's `viewray`
//! does for these four types (issue 15's cameras).

use crate::error::{Error, Result};
use glam::DVec3;
use std::path::Path;

/// Projection of a view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewType {
    /// `-vtv`: perspective; `-vh`/`-vv` are full angles, degrees.
    Perspective,
    /// `-vta`: angular fisheye, distance from the centre proportional to the angle from
    /// the view direction; `-vh`/`-vv` full angles, degrees (up to 360).
    Angular,
    /// `-vth`: hemispherical fisheye, distance from the centre proportional to the sine of
    /// the angle; `-vh`/`-vv` full angles, degrees (up to 180).
    Hemispherical,
    /// `-vtl`: parallel; `-vh`/`-vv` are the image's width and height, m.
    Parallel,
}

/// A camera in Radiance's terms (scene frame, metres and degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Projection.
    pub kind: ViewType,
    /// Eye point, m.
    pub vp: DVec3,
    /// View direction (unit).
    pub vd: DVec3,
    /// Up vector (unit; only its component across `vd` matters).
    pub vu: DVec3,
    /// Horizontal size: degrees, or m for [`ViewType::Parallel`].
    pub vh: f64,
    /// Vertical size: degrees, or m for [`ViewType::Parallel`].
    pub vv: f64,
    /// Horizontal shift of the image centre, in image widths.
    pub vs: f64,
    /// Vertical lift of the image centre, in image heights.
    pub vl: f64,
}

impl Default for View {
    fn default() -> Self {
        View {
            kind: ViewType::Perspective,
            vp: DVec3::ZERO,
            vd: DVec3::Y,
            vu: DVec3::Z,
            vh: 45.0,
            vv: 45.0,
            vs: 0.0,
            vl: 0.0,
        }
    }
}

/// Largest eye-point coordinate (`-vp`) and parallel-view size (`-vh`, `-vv` of `-vtl`),
/// m: a million kilometres, far beyond any site, and small enough that every ray a view
/// makes stays finite.
pub const MAX_COORDINATE_M: f64 = 1e9;

/// Largest view shift or lift (`-vs`, `-vl`), in image widths or heights: a thousand tiles
/// of a tiled rendering either way.
pub const MAX_SHIFT: f64 = 1000.0;

/// What rpict calls a view file or view text that sets no view option, and why.
const NO_VIEW: &str = "bad view file: it sets no view option (-vt?, -vp, -vd, -vu, -vh, -vv, \
                       -vo, -va, -vs, -vl), so there is no camera; rpict refuses it too";

/// `v` scaled to unit length (left as it is when it already is, so that a view read back
/// from [`View::options`] is the same view); `None` when it is zero or not finite.
fn unit(v: DVec3) -> Option<DVec3> {
    if !v.is_finite() {
        return None;
    }
    // Scaled by its largest component first, so that neither huge nor tiny components
    // overflow or underflow when squared.
    let m = v.abs().max_element();
    if m == 0.0 {
        return None;
    }
    if (v.length_squared() - 1.0).abs() <= 1e-12 {
        return Some(v);
    }
    let s = v / m;
    Some(s / s.length())
}

impl View {
    /// The view given by Radiance view options in `text` (whitespace-separated; other
    /// options and a leading program name such as `rvu` are ignored), applied over `self`.
    /// `source` names where the text came from, for errors.
    ///
    /// # Errors
    /// Text that sets no view option (as rpict's "bad view file"), a view option with a
    /// missing or non-numeric value, an unknown `-vt` type, a clipping plane (`-vo`, `-va`)
    /// other than 0, or a view that is not usable (see [`View::check`]), naming `source`
    /// and the value.
    pub fn with_options(self, text: &str, source: &Path, line: Option<usize>) -> Result<View> {
        let (v, set) = self.apply(text, source, line)?;
        if set == 0 {
            let value = text.trim();
            return Err(Error::input(
                source,
                line,
                Some(value).filter(|v| !v.is_empty()),
                NO_VIEW,
            ));
        }
        v.check(source, line)
    }

    /// The options of `text` applied over `self`, unchecked, and how many view options it
    /// set.
    fn apply(mut self, text: &str, source: &Path, line: Option<usize>) -> Result<(View, usize)> {
        let tokens: Vec<&str> = text.split_whitespace().collect();
        let bad = |value: &str, msg: &str| Error::input(source, line, Some(value), msg);
        let mut set = 0;
        let mut i = 0;
        while i < tokens.len() {
            let t = tokens[i];
            let num = |k: usize| -> Result<f64> {
                let v = tokens
                    .get(i + k)
                    .ok_or_else(|| bad(t, "view option without its value"))?;
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad(v, &format!("{t} takes finite numbers")))
            };
            let vec3 = || -> Result<DVec3> { Ok(DVec3::new(num(1)?, num(2)?, num(3)?)) };
            match t {
                "-vtv" => self.kind = ViewType::Perspective,
                "-vta" => self.kind = ViewType::Angular,
                "-vth" => self.kind = ViewType::Hemispherical,
                "-vtl" => self.kind = ViewType::Parallel,
                _ if t.starts_with("-vt") => {
                    return Err(bad(
                        t,
                        "unknown view type (daystep reads -vtv, -vta, -vth, -vtl)",
                    ))
                }
                "-vp" | "-vd" | "-vu" => {
                    let v = vec3()?;
                    match t {
                        "-vp" => self.vp = v,
                        "-vd" => self.vd = v,
                        _ => self.vu = v,
                    }
                    i += 3;
                }
                "-vh" | "-vv" | "-vs" | "-vl" | "-vo" | "-va" => {
                    let v = num(1)?;
                    match t {
                        "-vh" => self.vh = v,
                        "-vv" => self.vv = v,
                        "-vs" => self.vs = v,
                        "-vl" => self.vl = v,
                        // rvu writes `-vo 0 -va 0` into every view file; other clipping
                        // planes would change the picture, and daystep has none.
                        _ if v != 0.0 => {
                            return Err(bad(
                                &format!("{t} {v}"),
                                "clipping planes (-vo, -va) are not supported; only 0",
                            ))
                        }
                        _ => {}
                    }
                    i += 1;
                }
                _ => {
                    i += 1;
                    continue;
                }
            }
            set += 1;
            i += 1;
        }
        Ok((self, set))
    }

    /// Reads a view file as rvu saves it (`rvu -vtv -vp … -vd …`, one view per line; `#`
    /// comments): the options of every line, in order, over Radiance's defaults.
    ///
    /// # Errors
    /// An unreadable file, a bad option naming the file and line, or a file that sets no
    /// view option at all (empty, comments only, `rvu` alone, other options only), which
    /// rpict calls a "bad view file".
    pub fn read_file(path: &Path) -> Result<View> {
        let text = crate::files::read_text(path)?;
        let mut v = View::default();
        let mut set = 0;
        let mut first = None;
        for (n, l) in text.lines().enumerate() {
            let l = l.split('#').next().unwrap_or("");
            if l.trim().is_empty() {
                continue;
            }
            first.get_or_insert((n + 1, l.trim()));
            let (next, k) = v.apply(l, path, Some(n + 1))?;
            if k > 0 {
                v = next.check(path, Some(n + 1))?;
                set += k;
            }
        }
        if set == 0 {
            let (line, value) = first.unzip();
            return Err(Error::input(path, line, value, NO_VIEW));
        }
        Ok(v)
    }

    /// Checks that the view can make rays, as Radiance's `setview` does: every number
    /// finite, a non-zero direction, a non-zero up vector not along it, and positive sizes
    /// within the type's range (perspective below 180°, angular fisheye up to 360°,
    /// hemispherical up to 180°, parallel up to [`MAX_COORDINATE_M`]); also the eye within
    /// [`MAX_COORDINATE_M`] of the origin and shifts within [`MAX_SHIFT`]. Normalises `vd`
    /// and `vu`.
    ///
    /// # Errors
    /// [`Error::Input`] naming `source` (and `line`) and the offending value.
    pub fn check(mut self, source: &Path, line: Option<usize>) -> Result<View> {
        let bad = |value: String, msg: &str| Error::input(source, line, Some(&value), msg);
        let shown = |name: &str, v: DVec3| format!("{name} {} {} {}", v.x, v.y, v.z);
        if !(self.vp.is_finite() && self.vp.abs().max_element() <= MAX_COORDINATE_M) {
            return Err(bad(
                shown("-vp", self.vp),
                "the eye -vp must be finite and within 1e9 m of the origin",
            ));
        }
        self.vd = unit(self.vd).ok_or_else(|| {
            bad(
                shown("-vd", self.vd),
                "view direction -vd must be finite and not zero",
            )
        })?;
        self.vu = unit(self.vu).ok_or_else(|| {
            bad(
                shown("-vu", self.vu),
                "up vector -vu must be finite and not zero",
            )
        })?;
        if self.vu.cross(self.vd).length() < 1e-9 {
            return Err(bad(
                shown("-vu", self.vu),
                "up vector -vu must not be parallel to -vd",
            ));
        }
        let (range, what) = match self.kind {
            ViewType::Perspective => ("(0, 180) degrees", "a perspective view (-vtv)"),
            ViewType::Angular => ("(0, 360] degrees", "an angular fisheye (-vta)"),
            ViewType::Hemispherical => ("(0, 180] degrees", "a hemispherical fisheye (-vth)"),
            ViewType::Parallel => ("(0, 1e9] m", "a parallel view (-vtl)"),
        };
        let fits = |v: f64| match self.kind {
            ViewType::Perspective => v > 0.0 && v < 180.0,
            ViewType::Angular => v > 0.0 && v <= 360.0,
            ViewType::Hemispherical => v > 0.0 && v <= 180.0,
            ViewType::Parallel => v > 0.0 && v <= MAX_COORDINATE_M,
        };
        for (name, v) in [("-vh", self.vh), ("-vv", self.vv)] {
            if !fits(v) {
                return Err(bad(
                    format!("{name} {v}"),
                    &format!("view size out of range for {what}: {range}"),
                ));
            }
        }
        for (name, v) in [("-vs", self.vs), ("-vl", self.vl)] {
            if !(v.is_finite() && v.abs() <= MAX_SHIFT) {
                return Err(bad(
                    format!("{name} {v}"),
                    "view shift and lift must be finite, within ±1000 image sizes",
                ));
            }
        }
        Ok(self)
    }

    /// The view as Radiance view options (`-vtv -vp x y z -vd … -vu … -vh … -vv … -vs …
    /// -vl …`), as rvu saves them and image headers (`VIEW=`) carry them.
    pub fn options(&self) -> String {
        let t = match self.kind {
            ViewType::Perspective => 'v',
            ViewType::Angular => 'a',
            ViewType::Hemispherical => 'h',
            ViewType::Parallel => 'l',
        };
        let v = |a: DVec3| format!("{} {} {}", a.x, a.y, a.z);
        format!(
            "-vt{t} -vp {} -vd {} -vu {} -vh {} -vv {} -vs {} -vl {}",
            v(self.vp),
            v(self.vd),
            v(self.vu),
            self.vh,
            self.vv,
            self.vs,
            self.vl
        )
    }

    /// The image's right and up unit vectors.
    fn frame(&self) -> (DVec3, DVec3) {
        let right = self.vd.cross(self.vu).normalize();
        (right, right.cross(self.vd).normalize())
    }

    /// The primary ray (origin m, unit direction) through image position (`x`, `y`), both
    /// in [0, 1] from the left and from the bottom; `None` outside a fisheye's circle.
    pub fn ray(&self, x: f64, y: f64) -> Option<(DVec3, DVec3)> {
        let (right, up) = self.frame();
        let (dx, dy) = (x - 0.5 + self.vs, y - 0.5 + self.vl);
        match self.kind {
            ViewType::Perspective => {
                let h = 2.0 * (self.vh.to_radians() / 2.0).tan();
                let v = 2.0 * (self.vv.to_radians() / 2.0).tan();
                Some((
                    self.vp,
                    (self.vd + right * (dx * h) + up * (dy * v)).normalize(),
                ))
            }
            ViewType::Parallel => Some((
                self.vp + right * (dx * self.vh) + up * (dy * self.vv),
                self.vd,
            )),
            ViewType::Angular => {
                let (ax, ay) = (dx * self.vh.to_radians(), dy * self.vv.to_radians());
                let theta = (ax * ax + ay * ay).sqrt();
                if theta > std::f64::consts::PI {
                    return None;
                }
                if theta == 0.0 {
                    return Some((self.vp, self.vd));
                }
                let side = (right * ax + up * ay) / theta;
                Some((
                    self.vp,
                    (self.vd * theta.cos() + side * theta.sin()).normalize(),
                ))
            }
            ViewType::Hemispherical => {
                let sx = dx * 2.0 * (self.vh.to_radians() / 2.0).sin();
                let sy = dy * 2.0 * (self.vv.to_radians() / 2.0).sin();
                let z2 = 1.0 - sx * sx - sy * sy;
                if z2 < 0.0 {
                    return None;
                }
                Some((
                    self.vp,
                    (self.vd * z2.sqrt() + right * sx + up * sy).normalize(),
                ))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<View> {
        View::default().with_options(s, Path::new("<test>"), None)
    }

    fn deg(a: DVec3, b: DVec3) -> f64 {
        a.angle_between(b).to_degrees()
    }

    #[test]
    fn options_parse_and_later_ones_override() {
        let v =
            parse("rvu -vtv -vp 1 2 1.5 -vd 0 2 0 -vu 0 0 1 -vh 60 -vv 40 -x 800 -vh 90").unwrap();
        assert_eq!(v.kind, ViewType::Perspective);
        assert_eq!(v.vp, DVec3::new(1.0, 2.0, 1.5));
        assert_eq!(v.vd, DVec3::Y, "normalised");
        assert_eq!((v.vh, v.vv), (90.0, 40.0));
        let e = parse("-vtv -vh abc").unwrap_err().to_string();
        assert!(e.contains("abc"), "{e}");
        assert!(parse("-vtx").is_err());
        assert!(parse("-vd 0 0 1 -vu 0 0 2").is_err(), "up along the view");
        assert!(parse("-vta -vh 400").is_err());
        assert!(parse("-vp 1 2").is_err(), "missing value");
    }

    #[test]
    fn perspective_rays_follow_the_field_of_view() {
        let v = parse("-vtv -vd 1 0 0 -vu 0 0 1 -vh 90 -vv 60").unwrap();
        let (o, c) = v.ray(0.5, 0.5).unwrap();
        assert_eq!((o, c), (DVec3::ZERO, DVec3::X));
        // The image's edges are at half the full angles, right is −y for vd = x, up z.
        let (_, r) = v.ray(1.0, 0.5).unwrap();
        assert!((deg(r, DVec3::X) - 45.0).abs() < 1e-9 && r.y < 0.0);
        let (_, t) = v.ray(0.5, 1.0).unwrap();
        assert!((deg(t, DVec3::X) - 30.0).abs() < 1e-9 && t.z > 0.0);
    }

    #[test]
    fn fisheyes_map_radius_to_angle_or_its_sine() {
        let a = parse("-vta -vd 0 0 1 -vu 0 1 0 -vh 180 -vv 180").unwrap();
        let (_, e) = a.ray(1.0, 0.5).unwrap();
        assert!((deg(e, DVec3::Z) - 90.0).abs() < 1e-9);
        let (_, m) = a.ray(0.75, 0.5).unwrap();
        assert!(
            (deg(m, DVec3::Z) - 45.0).abs() < 1e-9,
            "angle linear in radius"
        );
        assert!(
            a.ray(1.0, 1.0).is_some(),
            "180° angular keeps its corners up to 127°"
        );
        let h = parse("-vth -vd 0 0 1 -vu 0 1 0 -vh 180 -vv 180").unwrap();
        let (_, m) = h.ray(0.75, 0.5).unwrap();
        assert!(
            (deg(m, DVec3::Z) - 30.0).abs() < 1e-9,
            "sine of the angle linear in radius"
        );
        assert!(h.ray(1.0, 1.0).is_none(), "outside the circle");
    }

    #[test]
    fn parallel_views_shift_the_origin() {
        let v = parse("-vtl -vp 0 0 10 -vd 0 0 -1 -vu 0 1 0 -vh 20 -vv 10").unwrap();
        let (o, d) = v.ray(1.0, 1.0).unwrap();
        assert_eq!(d, -DVec3::Z);
        assert!((o - DVec3::new(10.0, 5.0, 10.0)).length() < 1e-9, "{o}");
    }

    #[test]
    fn view_files_read_as_rvu_writes_them() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("v.vf");
        std::fs::write(
            &p,
            "# saved by rvu\nrvu -vta -vp 2 3 1.2 -vd 0 1 0 -vu 0 0 1 -vh 180 -vv 180\n",
        )
        .unwrap();
        let v = View::read_file(&p).unwrap();
        assert_eq!(
            (v.kind, v.vp),
            (ViewType::Angular, DVec3::new(2.0, 3.0, 1.2))
        );
        std::fs::write(&p, "\nrvu -vtv -vh 0\n").unwrap();
        let e = View::read_file(&p).unwrap_err().to_string();
        assert!(
            e.contains("v.vf") && e.contains(":2") && e.contains("-vh 0"),
            "{e}"
        );
    }

    #[test]
    fn a_view_file_that_sets_no_view_is_a_bad_view_file() {
        // An empty .vf rendered from the origin along +y; rpict says "bad view file".
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("empty.vf");
        for text in [
            "",
            "\n\n",
            "# saved by nobody\n",
            "rvu\n",
            "rvu -x 800 -y 600\n# -vtv -vp 1 2 3\n",
        ] {
            std::fs::write(&p, text).unwrap();
            let e = View::read_file(&p).unwrap_err();
            let (shown, path, _, _) = crate::error::input_parts(e);
            assert_eq!(path, p, "{text:?}: {shown}");
            assert!(shown.contains("bad view file"), "{text:?}: {shown}");
        }
        // One option anywhere in the file is a view (Radiance's defaults for the rest).
        std::fs::write(&p, "rvu\n-vo 0\n").unwrap();
        assert_eq!(View::read_file(&p).unwrap(), View::default());
        for text in ["", "   ", "rvu", "rpict -x 10 -ab 2", "-vz 1"] {
            let e = parse(text).unwrap_err().to_string();
            assert!(
                e.contains("bad view file") && e.contains("<test>"),
                "{text:?}: {e}"
            );
        }
    }

    #[test]
    fn clipping_planes_other_than_zero_are_refused() {
        // rvu writes `-vo 0 -va 0`; daystep has no clipping, so anything else would be
        // ignored silently.
        let v = parse("rvu -vtv -vp 1 2 3 -vd 0 1 0 -vo 0 -va 0 -vs 0 -vl 0").unwrap();
        assert_eq!(v.vp, DVec3::new(1.0, 2.0, 3.0));
        for bad in ["-vo 0.5", "-va 10", "-vo nan", "-va"] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn view_sizes_are_checked_per_type_with_their_range() {
        for (ok, bad) in [
            ("-vtv -vh 179.9", "-vtv -vh 180"),
            ("-vta -vh 360", "-vta -vh 360.1"),
            ("-vth -vv 180", "-vth -vv 181"),
            ("-vtl -vh 1e9", "-vtl -vh 1000000001"),
        ] {
            assert!(parse(ok).is_ok(), "{ok}");
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains(bad.split_at(5).1), "{bad}: {e}");
            assert!(e.contains("(0, "), "the range is named: {e}");
        }
        for bad in [
            "-vh 0", "-vv -5", "-vh nan", "-vh inf", "-vs 1e4", "-vl inf",
        ] {
            assert!(parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn huge_or_tiny_directions_normalise_without_overflow() {
        // |vd|² overflows to ∞ (or underflows to 0) when squared as given.
        let v = parse("-vd 1e300 1e300 0 -vu 0 0 1e-300").unwrap();
        assert!((v.vd - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-15);
        assert_eq!(v.vu, DVec3::Z);
        let v = parse("-vd 1e-320 0 0").unwrap();
        assert_eq!(v.vd, DVec3::X);
        assert!(parse("-vp 2e9 0 0").is_err(), "eye beyond 1e9 m");
        assert!(parse("-vu 0 0 0").is_err(), "zero up vector");
    }

    #[test]
    fn options_read_back_as_the_same_view() {
        let v = View::default()
            .with_options(
                "-vta -vp 1.5 -2 3.25 -vd 0 -1 0 -vu 0 0 1 -vh 180 -vv 170 -vs 0.1 -vl -0.2",
                Path::new("cmd"),
                None,
            )
            .unwrap();
        let back = View::default()
            .with_options(&v.options(), Path::new("cmd"), None)
            .unwrap();
        assert_eq!(back, v);
    }
}
