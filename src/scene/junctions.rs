//! Cutting surfaces where walls stand on them (T-junctions).
//!
//! Modellers draw a floor plate as one polygon and stand partitions on it; a façade as
//! one polygon and meet it with slabs. The transport meshes each input triangle by
//! quadtree, so an element of such a floor straddles the partition: its one radiosity
//! averages the bright room and the dark corridor, and light leaks through the wall's foot
//! in both directions. Radiance has no mesh and no such error.
//!
//! [`split_at_junctions`] cuts every triangle along the line of each tall triangle edge
//! that lies in its plane and crosses its interior, before any meshing, so no element
//! spans a junction. Low objects (desks, sills, skirtings) and short ones (a door's jambs,
//! table legs) do not cut: they shade the surface but do not divide space into parts lit
//! differently.

use super::Triangle;
use glam::DVec3;
use rayon::prelude::*;
use rstar::{RTree, RTreeObject, AABB};

/// How far (m) a standing triangle must reach out of a surface's plane for its foot to cut
/// that surface: above desk and sill height, below any storey's clear height.
pub const TALL_M: f64 = 1.0;

/// Shortest wall (m) whose foot cuts: the feet on one line are summed (a wall drawn as many
/// small triangles, or interrupted by doors, counts whole). A door's jambs (a wall's
/// thickness each) and a table's legs do not cut.
pub const MIN_FOOT_M: f64 = 1.0;

/// How far (m) an edge may sit off a surface's plane and still stand on it: modelling
/// tolerance of exported models (Rhino's default absolute tolerance is 1 mm).
pub const ON_PLANE_M: f64 = 2e-3;

/// A cut: the foot of a tall edge (two points in the plane of the surface it cuts, scene
/// frame, m).
#[derive(Clone, Copy, Debug)]
struct Cut {
    surface: u32,
    a: DVec3,
    b: DVec3,
}

/// A triangle's box in the broad phase.
struct Boxed {
    index: u32,
    envelope: AABB<[f64; 3]>,
}

impl RTreeObject for Boxed {
    type Envelope = AABB<[f64; 3]>;
    fn envelope(&self) -> Self::Envelope {
        self.envelope
    }
}

fn aabb(points: &[DVec3], grow: f64) -> AABB<[f64; 3]> {
    let lo = points.iter().fold(DVec3::INFINITY, |m, p| m.min(*p)) - grow;
    let hi = points.iter().fold(DVec3::NEG_INFINITY, |m, p| m.max(*p)) + grow;
    AABB::from_corners(lo.to_array(), hi.to_array())
}

/// What [`split_at_junctions`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct JunctionReport {
    /// Input triangles cut along at least one junction.
    pub cut: usize,
    /// Triangles added by the cuts (output count − input count).
    pub added: usize,
}

/// Cuts each triangle along the feet of the tall triangles standing on it (see the module
/// documentation). A triangle stands on surface S when one of its edges lies within
/// [`ON_PLANE_M`] of S's plane, crosses S's interior, and its third vertex is at least
/// [`TALL_M`] from that plane on S's front side (either side when `both_sides`, for
/// models whose surfaces reflect on both faces). The pieces keep the original's material,
/// group and winding, replace it in place, and tile it exactly; the order of the output is
/// a function of the input alone (deterministic whatever the thread count).
pub fn split_at_junctions(
    triangles: Vec<Triangle>,
    both_sides: bool,
) -> (Vec<Triangle>, JunctionReport) {
    let normals: Vec<DVec3> = triangles.iter().map(|t| t.normal()).collect();
    let tree = RTree::bulk_load(
        triangles
            .iter()
            .enumerate()
            .map(|(i, t)| Boxed {
                index: i as u32,
                envelope: aabb(&t.v, ON_PLANE_M),
            })
            .collect(),
    );
    let mut cuts: Vec<Cut> = triangles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(w, t)| {
            let mut found = Vec::new();
            for e in 0..3 {
                let (a, b, apex) = (t.v[e], t.v[(e + 1) % 3], t.v[(e + 2) % 3]);
                for s in tree.locate_in_envelope_intersecting(&aabb(&[a, b], 0.0)) {
                    let si = s.index as usize;
                    if si == w {
                        continue;
                    }
                    let (n, o) = (normals[si], triangles[si].v[0]);
                    let on = |p: DVec3| n.dot(p - o).abs() <= ON_PLANE_M;
                    let h = n.dot(apex - o);
                    let tall = if both_sides { h.abs() } else { h } >= TALL_M;
                    if tall && on(a) && on(b) {
                        found.push(Cut {
                            surface: s.index,
                            a,
                            b,
                        });
                    }
                }
            }
            found
        })
        .collect();
    // Per surface, in the order of the standing triangles: deterministic.
    cuts.sort_by_key(|c| c.surface);
    let cuts = long_feet(cuts, &normals);
    let mut out = Vec::with_capacity(triangles.len() + 2 * cuts.len());
    let mut report = JunctionReport::default();
    let mut next = 0;
    for (i, t) in triangles.iter().enumerate() {
        let start = next;
        while next < cuts.len() && cuts[next].surface as usize == i {
            next += 1;
        }
        if start == next {
            out.push(*t);
            continue;
        }
        // Convex polygons, cut whole and triangulated at the end: k parallel feet make
        // k + 1 cells, not the fans of fans that cutting triangles would.
        let mut cells: Vec<Vec<DVec3>> = vec![t.v.to_vec()];
        for c in &cuts[start..next] {
            cells = cells
                .into_iter()
                .flat_map(|p| cut_cell(p, normals[i], c.a, c.b))
                .collect();
        }
        let pieces: Vec<Triangle> = cells
            .iter()
            .flat_map(|poly| {
                (1..poly.len() - 1).map(|k| Triangle {
                    v: [poly[0], poly[k], poly[k + 1]],
                    ..*t
                })
            })
            .filter(|p| p.cross().length_squared().is_normal())
            .collect();
        if pieces.len() > 1 {
            report.cut += 1;
            report.added += pieces.len() - 1;
        }
        out.extend(pieces);
    }
    (out, report)
}

/// The cuts whose line holds at least [`MIN_FOOT_M`] of feet on their surface (`cuts`
/// sorted by surface; order kept).
fn long_feet(cuts: Vec<Cut>, normals: &[DVec3]) -> Vec<Cut> {
    let mut keep = vec![false; cuts.len()];
    let mut start = 0;
    while start < cuts.len() {
        let s = cuts[start].surface;
        let mut end = start;
        while end < cuts.len() && cuts[end].surface == s {
            end += 1;
        }
        let group = &cuts[start..end];
        let n = normals[s as usize];
        for (k, f) in group.iter().enumerate() {
            let m = n.cross(f.b - f.a).normalize_or_zero();
            let on = |p: DVec3| m.dot(p - f.a).abs() <= ON_PLANE_M;
            let total: f64 = group
                .iter()
                .filter(|g| on(g.a) && on(g.b))
                .map(|g| (g.b - g.a).length())
                .sum();
            keep[start + k] = total >= MIN_FOOT_M;
        }
        start = end;
    }
    cuts.into_iter()
        .zip(keep)
        .filter_map(|(c, k)| k.then_some(c))
        .collect()
}

/// Distance (m) below which a vertex counts as on the cutting line: no sliver thinner than
/// this is made.
const ON_LINE_M: f64 = 1e-6;

/// The convex polygon `cell` (counter-clockwise about `n`) cut by the line through the foot
/// `a`–`b` when the foot crosses its interior: the two convex halves, in the cell's own
/// cyclic order; else the cell unchanged.
fn cut_cell(cell: Vec<DVec3>, n: DVec3, a: DVec3, b: DVec3) -> Vec<Vec<DVec3>> {
    let m = n.cross(b - a);
    let len = m.length();
    if len <= ON_LINE_M {
        return vec![cell];
    }
    let m = m / len;
    let s: Vec<f64> = cell
        .iter()
        .map(|v| {
            let s = m.dot(*v - a);
            if s.abs() <= ON_LINE_M {
                0.0
            } else {
                s
            }
        })
        .collect();
    let straddles = s.iter().any(|x| *x > 0.0) && s.iter().any(|x| *x < 0.0);
    if !straddles || !foot_crosses(&cell, n, a, b) {
        return vec![cell];
    }
    let (mut plus, mut minus) = (Vec::new(), Vec::new());
    for k in 0..cell.len() {
        let l = (k + 1) % cell.len();
        let (p, q, sp, sq) = (cell[k], cell[l], s[k], s[l]);
        if sp >= 0.0 {
            plus.push(p);
        }
        if sp <= 0.0 {
            minus.push(p);
        }
        if sp * sq < 0.0 {
            let x = crossing(p, sp, q, sq);
            plus.push(x);
            minus.push(x);
        }
    }
    vec![plus, minus]
}

/// Where the line crosses edge `p`–`q` (signed distances `sp`, `sq`), computed from the
/// edge's endpoints in a fixed order so the two triangles sharing the edge get the same
/// point to the bit (no crack along the cut).
fn crossing(p: DVec3, sp: f64, q: DVec3, sq: f64) -> DVec3 {
    let ((p, sp), (q, sq)) = if p.to_array() <= q.to_array() {
        ((p, sp), (q, sq))
    } else {
        ((q, sq), (p, sp))
    };
    let t = sp / (sp - sq);
    p + (q - p) * t
}

/// Whether the foot `a`–`b` runs through the convex cell's interior for more than
/// [`ON_LINE_M`] (a wall ending at a cell's edge, or beside it, does not cut it).
fn foot_crosses(cell: &[DVec3], n: DVec3, a: DVec3, b: DVec3) -> bool {
    let d = b - a;
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..cell.len() {
        let (p, q) = (cell[k], cell[(k + 1) % cell.len()]);
        // Inward normal of the edge, for a counter-clockwise piece about `n`.
        let inward = n.cross(q - p).normalize();
        let (f, g) = (inward.dot(a - p), inward.dot(d));
        // Inside strictly: the foot along an edge is not inside.
        let f = f - ON_LINE_M;
        if g.abs() < 1e-300 {
            if f < 0.0 {
                return false;
            }
        } else if g > 0.0 {
            t0 = t0.max(-f / g);
        } else {
            t1 = t1.min(-f / g);
        }
    }
    (t1 - t0) * d.length() > ON_LINE_M
}

#[cfg(test)]
#[path = "junctions_tests.rs"]
mod tests;
