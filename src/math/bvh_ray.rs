//! A ray of the [`Bvh`](super::Bvh) queries: its precomputation, the slab test of a
//! node's four child boxes and the watertight triangle test.

use super::*;

/// Per-ray precomputation shared by the box and triangle tests.
pub(super) struct Ray {
    org: DVec3,
    dir: DVec3,
    /// 1/dir with zero components replaced by ±1e-300 first, so the slab test never forms
    /// 0·∞ = NaN for an origin lying on a slab plane.
    inv: DVec3,
    /// Watertight test: kz is the dominant axis of dir, (kx, ky) the others, swapped when
    /// dir[kz] < 0 to keep the winding; (sx, sy, sz) the shear onto the unit z ray.
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl Ray {
    pub(super) fn new(org: DVec3, dir: DVec3) -> Ray {
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let safe = |d: f64| {
            if d.abs() < 1e-300 {
                1e-300_f64.copysign(d)
            } else {
                d
            }
        };
        let inv = DVec3::new(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z));
        Ray {
            org,
            dir,
            inv,
            kx,
            ky,
            kz,
            sx: dir[kx] / dir[kz],
            sy: dir[ky] / dir[kz],
            sz: 1.0 / dir[kz],
        }
    }

    /// The slab test of a node's four child boxes at once: each child's entry distance,
    /// and whether the ray meets its box within [t_min, t_max] (never an unused slot).
    /// Written lane by lane over fixed arrays, so the compiler keeps the four in vector
    /// registers; the comparisons stand for `min`/`max`, equal here since no operand is
    /// NaN (finite boxes and origins, `inv` never infinite).
    #[inline(always)]
    pub(super) fn hit_boxes(&self, n: &Node, t_min: f64, t_max: f64) -> ([f64; 4], [bool; 4]) {
        let mut near = [t_min; 4];
        let mut far = [t_max; 4];
        for a in 0..3 {
            let (o, inv) = (self.org[a], self.inv[a]);
            let lo = n.corners[0][a].map(f64::from);
            let hi = n.corners[1][a].map(f64::from);
            let t_lo: [f64; 4] = std::array::from_fn(|j| (lo[j] - o) * inv);
            let t_hi: [f64; 4] = std::array::from_fn(|j| (hi[j] - o) * inv);
            // The entry plane is the lower one when the ray runs up the axis: the same
            // pick as the smaller of the two distances, since rounding keeps their order.
            let (t_enter, t_exit) = if inv >= 0.0 {
                (t_lo, t_hi)
            } else {
                (t_hi, t_lo)
            };
            near = std::array::from_fn(|j| max(t_enter[j], near[j]));
            far = std::array::from_fn(|j| min(t_exit[j], far[j]));
        }
        let mut hit = [false; 4];
        for j in 0..4 {
            hit[j] = near[j] <= far[j] && n.count[j] != EMPTY;
        }
        (near, hit)
    }

    /// [`Self::hit_triangle_with`] working out the normal first (the tests' brute force).
    #[cfg(test)]
    pub(super) fn hit_triangle(
        &self,
        v: &[DVec3; 3],
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, f64, DVec3)> {
        self.hit_triangle_with(v, face_normal(v), t_min, t_max)
    }

    /// Watertight two-sided test of the triangle `v` with unit normal `normal`:
    /// `(t, cos, normal)` for a hit with t_min < t < t_max.
    #[inline]
    pub(super) fn hit_triangle_with(
        &self,
        v: &[DVec3; 3],
        normal: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, f64, DVec3)> {
        let a = v[0] - self.org;
        let b = v[1] - self.org;
        let c = v[2] - self.org;
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        // Edge functions; a shared edge gives exactly negated values in its two triangles
        // (same products, operands swapped), which is what makes the test watertight.
        let u = cx * by - cy * bx;
        let v_ = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v_ + w;
        if det == 0.0 {
            return None;
        }
        let t = (u * (self.sz * a[kz]) + v_ * (self.sz * b[kz]) + w * (self.sz * c[kz])) / det;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let cos = self.dir.dot(normal);
        if cos.is_nan() || cos.abs() <= GRAZING_COS {
            return None;
        }
        Some((t, cos, normal))
    }
}
