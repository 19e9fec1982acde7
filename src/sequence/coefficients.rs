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

use super::config::SkySpec;
use super::direct::mesh_weights;
use super::directions::Directions;
use super::estimate::SensorValue;
use super::step::StepTime;
use crate::cache::{self, RecordKey, SceneHash, Section, FIRST_USER_TAG};
use crate::error::Result;
use crate::photometry::{from_lux, lux, Rgb};
use crate::radiosity::{DirectionTerms, Transport, TransportParams, TransportSensor};
use crate::scene::Scene;
use crate::sensors::SensorDirect;
use crate::sky::Sky;
use crate::sources::{Source, SourceKey, SunGrid};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Section tag of a coefficient record: (parts + 1) × sensors f32.
const TAG_VALUES: u32 = FIRST_USER_TAG;
/// Section tag of a sky or ground node's direct rows ([`DIRECT_ROWS`] × sensors f32), a
/// copy of what its direction record yields: a warm run then reads no direction record
/// (a large scene's projection leaves are megabytes each).
const TAG_DIRECT: u32 = FIRST_USER_TAG + 1;
/// Version of what a coefficient record holds, hashed into its key.
const COEFFICIENTS_VERSION: u32 = 4;
/// Direct rows per node: 4 child responses, their sum, 4 uncertainties.
const DIRECT_ROWS: usize = 9;
/// Adjoint responses held at once without a memory cap, bytes: beyond it, larger blocks
/// save little time (each block reads every direction once more). 256 MB of bfloat16
/// responses hold as many sensors as 512 MB did in f32.
pub const RESPONSE_MAX_BYTES: u64 = 256 << 20;
/// Directions whose source terms are held at once while coefficients are computed, and
/// applied together ([`crate::radiosity::AdjointBlock::apply_many`]): a few megabytes of
/// terms each on the generated building, and the block's responses read once per batch.
const BATCH: usize = 64;

/// One node's per-sensor data, rows of `sensors` f32 each.
#[derive(Clone, Debug, Default)]
struct NodeData {
    /// [`DIRECT_ROWS`] rows (empty for sun-grid vertices).
    direct: Vec<f32>,
    /// parts rows of fine interreflected lux per W/m², then the coarse mean; shared by
    /// the nodes that take them from one ancestor ([`indirect_ancestors`]).
    indirect: Arc<Vec<f32>>,
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
pub use budget::adjoint_budget;
use budget::{direction_bytes, scene_bytes};
pub(super) use cut_batch::CutBatch;
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
    /// Bytes the coefficients take in memory.
    pub bytes: u64,
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

/// How the caller follows and stops [`Coefficients::prepare`].
#[derive(Clone, Copy)]
pub(super) struct Watch<'a> {
    /// Called after each batch of directions in each sensor block with (direction passes
    /// done, passes in all): a pass is one direction in one block.
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Polled before each sensor block and batch of directions.
    pub stop: &'a std::sync::atomic::AtomicBool,
}

impl Coefficients {
    /// Prepares the coefficients every step of `steps` needs: the nodes of each step's
    /// cut (read from the cache or computed, through `dirs` for the projections and
    /// direct responses and `op` for the interreflection) and the sun-grid vertices
    /// around each step's sun, with the adjoint responses sized to what the cap
    /// `opts.max_memory_bytes` leaves ([`adjoint_budget`]; 0: no cap). Also returns each step's sky (`None`
    /// where it cannot be built), so the steps need not build them again. With
    /// `opts.values_only` only what the values need is kept ([`Self::evaluate_values_batch`]: the
    /// children's direct rows and the parts' mean, 5 rows per node instead of 14); the
    /// cache records are the same. `watch` follows the work and can stop it.
    ///
    /// # Errors
    /// [`crate::Error::Interrupted`] once `watch.stop` is set (nothing of the coefficients is
    /// kept: a direction's are stored when every block is done). The coefficients, one
    /// adjoint block and the directions in flight cannot fit
    /// the cap beside what the process already holds ([`crate::Error::Input`]).
    pub(super) fn prepare(
        scene: &Scene,
        dirs: &Directions,
        op: &mut Option<Transport>,
        load_operator: impl FnOnce() -> Transport,
        steps: &[(StepTime, SkySpec)],
        opts: &super::EngineOptions,
        watch: &Watch,
    ) -> Result<(Coefficients, Vec<Option<Sky>>)> {
        let Watch { progress, stop } = *watch;
        let t0 = Instant::now();
        let quality = dirs.quality();
        let grid = SunGrid {
            spacing_deg: quality.sun_grid_deg,
        };
        let k = scene.sensors.len();
        let store = dirs.store();
        let hash = coefficient_hash(scene, dirs, &quality.transport);
        // The nodes of every step's cut (and each step's sky where they were made here).
        let union = super::cuts::union(scene, quality, steps, store);
        let (wanted, skies) = (union.nodes, union.skies);
        let mut stats = CoefficientStats {
            cuts_from_cache: union.from_cache,
            nodes: wanted.values().filter(|s| !s.is_sun()).count(),
            sun_grid_vertices: wanted.values().filter(|s| s.is_sun()).count(),
            sun_grid_deg: grid.spacing_deg,
            ..CoefficientStats::default()
        };
        let parts = quality.transport.parts.max(2) as usize;
        let union: Vec<Source> = wanted.into_values().collect();
        let plan = indirect_ancestors::plan(&union, quality.indirect_depth);
        stats.indirect_from_ancestors = plan.deep.len();
        let list = &plan.solved;
        // Grid vertices feed only the interreflection mesh (0.25 m² rows, not shadows on
        // sensors), so they are projected at the sky nodes' resolution.
        let res_of = |src: &Source| {
            let sun = matches!(src.key, SourceKey::Sun(_));
            quality.projection.resolution_for(sun)
        };
        // Cached coefficients, with the direct rows from the direction's sensor responses.
        let mut data: Vec<Option<NodeData>> = list
            .par_iter()
            .map(|src| {
                let key = record_key(hash, dirs, src, res_of(src))?;
                let r = store.get(&key)?;
                let v = r.section::<f32>(TAG_VALUES).ok()?.to_vec();
                if v.len() != (parts + 1) * k {
                    return None;
                }
                let direct = if src.is_sun() {
                    Vec::new()
                } else {
                    r.section::<f32>(TAG_DIRECT)
                        .ok()
                        .filter(|d| d.len() == DIRECT_ROWS * k)
                        .map(|d| d.to_vec())
                        .unwrap_or_else(|| direct_rows(&dirs.sensor_responses(src, res_of(src)), k))
                };
                Some(NodeData {
                    direct,
                    indirect: Arc::new(v),
                    ..NodeData::default()
                })
            })
            .collect();
        let todo: Vec<usize> = (0..list.len()).filter(|&i| data[i].is_none()).collect();
        stats.from_cache = list.len() - todo.len();
        stats.computed = todo.len();
        stats.operator_needed = !todo.is_empty();
        if !todo.is_empty() {
            // Sensors in blocks that fit the budget; each block's adjoint responses turn
            // every missing direction's mesh irradiance into its coefficients.
            // The operator only now: a run whose coefficients are all cached never reads it.
            let op: &Transport = op.get_or_insert_with(load_operator);
            // The union's nodes, each with a row of stated error when it takes its
            // ancestor's interreflection.
            let coefficient_bytes = (union.len() * k * (DIRECT_ROWS + parts + 2) * 4) as u64;
            // A direction in flight per thread (applying) or the solves' scratch (solving).
            let threads = rayon::current_num_threads();
            let in_flight = (threads as u64
                * direction_bytes(quality.projection.resolution_for(true)))
            .max(op.adjoint_scratch_bytes(threads));
            // What is held beside the adjoint blocks, from sizes (not from the resident
            // memory, which other work in the process would make a moving target): the
            // same inputs always get the same blocks and the same smallest cap.
            let held = op.bytes() + scene_bytes(scene) + coefficient_bytes + in_flight;
            // The process may hold more than the sizes say (the allocator keeps what the
            // operator's build freed): the blocks shrink to that too, never below one.
            let resident =
                crate::memory::resident_bytes().map_or(0, |r| r + coefficient_bytes + in_flight);
            let budget = adjoint_budget(
                opts.max_memory_bytes,
                opts.max_memory_given,
                held,
                resident,
                op.adjoint_bytes_per_sensor() * op.adjoint_block_size(0) as u64,
            )?;
            let block = op.adjoint_block_size(budget);
            stats.block_sensors = block.min(k);
            let mut fresh: Vec<NodeData> = todo
                .iter()
                .map(|_| NodeData {
                    indirect: Arc::new(vec![0f32; (parts + 1) * k]),
                    ..NodeData::default()
                })
                .collect();
            let passes = k.div_ceil(block) * todo.len();
            progress(0, passes);
            for (b, s0) in (0..k).step_by(block).enumerate() {
                if stop.load(std::sync::atomic::Ordering::SeqCst) {
                    return Err(crate::Error::Interrupted);
                }
                let xb = op.adjoint_block(s0..(s0 + block).min(k));
                stats.sweeps += xb.sweeps;
                let w = xb.sensors.len();
                for (c, (ids, outs)) in todo.chunks(BATCH).zip(fresh.chunks_mut(BATCH)).enumerate()
                {
                    if stop.load(std::sync::atomic::Ordering::SeqCst) {
                        return Err(crate::Error::Interrupted);
                    }
                    // The batch's projections and mesh weights in parallel, then the
                    // block's responses applied to all of them in one pass.
                    let terms: Vec<DirectionTerms> = ids
                        .par_iter()
                        .zip(outs.par_iter_mut())
                        .map(|(&i, nd)| {
                            let src = &list[i];
                            let d = dirs.fetch(src, res_of(src));
                            if s0 == 0 && !src.is_sun() {
                                nd.direct = direct_rows(&d.sensors, k);
                            }
                            op.direction_terms(&mesh_weights(scene, op, src, &d.record))
                        })
                        .collect();
                    let vs = xb.apply_many(op, &terms);
                    for (nd, v) in outs.iter_mut().zip(vs) {
                        for row in 0..=parts {
                            Arc::make_mut(&mut nd.indirect)[row * k + s0..row * k + s0 + w]
                                .copy_from_slice(&v[row * w..(row + 1) * w]);
                        }
                    }
                    progress(b * todo.len() + (todo.len()).min((c + 1) * BATCH), passes);
                }
            }
            for (&i, nd) in todo.iter().zip(fresh) {
                let src = &list[i];
                if let Some(key) = record_key(hash, dirs, src, res_of(src)) {
                    if store.is_enabled() {
                        let mut sections = vec![Section::of(TAG_VALUES, &nd.indirect)];
                        if !nd.direct.is_empty() {
                            sections.push(Section::of(TAG_DIRECT, &nd.direct));
                        }
                        store.put(&key, &cache::encode(&key, &sections));
                    }
                }
                data[i] = Some(nd);
            }
        }
        let solved: Vec<NodeData> = data
            .into_iter()
            .map(|d| d.expect("every direction prepared"))
            .collect();
        let deep = indirect_ancestors::deep_direct(scene, dirs, hash, &plan.deep, res_of);
        let nodes: HashMap<SourceKey, NodeData, ahash::RandomState> =
            indirect_ancestors::assemble(&union, list, solved, &plan.deep, deep, parts)
                .into_iter()
                .map(|(key, d)| {
                    (
                        key,
                        if opts.values_only {
                            d.values_only(parts, k)
                        } else {
                            d
                        },
                    )
                })
                .collect();
        // Interreflected rows shared by several nodes counted once.
        let mut shared = std::collections::HashSet::new();
        stats.bytes = nodes
            .values()
            .map(|n| {
                let ind = if shared.insert(Arc::as_ptr(&n.indirect)) {
                    n.indirect.len()
                } else {
                    0
                };
                4 * (n.direct.len() + ind + n.direction_err.len()) as u64
            })
            .sum();
        stats.seconds = t0.elapsed().as_secs_f64();
        let c = Coefficients {
            sensors: k,
            parts,
            grid,
            nodes,
            coarse: Mutex::new(HashMap::default()),
            ground: Default::default(),
            stats,
        };
        Ok((c, skies))
    }

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
                    indirect_ancestors::add_err(
                        &mut inherited[j * k..(j + 1) * k],
                        l,
                        &gs.direction_err,
                    );
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
                indirect_ancestors::add_err(
                    &mut inherited[j * k..(j + 1) * k],
                    e,
                    &nd.direction_err,
                );
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
        // Only the sensor section of the record, kept here compactly (not also in `dirs`).
        let res = dirs.quality().projection.resolution_for(false);
        let d = std::sync::Arc::new(direct_rows(&dirs.sensor_responses(src, res), self.sensors));
        self.coarse
            .lock()
            .expect("coarse lock")
            .entry(src.key)
            .or_insert(d)
            .clone()
    }
}

/// What coefficient records depend on: the directions' hash (geometry, glazing, sensors,
/// projection parameters), the operator's key, and every triangle's reflectance and
/// emission.
fn coefficient_hash(scene: &Scene, dirs: &Directions, params: &TransportParams) -> SceneHash {
    let mut extra = b"daylight coefficients v".to_vec();
    extra.extend_from_slice(&COEFFICIENTS_VERSION.to_le_bytes());
    extra.extend_from_slice(&dirs.hash().0);
    extra.extend_from_slice(&super::operator::key(scene, params).to_bytes());
    // Each triangle's reflectance and emission: what, with the mesh the operator's key
    // fixes, sets every row's ρ and exitance.
    for t in &scene.triangles {
        let m = &scene.materials[t.material as usize];
        for v in [m.reflectance(), m.ke] {
            for c in v.to_array() {
                extra.extend_from_slice(&c.to_bits().to_le_bytes());
            }
        }
    }
    extra.extend_from_slice(&(crate::radiosity::response::BLOCK as u64).to_le_bytes());
    cache::scene_hash(scene, &dirs.quality().projection, &extra)
}

fn record_key(hash: SceneHash, dirs: &Directions, src: &Source, res: u32) -> Option<RecordKey> {
    let own = RecordKey::for_source(dirs.hash(), src.key, res)?;
    // The direction's own kind goes into the hash: sky, ground and grid ids may overlap.
    let mut h = blake3::Hasher::new();
    h.update(&hash.0);
    h.update(&[own.kind]);
    Some(RecordKey {
        scene: SceneHash(*h.finalize().as_bytes()),
        kind: cache::KIND_COEFFICIENTS,
        direction: own.direction,
        resolution: res,
    })
}
