//! The run's global-line interreflection operator ([`Transport`]), read from the cache
//! when a run with the same geometry, glazing, sensors and operator parameters stored it,
//! built and stored otherwise. Like the projections it holds no reflectance, emission,
//! site or weather, so those changes reuse it.
//!
//! Each independent part is a record of its own, stored as soon as it is built and then
//! read back in place (memory-mapped): a cold build never holds more than the part in
//! progress, the stages after it keep only the part they read resident
//! ([`Transport::release_pages`]), and a build cut short keeps the parts it finished.

use crate::cache::{self, RecordKey, Section, Store, FIRST_USER_TAG, KIND_TRANSPORT};
use crate::projection::ProjectionParams;
use crate::radiosity::transport::{SparseBufs, TransportPart};
use crate::radiosity::{Buf, Transport, TransportParams};
use crate::scene::Scene;
use crate::trace::Tracer;
use std::sync::Arc;
use std::time::Instant;

/// Section tags of a part's record: its line count, then per matrix m (fine operator,
/// fine gather, coarse operator, coarse gather) three arrays (offsets, columns, values:
/// one f32 per column when the matrix is grey, else three) at `TAG_MATRICES + 4 m + {0,
/// 1, 2}`.
const TAG_LINES: u32 = FIRST_USER_TAG;
const TAG_MATRICES: u32 = FIRST_USER_TAG + 0x100;

/// Version of what an operator holds, hashed into its key: bumped when the operator's
/// content changes for the same scene and parameters, so older operators are rebuilt
/// rather than reused. 2: glazing reflects specularly (Radiance `glass`). 3: grey
/// matrices store one value per entry. (Since 2026-12-07 each part is a record of its
/// own, [`part_key`]; the content, and so the version, is the same.)
pub const OPERATOR_VERSION: u32 = 3;

/// The cache key of `scene`'s operator for `params`: what its daylight coefficients are
/// keyed by, with the reflectances, and what its parts' keys derive from.
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

/// The record key of part `p` of the operator keyed `operator`.
fn part_key(operator: &RecordKey, p: usize) -> RecordKey {
    RecordKey {
        direction: p as u64 + 1,
        ..*operator
    }
}

/// The operator of `scene` for its sensors, and whether it came from the cache (every
/// part); built through `tracer` (the run's ray caster over `scene`) where not.
pub fn transport(
    scene: &Scene,
    params: &TransportParams,
    store: &Store,
    tracer: &Tracer,
) -> (Transport, bool) {
    let t0 = Instant::now();
    let k = key(scene, params);
    let mut t = Transport::shell(scene, &scene.sensors, params);
    let shell = &t;
    let one = |p: usize| -> (TransportPart, bool) {
        let key = part_key(&k, p);
        if let Some(part) = store.get(&key).and_then(|r| decode(shell, r)) {
            return (part, true);
        }
        let built = shell.build_part(scene, &scene.sensors, tracer, p);
        if !store.is_enabled() {
            return (built, false);
        }
        let lines = [built.lines() as f64];
        if !store.put_sections(&key, &sections(&lines, &built.export())) {
            return (built, false);
        }
        // Read back in place, the same arrays: the built copy is freed first (else
        // both are resident while the record is validated).
        drop(built);
        match store.read_back(&key).and_then(|r| decode(shell, r)) {
            Some(part) => (part, false),
            // Gone already (evicted by a cache smaller than the operator, or removed
            // by another process): built again, the same part, and held.
            None => (shell.build_part(scene, &scene.sensors, tracer, p), false),
        }
    };
    // One part at a time, each with every thread on its lines: two parts side by side
    // each held their line lists (the build's largest holding) at once. Building-10k:
    // the build's peak 406–449 → 268 MB, its time the same (16.6 s against 15.7–18.4).
    // Parts are independent: the same whatever the order.
    let parts: Vec<(TransportPart, bool)> = (0..t.part_count()).map(one).collect();
    let cached = parts.iter().all(|p| p.1);
    let seconds = if cached {
        0.0
    } else {
        t0.elapsed().as_secs_f64()
    };
    t.set_parts(parts.into_iter().map(|p| p.0).collect(), seconds);
    (t, cached)
}

/// A part's record sections, borrowing its arrays (written as they lie).
fn sections<'a>(
    lines: &'a [f64; 1],
    mats: &[crate::radiosity::transport::SparseSlices<'a>; 4],
) -> Vec<Section<'a>> {
    let mut sections = vec![Section::f64s(TAG_LINES, lines)];
    for (m, (o, c, v)) in mats.iter().enumerate() {
        let tag = TAG_MATRICES + 4 * m as u32;
        sections.push(Section::u32s(tag, o));
        sections.push(Section::u32s(tag + 1, c));
        sections.push(Section::of(tag + 2, v));
    }
    sections
}

/// The part stored in `r` for the operator `shell`, its arrays read in place; the
/// record's pages, all read by its validation and checks, are given back.
fn decode(shell: &Transport, r: cache::MappedRecord) -> Option<TransportPart> {
    let r = Arc::new(r);
    let [lines] = *r.f64s(TAG_LINES).ok()? else {
        return None;
    };
    let mut mats: [SparseBufs; 4] = Default::default();
    for (m, slot) in mats.iter_mut().enumerate() {
        let tag = TAG_MATRICES + 4 * m as u32;
        *slot = (
            Buf::mapped(&r, r.u32s(tag).ok()?)?,
            Buf::mapped(&r, r.u32s(tag + 1).ok()?)?,
            Buf::mapped(&r, r.section::<f32>(tag + 2).ok()?)?,
        );
    }
    let part = shell.import_part(mats, lines as u64)?;
    part.release_pages();
    Some(part)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::Rgb;
    use crate::scene::synthetic::SceneBuilder;
    use glam::DVec3;

    /// A room's operator, stored when built, is read back in place from its record: the
    /// same arrays as a build held in memory, solving to the same bits, before and after
    /// its pages are given back; a second run reads the same record.
    #[test]
    fn a_stored_operator_is_read_in_place_and_solves_as_built() {
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("room", 0.6);
        b.add_box("room", m, DVec3::ZERO, DVec3::new(4.0, 3.0, 2.5));
        for x in [0.5, 2.0, 3.5] {
            b.add_sensor(DVec3::new(x, 1.5, 0.8), DVec3::Z);
        }
        let scene = b.build("room").unwrap();
        let params = TransportParams {
            directions: 16,
            resolution: 96,
            gather_rays: 256,
            ..TransportParams::default()
        };
        let folder = tempfile::tempdir().unwrap();
        let store = Store::open(folder.path(), cache::DEFAULT_MAX_BYTES);
        let tracer = Tracer::new(&scene);
        let held = Transport::build_with(&scene, &scene.sensors, &params, &tracer);
        let (cold, cached) = transport(&scene, &params, &store, &tracer);
        assert!(!cached);
        assert_eq!(cold.export(), held.export(), "the arrays as built");
        assert!(
            cold.bytes() < held.bytes(),
            "read in place: one part counted, not four ({} vs {})",
            cold.bytes(),
            held.bytes()
        );
        let direct = vec![Rgb::splat(100.0); held.rows()];
        let solve = |t: &Transport| t.sensors(&t.solve(&direct, None).0);
        let want = solve(&held);
        assert!(
            want.iter().all(|s| s.irradiance.x > 0.0),
            "light reaches the sensors"
        );
        assert_eq!(solve(&cold), want);
        cold.release_pages();
        assert_eq!(solve(&cold), want, "pages given back read the same bytes");
        let (warm, cached) = transport(&scene, &params, &store, &tracer);
        assert!(cached);
        assert_eq!(solve(&warm), want);
        // A build cut short: the parts it stored are read, the missing one built again.
        let gone = folder
            .path()
            .join(part_key(&key(&scene, &params), 1).file_name());
        std::fs::remove_file(&gone).unwrap();
        let before = store.stats();
        let (again, cached) = transport(&scene, &params, &store, &tracer);
        let after = store.stats();
        assert!(!cached);
        assert_eq!(
            (after.hits - before.hits, after.writes - before.writes),
            (held.part_count() as u64 - 1, 1),
            "the other parts read, the missing one built and stored"
        );
        assert_eq!(solve(&again), want);
    }
}
