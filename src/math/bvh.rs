//! Bounding-volume hierarchy over triangles for exact ray casts (sensor visibility).
//! PLACEHOLDER: to be implemented.

use glam::DVec3;

/// One ray–triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the triangle in the slice the BVH was built from.
    pub triangle: u32,
    /// Ray parameter of the hit (distance along the unit direction, m).
    pub t: f64,
    /// Cosine between the ray direction and the triangle's geometric normal (signed).
    pub cos: f64,
}

/// A BVH over a fixed triangle list (vertices in metres, f64).
#[derive(Clone, Debug, Default)]
pub struct Bvh {}

impl Bvh {
    /// Builds the hierarchy over `triangles` (each three vertices).
    pub fn build(triangles: &[[DVec3; 3]]) -> Bvh {
        let _ = triangles;
        todo!()
    }

    /// Visits every triangle hit by the ray `origin + t·dir` with `t_min < t < t_max`, in
    /// increasing `t`, calling `visit(hit)`; stops early when `visit` returns `false`.
    /// `dir` must be a unit vector.
    pub fn hits_in_order(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        visit: impl FnMut(Hit) -> bool,
    ) {
        let _ = (origin, dir, t_min, t_max, visit);
        todo!()
    }
}
