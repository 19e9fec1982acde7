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
    // the line counts. The pairs of many directions repeat; one list per worker, each
    // merged when it had doubled, held four to five times the operator's links at once,
    // the largest holding of a cold run. Fixed-point sums are exact, so neither the
    // grouping nor the order changes a bit of the result.
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
    let all = acc.finish();
    let lines: u64 = n.iter().sum();
    let entries = all.into_sorted().map(|(k, q)| {
        let (r, c) = ((k >> 32) as u32, k as u32);
        let inv = 1.0 / (n[r as usize].max(1) as f64 * FIX);
        (r, c, q.map(|x| (x as f64 * inv) as f32))
    });
    (Sparse::from_sorted(rows, entries), lines)
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
    let ldi = Ldi::build_window(pscene, d, pass.pixel, pass.window, line.jitter);
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
            // A back face's row, from its front's just before it (same point, mirrored
            // quadtree path): saves the descent.
            let mut last: Option<(u32, u32)> = None;
            for fr in list {
                let t = fr.tri as usize;
                if !opaque(t) {
                    // Light from the opaque fragment above (facing down, towards
                    // this pane) reflected back up to it.
                    if let Some((pr, false)) = prev {
                        mirror.link(pr, fr, base, d, tau, &mut local);
                    }
                    tau *= pass_factor[t];
                    panes.push(*fr);
                    continue;
                }
                let twin = match last {
                    Some((lt, lr)) if pscene.twin.get(t).is_some_and(|&w| w == lt) => {
                        mesh.twin_row(lr)
                    }
                    _ => None,
                };
                let row = twin.unwrap_or_else(|| {
                    let p = base + d * fr.height as f64;
                    mesh.row_at(fr.tri, barycentric(pscene.vertices[t], p))
                });
                last = Some((fr.tri, row));
                let up = pscene.normals[t].dot(d) > 0.0;
                if pass.serves(row) {
                    counts[row as usize] += 1;
                }
                if up {
                    // Light reflected down to this fragment by each pane above it
                    // (up to the previous opaque one), through the panes between.
                    let mut between = Rgb::ONE;
                    for g in panes.iter().rev() {
                        mirror.link(row, g, base, -d, between, &mut local);
                        between *= pass_factor[g.tri as usize];
                    }
                }
                panes.clear();
                if let Some((pr, p_up)) = prev {
                    if !p_up && up && tau != Rgb::ZERO {
                        let q = fixed(tau);
                        local.push((row as u64) << 32 | pr as u64, q);
                        local.push((pr as u64) << 32 | row as u64, q);
                    }
                }
                prev = Some((row, up));
                tau = Rgb::ONE;
            }
        }
    }
    local.retain(|k| pass.serves((k >> 32) as u32));
    pairs.extend(local);
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

/// Links (receiver row << 32 | source row, fixed-point τ), grey ones with one value: in
/// a scene without coloured glazing every link is grey, and half the bytes of the
/// lists, which are the operator build's largest holding.
#[derive(Default)]
struct Links {
    grey: Vec<(u64, u64)>,
    colour: Vec<(u64, [u64; 3])>,
}

impl Links {
    fn push(&mut self, key: u64, q: [u64; 3]) {
        if q[0] == q[1] && q[1] == q[2] {
            self.grey.push((key, q[0]));
        } else {
            self.colour.push((key, q));
        }
    }

    fn len(&self) -> usize {
        self.grey.len() + self.colour.len()
    }

    fn extend(&mut self, other: Links) {
        self.grey.extend(other.grey);
        self.colour.extend(other.colour);
    }

    fn retain(&mut self, keep: impl Fn(u64) -> bool) {
        self.grey.retain(|e| keep(e.0));
        self.colour.retain(|e| keep(e.0));
    }

    /// Each list sorted by key, equal keys' values summed.
    fn merged(self) -> Links {
        Links {
            grey: merge_pairs(self.grey, |a, b| *a += b),
            colour: merge_pairs(self.colour, |a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += y;
                }
            }),
        }
    }

    /// Every key once, in order, with its grey and colour sums added (exact: fixed
    /// point).
    fn into_sorted(self) -> impl Iterator<Item = (u64, [u64; 3])> {
        let m = self.merged();
        let mut grey = m.grey.into_iter().peekable();
        let mut colour = m.colour.into_iter().peekable();
        std::iter::from_fn(move || match (grey.peek(), colour.peek()) {
            (Some(&(kg, g)), Some(&(kc, c))) => Some(if kg < kc {
                grey.next();
                (kg, [g; 3])
            } else if kc < kg {
                colour.next();
                (kc, c)
            } else {
                grey.next();
                colour.next();
                (kc, c.map(|x| x + g))
            }),
            (Some(&(kg, g)), None) => {
                grey.next();
                Some((kg, [g; 3]))
            }
            (None, Some(_)) => colour.next(),
            (None, None) => None,
        })
    }
}

/// Links summed over many directions in bounded memory: one sorted list with one entry
/// per key, and the directions' lists pending beside it, sorted and merged into it (in
/// place, from its end) once they reach a quarter of it. Held at most: the links' sum and
/// half as much again, where lists merged when they had doubled held twice the sum and
/// more.
#[derive(Default)]
struct Accumulator {
    merged: Links,
    pending: Links,
}

impl Accumulator {
    /// Entries pending below which no merge is made, whatever the sum's size.
    const MIN_PENDING: usize = 1 << 20;

    fn add(&mut self, links: Links) {
        self.pending.extend(links);
        if self.pending.len() > (self.merged.len() / 4).max(Self::MIN_PENDING) {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let p = std::mem::take(&mut self.pending).merged();
        let m = &mut self.merged;
        m.grey = merge_sorted(std::mem::take(&mut m.grey), p.grey, |a, b| *a += b);
        m.colour = merge_sorted(std::mem::take(&mut m.colour), p.colour, |a, b| {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        });
    }

    /// The sum: each list sorted by key, one entry per key.
    fn finish(mut self) -> Links {
        self.flush();
        self.merged
    }
}

/// Two lists, each sorted by key with one entry per key, as one such list with equal
/// keys' values summed (by `add`): written into `a` from its end, so nothing but `a`
/// grows.
fn merge_sorted<V: Copy>(
    mut a: Vec<(u64, V)>,
    b: Vec<(u64, V)>,
    add: impl Fn(&mut V, V),
) -> Vec<(u64, V)> {
    let Some(&fill) = b.first() else {
        return a;
    };
    let (na, nb) = (a.len(), b.len());
    a.resize(na + nb, fill);
    let (mut i, mut j, mut w) = (na, nb, na + nb);
    // The write index never passes an unread entry of `a`: w − i is what of `b` is left
    // plus the keys merged, at least 0.
    while j > 0 {
        w -= 1;
        let y = b[j - 1];
        if i > 0 && a[i - 1].0 > y.0 {
            a[w] = a[i - 1];
            i -= 1;
        } else if i > 0 && a[i - 1].0 == y.0 {
            let mut x = a[i - 1];
            add(&mut x.1, y.1);
            a[w] = x;
            i -= 1;
            j -= 1;
        } else {
            a[w] = y;
            j -= 1;
        }
    }
    // Keys merged left a gap of w − i between a's untouched head and the merged tail.
    if w > i {
        a.copy_within(w.., i);
        a.truncate(a.len() - (w - i));
    }
    a
}

/// `v` sorted by key with equal keys' values summed (by `add`), in place.
fn merge_pairs<V: Copy + Send>(mut v: Vec<(u64, V)>, add: impl Fn(&mut V, V)) -> Vec<(u64, V)> {
    v.par_sort_unstable_by_key(|e| e.0);
    let mut w = 0;
    for i in 0..v.len() {
        if w > 0 && v[w - 1].0 == v[i].0 {
            let q = v[i].1;
            add(&mut v[w - 1].1, q);
        } else {
            v[w] = v[i];
            w += 1;
        }
    }
    v.truncate(w);
    v.shrink_to_fit();
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::mix64;
    use std::collections::BTreeMap;

    /// Grey and coloured links, pushed in any order and merged in any grouping, read back
    /// as one sum per key in key order: the same as a plain map's sums.
    #[test]
    fn links_sum_per_key_whatever_their_colour_and_grouping() {
        let mut want: BTreeMap<u64, [u64; 3]> = BTreeMap::new();
        let mut parts = vec![Links::default(), Links::default(), Links::default()];
        for i in 0..3000u64 {
            let h = mix64(i);
            let key = ((h % 37) << 32) | ((h >> 20) % 41);
            let g = (h >> 40) % 1000;
            let q = if h % 5 == 0 {
                [g, g + 1, g + 7]
            } else {
                [g; 3]
            };
            let w = want.entry(key).or_default();
            for (a, b) in w.iter_mut().zip(q) {
                *a += b;
            }
            parts[(h % 3) as usize].push(key, q);
        }
        let mut all = Links::default();
        for p in parts {
            all.extend(p.merged());
            all = all.merged();
        }
        assert!(!all.grey.is_empty() && !all.colour.is_empty());
        let got: Vec<(u64, [u64; 3])> = all.into_sorted().collect();
        let want: Vec<(u64, [u64; 3])> = want.into_iter().collect();
        assert_eq!(got, want);
    }

    /// The accumulator's sums equal a plain map's, whether its merges come after every
    /// list, every few, or only at the end, with keys before, between and after those
    /// already merged, and empty lists among them.
    #[test]
    fn the_accumulator_sums_per_key_whenever_it_merges() {
        for every in [1, 3, 1000] {
            let mut want: BTreeMap<u64, [u64; 3]> = BTreeMap::new();
            let mut acc = Accumulator::default();
            for list in 0..200u64 {
                let mut links = Links::default();
                for i in 0..(list % 7) * 5 {
                    let h = mix64(list << 20 | i);
                    // Few keys, so lists repeat them; the range widens as lists go on.
                    let key = ((h % (3 + list / 10)) << 32) | ((h >> 24) % 13);
                    let g = (h >> 40) % 1000;
                    let q = if h % 4 == 0 { [g, g + 3, 1] } else { [g; 3] };
                    let w = want.entry(key).or_default();
                    for (a, b) in w.iter_mut().zip(q) {
                        *a += b;
                    }
                    links.push(key, q);
                }
                acc.add(links.merged());
                if list % every == 0 {
                    acc.flush();
                    let grey: Vec<u64> = acc.merged.grey.iter().map(|e| e.0).collect();
                    let colour: Vec<u64> = acc.merged.colour.iter().map(|e| e.0).collect();
                    for l in [grey, colour] {
                        assert!(
                            l.windows(2).all(|w| w[0] < w[1]),
                            "sorted, one entry per key"
                        );
                    }
                }
            }
            let got: Vec<(u64, [u64; 3])> = acc.finish().into_sorted().collect();
            let want: Vec<(u64, [u64; 3])> = want.into_iter().collect();
            assert_eq!(got, want, "merging every {every} lists");
        }
    }
}
