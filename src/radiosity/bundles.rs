//! The operator estimate: bundles of parallel lines (one LDI per direction, one line per
//! pixel) counted per mesh row, with fixed-point transmission sums per (row, row) pair and
//! the glazing mirror's one-way links, normalised to F̂.

use super::mesh::Mesh;
use super::sparse::Sparse;
use super::strata::bundle_direction;
use crate::math::rng::uniform;
use crate::photometry::Rgb;
use crate::projection::ldi::Fragment;
use crate::projection::{Ldi, ProjectionScene};
use crate::trace::{barycentric, End, Tracer};
use glam::DVec3;
use rayon::prelude::*;

/// Fixed-point scale of transmission sums (τ quantised to 2⁻¹⁶).
const FIX: f64 = 65536.0;

/// One operator from `n_dirs` bundles: counts of lines per row and fixed-point
/// transmission sums per (row, row) pair, normalised to F̂.
pub(super) fn operator(
    pscene: &ProjectionScene,
    tracer: &Tracer,
    mesh: &Mesh,
    n_dirs: u32,
    resolution: u32,
    seed: u64,
) -> (Sparse, u64) {
    let rows = mesh.elements.len();
    // One pixel size for every direction (uniform line density): the bounding sphere's
    // diameter over `resolution`, or the elements' line-spacing floor where that is coarser.
    // Lines cover the whole scene: every element receives, so every element's line count
    // must be complete.
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for t in &pscene.vertices {
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    let diameter = if lo.is_finite() {
        (hi - lo).length()
    } else {
        1.0
    };
    // Work sized to the scene: no finer than the elements need.
    let pixel = (diameter.max(1e-9) / resolution.max(1) as f64).max(mesh.line_spacing_floor());
    let opaque: Vec<bool> = (0..pscene.vertices.len())
        .map(|t| pscene.glazing_tf[t].max_element() <= 0.0)
        .collect();
    // Each direction: (pair key, fixed-point τ) sorted and merged, plus line counts.
    let per_dir: Vec<DirectionLines> = (0..n_dirs)
        .into_par_iter()
        .map(|m| {
            let d = bundle_direction(m, n_dirs, seed);
            let jitter = glam::DVec2::new(
                uniform(seed, 13, 2 * m as u64),
                uniform(seed, 13, 2 * m as u64 + 1),
            );
            let ldi = Ldi::build_window(pscene, d, pixel, (lo, hi), jitter);
            let cam = ldi.camera;
            let pass: Vec<Rgb> = (0..pscene.vertices.len())
                .map(|t| pscene.pass_factor(t, d))
                .collect();
            let mut pairs: Vec<(u64, [u64; 3])> = Vec::new();
            let mut counts = vec![0u32; rows];
            let mut panes: Vec<Fragment> = Vec::new();
            let mirror = Mirror {
                pscene,
                tracer,
                mesh,
            };
            for j in 0..cam.height {
                for i in 0..cam.width {
                    let list = ldi.pixel(i, j);
                    if list.is_empty() {
                        continue;
                    }
                    let x = cam.origin.x + (i as f64 + 0.5) * cam.pixel;
                    let y = cam.origin.y + (j as f64 + 0.5) * cam.pixel;
                    let base = cam.u * x + cam.v * y;
                    // (row, faces the source side) of the last opaque fragment, τ since.
                    let mut prev: Option<(u32, bool)> = None;
                    let mut tau = Rgb::ONE;
                    // Glazing fragments since the last opaque one (triangle, height).
                    panes.clear();
                    for fr in list {
                        let t = fr.tri as usize;
                        if !opaque[t] {
                            // Light from the opaque fragment above (facing down, towards
                            // this pane) reflected back up to it.
                            if let Some((pr, false)) = prev {
                                mirror.link(pr, fr, base, d, tau, &mut pairs);
                            }
                            tau *= pass[t];
                            panes.push(*fr);
                            continue;
                        }
                        let p = base + d * fr.height as f64;
                        let bary = barycentric(pscene.vertices[t], p);
                        let row = mesh.row_at(fr.tri, bary);
                        let up = pscene.normals[t].dot(d) > 0.0;
                        counts[row as usize] += 1;
                        if up {
                            // Light reflected down to this fragment by each pane above it
                            // (up to the previous opaque one), through the panes between.
                            let mut between = Rgb::ONE;
                            for g in panes.iter().rev() {
                                mirror.link(row, g, base, -d, between, &mut pairs);
                                between *= pass[g.tri as usize];
                            }
                        }
                        panes.clear();
                        if let Some((pr, p_up)) = prev {
                            if !p_up && up && tau != Rgb::ZERO {
                                let q = fixed(tau);
                                pairs.push(((row as u64) << 32 | pr as u64, q));
                                pairs.push(((pr as u64) << 32 | row as u64, q));
                            }
                        }
                        prev = Some((row, up));
                        tau = Rgb::ONE;
                    }
                }
            }
            (merge_pairs(pairs), counts)
        })
        .collect();
    let mut n = vec![0u64; rows];
    let mut all: Vec<(u64, [u64; 3])> = Vec::new();
    for (pairs, counts) in per_dir {
        for (r, c) in counts.into_iter().enumerate() {
            n[r] += c as u64;
        }
        all.extend(pairs);
    }
    let lines: u64 = n.iter().sum();
    let all = merge_pairs(all);
    let entries = all.into_iter().map(|(k, q)| {
        let (r, c) = ((k >> 32) as u32, k as u32);
        let inv = 1.0 / (n[r as usize].max(1) as f64 * FIX);
        (r, c, q.map(|x| (x as f64 * inv) as f32))
    });
    (Sparse::from_sorted(rows, entries), lines)
}

/// Fixed-point value of a transmission (or reflection) factor.
fn fixed(v: Rgb) -> [u64; 3] {
    [
        (v.x * FIX).round() as u64,
        (v.y * FIX).round() as u64,
        (v.z * FIX).round() as u64,
    ]
}

/// The specular reflection of glazing in the global-line operator ([`Tracer::mirror`]).
struct Mirror<'a> {
    pscene: &'a ProjectionScene,
    tracer: &'a Tracer,
    mesh: &'a Mesh,
}

impl Mirror<'_> {
    /// A line of the bundle (pixel line `base + h·d`) reaches row `receiver` from pane
    /// fragment `g`, travelling along unit `u` (±d) through panes of transmission
    /// `between`: the light arriving along it was reflected at g, coming from the mirror
    /// direction. Traces that direction (through further panes, τ) and, when it meets the
    /// front face of an opaque triangle, adds the one-way link receiver ← source with
    /// weight between · R_g(θ) · τ_after. One way only: the reverse path is the line of the
    /// mirrored bundle direction, which the directions cover in expectation.
    fn link(
        &self,
        receiver: u32,
        g: &Fragment,
        base: DVec3,
        u: DVec3,
        between: Rgb,
        pairs: &mut Vec<(u64, [u64; 3])>,
    ) {
        if between == Rgb::ZERO {
            return;
        }
        let n = self.tracer.normal(g.tri);
        let c = u.dot(n);
        // The point on the pane's plane, in f64: the fragment's f32 height could leave it
        // on the far side, and the mirror ray would then cross the pane. (A line in the
        // pane's plane, c = 0, is of measure zero.)
        if c.abs() < 1e-12 {
            return;
        }
        let origin = base + u * ((self.pscene.vertices[g.tri as usize][0] - base).dot(n) / c);
        let Some(out) = self.tracer.mirror(g.tri, origin, u, between) else {
            return;
        };
        if let End::Front { tri, point, .. } = out.end {
            if out.power == Rgb::ZERO {
                return;
            }
            let root = self.pscene.vertices[tri as usize];
            let source = self.mesh.row_at(tri, barycentric(root, point));
            pairs.push(((receiver as u64) << 32 | source as u64, fixed(out.power)));
        }
    }
}

/// One bundle's merged (pair key, fixed-point τ) links and per-row line counts.
type DirectionLines = (Vec<(u64, [u64; 3])>, Vec<u32>);

fn merge_pairs(mut v: Vec<(u64, [u64; 3])>) -> Vec<(u64, [u64; 3])> {
    v.sort_unstable_by_key(|e| e.0);
    let mut out: Vec<(u64, [u64; 3])> = Vec::with_capacity(v.len() / 2);
    for (k, q) in v {
        match out.last_mut() {
            Some((lk, lq)) if *lk == k => {
                for c in 0..3 {
                    lq[c] += q[c];
                }
            }
            _ => out.push((k, q)),
        }
    }
    out
}
