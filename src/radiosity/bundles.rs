//! The operator estimate: bundles of parallel lines (one LDI per direction, one line per
//! pixel) counted per mesh row, with fixed-point transmission sums per (row, row) pair and
//! the glazing mirror's one-way links, normalised to F̂.

use super::link_sum::{Accumulator, Links};
use super::mesh::Mesh;
use super::sparse::Sparse;
use super::strata::bundle_direction;
use crate::math::rng::uniform;
use crate::photometry::Rgb;
use crate::projection::ldi::Fragment;
use crate::projection::{Ldi, ProjectionScene, Reader};
use crate::trace::{barycentric, End, Tracer};
use glam::DVec3;
use rayon::prelude::*;

/// Fixed-point scale of transmission sums (τ quantised to 2⁻¹⁶).
const FIX: f64 = 65536.0;

/// One operator from `n_dirs` bundles: counts of lines per row and fixed-point
/// transmission sums per (row, row) pair, normalised to F̂.
///
/// A scene that fits the first of the nested windows around the mesh's region
/// ([`crate::scene::context_windows`]) gets one pass of lines at `resolution` pixels across
/// its diameter. A larger one gets a pass per window, with the same directions: the first
/// at `resolution` pixels across that window's diameter, each further one at
/// [`crate::scene::WINDOW_PIXEL_GROWTH`] times the spacing of the one inside it, and each estimating the rows whose smallest window it
/// is (far context still reflects into the room, at a line spacing that grows with its
/// distance like its elements). Each row's estimate comes from the lines of one pass, all
/// of which cross it completely, so it stays unbiased.
pub(super) fn operator(
    pscene: &ProjectionScene,
    tracer: &Tracer,
    mesh: &Mesh,
    n_dirs: u32,
    resolution: u32,
    seed: u64,
) -> (Sparse, u64) {
    let rows = mesh.elements.len();
    let diameter = |b: (DVec3, DVec3)| {
        let d = (b.1 - b.0).length();
        if d.is_finite() {
            d.max(1e-9)
        } else {
            1.0
        }
    };
    let whole = pscene.bounds;
    let res = resolution.max(1) as f64;
    // Work sized to the scene: no finer than the elements need.
    let floor = mesh.line_spacing_floor();
    let windows = crate::scene::context_windows(mesh.region, whole);
    let passes: Vec<Pass> = if windows.len() <= 1 {
        vec![Pass {
            window: whole,
            pixel: (diameter(whole) / res).max(floor),
            rows: None,
        }]
    } else {
        let of_row: Vec<usize> = mesh
            .elements
            .iter()
            .map(|&e| {
                crate::scene::window_of(&windows, &mesh.hierarchy.elements[e as usize].vertices)
            })
            .collect();
        let pixel = (diameter(windows[0]) / res).max(floor);
        windows
            .iter()
            .enumerate()
            .map(|(k, w)| Pass {
                window: *w,
                pixel: pixel * crate::scene::WINDOW_PIXEL_GROWTH.powi(k as i32),
                rows: Some(of_row.iter().map(|&x| x == k).collect()),
            })
            .collect()
    };
    // Each direction's links (pair key, fixed-point τ), sorted and merged by the worker
    // that made them, are summed into one [`Accumulator`] a few directions at a time, with
    // the line counts; past a bound, the sum goes to disk as sorted runs
    // ([`super::link_sum`]). Fixed-point sums are exact, so neither the grouping, the
    // order nor the runs change a bit of the result.
    let mut acc = Accumulator::default();
    let mut n = vec![0u64; rows];
    let in_flight = 2 * rayon::current_num_threads().max(1);
    let all_dirs: Vec<u32> = (0..n_dirs).collect();
    for chunk in all_dirs.chunks(in_flight) {
        let done: Vec<(Links, Vec<u32>)> = chunk
            .par_iter()
            .map(|&m| {
                let d = bundle_direction(m, n_dirs, seed);
                let jitter = glam::DVec2::new(
                    uniform(seed, 13, 2 * m as u64),
                    uniform(seed, 13, 2 * m as u64 + 1),
                );
                let mut pairs = Links::default();
                let mut counts = vec![0u32; rows];
                let pass_factor: Vec<Rgb> = (0..pscene.vertices.len())
                    .map(|t| pscene.pass_factor(t, d))
                    .collect();
                for pass in &passes {
                    let line = Line {
                        d,
                        jitter,
                        pass_factor: &pass_factor,
                    };
                    bundle(pscene, tracer, mesh, pass, &line, &mut pairs, &mut counts);
                }
                (pairs.merged(), counts)
            })
            .collect();
        for (pairs, counts) in done {
            for (t, c) in n.iter_mut().zip(counts) {
                *t += c as u64;
            }
            acc.add(pairs);
        }
    }
    let sum = acc.finish();
    let lines: u64 = n.iter().sum();
    let entries = sum.sorted().map(|(k, q)| {
        let (r, c) = ((k >> 32) as u32, k as u32);
        let inv = 1.0 / (n[r as usize].max(1) as f64 * FIX);
        (r, c, q.map(|x| (x as f64 * inv) as f32))
    });
    (
        Sparse::from_sorted_len(rows, sum.most_len(), entries),
        lines,
    )
}

/// One pass of a bundle: the window its LDI covers (scene frame, m), its pixel (line
/// spacing, m) and the rows it estimates (`None`: all).
struct Pass {
    window: (DVec3, DVec3),
    pixel: f64,
    rows: Option<Vec<bool>>,
}

impl Pass {
    fn serves(&self, row: u32) -> bool {
        self.rows.as_ref().is_none_or(|r| r[row as usize])
    }
}

/// One bundle direction, shared by its passes: the direction, the pixel grid's jitter and
/// each triangle's transmission along it.
struct Line<'a> {
    d: DVec3,
    jitter: glam::DVec2,
    pass_factor: &'a [Rgb],
}

/// The lines of one bundle direction in one pass: per opaque fragment a line count for
/// its row, per pair of consecutive faces that face each other a link each way, and the
/// glazing mirror's one-way links; only for the rows the pass serves (as receivers).
fn bundle(
    pscene: &ProjectionScene,
    tracer: &Tracer,
    mesh: &Mesh,
    pass: &Pass,
    line: &Line,
    pairs: &mut Links,
    counts: &mut [u32],
) {
    let (d, pass_factor) = (line.d, line.pass_factor);
    let ldi = Ldi::build_window(
        pscene,
        d,
        pass.pixel,
        pass.window,
        line.jitter,
        Reader::Lines,
    );
    let cam = ldi.camera;
    let opaque = |t: usize| pscene.glazing_tf[t].max_element() <= 0.0;
    let mut panes: Vec<Fragment> = Vec::new();
    let mirror = Mirror {
        pscene,
        tracer,
        mesh,
    };
    // Links whose receiver this pass does not serve are dropped here.
    let mut local = Links::default();
    // Where each pixel's line is inside the pass's window box (grown by a margin far
    // above a fragment's f32 rounding). A fragment outside it lies on no element the
    // pass serves (those lie inside the box), so it is counted for no row and receives
    // no kept link: its row is found only when it sends a link to one inside.
    let inside = Inside::new(&cam, pass.window, pass.rows.is_some());
    for j in 0..cam.height {
        for i in 0..cam.width {
            let list = ldi.pixel(i, j);
            if list.is_empty() {
                continue;
            }
            let x = cam.origin.x + (i as f64 + 0.5) * cam.pixel;
            let y = cam.origin.y + (j as f64 + 0.5) * cam.pixel;
            let base = cam.u * x + cam.v * y;
            let span = inside.span(base);
            // The last two opaque fragments, each with its row once found: (fragment,
            // row, faces the source side, lies in the box). τ since the last.
            let mut prev: Option<(Fragment, Option<u32>, bool, bool)> = None;
            let mut before_prev: Option<(Fragment, Option<u32>)> = None;
            let mut tau = Rgb::ONE;
            // Glazing fragments since the last opaque one (triangle, height).
            panes.clear();
            let descend = |fr: &Fragment| {
                let p = base + d * fr.height as f64;
                mesh.row_at(fr.tri, barycentric(pscene.vertices[fr.tri as usize], p))
            };
            let is_twin = |a: &Fragment, b: &Fragment| {
                pscene.twin.get(a.tri as usize).is_some_and(|&w| w == b.tri)
            };
            // A fragment's row given the opaque one before it: a back face's row from
            // its front's just before it (same point, mirrored quadtree path) saves the
            // descent. Found only when needed, the same rows as finding every one: a
            // face's twin is never also the twin of the fragment before that.
            let row_after = |fr: &Fragment, before: Option<(Fragment, Option<u32>)>| {
                match before {
                    Some((bf, br)) if is_twin(fr, &bf) => {
                        mesh.twin_row(br.unwrap_or_else(|| descend(&bf)))
                    }
                    _ => None,
                }
                .unwrap_or_else(|| descend(fr))
            };
            for fr in list {
                let t = fr.tri as usize;
                if !opaque(t) {
                    // Light from the opaque fragment above (facing down, towards
                    // this pane) reflected back up to it.
                    if let Some((_, Some(pr), false, true)) = prev {
                        mirror.link(pr, fr, base, d, tau, &mut local);
                    }
                    tau *= pass_factor[t];
                    panes.push(*fr);
                    continue;
                }
                let within = span.holds(fr.height);
                let up = pscene.normals[t].dot(d) > 0.0;
                let linked = matches!(prev, Some((_, _, false, p_in)) if up && tau != Rgb::ZERO && (p_in || within));
                // The previous fragment's row, when this one links to it or is its twin.
                let prev_row = match prev {
                    Some((pf, None, _, _)) if linked || (within && is_twin(fr, &pf)) => {
                        Some(row_after(&pf, before_prev))
                    }
                    Some((_, r, _, _)) => r,
                    None => None,
                };
                let row = (within || linked)
                    .then(|| row_after(fr, prev.map(|(pf, _, _, _)| (pf, prev_row))));
                if let Some(row) = row.filter(|&r| within && pass.serves(r)) {
                    counts[row as usize] += 1;
                }
                if let (true, true, Some(row)) = (up, within, row) {
                    // Light reflected down to this fragment by each pane above it
                    // (up to the previous opaque one), through the panes between.
                    let mut between = Rgb::ONE;
                    for g in panes.iter().rev() {
                        mirror.link(row, g, base, -d, between, &mut local);
                        between *= pass_factor[g.tri as usize];
                    }
                }
                panes.clear();
                if let (true, Some(pr), Some(row)) = (linked, prev_row, row) {
                    let q = fixed(tau);
                    local.push((row as u64) << 32 | pr as u64, q);
                    local.push((pr as u64) << 32 | row as u64, q);
                }
                before_prev = prev.map(|(pf, _, _, _)| (pf, prev_row));
                prev = Some((*fr, row, up, within));
                tau = Rgb::ONE;
            }
        }
    }
    local.retain(|k| pass.serves((k >> 32) as u32));
    pairs.extend(local);
}

/// The part of each pixel's line inside a pass's window box, grown by
/// [`crate::projection::ldi::window_margin`] (far above a fragment's f32 height rounding).
/// `box_` is `None` when the pass serves every row (the whole scene): everything is
/// inside.
struct Inside {
    box_: Option<(DVec3, DVec3)>,
    inv_dir: DVec3,
    margin: f64,
}

/// The heights (along the bundle direction, m) between which one pixel's line is inside
/// the box.
#[derive(Clone, Copy)]
struct Span {
    low: f64,
    high: f64,
}

impl Span {
    fn holds(&self, h: f32) -> bool {
        let h = h as f64;
        h >= self.low && h <= self.high
    }
}

impl Inside {
    fn new(cam: &crate::projection::Camera, window: (DVec3, DVec3), windowed: bool) -> Inside {
        let margin = crate::projection::ldi::window_margin(window);
        Inside {
            box_: windowed.then(|| {
                (
                    window.0 - DVec3::splat(margin),
                    window.1 + DVec3::splat(margin),
                )
            }),
            inv_dir: cam.dir.recip(),
            margin,
        }
    }

    /// The span of the line `base + dir·h`; an axis the line runs parallel to gives ±inf
    /// (or NaN in one of the slab's planes, which `max_element`/`min_element` pass over).
    fn span(&self, base: DVec3) -> Span {
        let Some((lo, hi)) = self.box_ else {
            return Span {
                low: f64::NEG_INFINITY,
                high: f64::INFINITY,
            };
        };
        let a = (lo - base) * self.inv_dir;
        let b = (hi - base) * self.inv_dir;
        Span {
            low: a.min(b).max_element() - self.margin,
            high: a.max(b).min_element() + self.margin,
        }
    }
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
        pairs: &mut Links,
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
            pairs.push((receiver as u64) << 32 | source as u64, fixed(out.power));
        }
    }
}
