//! Exact, reusable keys for projection directions: a node of the fixed octahedral quadtree
//! (base face + path), and a cell of the fixed sun-snapping grid.

use crate::math::{quadtree, spherical_triangle};
use glam::DVec3;

/// The 8 faces of the octahedron; 0–3 above the horizon, 4–7 below. Vertex order is
/// counter-clockwise seen from outside.
const BASE: [[DVec3; 3]; 8] = [
    [DVec3::X, DVec3::Y, DVec3::Z],
    [DVec3::Y, DVec3::NEG_X, DVec3::Z],
    [DVec3::NEG_X, DVec3::NEG_Y, DVec3::Z],
    [DVec3::NEG_Y, DVec3::X, DVec3::Z],
    [DVec3::Y, DVec3::X, DVec3::NEG_Z],
    [DVec3::NEG_X, DVec3::Y, DVec3::NEG_Z],
    [DVec3::NEG_Y, DVec3::NEG_X, DVec3::NEG_Z],
    [DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z],
];

/// A node of the octahedral quadtree: `base` face 0..8 and a path of child indices.
/// `path` is heap-encoded: 1 is the base face, child k of node p is `4p + k`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SkyNodeKey {
    /// Octahedron face, 0..4 sky, 4..8 ground.
    pub base: u8,
    /// Heap-encoded path (1 = the face itself).
    pub path: u64,
}

crate::quadtree_key!(SkyNodeKey, base: u8);

impl SkyNodeKey {
    /// Unit vertices of the node's spherical triangle, recomputed from the base face so
    /// the same key always gives bit-identical directions.
    pub fn vertices(&self) -> [DVec3; 3] {
        quadtree::descend(BASE[self.base as usize], self.path, |t| {
            spherical_triangle::split(t[0], t[1], t[2])
        })
    }
    /// True for the four faces above the horizon and their descendants.
    pub fn is_sky(&self) -> bool {
        self.base < 4
    }
    /// A single 64-bit id (base in the top byte), for file names and hashing.
    pub fn id(&self) -> u64 {
        ((self.base as u64) << 56) | self.path
    }
}

/// A cell of the fixed sun grid: altitude band `band` (centre (band + ½)·δ) and azimuth
/// index `index` within the band, for spacing δ in micro-degrees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SunKey {
    /// Altitude band; the band centre is (band + ½)·δ.
    pub band: i32,
    /// Azimuth cell within the band.
    pub index: i32,
    /// Grid spacing δ, micro-degrees.
    pub spacing_udeg: u32,
}

impl SunKey {
    /// Snaps a sun at `altitude_deg`, `azimuth_deg` (clockwise from north) onto the grid of
    /// spacing `spacing_deg`. Band centres are at (k + ½)·δ, so a sun above the horizon
    /// stays above it after snapping.
    pub fn snap(altitude_deg: f64, azimuth_deg: f64, spacing_deg: f64) -> SunKey {
        let spacing_udeg = (spacing_deg * 1e6).round().max(1.0) as u32;
        let d = spacing_udeg as f64 * 1e-6;
        let max_band = (90.0 / d).ceil() as i32 - 1;
        let band = ((altitude_deg / d).floor() as i32).clamp(-max_band - 1, max_band);
        let n = Self::cells(band, d);
        let az = azimuth_deg.rem_euclid(360.0);
        let index = ((az / (360.0 / n as f64)).round() as i64).rem_euclid(n as i64) as i32;
        SunKey {
            band,
            index,
            spacing_udeg,
        }
    }
    fn cells(band: i32, d: f64) -> i32 {
        let alt = ((band as f64 + 0.5) * d).to_radians();
        ((360.0 * alt.cos() / d).round() as i32).max(1)
    }
    /// (altitude, azimuth) of the cell centre, degrees.
    pub fn alt_az_deg(&self) -> (f64, f64) {
        let d = self.spacing_udeg as f64 * 1e-6;
        let n = Self::cells(self.band, d);
        (
            (self.band as f64 + 0.5) * d,
            self.index as f64 * 360.0 / n as f64,
        )
    }
    /// Unit direction of the cell centre, scene frame.
    pub fn direction(&self) -> DVec3 {
        let (alt, az) = self.alt_az_deg();
        crate::site::direction_from_alt_az(alt, az)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn base_faces_tile_the_sphere() {
        let total: f64 = (0..8)
            .map(|b| {
                let [a, b, c] = SkyNodeKey::root(b).vertices();
                spherical_triangle::solid_angle(a, b, c)
            })
            .sum();
        assert!((total - 4.0 * PI).abs() < 1e-12);
        for b in 0..4 {
            assert!(SkyNodeKey::root(b).vertices().iter().all(|v| v.z >= 0.0));
        }
    }

    #[test]
    fn path_round_trips() {
        let k = SkyNodeKey::root(2).child(3).child(0).child(2);
        assert_eq!(k.depth(), 3);
        assert_eq!(
            k.parent().unwrap().parent().unwrap().parent().unwrap(),
            SkyNodeKey::root(2)
        );
        let [a, b, c] = SkyNodeKey::root(2).child(3).vertices();
        assert_eq!(
            spherical_triangle::split(a, b, c)[0],
            k.parent().unwrap().vertices()
        );
    }

    #[test]
    fn snapping_error_is_bounded_by_spacing() {
        let d = 0.5;
        for i in 0..2000 {
            let alt = 0.05 + 89.9 * ((i * 7919) % 2000) as f64 / 2000.0;
            let az = 360.0 * ((i * 104729) % 2000) as f64 / 2000.0;
            let k = SunKey::snap(alt, az, d);
            let err = crate::site::direction_from_alt_az(alt, az)
                .angle_between(k.direction())
                .to_degrees();
            assert!(err <= d * 0.75, "alt {alt} az {az}: {err}");
            assert!(k.direction().z > 0.0);
        }
    }
}
