//! L5 the direction-keyed projection cache: on-disk, memory-mapped records of per-direction
//! projection results ([`crate::projection::DirectionRecord`], plus caller sections such
//! as per-sensor visibility), so re-runs and annual sequences project each direction once
//! per geometry.
//!
//! **What is in the key, and why.** A direction's record is pure geometry: which elements
//! a parallel beam reaches and through how much glass. It depends on the triangles'
//! vertices (as the scene holds them: metres, scene frame), on which triangles are glazing
//! and their transmittance `Tf`, on the projection parameters, and — since sensor
//! visibility is stored too — on the sensors' positions and normals. It does not depend on
//! opaque reflectances `Kd`, emitted radiance `Ke`, the site, the date or the weather, so
//! changing wall colours, the climate file or the year reuses the whole cache, while
//! changing geometry invalidates it. [`key::scene_hash`] hashes exactly those inputs plus
//! [`FORMAT_VERSION`]; a [`RecordKey`] adds the record kind (sky node, sun, ground), the
//! exact direction id ([`crate::sources::SkyNodeKey::id`] or a packed
//! [`crate::sources::SunKey`]) and the LDI resolution. The file name is a hash of the key;
//! the full key is also stored in the record header and checked on every read.
//!
//! **Robustness.** Records are written to a unique temporary name and renamed, so readers
//! only ever see complete files, and concurrent runs (threads, processes, shards on a
//! shared file system) fill one folder without locks. Every read validates magic, version,
//! key, lengths, section bounds and two blake3 checksums before the data is used; anything
//! invalid is removed and rebuilt, with a warning. A cache that cannot be written degrades
//! to a disabled one with a warning: the cache can make a run faster, never make it fail.
//!
//! Modules: [`key`] (scene hash, record key, file name), [`record`] (file format),
//! [`direction_codec`] (direction records as record sections), [`store`] (the folder: get,
//! put, counters), `eviction` (keeping the folder under its size limit) and
//! [`maintenance`] (stats, verify, clear).

pub mod key;
pub mod record;
pub mod direction_codec;
pub mod store;
mod eviction;
pub mod maintenance;

pub use key::{
    scene_hash, sun_direction_id, RecordKey, SceneHash, KIND_COEFFICIENTS, KIND_CUTS,
    KIND_DAY_CUTS, KIND_DAY_SUNS, KIND_GROUND, KIND_SKY_NODE, KIND_SUN, KIND_SUN_GRID,
    KIND_TRANSPORT, KIND_VIEW,
};
pub use record::{
    decode_direction, encode, encode_direction, Invalid, MappedRecord, Record, Section,
    FIRST_USER_TAG,
};
pub use store::{
    clear, dir_stats, verify, CacheStats, DirStats, Store, VerifyReport, DEFAULT_MAX_BYTES,
    READ_MAX_BYTES,
};

/// Version of the record format and of the scene-hash content; bump on any change to
/// either, so old records are rebuilt rather than misread.
pub const FORMAT_VERSION: u32 = 1;

/// Extension of record files.
pub const RECORD_EXTENSION: &str = "dsr";
