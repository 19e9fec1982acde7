//! Global-line transport: the interreflection operator of a fixed mesh, estimated once per
//! geometry with bundles of parallel lines (the paper's LDIs, DESIGN §3), then solved
//! deterministically for every timestep, warm-started from the previous one.
//!
//! * **Lines.** A random direction's orthographic projection is a bundle of parallel
//!   lines, one per pixel; consecutive opaque fragments on a pixel's list see each other
//!   (glazing between them multiplies the line by τ(θ)). Over directions uniform on the
//!   sphere, the lines crossing element i are cosine-distributed about its normal on its
//!   front side, so F̂_ij = (Σ τ over i's lines whose next front face is j) / (lines
//!   crossing i) estimates the form factor from i to j, without bias (Sbert's global
//!   lines; the transillumination idea of the paper's references [10], [15]). Counts are
//!   summed in fixed point, so the operator does not depend on thread scheduling.
//! * **Glazing reflection.** Glazing also reflects specularly, with Radiance `glass`'s
//!   R(θ) ([`crate::scene::material::glass_reflectance`]). Where a line meets a pane g
//!   and the nearest opaque fragment A on one side faces g, the light A receives along
//!   the line from g includes g's mirror image: the mirror direction is traced from g (a
//!   BVH ray, through further panes with τ) and, at the front face of an opaque C, the
//!   one-way link A ← C gets τ_between · R_g(θ) · τ_after (per line of A, like the
//!   transmitted links). One way only: the reverse path C ← A is the line of the mirrored
//!   bundle direction, which the uniform directions cover in expectation. Second
//!   reflections (R² ≈ 1 %) are left out; the sensor gather adds the mirror image in the
//!   first pane a ray meets. Scenes without glazing are unchanged (no extra work). Direct
//!   light (sun and sky onto surfaces, `src/projection`, `src/sensors.rs`) stays
//!   transmission-only.
//! * **Mesh.** The input triangles, split by midpoint quadtree until each element is at
//!   most `element_area_m2`. The operator does not contain reflectances, emission or
//!   daylight: a change of `Kd`, site or weather reuses it, and the direct irradiance of
//!   any hierarchy is averaged onto the mesh by area.
//! * **Solve.** B = S + ρ ⊙ (F̂ B) with S = ρ E_direct + π Ke, by Gauss–Seidel sweeps
//!   until the residual, extrapolated by the observed contraction, is below `tolerance`
//!   of ‖B‖. The operator is fixed, so a warm start (B_prev + ΔS) accumulates no noise:
//!   only the iteration error, which the stop rule bounds at every step.
//! * **Error.** `parts` independent operators (disjoint direction sets, independent sensor
//!   rays) are solved side by side; a sensor's value is their mean and its 1σ noise the
//!   standard error of the mean over parts. The discretisation of the mesh is estimated
//!   per sensor from the same lines aggregated one level coarser (parent elements):
//!   |fine − coarse|.

use super::lines::{barycentric, cosine_direction, End, Outcome, Tracer};
use super::{child_of, MAX_RHO};
use crate::hierarchy::{ElementKey, Hierarchy, MAX_DEPTH};
use crate::math::rng::{mix64, uniform};
use crate::photometry::{grey, Rgb};
use crate::projection::ldi::Fragment;
use crate::projection::{Ldi, ProjectionScene};
use crate::scene::{Scene, Sensor};
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::time::Instant;

/// Fixed-point scale of transmission sums (τ quantised to 2⁻¹⁶).
const FIX: f64 = 65536.0;

/// Knobs of the global-line operator and its solve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TransportParams {
    /// Largest mesh element, m². Smaller: finer indirect detail, more unknowns and links.
    pub element_area_m2: f64,
    /// Line-bundle directions over all parts.
    pub directions: u32,
    /// LDI pixels across the whole scene's bounding-box diagonal (the same pixel size, so
    /// the same line density, for every bundle).
    pub resolution: u32,
    /// Independent operators (≥ 2) whose spread is the noise estimate.
    pub parts: u32,
    /// Sensor gather rays over all parts.
    pub gather_rays: u32,
    /// Stop sweeping when the extrapolated iteration error is below this fraction of each
    /// row's B (default 1e-3: a tenth of the default noise, measured 1.6 %).
    pub tolerance: f64,
    /// Hard cap on Gauss–Seidel sweeps per solve.
    pub max_sweeps: u32,
    /// Region of interest: the sensors' bounding box grown by this margin, m (the whole
    /// scene when there are no sensors). Elements there are meshed to `element_area_m2`,
    /// elsewhere (a far ground plane, distant blocks) to `far_element_area_m2`; every
    /// element receives interreflection.
    pub margin_m: f64,
    /// Largest mesh element outside the region of interest, m².
    pub far_element_area_m2: f64,
    /// Target number of elements in the region of interest: when the region's area over
    /// `element_area_m2` exceeds it, elements there are made larger.
    pub max_rows: u64,
    /// Seed of the directions and rays.
    pub seed: u64,
}

impl Default for TransportParams {
    fn default() -> Self {
        TransportParams {
            element_area_m2: 0.25,
            directions: 256,
            resolution: 512,
            parts: 4,
            gather_rays: 4096,
            tolerance: 1e-3,
            max_sweeps: 1000,
            margin_m: 6.0,
            far_element_area_m2: 4.0,
            max_rows: 20_000,
            seed: 0x5eed,
        }
    }
}

/// Sparse rows: row r holds (column, value) pairs `cols[offsets[r]..offsets[r+1]]`.
#[derive(Clone, Debug, Default)]
pub(super) struct Sparse {
    pub(super) offsets: Vec<u32>,
    pub(super) cols: Vec<u32>,
    pub(super) vals: Vec<[f32; 3]>,
}

impl Sparse {
    fn row_dot(&self, r: usize, x: &[Rgb]) -> Rgb {
        let (a, b) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
        let mut s = Rgb::ZERO;
        for k in a..b {
            let v = self.vals[k];
            let xj = x[self.cols[k] as usize];
            s += Rgb::new(v[0] as f64 * xj.x, v[1] as f64 * xj.y, v[2] as f64 * xj.z);
        }
        s
    }

    pub(super) fn rows(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Builds rows from (row, col, value) triples sorted by (row, col), no duplicates.
    fn from_sorted(n_rows: usize, entries: impl Iterator<Item = (u32, u32, [f32; 3])>) -> Sparse {
        let mut offsets = vec![0u32; n_rows + 1];
        let mut cols = Vec::new();
        let mut vals = Vec::new();
        for (r, c, v) in entries {
            offsets[r as usize + 1] += 1;
            cols.push(c);
            vals.push(v);
        }
        for r in 0..n_rows {
            offsets[r + 1] += offsets[r];
        }
        Sparse {
            offsets,
            cols,
            vals,
        }
    }

    /// Aggregates columns through `map` (column → coarse column), rows kept.
    fn map_cols(&self, map: &[u32]) -> Sparse {
        let mut entries = Vec::new();
        for r in 0..self.rows() {
            let (a, b) = (self.offsets[r] as usize, self.offsets[r + 1] as usize);
            let row: Vec<(u32, [f32; 3])> = (a..b)
                .map(|k| (map[self.cols[k] as usize], self.vals[k]))
                .collect();
            for (c, v) in merge_columns(row) {
                entries.push((r as u32, c, v));
            }
        }
        Sparse::from_sorted(self.rows(), entries.into_iter())
    }
}

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

/// One independent estimate: the operator (E_i = Σ_j F_ij B_j, W/m² per W/m²) and the
/// sensor gather (E_k = Σ_j G_kj B_j).
#[derive(Clone, Debug, Default)]
pub(super) struct Part {
    pub(super) f: Sparse,
    pub(super) g: Sparse,
    pub(super) f_coarse: Sparse,
    pub(super) g_coarse: Sparse,
}

/// One sparse matrix as flat arrays: row offsets, columns, values (RGB).
pub type SparseArrays = (Vec<u32>, Vec<u32>, Vec<[f32; 3]>);
/// Borrowed [`SparseArrays`].
pub type SparseSlices<'a> = (&'a [u32], &'a [u32], &'a [[f32; 3]]);

/// Counters of an operator build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TransportStats {
    /// Mesh unknowns.
    pub rows: usize,
    /// Lines (pixels × fragments crossings) counted, all parts.
    pub lines: u64,
    /// Non-zero links, all parts.
    pub links: u64,
    /// Sensor rays, all parts.
    pub sensor_rays: u64,
    /// Wall time of the build, s.
    pub seconds: f64,
}

/// The global-line interreflection operator of a scene (geometry and glazing only).
#[derive(Clone, Debug)]
pub struct Transport {
    /// The mesh.
    pub mesh: Mesh,
    pub(super) parts: Vec<Part>,
    /// Reflectance (clamped below 1; 0 for glazing) and exitance π·Ke per row.
    pub(super) rho: Vec<Rgb>,
    pub(super) emit: Vec<Rgb>,
    pub(super) coarse_rho: Vec<Rgb>,
    pub(super) coarse_area: Vec<f64>,
    /// Parameters used.
    pub params: TransportParams,
    /// Build counters.
    pub stats: TransportStats,
}

/// Per part, the radiosity of every row (fine and coarse) and the source it answers.
#[derive(Clone, Debug, Default)]
pub struct TransportState {
    b: Vec<Vec<Rgb>>,
    b_coarse: Vec<Vec<Rgb>>,
    s: Vec<Rgb>,
    s_coarse: Vec<Rgb>,
}

/// What one solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TransportReport {
    /// Gauss–Seidel sweeps, summed over parts and levels.
    pub sweeps: u32,
    /// Extrapolated relative iteration error at the stop (largest over parts).
    pub iteration_error: f64,
    /// True when started from a previous state.
    pub warm: bool,
    /// Wall time, s.
    pub seconds: f64,
}

/// A sensor's indirect irradiance from the transport solution.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TransportSensor {
    /// Mean over parts, RGB W/m².
    pub irradiance: Rgb,
    /// 1σ standard error of the mean over parts, RGB W/m².
    pub std_err: Rgb,
    /// |fine − one level coarser| (mean over parts), RGB W/m².
    pub discretisation: Rgb,
}

impl Transport {
    /// Estimates the operator of `scene` and the gather of `sensors` with global lines.
    /// The mesh and per-row materials of `scene` for `params` (deterministic: the same
    /// inputs give the same rows, which cached operators rely on).
    fn setup(scene: &Scene, sensors: &[Sensor], params: &TransportParams) -> Transport {
        let (lo, hi) = scene.bounds();
        let region = if sensors.is_empty() || scene.triangles.is_empty() {
            (lo, hi)
        } else {
            let m = DVec3::splat(params.margin_m.max(0.0));
            let (a, b) = sensors.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(a, b), s| (a.min(s.position), b.max(s.position)),
            );
            ((a - m).max(lo), (b + m).min(hi))
        };
        // Bound the unknowns (memory and time grow with rows × links): a large region
        // gets coarser elements.
        let area_in_region: f64 = scene
            .triangles
            .iter()
            .filter(|t| {
                let lo = t.v[0].min(t.v[1]).min(t.v[2]);
                let hi = t.v[0].max(t.v[1]).max(t.v[2]);
                lo.cmple(region.1).all() && hi.cmpge(region.0).all()
            })
            .map(|t| t.area())
            .sum();
        let element_area = params
            .element_area_m2
            .max(area_in_region / params.max_rows.max(1) as f64);
        let mesh = Mesh::new(scene, element_area, params.far_element_area_m2, region);
        let rho: Vec<Rgb> = mesh
            .elements
            .iter()
            .map(|&e| {
                let tri = mesh.hierarchy.elements[e as usize].key.tri as usize;
                let m = &scene.materials[scene.triangles[tri].material as usize];
                m.reflectance().clamp(Rgb::ZERO, Rgb::splat(MAX_RHO))
            })
            .collect();
        let emit: Vec<Rgb> = mesh
            .elements
            .iter()
            .map(|&e| {
                let tri = mesh.hierarchy.elements[e as usize].key.tri as usize;
                scene.materials[scene.triangles[tri].material as usize].ke * PI
            })
            .collect();
        let mut coarse_rho = vec![Rgb::ZERO; mesh.coarse_rows];
        let mut coarse_area = vec![0.0; mesh.coarse_rows];
        for (r, &c) in mesh.coarse_of.iter().enumerate() {
            coarse_rho[c as usize] = rho[r];
            coarse_area[c as usize] += mesh.area[r];
        }
        Transport {
            mesh,
            parts: Vec::new(),
            rho,
            emit,
            coarse_rho,
            coarse_area,
            params: *params,
            stats: TransportStats::default(),
        }
    }

    /// Estimates the operator of `scene` and the gather of `sensors` with global lines.
    pub fn build(scene: &Scene, sensors: &[Sensor], params: &TransportParams) -> Transport {
        let t0 = Instant::now();
        let mut t = Transport::setup(scene, sensors, params);
        let parts_n = params.parts.max(2);
        let mesh = &t.mesh;
        let pscene = ProjectionScene::new(scene);
        let tracer = Tracer::new(scene);
        let per = params.directions.div_ceil(parts_n).max(1);
        let gather_per = (params.gather_rays / parts_n).max(16);
        let mut stats = TransportStats {
            rows: mesh.elements.len(),
            ..TransportStats::default()
        };
        let built: Vec<(Part, u64)> = (0..parts_n)
            .into_par_iter()
            .map(|p| {
                let seed = mix64(params.seed ^ mix64(p as u64 + 1));
                let (f, lines) = operator(&pscene, &tracer, mesh, per, params.resolution, seed);
                let g = gather(&tracer, mesh, sensors, gather_per, seed);
                let f_coarse = coarse_operator(&f, mesh);
                let g_coarse = g.map_cols(&mesh.coarse_of);
                (
                    Part {
                        f,
                        g,
                        f_coarse,
                        g_coarse,
                    },
                    lines,
                )
            })
            .collect();
        let mut parts = Vec::new();
        for (p, lines) in built {
            stats.lines += lines;
            stats.links += p.f.cols.len() as u64;
            parts.push(p);
        }
        stats.sensor_rays = gather_per as u64 * sensors.len() as u64 * parts_n as u64;
        stats.seconds = t0.elapsed().as_secs_f64();
        t.parts = parts;
        t.stats = stats;
        t
    }

    /// The operator as flat arrays, for storage: per part, four sparse matrices (fine
    /// operator, fine gather, coarse operator, coarse gather), each as (row offsets,
    /// columns, values RGB).
    pub fn export(&self) -> Vec<[SparseSlices<'_>; 4]> {
        self.parts
            .iter()
            .map(|p| {
                [&p.f, &p.g, &p.f_coarse, &p.g_coarse]
                    .map(|m| (&m.offsets[..], &m.cols[..], &m.vals[..]))
            })
            .collect()
    }

    /// Rebuilds an operator from [`Transport::export`]ed arrays for the same scene, sensors
    /// and parameters; `None` when the arrays do not fit (wrong sizes or indices), so a
    /// stale or foreign record is never used.
    pub fn import(
        scene: &Scene,
        sensors: &[Sensor],
        params: &TransportParams,
        parts: &[[SparseArrays; 4]],
        stats: TransportStats,
    ) -> Option<Transport> {
        let mut t = Transport::setup(scene, sensors, params);
        if parts.len() != params.parts.max(2) as usize {
            return None;
        }
        let rows = t.mesh.elements.len();
        let coarse = t.mesh.coarse_rows;
        // (rows, columns) of each matrix.
        let shape = [
            (rows, rows),
            (sensors.len(), rows),
            (coarse, coarse),
            (sensors.len(), coarse),
        ];
        for p in parts {
            let mut m = p.iter().zip(shape).map(|((o, c, v), (nr, nc))| {
                let ok = o.len() == nr + 1
                    && o.first() == Some(&0)
                    && o.windows(2).all(|w| w[0] <= w[1])
                    && *o.last().unwrap_or(&1) as usize == c.len()
                    && c.len() == v.len()
                    && c.iter().all(|&j| (j as usize) < nc)
                    && v.iter().flatten().all(|x| x.is_finite());
                ok.then(|| Sparse {
                    offsets: o.clone(),
                    cols: c.clone(),
                    vals: v.clone(),
                })
            });
            let (f, g, f_coarse, g_coarse) = (m.next()??, m.next()??, m.next()??, m.next()??);
            t.parts.push(Part {
                f,
                g,
                f_coarse,
                g_coarse,
            });
        }
        t.stats = TransportStats {
            rows,
            seconds: 0.0,
            ..stats
        };
        Some(t)
    }

    /// Solves for the mesh direct irradiance `direct` (RGB W/m² per row, see
    /// [`Mesh::average_onto`]), warm-started from `previous` when given.
    pub fn solve(
        &self,
        direct: &[Rgb],
        previous: Option<&TransportState>,
    ) -> (TransportState, TransportReport) {
        let t0 = Instant::now();
        let s: Vec<Rgb> = direct
            .iter()
            .zip(&self.rho)
            .zip(&self.emit)
            .map(|((e, r), m)| *r * *e + *m)
            .collect();
        let mut s_coarse = vec![Rgb::ZERO; self.mesh.coarse_rows];
        for (r, &c) in self.mesh.coarse_of.iter().enumerate() {
            s_coarse[c as usize] += s[r] * self.mesh.area[r];
        }
        for (c, a) in s_coarse.iter_mut().zip(&self.coarse_area) {
            if *a > 0.0 {
                *c /= *a;
            }
        }
        let warm = previous.is_some_and(|p| p.b.len() == self.parts.len());
        let start = |prev: Option<&Vec<Rgb>>, prev_s: &[Rgb], s: &[Rgb]| -> Vec<Rgb> {
            match prev {
                Some(b) if warm => b
                    .iter()
                    .zip(prev_s)
                    .zip(s)
                    .map(|((b, ps), s)| *b + *s - *ps)
                    .collect(),
                _ => s.to_vec(),
            }
        };
        let tol = self.params.tolerance;
        let max = self.params.max_sweeps;
        let results: Vec<(Vec<Rgb>, Vec<Rgb>, u32, f64)> = self
            .parts
            .par_iter()
            .enumerate()
            .map(|(p, part)| {
                let (pb, pbc) = match previous {
                    Some(st) if warm => (Some(&st.b[p]), Some(&st.b_coarse[p])),
                    _ => (None, None),
                };
                let ps = previous.map_or(&[][..], |st| &st.s[..]);
                let psc = previous.map_or(&[][..], |st| &st.s_coarse[..]);
                let mut b = start(pb, ps, &s);
                let (n1, e1) = gauss_seidel(&part.f, &self.rho, &s, &mut b, tol, max);
                let mut bc = start(pbc, psc, &s_coarse);
                let (n2, e2) = gauss_seidel(
                    &part.f_coarse,
                    &self.coarse_rho,
                    &s_coarse,
                    &mut bc,
                    tol,
                    max,
                );
                (b, bc, n1 + n2, e1.max(e2))
            })
            .collect();
        let mut report = TransportReport {
            warm,
            ..TransportReport::default()
        };
        let mut state = TransportState {
            s,
            s_coarse,
            ..TransportState::default()
        };
        for (b, bc, n, e) in results {
            report.sweeps += n;
            report.iteration_error = report.iteration_error.max(e);
            state.b.push(b);
            state.b_coarse.push(bc);
        }
        report.seconds = t0.elapsed().as_secs_f64();
        (state, report)
    }

    /// Radiosity of mesh row `r` (mean over parts), RGB W/m².
    pub fn radiosity(&self, state: &TransportState, r: usize) -> Rgb {
        state.b.iter().map(|b| b[r]).fold(Rgb::ZERO, |a, x| a + x) / state.b.len() as f64
    }

    /// Indirect irradiance received by mesh row `r` (mean over parts), RGB W/m².
    pub fn indirect_irradiance(&self, state: &TransportState, r: usize) -> Rgb {
        self.parts
            .iter()
            .zip(&state.b)
            .map(|(p, b)| p.f.row_dot(r, b))
            .fold(Rgb::ZERO, |a, x| a + x)
            / self.parts.len() as f64
    }

    /// Number of mesh rows (unknowns).
    pub fn rows(&self) -> usize {
        self.mesh.elements.len()
    }

    /// Indirect irradiance at every sensor given to [`Transport::build`], in order.
    pub fn sensors(&self, state: &TransportState) -> Vec<TransportSensor> {
        let k = self.parts.first().map_or(0, |p| p.g.rows());
        let n = self.parts.len() as f64;
        (0..k)
            .map(|s| {
                let fine: Vec<Rgb> = self
                    .parts
                    .iter()
                    .zip(&state.b)
                    .map(|(p, b)| p.g.row_dot(s, b))
                    .collect();
                let coarse: Rgb = self
                    .parts
                    .iter()
                    .zip(&state.b_coarse)
                    .map(|(p, b)| p.g_coarse.row_dot(s, b))
                    .fold(Rgb::ZERO, |a, x| a + x)
                    / n;
                TransportSensor::from_parts(&fine, coarse)
            })
            .collect()
    }
}

impl TransportSensor {
    /// A sensor's estimate from its per-part fine values and the mean coarse value: mean,
    /// standard error of the mean over parts, |mean − coarse|.
    pub(super) fn from_parts(fine: &[Rgb], coarse: Rgb) -> TransportSensor {
        let n = fine.len() as f64;
        let mean = fine.iter().fold(Rgb::ZERO, |a, x| a + *x) / n;
        let var = fine
            .iter()
            .fold(Rgb::ZERO, |a, x| a + (*x - mean) * (*x - mean))
            / (n - 1.0)
            / n;
        TransportSensor {
            irradiance: mean,
            std_err: super::sqrt3(var),
            discretisation: (mean - coarse).abs(),
        }
    }
}

/// Gauss–Seidel sweeps of B = S + ρ ⊙ (F B) in row order from the given `b`; returns the
/// sweeps done and the extrapolated relative error at the stop.
fn gauss_seidel(
    f: &Sparse,
    rho: &[Rgb],
    s: &[Rgb],
    b: &mut [Rgb],
    tol: f64,
    max_sweeps: u32,
) -> (u32, f64) {
    let s_max = s.iter().map(|x| grey(x.abs())).fold(0.0, f64::max);
    if s_max == 0.0 {
        b.iter_mut().for_each(|x| *x = Rgb::ZERO);
        return (0, 0.0);
    }
    // Relative to each row's own radiosity (a dim room beside a bright outdoor ground
    // must converge too), with a floor far below anything a sensor can read.
    let floor = 1e-6 * s_max;
    let mut prev_change = f64::INFINITY;
    let mut err = f64::INFINITY;
    for sweep in 1..=max_sweeps {
        let mut change = 0.0f64;
        for r in 0..b.len() {
            let new = s[r] + rho[r] * f.row_dot(r, b);
            let d = grey((new - b[r]).abs()) / grey(new.abs()).max(floor);
            change = change.max(d);
            b[r] = new;
        }
        // The change per sweep shrinks geometrically by q; the error left is about
        // change·q/(1 − q).
        let q = if prev_change.is_finite() && prev_change > 0.0 {
            (change / prev_change).clamp(0.5, 0.999)
        } else {
            rho.iter().map(|r| r.max_element()).fold(0.5, f64::max)
        };
        prev_change = change;
        err = change * q / (1.0 - q);
        if err <= tol {
            return (sweep, err);
        }
    }
    (max_sweeps, err)
}

/// Sorts one row's (column, value) entries and sums the values of equal columns.
fn merge_columns<T: Copy + std::ops::AddAssign>(mut row: Vec<(u32, [T; 3])>) -> Vec<(u32, [T; 3])> {
    row.sort_by_key(|e| e.0);
    let mut out: Vec<(u32, [T; 3])> = Vec::with_capacity(row.len());
    for (c, v) in row {
        match out.last_mut() {
            Some((lc, lv)) if *lc == c => {
                for (a, b) in lv.iter_mut().zip(v) {
                    *a += b;
                }
            }
            _ => out.push((c, v)),
        }
    }
    out
}

/// The coarse operator: rows of the same parent merged (area-weighted), columns summed.
fn coarse_operator(f: &Sparse, mesh: &Mesh) -> Sparse {
    let cols = f.map_cols(&mesh.coarse_of);
    let mut rows: Vec<Vec<(u32, [f64; 3])>> = vec![Vec::new(); mesh.coarse_rows];
    let mut area = vec![0.0; mesh.coarse_rows];
    for (r, &c) in mesh.coarse_of.iter().enumerate() {
        area[c as usize] += mesh.area[r];
    }
    for (r, &c) in mesh.coarse_of.iter().enumerate() {
        let w = mesh.area[r] / area[c as usize].max(1e-300);
        let (a, b) = (cols.offsets[r] as usize, cols.offsets[r + 1] as usize);
        for k in a..b {
            let v = cols.vals[k];
            rows[c as usize].push((
                cols.cols[k],
                [v[0] as f64 * w, v[1] as f64 * w, v[2] as f64 * w],
            ));
        }
    }
    let mut entries = Vec::new();
    for (r, row) in rows.into_iter().enumerate() {
        for (c, v) in merge_columns(row) {
            entries.push((r as u32, c, v.map(|x| x as f32)));
        }
    }
    Sparse::from_sorted(mesh.coarse_rows, entries.into_iter())
}

/// Direction `m` of `n` stratified uniformly on the upper hemisphere (a line and its
/// reverse are the same bundle), jittered by `seed`. The unit square (u1 → cos θ, u2 → φ)
/// is cut into `n` cells of equal area, one direction each: ⌈n/k⌉ rows (k = ⌈√n⌉), each
/// row as tall as its share of the cells and split into that many columns. A plain k × rows
/// grid with its last row only partly used left a sector of azimuths without its steep
/// directions whenever n is not a product k·rows (8 192 directions in 4 parts: 2 048 of
/// 2 070 cells), which biased the operator (README, presets).
fn bundle_direction(m: u32, n: u32, seed: u64) -> DVec3 {
    let (lo, size) = stratum(m, n);
    let u1 = lo[0] + size[0] * uniform(seed, 11, 2 * m as u64);
    let u2 = lo[1] + size[1] * uniform(seed, 11, 2 * m as u64 + 1);
    let z = u1.clamp(1e-6, 1.0);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Cell `m` of `n` equal-area cells tiling the unit square: (lower corner, size).
fn stratum(m: u32, n: u32) -> ([f64; 2], [f64; 2]) {
    let n = n.max(1);
    let k = (n as f64).sqrt().ceil() as u32;
    let rows = n.div_ceil(k);
    // The first `extra` rows have base + 1 cells, the others base.
    let (base, extra) = (n / rows, n % rows);
    let long = extra * (base + 1);
    let (i, cells, start) = if m < long {
        (m % (base + 1), base + 1, (m / (base + 1)) * (base + 1))
    } else {
        let j = (m - long) / base;
        ((m - long) % base, base, long + j * base)
    };
    (
        [i as f64 / cells as f64, start as f64 / n as f64],
        [1.0 / cells as f64, cells as f64 / n as f64],
    )
}

/// One operator from `n_dirs` bundles: counts of lines per row and fixed-point
/// transmission sums per (row, row) pair, normalised to F̂.
fn operator(
    pscene: &ProjectionScene,
    tracer: &Tracer,
    mesh: &Mesh,
    n_dirs: u32,
    resolution: u32,
    seed: u64,
) -> (Sparse, u64) {
    let rows = mesh.elements.len();
    // One pixel size for every direction (uniform line density): the bounding sphere's
    // diameter over `resolution`.
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
    let pixel = diameter.max(1e-9) / resolution.max(1) as f64;
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

/// The specular reflection of glazing in the global-line operator.
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
        let t = g.tri as usize;
        let n = self.pscene.normals[t];
        let c = u.dot(n);
        let r = self.pscene.materials[self.pscene.material[t] as usize].specular_reflectance(c);
        let w = between * r;
        if w == Rgb::ZERO {
            return;
        }
        // The point on the pane's plane, in f64: the fragment's f32 height could leave it
        // on the far side, and the mirror ray would then cross the pane. (A line in the
        // pane's plane, c = 0, is of measure zero.)
        if c.abs() < 1e-12 {
            return;
        }
        let origin = base + u * ((self.pscene.vertices[t][0] - base).dot(n) / c);
        let dir = (n * (2.0 * c) - u).normalize();
        let out = self.tracer.trace(origin, dir, w);
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

/// The sensor gather: `rays` jittered-stratified cosine rays per sensor; a ray through
/// glazing keeps τ(θ); one reaching a front face adds τ/rays to G[sensor, row]. At the
/// first pane a ray meets (only the first: second reflections, R² ≈ 1 %, are left out) the
/// mirror direction is traced too, with weight R(θ), and adds R·τ_after/rays where it
/// reaches a front face.
fn gather(tracer: &Tracer, mesh: &Mesh, sensors: &[Sensor], rays: u32, seed: u64) -> Sparse {
    let m = (rays as f64).sqrt().ceil() as u64;
    let per: Vec<Vec<(u32, [f32; 3])>> = sensors
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let stream = mix64(seed ^ (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut acc: std::collections::BTreeMap<u32, Rgb> = Default::default();
            let n = s.normal.normalize();
            for i in 0..m {
                for j in 0..m {
                    let idx = i * m + j;
                    let u1 = (i as f64 + uniform(seed, stream, 2 * idx)) / m as f64;
                    let u2 = (j as f64 + uniform(seed, stream, 2 * idx + 1)) / m as f64;
                    let (d, _) = cosine_direction(n, u1, u2);
                    let mut add = |out: Outcome| {
                        if let End::Front { tri, point, .. } = out.end {
                            let root = mesh.hierarchy.elements[tri as usize].vertices;
                            let row = mesh.row_at(tri, barycentric(root, point));
                            *acc.entry(row).or_default() += out.power;
                        }
                    };
                    let out = tracer.trace(s.position, d, Rgb::ONE);
                    // Only a ray that met glazing (every pane loses something: Fresnel)
                    // looks for the mirror image in the first pane it met.
                    let met_glazing = out.glazing_loss != Rgb::ZERO;
                    add(out);
                    if let Some(h) = met_glazing
                        .then(|| tracer.first_hit(s.position, d))
                        .flatten()
                    {
                        if h.glazing {
                            let n = tracer.normal(h.tri);
                            let r = tracer.material_of(h.tri).specular_reflectance(h.cos);
                            let dir = (d - n * (2.0 * d.dot(n))).normalize();
                            add(tracer.trace(h.point, dir, r));
                        }
                    }
                }
            }
            let w = 1.0 / (m * m) as f64;
            acc.into_iter()
                .map(|(r, t)| (r, [(t.x * w) as f32, (t.y * w) as f32, (t.z * w) as f32]))
                .collect()
        })
        .collect();
    let entries = per
        .into_iter()
        .enumerate()
        .flat_map(|(k, row)| row.into_iter().map(move |(c, v)| (k as u32, c, v)));
    Sparse::from_sorted(sensors.len(), entries)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundle_directions_cover_the_hemisphere_uniformly() {
        // Uniform on the hemisphere: E[z] = 1/2, E[z²] = 1/3.
        let n = 400;
        let (mut s1, mut s2) = (0.0, 0.0);
        for m in 0..n {
            let d = bundle_direction(m, n, 9);
            assert!((d.length() - 1.0).abs() < 1e-12 && d.z > 0.0);
            s1 += d.z;
            s2 += d.z * d.z;
        }
        assert!((s1 / n as f64 - 0.5).abs() < 0.01);
        assert!((s2 / n as f64 - 1.0 / 3.0).abs() < 0.01);
    }

    #[test]
    fn direction_strata_tile_the_square_for_any_count() {
        // Each bundle direction is uniform in its own stratum, so the set is unbiased only
        // if the strata tile (cos θ, φ/2π) ∈ [0, 1)² with equal areas, for every n (not just
        // squares: 8 192 directions in 4 parts is 2 048 per part).
        for n in [1u32, 2, 7, 17, 257, 1000, 2048, 3001] {
            let cells: Vec<([f64; 2], [f64; 2])> = (0..n).map(|m| stratum(m, n)).collect();
            for (_, size) in &cells {
                assert!(
                    (size[0] * size[1] - 1.0 / n as f64).abs() < 1e-12,
                    "n = {n}"
                );
            }
            let g = 97;
            for a in 0..g {
                for b in 0..g {
                    let p = [(a as f64 + 0.5) / g as f64, (b as f64 + 0.5) / g as f64];
                    let owners = cells
                        .iter()
                        .filter(|(lo, size)| {
                            (0..2).all(|c| p[c] >= lo[c] && p[c] < lo[c] + size[c])
                        })
                        .count();
                    assert_eq!(owners, 1, "n = {n}: point {p:?} in {owners} strata");
                }
            }
        }
    }
}
