//! HDR image skies (issue 16): captured or rendered sky radiance, in an equirectangular or
//! an angular-fisheye mapping, as a [`SkyDistribution`].
//!
//! A sky node's radiance is the image's radiance integrated over the node by solid angle
//! ([`SkyDistribution::mean_over`]): every pixel is split into 3 × 3 sub-samples, each
//! carrying its share of the pixel's solid angle (from the mapping's area element), and a
//! node takes the sub-samples inside it. So the sky tree reads the image's energy, not the
//! nearest pixel at a few points; a uniform image gives E = πL on a horizontal plane.
//!
//! Mappings (scene frame, x east, y north, z up; `rotate_deg` turns the image clockwise
//! seen from above, i.e. adds to every azimuth):
//! - **equirect:** the full sphere; column `u` (0 at the left edge) is the azimuth
//!   clockwise from north, 360° × u, so north is at both edges and south in the middle;
//!   row `v` (0 at the top) is the zenith angle, 180° × v (the lower half is ground).
//! - **angular:** Radiance's `-vta -vd 0 0 1 -vu 0 1 0 -vh 180 -vv 180`, a fisheye looking
//!   up with north at the top (east on the left, as a sky map); the circle is the horizon.
//!
//! The sun: with a DNI given, the saturated pixels (within 1 % of the image's largest
//! grey value, above the horizon) are taken out of the sky (set to the mean radiance of
//! the pixels around them) and their luminance-weighted centre becomes a parallel sun of
//! that DNI; without one, the sun is whatever the image holds.

use super::SkyDistribution;
use crate::photometry::{grey, Rgb};
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// How an image maps onto directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mapping {
    /// Equirectangular, full sphere (see the module doc).
    Equirect,
    /// Angular fisheye of the upper hemisphere, zenith at the centre (see the module doc).
    Angular,
}

/// Sub-samples per pixel side.
const SUB: usize = 3;
/// Bins per degree of zenith angle and azimuth for the sub-sample index.
const BIN_DEG: f64 = 1.0;

/// A sky from an HDR image: RGB radiance W·sr⁻¹·m⁻² per pixel.
pub struct ImageSky {
    width: usize,
    height: usize,
    mapping: Mapping,
    rotate_rad: f64,
    rgb: Vec<Rgb>,
    /// Sub-samples above the horizon: (unit direction, pixel, solid angle sr), sorted by
    /// bin; `bins[b]..bins[b + 1]` are bin `b`'s.
    samples: Vec<(DVec3, u32, f64)>,
    bins: Vec<u32>,
}

fn n_theta() -> usize {
    (90.0 / BIN_DEG) as usize
}

fn n_phi() -> usize {
    (360.0 / BIN_DEG) as usize
}

/// Zenith angle and azimuth (clockwise from north, [0, 2π)) of unit `d`.
fn angles(d: DVec3) -> (f64, f64) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let phi = d.x.atan2(d.y).rem_euclid(2.0 * PI);
    (theta, phi)
}

fn bin_of(theta: f64, phi: f64) -> usize {
    let t = ((theta.to_degrees() / BIN_DEG) as usize).min(n_theta() - 1);
    let p = ((phi.to_degrees() / BIN_DEG) as usize).min(n_phi() - 1);
    t * n_phi() + p
}

impl ImageSky {
    /// The sky of a `width × height` image (`rgb` row-major from the top-left) in
    /// `mapping`, turned by `rotate_deg` clockwise.
    ///
    /// # Panics
    /// When the sub-sample index (about 400 bytes a pixel) cannot be allocated; pictures a
    /// user gives go through [`ImageSky::try_new`].
    pub fn new(
        width: usize,
        height: usize,
        rgb: Vec<Rgb>,
        mapping: Mapping,
        rotate_deg: f64,
    ) -> ImageSky {
        Self::try_new(width, height, rgb, mapping, rotate_deg)
            .expect("memory for the image sky's sub-sample index")
    }

    /// [`ImageSky::new`], `None` when this machine cannot allocate the sub-sample index
    /// (9 sub-samples of 48 bytes a pixel while it is built): a picture that was read
    /// can still be too large to index, and that must be an error, not an abort.
    pub fn try_new(
        width: usize,
        height: usize,
        rgb: Vec<Rgb>,
        mapping: Mapping,
        rotate_deg: f64,
    ) -> Option<ImageSky> {
        let mut sky = ImageSky {
            width,
            height,
            mapping,
            rotate_rad: rotate_deg.to_radians(),
            rgb,
            samples: Vec::new(),
            bins: Vec::new(),
        };
        sky.index()?;
        Some(sky)
    }

    /// Unit direction and solid-angle density (sr per unit image area, the image being
    /// 1 × 1) at image position (`x`, `y`) in [0, 1] from the left and the top; `None`
    /// outside the mapping.
    fn direction(&self, x: f64, y: f64) -> Option<(DVec3, f64)> {
        let (theta, phi, density) = match self.mapping {
            Mapping::Equirect => {
                let theta = PI * y;
                (theta, 2.0 * PI * x, 2.0 * PI * PI * theta.sin())
            }
            Mapping::Angular => {
                // Image-plane angles (rad): right = west, up = north.
                let (ax, ay) = ((x - 0.5) * PI, (0.5 - y) * PI);
                let r = (ax * ax + ay * ay).sqrt();
                if r > FRAC_PI_2 {
                    return None;
                }
                let density = if r > 0.0 { r.sin() / r } else { 1.0 } * PI * PI;
                // Azimuth clockwise from north: up is north (0), left is east (90°).
                let phi = if r > 0.0 { (-ax).atan2(ay) } else { 0.0 };
                (r, phi, density)
            }
        };
        let phi = phi + self.rotate_rad;
        let (st, ct) = theta.sin_cos();
        Some((DVec3::new(st * phi.sin(), st * phi.cos(), ct), density))
    }

    /// Pixel holding unit direction `d`, if the mapping covers it.
    fn pixel_of(&self, d: DVec3) -> Option<usize> {
        let (theta, phi) = angles(d);
        let phi = (phi - self.rotate_rad).rem_euclid(2.0 * PI);
        let (x, y) = match self.mapping {
            Mapping::Equirect => (phi / (2.0 * PI), theta / PI),
            Mapping::Angular => {
                if theta > FRAC_PI_2 {
                    return None;
                }
                let (ax, ay) = (-theta * phi.sin(), theta * phi.cos());
                (ax / PI + 0.5, 0.5 - ay / PI)
            }
        };
        let col = ((x * self.width as f64) as usize).min(self.width - 1);
        let row = ((y * self.height as f64) as usize).min(self.height - 1);
        Some(row * self.width + col)
    }

    /// The sub-sample index: every pixel's 3 × 3 sub-samples above the horizon; `None`
    /// when its memory cannot be reserved.
    fn index(&mut self) -> Option<()> {
        let (w, h) = (self.width as f64, self.height as f64);
        let area = 1.0 / (w * h * (SUB * SUB) as f64);
        let most = self
            .width
            .checked_mul(self.height)?
            .checked_mul(SUB * SUB)?;
        let mut all: Vec<(usize, DVec3, u32, f64)> = Vec::new();
        all.try_reserve_exact(most).ok()?;
        for row in 0..self.height {
            for col in 0..self.width {
                for i in 0..SUB {
                    for j in 0..SUB {
                        let x = (col as f64 + (i as f64 + 0.5) / SUB as f64) / w;
                        let y = (row as f64 + (j as f64 + 0.5) / SUB as f64) / h;
                        if let Some((d, density)) = self.direction(x, y) {
                            if d.z > 0.0 {
                                let (t, p) = angles(d);
                                let px = (row * self.width + col) as u32;
                                all.push((bin_of(t, p), d, px, density * area));
                            }
                        }
                    }
                }
            }
        }
        // The stable sort keeps the sub-samples of a bin in image order (so sums are
        // reproducible) and allocates half the vector as scratch: probe for that first.
        let scratch =
            (all.len() / 2).checked_mul(std::mem::size_of::<(usize, DVec3, u32, f64)>())?;
        Vec::<u8>::new().try_reserve_exact(scratch).ok()?;
        all.sort_by_key(|s| s.0);
        let nb = n_theta() * n_phi();
        self.bins = vec![0; nb + 1];
        for s in &all {
            self.bins[s.0 + 1] += 1;
        }
        for b in 0..nb {
            self.bins[b + 1] += self.bins[b];
        }
        self.samples.try_reserve_exact(all.len()).ok()?;
        self.samples
            .extend(all.into_iter().map(|(_, d, p, w)| (d, p, w)));
        Some(())
    }

    /// Takes the sun out of the image: the saturated pixels above the horizon (grey value
    /// within 1 % of the largest) are replaced by the mean of the unsaturated pixels
    /// next to them. Returns their luminance-weighted centre, or `None` when nothing is
    /// above the horizon.
    pub fn extract_sun(&mut self) -> Option<DVec3> {
        let up: Vec<bool> = (0..self.rgb.len())
            .map(|i| {
                let (col, row) = (i % self.width, i / self.width);
                let x = (col as f64 + 0.5) / self.width as f64;
                let y = (row as f64 + 0.5) / self.height as f64;
                self.direction(x, y).is_some_and(|(d, _)| d.z > 0.0)
            })
            .collect();
        let top = (0..self.rgb.len())
            .filter(|&i| up[i])
            .map(|i| grey(self.rgb[i]))
            .fold(0.0, f64::max);
        if top <= 0.0 {
            return None;
        }
        let sat: Vec<usize> = (0..self.rgb.len())
            .filter(|&i| up[i] && grey(self.rgb[i]) >= 0.99 * top)
            .collect();
        let (mut centre, mut ring, mut n) = (DVec3::ZERO, Rgb::ZERO, 0.0);
        for &i in &sat {
            let (col, row) = (i % self.width, i / self.width);
            let x = (col as f64 + 0.5) / self.width as f64;
            let y = (row as f64 + 0.5) / self.height as f64;
            if let Some((d, _)) = self.direction(x, y) {
                centre += d * grey(self.rgb[i]);
            }
            for (dc, dr) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (c, r) = (col as i64 + dc, row as i64 + dr);
                if c < 0 || r < 0 || c >= self.width as i64 || r >= self.height as i64 {
                    continue;
                }
                let k = r as usize * self.width + c as usize;
                if grey(self.rgb[k]) < 0.99 * top {
                    ring += self.rgb[k];
                    n += 1.0;
                }
            }
        }
        let fill = if n > 0.0 { ring / n } else { Rgb::ZERO };
        for &i in &sat {
            self.rgb[i] = fill;
        }
        (centre.length() > 0.0).then(|| centre.normalize())
    }

    /// ∫ L cos θ dω over the upper hemisphere from the sub-samples (W/m²).
    pub fn horizontal_irradiance(&self) -> Rgb {
        self.samples.iter().fold(Rgb::ZERO, |a, &(d, p, w)| {
            a + self.rgb[p as usize] * (w * d.z)
        })
    }
}

impl SkyDistribution for ImageSky {
    fn radiance(&self, dir: DVec3) -> Rgb {
        self.pixel_of(dir).map_or(Rgb::ZERO, |p| self.rgb[p])
    }

    fn integrates(&self) -> bool {
        true
    }

    fn mean_over(&self, v: &[DVec3; 3]) -> Option<Rgb> {
        // Edge planes of the spherical triangle (counter-clockwise or not: take the side
        // the third vertex is on).
        let planes: Vec<(DVec3, f64)> = (0..3)
            .map(|k| {
                let (a, b, c) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
                let n = a.cross(b);
                (n, n.dot(c).signum())
            })
            .collect();
        let centre = (v[0] + v[1] + v[2]).normalize();
        let radius = v
            .iter()
            .map(|x| x.dot(centre).clamp(-1.0, 1.0).acos())
            .fold(0.0, f64::max);
        let (tc, pc) = angles(centre);
        let pad = BIN_DEG.to_radians();
        let (t0, t1) = (
            (tc - radius - pad).max(0.0),
            (tc + radius + pad).min(FRAC_PI_2),
        );
        let (mut sum, mut omega) = (Rgb::ZERO, 0.0);
        let rows = (t0.to_degrees() / BIN_DEG) as usize
            ..=((t1.to_degrees() / BIN_DEG) as usize).min(n_theta() - 1);
        for tb in rows {
            // Azimuth half-width of the cap at this ring (all of it near the zenith).
            let ring_t = ((tb as f64 + 0.5) * BIN_DEG).to_radians().max(1e-9);
            let half = if tc <= radius + pad || ring_t <= radius + pad {
                PI
            } else {
                ((radius + pad).sin() / ring_t.sin().max((tc - radius - pad).sin()))
                    .min(1.0)
                    .asin()
                    + 2.0 * pad
            };
            let bins: Vec<usize> = if half >= PI {
                (0..n_phi()).collect()
            } else {
                let lo = ((pc - half).to_degrees() / BIN_DEG).floor() as i64;
                let hi = ((pc + half).to_degrees() / BIN_DEG).ceil() as i64;
                (lo..=hi)
                    .map(|p| p.rem_euclid(n_phi() as i64) as usize)
                    .collect()
            };
            for pb in bins {
                let b = tb * n_phi() + pb;
                for &(d, p, w) in &self.samples[self.bins[b] as usize..self.bins[b + 1] as usize] {
                    if planes.iter().all(|&(n, s)| n.dot(d) * s >= 0.0) {
                        sum += self.rgb[p as usize] * w;
                        omega += w;
                    }
                }
            }
        }
        (omega > 0.0).then(|| sum / omega)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::spherical_triangle;

    fn uniform(mapping: Mapping, w: usize, h: usize) -> ImageSky {
        ImageSky::new(w, h, vec![Rgb::splat(2.0); w * h], mapping, 0.0)
    }

    #[test]
    fn sub_samples_cover_the_hemisphere_with_pi_projected() {
        for (m, w, h) in [(Mapping::Equirect, 128, 64), (Mapping::Angular, 96, 96)] {
            let s = uniform(m, w, h);
            let omega: f64 = s.samples.iter().map(|x| x.2).sum();
            let proj: f64 = s.samples.iter().map(|x| x.2 * x.0.z).sum();
            assert!(
                (omega - 2.0 * PI).abs() < 2e-3 * 2.0 * PI,
                "{m:?} ω {omega}"
            );
            assert!((proj - PI).abs() < 2e-3 * PI, "{m:?} cos-weighted {proj}");
        }
    }

    #[test]
    fn directions_and_pixels_agree_in_both_mappings() {
        for (m, w, h) in [(Mapping::Equirect, 64, 32), (Mapping::Angular, 64, 64)] {
            let s = ImageSky::new(w, h, vec![Rgb::ZERO; w * h], m, 30.0);
            for (col, row) in [(5, 3), (20, 10), (40, 12), (31, 31)] {
                if row >= h {
                    continue;
                }
                let x = (col as f64 + 0.5) / w as f64;
                let y = (row as f64 + 0.5) / h as f64;
                let Some((d, _)) = s.direction(x, y) else {
                    continue;
                };
                assert_eq!(s.pixel_of(d), Some(row * w + col), "{m:?} {col} {row}");
            }
        }
        // Angular: north at the top, east on the left.
        let s = ImageSky::new(64, 64, vec![Rgb::ZERO; 64 * 64], Mapping::Angular, 0.0);
        let (north, _) = s.direction(0.5, 0.25).unwrap();
        let (east, _) = s.direction(0.25, 0.5).unwrap();
        assert!(north.y > 0.7 && north.x.abs() < 1e-9, "{north}");
        assert!(east.x > 0.7 && east.y.abs() < 1e-9, "{east}");
    }

    #[test]
    fn node_means_weigh_pixels_by_solid_angle() {
        // Radiance = z (cos of zenith): a node's exact mean is ∫ z dω / ω.
        let (w, h) = (720, 360);
        let mut rgb = vec![Rgb::ZERO; w * h];
        for row in 0..h {
            let z = (PI * (row as f64 + 0.5) / h as f64).cos();
            for col in 0..w {
                rgb[row * w + col] = Rgb::splat(z.max(0.0));
            }
        }
        let s = ImageSky::new(w, h, rgb, Mapping::Equirect, 0.0);
        let v = [
            DVec3::new(1.0, 0.0, 0.2).normalize(),
            DVec3::new(0.0, 1.0, 0.3).normalize(),
            DVec3::new(0.3, 0.3, 1.0).normalize(),
        ];
        let got = s.mean_over(&v).unwrap().x;
        let omega = spherical_triangle::solid_angle(v[0], v[1], v[2]);
        let exact = spherical_triangle::projected_solid_angle(v[0], v[1], v[2], DVec3::Z) / omega;
        assert!((got - exact).abs() < 3e-3 * exact, "{got} against {exact}");
    }

    #[test]
    fn saturated_pixels_become_the_sun_and_leave_the_sky() {
        // Equirect 360 × 180 (1° pixels): a 3 × 3 saturated patch centred at azimuth
        // 135.5°, zenith angle 40.5° on a sky of 1.
        let (w, h) = (360, 180);
        let mut rgb = vec![Rgb::ONE; w * h];
        for row in 39..42 {
            for col in 134..137 {
                rgb[row * w + col] = Rgb::splat(5e4);
            }
        }
        let mut s = ImageSky::new(w, h, rgb, Mapping::Equirect, 0.0);
        let d = s.extract_sun().unwrap();
        let (t, p) = angles(d);
        assert!(
            (t.to_degrees() - 40.5).abs() < 0.05,
            "zenith {}",
            t.to_degrees()
        );
        assert!(
            (p.to_degrees() - 135.5).abs() < 0.05,
            "azimuth {}",
            p.to_degrees()
        );
        assert!(s
            .rgb
            .iter()
            .all(|c| (*c - Rgb::ONE).abs().max_element() < 1e-12));
    }
}
