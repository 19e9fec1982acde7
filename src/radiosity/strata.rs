//! Equal-area direction strata of the global-line bundles: one jittered direction per
//! cell of an equal-area tiling of (cos θ, φ/2π), uniform on the hemisphere for any count.

use crate::math::rng::uniform;
use glam::DVec3;
use std::f64::consts::PI;

/// Direction `m` of `n` stratified uniformly on the upper hemisphere (a line and its
/// reverse are the same bundle), jittered by `seed`. The unit square (u1 → cos θ, u2 → φ)
/// is cut into `n` cells of equal area, one direction each: ⌈n/k⌉ rows (k = ⌈√n⌉), each
/// row as tall as its share of the cells and split into that many columns. A plain k × rows
/// grid with its last row only partly used left a sector of azimuths without its steep
/// directions whenever n is not a product k·rows (8 192 directions in 4 parts: 2 048 of
/// 2 070 cells), which biased the operator (README, presets).
pub(super) fn bundle_direction(m: u32, n: u32, seed: u64) -> DVec3 {
    let (lo, size) = stratum(m, n);
    let u1 = lo[0] + size[0] * uniform(seed, 11, 2 * m as u64);
    let u2 = lo[1] + size[1] * uniform(seed, 11, 2 * m as u64 + 1);
    let z = u1.clamp(1e-6, 1.0);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Cell `m` of `n` equal-area cells tiling the unit square: (lower corner, size).
fn stratum(m: u32, n: u32) -> ([f64; 2], [f64; 2]) {
    let n = n.max(1);
    let k = (n as f64).sqrt().ceil() as u32;
    let rows = n.div_ceil(k);
    // The first `extra` rows have base + 1 cells, the others base.
    let (base, extra) = (n / rows, n % rows);
    let long = extra * (base + 1);
    let (i, cells, start) = if m < long {
        (m % (base + 1), base + 1, (m / (base + 1)) * (base + 1))
    } else {
        let j = (m - long) / base;
        ((m - long) % base, base, long + j * base)
    };
    (
        [i as f64 / cells as f64, start as f64 / n as f64],
        [1.0 / cells as f64, cells as f64 / n as f64],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundle_directions_cover_the_hemisphere_uniformly() {
        // Uniform on the hemisphere: E[z] = 1/2, E[z²] = 1/3.
        let n = 400;
        let (mut s1, mut s2) = (0.0, 0.0);
        for m in 0..n {
            let d = bundle_direction(m, n, 9);
            assert!((d.length() - 1.0).abs() < 1e-12 && d.z > 0.0);
            s1 += d.z;
            s2 += d.z * d.z;
        }
        assert!((s1 / n as f64 - 0.5).abs() < 0.01);
        assert!((s2 / n as f64 - 1.0 / 3.0).abs() < 0.01);
    }

    #[test]
    fn direction_strata_tile_the_square_for_any_count() {
        // Each bundle direction is uniform in its own stratum, so the set is unbiased only
        // if the strata tile (cos θ, φ/2π) ∈ [0, 1)² with equal areas, for every n (not just
        // squares: 8 192 directions in 4 parts is 2 048 per part).
        for n in [1u32, 2, 7, 17, 257, 1000, 2048, 3001] {
            let cells: Vec<([f64; 2], [f64; 2])> = (0..n).map(|m| stratum(m, n)).collect();
            for (_, size) in &cells {
                assert!(
                    (size[0] * size[1] - 1.0 / n as f64).abs() < 1e-12,
                    "n = {n}"
                );
            }
            let g = 97;
            for a in 0..g {
                for b in 0..g {
                    let p = [(a as f64 + 0.5) / g as f64, (b as f64 + 0.5) / g as f64];
                    let owners = cells
                        .iter()
                        .filter(|(lo, size)| {
                            (0..2).all(|c| p[c] >= lo[c] && p[c] < lo[c] + size[c])
                        })
                        .count();
                    assert_eq!(owners, 1, "n = {n}: point {p:?} in {owners} strata");
                }
            }
        }
    }
}
