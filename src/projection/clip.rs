//! Which pixels of a triangle an LDI needs, row by row: those whose line meets its window
//! box, and for a source's projection only up to where the line leaves the box on the far
//! side from the source ([`super::Reader`]). Scan conversion then skips the rest
//! ([`crate::math::raster::rasterize_within`]) rather than making fragments to drop.
//!
//! Along pixel (i, j)'s line `o(i, j) + dir·t` (t: height towards the source, m), every
//! slab of the box and the triangle's own height are affine in i within a row, so each
//! condition keeps a half-line of i and the row keeps their intersection. The span is
//! widened by two pixels against rounding: it may keep a few pixels more than needed,
//! never fewer.

use super::Camera;
use glam::{DVec2, DVec3};

/// Rows' spans of needed pixels for one LDI (pixel coordinates of its [`Camera`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Clip {
    /// The line of pixel (i, j) starts at `base + step_u·i + step_v·j`.
    base: DVec3,
    step_u: DVec3,
    step_v: DVec3,
    dir: DVec3,
    /// The box, already grown by its margin (scene frame, m).
    lo: DVec3,
    hi: DVec3,
    /// With `Some(m)`, a fragment lower than `m` below where the line leaves the box is
    /// not needed (a source's projection); with `None` only lines missing the box are
    /// skipped.
    beyond: Option<f64>,
}

/// One condition `alpha + beta·i ≥ 0` on the pixels of a row.
#[derive(Clone, Copy)]
struct Affine {
    alpha: f64,
    beta: f64,
}

impl Affine {
    fn minus(self, o: Affine) -> Affine {
        Affine {
            alpha: self.alpha - o.alpha,
            beta: self.beta - o.beta,
        }
    }
}

impl Clip {
    /// The box `lo..hi` (grown already) seen by `camera`; `beyond` as the field.
    pub(super) fn new(camera: &Camera, lo: DVec3, hi: DVec3, beyond: Option<f64>) -> Clip {
        let c = camera;
        Clip {
            base: c.u * (c.origin.x + 0.5 * c.pixel) + c.v * (c.origin.y + 0.5 * c.pixel),
            step_u: c.u * c.pixel,
            step_v: c.v * c.pixel,
            dir: c.dir,
            lo,
            hi,
            beyond,
        }
    }

    /// Whether every point of the triangle `v` lies inside the box: then all its pixels
    /// are needed (what lies in the box is read whole).
    pub(super) fn holds(&self, v: &[DVec3; 3]) -> bool {
        v.iter()
            .all(|p| p.cmpge(self.lo).all() && p.cmple(self.hi).all())
    }

    /// The span `(first, last)` of row `j`'s needed pixels for a triangle of `plane`
    /// ([`Plane::of`]; `None`: no area) (empty when `first > last`).
    pub(super) fn row(&self, plane: Option<&Plane>, j: u32) -> (i64, i64) {
        let o0 = self.base + self.step_v * j as f64;
        let mut conds: [Affine; 16] = [Affine {
            alpha: 0.0,
            beta: 0.0,
        }; 16];
        let mut n = 0;
        // Per axis: where the line enters (near) and leaves (far) the slab, as affine
        // functions of i, for the axes it is not parallel to.
        let mut near: [Option<Affine>; 3] = [None; 3];
        let mut far: [Option<Affine>; 3] = [None; 3];
        for a in 0..3 {
            let (oa, sa, da) = (o0[a], self.step_u[a], self.dir[a]);
            if da == 0.0 {
                // Parallel: the row's line must lie between the slab's planes.
                conds[n] = Affine {
                    alpha: oa - self.lo[a],
                    beta: sa,
                };
                conds[n + 1] = Affine {
                    alpha: self.hi[a] - oa,
                    beta: -sa,
                };
                n += 2;
                continue;
            }
            let at = |plane: f64| Affine {
                alpha: (plane - oa) / da,
                beta: -sa / da,
            };
            let (t_lo, t_hi) = (at(self.lo[a]), at(self.hi[a]));
            let (nr, fr) = if da > 0.0 { (t_lo, t_hi) } else { (t_hi, t_lo) };
            near[a] = Some(nr);
            far[a] = Some(fr);
        }
        for nr in near.iter().flatten() {
            for fr in far.iter().flatten() {
                conds[n] = fr.minus(*nr);
                n += 1;
            }
        }
        if let Some(m) = self.beyond {
            if let Some(z) = plane.map(|pl| pl.row(j)) {
                for nr in near.iter().flatten() {
                    let mut c = z.minus(*nr);
                    c.alpha += m;
                    conds[n] = c;
                    n += 1;
                }
            }
        }
        let (mut first, mut last) = (f64::NEG_INFINITY, f64::INFINITY);
        for c in &conds[..n] {
            if !(c.alpha.is_finite() && c.beta.is_finite()) {
                continue; // no bound: keep
            }
            if c.beta > 0.0 {
                first = first.max(-c.alpha / c.beta);
            } else if c.beta < 0.0 {
                last = last.min(-c.alpha / c.beta);
            } else if c.alpha < 0.0 {
                return (1, 0);
            }
        }
        ((first.floor() - 2.0) as i64, (last.ceil() + 2.0) as i64)
    }
}

/// A triangle's plane in its LDI: heights (m) from its first projected vertex and the
/// gradient over pixel coordinates, found once per triangle.
#[derive(Clone, Copy, Debug)]
pub(super) struct Plane {
    p0: DVec2,
    h0: f64,
    gx: f64,
    gy: f64,
}

impl Plane {
    /// The plane of the triangle projected to pixel coordinates `p` with heights `h`;
    /// `None` for a triangle of no area in the image (which covers no pixel).
    pub(super) fn of(p: &[DVec2; 3], h: &[f64; 3]) -> Option<Plane> {
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let det = e1.perp_dot(e2);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (d1, d2) = (h[1] - h[0], h[2] - h[0]);
        Some(Plane {
            p0: p[0],
            h0: h[0],
            gx: (d1 * e2.y - d2 * e1.y) / det,
            gy: (d2 * e1.x - d1 * e2.x) / det,
        })
    }

    /// The height at pixel (i + ½, j + ½) as an affine function of i, for row `j`.
    fn row(&self, j: u32) -> Affine {
        let y = j as f64 + 0.5;
        Affine {
            alpha: self.h0 + self.gx * (0.5 - self.p0.x) + self.gy * (y - self.p0.y),
            beta: self.gx,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::frame;
    use crate::math::raster::{rasterize, rasterize_within};
    use crate::math::rng::uniform;

    /// Whether the fragment at height `z` of pixel (i, j) is needed, tested on its own:
    /// the line meets the (grown) box and, with `beyond`, `z` is not more than `m` below
    /// where it leaves it.
    fn needed(c: &Clip, i: u32, j: u32, z: f64) -> bool {
        let o = c.base + c.step_u * i as f64 + c.step_v * j as f64;
        let (mut low, mut high) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if c.dir[a] == 0.0 {
                if o[a] < c.lo[a] || o[a] > c.hi[a] {
                    return false;
                }
                continue;
            }
            let (t0, t1) = ((c.lo[a] - o[a]) / c.dir[a], (c.hi[a] - o[a]) / c.dir[a]);
            low = low.max(t0.min(t1));
            high = high.min(t0.max(t1));
        }
        low <= high && c.beyond.is_none_or(|m| z >= low - m)
    }

    /// The row spans keep every needed fragment, and drop most of the others, for
    /// triangles inside, across and outside a box, seen from directions at random, along
    /// the axes (lines parallel to two slabs) and grazing.
    #[test]
    fn row_spans_keep_every_needed_pixel() {
        let (lo, hi) = (DVec3::new(-10.0, -8.0, -1.0), DVec3::new(12.0, 9.0, 6.0));
        let mut dirs: Vec<DVec3> = vec![DVec3::Z, -DVec3::Z, DVec3::X, DVec3::new(0.0, 0.6, 0.8)];
        dirs.push(DVec3::new(0.999, 0.0, 0.002).normalize());
        for k in 0..40 {
            let z = 2.0 * uniform(7, 1, k) - 1.0;
            let a = std::f64::consts::TAU * uniform(7, 2, k);
            let r = (1.0 - z * z).sqrt();
            dirs.push(DVec3::new(r * a.cos(), r * a.sin(), z));
        }
        let (mut kept, mut skipped) = (0u64, 0u64);
        for (n, &dir) in dirs.iter().enumerate() {
            let (u, v) = frame::basis(dir);
            let pixel = 0.35;
            let cam = Camera {
                dir,
                u,
                v,
                origin: DVec2::new(-80.0, -80.0),
                pixel,
                width: 460,
                height: 460,
            };
            for beyond in [None, Some(0.5)] {
                let clip = Clip::new(&cam, lo, hi, beyond);
                for t in 0..12u64 {
                    let s = (n as u64) * 100 + t;
                    let point = |q: u64| {
                        DVec3::new(
                            -60.0 + 120.0 * uniform(s, 3, q),
                            -60.0 + 120.0 * uniform(s, 4, q),
                            -20.0 + 40.0 * uniform(s, 5, q),
                        )
                    };
                    // A ground-like plane through the box half the time.
                    let tri = if t % 2 == 0 {
                        [point(0), point(1), point(2)]
                    } else {
                        let h = -1.0 + 7.0 * uniform(s, 6, 0);
                        [
                            DVec3::new(-70.0, -70.0, h),
                            DVec3::new(70.0, -70.0, h),
                            DVec3::new(0.0, 75.0, h),
                        ]
                    };
                    let p = tri.map(|x| cam.to_pixel(x));
                    let h = tri.map(|x| cam.height_of(x));
                    let plane = Plane::of(&p, &h);
                    let mut inside = Vec::new();
                    rasterize_within(
                        p,
                        h,
                        cam.width,
                        cam.height,
                        |j| clip.row(plane.as_ref(), j),
                        |i, j, z| inside.push((i, j, z.to_bits())),
                    );
                    let mut all = Vec::new();
                    rasterize(p, h, cam.width, cam.height, |i, j, z| {
                        all.push((i, j, z.to_bits()))
                    });
                    let mut at = inside.iter().peekable();
                    for &(i, j, z) in &all {
                        if at.peek() == Some(&&(i, j, z)) {
                            at.next();
                            kept += 1;
                        } else {
                            skipped += 1;
                            assert!(
                                !needed(&clip, i, j, f64::from_bits(z)),
                                "{dir:?} {beyond:?} triangle {t}: pixel ({i}, {j}) skipped"
                            );
                        }
                    }
                    assert!(
                        at.next().is_none(),
                        "a pixel visited that rasterize does not"
                    );
                }
            }
        }
        assert!(skipped > kept / 4, "kept {kept}, skipped only {skipped}");
    }
}
