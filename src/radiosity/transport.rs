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
use super::sparse::{Buf, Sparse};
use super::MAX_RHO;
use crate::math::rng::mix64;
use crate::photometry::Rgb;
use crate::projection::ProjectionScene;
use crate::scene::{Scene, Sensor};
use crate::trace::Tracer;
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::sync::Arc;
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

impl Part {
    /// Its four matrices: operator and gather, fine then coarse.
    pub(super) fn matrices(&self) -> [&Sparse; 4] {
        [&self.f, &self.g, &self.f_coarse, &self.g_coarse]
    }
}

/// One independent part of an operator as built or read ([`Transport::build_part`],
/// [`Transport::import_part`]): what a cache stores and reads on its own.
#[derive(Debug)]
pub struct TransportPart {
    part: Part,
    lines: u64,
}

impl TransportPart {
    /// Its four matrices as flat arrays ([`Transport::export`]'s entry for one part).
    pub fn export(&self) -> [SparseSlices<'_>; 4] {
        export_part(&self.part)
    }

    /// Lines counted (pixels × fragment crossings).
    pub fn lines(&self) -> u64 {
        self.lines
    }

    /// Gives back the pages of its arrays read in place from a record
    /// ([`Transport::release_pages`]).
    pub fn release_pages(&self) {
        release_parts(std::slice::from_ref(&self.part));
    }
}

fn export_part(p: &Part) -> [SparseSlices<'_>; 4] {
    p.matrices()
        .map(|m| (&m.offsets[..], &m.cols[..], &m.vals[..]))
}

/// Gives back the pages of `parts`' arrays read in place, each record once.
fn release_parts(parts: &[Part]) {
    let mut seen: Vec<*const crate::cache::MappedRecord> = Vec::new();
    for p in parts {
        for m in p.matrices() {
            for r in [m.offsets.record(), m.cols.record()]
                .into_iter()
                .chain([m.vals.record()])
                .flatten()
            {
                if !seen.contains(&Arc::as_ptr(r)) {
                    seen.push(Arc::as_ptr(r));
                    r.release();
                }
            }
        }
    }
}

/// One stored sparse matrix's arrays: row offsets, columns, values (one per column when
/// the matrix is grey, else three: R, G, B), held or read in place from a record.
pub type SparseBufs = (Buf<u32>, Buf<u32>, Buf<f32>);
/// Borrowed [`SparseBufs`].
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
    /// Sensors the gather reads.
    sensor_count: usize,
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
            sensor_count: sensors.len(),
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
        let mut t = Transport::shell(scene, sensors, params);
        let parts: Vec<TransportPart> = (0..t.part_count())
            .into_par_iter()
            .map(|p| t.build_part(scene, sensors, tracer, p))
            .collect();
        t.set_parts(parts, t0.elapsed().as_secs_f64());
        t
    }

    /// The operator's mesh and per-row materials for `scene`, `sensors` and `params`,
    /// without its parts: what [`Transport::build_part`] and [`Transport::import_part`]
    /// make parts for, and [`Transport::set_parts`] completes.
    pub fn shell(scene: &Scene, sensors: &[Sensor], params: &TransportParams) -> Transport {
        let mut t = Transport::setup(scene, sensors, params);
        t.stats.rows = t.rows();
        t
    }

    /// Number of independent parts (`params.parts`, at least 2).
    pub fn part_count(&self) -> usize {
        self.params.parts.max(2) as usize
    }

    /// Estimates part `p` on this operator's mesh (its own seed: the same part whether
    /// built alone or beside the others): the line operator and the gather of `sensors`,
    /// each at the fine and the coarse level.
    pub fn build_part(
        &self,
        scene: &Scene,
        sensors: &[Sensor],
        tracer: &Tracer,
        p: usize,
    ) -> TransportPart {
        let params = &self.params;
        let parts_n = params.parts.max(2);
        let mesh = &self.mesh;
        let pscene = ProjectionScene::new(scene);
        let per = params.directions.div_ceil(parts_n).max(1);
        let gather_per = (params.gather_rays / parts_n).max(16);
        let seed = mix64(params.seed ^ mix64(p as u64 + 1));
        let (f, lines) = operator(&pscene, tracer, mesh, per, params.resolution, seed);
        let g = gather(tracer, mesh, sensors, gather_per, seed);
        let f_coarse = coarse_operator(&f, mesh);
        let g_coarse = g.map_cols(&mesh.coarse_of);
        TransportPart {
            part: Part {
                f,
                g,
                f_coarse,
                g_coarse,
            },
            lines,
        }
    }

    /// Completes the operator with its parts, in part order, and the build's wall time
    /// (s) for its counters.
    pub fn set_parts(&mut self, parts: Vec<TransportPart>, seconds: f64) {
        let parts_n = self.part_count() as u64;
        let gather_per = (self.params.gather_rays as u64 / parts_n).max(16);
        self.stats = TransportStats {
            rows: self.rows(),
            lines: parts.iter().map(|p| p.lines).sum(),
            links: parts.iter().map(|p| p.part.f.cols.len() as u64).sum(),
            sensor_rays: gather_per * self.sensor_count as u64 * parts_n,
            seconds,
        };
        self.parts = parts.into_iter().map(|p| p.part).collect();
    }

    /// The operator as flat arrays, for storage: per part, four sparse matrices (fine
    /// operator, fine gather, coarse operator, coarse gather), each as (row offsets,
    /// columns, values: one per column when grey, else R, G, B).
    pub fn export(&self) -> Vec<[SparseSlices<'_>; 4]> {
        self.parts.iter().map(export_part).collect()
    }

    /// A part from [`TransportPart::export`]ed arrays (held, or read in place from the
    /// record they were stored in) for this operator's mesh and sensors, with its line
    /// count; `None` when the arrays do not fit (wrong sizes or indices), so a stale or
    /// foreign record is never used.
    pub fn import_part(&self, arrays: [SparseBufs; 4], lines: u64) -> Option<TransportPart> {
        let rows = self.rows();
        let coarse = self.mesh.coarse_rows;
        let sensors = self.sensor_count;
        // (rows, columns) of each matrix.
        let shape = [
            (rows, rows),
            (sensors, rows),
            (coarse, coarse),
            (sensors, coarse),
        ];
        let mut m = arrays
            .into_iter()
            .zip(shape)
            .map(|((o, c, v), s)| Sparse::from_parts(o, c, v, s));
        let (f, g, f_coarse, g_coarse) = (m.next()??, m.next()??, m.next()??, m.next()??);
        Some(TransportPart {
            part: Part {
                f,
                g,
                f_coarse,
                g_coarse,
            },
            lines,
        })
    }

    /// Gives the pages of the arrays read in place from a cache record back to the kernel
    /// ([`crate::cache::MappedRecord::release`]): a stage calls it when done with a part,
    /// so that the operator is not resident as a whole. Values are unchanged; held
    /// arrays are untouched.
    pub fn release_pages(&self) {
        release_parts(&self.parts);
    }

    /// Number of mesh rows (unknowns).
    pub fn rows(&self) -> usize {
        self.mesh.elements.len()
    }
}
