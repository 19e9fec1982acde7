//! Orthonormal frames built from one direction.

use glam::DVec3;

/// Two unit vectors `(u, v)` such that `(u, v, w)` is a right-handed orthonormal basis,
/// for a unit vector `w`. Stable for every `w` (branchless construction of Duff et al. 2017).
pub fn basis(w: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(w.z);
    let a = -1.0 / (sign + w.z);
    let b = w.x * w.y * a;
    let u = DVec3::new(1.0 + sign * w.x * w.x * a, sign * b, -sign * w.x);
    let v = DVec3::new(b, sign + w.y * w.y * a, -w.y);
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn basis_is_orthonormal_and_right_handed() {
        for w in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::new(0.3, -0.4, 0.5).normalize(),
            DVec3::new(1e-9, 0.0, -1.0).normalize(),
        ] {
            let (u, v) = basis(w);
            assert!((u.length() - 1.0).abs() < 1e-12 && (v.length() - 1.0).abs() < 1e-12);
            assert!(u.dot(v).abs() < 1e-12 && u.dot(w).abs() < 1e-12 && v.dot(w).abs() < 1e-12);
            assert!((u.cross(v) - w).length() < 1e-12);
        }
    }
}
