//! A day's sky cuts as a cache record, so that a warm annual run by daylight coefficients
//! does only the sums. Cutting each lit step's Perez sky (about 1 850 evaluations of the
//! distribution, at both the run's quality and the error estimate's coarser one) was a
//! third of a warm office year's work, repeated on every run over the same weather.
//!
//! A record holds, per step of one day, what the sums read of its cuts and nothing more:
//! each node's key and its grey radiances as the f32 the sums weight with (node, four
//! children, L̂·ω), and the snapped sun exactly. Steps are summed from this form whether
//! it was read or just cut ([`canonical`]), so a warm run writes the same bits as a cold
//! one. The key hashes what a cut depends on ([`super::cuts::hash_context`] at both
//! qualities, and each of the day's records' time, sky and missing flag), never the
//! geometry, so a design change reuses the day's cuts.
//!
//! A record is trusted only when it decodes to the day's own layout and, for one lit step
//! of the day, equals that step's cut made again; otherwise the day is cut again and the
//! record rewritten.

use super::config::{Quality, SkySpec};
use super::cuts::{encode_key, hash_context, hash_step};
use super::sky::SkySources;
use super::step::StepTime;
use crate::cache::{self, MappedRecord, RecordKey, SceneHash, Section, FIRST_USER_TAG};
use crate::photometry::Rgb;
use crate::scene::Scene;
use crate::sources::{node_source, SkyNodeKey, Source, SourceKey, SunKey};
use glam::DVec3;
use std::collections::hash_map::Entry;
use std::collections::HashMap;

/// Per step: flags ([`LIT`], [`FINE_SUN`], [`COARSE_SUN`], [`SNAP`], [`COARSE`]), the
/// fine and the coarse cut's other nodes, negligible nodes, and the fine and the coarse
/// cut's uniform ground (1 + its index in [`TAG_GROUND_LENS`], 0 for none).
const TAG_HEAD: u32 = FIRST_USER_TAG;
/// One [`SkyNodeKey::id`] per node that is not in a uniform ground: each lit step's fine
/// nodes, then its coarse ones.
const TAG_IDS: u32 = FIRST_USER_TAG + 1;
/// Per node, as [`TAG_IDS`]: grey radiance of the node and of its four children.
const TAG_WEIGHTS: u32 = FIRST_USER_TAG + 2;
/// Per sun (each step's fine, then coarse): its key ([`encode_key`]), normal irradiance
/// and true direction, as f64 bits.
const TAG_SUNS: u32 = FIRST_USER_TAG + 3;
/// Per step with a snapped sun: the snapping angle, degrees.
const TAG_SNAPS: u32 = FIRST_USER_TAG + 4;
/// The distinct node lists of the uniform grounds, concatenated ids (every step's cut
/// has the same few hundred ground nodes, each with the step's one radiance).
const TAG_GROUND_IDS: u32 = FIRST_USER_TAG + 5;
/// Length of each list in [`TAG_GROUND_IDS`].
const TAG_GROUND_LENS: u32 = FIRST_USER_TAG + 6;
/// Per uniform ground (each step's fine, then coarse): its grey radiance.
const TAG_GROUND_L: u32 = FIRST_USER_TAG + 7;

const LIT: u64 = 1;
const FINE_SUN: u64 = 2;
const COARSE_SUN: u64 = 4;
const SNAP: u64 = 8;
const COARSE: u64 = 16;

/// Node ids carry the face in the top byte ([`SkyNodeKey::id`]).
const PATH_BITS: u32 = 56;

/// The record key of one day's cuts: `steps` are every record of the day in order, each
/// `None` where the step has no daylight (night or missing), `fine` and `coarse` the two
/// cuts' qualities (no coarse cut when `None`).
pub(super) fn record_key(
    scene: &Scene,
    fine: &Quality,
    coarse: Option<&Quality>,
    steps: &[Option<(StepTime, SkySpec)>],
) -> RecordKey {
    let mut h = blake3::Hasher::new();
    h.update(b"daystep day cuts v1\0");
    hash_context(&mut h, scene, fine);
    match coarse {
        Some(q) => {
            h.update(b"coarse\0");
            hash_context(&mut h, scene, q);
        }
        None => {
            h.update(b"no coarse\0");
        }
    }
    h.update(&(steps.len() as u64).to_le_bytes());
    for s in steps {
        match s {
            Some((at, spec)) => {
                h.update(&[1]);
                hash_step(&mut h, at, spec);
            }
            None => {
                h.update(&[0]);
            }
        }
    }
    RecordKey {
        scene: SceneHash(*h.finalize().as_bytes()),
        kind: cache::KIND_DAY_CUTS,
        direction: 0,
        resolution: 0,
    }
}

/// A grey radiance as the sums read it ([`super::coefficients`] weights with its green
/// channel as f32), back as a grey colour.
fn grey32(v: Rgb) -> Rgb {
    Rgb::splat(v.y as f32 as f64)
}

/// A node's L̂·ω from its canonical radiance `l` and solid angle, canonical too.
fn irradiance(l: Rgb, solid_angle: f64) -> Rgb {
    grey32(l * solid_angle)
}

/// A node's L̂·ω as the sums read it: from its radiance in [`canonical`] form, whether or
/// not `src` is in that form.
pub(super) fn node_irradiance(src: &Source) -> Rgb {
    irradiance(grey32(src.radiance), src.solid_angle)
}

/// `s` in the form a record holds: every node's radiances grey at f32, and its L̂·ω made
/// from them. The sums read nothing else of a node, and these values differ from the
/// cut's by an f32 rounding at most; it makes a step summed from its fresh cut and one
/// summed from the record the same bits. The sun is kept exactly.
pub(super) fn canonical(s: &mut SkySources) {
    for src in s.sources.iter_mut().chain(s.coarse.iter_mut().flatten()) {
        if !src.is_sun() {
            src.radiance = grey32(src.radiance);
            src.child_radiance = src.child_radiance.map(grey32);
            src.normal_irradiance = node_irradiance(src);
        }
    }
}

/// Sections being gathered for a record.
#[derive(Default)]
struct Flat {
    head: Vec<[u64; 6]>,
    ids: Vec<u64>,
    weights: Vec<[f32; 5]>,
    suns: Vec<[u64; 9]>,
    snaps: Vec<f64>,
    ground_lists: HashMap<Vec<u64>, usize>,
    ground_ids: Vec<u64>,
    ground_lens: Vec<u64>,
    ground_l: Vec<f32>,
}

/// The id of a sky or ground node, when a record can hold it.
fn node_id(s: &Source) -> Option<u64> {
    match s.key {
        SourceKey::Sky(k) | SourceKey::Ground(k) if k.path >> PATH_BITS == 0 => Some(k.id()),
        _ => None,
    }
}

impl Flat {
    /// Appends a cut's nodes: returns how many are held one by one, the index + 1 of its
    /// uniform ground (0: none) and its sun (last, when it is one); `None` when a source
    /// cannot be held (the day is then not stored).
    fn cut<'a>(&mut self, cut: &'a [Source]) -> Option<(usize, u64, Option<&'a Source>)> {
        let (nodes, sun) = match cut.split_last() {
            Some((last, rest)) if last.is_sun() => (rest, Some(last)),
            _ => (cut, None),
        };
        // A uniform ground: a last run of ground nodes, the only ones, all of one
        // radiance on the node and on every child.
        let is_ground = |s: &Source| matches!(s.key, SourceKey::Ground(_));
        let first = nodes.iter().position(is_ground).unwrap_or(nodes.len());
        let ground = &nodes[first..];
        let uniform = ground.first().is_some_and(|g0| {
            ground.iter().all(|s| {
                is_ground(s)
                    && s.radiance == g0.radiance
                    && s.child_radiance.iter().all(|c| *c == g0.radiance)
            })
        });
        let (single, ground_index) = if uniform {
            let ids = ground.iter().map(node_id).collect::<Option<Vec<u64>>>()?;
            let next = self.ground_lists.len();
            let index = *self.ground_lists.entry(ids).or_insert_with_key(|ids| {
                self.ground_ids.extend_from_slice(ids);
                self.ground_lens.push(ids.len() as u64);
                next
            });
            self.ground_l.push(ground[0].radiance.y as f32);
            (&nodes[..first], index as u64 + 1)
        } else {
            (nodes, 0)
        };
        for s in single {
            self.ids.push(node_id(s)?);
            let c = s.child_radiance.map(|c| c.y as f32);
            self.weights
                .push([s.radiance.y as f32, c[0], c[1], c[2], c[3]]);
        }
        Some((single.len(), ground_index, sun))
    }

    fn sun(&mut self, s: &Source) -> Option<()> {
        if !matches!(s.key, SourceKey::Sun(_)) {
            return None;
        }
        let k = encode_key(&s.key);
        let b = |v: DVec3| v.to_array().map(f64::to_bits);
        let (e, d) = (b(s.normal_irradiance), b(s.true_direction));
        self.suns
            .push([k[0], k[1], k[2], e[0], e[1], e[2], d[0], d[1], d[2]]);
        Some(())
    }
}

/// The record of a day's cuts, `steps` in the day's order (`None` without daylight), each
/// in [`canonical`] form; `None` when a cut holds what a record cannot (such a day is
/// simply not stored).
pub(super) fn encode(key: &RecordKey, steps: &[Option<&SkySources>]) -> Option<Vec<u8>> {
    let mut f = Flat::default();
    for s in steps {
        let Some(s) = s else {
            f.head.push([0; 6]);
            continue;
        };
        let (n_fine, fine_ground, fine_sun) = f.cut(&s.sources)?;
        let (n_coarse, coarse_ground, coarse_sun) = match &s.coarse {
            Some(c) => f.cut(c)?,
            None => (0, 0, None),
        };
        let mut flags = LIT;
        if let Some(sun) = fine_sun {
            f.sun(sun)?;
            flags |= FINE_SUN;
        }
        if let Some(sun) = coarse_sun {
            f.sun(sun)?;
            flags |= COARSE_SUN;
        }
        if let Some(a) = s.sun_snapping_deg {
            f.snaps.push(a);
            flags |= SNAP;
        }
        if s.coarse.is_some() {
            flags |= COARSE;
        }
        f.head.push([
            flags,
            n_fine as u64,
            n_coarse as u64,
            s.negligible as u64,
            fine_ground,
            coarse_ground,
        ]);
    }
    Some(cache::encode(
        key,
        &[
            Section::of(TAG_HEAD, &f.head),
            Section::of(TAG_IDS, &f.ids),
            Section::of(TAG_WEIGHTS, &f.weights),
            Section::of(TAG_SUNS, &f.suns),
            Section::f64s(TAG_SNAPS, &f.snaps),
            Section::of(TAG_GROUND_IDS, &f.ground_ids),
            Section::of(TAG_GROUND_LENS, &f.ground_lens),
            Section::of(TAG_GROUND_L, &f.ground_l),
        ],
    ))
}

/// Node `id` as a source without radiance, when it is one a cut could hold.
fn node(id: u64) -> Option<Source> {
    let (base, path) = ((id >> PATH_BITS) as u8, id & ((1 << PATH_BITS) - 1));
    (base < 8 && path != 0).then(|| node_source(SkyNodeKey { base, path }))
}

/// A node with canonical radiances `l` (node) and `children`.
fn lit(mut s: Source, l: f32, children: [f32; 4]) -> Source {
    s.radiance = Rgb::splat(l as f64);
    s.child_radiance = children.map(|c| Rgb::splat(c as f64));
    s.normal_irradiance = irradiance(s.radiance, s.solid_angle);
    s
}

/// Reads sections in order, refusing anything out of bounds.
struct Reader<'a> {
    ids: &'a [u64],
    weights: &'a [[f32; 5]],
    suns: &'a [[u64; 9]],
    snaps: &'a [f64],
    ground_l: &'a [f32],
    /// The uniform grounds' node lists, without radiance.
    grounds: Vec<Vec<Source>>,
    /// Each node met so far, without radiance: a day's cuts share most of their nodes,
    /// and working out a node's geometry (vertices, solid angle) for every step and
    /// level was about 2 % of a warm year's CPU.
    seen: HashMap<u64, Source, ahash::RandomState>,
}

impl Reader<'_> {
    /// A cut's nodes: `n` held one by one, then the uniform ground `ground` (0: none).
    fn nodes(&mut self, n: usize, ground: u64) -> Option<Vec<Source>> {
        if n > self.ids.len() || n > self.weights.len() {
            return None;
        }
        let (ids, rest) = self.ids.split_at(n);
        let (ws, wrest) = self.weights.split_at(n);
        self.ids = rest;
        self.weights = wrest;
        let g = match ground {
            0 => None,
            i => Some(self.grounds.get(usize::try_from(i - 1).ok()?)?),
        };
        // Room for the sun too.
        let mut out = Vec::with_capacity(n + g.map_or(0, Vec::len) + 1);
        for (&id, w) in ids.iter().zip(ws) {
            if w.iter().any(|x| !x.is_finite()) {
                return None;
            }
            let s = match self.seen.entry(id) {
                Entry::Occupied(e) => *e.get(),
                Entry::Vacant(e) => *e.insert(node(id)?),
            };
            out.push(lit(s, w[0], [w[1], w[2], w[3], w[4]]));
        }
        if let Some(g) = g {
            let (&l, rest) = self.ground_l.split_first()?;
            self.ground_l = rest;
            if !l.is_finite() {
                return None;
            }
            out.extend(g.iter().map(|s| lit(*s, l, [l; 4])));
        }
        Some(out)
    }

    fn sun(&mut self) -> Option<Source> {
        let (w, rest) = self.suns.split_first()?;
        self.suns = rest;
        let v = |i: usize| DVec3::from_array([0, 1, 2].map(|j| f64::from_bits(w[i + j])));
        let (e, d) = (v(3), v(6));
        let (kind, band, packed) = (w[0], w[1], w[2]);
        if kind != 2 || !e.is_finite() || !d.is_finite() {
            return None;
        }
        let key = SunKey {
            band: band as u32 as i32,
            index: packed as u32 as i32,
            spacing_udeg: (packed >> 32) as u32,
        };
        if key.spacing_udeg == 0 {
            return None;
        }
        Some(Source {
            key: SourceKey::Sun(key),
            direction: key.direction(),
            normal_irradiance: e,
            radiance: Rgb::ZERO,
            child_radiance: [Rgb::ZERO; 4],
            solid_angle: 0.0,
            vertices: None,
            true_direction: d,
        })
    }
}

/// The day's cuts from record `r`: one entry per step of `lit` (the day's steps, true
/// where the step has daylight), `None` where it has none. `None` when the record does
/// not hold exactly that layout or holds anything a cut could not.
pub(super) fn decode(r: &MappedRecord, lit: &[bool]) -> Option<Vec<Option<SkySources>>> {
    let head = r.section::<[u64; 6]>(TAG_HEAD).ok()?;
    if head.len() != lit.len() {
        return None;
    }
    let mut ground_ids = r.section::<u64>(TAG_GROUND_IDS).ok()?;
    let mut grounds = Vec::new();
    for &len in r.section::<u64>(TAG_GROUND_LENS).ok()? {
        let len = usize::try_from(len)
            .ok()
            .filter(|&l| l <= ground_ids.len())?;
        let (ids, rest) = ground_ids.split_at(len);
        ground_ids = rest;
        let nodes = ids.iter().map(|&id| node(id)).collect::<Option<Vec<_>>>()?;
        if !nodes.iter().all(|s| matches!(s.key, SourceKey::Ground(_))) {
            return None;
        }
        grounds.push(nodes);
    }
    let mut rd = Reader {
        ids: r.section(TAG_IDS).ok()?,
        weights: r.section(TAG_WEIGHTS).ok()?,
        suns: r.section(TAG_SUNS).ok()?,
        snaps: r.section(TAG_SNAPS).ok()?,
        ground_l: r.section(TAG_GROUND_L).ok()?,
        grounds,
        seen: HashMap::default(),
    };
    let mut out = Vec::with_capacity(lit.len());
    for (&[flags, n_fine, n_coarse, negligible, fine_ground, coarse_ground], &is_lit) in
        head.iter().zip(lit)
    {
        if (flags & LIT != 0) != is_lit || flags >> 5 != 0 {
            return None;
        }
        if !is_lit {
            out.push(None);
            continue;
        }
        let mut sources = rd.nodes(usize::try_from(n_fine).ok()?, fine_ground)?;
        let mut coarse = rd.nodes(usize::try_from(n_coarse).ok()?, coarse_ground)?;
        if flags & FINE_SUN != 0 {
            sources.push(rd.sun()?);
        }
        if flags & COARSE_SUN != 0 {
            coarse.push(rd.sun()?);
        }
        let sun_snapping_deg = if flags & SNAP != 0 {
            let (&a, rest) = rd.snaps.split_first()?;
            rd.snaps = rest;
            Some(a)
        } else {
            None
        };
        out.push(Some(SkySources {
            sources,
            negligible: usize::try_from(negligible).ok()?,
            sun_snapping_deg,
            coarse: (flags & COARSE != 0).then_some(coarse),
        }));
    }
    let used = rd.ids.is_empty() && rd.weights.is_empty() && rd.suns.is_empty();
    (used && rd.snaps.is_empty() && rd.ground_l.is_empty() && ground_ids.is_empty()).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::super::sky::{build_sky, sources_with_coarse};
    use super::*;
    use crate::site::{solar_position::solar_position, Site};
    use chrono::{NaiveDate, TimeDelta};

    /// A June day at 45° N: night, then clear and overcast hours with and without sun.
    fn day() -> (Vec<Option<SkySources>>, Vec<bool>) {
        let (fine, coarse) = (Quality::preset("default").unwrap(), None::<Quality>);
        let coarse = coarse.unwrap_or_else(|| fine.coarser());
        let site = Site {
            latitude: 45.0,
            longitude: 7.0,
            utc_offset_h: 1.0,
            elevation_m: 0.0,
        };
        let steps: Vec<Option<SkySources>> = [(3, 0.0, 0.0), (9, 600.0, 120.0), (13, 0.0, 250.0)]
            .into_iter()
            .map(|(h, dni, dhi)| {
                let local = NaiveDate::from_ymd_opt(2021, 6, 21)
                    .unwrap()
                    .and_hms_opt(h, 30, 0)
                    .unwrap();
                let sun = solar_position((local - TimeDelta::hours(1)).and_utc(), &site);
                if dni + dhi <= 0.0 {
                    return None;
                }
                let spec = SkySpec::Perez {
                    dni,
                    dhi,
                    dew_point_c: Some(10.0),
                };
                let sky = build_sky(&spec, &sun, 172, 0.2).unwrap();
                let mut s = sources_with_coarse(&sky, &fine, &coarse);
                canonical(&mut s);
                Some(s)
            })
            .collect();
        let lit = steps.iter().map(Option::is_some).collect();
        (steps, lit)
    }

    fn key() -> RecordKey {
        RecordKey {
            scene: SceneHash([7; 32]),
            kind: cache::KIND_DAY_CUTS,
            direction: 0,
            resolution: 0,
        }
    }

    #[test]
    fn a_day_reads_back_as_its_canonical_cuts_to_the_bit() {
        let (steps, lit) = day();
        let clear = steps[1].as_ref().unwrap();
        assert!(clear.sources.last().unwrap().is_sun());
        assert!(
            clear
                .sources
                .iter()
                .any(|s| matches!(s.key, SourceKey::Ground(_))),
            "a ground to hold as one list"
        );
        let refs: Vec<Option<&SkySources>> = steps.iter().map(Option::as_ref).collect();
        let bytes = encode(&key(), &refs).unwrap();
        let back = decode(&MappedRecord::from_bytes(&bytes, &key()).unwrap(), &lit).unwrap();
        for (a, b) in steps.iter().zip(&back) {
            assert_eq!(a, b);
        }
        // Canonical twice is canonical once.
        let held = back[1].as_ref().unwrap();
        let mut again = SkySources {
            sources: held.sources.clone(),
            coarse: held.coarse.clone(),
            ..*held
        };
        canonical(&mut again);
        assert_eq!(again.sources, held.sources);
        assert_eq!(again.coarse, held.coarse);
    }

    #[test]
    fn a_record_of_another_layout_or_cut_short_is_refused() {
        let (steps, lit) = day();
        let refs: Vec<Option<&SkySources>> = steps.iter().map(Option::as_ref).collect();
        let bytes = encode(&key(), &refs).unwrap();
        let r = MappedRecord::from_bytes(&bytes, &key()).unwrap();
        assert!(
            decode(&r, &[true, true, true]).is_none(),
            "a dark step read as lit"
        );
        assert!(decode(&r, &lit[..2]).is_none(), "a step too many");
        // Every section as it is, but the nodes' ids and weights.
        let with = |ids: &[u64], weights: &[[f32; 5]]| {
            let bytes = cache::encode(
                &key(),
                &[
                    Section::of(TAG_HEAD, r.section::<[u64; 6]>(TAG_HEAD).unwrap()),
                    Section::of(TAG_IDS, ids),
                    Section::of(TAG_WEIGHTS, weights),
                    Section::of(TAG_SUNS, r.section::<[u64; 9]>(TAG_SUNS).unwrap()),
                    Section::f64s(TAG_SNAPS, r.f64s(TAG_SNAPS).unwrap()),
                    Section::of(TAG_GROUND_IDS, r.section::<u64>(TAG_GROUND_IDS).unwrap()),
                    Section::of(TAG_GROUND_LENS, r.section::<u64>(TAG_GROUND_LENS).unwrap()),
                    Section::of(TAG_GROUND_L, r.section::<f32>(TAG_GROUND_L).unwrap()),
                ],
            );
            decode(&MappedRecord::from_bytes(&bytes, &key()).unwrap(), &lit)
        };
        let ids = r.section::<u64>(TAG_IDS).unwrap();
        let weights = r.section::<[f32; 5]>(TAG_WEIGHTS).unwrap();
        assert!(with(ids, weights).is_some(), "the record as written");
        // One node fewer than the heads say.
        assert!(with(&ids[..ids.len() - 1], &weights[..weights.len() - 1]).is_none());
        // A weight that is not a number.
        let mut bad = weights.to_vec();
        bad[3][1] = f32::NAN;
        assert!(with(ids, &bad).is_none());
        // A node id no cut holds (path 0).
        let mut foreign = ids.to_vec();
        foreign[0] &= !((1 << PATH_BITS) - 1);
        assert!(with(&foreign, weights).is_none());
    }
}
