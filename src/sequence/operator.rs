//! The run's global-line interreflection operator ([`Transport`]), read from the cache
//! when a run with the same geometry, glazing, sensors and operator parameters stored it,
//! built and stored otherwise. Like the projections it holds no reflectance, emission,
//! site or weather, so those changes reuse it.

use crate::cache::{self, RecordKey, Section, Store, FIRST_USER_TAG, KIND_TRANSPORT};
use crate::projection::ProjectionParams;
use crate::radiosity::transport::SparseArrays;
use crate::radiosity::{Transport, TransportParams, TransportStats};
use crate::scene::Scene;
use crate::trace::Tracer;

/// Section tags: stats, then per part p and matrix m three arrays (offsets, columns,
/// values: one f32 per column when the matrix is grey, else three) at `TAG_PARTS + 16 p + 4 m + {0, 1, 2}`.
const TAG_STATS: u32 = FIRST_USER_TAG;
const TAG_PARTS: u32 = FIRST_USER_TAG + 0x100;

/// Version of what an operator record holds, hashed into its key: bumped when the
/// operator's content changes for the same scene and parameters, so older operators are
/// rebuilt rather than reused. 2: glazing reflects specularly (Radiance `glass`). 3: grey
/// matrices store one value per entry.
pub const OPERATOR_VERSION: u32 = 3;

/// The cache key of `scene`'s operator for `params` (what its daylight coefficients are
/// keyed by, with the reflectances).
pub fn key(scene: &Scene, params: &TransportParams) -> RecordKey {
    let mut extra = b"transport operator v".to_vec();
    extra.extend_from_slice(&OPERATOR_VERSION.to_le_bytes());
    extra.extend(serde_json::to_vec(params).expect("parameters serialise"));
    RecordKey {
        scene: cache::scene_hash(scene, &ProjectionParams::default(), &extra),
        kind: KIND_TRANSPORT,
        direction: 0,
        resolution: 0,
    }
}

/// The operator of `scene` for its sensors, and whether it came from the cache; built
/// through `tracer` (the run's ray caster over `scene`) when not.
pub fn transport(
    scene: &Scene,
    params: &TransportParams,
    store: &Store,
    tracer: &Tracer,
) -> (Transport, bool) {
    let k = key(scene, params);
    if let Some(r) = store.get(&k) {
        if let Some(t) = decode(scene, params, &r) {
            return (t, true);
        }
    }
    let t = Transport::build_with(scene, &scene.sensors, params, tracer);
    if store.is_enabled() {
        let stats = stats_of(&t);
        let parts = t.export();
        store.put_sections(&k, &sections(&stats, &parts));
    }
    (t, false)
}

fn stats_of(t: &Transport) -> [f64; 3] {
    [
        t.stats.lines as f64,
        t.stats.links as f64,
        t.stats.sensor_rays as f64,
    ]
}

/// The operator's record sections, borrowing its arrays (written as they lie).
fn sections<'a>(
    stats: &'a [f64; 3],
    parts: &'a [[crate::radiosity::transport::SparseSlices<'a>; 4]],
) -> Vec<Section<'a>> {
    let mut sections = vec![Section::f64s(TAG_STATS, stats)];
    for (p, mats) in parts.iter().enumerate() {
        for (m, (o, c, v)) in mats.iter().enumerate() {
            let tag = TAG_PARTS + 16 * p as u32 + 4 * m as u32;
            sections.push(Section::u32s(tag, o));
            sections.push(Section::u32s(tag + 1, c));
            sections.push(Section::of(tag + 2, v));
        }
    }
    sections
}

fn decode(scene: &Scene, params: &TransportParams, r: &cache::MappedRecord) -> Option<Transport> {
    let stats = r.f64s(TAG_STATS).ok()?;
    let [lines, links, rays] = stats else {
        return None;
    };
    let n = params.parts.max(2) as usize;
    let mut parts = Vec::with_capacity(n);
    for p in 0..n {
        let mut mats: [SparseArrays; 4] = Default::default();
        for (m, slot) in mats.iter_mut().enumerate() {
            let tag = TAG_PARTS + 16 * p as u32 + 4 * m as u32;
            *slot = (
                r.u32s(tag).ok()?.to_vec(),
                r.u32s(tag + 1).ok()?.to_vec(),
                r.section::<f32>(tag + 2).ok()?.to_vec(),
            );
        }
        parts.push(mats);
    }
    let stats = TransportStats {
        lines: *lines as u64,
        links: *links as u64,
        sensor_rays: *rays as u64,
        ..TransportStats::default()
    };
    Transport::import(scene, &scene.sensors, params, &parts, stats)
}
