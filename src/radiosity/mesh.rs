//! The transport's fixed mesh: the input triangles split by midpoint quadtree until each
//! element is at most the target area (finer in the region of interest around the
//! sensors), one unknown per leaf; the area-weighted mapping of any other hierarchy's
//! element values onto it; and the parent level the discretisation estimate reads.

use super::child_of;
use crate::hierarchy::{ElementKey, Hierarchy, MAX_DEPTH};
use crate::photometry::Rgb;
use crate::scene::Scene;
use crate::trace::barycentric;
use glam::DVec3;

/// The fixed mesh: leaves of a uniformly refined hierarchy, one unknown each.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// The refined hierarchy (leaves are the unknowns).
    pub hierarchy: Hierarchy,
    /// Element index of each unknown (row).
    pub elements: Vec<u32>,
    /// Row of each element (`u32::MAX` for inner elements).
    pub row_of: Vec<u32>,
    /// Area of each row, m².
    pub area: Vec<f64>,
    /// Coarse row (parent element, or the element itself at the root) of each row.
    pub coarse_of: Vec<u32>,
    /// Number of coarse rows.
    pub coarse_rows: usize,
    /// The region of interest (min, max corners, scene frame, m).
    pub region: (DVec3, DVec3),
    /// Largest element inside the region of interest, m² (what `Mesh::new` was given).
    pub max_area: f64,
    /// The row of the same element on the opposite face (a back face's and its front's,
    /// both ways), `u32::MAX` where there is none. Both faces are split alike, so their
    /// leaves pair up exactly.
    twin_row: Vec<u32>,
    /// Per element of `hierarchy`: its first child's index, or for a leaf its row with
    /// [`LEAF`] set. One `u32` a level keeps a point's descent to its row (once per
    /// line and surface crossing in the operator's build) in cache, where each
    /// [`crate::hierarchy::Element`] is 112 bytes.
    descent: Vec<u32>,
}

/// Marks a [`Mesh`] descent entry as a leaf's row.
const LEAF: u32 = 1 << 31;

/// Largest far element (outside the region of interest) per squared distance from the
/// region, m²/m²: an element's edge is then about half its distance.
pub const FAR_AREA_PER_D2: f64 = 0.1;

/// Lines per direction that cross an element of the region of interest face-on, at the
/// coarsest line spacing a run uses ([`Mesh::line_spacing_floor`]).
pub const LINES_PER_ELEMENT: f64 = 4.0;

impl Mesh {
    /// The coarsest line spacing (m) that still crosses every element of the region of
    /// interest, but for the smallest ones holding 1 % of its area, with
    /// [`LINES_PER_ELEMENT`] lines per direction. Lines finer than this only add work: the
    /// noise of an element's row is set by the lines crossing it. In a small scene (a 2 m
    /// box) the scene-wide spacing is far finer; in a room with its site it is coarser, and
    /// this floor does not apply.
    pub fn line_spacing_floor(&self) -> f64 {
        let mut a: Vec<f64> = self
            .area
            .iter()
            .copied()
            .filter(|&x| x > 0.0 && x <= self.max_area * (1.0 + 1e-9))
            .collect();
        if a.is_empty() {
            return 0.0;
        }
        a.sort_by(f64::total_cmp);
        let total: f64 = a.iter().sum();
        let mut acc = 0.0;
        let mut q = a[0];
        for x in a {
            acc += x;
            q = x;
            if acc > 0.01 * total {
                break;
            }
        }
        (q / LINES_PER_ELEMENT).sqrt()
    }

    /// Splits every triangle until its elements are at most `max_area` m² where they meet
    /// `region`, elsewhere `far_area` m² or [`FAR_AREA_PER_D2`] × the squared distance from
    /// the region, whichever is larger.
    pub fn new(scene: &Scene, max_area: f64, far_area: f64, region: (DVec3, DVec3)) -> Mesh {
        let mut h = Hierarchy::new(scene);
        let meets = |v: &[DVec3; 3]| {
            let lo = v[0].min(v[1]).min(v[2]);
            let hi = v[0].max(v[1]).max(v[2]);
            lo.cmple(region.1).all() && hi.cmpge(region.0).all()
        };
        // Beyond the region an element may grow with its distance d from it: at most
        // FAR_AREA_PER_D2 · d² (an edge about half the distance), so a site of any extent
        // costs a number of rows that grows with the logarithm of its size, and every far
        // element still subtends a bounded angle from the room.
        let distance = |v: &[DVec3; 3]| {
            let lo = v[0].min(v[1]).min(v[2]);
            let hi = v[0].max(v[1]).max(v[2]);
            (region.0 - hi).max(lo - region.1).max(DVec3::ZERO).length()
        };
        let mut i = 0;
        while i < h.elements.len() {
            let e = &h.elements[i];
            let limit = if meets(&e.vertices) {
                max_area
            } else {
                far_area
                    .max(max_area)
                    .max(FAR_AREA_PER_D2 * distance(&e.vertices).powi(2))
            };
            if e.area > limit && e.key.depth() + 1 < MAX_DEPTH.min(16) {
                let k = e.key.child(0);
                h.insert(k);
            }
            i += 1;
        }
        let mut row_of = vec![u32::MAX; h.elements.len()];
        let mut elements = Vec::new();
        let mut area = Vec::new();
        for l in h.leaves() {
            row_of[l as usize] = elements.len() as u32;
            elements.push(l);
            area.push(h.elements[l as usize].area);
        }
        // Coarse level: a leaf's parent (all siblings of a uniform split are leaves too).
        let mut coarse_id = std::collections::HashMap::new();
        let coarse_of: Vec<u32> = elements
            .iter()
            .map(|&e| {
                let el = &h.elements[e as usize];
                let c = el.parent.unwrap_or(e);
                let n = coarse_id.len() as u32;
                *coarse_id.entry(c).or_insert(n)
            })
            .collect();
        assert!(
            h.elements.len() < LEAF as usize,
            "mesh of {} elements",
            h.elements.len()
        );
        let descent: Vec<u32> = h
            .elements
            .iter()
            .zip(&row_of)
            .map(|(e, &row)| e.first_child.unwrap_or(row | LEAF))
            .collect();
        let mut twin_row = vec![u32::MAX; elements.len()];
        for (r, &e) in elements.iter().enumerate() {
            let el = &h.elements[e as usize];
            let tri = el.key.tri as usize;
            match scene.twin.get(tri) {
                // From each back face (after its front) to its front's leaf at its centre.
                Some(&f) if f != u32::MAX && (f as usize) < tri => {
                    let c = (el.vertices[0] + el.vertices[1] + el.vertices[2]) / 3.0;
                    let b = barycentric(scene.triangles[f as usize].v, c);
                    let fr = descend(&descent, f, b);
                    twin_row[r] = fr;
                    twin_row[fr as usize] = r as u32;
                }
                _ => {}
            }
        }
        Mesh {
            twin_row,
            descent,
            region,
            max_area,
            coarse_rows: coarse_id.len(),
            hierarchy: h,
            elements,
            row_of,
            area,
            coarse_of,
        }
    }

    /// Row containing the point with barycentrics `bary` on input triangle `tri`.
    pub fn row_at(&self, tri: u32, bary: [f64; 3]) -> u32 {
        descend(&self.descent, tri, bary)
    }

    /// The row of the same element on the opposite face of `row`'s triangle, if it has one.
    pub fn twin_row(&self, row: u32) -> Option<u32> {
        self.twin_row
            .get(row as usize)
            .copied()
            .filter(|&r| r != u32::MAX)
    }

    /// Area-weighted mean of `value` (per element of `h`, leaf totals as
    /// [`crate::transfer::transfer`] returns) over each row: rows finer than `h` take their
    /// containing leaf's value, rows coarser average `h`'s leaves inside them.
    pub fn average_onto(&self, h: &Hierarchy, value: &[Rgb]) -> Vec<Rgb> {
        fn mean(h: &Hierarchy, v: &[Rgb], i: u32) -> Rgb {
            let e = &h.elements[i as usize];
            match e.first_child {
                None => v.get(i as usize).copied().unwrap_or(Rgb::ZERO),
                Some(fc) => {
                    let mut s = Rgb::ZERO;
                    for k in 0..4 {
                        let c = fc + k;
                        s += mean(h, v, c) * h.elements[c as usize].area;
                    }
                    if e.area > 0.0 {
                        s / e.area
                    } else {
                        Rgb::ZERO
                    }
                }
            }
        }
        self.elements
            .iter()
            .map(|&e| {
                let mut key: ElementKey = self.hierarchy.elements[e as usize].key;
                loop {
                    if let Some(j) = h.get(key) {
                        return mean(h, value, j);
                    }
                    match key.parent() {
                        Some(p) => key = p,
                        None => return Rgb::ZERO,
                    }
                }
            })
            .collect()
    }
}

/// The leaf row under triangle `tri` containing barycentrics `bary`, by [`Mesh`]'s
/// `descent` table.
fn descend(descent: &[u32], tri: u32, bary: [f64; 3]) -> u32 {
    let mut i = tri;
    let mut b = bary;
    loop {
        let step = descent[i as usize];
        if step & LEAF != 0 {
            return step & !LEAF;
        }
        i = step + child_of(&mut b) as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::synthetic::SceneBuilder;

    fn mesh_of(b: SceneBuilder, max_area: f64) -> Mesh {
        let scene = b.build("test").unwrap();
        let big = DVec3::splat(1e6);
        Mesh::new(&scene, max_area, 4.0, (-big, big))
    }

    #[test]
    fn line_spacing_floor_follows_the_elements_not_a_sliver() {
        // A 2 m box: 2 m² half-faces split to 0.125 m² (≤ 0.25 m²), 4 lines per direction.
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("wall", 0.5);
        b.add_box("box", m, DVec3::ZERO, DVec3::splat(2.0));
        let floor = mesh_of(b, 0.25).line_spacing_floor();
        assert!(
            (floor - (0.125f64 / LINES_PER_ELEMENT).sqrt()).abs() < 1e-12,
            "{floor}"
        );
        // A sliver of 1e-6 m² holds far less than 1 % of the area: the floor stays.
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("wall", 0.5);
        b.add_box("box", m, DVec3::ZERO, DVec3::splat(2.0));
        b.add_triangle(
            "sliver",
            m,
            [
                DVec3::new(5.0, 0.0, 0.0),
                DVec3::new(5.001, 0.0, 0.0),
                DVec3::new(5.0, 0.002, 0.0),
            ],
        );
        let with_sliver = mesh_of(b, 0.25).line_spacing_floor();
        assert_eq!(with_sliver, floor);
    }
}
