//! The transport's fixed mesh: the input triangles split by midpoint quadtree until each
//! element is at most the target area (finer in the region of interest around the
//! sensors), one unknown per leaf; the area-weighted mapping of any other hierarchy's
//! element values onto it; and the parent level the discretisation estimate reads.

use super::child_of;
use crate::hierarchy::{ElementKey, Hierarchy, MAX_DEPTH};
use crate::photometry::Rgb;
use crate::scene::Scene;
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
}

impl Mesh {
    /// Splits every triangle until its elements are at most `max_area` m² where they meet
    /// `region`, `far_area` m² elsewhere.
    pub fn new(scene: &Scene, max_area: f64, far_area: f64, region: (DVec3, DVec3)) -> Mesh {
        let mut h = Hierarchy::new(scene);
        let meets = |v: &[DVec3; 3]| {
            let lo = v[0].min(v[1]).min(v[2]);
            let hi = v[0].max(v[1]).max(v[2]);
            lo.cmple(region.1).all() && hi.cmpge(region.0).all()
        };
        let mut i = 0;
        while i < h.elements.len() {
            let e = &h.elements[i];
            let limit = if meets(&e.vertices) {
                max_area
            } else {
                far_area.max(max_area)
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
        Mesh {
            region,
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
        let mut i = tri;
        let mut b = bary;
        while let Some(fc) = self.hierarchy.elements[i as usize].first_child {
            i = fc + child_of(&mut b) as u32;
        }
        self.row_of[i as usize]
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
