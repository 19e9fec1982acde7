//! Visibility ratio and quad-tree refinement (Besuievsky & Martín §5.2–5.3).
//!
//! For a patch, n_p counts the pixels it is projected into (at any depth) and n_v those in
//! which light reaches it (it is first along the line, or only glazing lies in front:
//! transmitted visibility). A patch with V_min < VR = n_v/n_p < V_max is split into four
//! children, which are scan-converted over the same pixels and take their parent's place
//! there (here: the child looks up its triangle's fragment in each pixel it covers, which
//! is exactly the exchanged entry). Refinement stops at the minimum area, the maximum
//! depth, or when a patch's projection is smaller than a pixel. A leaf's transfer weight
//! is (Ap/A)·Σt/n_p = cos θ · (mean transmission over its pixels).

use super::{DirectionRecord, Ldi, LeafWeight, ProjectionParams, ProjectionScene};
use crate::hierarchy::{split, ElementKey, MAX_DEPTH};
use crate::math::raster;
use crate::photometry::Rgb;
use glam::DVec3;
use rayon::prelude::*;

/// Coverage of one patch in the LDI.
#[derive(Clone, Copy, Debug, Default)]
struct Coverage {
    n_p: u32,
    n_v: u32,
    t_sum: Rgb,
}

impl Coverage {
    /// Counts one covered pixel whose line arrives with transmission `t`.
    fn add(&mut self, t: Rgb) {
        self.n_p += 1;
        if t.max_element() > 0.0 {
            self.n_v += 1;
        }
        self.t_sum += t;
    }
}

/// Coverage of the element `v` of triangle `faces[0]` (`faces[1]`: its other face).
fn coverage(ldi: &Ldi, faces: [u32; 2], v: &[DVec3; 3]) -> Coverage {
    let tri = faces[0];
    let cam = &ldi.camera;
    let p = v.map(|x| cam.to_pixel(x));
    let h = v.map(|x| cam.height_of(x));
    let mut c = Coverage::default();
    raster::rasterize(p, h, cam.width, cam.height, |i, j, z| {
        let t = match ldi.arriving(i, j, tri) {
            Some(t) => t,
            // Rounding at the midpoints can put a child's sample just outside its
            // triangle's own samples; fall back to the line itself.
            None => ldi.transmission_at(i, j, z, faces),
        };
        c.add(t);
    });
    c
}

/// The coverage of every input triangle whole, from one pass over the LDI's fragments.
/// The LDI holds each triangle's fragment at exactly the pixels [`coverage`] would
/// rasterise it into (the same vertices and camera; a back face is its front's vertices
/// with two swapped, which rasterise alike), and the pass meets them in the same row
/// order, so the sums are the same to the bit. Refinement tests every triangle whole
/// first, and this spares that second rasterisation and its random fragment lookups.
fn whole_coverages(ldi: &Ldi, triangles: usize) -> Vec<Coverage> {
    let mut out = vec![Coverage::default(); triangles];
    ldi.for_each_arrival(|f, t| out[f.tri as usize].add(t));
    out
}

/// Transmission at a single point (for patches too small to cover a pixel centre).
fn point_transmission(ldi: &Ldi, faces: [u32; 2], v: &[DVec3; 3]) -> Rgb {
    let cam = &ldi.camera;
    let c = (v[0] + v[1] + v[2]) / 3.0;
    let q = cam.to_pixel(c);
    let i = (q.x.floor().max(0.0) as u32).min(cam.width - 1);
    let j = (q.y.floor().max(0.0) as u32).min(cam.height - 1);
    ldi.transmission_at(i, j, cam.height_of(c), faces)
}

/// The LDIs of one direction, one per window ([`crate::scene::context_windows`]; one LDI
/// of the whole scene and no windows when it is projected whole).
#[derive(Clone, Copy)]
struct Views<'a> {
    ldis: &'a [Ldi],
    windows: &'a [(DVec3, DVec3)],
    /// [`whole_coverages`] of each of `ldis`.
    whole: &'a [Vec<Coverage>],
}

impl Views<'_> {
    /// The index in `ldis` of the LDI an element with vertices `v` is refined against:
    /// that of the smallest window holding it (so its whole projection is in that image).
    fn for_element(&self, v: &[DVec3; 3]) -> usize {
        if self.windows.is_empty() {
            0
        } else {
            crate::scene::window_of(self.windows, v)
        }
    }

    /// Whether an element reaches into a window finer than its own with an edge longer
    /// than 16 of that window's pixels: a large triangle across a window's edge (a site's
    /// ground running into the room's region, often a long strip between footprints).
    /// Seen in its coarse image, a shadow near the room can fall between pixel centres and
    /// the element look fully lit (measured: the office on a 1 km ground refined to 12 000
    /// elements instead of 87 000, and its sensors read up to 8 % high), so it is split
    /// until its parts lie in their own windows or are short in the finer one's pixels.
    /// By edge, not area: a 490 × 12 m strip has the area of a small square.
    fn straddles(&self, v: &[DVec3; 3]) -> bool {
        let k = crate::scene::window_of(self.windows, v);
        if k == 0 {
            return false;
        }
        let (a, b) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
        let w = self.windows[k - 1];
        let finer = self.ldis[k - 1].camera.pixel;
        let edge = (0..3)
            .map(|i| (v[(i + 1) % 3] - v[i]).length())
            .fold(0.0, f64::max);
        a.cmple(w.1).all() && b.cmpge(w.0).all() && edge > 16.0 * finer
    }
}

/// Refines one input triangle; pushes its lit leaves. Returns (tested, split).
fn refine_triangle(
    scene: &ProjectionScene,
    views: Views,
    params: &ProjectionParams,
    tri: u32,
    out: &mut Vec<LeafWeight>,
) -> (u64, u64) {
    let dir = views.ldis[0].camera.dir;
    let cos = scene.normals[tri as usize].dot(dir);
    if cos <= 0.0 || cos.is_nan() {
        return (0, 0); // faces away: receives nothing from this source
    }
    let glazing = scene.glazing_tf[tri as usize].max_element() > 0.0;
    let faces = [
        tri,
        scene.twin.get(tri as usize).copied().unwrap_or(u32::MAX),
    ];
    let max_depth = params.max_depth.min(MAX_DEPTH);
    let (mut tested, mut splits) = (0, 0);
    let mut stack = vec![(ElementKey::root(tri), scene.vertices[tri as usize])];
    while let Some((key, v)) = stack.pop() {
        tested += 1;
        let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
        let view = views.for_element(&v);
        let ldi = &views.ldis[view];
        let pixel_area = ldi.camera.pixel * ldi.camera.pixel;
        let c = if key.depth() == 0 {
            views.whole[view][tri as usize]
        } else {
            coverage(ldi, faces, &v)
        };
        let t_mean = if c.n_p == 0 {
            point_transmission(ldi, faces, &v)
        } else {
            let vr = c.n_v as f64 / c.n_p as f64;
            let partial = vr > params.v_min && vr < params.v_max
                || (c.n_v > 0 && c.n_v < c.n_p && area > params.partial_area_m2);
            let refine = !glazing
                && key.depth() < max_depth
                && (partial && area > params.min_area_m2 && area * cos > pixel_area
                    || views.straddles(&v));
            if refine {
                splits += 1;
                let kids = split(v);
                for k in (0..4).rev() {
                    stack.push((key.child(k as u8), kids[k]));
                }
                continue;
            }
            c.t_sum / c.n_p as f64
        };
        let weight = t_mean * cos;
        if weight.max_element() > 0.0 {
            out.push(LeafWeight { key, weight });
        }
    }
    (tested, splits)
}

/// Refines every input triangle and returns the lit leaves in key order: against `ldis[0]`
/// when `windows` is empty, else each element against the LDI of the smallest of `windows`
/// holding it (`ldis[k]` covers `windows[k]`). The record's image counters are those of
/// `ldis[0]`; its fragments count all of them.
pub fn refine_all(
    scene: &ProjectionScene,
    ldis: &[Ldi],
    windows: &[(DVec3, DVec3)],
    params: &ProjectionParams,
) -> DirectionRecord {
    let whole: Vec<Vec<Coverage>> = ldis
        .par_iter()
        .map(|l| whole_coverages(l, scene.vertices.len()))
        .collect();
    let views = Views {
        ldis,
        windows,
        whole: &whole,
    };
    let parts: Vec<(Vec<LeafWeight>, u64, u64)> = (0..scene.vertices.len() as u32)
        .into_par_iter()
        .with_min_len(64)
        .map(|tri| {
            let mut leaves = Vec::new();
            let (t, s) = refine_triangle(scene, views, params, tri, &mut leaves);
            (leaves, t, s)
        })
        .collect();
    let mut record = DirectionRecord::default();
    for (mut leaves, t, s) in parts {
        leaves.sort_unstable_by_key(|l| l.key.path);
        record.leaves.append(&mut leaves);
        record.stats.elements_tested += t;
        record.stats.elements_split += s;
    }
    record.stats.lit_leaves = record.leaves.len() as u64;
    let cam = &ldis[0].camera;
    record.stats.width = cam.width;
    record.stats.height = cam.height;
    record.stats.pixel_m = cam.pixel;
    record.stats.fragments = ldis.iter().map(|l| l.fragment_count() as u64).sum();
    record
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::uniform;
    use crate::projection::ldi::tests::scene_of;
    use crate::scene::Material;

    /// Refinement takes each whole triangle's coverage from one pass over the LDI's
    /// fragments: it must be what rasterising the triangle gives, to the bit, for front
    /// faces, back faces and glazing, sliver and pixel-sized triangles among them.
    #[test]
    fn whole_triangle_coverage_from_the_fragments_is_the_rasterised_one() {
        let material = |name: &str, kd: f64, tf: Rgb| Material {
            name: name.into(),
            kd: Rgb::splat(kd),
            tf,
            ke: Rgb::ZERO,
        };
        let materials = vec![
            material("grey", 0.5, Rgb::ZERO),
            material("glass", 0.08, Rgb::new(0.613, 0.771, 0.837)),
            material("tinted", 0.05, Rgb::new(0.291, 0.447, 0.519)),
        ];
        let r = |i: u64| uniform(11, 0, i);
        let mut tris = Vec::new();
        for k in 0..400u64 {
            let c = DVec3::new(r(8 * k) * 10.0, r(8 * k + 1) * 10.0, r(8 * k + 2) * 4.0);
            // Sizes from 1 cm to 4 m, so some cover no pixel centre and some hundreds.
            let size = 0.01 * 400f64.powf(r(8 * k + 3));
            let corner = |a: u64| {
                c + size
                    * DVec3::new(
                        r(8 * k + 4 + a) - 0.5,
                        r(8 * k + 5 + a) - 0.5,
                        r(8 * k + 6 + a) - 0.5,
                    )
            };
            let m = [0, 1, 2][(k % 3) as usize];
            tris.push(([corner(0), corner(1), corner(2)], m));
        }
        let fronts = tris.len();
        let mut twin = vec![u32::MAX; fronts];
        for k in (0..fronts).step_by(3) {
            if tris[k].1 == 0 {
                let v = tris[k].0;
                twin[k] = tris.len() as u32;
                twin.push(k as u32);
                tris.push(([v[0], v[2], v[1]], 0));
            }
        }
        let mut s = scene_of(tris, materials);
        s.twin = twin;
        let (mut partial, mut tinted) = (0, 0);
        for d in 0..6u64 {
            let (alt, az) = (
                0.05 + 1.4 * r(10_000 + 2 * d),
                std::f64::consts::TAU * r(10_001 + 2 * d),
            );
            let dir = DVec3::new(alt.cos() * az.cos(), alt.cos() * az.sin(), alt.sin());
            let ldi = Ldi::build(&s, dir, 96);
            let whole = whole_coverages(&ldi, s.vertices.len());
            for (tri, w) in whole.iter().enumerate() {
                let faces = [tri as u32, s.twin[tri]];
                let c = coverage(&ldi, faces, &s.vertices[tri]);
                assert_eq!(
                    (c.n_p, c.n_v),
                    (w.n_p, w.n_v),
                    "triangle {tri}, direction {d}"
                );
                assert_eq!(c.t_sum, w.t_sum, "triangle {tri}, direction {d}");
                partial += usize::from(c.n_v > 0 && c.n_v < c.n_p);
                tinted += usize::from(c.t_sum.x != c.t_sum.z);
            }
        }
        // The scene must exercise shadows and glass, or the test proves little.
        assert!(
            partial > 50 && tinted > 10,
            "{partial} partial, {tinted} tinted"
        );
    }
}
