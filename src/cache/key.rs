//! Cache keys: a content hash of everything a projection's visibility depends on
//! ([`SceneHash`]) and the full address of one record ([`RecordKey`]).

use super::FORMAT_VERSION;
use crate::projection::ProjectionParams;
use crate::scene::Scene;
use crate::sources::{SkyNodeKey, SourceKey, SunKey};

/// A blake3 content hash (32 bytes) of what visibility depends on: geometry, glazing,
/// projection parameters, sensors, the record format version and caller bytes. See
/// [`scene_hash`] for the exact content.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SceneHash(pub [u8; 32]);

impl SceneHash {
    /// Lower-case hex of the 32 bytes (64 characters).
    pub fn to_hex(&self) -> String {
        hex(&self.0)
    }
}

/// Lower-case hex of `bytes`.
pub(crate) fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(bytes.len() * 2);
    for b in bytes {
        let _ = write!(s, "{b:02x}");
    }
    s
}

/// Appends the little-endian bit patterns of `v` to the hasher.
fn put_f64s(h: &mut blake3::Hasher, v: &[f64]) {
    for x in v {
        h.update(&x.to_bits().to_le_bytes());
    }
}

/// The bytes of [`ProjectionParams`] that enter [`scene_hash`]: every field's bit pattern,
/// little-endian, in declaration order (u32 as 4 bytes, f64 as its 8 IEEE-754 bytes).
pub fn projection_params_bytes(p: &ProjectionParams) -> Vec<u8> {
    // Destructured so that a new field fails to compile here rather than being left out.
    let ProjectionParams {
        max_resolution,
        min_resolution,
        v_min,
        v_max,
        min_area_m2,
        partial_area_m2,
        max_depth,
        margin_m,
    } = *p;
    let mut out = Vec::with_capacity(60);
    out.extend_from_slice(&max_resolution.to_le_bytes());
    out.extend_from_slice(&min_resolution.to_le_bytes());
    for x in [v_min, v_max, min_area_m2, partial_area_m2] {
        out.extend_from_slice(&x.to_bits().to_le_bytes());
    }
    out.extend_from_slice(&max_depth.to_le_bytes());
    out.extend_from_slice(&margin_m.to_bits().to_le_bytes());
    out
}

/// Content hash of exactly what a direction's visibility depends on.
///
/// Hashed, in this order, each list preceded by its length (u64, little-endian), every f64
/// as its bit pattern (so −0.0 ≠ 0.0 and the hash is exact, not tolerant):
/// - a domain tag and [`FORMAT_VERSION`];
/// - every triangle's three vertices as the [`Scene`] holds them (metres, scene frame, after
///   unit/axis/north conversion and origin shift), in triangle order;
/// - per triangle, whether its material is glazing (one byte) and its normal-incidence
///   transmittance `Tf` (RGB), which sets the angular transmittance;
/// - the projection parameters ([`projection_params_bytes`]);
/// - every sensor's position and unit normal (scene frame), since sensor visibility is
///   stored in records too;
/// - `extra`: any further caller parameters (e.g. a sensor-visibility tolerance).
///
/// Not hashed: opaque reflectances `Kd`, emitted radiance `Ke`, material and group names,
/// the site, the ground reflectance, dates and weather — changing them reuses the cache.
pub fn scene_hash(scene: &Scene, params: &ProjectionParams, extra: &[u8]) -> SceneHash {
    let mut h = blake3::Hasher::new();
    h.update(b"daystep scene hash\0");
    h.update(&FORMAT_VERSION.to_le_bytes());
    h.update(&(scene.triangles.len() as u64).to_le_bytes());
    for t in &scene.triangles {
        for v in t.v {
            put_f64s(&mut h, &v.to_array());
        }
    }
    h.update(&(scene.triangles.len() as u64).to_le_bytes());
    for t in &scene.triangles {
        // A triangle referring to a missing material cannot come out of `Scene::from_model`;
        // hash it as opaque rather than panic.
        let (glazing, tf) = match scene.materials.get(t.material as usize) {
            Some(m) => (m.is_glazing(), m.tf.to_array()),
            None => (false, [0.0; 3]),
        };
        h.update(&[glazing as u8]);
        put_f64s(&mut h, &tf);
    }
    let pb = projection_params_bytes(params);
    h.update(&(pb.len() as u64).to_le_bytes());
    h.update(&pb);
    h.update(&(scene.sensors.len() as u64).to_le_bytes());
    for s in &scene.sensors {
        put_f64s(&mut h, &s.position.to_array());
        put_f64s(&mut h, &s.normal.to_array());
    }
    h.update(&(extra.len() as u64).to_le_bytes());
    h.update(extra);
    SceneHash(*h.finalize().as_bytes())
}

/// Record kind: a sky node above the horizon ([`SkyNodeKey::id`]).
pub const KIND_SKY_NODE: u8 = 0;
/// Record kind: the snapped sun ([`sun_direction_id`]).
pub const KIND_SUN: u8 = 1;
/// Record kind: a node of the ground glow below the horizon ([`SkyNodeKey::id`]).
pub const KIND_GROUND: u8 = 2;
/// Record kind: a global-line interreflection operator (direction 0, resolution 0).
pub const KIND_TRANSPORT: u8 = 3;
/// Record kind: a vertex of the sun's interpolation grid ([`sun_direction_id`] of its key).
pub const KIND_SUN_GRID: u8 = 4;
/// Record kind: one direction's interreflection responses at the sensors (daylight
/// coefficients; the direction id and kind of the direction's own record, hashed in
/// `scene`).
pub const KIND_COEFFICIENTS: u8 = 5;
/// Record kind: a camera's traced geometry for renders (primary hits and gather rows;
/// `scene` hashes the operator's key, the view and the render options).
pub const KIND_VIEW: u8 = 6;
/// Record kind: the direction nodes a run's steps use, the union of their adaptive sky
/// cuts (direction 0, resolution 0; `scene` hashes the steps' times and skies, the site,
/// the ground reflectance and the sky parameters, never the geometry).
pub const KIND_CUTS: u8 = 7;
/// Record kind: one day's sky cuts as the daylight-coefficient sums read them (direction 0,
/// resolution 0; `scene` hashes the day's records, the site, the ground reflectance and
/// the sky parameters of both cuts, never the geometry).
pub const KIND_DAY_CUTS: u8 = 8;
/// Record kind: the sensors' responses to one day's snapped suns at one level, in step
/// order (direction 0; `scene` hashes the directions' own scene hash and the suns' ids,
/// [`sun_direction_id`]; `resolution` the suns' LDI resolution).
pub const KIND_DAY_SUNS: u8 = 9;
// Kinds 10..=255 are free for later record types (global-line bundles, depth maps, …).

/// Lossless 64-bit id of a sun-grid cell: spacing δ (µdeg) in the top 32 bits, the altitude
/// band as a signed 16-bit value in the next 16, the azimuth index in the low 16.
///
/// `None` when the cell does not fit, i.e. for grids finer than about 0.0055° (more than
/// 32 767 bands or 65 535 azimuth cells); such suns are simply not cached.
pub fn sun_direction_id(sun: &SunKey) -> Option<u64> {
    let band = i16::try_from(sun.band).ok()?;
    let index = u16::try_from(sun.index).ok()?;
    Some(((sun.spacing_udeg as u64) << 32) | ((band as u16 as u64) << 16) | index as u64)
}

/// The full address of one cache record. Two runs that build the same key get the same
/// file; anything that changes visibility changes `scene` and therefore the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RecordKey {
    /// What visibility depends on ([`scene_hash`]).
    pub scene: SceneHash,
    /// Record kind: [`KIND_SKY_NODE`], [`KIND_SUN`], [`KIND_GROUND`]; others reserved.
    pub kind: u8,
    /// Direction id: [`SkyNodeKey::id`] for sky and ground nodes, [`sun_direction_id`] for
    /// the sun.
    pub direction: u64,
    /// LDI resolution, pixels along the longer image side.
    pub resolution: u32,
}

/// Size of [`RecordKey::to_bytes`].
pub const RECORD_KEY_BYTES: usize = 48;

impl RecordKey {
    /// Key of a sky node (above the horizon) projected at `resolution`.
    pub fn sky_node(scene: SceneHash, node: SkyNodeKey, resolution: u32) -> RecordKey {
        RecordKey {
            scene,
            kind: KIND_SKY_NODE,
            direction: node.id(),
            resolution,
        }
    }

    /// Key of a ground-glow node (below the horizon) projected at `resolution`.
    pub fn ground(scene: SceneHash, node: SkyNodeKey, resolution: u32) -> RecordKey {
        RecordKey {
            scene,
            kind: KIND_GROUND,
            direction: node.id(),
            resolution,
        }
    }

    /// Key of a snapped sun projected at `resolution`; `None` when the grid is too fine
    /// for a lossless id ([`sun_direction_id`]).
    pub fn sun(scene: SceneHash, sun: SunKey, resolution: u32) -> Option<RecordKey> {
        Some(RecordKey {
            scene,
            kind: KIND_SUN,
            direction: sun_direction_id(&sun)?,
            resolution,
        })
    }

    /// Key of any source ([`SourceKey`]); `None` only for suns on too fine a grid.
    pub fn for_source(scene: SceneHash, source: SourceKey, resolution: u32) -> Option<RecordKey> {
        match source {
            SourceKey::Sky(n) => Some(Self::sky_node(scene, n, resolution)),
            SourceKey::Ground(n) => Some(Self::ground(scene, n, resolution)),
            SourceKey::Sun(s) => Self::sun(scene, s, resolution),
            SourceKey::SunGrid(s) => Some(RecordKey {
                kind: KIND_SUN_GRID,
                ..Self::sun(scene, s, resolution)?
            }),
        }
    }

    /// The 48 bytes stored in a record header: scene hash (32), direction (u64 LE),
    /// resolution (u32 LE), kind (u8), three zero bytes.
    pub fn to_bytes(&self) -> [u8; RECORD_KEY_BYTES] {
        let mut b = [0u8; RECORD_KEY_BYTES];
        b[..32].copy_from_slice(&self.scene.0);
        b[32..40].copy_from_slice(&self.direction.to_le_bytes());
        b[40..44].copy_from_slice(&self.resolution.to_le_bytes());
        b[44] = self.kind;
        b
    }

    /// Inverse of [`RecordKey::to_bytes`]; `None` when the padding bytes are not zero.
    pub fn from_bytes(b: &[u8; RECORD_KEY_BYTES]) -> Option<RecordKey> {
        if b[45..].iter().any(|&x| x != 0) {
            return None;
        }
        let mut scene = [0u8; 32];
        scene.copy_from_slice(&b[..32]);
        Some(RecordKey {
            scene: SceneHash(scene),
            direction: u64::from_le_bytes(b[32..40].try_into().expect("8 bytes")),
            resolution: u32::from_le_bytes(b[40..44].try_into().expect("4 bytes")),
            kind: b[44],
        })
    }

    /// The record's file name: hex of blake3(domain tag ‖ [`RecordKey::to_bytes`]) and
    /// the extension `.dsr`, e.g. `ab12…cd.dsr` (64 hex digits).
    pub fn file_name(&self) -> String {
        let mut h = blake3::Hasher::new();
        h.update(b"daystep record key\0");
        h.update(&self.to_bytes());
        format!(
            "{}.{}",
            hex(h.finalize().as_bytes()),
            super::RECORD_EXTENSION
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::Rgb;
    use crate::scene::synthetic::SceneBuilder;
    use glam::DVec3;

    fn scene(kd: f64, tf: f64, sensor_z: f64) -> Scene {
        let mut b = SceneBuilder::new();
        let wall = b.add_opaque("wall", kd);
        let glass = b.add_glazing("glass", tf);
        b.add_triangle("w", wall, [DVec3::ZERO, DVec3::X, DVec3::Y]);
        b.add_triangle(
            "g",
            glass,
            [DVec3::Z, DVec3::X + DVec3::Z, DVec3::Y + DVec3::Z],
        );
        b.add_sensor(DVec3::new(0.2, 0.2, sensor_z), DVec3::Z);
        b.build("key test").unwrap()
    }

    #[test]
    fn hash_follows_visibility_inputs_only() {
        let p = ProjectionParams::default();
        let base = scene_hash(&scene(0.5, 0.6, 0.5), &p, b"");
        assert_eq!(base, scene_hash(&scene(0.5, 0.6, 0.5), &p, b""));
        // Opaque reflectance, emission, site, ground: no change.
        let mut s = scene(0.2, 0.6, 0.5);
        s.materials[0].ke = Rgb::ONE;
        s.site.latitude = -33.0;
        s.ground_reflectance = 0.4;
        assert_eq!(base, scene_hash(&s, &p, b""));
        // Glazing, geometry, sensors, parameters, extra: change.
        assert_ne!(base, scene_hash(&scene(0.5, 0.7, 0.5), &p, b""));
        assert_ne!(base, scene_hash(&scene(0.5, 0.6, 0.6), &p, b""));
        let mut s = scene(0.5, 0.6, 0.5);
        s.triangles[0].v[1].x = f64::from_bits(1.0f64.to_bits() + 1);
        assert_ne!(base, scene_hash(&s, &p, b""));
        let q = ProjectionParams { v_max: 0.9, ..p };
        assert_ne!(base, scene_hash(&scene(0.5, 0.6, 0.5), &q, b""));
        assert_ne!(base, scene_hash(&scene(0.5, 0.6, 0.5), &p, b"x"));
    }

    #[test]
    fn keys_round_trip_and_name_files() {
        let k = RecordKey::sky_node(SceneHash([7; 32]), SkyNodeKey::root(2).child(3), 512);
        assert_eq!(RecordKey::from_bytes(&k.to_bytes()), Some(k));
        let name = k.file_name();
        assert_eq!(name.len(), 64 + 4);
        assert!(name.ends_with(".dsr"));
        assert!(name[..64].bytes().all(|c| c.is_ascii_hexdigit()));
        let other = RecordKey {
            resolution: 513,
            ..k
        };
        assert_ne!(other.file_name(), name);
        let ground = RecordKey::ground(k.scene, SkyNodeKey::root(2).child(3), 512);
        assert_ne!(ground.file_name(), name);
    }

    #[test]
    fn sun_ids_are_lossless_where_they_fit() {
        let a = SunKey::snap(10.0, 120.0, 0.05);
        let b = SunKey::snap(-10.0, 120.0, 0.05);
        let ia = sun_direction_id(&a).unwrap();
        assert_ne!(ia, sun_direction_id(&b).unwrap());
        assert_eq!(ia >> 32, 50_000);
        assert_eq!(((ia >> 16) & 0xffff) as u16 as i16 as i32, a.band);
        assert_eq!((ia & 0xffff) as i32, a.index);
        assert!(sun_direction_id(&SunKey::snap(10.0, 120.0, 0.001)).is_none());
    }
}
