//! Interreflected coefficients of deep sky and ground nodes taken from an ancestor.
//!
//! A year's adaptive cuts refine the sky where its radiance changes fast (around the sun,
//! at the horizon), for the direct light, and their union is mostly deep nodes: 1 164 of
//! the office year's 1 396 sky nodes are one or two levels below
//! [`crate::sequence::config::Quality::indirect_depth`]. Each node's interreflected
//! coefficients cost a projection and its mesh weights, about half a cold year. But
//! interreflected light is smooth in direction: it reaches a sensor from the patches the
//! node lights, and those move little between neighbouring nodes. So a node deeper than
//! the depth takes its ancestor's at that depth (per W/m² of the node's own normal
//! irradiance); its direct light is still its own, from its sensor rays.
//!
//! The error this leaves is stated to first order: per sensor, the slope of the
//! interreflected coefficient around the ancestor (the largest change to one of its three
//! siblings over the angle between their centres) times the angle from the ancestor's
//! centre to the node's, times the node's irradiance; the step's nodes combined in
//! quadrature. The siblings, not the parent: a parent's middle child has its centre, so
//! their coefficients are equal whatever the slope.
//!
//! Measured on the office (`tests/coefficients.rs`, every sensor, four days at
//! `default`, depth 3): the sky part differs from every node solved by a median 0.33 %
//! (p95 3.1 %, max 4.9 %), and `lux_err` covers 99.97 % of sensor-steps; the year's
//! median stated error rises from 5.1 % to 5.8 %, its cold time falls by 29 % (paired).
//! Summed without signs the statement was looser (8.8 %); a signed first-order sum, with
//! the slope fitted as a vector, covered only 73 % (at depth 2), and correcting the value by that
//! slope made it worse: the interreflection is smooth in direction, not linear. At depth
//! 2 (22° ancestors) even the quadrature sum covered only 86 %, so `draft` keeps every
//! node.

use super::{direct_rows, mapped_rows, record_key, Directions, NodeData, DIRECT_ROWS, TAG_DIRECT};
use crate::cache::{self, SceneHash, Section};
use crate::radiosity::Buf;
use crate::scene::Scene;
use crate::sources::{node_source, SkyNodeKey, Source, SourceKey};
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap};

/// Which nodes get solved coefficients, and which inherit them.
pub(super) struct Plan {
    /// The nodes whose interreflected coefficients are computed: the union's sun-grid
    /// vertices and nodes at or above the depth, and the ancestors at the depth of deeper
    /// ones with their siblings; in key order.
    pub solved: Vec<Source>,
    /// The union's deeper nodes, each with its ancestor at the depth and that ancestor's
    /// three siblings, in the union's order.
    pub deep: Vec<(Source, SourceKey, [SourceKey; 3])>,
}

/// The node `key`'s ancestor at `depth` (≤ its own), as the same kind of key.
fn ancestor(key: SkyNodeKey, depth: u32) -> SkyNodeKey {
    let mut k = key;
    while k.depth() > depth {
        k = k.parent().expect("a node deeper than 0 has a parent");
    }
    k
}

fn wrap(like: &SourceKey, k: SkyNodeKey) -> SourceKey {
    match like {
        SourceKey::Ground(_) => SourceKey::Ground(k),
        _ => SourceKey::Sky(k),
    }
}

/// Splits the union `list` at `depth` (at least 1, so that an ancestor has siblings).
pub(super) fn plan(list: &[Source], depth: u32) -> Plan {
    let depth = depth.max(1);
    let mut solved: BTreeMap<SourceKey, Source> = BTreeMap::new();
    let mut deep = Vec::new();
    for src in list {
        let node = match src.key {
            SourceKey::Sky(k) | SourceKey::Ground(k) if k.depth() > depth => k,
            _ => {
                solved.insert(src.key, *src);
                continue;
            }
        };
        let a = ancestor(node, depth);
        let p = ancestor(a, depth - 1);
        let kids = [0, 1, 2, 3].map(|c| p.child(c));
        for k in kids {
            solved
                .entry(wrap(&src.key, k))
                .or_insert_with(|| node_source(k));
        }
        let mut sib = kids.iter().filter(|k| **k != a).map(|k| wrap(&src.key, *k));
        let sib = [0; 3].map(|_| sib.next().expect("three siblings"));
        deep.push((*src, wrap(&src.key, a), sib));
    }
    Plan {
        solved: solved.into_values().collect(),
        deep,
    }
}

/// The data of the deep node `node`: its own `direct` rows, its ancestor `a`'s
/// interreflected rows, and per sensor their stated error (interreflected lux per W/m²):
/// the largest of |mean over parts of `a` − that of a sibling| / (angle between their
/// centres), times the angle from `a`'s centre to the node's.
pub(super) fn inherit(
    node: &Source,
    direct: Buf<f32>,
    a: (&Source, &NodeData),
    siblings: [(&Source, &NodeData); 3],
    parts: usize,
) -> NodeData {
    let k = a.1.indirect.len() / (parts + 1);
    let mean = |nd: &NodeData, s: usize| -> f32 {
        (0..parts).map(|q| nd.indirect[q * k + s]).sum::<f32>() / parts as f32
    };
    let off = node.direction.angle_between(a.0.direction);
    // Per sibling: the angle from the node to the ancestor over that to the sibling.
    let scale = siblings.map(|(src, _)| (off / a.0.direction.angle_between(src.direction)) as f32);
    NodeData {
        direct,
        indirect: std::sync::Arc::clone(&a.1.indirect),
        direction_err: (0..k)
            .map(|s| {
                let m = mean(a.1, s);
                (0..3)
                    .map(|i| scale[i] * (m - mean(siblings[i].1, s)).abs())
                    .fold(0.0, f32::max)
            })
            .collect(),
    }
}

/// The direct rows of the `deep` nodes, in their order: from each node's coefficient
/// record, or from sensor rays alone (no projection), then recorded; read in place from
/// the record either way where the cache holds it (mapped whatever its size when `map`, [`cache::Store::get_mapped`]).
/// `res_of` gives a node's LDI resolution (part of its record's key).
pub(super) fn deep_direct(
    scene: &Scene,
    dirs: &Directions,
    hash: SceneHash,
    deep: &[(Source, SourceKey, [SourceKey; 3])],
    res_of: impl Fn(&Source) -> u32 + Sync,
    map: bool,
) -> Vec<Buf<f32>> {
    let k = scene.sensors.len();
    let store = dirs.store();
    let in_place = |r: Option<cache::MappedRecord>| {
        let r = std::sync::Arc::new(r?);
        let rows = mapped_rows(&r, TAG_DIRECT, DIRECT_ROWS * k);
        // Validating the record read every page: back to the kernel until a step reads
        // them.
        r.release();
        rows
    };
    deep.par_iter()
        .map(|(src, _, _)| {
            let key = record_key(hash, dirs, src, res_of(src));
            let cached = key
                .as_ref()
                .and_then(|key| in_place(store.get_mapped(key, map)));
            cached.unwrap_or_else(|| {
                let d = direct_rows(&dirs.responses(src).0, k);
                let stored = key.filter(|key| {
                    store.is_enabled() && store.put_sections(key, &[Section::of(TAG_DIRECT, &d)])
                });
                let stored = stored.filter(|_| map);
                stored
                    .and_then(|key| in_place(store.read_back_mapped(&key)))
                    .unwrap_or(d.into())
            })
        })
        .collect()
}

/// The union's nodes by key: a solved node's data (`solved`, in the order of `list`) as
/// it is, a deep node's (`deep`, with its `direct` rows in the same order) from its own
/// direct rows and its ancestors' interreflected ones ([`inherit`], shared, not copied).
pub(super) fn assemble(
    union: &[Source],
    list: &[Source],
    solved: Vec<NodeData>,
    deep: &[(Source, SourceKey, [SourceKey; 3])],
    direct: Vec<Buf<f32>>,
    parts: usize,
) -> Vec<(SourceKey, NodeData)> {
    let mut solved: HashMap<SourceKey, (&Source, NodeData)> = list
        .iter()
        .zip(solved)
        .map(|(src, d)| (src.key, (src, d)))
        .collect();
    let mut inherited: HashMap<SourceKey, NodeData> = {
        let get = |k: &SourceKey| (solved[k].0, &solved[k].1);
        deep.iter()
            .zip(direct)
            .map(|((src, a, sib), d)| {
                (
                    src.key,
                    inherit(src, d, get(a), sib.map(|k| get(&k)), parts),
                )
            })
            .collect()
    };
    union
        .iter()
        .map(|src| {
            let d = inherited
                .remove(&src.key)
                .or_else(|| solved.remove(&src.key).map(|(_, d)| d))
                .expect("a union node is solved or inherits");
            (src.key, d)
        })
        .collect()
}
