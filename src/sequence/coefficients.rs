//! Stage 5 of annual steps by daylight coefficients: everything after the sky is linear in
//! its radiance, and the sources are nodes of a tree fixed in the world frame, so each
//! node's light at every sensor (direct, and interreflected through the global-line
//! operator) is computed once per geometry and materials, cached, and a step's sensor
//! values become sums over the step's adaptive cut of the node's radiance × its
//! coefficients. The cut, its accuracy and its error terms are those of a forward step;
//! only the arithmetic moves.
//!
//! * **Sky and ground nodes.** Per node and sensor: the direct response of each of the
//!   node's four children (lux per W·sr⁻¹·m⁻² of the child's radiance), their sum and
//!   their visibility uncertainties (from the cached direction record), and the
//!   interreflected illuminance per W/m² of normal irradiance in each independent part
//!   and one mesh level coarser ([`Transport::grey_coefficients`]). A step's noise and
//!   discretisation estimates come from the same coefficients (their spread over parts,
//!   and the coarse level), not from extra solves.
//! * **The sun.** Its direct light stays exact: the sensors' cached visibility of the
//!   step's snapped sun cell, with glazing τ at the true angle. Its interreflected light
//!   is interpolated bilinearly between the coefficients of the four vertices of the
//!   [`SunGrid`] cell around the true direction. The interpolation error is stated as
//!   the largest difference between the interpolated value and a corner's value, per
//!   sensor, and added to `lux_err`: the true value of a function monotone across the
//!   cell lies within its corners' range.
//! * **Deep nodes.** A node deeper than [`super::config::Quality::indirect_depth`]
//!   takes its ancestor's interreflected coefficients, with a first-order error stated
//!   ([`indirect_ancestors`]); its direct rows are its own.
//! * **Grey.** Coefficients are illuminance, exact for grey sources (Perez skies, their
//!   ground glow and the sun, which is what annual runs use).
//! * **Cache.** A node's interreflected coefficients are a record keyed by the node, the
//!   operator's key, every triangle's reflectance and emission and the directions' hash: a
//!   reflectance change recomputes them and reuses the projections and the operator; a
//!   weather or site change reuses everything.

use super::directions::Directions;
use super::estimate::SensorValue;
use crate::cache::FIRST_USER_TAG;
use crate::photometry::{from_lux, lux, Rgb};
use crate::radiosity::{Buf, TransportSensor};
use crate::sensors::SensorDirect;
use crate::sources::{Source, SourceKey, SunGrid};
use serde::Serialize;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Section tag of a coefficient record: (parts + 1) × sensors f32.
const TAG_VALUES: u32 = FIRST_USER_TAG;
/// Section tag of a sky or ground node's direct rows ([`DIRECT_ROWS`] × sensors f32), a
/// copy of what its direction record yields: a warm run then reads no direction record
/// (a large scene's projection leaves are megabytes each).
const TAG_DIRECT: u32 = FIRST_USER_TAG + 1;
/// Version of what a coefficient record holds, hashed into its key (5: made from
/// direction records of [`super::directions::DIRECTIONS_VERSION`] 2).
const COEFFICIENTS_VERSION: u32 = 5;
/// Direct rows per node: 4 child responses, their sum, 4 uncertainties.
const DIRECT_ROWS: usize = 9;
/// Adjoint responses held at once without a memory cap, bytes: beyond it, larger blocks
/// save little time, since the later blocks read the first one's source terms
/// ([`spill`]) rather than make them again. 128 MB of bfloat16 responses hold as many
/// sensors as 256 MB did in f32.
pub const RESPONSE_MAX_BYTES: u64 = 128 << 20;
/// Days summed between two givings-back of the coefficients' pages
/// ([`Coefficients::day_done`]). Neighbouring days use mostly the same nodes, so a
/// fortnight holds little more than a day; given back after every day, the warm
/// building year spent 10 s in the kernel (madvise and page faults) against 0.8 s.
const RELEASE_DAYS: usize = 16;
/// Directions whose source terms are held at once while coefficients are computed, and
/// applied together ([`crate::radiosity::AdjointBlock::apply_many`]): a few megabytes of
/// terms each on the generated building, and the block's responses read once per batch.
/// 32 rather than 64: the batch's terms (held twice, as made and regrouped by row) were
/// the first block's largest transient; on the corridor building (162 sensors) the cold
/// year's peak fell by 12–16 MB, at 1.01–1.02× the time there and on building-10k (whose
/// peak is its held responses and did not move); 16 took no less memory and more time.
const BATCH: usize = 32;

/// One node's per-sensor data, rows of `sensors` f32 each, held or read in place from
/// its cache record ([`Buf`]: the steps then keep resident only what recent days read,
/// [`Coefficients::release_pages`]).
#[derive(Clone, Debug, Default)]
struct NodeData {
    /// [`DIRECT_ROWS`] rows (empty for sun-grid vertices).
    direct: Buf<f32>,
    /// parts rows of fine interreflected lux per W/m², then the coarse mean; shared by
    /// the nodes that take them from one ancestor ([`indirect_ancestors`]).
    indirect: Arc<Buf<f32>>,
    /// For a node whose interreflected rows are an ancestor's, their stated error per
    /// sensor, lux per W/m² ([`indirect_ancestors`]); empty otherwise.
    direction_err: Vec<f32>,
}

#[path = "cut_batch.rs"]
mod cut_batch;
#[path = "coefficient_budget.rs"]
mod budget;
#[path = "ground_sum.rs"]
mod ground_sum;
#[path = "indirect_ancestors.rs"]
mod indirect_ancestors;
#[path = "coefficient_sums.rs"]
mod sums;
#[path = "coefficient_prepare.rs"]
mod prepare;
#[path = "terms_spill.rs"]
mod spill;
#[path = "coefficient_scratch.rs"]
mod scratch;
pub use budget::adjoint_budget;
pub(super) use cut_batch::CutBatch;
pub(super) use prepare::Watch;
use prepare::{mapped_rows, record_key};
use sums::axpy;

/// What preparing the coefficients did (`report.json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CoefficientStats {
    /// Whether the union of the steps' cuts (which nodes they use) came from the cache
    /// ([`super::cuts`]) rather than from a cut of every step.
    pub cuts_from_cache: bool,
    /// Days whose steps' cuts were read from the cache ([`super::day_cuts`]) rather than
    /// made from their skies.
    pub cut_days_from_cache: usize,
    /// Sky and ground nodes the run's steps use.
    pub nodes: usize,
    /// Sun-grid vertices the site's sun visits.
    pub sun_grid_vertices: usize,
    /// Sky and ground nodes whose interreflected coefficients are their ancestor's at
    /// [`super::config::Quality::indirect_depth`] (their direct light is their own).
    pub indirect_from_ancestors: usize,
    /// Nodes and vertices whose interreflected coefficients were computed now (the
    /// ancestors among them).
    pub computed: usize,
    /// ... read from the cache.
    pub from_cache: usize,
    /// Sensors per adjoint block (the memory budget's choice).
    pub block_sensors: usize,
    /// Gauss–Seidel sweeps of the adjoint solves.
    pub sweeps: u64,
    /// Bytes of source terms the first sensor block wrote to a scratch file for the later
    /// blocks to read (0: one block, or the file could not be used).
    pub spilled_bytes: u64,
    /// Bytes the coefficients take, held or read in place.
    pub bytes: u64,
    /// Whether their rows are read in place from the cache's records (memory-mapped, their
    /// pages given back every few days) rather than held: where they are large, or under
    /// a cap the user set.
    pub in_place: bool,
    /// Sun-grid spacing, degrees.
    pub sun_grid_deg: f64,
    /// Whether the interreflection operator had to be read or built (only when some
    /// coefficients were missing).
    pub operator_needed: bool,
    /// Wall time of the preparation, s.
    pub seconds: f64,
}

/// The daylight coefficients of a run's steps (see the module doc).
pub struct Coefficients {
    sensors: usize,
    parts: usize,
    grid: SunGrid,
    nodes: HashMap<SourceKey, NodeData, ahash::RandomState>,
    /// Coarser level's nodes: 4 rows of child responses.
    coarse: Mutex<HashMap<SourceKey, std::sync::Arc<Vec<f32>>, ahash::RandomState>>,
    /// The uniform ground's nodes summed, per ground cut.
    ground: ground_sum::GroundMemo,
    /// The cache records the nodes' rows are read from in place, each once.
    records: Vec<Arc<crate::cache::MappedRecord>>,
    /// Days summed since the pages were last given back ([`Self::day_done`]).
    days: std::sync::atomic::AtomicUsize,
    /// Preparation counters.
    pub stats: CoefficientStats,
}

/// One step's cuts and direct sun, for [`Coefficients::evaluate`].
pub(super) struct StepCuts<'a> {
    /// The step's sources at the run's quality.
    pub fine: &'a [Source],
    /// ... and one level coarser (the error estimate's).
    pub coarse: &'a [Source],
    /// Each sensor's direct sun at the run's quality, lux.
    pub sun_fine: &'a [f64],
    /// Each sensor's direct sun one level coarser, lux.
    pub sun_coarse: &'a [f64],
}

/// A step `j`'s use of the node `src`, with its weights, for [`sums::sort_uses`].
fn use_of(j: usize, src: &Source) -> (SourceKey, usize, (&Source, sums::Weights)) {
    (src.key, j, (src, sums::Weights::of(src)))
}

/// The grey value of a grey RGB quantity.
fn g(v: Rgb) -> f32 {
    debug_assert!(
        (v.x - v.y).abs() <= 1e-9 * v.x.abs().max(1e-300)
            && (v.x - v.z).abs() <= 1e-9 * v.x.abs().max(1e-300),
        "daylight coefficients need grey sources: {v:?}"
    );
    v.y as f32
}

/// Direct rows of a node from its cached sensor responses.
fn direct_rows(resp: &[crate::sensors::NodeResponse], k: usize) -> Vec<f32> {
    let mut d = vec![0f32; DIRECT_ROWS * k];
    for (s, r) in resp.iter().enumerate() {
        let mut sum = 0.0;
        for c in 0..4 {
            let l = lux(r.child[c]);
            d[c * k + s] = l as f32;
            sum += l;
            d[(5 + c) * k + s] = (lux(Rgb::ONE) * r.uncertainty[c]) as f32;
        }
        d[4 * k + s] = sum as f32;
    }
    d
}

impl Coefficients {
    /// Sensor values of `steps` from the coefficients, with `coarse_dirs` the coarser
    /// level's directions (sensor responses only) and `iteration_rel` the relative error
    /// of the interreflected part (the solves' tolerance and the responses' rounding).
    /// Returns per step the values (with the sun's interpolation error in `lux_err`) and
    /// that error, lux. Node by node: each node's rows are read once for
    /// every step that uses it (read once per step, hundreds of kilobytes a step, they
    /// kept the sums waiting on memory). Each step sums its nodes in key order, so its
    /// values do not depend on which steps share the call.
    pub(super) fn evaluate(
        &self,
        steps: &[StepCuts],
        coarse_dirs: &Directions,
        iteration_rel: f64,
    ) -> Vec<(Vec<SensorValue>, Vec<f64>)> {
        let k = self.sensors;
        let p = self.parts;
        // Per step, accumulators: sky, Σ L̂ × response sum, uncertainty, parts, coarse
        // mesh; then the coarser level's direct sky; and the sun's interpolation error.
        let w = (3 + p + 1) * k;
        let mut acc = vec![0f32; steps.len() * w];
        let mut csky = vec![0f32; steps.len() * k];
        let mut interp = vec![0f64; steps.len() * k];
        // ... and the squared error of interreflected rows taken from ancestors.
        let mut inherited = vec![0f64; steps.len() * k];
        // A node's weights are read here, in step order: read in the node-major sums
        // below, each source was a cache miss (a third of the sums' own time).
        let mut fine_uses: Vec<(SourceKey, usize, (&Source, sums::Weights))> = Vec::new();
        let mut coarse_uses: Vec<(SourceKey, usize, (&Source, sums::Weights))> = Vec::new();
        for (j, st) in steps.iter().enumerate() {
            let acc = &mut acc[j * w..(j + 1) * w];
            // The ground glow, uniform, as one source ([`ground_sum`]); node by node
            // otherwise.
            let (ground, rest) = ground_sum::split_ground(st.fine);
            match ground_sum::uniform_radiance(&ground) {
                Some(l) => {
                    let gs = self.ground_sum(&ground);
                    let (sky, rest) = acc.split_at_mut(k);
                    let (refsum, rest) = rest.split_at_mut(k);
                    let (unc, ind) = rest.split_at_mut(k);
                    axpy(sky, l, &gs.direct);
                    axpy(refsum, l, &gs.direct);
                    axpy(unc, l, &gs.uncertainty);
                    axpy(ind, l, &gs.indirect);
                    sums::add_err(&mut inherited[j * k..(j + 1) * k], l, &gs.direction_err);
                }
                None => fine_uses.extend(ground.iter().map(|s| use_of(j, s))),
            }
            for src in rest {
                if src.is_sun() {
                    let interp = &mut interp[j * k..(j + 1) * k];
                    self.add_sun(src, &mut acc[3 * k..], Some(interp));
                } else {
                    fine_uses.push(use_of(j, src));
                }
            }
            let (cground, crest) = ground_sum::split_ground(st.coarse);
            match ground_sum::uniform_radiance(&cground) {
                Some(l) => {
                    let d = self.coarse_ground_sum(&cground, |s| self.coarse_node(s, coarse_dirs));
                    axpy(&mut csky[j * k..(j + 1) * k], l, &d);
                }
                None => coarse_uses.extend(cground.iter().map(|s| use_of(j, s))),
            }
            coarse_uses.extend(crest.iter().filter(|s| !s.is_sun()).map(|s| use_of(j, s)));
        }
        sums::sort_uses(&mut fine_uses);
        for uses in fine_uses.chunk_by(|a, b| a.0 == b.0) {
            let nd = self.node(uses[0].2 .0);
            for &(_, j, (_, weights)) in uses {
                sums::add_node(
                    &mut acc[j * w..(j + 1) * w],
                    k,
                    &nd.direct,
                    &nd.indirect,
                    weights,
                );
                let e = weights.irradiance;
                sums::add_err(&mut inherited[j * k..(j + 1) * k], e, &nd.direction_err);
            }
        }
        sums::sort_uses(&mut coarse_uses);
        for uses in coarse_uses.chunk_by(|a, b| a.0 == b.0) {
            let d = self.coarse_node(uses[0].2 .0, coarse_dirs);
            for &(_, j, (_, weights)) in uses {
                let csky = &mut csky[j * k..(j + 1) * k];
                for c in 0..4 {
                    axpy(csky, weights.children[c], &d[c * k..(c + 1) * k]);
                }
            }
        }
        steps
            .iter()
            .enumerate()
            .map(|(j, st)| {
                let (acc, csky) = (&acc[j * w..(j + 1) * w], &csky[j * k..(j + 1) * k]);
                let interp = interp[j * k..(j + 1) * k].to_vec();
                let inherited = &inherited[j * k..(j + 1) * k];
                let values = (0..k)
                    .map(|s| {
                        let sky = acc[s] as f64;
                        let fine = SensorDirect {
                            sun: from_lux(st.sun_fine[s]),
                            sky: from_lux(sky),
                            rays: 0,
                            visibility_err_lux: acc[2 * k + s] as f64,
                            radiance_error: from_lux(sky - acc[k + s] as f64),
                        };
                        let coarse = SensorDirect {
                            sun: from_lux(st.sun_coarse[s]),
                            sky: from_lux(csky[s] as f64),
                            ..SensorDirect::default()
                        };
                        // The parts on the stack (four at every preset): one allocation
                        // per sensor and step was a twentieth of a warm year.
                        let part = |q: usize| from_lux(acc[(3 + q) * k + s] as f64);
                        let mut stack = [Rgb::ZERO; 8];
                        let heap: Vec<Rgb>;
                        let parts: &[Rgb] = if p <= stack.len() {
                            for (q, x) in stack[..p].iter_mut().enumerate() {
                                *x = part(q);
                            }
                            &stack[..p]
                        } else {
                            heap = (0..p).map(part).collect();
                            &heap
                        };
                        let ind = TransportSensor::from_parts(
                            parts,
                            from_lux(acc[(3 + p) * k + s] as f64),
                        );
                        let mut v = SensorValue::estimate(&fine, &coarse, &ind, iteration_rel);
                        v.lux_err += interp[s] + inherited[s].sqrt();
                        v
                    })
                    .collect();
                (values, interp)
            })
            .collect()
    }

    /// Adds the sun's interreflected light, interpolated on the grid, to `ind` (the rows
    /// its vertices hold), and its interpolation error to `interp` (lux) when given.
    fn add_sun(&self, src: &Source, ind: &mut [f32], interp: Option<&mut [f64]>) {
        let k = self.sensors;
        let p = self.parts;
        let e = g(src.normal_irradiance);
        let corners: Vec<(&NodeData, f32)> = self
            .grid
            .corners(src.true_direction)
            .into_iter()
            .map(|(v, w)| (self.node(&self.grid.source(v)), w as f32))
            .collect();
        for (nd, w) in &corners {
            axpy(ind, e * w, &nd.indirect);
        }
        let Some(interp) = interp else {
            return;
        };
        // Per sensor: the mean over parts at each corner against the interpolated mean.
        let mean = |nd: &NodeData, s: usize| -> f64 {
            (0..p).map(|q| nd.indirect[q * k + s] as f64).sum::<f64>() / p as f64
        };
        for (s, out) in interp.iter_mut().enumerate() {
            let m: f64 = corners.iter().map(|(nd, w)| *w as f64 * mean(nd, s)).sum();
            let spread = corners
                .iter()
                .map(|(nd, _)| (mean(nd, s) - m).abs())
                .fold(0.0, f64::max);
            *out = e as f64 * spread;
        }
    }

    /// Counts a day summed, and every [`RELEASE_DAYS`] days gives the pages read in
    /// place back ([`Self::release_pages`]).
    pub(super) fn day_done(&self) {
        let n = self.days.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if n % RELEASE_DAYS == 0 {
            self.release_pages();
        }
    }

    /// Gives the pages of the rows read in place back to the kernel: they come back from
    /// the page cache when a later step reads them, so a year's steps keep resident what
    /// the days since the last call read, not every node they have met. Values never
    /// depend on it.
    pub(super) fn release_pages(&self) {
        for r in &self.records {
            r.release();
        }
    }

    fn node(&self, src: &Source) -> &NodeData {
        self.nodes.get(&src.key).unwrap_or_else(|| {
            panic!(
                "daylight coefficients: {:?} was not prepared (Engine::prepare must see every step)",
                src.key
            )
        })
    }

    fn coarse_node(&self, src: &Source, dirs: &Directions) -> std::sync::Arc<Vec<f32>> {
        if let Some(d) = self.coarse.lock().expect("coarse lock").get(&src.key) {
            return d.clone();
        }
        // Only the sensor section of the record, kept here compactly (not also in `dirs`),
        // and of it only the children's rows, which are all the coarse sums read: the
        // other five of the nine were half a warm year's growth in memory.
        let res = dirs.quality().projection.resolution_for(false);
        let mut rows = direct_rows(&dirs.sensor_responses(src, res), self.sensors);
        rows.truncate(4 * self.sensors);
        rows.shrink_to_fit();
        let d = std::sync::Arc::new(rows);
        self.coarse
            .lock()
            .expect("coarse lock")
            .entry(src.key)
            .or_insert(d)
            .clone()
    }
}
