//! The Layered Depth Image of one parallel projection (Shade et al. 1998; Besuievsky &
//! Martín §5.1): an orthographic camera looking against the source direction; every pixel
//! keeps all fragments along its line, ordered from the source inwards. The transmission
//! of the light that reaches a fragment (1 until glazing or an opaque surface) is the
//! product of the pass factors in front of it, taken as the list is read
//! ([`Ldi::arriving`], [`Ldi::for_each_arrival`]) rather than stored with each fragment:
//! a fragment is then 8 bytes instead of 20, and the LDIs in flight were a cold annual
//! run's largest allocations on a building with few sensors.

use super::clip::{Clip, Plane};
use super::ProjectionScene;
use crate::math::{frame, raster};
use crate::photometry::Rgb;
use glam::{DVec2, DVec3};

/// Orthographic camera: image axes `u`, `v` perpendicular to the source direction.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Unit vector towards the source.
    pub dir: DVec3,
    /// Image x axis (unit).
    pub u: DVec3,
    /// Image y axis (unit).
    pub v: DVec3,
    /// Image-plane coordinates (m) of the image's lower-left corner.
    pub origin: DVec2,
    /// Pixel edge length, m.
    pub pixel: f64,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

impl Camera {
    /// Pixel coordinates of a scene point.
    pub fn to_pixel(&self, p: DVec3) -> DVec2 {
        (DVec2::new(self.u.dot(p), self.v.dot(p)) - self.origin) / self.pixel
    }
    /// Height of a point along the source direction (larger = nearer the source), m.
    pub fn height_of(&self, p: DVec3) -> f64 {
        self.dir.dot(p)
    }
}

/// One fragment of a pixel's list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fragment {
    /// Input triangle.
    pub tri: u32,
    /// Height along the source direction at the pixel centre, m.
    pub height: f32,
}

/// Fragments closer than this along the source direction (m) lie on one surface: exported
/// models lay a floor on the ground plane or a desk on a floor in the same plane, and the
/// two triangles' interpolated heights differ only by rounding (f32 heights carry about
/// 6·10⁻⁵ m at 1 km). Real surfaces are further apart (the thinnest wall of a model, two
/// faces 1 mm apart, stays two surfaces).
pub const COINCIDENT_M: f32 = 5e-4;

/// Orders each run of coincident fragments (parallel faces within [`COINCIDENT_M`] of the
/// run's first) of
/// a depth-sorted `list` so that what it shows does not depend on rounding:
/// * fragments facing the source come before those facing away, so two faces back to
///   back (a wall modelled twice) keep their backs together and no light passes between
///   their sides, and a face-down face on a face-up one (a desk on a floor) hides both;
/// * among faces facing the same way the smaller triangle shows (nearest its side): a
///   floor on a ground plane, a door on its wall — the detail lying on the context.
pub fn order_coincident(list: &mut [Fragment], scene: &ProjectionScene, dir: DVec3) {
    order_coincident_facing(list, scene, &|k| scene.normals[k].dot(dir) > 0.0);
}

/// [`order_coincident`] with `facing(k)`: whether triangle `k` faces the source (n·dir > 0).
/// An LDI's pixels ask it of every coincident pair (a face and its back face), so the LDI
/// computes it once per triangle.
fn order_coincident_facing(
    list: &mut [Fragment],
    scene: &ProjectionScene,
    facing: &impl Fn(usize) -> bool,
) {
    let mut start = 0;
    while start < list.len() {
        let top = list[start].height;
        let t0 = list[start].tri as usize;
        // A face's back face is rasterised with it (same heights, opposite normal): it is
        // coincident and parallel without reading a normal. Most pixels of a two-sided
        // model hold only such pairs, and the normals' reads were a twentieth of a cold
        // annual run's time.
        let twin = scene.twin.get(t0).copied().unwrap_or(u32::MAX);
        let mut end = start + 1;
        // Parallel planes only: two faces meeting at an edge are as close near the edge,
        // and their order there is geometry, not rounding.
        while end < list.len()
            && top - list[end].height < COINCIDENT_M
            && (list[end].tri == twin
                || scene.normals[list[end].tri as usize]
                    .dot(scene.normals[t0])
                    .abs()
                    > 1.0 - 1e-9)
        {
            end += 1;
        }
        if end - start == 2 && list[start + 1].tri == twin {
            // A face and its back face: exactly one faces the source unless the line
            // grazes them, and the order below puts it first.
            let (fa, fb) = (facing(t0), facing(twin as usize));
            if fa != fb {
                if fb {
                    list.swap(start, start + 1);
                }
                start = end;
                continue;
            }
        }
        if end - start > 1 {
            list[start..end].sort_by(|a, b| {
                let (ta, tb) = (a.tri as usize, b.tri as usize);
                let (fa, fb) = (facing(ta), facing(tb));
                // Facing the source first; then the smaller first when facing it (it shows
                // to the source side), the smaller last when facing away (it shows to the
                // far side).
                // Equal areas: the lower index shows on both sides (nearest the source
                // side when facing it, last when facing away), as the tracer settles it; two
                // walls modelled back to back then keep one face per side for every kind
                // of light.
                let by_area = scene.areas[ta].total_cmp(&scene.areas[tb]);
                let by_index = a.tri.cmp(&b.tri);
                fb.cmp(&fa).then(if fa {
                    by_area.then(by_index)
                } else {
                    by_area.reverse().then(by_index.reverse())
                })
            });
        }
        start = end;
    }
}

/// What an [`Ldi`] is read for, which decides the fragments it keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reader {
    /// Global lines: every fragment, both faces of a two-sided surface (each face is
    /// linked with what it sees on its own side), of every line that meets the window box
    /// (grown by three [`window_margin`]s): a line that misses it crosses none of the rows
    /// its pass serves.
    Lines,
    /// A source's projection, whose pixels are read for the elements inside its window
    /// box (or the whole scene) and what lies in front of them. It drops two kinds of
    /// fragment:
    /// * of a two-sided surface (a triangle and its back face,
    ///   [`ProjectionScene::twin`]), the face turned away from the source (the front face
    ///   when the line grazes both). The two lie at the same heights and the one towards
    ///   the source is opaque, so what lies behind them is dark and the face turned away
    ///   receives nothing. One change: where a line runs along the edge two faces share
    ///   (a box's corner), the list held all four faces at one height, ordered by index,
    ///   and a face turned away from the source could come first and hide the lit face
    ///   beside it; now it is not there;
    /// * those beyond the window box along the line (below where the line leaves it, by
    ///   more than a margin), and every fragment of a pixel whose line misses the box: no
    ///   element refined against this image lies there, and they are behind everything
    ///   that does. Scan conversion skips them row by row (`clip.rs`). Exact: the records
    ///   are those of [`Reader::SourceUncut`] to the bit. A site's ground seen past a
    ///   window's edges was most of a windowed image's fragments.
    Source,
    /// [`Reader::Source`] without the cut beyond the window box: for the check that the
    /// cut drops no fragment its refinement reads (the records must be the same to the
    /// bit).
    SourceUncut,
}

/// A Layered Depth Image: per pixel, a depth-ordered fragment list (CSR layout).
#[derive(Clone, Debug)]
pub struct Ldi {
    /// The camera.
    pub camera: Camera,
    offsets: Vec<u32>,
    fragments: Vec<Fragment>,
    /// Per-triangle factor applied to light passing it along this direction.
    pass: Vec<Rgb>,
}

/// The margin a window box is grown by before it decides which fragments lie in it
/// (m): 10⁻³ of its diagonal plus 1 mm, far above the rounding of a fragment's f32
/// height. A line pass of the interreflection's operator counts a fragment for its
/// window's rows only within it; its LDI skips lines that miss the box grown by three
/// times it, which no such fragment lies on.
pub fn window_margin(w: (DVec3, DVec3)) -> f64 {
    1e-3 * (w.1 - w.0).length() + 1e-3
}

impl Ldi {
    /// Scan-converts every triangle (both faces occlude) along `dir` at a resolution of
    /// `resolution` pixels along the image's longer side.
    pub fn build(scene: &ProjectionScene, dir: DVec3, resolution: u32) -> Ldi {
        Ldi::build_sized(scene, dir, None, DVec2::ZERO, Reader::Lines, |ext| {
            ext.max_element() / resolution.max(1) as f64
        })
    }

    /// An LDI over the projection of the box `window` only, `resolution` pixels along the
    /// longer side of that projection (its pixel no finer than `floor_m` metres), holding
    /// what `reader` reads.
    pub fn build_region(
        scene: &ProjectionScene,
        dir: DVec3,
        resolution: u32,
        window: (DVec3, DVec3),
        floor_m: f64,
        reader: Reader,
    ) -> Ldi {
        Ldi::build_sized(scene, dir, Some(window), DVec2::ZERO, reader, |ext| {
            (ext.max_element() / resolution.max(1) as f64).max(floor_m)
        })
    }

    /// As [`Ldi::build`], its pixel no finer than `floor_m` metres, holding what `reader`
    /// reads.
    pub fn build_floored(
        scene: &ProjectionScene,
        dir: DVec3,
        resolution: u32,
        floor_m: f64,
        reader: Reader,
    ) -> Ldi {
        Ldi::build_sized(scene, dir, None, DVec2::ZERO, reader, |ext| {
            (ext.max_element() / resolution.max(1) as f64).max(floor_m)
        })
    }

    /// As [`Ldi::build`] with a fixed pixel edge of `pixel_m` metres whatever the
    /// direction: every bundle then has the same line density (lines per m² across the
    /// bundle), which global-line estimates need.
    pub fn build_with_pixel(scene: &ProjectionScene, dir: DVec3, pixel_m: f64) -> Ldi {
        Ldi::build_sized(scene, dir, None, DVec2::ZERO, Reader::Lines, |_| pixel_m)
    }

    /// As [`Ldi::build_with_pixel`], the image covering only the projection of the box
    /// `window` (scene frame, m): lines that miss the box are not drawn, fragments along
    /// the drawn ones are complete for [`Reader::Lines`]. The pixel grid is shifted by
    /// `jitter` (fractions of a pixel, each in [0, 1)) so that random bundles do not alias
    /// with the geometry.
    pub fn build_window(
        scene: &ProjectionScene,
        dir: DVec3,
        pixel_m: f64,
        window: (DVec3, DVec3),
        jitter: DVec2,
        reader: Reader,
    ) -> Ldi {
        Ldi::build_sized(scene, dir, Some(window), jitter, reader, |_| pixel_m)
    }

    fn build_sized(
        scene: &ProjectionScene,
        dir: DVec3,
        window: Option<(DVec3, DVec3)>,
        jitter: DVec2,
        reader: Reader,
        pixel_of: impl Fn(DVec2) -> f64,
    ) -> Ldi {
        let (u, v) = frame::basis(dir);
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        let mut add = |p: DVec3| {
            let q = DVec2::new(u.dot(p), v.dot(p));
            lo = lo.min(q);
            hi = hi.max(q);
        };
        match window {
            Some((a, b)) => {
                for k in 0..8 {
                    add(DVec3::new(
                        if k & 1 == 0 { a.x } else { b.x },
                        if k & 2 == 0 { a.y } else { b.y },
                        if k & 4 == 0 { a.z } else { b.z },
                    ));
                }
            }
            None => {
                for t in &scene.vertices {
                    for p in t {
                        add(*p);
                    }
                }
            }
        }
        if !lo.is_finite() {
            lo = DVec2::ZERO;
            hi = DVec2::ONE;
        }
        let ext = (hi - lo).max(DVec2::splat(1e-9));
        let pixel = pixel_of(ext);
        // Half a pixel of margin so vertices on the bounds sample like interior ones.
        let origin = lo - (DVec2::splat(0.5) + jitter) * pixel;
        let width = ((ext.x / pixel).ceil() as u32 + 2).max(1);
        let height = ((ext.y / pixel).ceil() as u32 + 2).max(1);
        let camera = Camera {
            dir,
            u,
            v,
            origin,
            pixel,
            width,
            height,
        };
        let n_pix = width as usize * height as usize;
        let project = |t: &[DVec3; 3]| {
            (
                t.map(|p| camera.to_pixel(p)),
                t.map(|p| camera.height_of(p)),
            )
        };
        // A back face lies on its front triangle: one rasterisation gives both fragments,
        // at the same pixels and heights (then `order_coincident` puts the face towards
        // the source first). Each front triangle is rasterised once: its pixels and
        // heights are staged (8 bytes a pixel, freed when the image is built) while the
        // pixels' counts are taken, then placed in the same order a second rasterisation
        // would place them (it measured a tenth of a building instant's time).
        let kept = |k: usize| -> [Option<u32>; 2] {
            let back = scene.back_of(k);
            match (reader, back) {
                (Reader::Source | Reader::SourceUncut, Some(b))
                    if scene.normals[k].dot(dir) <= 0.0
                        && scene.normals[b as usize].dot(dir) > 0.0 =>
                {
                    [Some(b), None]
                }
                (Reader::Source | Reader::SourceUncut, _) => [Some(k as u32), None],
                (Reader::Lines, _) => [Some(k as u32), back],
            }
        };
        // A source's LDI: the box grown by a pixel besides the margin, since an element
        // too small to cover a pixel centre is read at the pixel holding its centroid, up
        // to 0.71 pixel from it.
        let clip = match (reader, window) {
            (Reader::Source, Some(w)) => {
                let m = window_margin(w) + pixel;
                Some(Clip::new(&camera, w.0 - m, w.1 + m, Some(m)))
            }
            (Reader::Lines, Some(w)) => {
                let m = 3.0 * window_margin(w);
                Some(Clip::new(&camera, w.0 - m, w.1 + m, None))
            }
            _ => None,
        };
        let mut counts = vec![0u32; n_pix + 1];
        let mut staged: Vec<(u32, f32)> = Vec::new();
        let mut ends = vec![0usize; scene.vertices.len()];
        for (k, t) in scene.vertices.iter().enumerate() {
            if !scene.is_back_face(k) {
                let faces = kept(k).iter().flatten().count() as u32;
                let (p, h) = project(t);
                let stage = |i: u32, j: u32, z: f64| {
                    let px = j as usize * width as usize + i as usize;
                    counts[px] += faces;
                    staged.push((px as u32, z as f32));
                };
                match clip.filter(|c| !c.holds(t)) {
                    Some(c) => {
                        let plane = Plane::of(&p, &h);
                        raster::rasterize_within(
                            p,
                            h,
                            width,
                            height,
                            |j| c.row(plane.as_ref(), j),
                            stage,
                        )
                    }
                    None => raster::rasterize(p, h, width, height, stage),
                }
            }
            ends[k] = staged.len();
        }
        // Each pixel's end, then its fragments placed downwards from it: the counts become
        // the starts without a second array. The order they are placed in does not matter,
        // since each list is sorted below by a key no two fragments of a pixel share.
        let mut offsets = counts;
        let mut acc = 0u32;
        for c in offsets.iter_mut() {
            acc += *c;
            *c = acc;
        }
        let mut fragments = vec![
            Fragment {
                tri: 0,
                height: 0.0,
            };
            acc as usize
        ];
        let mut start = 0;
        for (k, &end) in ends.iter().enumerate() {
            let faces = kept(k);
            for &(px, height) in &staged[start..end] {
                let px = px as usize;
                for tri in faces.into_iter().flatten() {
                    offsets[px] -= 1;
                    fragments[offsets[px] as usize] = Fragment { tri, height };
                }
            }
            start = end;
        }
        drop(staged);
        let pass: Vec<Rgb> = (0..scene.vertices.len())
            .map(|k| scene.pass_factor(k, dir))
            .collect();
        let facing: Vec<bool> = scene.normals.iter().map(|n| n.dot(dir) > 0.0).collect();
        let facing = |k: usize| facing[k];
        for px in 0..n_pix {
            let list = &mut fragments[offsets[px] as usize..offsets[px + 1] as usize];
            // Nearest the source first; ties broken by triangle index for determinism.
            list.sort_unstable_by(|a, b| b.height.total_cmp(&a.height).then(a.tri.cmp(&b.tri)));
            order_coincident_facing(list, scene, &facing);
        }
        Ldi {
            camera,
            offsets,
            fragments,
            pass,
        }
    }

    /// Total number of fragments.
    pub fn fragment_count(&self) -> usize {
        self.fragments.len()
    }

    /// The fragment list of pixel `(i, j)`, nearest the source first.
    pub fn pixel(&self, i: u32, j: u32) -> &[Fragment] {
        let px = j as usize * self.camera.width as usize + i as usize;
        &self.fragments[self.offsets[px] as usize..self.offsets[px + 1] as usize]
    }

    /// Transmission (per channel) of the light arriving at each fragment of `list` (one
    /// pixel's, nearest the source first): the product of the pass factors of those in
    /// front. Rounded to f32, as the fragments held it when they stored it, so that the
    /// projections' records are the same to the bit.
    fn arrivals<'a>(&'a self, list: &'a [Fragment]) -> impl Iterator<Item = (&'a Fragment, Rgb)> {
        list.iter().scan(Rgb::ONE, move |t, f| {
            let arriving = Rgb::new(t.x as f32 as f64, t.y as f32 as f64, t.z as f32 as f64);
            *t *= self.pass[f.tri as usize];
            Some((f, arriving))
        })
    }

    /// Transmission (per channel) of the light arriving at triangle `tri`'s fragment in
    /// pixel `(i, j)`; `None` where the triangle has no fragment there.
    pub fn arriving(&self, i: u32, j: u32, tri: u32) -> Option<Rgb> {
        self.arrivals(self.pixel(i, j))
            .find(|(f, _)| f.tri == tri)
            .map(|(_, t)| t)
    }

    /// Calls `visit` with every fragment and the transmission of the light arriving at it,
    /// pixel by pixel in row order (`j`, then `i`, ascending), each pixel's list nearest
    /// the source first: the order in which rasterising a triangle visits its pixels.
    pub fn for_each_arrival(&self, mut visit: impl FnMut(&Fragment, Rgb)) {
        for w in self.offsets.windows(2) {
            let list = &self.fragments[w[0] as usize..w[1] as usize];
            for (f, t) in self.arrivals(list) {
                visit(f, t);
            }
        }
    }

    /// Transmission (per channel) of light reaching height `h` in pixel `(i, j)` along the
    /// line, ignoring fragments of the triangles `skip`: the receiver's two faces (its
    /// front and its back face, `u32::MAX` for none). A point off the pixel centre lies
    /// below its own plane's fragment there when the plane is tilted to the line, and a
    /// surface does not shadow itself.
    pub fn transmission_at(&self, i: u32, j: u32, h: f64, skip: [u32; 2]) -> Rgb {
        let mut t = Rgb::ONE;
        let eps = 1e-6 * (1.0 + h.abs());
        for f in self.pixel(i, j) {
            if (f.height as f64) <= h + eps {
                break;
            }
            if !skip.contains(&f.tri) {
                t *= self.pass[f.tri as usize];
                if t == Rgb::ZERO {
                    break;
                }
            }
        }
        t
    }
}

#[cfg(test)]
#[path = "ldi_tests.rs"]
pub(super) mod tests;
