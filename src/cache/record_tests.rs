//! Unit tests of the record file format ([`super`]) and of the direction-record codec
//! ([`crate::cache::direction_codec`]): documented layout, bit-exact round trip, and that
//! every corruption is detected and named.

use super::*;
use crate::cache::key::{SceneHash, KIND_SUN};
use crate::hierarchy::ElementKey;
use crate::photometry::Rgb;
use crate::projection::{DirectionRecord, LeafWeight, ProjectionStats};

fn key() -> RecordKey {
    RecordKey {
        scene: SceneHash([3; 32]),
        kind: KIND_SUN,
        direction: 0x0123_4567_89ab_cdef,
        resolution: 256,
    }
}

fn direction() -> DirectionRecord {
    DirectionRecord {
        leaves: (0..5u32)
            .map(|i| LeafWeight {
                key: ElementKey {
                    tri: i,
                    path: 4 * i as u64 + 1,
                },
                weight: Rgb::new(0.1 * i as f64, -0.0, f64::MIN_POSITIVE),
            })
            .collect(),
        stats: ProjectionStats {
            width: 64,
            height: 48,
            pixel_m: 0.01,
            fragments: 9,
            elements_tested: 8,
            elements_split: 2,
            lit_leaves: 5,
        },
    }
}

#[test]
fn layout_matches_the_documented_offsets() {
    assert_eq!(std::mem::size_of::<LeafRec>(), 40);
    assert_eq!(std::mem::size_of::<StatsRec>(), 48);
    let vis = [0.5, 1.0, 0.25];
    let b = encode_direction(&key(), &direction(), &[Section::f64s(FIRST_USER_TAG, &vis)]);
    assert_eq!(&b[..8], b"DAYSTEP\0");
    assert_eq!(u32_at(&b, 8), FORMAT_VERSION);
    assert_eq!(u32_at(&b, 12) as usize, header_len(3));
    assert_eq!(u32_at(&b, 68), 3);
    assert_eq!(u64_at(&b, 48), key().direction);
    assert_eq!(u32_at(&b, 56), 256);
    assert_eq!(b[60], KIND_SUN);
    let h = header_len(3);
    assert_eq!(u64_at(&b, FIXED_HEADER_BYTES + 16) as usize, h);
    assert_eq!(b.len(), h + 5 * 40 + 48 + 24);
    let r = Record::validate(&b, &key()).unwrap();
    assert_eq!(r.sections().len(), 3);
    assert!(r.sections().iter().all(|s| s.offset % 8 == 0));
}

#[test]
fn round_trip_is_bit_exact() {
    let d = direction();
    let vis = [0.5, 1.0, 0.25];
    let idx = [1u32, 2, 3];
    let b = encode_direction(
        &key(),
        &d,
        &[
            Section::f64s(FIRST_USER_TAG, &vis),
            Section::u32s(FIRST_USER_TAG + 1, &idx),
        ],
    );
    let m = MappedRecord::from_bytes(&b, &key()).unwrap();
    assert!(!m.is_mapped());
    assert_eq!(m.bytes(), &b[..]);
    let back = decode_direction(&m).unwrap();
    assert_eq!(back, d);
    assert_eq!(back.leaves[0].weight.y.to_bits(), (-0.0f64).to_bits());
    assert_eq!(m.f64s(FIRST_USER_TAG).unwrap(), &vis);
    assert_eq!(m.u32s(FIRST_USER_TAG + 1).unwrap(), &idx);
    assert_eq!(m.f64s(7), Err(Invalid::MissingSection { tag: 7 }));
    assert!(matches!(
        m.u32s(FIRST_USER_TAG),
        Err(Invalid::ElementSize { .. })
    ));
    // An empty record is fine too.
    let e = encode_direction(&key(), &DirectionRecord::default(), &[]);
    let m = MappedRecord::from_bytes(&e, &key()).unwrap();
    assert_eq!(decode_direction(&m).unwrap(), DirectionRecord::default());
}

#[test]
fn every_single_bit_flip_and_every_truncation_is_detected() {
    let b = encode_direction(&key(), &direction(), &[]);
    for bit in 0..b.len() * 8 {
        let mut c = b.clone();
        c[bit / 8] ^= 1 << (bit % 8);
        assert!(
            Record::validate(&c, &key()).is_err(),
            "bit {bit} not detected"
        );
    }
    for len in 0..b.len() {
        assert!(
            Record::validate(&b[..len], &key()).is_err(),
            "truncation to {len} not detected"
        );
    }
    let mut longer = b.clone();
    longer.push(0);
    assert!(matches!(
        Record::validate(&longer, &key()),
        Err(Invalid::LengthMismatch { .. })
    ));
}

/// Rewrites the header checksum after a deliberate header edit.
fn reseal(b: &mut [u8]) {
    let h = u32_at(b, 12) as usize;
    let sum = *blake3::hash(&b[..h - 32]).as_bytes();
    b[h - 32..h].copy_from_slice(&sum);
}

#[test]
fn reasons_name_the_failed_check() {
    let b = encode_direction(&key(), &direction(), &[]);
    let v = |c: &[u8]| Record::validate(c, &key()).unwrap_err();
    assert!(matches!(v(&[]), Invalid::Truncated { len: 0, .. }));
    assert_eq!(v(b"hello, world, this is text"), Invalid::BadMagic);
    let mut c = b.clone();
    c[8] = 2;
    assert_eq!(v(&c), Invalid::Version { found: 2 });
    let mut c = b.clone();
    c[57] ^= 1;
    assert_eq!(v(&c), Invalid::HeaderChecksum);
    let mut c = b.clone();
    let last = c.len() - 1;
    c[last] ^= 0x80;
    assert_eq!(v(&c), Invalid::PayloadChecksum);
    let other = RecordKey {
        resolution: 257,
        ..key()
    };
    assert_eq!(Record::validate(&b, &other).unwrap_err(), Invalid::OtherKey);
    let entry1 = FIXED_HEADER_BYTES + SECTION_ENTRY_BYTES;
    let mut c = b.clone();
    c[entry1 + 16] += 4;
    reseal(&mut c);
    assert_eq!(v(&c), Invalid::SectionMisaligned { index: 1 });
    let mut c = b.clone();
    c[entry1 + 8] = 200;
    reseal(&mut c);
    assert_eq!(v(&c), Invalid::SectionOutOfBounds { index: 1 });
    let mut c = b.clone();
    c[entry1 + 16..entry1 + 24].copy_from_slice(&0u64.to_le_bytes());
    reseal(&mut c);
    assert_eq!(v(&c), Invalid::SectionOutOfBounds { index: 1 });
    let mut c = b.clone();
    c[64] = if HOST_BYTE_ORDER == BYTE_ORDER_LITTLE {
        BYTE_ORDER_BIG
    } else {
        BYTE_ORDER_LITTLE
    };
    reseal(&mut c);
    assert_eq!(v(&c), Invalid::ByteOrder);
}

#[test]
fn misaligned_buffers_are_refused_not_misread() {
    let b = encode_direction(&key(), &direction(), &[]);
    let mut shifted = vec![0u8; b.len() + 8];
    let base = shifted.as_ptr() as usize;
    let start = (8 - base % 8) % 8 + 1; // one byte past an 8-byte boundary
    shifted[start..start + b.len()].copy_from_slice(&b);
    let r = Record::validate(&shifted[start..start + b.len()], &key()).unwrap();
    assert!(matches!(
        r.section::<LeafRec>(TAG_LEAVES),
        Err(Invalid::SectionMisaligned { .. })
    ));
}
