//! The direction nodes a run's steps use: the union of every step's adaptive sky cut, with
//! the sun-grid vertices around each step's sun, which the daylight coefficients are
//! prepared for. Finding it takes one cut per step, as much sky arithmetic as the steps'
//! own cuts, so a warm run made every cut twice. The union is therefore a cache record,
//! keyed by what the cuts depend on (each step's time and sky, the site, the ground
//! reflectance, the sky parameters and [`CUTS_VERSION`]) and never by the geometry, so
//! light-path runs and geometry changes share it. A record is trusted only after the
//! cuts of a sample of its steps are all found in it; otherwise the union is made again.

use super::config::{Quality, SkySpec};
use super::sky::{build_sky, sources_for};
use super::step::StepTime;
use crate::cache::{self, RecordKey, SceneHash, Section, Store, FIRST_USER_TAG};
use crate::scene::Scene;
use crate::site::solar_position::solar_position;
use crate::sky::{perez, Sky};
use crate::sources::{node_source, SkyNodeKey, Source, SourceKey, SunGrid, SunKey};
use chrono::{Datelike, Timelike};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Version of the cuts a record lists, hashed into its key: bumped whenever the sky
/// models, the subdivision or the sun grid change what a step's cut is.
pub const CUTS_VERSION: u32 = 3;

/// Section tag: three u64 per node ([`encode_key`]).
const TAG_NODES: u32 = FIRST_USER_TAG;
/// Section tag: the Perez skies' horizontal integrals the union's skies needed
/// ([`perez::remembered_integrals`]), so a warm run does not integrate each step's sky
/// again (8 192 evaluations of the distribution per step, a fifth of a warm office year).
const TAG_INTEGRALS: u32 = FIRST_USER_TAG + 1;

/// A cached union is checked against the cuts of every (steps / [`CHECK_MIN`])th step, at
/// least every `CHECK_EVERY`th (and the last): every step of a run under 64 steps.
const CHECK_EVERY: usize = 97;
/// See [`CHECK_EVERY`].
const CHECK_MIN: usize = 32;

/// The nodes of a run's steps.
pub(super) struct Union {
    /// Each node once, as a direction (the cut's own source for sky and ground nodes,
    /// [`SunGrid::source`] for grid vertices), in key order.
    pub nodes: BTreeMap<SourceKey, Source>,
    /// Each step's sky where the union was made here (`None`: not built, or the union
    /// came from the cache and the steps build their own).
    pub skies: Vec<Option<Sky>>,
    /// Whether the union came from the cache.
    pub from_cache: bool,
}

/// One step's sky and its cut (`None` where the sky cannot be built).
fn step_sources(
    scene: &Scene,
    quality: &Quality,
    at: &StepTime,
    spec: &SkySpec,
) -> Option<(Sky, Vec<Source>)> {
    let sun = solar_position(at.utc, &scene.site);
    let sky = build_sky(spec, &sun, at.local.ordinal(), scene.ground_reflectance).ok()?;
    let s = sources_for(&sky, quality).sources;
    Some((sky, s))
}

/// The nodes one cut needs: its sky and ground nodes, and for its sun the grid's corners.
fn cut_nodes(grid: &SunGrid, cut: Vec<Source>) -> impl Iterator<Item = Source> + '_ {
    cut.into_iter().flat_map(move |src| match src.key {
        SourceKey::Sun(_) => grid
            .corners(src.true_direction)
            .into_iter()
            .map(|(v, _)| grid.source(v))
            .collect::<Vec<_>>(),
        _ => vec![src],
    })
}

/// The union of the cuts of `steps`, from `store` when a record there holds the cuts of
/// the sampled steps, else made (in parallel, folded per thread so the year's cuts are
/// never all held) and stored.
pub(super) fn union(
    scene: &Scene,
    quality: &Quality,
    steps: &[(StepTime, SkySpec)],
    store: &Store,
) -> Union {
    let grid = SunGrid {
        spacing_deg: quality.sun_grid_deg,
    };
    let key = record_key(scene, quality, steps);
    let record = store.get(&key);
    if let Some((r, nodes)) = record.and_then(|r| decode(&r, &grid).map(|n| (r, n))) {
        let every = (steps.len() / CHECK_MIN).clamp(1, CHECK_EVERY);
        let sampled: Vec<usize> = (0..steps.len())
            .step_by(every)
            .chain(steps.len().checked_sub(1))
            .collect();
        let holds = sampled.par_iter().all(|&i| {
            let (at, spec) = &steps[i];
            step_sources(scene, quality, at, spec)
                .is_none_or(|(_, cut)| cut_nodes(&grid, cut).all(|s| nodes.contains_key(&s.key)))
        });
        if holds {
            if let Ok(e) = r.section::<perez::RememberedIntegral>(TAG_INTEGRALS) {
                perez::remember_integrals(e);
            }
            return Union {
                nodes,
                skies: (0..steps.len()).map(|_| None).collect(),
                from_cache: true,
            };
        }
    }
    type Acc = (BTreeMap<SourceKey, Source>, Vec<(usize, Sky)>);
    let (nodes, mut indexed): Acc = steps
        .par_iter()
        .enumerate()
        .fold(
            || (BTreeMap::new(), Vec::new()),
            |(mut m, mut skies): Acc, (i, (at, spec))| {
                if let Some((sky, cut)) = step_sources(scene, quality, at, spec) {
                    for src in cut_nodes(&grid, cut) {
                        m.entry(src.key).or_insert(src);
                    }
                    skies.push((i, sky));
                }
                (m, skies)
            },
        )
        .reduce(
            || (BTreeMap::new(), Vec::new()),
            // A key's source is the same direction and vertices whichever step it came
            // from (only those are read), so the merge order does not matter.
            |(mut a, mut sa), (b, sb)| {
                for (k, v) in b {
                    a.entry(k).or_insert(v);
                }
                sa.extend(sb);
                (a, sa)
            },
        );
    indexed.sort_by_key(|e| e.0);
    let mut skies: Vec<Option<Sky>> = (0..steps.len()).map(|_| None).collect();
    for (i, sky) in indexed {
        skies[i] = Some(sky);
    }
    if store.is_enabled() {
        let flat: Vec<[u64; 3]> = nodes.keys().map(encode_key).collect();
        // Every integral the process holds: this run's skies' (any other is as true).
        let integrals = perez::remembered_integrals();
        store.put(
            &key,
            &cache::encode(
                &key,
                &[
                    Section::of(TAG_NODES, &flat),
                    Section::of(TAG_INTEGRALS, &integrals),
                ],
            ),
        );
    }
    Union {
        nodes,
        skies,
        from_cache: false,
    }
}

/// `v` as JSON bytes, for hashing: deterministic, since serde_json writes every f64 so
/// that it reads back exactly.
fn json<T: serde::Serialize>(v: &T) -> Vec<u8> {
    serde_json::to_vec(v).expect("plain data serialises")
}

/// The record key of the union of `steps`' cuts.
fn record_key(scene: &Scene, quality: &Quality, steps: &[(StepTime, SkySpec)]) -> RecordKey {
    let mut h = blake3::Hasher::new();
    h.update(b"daystep cuts\0");
    hash_context(&mut h, scene, quality);
    h.update(&(steps.len() as u64).to_le_bytes());
    for (at, spec) in steps {
        hash_step(&mut h, at, spec);
    }
    RecordKey {
        scene: SceneHash(*h.finalize().as_bytes()),
        kind: cache::KIND_CUTS,
        direction: 0,
        resolution: 0,
    }
}

/// Hashes what every step's cut at `quality` depends on besides its time and sky:
/// [`CUTS_VERSION`], the program's version, the sky and sun parameters, the ground
/// reflectance and the site (never the geometry).
pub(super) fn hash_context(h: &mut blake3::Hasher, scene: &Scene, quality: &Quality) {
    h.update(&CUTS_VERSION.to_le_bytes());
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update(&json(&quality.sky));
    for x in [
        quality.sun_spacing_deg,
        quality.sun_grid_deg,
        scene.ground_reflectance,
    ] {
        h.update(&x.to_bits().to_le_bytes());
    }
    h.update(&json(&scene.site));
}

/// Hashes one step's time and sky, exactly.
pub(super) fn hash_step(h: &mut blake3::Hasher, at: &StepTime, spec: &SkySpec) {
    h.update(&at.utc.timestamp().to_le_bytes());
    h.update(&at.utc.timestamp_subsec_nanos().to_le_bytes());
    h.update(&at.local.ordinal().to_le_bytes());
    h.update(&at.local.num_seconds_from_midnight().to_le_bytes());
    h.update(&json(spec));
}

/// A node key as three u64: kind (0 sky, 1 ground, 2 snapped sun, 3 sun-grid vertex) and
/// its fields.
pub(super) fn encode_key(k: &SourceKey) -> [u64; 3] {
    let sun = |kind: u64, s: SunKey| {
        [
            kind,
            u64::from(s.band as u32),
            u64::from(s.index as u32) | (u64::from(s.spacing_udeg) << 32),
        ]
    };
    match *k {
        SourceKey::Sky(n) => [0, u64::from(n.base), n.path],
        SourceKey::Ground(n) => [1, u64::from(n.base), n.path],
        SourceKey::Sun(s) => sun(2, s),
        SourceKey::SunGrid(s) => sun(3, s),
    }
}

/// The nodes of a record [`union`] wrote; `None` when any entry is not a node this run's
/// cuts could hold (the union is then made again, never trusted).
fn decode(r: &cache::MappedRecord, grid: &SunGrid) -> Option<BTreeMap<SourceKey, Source>> {
    let flat = r.section::<[u64; 3]>(TAG_NODES).ok()?;
    let spacing = (grid.spacing_deg * 1e6).round().max(1.0) as u64;
    let mut nodes = BTreeMap::new();
    for &[kind, a, b] in flat {
        let src = match kind {
            0 | 1 => {
                // A face of its half of the octahedron (0..4 sky, 4..8 ground) and a heap
                // path of at most 30 levels, deeper than any preset subdivides.
                if a >= 8 || (a < 4) != (kind == 0) || b == 0 || b >= 1 << 62 {
                    return None;
                }
                node_source(SkyNodeKey {
                    base: a as u8,
                    path: b,
                })
            }
            3 if b >> 32 == spacing => grid.source(SunKey {
                band: a as u32 as i32,
                index: b as u32 as i32,
                spacing_udeg: (b >> 32) as u32,
            }),
            _ => return None,
        };
        nodes.insert(src.key, src);
    }
    Some(nodes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_keys_round_trip_and_foreign_entries_are_refused() {
        let grid = SunGrid { spacing_deg: 3.0 };
        let sky = SkyNodeKey {
            base: 2,
            path: 4 * 5 + 3,
        };
        let vertex = SunKey::snap(20.0, 135.0, 3.0);
        let keys = [
            SourceKey::Sky(sky),
            SourceKey::Ground(SkyNodeKey { base: 6, path: 1 }),
            SourceKey::SunGrid(vertex),
        ];
        let key = RecordKey {
            scene: SceneHash([0; 32]),
            kind: cache::KIND_CUTS,
            direction: 0,
            resolution: 0,
        };
        let read = |entries: &[[u64; 3]]| {
            let rec = cache::encode(&key, &[Section::of(TAG_NODES, entries)]);
            let r = cache::MappedRecord::from_bytes(&rec, &key).unwrap();
            decode(&r, &grid)
        };
        let flat: Vec<[u64; 3]> = keys.iter().map(encode_key).collect();
        let nodes = read(&flat).unwrap();
        let mut want = keys.to_vec();
        want.sort();
        assert_eq!(nodes.keys().copied().collect::<Vec<_>>(), want);
        // Sky and ground nodes come back as the cut makes them (direction and vertices).
        assert_eq!(nodes[&keys[0]].vertices, Some(sky.vertices()));
        // A sky key on a ground face, a ground key on a sky face, a grid vertex of another
        // spacing, a snapped sun (never a node: its grid corners are) and an unknown kind
        // are refused.
        for bad in [
            [0, 5, 1],
            [1, 2, 1],
            [3, 0, 1 << 32],
            encode_key(&SourceKey::Sun(vertex)),
            [9, 0, 0],
        ] {
            assert!(read(&[bad]).is_none(), "{bad:?}");
        }
    }
}
