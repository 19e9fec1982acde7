//! Per-direction data of a run: each source direction's projection record (which elements
//! its parallel beam reaches, with what weight) and every sensor's geometry-only response
//! to it. Both depend on geometry, glazing, sensors and parameters only, so they are read
//! from the on-disk cache ([`crate::cache`]) when present and computed and stored
//! otherwise. Within a run a projected direction is also kept in memory from its second
//! use, so a sequence computes a recurring direction at most twice (once, when the disk
//! cache is on) and a single step keeps none: an instant's 752 directions held 310 MB of
//! leaves on the generated building.

use super::config::Quality;
use crate::cache::{self, MappedRecord, RecordKey, SceneHash, Section, Store, FIRST_USER_TAG};
use crate::photometry::Rgb;
use crate::projection::{self, DirectionRecord, ProjectionScene};
use crate::scene::Scene;
use crate::sensors::{node_response, sun_response, NodeResponse};
use crate::sources::{Source, SourceKey};
use crate::trace::Tracer;
use rayon::prelude::*;
use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Version of what a direction record holds, hashed into its key. 2: a source's LDI keeps
/// one face of a two-sided surface ([`projection::Reader::Source`]), so where two faces
/// meet at a pixel's line, one turned away from the source no longer hides the other.
pub(crate) const DIRECTIONS_VERSION: u32 = 2;

/// Section tag of a sky or ground node's per-sensor responses: 16 f64 per sensor (4
/// children × RGB, then 4 uncertainties). Suns use [`TAG_SUN_SENSORS`]; in memory a sun's
/// child 0 holds the transmission and child 1's first value is 1 when the ray crossed
/// glazing.
const TAG_SENSORS: u32 = FIRST_USER_TAG;
const PER_SENSOR: usize = 16;
/// Section tag of a sun direction's responses: 9 f64 per sensor (transmission RGB; 1 when
/// the ray crossed glazing; the number of panes listed, 0 when more than
/// [`MAX_SUN_PANES`]; up to 4 pane triangle indices). A year meets thousands of sun cells, so they are kept
/// small.
const TAG_SUN_SENSORS: u32 = FIRST_USER_TAG + 2;
/// Values a sun's response keeps per sensor ([`TAG_SUN_SENSORS`]).
pub(super) const PER_SUN_SENSOR: usize = 9;
/// Panes a sun ray's record lists (more: τ at the true angle is found by a new ray).
const MAX_SUN_PANES: usize = 4;

/// What one direction yields.
#[derive(Clone, Debug, Default)]
pub struct DirectionData {
    /// The projection: lit leaves and their transfer weights.
    pub record: DirectionRecord,
    /// Per sensor (in order), its response ([`NodeResponse`]; for the sun, the
    /// transmission in `child[0]`).
    pub sensors: Vec<NodeResponse>,
    /// Rays cast for the sensor responses (0 when read from the cache).
    pub rays: u64,
}

/// Counters of a run's direction lookups.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct DirectionCounts {
    /// Directions computed (projection + sensor responses).
    pub built: u64,
    /// Directions read from the on-disk cache.
    pub from_cache: u64,
    /// Directions found in this run's memory (a sequence's repeated directions).
    pub reused: u64,
}

/// Directions kept in a run's memory, and those met once (kept from their next use).
#[derive(Default)]
struct Memo {
    kept: HashMap<(SourceKey, u32), Arc<DirectionData>, ahash::RandomState>,
    seen: HashSet<(SourceKey, u32), ahash::RandomState>,
}

/// The per-direction data of one scene and quality, cached on disk and in memory.
pub struct Directions<'a> {
    scene: &'a Scene,
    /// The scene as projections see it; `None` when directions are not projected (sensor
    /// responses only, for the coarser level of the error estimate, which reads no
    /// projection).
    pscene: Option<ProjectionScene>,
    vis: Arc<Tracer>,
    store: &'a Store,
    hash: SceneHash,
    quality: Quality,
    memo: Mutex<Memo>,
    built: AtomicU64,
    from_cache: AtomicU64,
    reused: AtomicU64,
}

impl<'a> Directions<'a> {
    /// Prepares lookups for `scene` at `quality` through `store` (use
    /// [`Store::disabled`] for no disk cache), casting rays with `tracer` (the run's one
    /// BVH over `scene`).
    pub fn new(
        scene: &'a Scene,
        quality: &Quality,
        store: &'a Store,
        tracer: Arc<Tracer>,
    ) -> Directions<'a> {
        Directions::with(scene, quality, store, tracer, true)
    }

    /// As [`Self::new`], computing and caching only the sensor responses (each record's
    /// projection is left empty): what the error estimate's coarser level needs.
    pub fn sensors_only(
        scene: &'a Scene,
        quality: &Quality,
        store: &'a Store,
        tracer: Arc<Tracer>,
    ) -> Directions<'a> {
        Directions::with(scene, quality, store, tracer, false)
    }

    fn with(
        scene: &'a Scene,
        quality: &Quality,
        store: &'a Store,
        tracer: Arc<Tracer>,
        project: bool,
    ) -> Directions<'a> {
        let s = &quality.sensors;
        let mut extra = Vec::new();
        if !project {
            // Records without projections must not serve a run that reads them.
            extra.extend_from_slice(b"sensors only");
        }
        extra.extend_from_slice(&DIRECTIONS_VERSION.to_le_bytes());
        extra.extend_from_slice(&s.visibility_depth.to_le_bytes());
        extra.extend_from_slice(&s.visibility_tolerance.to_bits().to_le_bytes());
        extra.extend_from_slice(&s.sample_angle_deg.to_bits().to_le_bytes());
        Directions {
            scene,
            pscene: project
                .then(|| ProjectionScene::with_region(scene, quality.projection.margin_m)),
            vis: tracer,
            store,
            hash: cache::scene_hash(scene, &quality.projection, &extra),
            quality: *quality,
            memo: Mutex::new(Memo::default()),
            built: AtomicU64::new(0),
            from_cache: AtomicU64::new(0),
            reused: AtomicU64::new(0),
        }
    }

    /// The cache store the directions go through.
    pub fn store(&self) -> &Store {
        self.store
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        self.scene
    }

    /// The run's ray caster over the scene.
    pub fn tracer(&self) -> &Tracer {
        &self.vis
    }

    /// Transmission (RGB) from sensor `k` towards the sun `source`: the cached response,
    /// with glazing τ(θ) re-evaluated at the true (unsnapped) sun direction.
    pub fn sun_transmission(&self, k: usize, source: &Source, response: &NodeResponse) -> Rgb {
        if response.child[1].x <= 0.0 {
            return response.child[0];
        }
        let n = response.child[1].y as usize;
        if (1..=MAX_SUN_PANES).contains(&n) {
            // The panes the snapped ray crosses, cached: τ at the true angle, no new ray.
            let ids = [
                response.child[2].x,
                response.child[2].y,
                response.child[2].z,
                response.child[3].x,
            ];
            let panes: Vec<u32> = ids[..n].iter().map(|&v| v as u32).collect();
            return self.vis.transmission_through(&panes, source.true_direction);
        }
        let s = &self.scene.sensors[k];
        self.vis
            .transmission_for(s.position, source.direction, source.true_direction)
    }

    /// The quality these directions are computed at.
    pub fn quality(&self) -> &Quality {
        &self.quality
    }

    /// The counters so far.
    pub fn counts(&self) -> DirectionCounts {
        DirectionCounts {
            built: self.built.load(Ordering::Relaxed),
            from_cache: self.from_cache.load(Ordering::Relaxed),
            reused: self.reused.load(Ordering::Relaxed),
        }
    }

    /// The data of every source (in order), at its kind's LDI resolution
    /// ([`crate::projection::ProjectionParams::resolution_for`]); missing directions are
    /// computed in parallel.
    pub fn get_all(&self, sources: &[Source]) -> Vec<Arc<DirectionData>> {
        sources
            .par_iter()
            .map(|s| {
                let res = self.quality.projection.resolution_for(s.is_sun());
                self.get(s, res)
            })
            .collect()
    }

    /// The data of one source at LDI resolution `resolution`: kept in this run's memory
    /// from its second request (sensors-only directions, which hold no projection, from
    /// their first).
    pub fn get(&self, source: &Source, resolution: u32) -> Arc<DirectionData> {
        let id = (source.key, resolution);
        let keep = {
            let mut m = self.memo.lock().expect("memo lock");
            if let Some(d) = m.kept.get(&id) {
                self.reused.fetch_add(1, Ordering::Relaxed);
                return d.clone();
            }
            self.pscene.is_none() || !m.seen.insert(id)
        };
        let data = Arc::new(self.fetch(source, resolution));
        if !keep {
            return data;
        }
        self.memo
            .lock()
            .expect("memo lock")
            .kept
            .entry(id)
            .or_insert(data)
            .clone()
    }

    /// As [`Self::get`], without keeping the data in this run's memory (read from the
    /// disk cache, or computed and stored): for directions a run meets once.
    pub fn fetch(&self, source: &Source, resolution: u32) -> DirectionData {
        let key = RecordKey::for_source(self.hash, source.key, resolution);
        let from_disk = key
            .as_ref()
            .and_then(|k| self.store.get(k))
            .and_then(|r| self.decode(&r, source.vertices.is_none()));
        let data = match from_disk {
            Some(d) => {
                self.from_cache.fetch_add(1, Ordering::Relaxed);
                d
            }
            None => {
                let d = self.compute(source, resolution);
                if let Some(k) = &key {
                    if self.store.is_enabled() {
                        let sun = source.vertices.is_none();
                        let flat = flatten(&d.sensors, sun);
                        let bytes = cache::encode_direction(
                            k,
                            &d.record,
                            &[Section::f64s(tag(sun), &flat)],
                        );
                        self.store.put(k, &bytes);
                    }
                }
                self.built.fetch_add(1, Ordering::Relaxed);
                d
            }
        };
        data
    }

    /// The sensors' responses to one source, read from the disk cache without decoding the
    /// projection (or computed and stored with it when missing); not kept in memory.
    pub fn sensor_responses(&self, source: &Source, resolution: u32) -> Vec<NodeResponse> {
        let cached = RecordKey::for_source(self.hash, source.key, resolution)
            .and_then(|k| self.store.get(&k))
            .and_then(|r| {
                r.f64s(tag(source.vertices.is_none()))
                    .ok()
                    .and_then(|f| unflatten(f, self.scene.sensors.len(), source.vertices.is_none()))
            });
        match cached {
            Some(s) => {
                self.from_cache.fetch_add(1, Ordering::Relaxed);
                s
            }
            None => self.fetch(source, resolution).sensors,
        }
    }

    /// The sensors' responses to each of `suns` (a day's snapped suns, in step order) at
    /// `resolution`, read from one cache record for them all, or computed and stored as
    /// one ([`super::day_suns`], sparse): a warm year then opens a record a day for its
    /// suns, where it opened one a sun (two thirds of the office's 12 000). They are not
    /// stored sun by sun: a year meets most snapped suns once, and a sun's responses are
    /// one ray per sensor, so the few a cold year meets again are cast again rather than
    /// kept twice on disk. With fewer than two suns, or no cache, as
    /// [`Self::sensor_responses`] one by one.
    pub fn day_sun_responses(&self, suns: &[&Source], resolution: u32) -> Vec<Vec<NodeResponse>> {
        let k = self.scene.sensors.len();
        let key = (suns.len() > 1 && k > 0 && self.store.is_enabled())
            .then(|| self.day_suns_key(suns, resolution))
            .flatten();
        let Some(key) = key else {
            return suns
                .iter()
                .map(|s| self.sensor_responses(s, resolution))
                .collect();
        };
        let cached = self
            .store
            .get(&key)
            .and_then(|r| super::day_suns::decode(&r, suns.len(), k));
        if let Some(c) = cached {
            self.from_cache
                .fetch_add(suns.len() as u64, Ordering::Relaxed);
            return c;
        }
        let made: Vec<Vec<NodeResponse>> = suns.par_iter().map(|s| self.responses(s).0).collect();
        self.built.fetch_add(suns.len() as u64, Ordering::Relaxed);
        self.store.put(&key, &super::day_suns::encode(&key, &made));
        made
    }

    /// The key of [`Self::day_sun_responses`]' record; `None` when a source is not a
    /// snapped sun with a lossless id.
    fn day_suns_key(&self, suns: &[&Source], resolution: u32) -> Option<RecordKey> {
        let mut h = blake3::Hasher::new();
        h.update(b"daystep day suns v1\0");
        h.update(&self.hash.0);
        h.update(&(suns.len() as u64).to_le_bytes());
        for s in suns {
            let SourceKey::Sun(sun) = s.key else {
                return None;
            };
            h.update(&cache::sun_direction_id(&sun)?.to_le_bytes());
        }
        Some(RecordKey {
            scene: SceneHash(*h.finalize().as_bytes()),
            kind: cache::KIND_DAY_SUNS,
            direction: 0,
            resolution,
        })
    }

    /// The hash of what these directions depend on (geometry, glazing, sensors,
    /// parameters): the `scene` of their record keys.
    pub fn hash(&self) -> SceneHash {
        self.hash
    }

    fn compute(&self, source: &Source, resolution: u32) -> DirectionData {
        let record = match &self.pscene {
            Some(p) if !self.scene.triangles.is_empty() => {
                projection::project(p, source.direction, resolution, &self.quality.projection)
            }
            _ => DirectionRecord::default(),
        };
        let (sensors, rays) = self.responses(source);
        DirectionData {
            record,
            sensors,
            rays,
        }
    }

    /// The sensors' responses to one source, computed now (no projection, no cache), and
    /// the rays they took: for nodes whose direct light is all a run needs of them.
    pub fn responses(&self, source: &Source) -> (Vec<NodeResponse>, u64) {
        let mut rays = 0;
        let sensors = self
            .scene
            .sensors
            .iter()
            .map(|s| match source.vertices {
                Some(tri) => {
                    let r = node_response(&self.vis, s, tri, &self.quality.sensors);
                    rays += r.rays;
                    r
                }
                None => {
                    rays += 1;
                    let mut r = NodeResponse::default();
                    let (t, glazed) = sun_response(&self.vis, s, source.direction);
                    r.child[0] = t;
                    r.child[1].x = if glazed { 1.0 } else { 0.0 };
                    if glazed {
                        if let Some(p) =
                            self.vis
                                .panes_along(s.position, source.direction, MAX_SUN_PANES)
                        {
                            r.child[1].y = p.len() as f64;
                            let mut ids = [0.0; MAX_SUN_PANES];
                            for (slot, id) in ids.iter_mut().zip(p) {
                                *slot = id as f64;
                            }
                            r.child[2] = Rgb::new(ids[0], ids[1], ids[2]);
                            r.child[3].x = ids[3];
                        }
                    }
                    r
                }
            })
            .collect();
        (sensors, rays)
    }

    /// A cached record, or `None` (counted as a rebuild by the store's validation when it
    /// is not ours) if its sections do not fit this scene.
    fn decode(&self, r: &MappedRecord, sun: bool) -> Option<DirectionData> {
        let record = cache::decode_direction(r).ok()?;
        let sensors = unflatten(r.f64s(tag(sun)).ok()?, self.scene.sensors.len(), sun)?;
        Some(DirectionData {
            record,
            sensors,
            rays: 0,
        })
    }
}

fn tag(sun: bool) -> u32 {
    if sun {
        TAG_SUN_SENSORS
    } else {
        TAG_SENSORS
    }
}

/// The responses of `n` sensors from their flat cached form (a sun's when `sun`); `None`
/// when it does not fit.
fn unflatten(flat: &[f64], n: usize, sun: bool) -> Option<Vec<NodeResponse>> {
    let per = if sun { PER_SUN_SENSOR } else { PER_SENSOR };
    if flat.len() != per * n {
        return None;
    }
    Some(
        flat.chunks_exact(per)
            .map(|c| {
                if sun {
                    return unflatten_sun(c);
                }
                let mut r = NodeResponse::default();
                for k in 0..4 {
                    r.child[k] = Rgb::new(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
                    r.uncertainty[k] = c[12 + k];
                }
                r
            })
            .collect(),
    )
}

/// A sun's response at one sensor as its [`PER_SUN_SENSOR`] cached values.
pub(super) fn flatten_sun(n: &NodeResponse) -> [f64; PER_SUN_SENSOR] {
    [
        n.child[0].x,
        n.child[0].y,
        n.child[0].z,
        n.child[1].x,
        n.child[1].y,
        n.child[2].x,
        n.child[2].y,
        n.child[2].z,
        n.child[3].x,
    ]
}

/// Inverse of [`flatten_sun`] (`c` holds [`PER_SUN_SENSOR`] values).
pub(super) fn unflatten_sun(c: &[f64]) -> NodeResponse {
    let mut r = NodeResponse::default();
    r.child[0] = Rgb::new(c[0], c[1], c[2]);
    r.child[1] = Rgb::new(c[3], c[4], 0.0);
    r.child[2] = Rgb::new(c[5], c[6], c[7]);
    r.child[3].x = c[8];
    r
}

fn flatten(sensors: &[NodeResponse], sun: bool) -> Vec<f64> {
    let per = if sun { PER_SUN_SENSOR } else { PER_SENSOR };
    let mut flat = Vec::with_capacity(per * sensors.len());
    for n in sensors {
        if sun {
            flat.extend_from_slice(&flatten_sun(n));
            continue;
        }
        for c in &n.child {
            flat.extend_from_slice(&c.to_array());
        }
        flat.extend_from_slice(&n.uncertainty);
    }
    flat
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::synthetic::{Face, Rect, SceneBuilder};
    use crate::sources::{node_source, SkyNodeKey};
    use glam::DVec3;

    /// A scene of one square floor `side` metres wide at z = 0, and its material.
    fn floor(side: f64) -> (SceneBuilder, u32) {
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("floor", 0.5);
        b.add_rect(
            "floor",
            m,
            Face::from_axis(2, true),
            0.0,
            Rect::new([0.0, side], [0.0, side]),
        );
        (b, m)
    }

    /// A projected direction is computed at its first two uses and kept from the second;
    /// a sensors-only one (no leaves to hold) is kept from the first.
    #[test]
    fn a_projected_direction_is_kept_from_its_second_use() {
        let (mut b, _) = floor(2.0);
        b.add_sensor(DVec3::new(1.0, 1.0, 0.5), DVec3::Z);
        let scene = b.build("one floor").unwrap();
        let q = Quality::preset("draft").unwrap();
        let store = Store::disabled();
        let tracer = Arc::new(Tracer::new(&scene));
        let src = node_source(SkyNodeKey::root(0));
        let res = q.projection.resolution_for(false);
        let count = |d: &Directions| {
            let c = d.counts();
            (c.built, c.reused)
        };
        let dirs = Directions::new(&scene, &q, &store, tracer.clone());
        let first = dirs.get(&src, res);
        assert!(!first.record.leaves.is_empty(), "the node lights the floor");
        assert_eq!(count(&dirs), (1, 0), "computed, not kept");
        dirs.get(&src, res);
        assert_eq!(count(&dirs), (2, 0), "computed again, kept");
        let third = dirs.get(&src, res);
        assert_eq!(count(&dirs), (2, 1), "from memory");
        assert_eq!(third.record.leaves.len(), first.record.leaves.len());
        let coarse = Directions::sensors_only(&scene, &q, &store, tracer);
        coarse.get(&src, res);
        coarse.get(&src, res);
        assert_eq!(count(&coarse), (1, 1));
    }

    /// A day's suns are read back as one record with the responses each sun gets alone,
    /// and a damaged record is cast again, never trusted.
    #[test]
    fn a_days_suns_are_one_record_equal_to_each_sun_alone() {
        use crate::sources::SunKey;
        let (mut b, m) = floor(4.0);
        // A wall that shades some sensors from some of the suns.
        b.add_rect(
            "wall",
            m,
            Face::from_axis(0, false),
            2.0,
            Rect::new([0.0, 4.0], [0.0, 3.0]),
        );
        for x in [0.5, 1.5, 2.5, 3.5] {
            b.add_sensor(DVec3::new(x, 2.0, 0.8), DVec3::Z);
        }
        let scene = b.build("floor and wall").unwrap();
        let q = Quality::preset("draft").unwrap();
        let folder = tempfile::tempdir().unwrap();
        let store = Store::open(folder.path(), cache::DEFAULT_MAX_BYTES);
        let tracer = Arc::new(Tracer::new(&scene));
        let sun = |alt: f64, az: f64| {
            let key = SunKey::snap(alt, az, 1.0);
            Source {
                key: SourceKey::Sun(key),
                direction: key.direction(),
                normal_irradiance: Rgb::splat(800.0),
                radiance: Rgb::ZERO,
                child_radiance: [Rgb::ZERO; 4],
                solid_angle: 0.0,
                vertices: None,
                true_direction: key.direction(),
            }
        };
        let suns = [sun(20.0, 80.0), sun(50.0, 180.0), sun(15.0, 280.0)];
        let refs: Vec<&Source> = suns.iter().collect();
        let res = q.projection.resolution_for(true);
        let dirs = Directions::sensors_only(&scene, &q, &store, tracer);
        let alone: Vec<Vec<NodeResponse>> = suns.iter().map(|s| dirs.responses(s).0).collect();
        let lit =
            |r: &[Vec<NodeResponse>]| r.iter().flatten().filter(|n| n.child[0].x > 0.0).count();
        let shaded = alone
            .iter()
            .flatten()
            .filter(|n| n.child[0].x == 0.0)
            .count();
        assert!(
            lit(&alone) > 0 && shaded > 0,
            "the wall shades some sensors"
        );
        let counts = |d: &Directions| (d.counts().built, d.counts().from_cache);
        let made = dirs.day_sun_responses(&refs, res);
        assert_eq!(made, alone);
        assert_eq!(counts(&dirs), (3, 0));
        let read = dirs.day_sun_responses(&refs, res);
        assert_eq!(read, alone);
        assert_eq!(counts(&dirs), (3, 3), "read as one record");
        assert_eq!(store.stats().hits, 1);
        // The suns in another order are another record.
        let swapped = [refs[1], refs[0], refs[2]];
        let other = dirs.day_sun_responses(&swapped, res);
        assert_eq!(other[0], alone[1]);
        assert_eq!(counts(&dirs), (6, 3));
        // A truncated record is rebuilt.
        for e in std::fs::read_dir(folder.path()).unwrap() {
            let p = e.unwrap().path();
            let len = std::fs::metadata(&p).unwrap().len();
            std::fs::OpenOptions::new()
                .write(true)
                .open(&p)
                .unwrap()
                .set_len(len - 8)
                .unwrap();
        }
        assert_eq!(dirs.day_sun_responses(&refs, res), alone);
        assert_eq!(counts(&dirs), (9, 3), "cast again");
    }
}
