//! Counter-based random numbers: a value is a pure function of (seed, stream, index), so
//! results do not depend on thread count or scheduling.

/// SplitMix64 finaliser: a bijective 64-bit mix with good avalanche.
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) determined by `(seed, stream, index)`.
pub fn uniform(seed: u64, stream: u64, index: u64) -> f64 {
    let h = mix64(seed ^ mix64(stream.wrapping_add(0x9e37_79b9_7f4a_7c15) ^ mix64(index)));
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}
