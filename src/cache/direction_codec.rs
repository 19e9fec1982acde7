//! The direction-record codec: how one direction's projection result
//! ([`DirectionRecord`]: lit leaves and projection stats) is laid out as record sections
//! ([`LeafRec`], [`StatsRec`]) and read back bit for bit. The container itself — header,
//! section table, checksums, validation — is [`super::record`]'s; this module only chooses
//! the sections. Its items are re-exported from [`super::record`], their historical home.

use super::key::RecordKey;
use super::record::{encode, Invalid, MappedRecord, Section};
use crate::hierarchy::ElementKey;
use crate::photometry::Rgb;
use crate::projection::{DirectionRecord, LeafWeight, ProjectionStats};
use bytemuck::{Pod, Zeroable};

/// Tag of the leaf-weight section of a direction record ([`LeafRec`]).
pub const TAG_LEAVES: u32 = 1;
/// Tag of the stats section of a direction record (one [`StatsRec`]).
pub const TAG_STATS: u32 = 2;
/// Smallest tag free for callers' extra sections (e.g. per-sensor visibility).
pub const FIRST_USER_TAG: u32 = 0x100;

/// One lit leaf on disk: [`LeafWeight`] as a plain 40-byte struct.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LeafRec {
    /// Input triangle index ([`ElementKey::tri`]).
    pub tri: u32,
    /// Zero.
    pub _pad: u32,
    /// Heap-encoded quadtree path ([`ElementKey::path`]).
    pub path: u64,
    /// Transfer weight (Ap/A)·VR with glazing transmission, RGB, dimensionless.
    pub weight: [f64; 3],
}

/// [`ProjectionStats`] on disk: a plain 48-byte struct.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct StatsRec {
    /// LDI width, pixels.
    pub width: u32,
    /// LDI height, pixels.
    pub height: u32,
    /// Pixel edge length, m.
    pub pixel_m: f64,
    /// Fragments stored in the LDI.
    pub fragments: u64,
    /// Elements whose VR was evaluated.
    pub elements_tested: u64,
    /// Elements split.
    pub elements_split: u64,
    /// Lit leaves in the record.
    pub lit_leaves: u64,
}

/// Encodes a projection result: sections [`TAG_LEAVES`] ([`LeafRec`], in the record's
/// order), [`TAG_STATS`] (one [`StatsRec`]), then `extra` (caller sections such as
/// per-sensor visibility, tags ≥ [`FIRST_USER_TAG`]).
///
/// # Panics
/// When an extra section uses a reserved tag, or as [`encode`].
pub fn encode_direction(
    key: &RecordKey,
    record: &DirectionRecord,
    extra: &[Section<'_>],
) -> Vec<u8> {
    assert!(
        extra.iter().all(|s| s.tag >= FIRST_USER_TAG),
        "extra section tags must be >= {FIRST_USER_TAG}"
    );
    let leaves: Vec<LeafRec> = record
        .leaves
        .iter()
        .map(|l| LeafRec {
            tri: l.key.tri,
            _pad: 0,
            path: l.key.path,
            weight: l.weight.to_array(),
        })
        .collect();
    let s = &record.stats;
    let stats = [StatsRec {
        width: s.width,
        height: s.height,
        pixel_m: s.pixel_m,
        fragments: s.fragments,
        elements_tested: s.elements_tested,
        elements_split: s.elements_split,
        lit_leaves: s.lit_leaves,
    }];
    let mut sections = vec![
        Section::of(TAG_LEAVES, &leaves),
        Section::of(TAG_STATS, &stats),
    ];
    sections.extend_from_slice(extra);
    encode(key, &sections)
}

/// Decodes the projection result of a record written by [`encode_direction`] (bit for bit:
/// f64 values are copied, never recomputed).
///
/// # Errors
/// [`Invalid::MissingSection`] / [`Invalid::ElementSize`] / [`Invalid::BadSection`] when the
/// record is valid but not a direction record.
pub fn decode_direction(record: &MappedRecord) -> Result<DirectionRecord, Invalid> {
    let leaves: &[LeafRec] = record.section(TAG_LEAVES)?;
    let stats: &[StatsRec] = record.section(TAG_STATS)?;
    let [s] = stats else {
        return Err(Invalid::BadSection {
            tag: TAG_STATS,
            what: "expected exactly one stats entry",
        });
    };
    Ok(DirectionRecord {
        leaves: leaves
            .iter()
            .map(|l| LeafWeight {
                key: ElementKey {
                    tri: l.tri,
                    path: l.path,
                },
                weight: Rgb::from_array(l.weight),
            })
            .collect(),
        stats: ProjectionStats {
            width: s.width,
            height: s.height,
            pixel_m: s.pixel_m,
            fragments: s.fragments,
            elements_tested: s.elements_tested,
            elements_split: s.elements_split,
            lit_leaves: s.lit_leaves,
        },
    })
}
