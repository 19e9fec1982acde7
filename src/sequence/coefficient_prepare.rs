//! Preparing the daylight coefficients ([`Coefficients::prepare`]): the nodes and sun-grid
//! vertices a run's steps use, read from the cache or computed, sensor block by sensor
//! block, with the adjoint responses sized to the memory cap.

use super::scratch::Scratch;
use super::spill::TermsSpill;
use super::{
    budget::{adjoint_budget, direction_bytes, scene_bytes},
    direct_rows, indirect_ancestors, CoefficientStats, Coefficients, NodeData, BATCH,
    COEFFICIENTS_VERSION, DIRECT_ROWS, TAG_DIRECT, TAG_VALUES,
};
use crate::cache::{self, RecordKey, SceneHash, Section};
use crate::error::Result;
use crate::radiosity::{Buf, Transport, TransportParams};
use crate::scene::Scene;
use crate::sequence::config::SkySpec;
use crate::sequence::direct::mesh_weights;
use crate::sequence::directions::Directions;
use crate::sequence::step::{EngineOptions, StepTime};
use crate::sky::Sky;
use crate::sources::{Source, SourceKey, SunGrid};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// How the caller follows and stops [`Coefficients::prepare`].
#[derive(Clone, Copy)]
pub(in crate::sequence) struct Watch<'a> {
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
    /// `opts.max_memory_bytes` leaves ([`adjoint_budget`]; 0: no cap). Also returns each
    /// step's sky (`None` where it cannot be built), so the steps need not build them
    /// again. With `opts.values_only` only what the values need is kept
    /// ([`Self::evaluate_values_batch`]: the children's direct rows and the parts' mean, 5
    /// rows per node instead of 14); the cache records are the same. `watch` follows the
    /// work and can stop it.
    ///
    /// # Errors
    /// [`crate::Error::Interrupted`] once `watch.stop` is set (nothing of the coefficients is
    /// kept: a direction's are stored when every block is done). The coefficients, one
    /// adjoint block and the directions in flight cannot fit the cap beside what the
    /// process already holds ([`crate::Error::Input`]).
    pub(in crate::sequence) fn prepare(
        scene: &Scene,
        dirs: &Directions,
        op: &mut Option<Transport>,
        load_operator: impl FnOnce() -> Transport,
        steps: &[(StepTime, SkySpec)],
        opts: &EngineOptions,
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
        let union = crate::sequence::cuts::union(scene, quality, steps, store);
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
        // Rows read in place where there are enough of them for it to matter, or where the
        // user set a cap.
        let map_rows = store.is_enabled()
            && ((union.len() * k * (DIRECT_ROWS + parts + 1) * 4) as u64 >= MAP_MIN_BYTES
                || opts.max_memory_given);
        stats.in_place = map_rows;
        // Grid vertices feed only the interreflection mesh (0.25 m² rows, not shadows on
        // sensors), so they are projected at the sky nodes' resolution.
        let res_of = |src: &Source| {
            let sun = matches!(src.key, SourceKey::Sun(_));
            quality.projection.resolution_for(sun)
        };
        // Cached coefficients read in place, with the direct rows from the direction's
        // sensor responses where the record lacks them.
        let mut data: Vec<Option<NodeData>> = list
            .par_iter()
            .map(|src| {
                let key = record_key(hash, dirs, src, res_of(src))?;
                in_place(store.get_mapped(&key, map_rows)?, parts, k, !src.is_sun()).map(
                    |(nd, whole)| {
                        if whole {
                            return nd;
                        }
                        let d = direct_rows(&dirs.sensor_responses(src, res_of(src)), k);
                        NodeData {
                            direct: d.into(),
                            ..nd
                        }
                    },
                )
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
            let block = Transport::balanced_block(k, op.adjoint_block_size(budget));
            stats.block_sensors = block.min(k);
            // Per node: its parts' and coarse interreflected rows, then its direct rows.
            let node_rows = parts + 1 + DIRECT_ROWS;
            let mut scratch = Scratch::new(todo.len(), node_rows, k);
            let scratch_err = |source| crate::Error::Io {
                path: std::env::temp_dir().join("(daystep coefficient scratch)"),
                source,
            };
            let blocks = k.div_ceil(block);
            let passes = blocks * todo.len();
            progress(0, passes);
            let mut spill = TermsSpill::new(blocks);
            let go_on = || {
                if stop.load(std::sync::atomic::Ordering::SeqCst) {
                    Err(crate::Error::Interrupted)
                } else {
                    Ok(())
                }
            };
            for (b, s0) in (0..k).step_by(block).enumerate() {
                go_on()?;
                // The last block's responses are freed: handed back before this one's
                // solves, or the arenas hold them beside its transposed operator.
                crate::allocator::give_back_freed();
                if b > 0 {
                    spill.rewind();
                }
                let xb = op.adjoint_block(s0..(s0 + block).min(k));
                stats.sweeps += xb.sweeps;
                // The solves' transposed operators are freed: handed back before the
                // batches' projections are made.
                crate::allocator::give_back_freed();
                let w = xb.sensors.len();
                for (c, ids) in todo.chunks(BATCH).enumerate() {
                    go_on()?;
                    // The batch's projections and mesh weights in parallel (the later
                    // blocks read the terms the first one made, [`TermsSpill`]), then the
                    // block's responses applied to all of them in one pass.
                    let terms = match spill.read(ids.len()) {
                        Some(t) => t,
                        None => {
                            let made: Vec<_> = ids
                                .par_iter()
                                .map(|&i| {
                                    let src = &list[i];
                                    let d = dirs.fetch(src, res_of(src));
                                    let direct = (s0 == 0 && !src.is_sun())
                                        .then(|| direct_rows(&d.sensors, k));
                                    let w = mesh_weights(scene, op, src, &d.record);
                                    (op.direction_terms(&w), direct)
                                })
                                .collect();
                            let mut terms = Vec::with_capacity(made.len());
                            for (j, (t, direct)) in made.into_iter().enumerate() {
                                if let Some(d) = direct {
                                    for row in 0..DIRECT_ROWS {
                                        let r = &d[row * k..(row + 1) * k];
                                        let at = parts + 1 + row;
                                        scratch
                                            .write(c * BATCH + j, at, 0, r)
                                            .map_err(scratch_err)?;
                                    }
                                }
                                terms.push(t);
                            }
                            terms
                        }
                    };
                    spill.write(&terms);
                    let vs = xb.apply_many(op, &terms);
                    for (j, v) in vs.iter().enumerate() {
                        for row in 0..=parts {
                            let r = &v[row * w..(row + 1) * w];
                            scratch
                                .write(c * BATCH + j, row, s0, r)
                                .map_err(scratch_err)?;
                        }
                    }
                    progress(b * todo.len() + (todo.len()).min((c + 1) * BATCH), passes);
                }
            }
            stats.spilled_bytes = spill.bytes;
            drop(spill);
            // The blocks' responses and the batches' projections are freed: handed back
            // before the deep nodes' direct rows are made.
            crate::allocator::give_back_freed();
            // Each node's rows stored, then read in place from its record (held where
            // the cache is off or the write failed).
            for (j, &i) in todo.iter().enumerate() {
                let src = &list[i];
                let read = |rows| scratch.read(j, rows).map_err(scratch_err);
                let indirect = read(0..parts + 1)?;
                let direct = if src.is_sun() {
                    Vec::new()
                } else {
                    read(parts + 1..node_rows)?
                };
                let mut sections = vec![Section::of(TAG_VALUES, &indirect)];
                if !direct.is_empty() {
                    sections.push(Section::of(TAG_DIRECT, &direct));
                }
                let stored = record_key(hash, dirs, src, res_of(src))
                    .filter(|key| store.is_enabled() && store.put_sections(key, &sections))
                    .filter(|_| map_rows);
                let mapped = stored
                    .and_then(|key| store.read_back_mapped(&key))
                    .and_then(|r| in_place(r, parts, k, !src.is_sun()))
                    .filter(|(_, whole)| *whole);
                data[i] = Some(match mapped {
                    Some((nd, _)) => nd,
                    None => NodeData {
                        indirect: Arc::new(indirect.into()),
                        direct: direct.into(),
                        ..NodeData::default()
                    },
                });
            }
        }
        let solved: Vec<NodeData> = data
            .into_iter()
            .map(|d| d.expect("every direction prepared"))
            .collect();
        let deep = indirect_ancestors::deep_direct(scene, dirs, hash, &plan.deep, res_of, map_rows);
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
        let mut records: Vec<Arc<cache::MappedRecord>> = Vec::new();
        let mut seen = std::collections::HashSet::new();
        for n in nodes.values() {
            for r in [n.direct.record(), n.indirect.record()]
                .into_iter()
                .flatten()
            {
                if seen.insert(Arc::as_ptr(r)) {
                    records.push(Arc::clone(r));
                }
            }
        }
        let c = Coefficients {
            sensors: k,
            parts,
            grid,
            nodes,
            coarse: Mutex::new(HashMap::default()),
            ground: Default::default(),
            records,
            days: Default::default(),
            stats,
        };
        // Assembling the deep nodes read their ancestors' rows.
        c.release_pages();
        Ok((c, skies))
    }
}

/// Coefficients below this size in all (bytes, as held) are read into memory rather than
/// in place, unless the user set a cap (`--max-memory`) ([`in_place`], [`cache::Store::get_mapped`]): mapping a record and giving its
/// pages back costs system calls and page faults, which the sample office's warm year
/// (a few megabytes of coefficients in 9 KB records) would pay for nothing. On the
/// generated building (270 MB, 1 620 sensors) read in place, the warm year's peak fell
/// from 306 to 195 MB, for 1.11× its time.
const MAP_MIN_BYTES: u64 = 64 << 20;

/// A node's rows read in place from its coefficient record `r` for `parts` parts and `k`
/// sensors, and whether the record held its direct rows too (where `direct`, they are
/// wanted); `None` when its values have the wrong size.
fn in_place(
    r: cache::MappedRecord,
    parts: usize,
    k: usize,
    direct: bool,
) -> Option<(NodeData, bool)> {
    let r = Arc::new(r);
    let indirect = Arc::new(mapped_rows(&r, TAG_VALUES, (parts + 1) * k)?);
    let rows = direct
        .then(|| mapped_rows(&r, TAG_DIRECT, DIRECT_ROWS * k))
        .flatten();
    let whole = rows.is_some() || !direct;
    // Validating the record read every page: back to the kernel until a step reads them.
    r.release();
    Some((
        NodeData {
            direct: rows.unwrap_or_default(),
            indirect,
            ..NodeData::default()
        },
        whole,
    ))
}

/// Section `tag` of record `r` read in place when it holds `len` values, else `None`.
pub(super) fn mapped_rows(r: &Arc<cache::MappedRecord>, tag: u32, len: usize) -> Option<Buf<f32>> {
    let v = r.section::<f32>(tag).ok()?;
    (v.len() == len).then(|| Buf::mapped(r, v))?
}

/// What coefficient records depend on: the directions' hash (geometry, glazing, sensors,
/// projection parameters), the operator's key, and every triangle's reflectance and
/// emission.
fn coefficient_hash(scene: &Scene, dirs: &Directions, params: &TransportParams) -> SceneHash {
    let mut extra = b"daylight coefficients v".to_vec();
    extra.extend_from_slice(&COEFFICIENTS_VERSION.to_le_bytes());
    extra.extend_from_slice(&dirs.hash().0);
    extra.extend_from_slice(&crate::sequence::operator::key(scene, params).to_bytes());
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

pub(super) fn record_key(
    hash: SceneHash,
    dirs: &Directions,
    src: &Source,
    res: u32,
) -> Option<RecordKey> {
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
