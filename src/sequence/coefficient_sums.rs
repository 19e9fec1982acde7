//! The per-step sums of daylight coefficients ([`super::Coefficients::evaluate`]), the
//! inner loops of a warm annual run: compiled for baseline x86-64 and again with AVX2,
//! chosen at run time. Both do the same operations in the same order (no fused
//! multiply-add, which rounds once instead of twice), so they give the same bits; AVX2
//! does eight lanes at a time instead of four. Also the order the nodes are summed in.

use crate::sources::SourceKey;

/// One node's weights in a step: its children's grey radiance and its own
/// (W·sr⁻¹·m⁻²), and its normal irradiance (W/m²).
#[derive(Clone, Copy)]
pub(super) struct Weights {
    pub children: [f32; 4],
    pub node: f32,
    pub irradiance: f32,
}

impl Weights {
    /// The weights of the grey source `src`.
    pub fn of(src: &crate::sources::Source) -> Weights {
        Weights {
            children: src.child_radiance.map(super::g),
            node: super::g(src.radiance),
            irradiance: super::g(src.normal_irradiance),
        }
    }
}

/// Adds a node's rows to a step's accumulators `acc` (sky, Σ L̂ × response sum,
/// uncertainty, then `indirect.len()` of interreflected rows; `k` sensors each): `direct`
/// holds its 4 children's responses, their sum and the children's 4 uncertainties. The
/// direct rows in one pass over the sensors.
#[allow(unsafe_code)] // calling the AVX2 build once the CPU is known to have AVX2
pub(super) fn add_node(acc: &mut [f32], k: usize, direct: &[f32], indirect: &[f32], w: Weights) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, checked just above.
        return unsafe { add_node_avx2(acc, k, direct, indirect, w) };
    }
    add_node_any(acc, k, direct, indirect, w)
}

/// y += a·x.
#[allow(unsafe_code)] // as in add_node
pub(super) fn axpy(y: &mut [f32], a: f32, x: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, checked just above.
        return unsafe { axpy_avx2(y, a, x) };
    }
    axpy_any(y, a, x)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn add_node_avx2(acc: &mut [f32], k: usize, direct: &[f32], indirect: &[f32], w: Weights) {
    add_node_any(acc, k, direct, indirect, w)
}

/// `err += (a·row)²`, lux² (`row` in lux per unit of `a`; empty: nothing): errors of
/// interreflected rows taken from ancestors ([`super::indirect_ancestors`]), combined in
/// quadrature.
#[allow(unsafe_code)] // as in add_node
pub(super) fn add_err(err: &mut [f64], a: f32, row: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, checked just above.
        return unsafe { add_err_avx2(err, a, row) };
    }
    add_err_any(err, a, row)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn add_err_avx2(err: &mut [f64], a: f32, row: &[f32]) {
    add_err_any(err, a, row)
}

#[inline(always)]
fn add_err_any(err: &mut [f64], a: f32, row: &[f32]) {
    for (e, r) in err.iter_mut().zip(row) {
        *e += (a as f64 * *r as f64).powi(2);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn axpy_avx2(y: &mut [f32], a: f32, x: &[f32]) {
    axpy_any(y, a, x)
}

#[inline(always)]
fn add_node_any(acc: &mut [f32], k: usize, direct: &[f32], indirect: &[f32], w: Weights) {
    let (sky, rest) = acc.split_at_mut(k);
    let (refsum, rest) = rest.split_at_mut(k);
    let (unc, ind) = rest.split_at_mut(k);
    let row = |r: usize| &direct[r * k..(r + 1) * k];
    let (d0, d1, d2, d3, d4) = (row(0), row(1), row(2), row(3), row(4));
    let (u0, u1, u2, u3) = (row(5), row(6), row(7), row(8));
    let l = w.children;
    for s in 0..k {
        sky[s] += l[0] * d0[s] + l[1] * d1[s] + l[2] * d2[s] + l[3] * d3[s];
        refsum[s] += w.node * d4[s];
        unc[s] += l[0] * u0[s] + l[1] * u1[s] + l[2] * u2[s] + l[3] * u3[s];
    }
    axpy_any(&mut ind[..indirect.len()], w.irradiance, indirect);
}

#[inline(always)]
fn axpy_any(y: &mut [f32], a: f32, x: &[f32]) {
    if a == 0.0 {
        return;
    }
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * *x;
    }
}

/// A sky or ground node's key and a step `j` as one u64 in the order of (key, j): the
/// variant, the face, the path in 40 bits (depth 19; presets stop at 7), then `j` in 20.
fn packed(k: &SourceKey, j: usize) -> Option<u64> {
    let (variant, n) = match k {
        SourceKey::Sky(n) => (0u64, n),
        SourceKey::Ground(n) => (1, n),
        _ => return None,
    };
    (n.path >> 40 == 0 && j >> 20 == 0)
        .then(|| (variant << 43 | u64::from(n.base) << 40 | n.path) << 20 | j as u64)
}

/// Sorts a call's node uses by key, then step: each step then sums its nodes in key
/// order. Through one u64 per use where every use packs (sorting the uses by their enum
/// keys was a twentieth of a warm annual run), the same order either way.
pub(super) fn sort_uses<T: Copy>(uses: &mut Vec<(SourceKey, usize, T)>) {
    let order: Option<Vec<(u64, u32)>> = uses
        .iter()
        .enumerate()
        .map(|(i, u)| packed(&u.0, u.1).map(|k| (k, i as u32)))
        .collect();
    match order {
        Some(mut order) if uses.len() < u32::MAX as usize => {
            order.sort_unstable();
            *uses = order.iter().map(|&(_, i)| uses[i as usize]).collect();
        }
        _ => uses.sort_by_key(|u| (u.0, u.1)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_keys_sort_as_the_keys_do() {
        use crate::sources::SkyNodeKey;
        let mut i = 0u64;
        let mut next = move || {
            i += 1;
            crate::math::rng::mix64(i)
        };
        let mut uses: Vec<(SourceKey, usize, ())> = (0..5000)
            .map(|_| {
                let depth = next() % 9;
                let mut n = SkyNodeKey::root((next() % 8) as u8);
                for _ in 0..depth {
                    n = n.child((next() % 4) as u8);
                }
                let key = if n.is_sky() {
                    SourceKey::Sky(n)
                } else {
                    SourceKey::Ground(n)
                };
                (key, (next() % 24) as usize, ())
            })
            .collect();
        let mut by_key = uses.clone();
        by_key.sort_by_key(|u| (u.0, u.1));
        sort_uses(&mut uses);
        assert!(uses
            .iter()
            .zip(&by_key)
            .all(|(a, b)| (a.0, a.1) == (b.0, b.1)));
    }

    #[test]
    fn both_kernels_give_the_same_bits() {
        // Values spread over many magnitudes, so that any change of the order or the
        // rounding of the operations shows.
        let k = 37;
        let v = |i: usize| {
            let m = (i.wrapping_mul(2_654_435_761) % 1000) as f32 / 37.0;
            m * 10f32.powi((i % 7) as i32 - 3)
        };
        let direct: Vec<f32> = (0..9 * k).map(v).collect();
        let indirect: Vec<f32> = (0..5 * k).map(|i| v(i + 1000)).collect();
        let w = Weights {
            children: [0.3, 1.7e-3, 41.0, 2.5],
            node: 11.3,
            irradiance: 0.071,
        };
        let mut a: Vec<f32> = (0..8 * k).map(|i| v(i + 5000)).collect();
        let mut b = a.clone();
        add_node_any(&mut a, k, &direct, &indirect, w);
        add_node(&mut b, k, &direct, &indirect, w);
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        // And the sums are the sums: sensor 5's sky.
        let s = 5;
        let want: f32 = (0..4).map(|c| w.children[c] * direct[c * k + s]).sum();
        let before = v(s + 5000);
        assert!((a[s] - before - want).abs() <= 1e-5 * (before.abs() + want.abs() + 1.0));
        // The errors in quadrature, alike.
        let mut e: Vec<f64> = (0..k).map(|i| v(i + 9000) as f64).collect();
        let mut f = e.clone();
        add_err_any(&mut e, w.irradiance, &indirect[..k]);
        add_err(&mut f, w.irradiance, &indirect[..k]);
        assert_eq!(
            e.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            f.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let want = v(9005) as f64 + (w.irradiance as f64 * indirect[5] as f64).powi(2);
        assert!((e[5] - want).abs() <= 1e-12 * want);
    }
}
