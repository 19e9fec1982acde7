//! The final gather's filter: each pixel's gathered interreflection (and sky) re-estimated
//! from the pixels around it on the same plane of the same material, over a window that
//! grows until the estimate's stated error is small (an edge-aware filter guided by the
//! stated error).
//!
//! The estimate is a local linear fit (value = a + b·dx + c·dy over the window, least
//! squares, read at the pixel): unlike a plain mean it has no bias where light varies
//! linearly across the window, which matters where the window is cut by an edge of the
//! plane and its centroid is off the pixel (corners, the window's reveal). The fit is a
//! weighted sum of the pixels' own estimates, Σ lᵢ yᵢ, so its variance is Σ lᵢ² σᵢ² from
//! each pixel's own variance, and the mesh discretisation term is the same weighted sum of
//! each pixel's signed fine − coarse difference, taken absolute after the sum (per pixel,
//! the absolute difference of 16 rays was mostly the rays' noise, not the mesh's error),
//! and a third of it is the fine mesh's error ([`DISCRETISATION_SHARE`]).
//! What the fit cannot see (curvature of the light within the window) is kept small by
//! the largest radius and checked against brute force (docs/render.md).
//!
//! The pixel order does not matter, so neither does the thread count.

use crate::photometry::{grey, Rgb};
use rayon::prelude::*;

/// The smallest half-width of the window (pixels).
const FIRST_RADIUS: usize = 2;

/// The window grows while the pixel's stated error (noise and discretisation) is above
/// this fraction of its value, up to the largest radius the caller allows.
const TARGET: f64 = 0.01;

/// What the image's error takes of a mesh discretisation difference (fine − one level
/// coarser): Richardson's 1 / (2^p − 1) for halving the element size, with p = 2. A pixel
/// reads element averages of a Galerkin solution, integrated over its gather's solid
/// angle; both the averages and that integration are second order in the element size
/// where the kernel is smooth, so fine − coarse is about three times the fine mesh's own
/// error, not one. Measured on the sample office (docs/render.md): where this term
/// dominates, brute force differed by a quarter of |fine − coarse| and a mesh one level
/// finer moved the pixels by about a tenth of it. The sensors' `lux_err` keeps the whole
/// difference (their benches have no such slack, issue 23).
pub(super) const DISCRETISATION_SHARE: f64 = 1.0 / 3.0;

/// One pixel of the gather before filtering.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PixelOut {
    /// Everything but the gathered part (radiance, or irradiance).
    pub direct: Rgb,
    /// The gathered interreflection and sky.
    pub ind: Rgb,
    /// Variance of `direct`'s mean (antialiasing) plus the parts' variance (grey).
    pub var_direct: f64,
    /// Variance of `ind`'s mean over antialiasing samples (grey).
    pub var_ind: f64,
    /// Signed mesh discretisation difference of `ind` (fine − one level coarser, grey).
    pub disc: f64,
    /// |fine − coarse| per sample, summed (grey): the discretisation term of a pixel the
    /// filter leaves alone.
    pub disc_abs: f64,
    /// The solve's iteration error (grey).
    pub iteration: f64,
    /// Whether `var_ind` was measured (two or more antialiasing samples): without it the
    /// window does not grow, since its noise could not be told from the light's variation.
    pub noise_known: bool,
    /// The plane all its samples lie on (0: several, glazing or sky: not filtered).
    pub key: u64,
    pub valid: bool,
}

/// A filtered pixel: its value and its stated error (1σ noise plus bias, grey).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Filtered {
    pub value: Rgb,
    pub err: f64,
}

/// Every pixel of a `w × h` image filtered over windows of half-width up to `max_radius`
/// (0: no filtering, each pixel as gathered).
pub(super) fn filter(px: &[PixelOut], w: usize, h: usize, max_radius: usize) -> Vec<Filtered> {
    (0..px.len())
        .into_par_iter()
        .map(|i| {
            let p = px[i];
            let alone = Filtered {
                value: p.direct + p.ind,
                err: (p.var_direct + p.var_ind).sqrt()
                    + DISCRETISATION_SHARE * p.disc_abs
                    + p.iteration,
            };
            if max_radius == 0 || p.key == 0 {
                return alone;
            }
            let mut best = alone;
            let mut r = FIRST_RADIUS.min(max_radius);
            loop {
                if let Some(f) = fit(px, w, h, i, r) {
                    best = Filtered {
                        value: p.direct + f.ind,
                        err: (p.var_direct + f.var).sqrt()
                            + DISCRETISATION_SHARE * f.disc.abs()
                            + p.iteration,
                    };
                }
                let small = best.err <= TARGET * grey(best.value).abs();
                if r >= max_radius || small || !p.noise_known {
                    return best;
                }
                r = (r * 3).div_ceil(2).min(max_radius);
            }
        })
        .collect()
}

/// A window's estimate at its centre pixel.
struct Fit {
    ind: Rgb,
    var: f64,
    disc: f64,
}

/// The local linear fit at pixel `i` over the pixels within `r` on its plane; a plain mean
/// where those pixels are too few or lie on a line.
fn fit(px: &[PixelOut], w: usize, h: usize, i: usize, r: usize) -> Option<Fit> {
    let key = px[i].key;
    let (x, y) = (i % w, i / w);
    let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
    let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
    let members = || {
        (y0..y1).flat_map(move |yy| {
            (x0..x1).filter_map(move |xx| {
                let q = &px[yy * w + xx];
                (q.key == key).then_some((xx as f64 - x as f64, yy as f64 - y as f64, q))
            })
        })
    };
    // Normal equations of value = a + b dx + c dy.
    let mut s = [[0.0f64; 3]; 3];
    for (dx, dy, _) in members() {
        let v = [1.0, dx, dy];
        for (row, a) in s.iter_mut().zip(v) {
            for (e, b) in row.iter_mut().zip(v) {
                *e += a * b;
            }
        }
    }
    let n = s[0][0];
    if n < 2.0 {
        return None;
    }
    // The first row of S⁻¹, so lᵢ = c · (1, dx, dy); a plain mean (c = (1/n, 0, 0)) when
    // S is near singular (pixels on one line, or too few for three coefficients).
    let c = first_row_of_inverse(&s).unwrap_or([1.0 / n, 0.0, 0.0]);
    let (mut ind, mut var, mut disc) = (Rgb::ZERO, 0.0, 0.0);
    for (dx, dy, q) in members() {
        let l = c[0] + c[1] * dx + c[2] * dy;
        ind += q.ind * l;
        var += l * l * q.var_ind;
        disc += l * q.disc;
    }
    Some(Fit { ind, var, disc })
}

/// The first row of the inverse of the symmetric 3 × 3 matrix `s`, or `None` when `s` is
/// near singular (determinant below 1e-9 of its diagonal's product).
fn first_row_of_inverse(s: &[[f64; 3]; 3]) -> Option<[f64; 3]> {
    let c00 = s[1][1] * s[2][2] - s[1][2] * s[2][1];
    let c01 = s[0][2] * s[2][1] - s[0][1] * s[2][2];
    let c02 = s[0][1] * s[1][2] - s[0][2] * s[1][1];
    let det = s[0][0] * c00 + s[1][0] * c01 + s[2][0] * c02;
    let scale = s[0][0] * s[1][1] * s[2][2];
    // NaN determinants fail the comparison and are refused too.
    if s[0][0] < 4.0 || det.is_nan() || det <= 1e-9 * scale {
        return None;
    }
    Some([c00 / det, c01 / det, c02 / det])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(ind: f64, var: f64, key: u64) -> PixelOut {
        PixelOut {
            ind: Rgb::new(ind, ind, ind),
            var_ind: var,
            key,
            valid: true,
            noise_known: true,
            ..PixelOut::default()
        }
    }

    #[test]
    fn a_linear_ramp_is_reproduced_even_in_a_corner() {
        // value = 10 + 0.5 x − 0.25 y on one plane: the fit is exact wherever the window
        // sits, also at the image's corner where the window is cut to a quarter.
        let (w, h) = (20, 15);
        let px: Vec<PixelOut> = (0..w * h)
            .map(|i| pixel(10.0 + 0.5 * (i % w) as f64 - 0.25 * (i / w) as f64, 1.0, 7))
            .collect();
        let out = filter(&px, w, h, 8);
        for (i, f) in out.iter().enumerate() {
            let want = grey(px[i].ind);
            assert!((grey(f.value) - want).abs() < 1e-9, "pixel {i}");
        }
    }

    #[test]
    fn the_stated_noise_is_that_of_the_weighted_sum() {
        // A full symmetric window is a plain mean: variance σ²/n, here 1/25 at radius 2
        // (the radius stops growing once 1 % is reached: value 1000, σ/5 = 0.2).
        let (w, h) = (11, 11);
        let px: Vec<PixelOut> = (0..w * h).map(|_| pixel(1000.0, 1.0, 3)).collect();
        let f = filter(&px, w, h, 8)[5 * w + 5];
        assert!((f.err - 0.2).abs() < 1e-9, "{}", f.err);
    }

    #[test]
    fn a_third_of_the_mesh_difference_is_stated_filtered_or_not() {
        // No noise, a signed fine − coarse of 6 everywhere: the fit's weights sum to one,
        // so a filtered pixel states 6 / 3; an unkeyed pixel states its own |d| / 3.
        let (w, h) = (9, 9);
        let px: Vec<PixelOut> = (0..w * h)
            .map(|i| PixelOut {
                disc: 6.0,
                disc_abs: 6.0,
                key: if i == 0 { 0 } else { 4 },
                ..pixel(100.0, 0.0, 4)
            })
            .collect();
        let out = filter(&px, w, h, 8);
        assert!(
            (out[4 * w + 4].err - 2.0).abs() < 1e-9,
            "{}",
            out[4 * w + 4].err
        );
        assert!((out[0].err - 2.0).abs() < 1e-12, "{}", out[0].err);
    }

    #[test]
    fn other_planes_and_unkeyed_pixels_are_left_out() {
        // Left half key 1 at 100, right half key 2 at 300, a middle column unkeyed at 50.
        let (w, h) = (9, 9);
        let px: Vec<PixelOut> = (0..w * h)
            .map(|i| match i % w {
                0..=3 => pixel(100.0, 4.0, 1),
                4 => pixel(50.0, 4.0, 0),
                _ => pixel(300.0, 4.0, 2),
            })
            .collect();
        let out = filter(&px, w, h, 4);
        for (i, f) in out.iter().enumerate() {
            assert!((grey(f.value) - grey(px[i].ind)).abs() < 1e-9, "pixel {i}");
        }
        // The unkeyed pixel keeps its own noise; filtered ones state less.
        assert!((out[4].err - 2.0).abs() < 1e-12);
        assert!(out[0].err < 2.0 && out[8].err < 2.0);
    }

    #[test]
    fn noise_shrinks_as_the_window_grows_and_the_mean_stays() {
        // Deterministic ±3 noise about 20: the filtered value stays within its stated
        // error of 20 and states less error than one pixel's 3.
        let (w, h) = (40, 40);
        let px: Vec<PixelOut> = (0..w * h)
            .map(|i| {
                let s = if crate::math::rng::mix64(i as u64) & 1 == 0 {
                    3.0
                } else {
                    -3.0
                };
                pixel(20.0 + s, 9.0, 5)
            })
            .collect();
        for f in filter(&px, w, h, 8) {
            assert!(f.err < 3.0 * 0.5, "{}", f.err);
            assert!(
                (grey(f.value) - 20.0).abs() <= 3.0 * f.err,
                "{} ± {}",
                grey(f.value),
                f.err
            );
        }
    }
}
