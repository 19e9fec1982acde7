//! The record of a day's snapped suns ([`super::directions::Directions::day_sun_responses`]):
//! each sun's sensor responses, sparse. A sensor whose response to a sun is all zeros (the
//! sun is behind an opaque surface and no pane was crossed: most sensors inside a
//! building, most hours) is left out, and read back as zeros, the same bits; so the record
//! is smaller than the suns' own records were, though a day's record repeats suns that
//! other days meet again.

use super::directions::{flatten_sun, unflatten_sun, PER_SUN_SENSOR};
use crate::cache::{self, MappedRecord, RecordKey, Section, FIRST_USER_TAG};
use crate::sensors::NodeResponse;

/// Section tag: per sun, how many sensors it lists (u32).
const TAG_COUNTS: u32 = FIRST_USER_TAG + 10;
/// Section tag: the listed sensors' indices, sun after sun, increasing within a sun (u32).
const TAG_SENSORS: u32 = FIRST_USER_TAG + 11;
/// Section tag: the listed sensors' responses, [`PER_SUN_SENSOR`] f64 each.
const TAG_VALUES: u32 = FIRST_USER_TAG + 12;

/// The record of `suns` (each sun's responses of all the scene's sensors) under `key`.
pub(super) fn encode(key: &RecordKey, suns: &[Vec<NodeResponse>]) -> Vec<u8> {
    let mut counts = Vec::with_capacity(suns.len());
    let mut sensors = Vec::new();
    let mut values = Vec::new();
    for sun in suns {
        let before = sensors.len();
        for (i, r) in sun.iter().enumerate() {
            let flat = flatten_sun(r);
            if flat.iter().any(|v| v.to_bits() != 0) {
                sensors.push(i as u32);
                values.extend_from_slice(&flat);
            }
        }
        counts.push((sensors.len() - before) as u32);
    }
    cache::encode(
        key,
        &[
            Section::u32s(TAG_COUNTS, &counts),
            Section::u32s(TAG_SENSORS, &sensors),
            Section::f64s(TAG_VALUES, &values),
        ],
    )
}

/// The responses of `n_suns` suns at `k` sensors from record `r`; `None` when it does not
/// fit them (a damaged or foreign record is never trusted).
pub(super) fn decode(r: &MappedRecord, n_suns: usize, k: usize) -> Option<Vec<Vec<NodeResponse>>> {
    let counts = r.u32s(TAG_COUNTS).ok()?;
    let sensors = r.u32s(TAG_SENSORS).ok()?;
    let values = r.f64s(TAG_VALUES).ok()?;
    let listed: usize = counts.iter().map(|&c| c as usize).sum();
    if counts.len() != n_suns || sensors.len() != listed || values.len() != listed * PER_SUN_SENSOR
    {
        return None;
    }
    let mut at = 0;
    let mut out = Vec::with_capacity(n_suns);
    for &c in counts {
        let mut sun = vec![NodeResponse::default(); k];
        let mut last = None;
        for e in at..at + c as usize {
            let i = sensors[e] as usize;
            if i >= k || last.is_some_and(|l| l >= i) {
                return None;
            }
            last = Some(i);
            sun[i] = unflatten_sun(&values[e * PER_SUN_SENSOR..(e + 1) * PER_SUN_SENSOR]);
        }
        at += c as usize;
        out.push(sun);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cache::SceneHash;
    use crate::photometry::Rgb;

    fn key() -> RecordKey {
        RecordKey {
            scene: SceneHash([7; 32]),
            kind: cache::KIND_DAY_SUNS,
            direction: 0,
            resolution: 1024,
        }
    }

    /// Zeros are left out and come back as the same bits; anything else is listed.
    #[test]
    fn sparse_suns_round_trip_to_the_bit() {
        let lit = |t: f64| {
            let mut r = NodeResponse::default();
            r.child[0] = Rgb::new(t, t * 0.9, t * 0.8);
            r
        };
        let mut glazed_dark = NodeResponse::default();
        glazed_dark.child[1] = Rgb::new(1.0, 2.0, 0.0);
        glazed_dark.child[2] = Rgb::new(17.0, 18.0, 0.0);
        let mut negative_zero = NodeResponse::default();
        negative_zero.child[0].y = -0.0;
        let zero = NodeResponse::default();
        let suns = vec![
            vec![lit(0.7), zero, glazed_dark, zero],
            vec![zero, zero, zero, zero],
            vec![zero, negative_zero, lit(1.0), lit(1e-300)],
        ];
        let bytes = encode(&key(), &suns);
        let r = MappedRecord::from_bytes(&bytes, &key()).unwrap();
        assert_eq!(r.u32s(TAG_COUNTS).unwrap(), &[2, 0, 3]);
        let back = decode(&r, 3, 4).unwrap();
        let bits = |s: &[Vec<NodeResponse>]| -> Vec<u64> {
            s.iter()
                .flatten()
                .flat_map(flatten_sun)
                .map(f64::to_bits)
                .collect()
        };
        assert_eq!(bits(&back), bits(&suns));
        // A record of other suns or sensors does not fit.
        assert!(decode(&r, 2, 4).is_none());
        assert!(decode(&r, 3, 2).is_none());
    }
}
