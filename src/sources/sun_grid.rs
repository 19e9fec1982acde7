//! The sun's interpolation grid: fixed directions at altitude i·δ and azimuth j·δ_az
//! (δ_az = 360°/round(360°/δ)), whose interreflection responses the sun's interreflected
//! light is interpolated between, bilinearly in (altitude, azimuth). The sun's direct
//! light does not use it (it stays exact, [`super::SunKey`]).
//!
//! Why bilinear on altitude and azimuth rather than barycentric on the sky tree: the
//! horizon is a grid line (a sun at 0.1° interpolates between the horizon row and the
//! row above, never below the ground), and a cell's four corners are found by two
//! floors, with no search.

use super::{Source, SourceKey, SunKey};
use crate::photometry::Rgb;
use glam::DVec3;

/// A bilinear grid of sun directions with spacing `spacing_deg` (degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunGrid {
    /// Altitude spacing δ, degrees; the azimuth spacing is the nearest divisor of 360°.
    pub spacing_deg: f64,
}

impl SunGrid {
    fn steps(&self) -> (u32, f64, i32, f64) {
        let d = self.spacing_deg.clamp(1e-3, 90.0);
        let rows = (90.0 / d).ceil() as i32;
        let n_az = (360.0 / d).round().max(1.0) as u32;
        (n_az, 360.0 / n_az as f64, rows, d)
    }

    /// The key of grid vertex (altitude row `row`, azimuth column `col`): a [`SunKey`]
    /// whose `band` is the row and `index` the column.
    fn key(&self, row: i32, col: i32) -> SunKey {
        SunKey {
            band: row,
            index: col,
            spacing_udeg: (self.spacing_deg * 1e6).round().max(1.0) as u32,
        }
    }

    /// Unit direction of grid vertex `key` (scene frame).
    pub fn direction(&self, key: SunKey) -> DVec3 {
        let (_, daz, _, d) = self.steps();
        let alt = (key.band as f64 * d).min(90.0);
        crate::site::direction_from_alt_az(alt, key.index as f64 * daz)
    }

    /// The grid vertices around the sun at unit direction `dir` (above the horizon) with
    /// their bilinear weights (summing to 1; zero weights left out).
    pub fn corners(&self, dir: DVec3) -> Vec<(SunKey, f64)> {
        let (n_az, daz, rows, d) = self.steps();
        let alt = dir.z.clamp(0.0, 1.0).asin().to_degrees();
        let az = dir.x.atan2(dir.y).to_degrees().rem_euclid(360.0);
        let u = (alt / d).clamp(0.0, rows as f64);
        let r0 = (u.floor() as i32).min(rows - 1);
        let fu = u - r0 as f64;
        let v = az / daz;
        let c0 = v.floor() as i64;
        let fv = v - c0 as f64;
        let col = |k: i64| k.rem_euclid(n_az as i64) as i32;
        let mut out = Vec::with_capacity(4);
        for (dr, wu) in [(0, 1.0 - fu), (1, fu)] {
            for (dc, wv) in [(0, 1.0 - fv), (1, fv)] {
                let w = wu * wv;
                if w > 0.0 {
                    out.push((self.key(r0 + dr, col(c0 + dc)), w));
                }
            }
        }
        out
    }

    /// Grid vertex `key` as a parallel source of unit normal irradiance (what its
    /// projection and interreflection response are computed for).
    pub fn source(&self, key: SunKey) -> Source {
        let dir = self.direction(key);
        Source {
            key: SourceKey::SunGrid(key),
            direction: dir,
            normal_irradiance: Rgb::ONE,
            radiance: Rgb::ZERO,
            child_radiance: [Rgb::ZERO; 4],
            solid_angle: 0.0,
            vertices: None,
            true_direction: dir,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_reproduce_the_direction_bilinearly() {
        let g = SunGrid { spacing_deg: 3.0 };
        for (alt, az) in [(0.1, 10.0), (45.0, 359.9), (88.0, 123.0), (30.0, 90.0)] {
            let d = crate::site::direction_from_alt_az(alt, az);
            let c = g.corners(d);
            let w: f64 = c.iter().map(|x| x.1).sum();
            assert!((w - 1.0).abs() < 1e-12);
            // Every corner lies within one cell of the sun, never below the horizon.
            for (k, _) in &c {
                let cd = g.direction(*k);
                assert!(cd.z >= -1e-12);
                assert!(cd.angle_between(d).to_degrees() < 3.0 * 1.5);
            }
            // The weighted altitude is the sun's altitude (bilinear in altitude).
            let a: f64 = c
                .iter()
                .map(|(k, w)| w * (k.band as f64 * 3.0).min(90.0))
                .sum();
            assert!((a - alt).abs() < 1e-9, "{a} vs {alt}");
        }
        // On a vertex: that vertex carries the whole weight (to rounding).
        let d = crate::site::direction_from_alt_az(30.0, 90.0);
        let c = g.corners(d);
        let top = c.iter().fold(0.0f64, |a, x| a.max(x.1));
        assert!(top > 1.0 - 1e-9, "{c:?}");
        let k = c.iter().find(|x| x.1 == top).unwrap().0;
        assert!(g.direction(k).angle_between(d) < 1e-9);
    }
}
