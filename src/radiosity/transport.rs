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
//!   lines; the transillumination idea of the paper's references \[10\], \[15\]). Counts are
//!   summed in fixed point, so the operator does not depend on thread scheduling
//!   (`bundles.rs`; the directions are equal-area strata, `strata.rs`).
//! * **Glazing reflection.** Glazing also reflects specularly, with Radiance `glass`'s
//!   R(θ) ([`crate::scene::material::glass_reflectance`]). Where a line meets a pane g
//!   and the nearest opaque fragment A on one side faces g, the light A receives along
//!   the line from g includes g's mirror image: the mirror direction is traced from g
//!   ([`Tracer::mirror`], through further panes with τ) and, at the front face of an opaque C, the
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
//!   any hierarchy is averaged onto the mesh by area (`mesh.rs`).
//! * **Solve.** B = S + ρ ⊙ (F̂ B) with S = ρ E_direct + π Ke, by Gauss–Seidel sweeps
//!   until the residual, extrapolated by the observed contraction, is below `tolerance`
//!   of ‖B‖. The operator is fixed, so a warm start (B_prev + ΔS) accumulates no noise:
//!   only the iteration error, which the stop rule bounds at every step (`solve.rs`).
//! * **Error.** `parts` independent operators (disjoint direction sets, independent sensor
//!   rays, `gather.rs`) are solved side by side; a sensor's value is their mean and its 1σ noise the
//!   standard error of the mean over parts. The discretisation of the mesh is estimated
//!   per sensor from the same lines aggregated one level coarser (parent elements,
//!   `coarse.rs`): |fine − coarse|.
//!
//! This file holds the [`Transport`] type, its parameters and build; the sparse matrices
//! are `sparse.rs`, the adjoint daylight coefficients [`super::response`].

use super::bundles::operator;
use super::coarse::coarse_operator;
use super::gather::gather;
use super::mesh::Mesh;
use super::sparse::Sparse;
use super::MAX_RHO;
use crate::math::rng::mix64;
use crate::photometry::{ChannelValues, Rgb};
use crate::projection::ProjectionScene;
use crate::scene::{Scene, Sensor};
use crate::trace::Tracer;
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::time::Instant;

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

/// Area (m²) of triangle `v` inside the box `region`, to within the elements of a
/// 12-level midpoint split of the triangles that cross its boundary.
fn area_within(v: [DVec3; 3], region: (DVec3, DVec3), depth: u32) -> f64 {
    let lo = v[0].min(v[1]).min(v[2]);
    let hi = v[0].max(v[1]).max(v[2]);
    let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
    if lo.cmpgt(region.1).any() || hi.cmplt(region.0).any() {
        0.0
    } else if (lo.cmpge(region.0) & hi.cmple(region.1)).all() || depth >= 12 {
        area
    } else {
        crate::hierarchy::split(v)
            .into_iter()
            .map(|c| area_within(c, region, depth + 1))
            .sum()
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

/// One sparse matrix as flat arrays: row offsets, columns, values (one per column when
/// the matrix is grey, else three: R, G, B).
pub type SparseArrays = (Vec<u32>, Vec<u32>, Vec<f32>);
/// Borrowed [`SparseArrays`].
pub type SparseSlices<'a> = (&'a [u32], &'a [u32], &'a [f32]);

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

impl Transport {
    /// The mesh and per-row materials of `scene` for `params` (deterministic: the same
    /// inputs give the same rows, which cached operators rely on).
    fn setup(scene: &Scene, sensors: &[Sensor], params: &TransportParams) -> Transport {
        let region = crate::scene::region_around(sensors, scene.bounds(), params.margin_m);
        // Bound the unknowns (memory and time grow with rows × links): a large region
        // gets coarser elements. Only the part of each triangle inside the region counts: a
        // site's ground plane or a large emitter crossing it must not coarsen the room.
        let area_in_region: f64 = scene
            .triangles
            .iter()
            .map(|t| area_within(t.v, region, 0))
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

    /// Estimates the operator of `scene` and the gather of `sensors` with global lines,
    /// tracing through its own [`Tracer`] (a run shares one: [`Transport::build_with`]).
    pub fn build(scene: &Scene, sensors: &[Sensor], params: &TransportParams) -> Transport {
        Transport::build_with(scene, sensors, params, &Tracer::new(scene))
    }

    /// [`Transport::build`] through `tracer`, the run's ray caster over `scene`'s triangles.
    pub fn build_with(
        scene: &Scene,
        sensors: &[Sensor],
        params: &TransportParams,
        tracer: &Tracer,
    ) -> Transport {
        let t0 = Instant::now();
        let mut t = Transport::setup(scene, sensors, params);
        let parts_n = params.parts.max(2);
        let mesh = &t.mesh;
        let pscene = ProjectionScene::new(scene);
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
                let (f, lines) = operator(&pscene, tracer, mesh, per, params.resolution, seed);
                let g = gather(tracer, mesh, sensors, gather_per, seed);
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
    /// columns, values: one per column when grey, else R, G, B).
    pub fn export(&self) -> Vec<[SparseSlices<'_>; 4]> {
        self.parts
            .iter()
            .map(|p| {
                [&p.f, &p.g, &p.f_coarse, &p.g_coarse]
                    .map(|m| (&m.offsets[..], &m.cols[..], m.vals.as_slice()))
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
                // Grey matrices hold one value per column, others three.
                let vals = ChannelValues::from_raw(v.clone(), c.len())?;
                let ok = o.len() == nr + 1
                    && o.first() == Some(&0)
                    && o.windows(2).all(|w| w[0] <= w[1])
                    && *o.last().unwrap_or(&1) as usize == c.len()
                    && c.iter().all(|&j| (j as usize) < nc)
                    && v.iter().all(|x| x.is_finite());
                ok.then(|| Sparse {
                    offsets: o.clone(),
                    cols: c.clone(),
                    vals,
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

    /// Number of mesh rows (unknowns).
    pub fn rows(&self) -> usize {
        self.mesh.elements.len()
    }
}
