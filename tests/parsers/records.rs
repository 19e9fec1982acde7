//! Parser properties ([`super`]): cache records and the cache folder.

use super::*;

// Cache records

const VISIBILITY: u32 = FIRST_USER_TAG;

fn record_key(direction: u64) -> RecordKey {
    RecordKey {
        scene: SceneHash(*blake3::hash(b"parser properties").as_bytes()),
        kind: KIND_SUN,
        direction,
        resolution: 64,
    }
}

/// A valid record: 7 leaves, the stats and a visibility section of 5 sensors.
fn record_sample() -> Vec<u8> {
    let record = DirectionRecord {
        leaves: (0..7u32)
            .map(|i| LeafWeight {
                key: ElementKey {
                    tri: i,
                    path: 1 + u64::from(i % 4),
                },
                weight: DVec3::new(0.1 * f64::from(i), 0.2, 0.3),
            })
            .collect(),
        stats: ProjectionStats {
            width: 64,
            height: 48,
            pixel_m: 0.05,
            fragments: 100,
            elements_tested: 20,
            elements_split: 3,
            lit_leaves: 7,
        },
    };
    encode_direction(
        &record_key(1),
        &record,
        &[Section::f64s(VISIBILITY, &[0.0, 0.25, 0.5, 0.75, 1.0])],
    )
}

/// Decodes `bytes` as a record of `key` (guarded); on success also decodes the
/// direction and reads the visibility section, which must stay inside the bytes.
fn decode(bytes: Vec<u8>, key: RecordKey) -> Result<bool, TestCaseError> {
    guarded(|| match MappedRecord::from_bytes(&bytes, &key) {
        Ok(r) => {
            let _ = decode_direction(&r);
            let _ = r.f64s(VISIBILITY);
            for s in r.sections() {
                let end = s.offset.checked_add(s.byte_len());
                assert!(end.is_some_and(|e| e <= bytes.len() as u64), "{s:?}");
            }
            true
        }
        Err(_) => false,
    })
}

/// Damage that both checksums catch: bits flipped, the record cut or bytes appended.
#[derive(Clone, Debug)]
struct Damage {
    flips: Vec<(Index, u8)>,
    cut: Option<Index>,
    append: Vec<u8>,
}

fn damage() -> impl Strategy<Value = Damage> {
    (
        prop::collection::vec((any::<Index>(), 0..8u8), 0..6),
        prop::option::weighted(0.3, any::<Index>()),
        prop::collection::vec(any::<u8>(), 0..3),
    )
        .prop_map(|(flips, cut, append)| Damage { flips, cut, append })
}

fn damaged(sample: &[u8], d: &Damage) -> Vec<u8> {
    let mut b = sample.to_vec();
    for (i, bit) in &d.flips {
        let k = i.index(b.len());
        b[k] ^= 1 << bit;
    }
    if let Some(c) = &d.cut {
        b.truncate(c.index(b.len()));
    }
    b.extend_from_slice(&d.append);
    b
}

#[test]
fn cache_record_arbitrary_bytes() {
    // Arbitrary bytes, and arbitrary bytes behind a valid magic and version.
    let mut head = b"DAYSTEP\0".to_vec();
    head.extend_from_slice(&daystep::cache::FORMAT_VERSION.to_le_bytes());
    let framed = any_bytes().prop_map(move |b| [head.clone(), b].concat());
    check(4096, prop_oneof![any_bytes(), framed], |bytes| {
        prop_assert!(!decode(bytes, record_key(1))?, "arbitrary bytes accepted");
        Ok(())
    });
}

#[test]
fn cache_record_bit_flips_and_cuts_are_rejected() {
    let sample = record_sample();
    assert!(decode(sample.clone(), record_key(1)).unwrap());
    check(4096, damage(), |d| {
        let bytes = damaged(&sample, &d);
        let same = bytes == sample;
        prop_assert_eq!(decode(bytes, record_key(1))?, same);
        Ok(())
    });
}

/// Header fields (and section-table fields) set to hostile integers with both checksums
/// recomputed, so the checks behind the checksums see them: never a panic, and a record
/// accepted anyway has every section inside its bytes.
#[test]
fn cache_record_resigned_header_fields() {
    let sample = record_sample();
    let n = 3usize;
    // (offset, width) of every integer field of the header and the section table.
    let mut fields: Vec<(usize, usize)> = vec![(8, 4), (12, 4), (64, 1), (65, 1), (68, 4), (72, 8)];
    for s in 0..n {
        let e = 112 + 24 * s;
        fields.extend([(e, 4), (e + 4, 4), (e + 8, 8), (e + 16, 8)]);
    }
    let values: Vec<u64> = vec![
        0,
        1,
        2,
        7,
        8,
        24,
        40,
        48,
        u64::from(u32::MAX),
        u64::from(u32::MAX) + 1,
        1 << 40,
        1 << 63,
        u64::MAX,
        u64::MAX - 7,
        u64::MAX / 24,
        u64::MAX / 40 + 1,
        1024,
        1025,
        sample.len() as u64,
        sample.len() as u64 + 8,
        216,
        144 + 24 * 1024,
    ];
    let edit = (any::<Index>(), any::<Index>(), any::<u64>());
    let edits = prop::collection::vec(edit, 1..=3);
    check(8192, (edits, any::<bool>()), |(edits, resign_payload)| {
        let mut b = sample.clone();
        for (field, value, random) in &edits {
            let (at, width) = fields[field.index(fields.len())];
            let v = if random & 1 == 0 {
                values[value.index(values.len())]
            } else {
                *random
            };
            b[at..at + width].copy_from_slice(&v.to_le_bytes()[..width]);
        }
        resign(&mut b, resign_payload);
        decode(b, record_key(1))?;
        Ok(())
    });
}

/// Recomputes the checksums of a record whose header may be damaged: the payload checksum
/// (when asked) over everything after the header its section count implies, then the header
/// checksum.
fn resign(b: &mut [u8], payload: bool) {
    let n = u32::from_le_bytes(b[68..72].try_into().unwrap()) as usize;
    let h = 144 + 24 * n;
    if h > b.len() {
        return;
    }
    if payload {
        let sum = *blake3::hash(&b[h..]).as_bytes();
        b[80..112].copy_from_slice(&sum);
    }
    let sum = *blake3::hash(&b[..h - 32]).as_bytes();
    b[h - 32..h].copy_from_slice(&sum);
}

/// A re-signed header claiming 1024 sections of `u64::MAX` elements, or a payload of
/// `u64::MAX` bytes, is rejected quickly without allocating for the claim.
#[test]
fn cache_record_claiming_huge_sizes_does_not_allocate_for_them() {
    let sample = record_sample();
    let mut claims = Vec::new();
    // A payload length of u64::MAX.
    let mut b = sample.clone();
    b[72..80].copy_from_slice(&u64::MAX.to_le_bytes());
    resign(&mut b, false);
    claims.push(b);
    // Every section u64::MAX elements long.
    let mut b = sample.clone();
    for s in 0..3 {
        let e = 112 + 24 * s + 8;
        b[e..e + 8].copy_from_slice(&u64::MAX.to_le_bytes());
    }
    resign(&mut b, true);
    claims.push(b);
    // 1024 sections, each claiming 2⁶⁰ 8-byte elements, in a file of 24 KiB.
    let n = 1024usize;
    let h = 144 + 24 * n;
    let mut b = vec![0u8; h];
    b[..80].copy_from_slice(&sample[..80]);
    b[12..16].copy_from_slice(&(h as u32).to_le_bytes());
    b[68..72].copy_from_slice(&(n as u32).to_le_bytes());
    b[72..80].copy_from_slice(&0u64.to_le_bytes());
    for s in 0..n {
        let e = 112 + 24 * s;
        b[e..e + 4].copy_from_slice(&(s as u32).to_le_bytes());
        b[e + 4..e + 8].copy_from_slice(&8u32.to_le_bytes());
        b[e + 8..e + 16].copy_from_slice(&(1u64 << 60).to_le_bytes());
        b[e + 16..e + 24].copy_from_slice(&(h as u64).to_le_bytes());
    }
    resign(&mut b, true);
    claims.push(b);
    for (k, bytes) in claims.iter().enumerate() {
        let (r, largest, total, took) =
            metered(|| MappedRecord::from_bytes(bytes, &record_key(1)).map(|_| ()));
        assert!(r.is_err(), "claim {k} accepted");
        let bound = bytes.len() + (64 << 10);
        assert!(
            largest <= bound && total <= 2 * bound,
            "claim {k}: {largest} B, {total} B"
        );
        assert!(took < Duration::from_secs(2), "claim {k}: {took:?}");
    }
}

// ---------------------------------------------------------------------------------------
// The cache folder

/// `Store::get` on a record file holding `bytes`: a miss when the file is invalid, counted
/// as a rebuild, and the file removed.
fn store_get_rejects(store: &Store, bytes: Vec<u8>, key: RecordKey) -> CaseResult {
    let dir = store.dir().expect("enabled").to_path_buf();
    let path = dir.join(key.file_name());
    std::fs::write(&path, &bytes).expect("write");
    let before = store.stats();
    let hit = guarded(|| store.get(&key).is_some())?;
    let after = store.stats();
    prop_assert!(!hit, "an invalid record was returned");
    prop_assert_eq!(after.rebuilds, before.rebuilds + 1);
    prop_assert_eq!((after.hits, after.misses), (before.hits, before.misses));
    prop_assert!(!path.exists(), "the invalid record was kept");
    Ok(())
}

#[test]
fn store_get_arbitrary_bytes() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    check(1024, any_bytes(), |bytes| {
        store_get_rejects(&store, bytes, record_key(2))
    });
}

#[test]
fn store_get_damaged_records() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let store = Store::open(dir.path(), DEFAULT_MAX_BYTES);
    let sample = record_sample();
    // A valid record filed under another key's name is rebuilt too.
    store_get_rejects(&store, sample.clone(), record_key(3)).unwrap();
    check(1024, damage(), |d| {
        let bytes = damaged(&sample, &d);
        if bytes == sample {
            return Ok(());
        }
        store_get_rejects(&store, bytes, record_key(1))
    });
    // The counters saw every rebuild, and nothing was left behind.
    assert_eq!(store.stats().hits, 0);
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name() != ".gitignore")
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

// ---------------------------------------------------------------------------------------
