//! Bounding-volume hierarchy over triangles for exact ray casts (sensor visibility).
//!
//! * Build: binned surface-area heuristic (16 bins, all three axes) over triangle centroids,
//!   falling back to a median split when the heuristic cannot separate the triangles or the
//!   tree grows too deep; nodes live in one flat array (children of an inner node are
//!   adjacent), triangles are copied into leaf order so a leaf reads contiguous memory.
//! * Intersection: the watertight ray–triangle test of Woop, Benthin & Wald (JCGT 2013) in
//!   f64, two-sided (occlusion does not depend on which face a ray meets). Watertight means
//!   a ray through an edge or vertex shared by triangles of a closed mesh hits at least one
//!   of them, so sensor rays cannot leak through the diagonals of triangulated walls.
//! * Robustness: zero-area (and numerically zero-area) triangles are left out of the tree
//!   and never hit; rays parallel to a triangle's plane never hit it (hits with
//!   |cos| ≤ 1e-12 are dropped, since rounding would otherwise report in-plane rays as
//!   random grazing hits); node boxes are padded so rounding in the slab test never culls
//!   a hit on a box boundary; zero direction components are handled without NaN.
//! * Coincident hits: where a ray crosses a shared edge or vertex of coplanar triangles
//!   with the same orientation (a triangulated quad's diagonal), the duplicates are
//!   reported once (the lowest triangle index), so a glazing pane never attenuates twice.

use glam::DVec3;
use std::mem::MaybeUninit;

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

/// Traversal stack capacity (depth ≤ 40 + 32 for any u32 triangle count).
const STACK: usize = 128;
/// Hits with |cos| at or below this are treated as parallel (no hit).
const GRAZING_COS: f64 = 1e-12;
/// A triangle whose |cross| ≤ this × (longest edge)² is numerically degenerate: its normal
/// is rounding noise. A 1e-10 m² sliver with 1 m edges is 1e4 times above the threshold.
const DEGENERATE_REL: f64 = 64.0 * f64::EPSILON;

/// A node of the flat hierarchy. Leaf: `count > 0` triangles from `start` (leaf order).
/// Inner: `count == 0`, children at `start` and `start + 1`.
///
/// The box is kept in f32, rounded outwards, and widened to f64 for the slab test: 32
/// bytes a node instead of 56, so two siblings share one cache line. A box that only
/// grows can only let more triangles be tested, and every query's answer is a function
/// of the hits alone (the nearest by (t, index), or all of them sorted), so the answers
/// are the same bits as with f64 boxes.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Node {
    lo: [f32; 3],
    start: u32,
    hi: [f32; 3],
    count: u32,
}

impl Node {
    /// Lower corner, m.
    #[inline]
    fn lo(&self) -> DVec3 {
        DVec3::new(self.lo[0] as f64, self.lo[1] as f64, self.lo[2] as f64)
    }

    /// Upper corner, m.
    #[inline]
    fn hi(&self) -> DVec3 {
        DVec3::new(self.hi[0] as f64, self.hi[1] as f64, self.hi[2] as f64)
    }

    /// Sets the box to the f32 box that contains `lo..hi`.
    fn set_box(&mut self, lo: DVec3, hi: DVec3) {
        self.lo = lo.to_array().map(|x| f32_toward(x, false));
        self.hi = hi.to_array().map(|x| f32_toward(x, true));
    }
}

/// `x` as f32, rounded up (`up`) or down where the nearest f32 is on the wrong side.
fn f32_toward(x: f64, up: bool) -> f32 {
    let r = x as f32;
    if up && (r as f64) < x {
        next_up_f32(r)
    } else if !up && (r as f64) > x {
        -next_up_f32(-r)
    } else {
        r
    }
}

/// The smallest f32 above `x` (finite `x`), as [`next_up`].
fn next_up_f32(x: f32) -> f32 {
    if x == 0.0 {
        f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        f32::from_bits(x.to_bits() - 1)
    }
}

/// A BVH over a fixed triangle list (vertices in metres, f64).
///
/// Coordinates should stay within about 1e3 m of the origin (callers subtract a local
/// origin); the box padding and the parallel-ray threshold assume f64 rounding at that scale.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Hittable triangles in leaf order.
    tris: Vec<[DVec3; 3]>,
    /// Unit normal of each entry of `tris` ([`face_normal`]), so a hit does not work it out.
    normals: Vec<DVec3>,
    /// Input index of each entry of `tris`.
    ids: Vec<u32>,
    /// Number of triangles passed to [`Bvh::build`], including degenerate ones.
    input_len: usize,
}

/// Per-ray precomputation shared by the box and triangle tests.
struct Ray {
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
    fn new(org: DVec3, dir: DVec3) -> Ray {
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
        Ray {
            org,
            dir,
            inv: DVec3::new(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z)),
            kx,
            ky,
            kz,
            sx: dir[kx] / dir[kz],
            sy: dir[ky] / dir[kz],
            sz: 1.0 / dir[kz],
        }
    }

    /// Entry distance into the box if the ray meets it within [t_min, t_max].
    #[inline]
    fn hit_box(&self, n: &Node, t_min: f64, t_max: f64) -> Option<f64> {
        let a = (n.lo() - self.org) * self.inv;
        let b = (n.hi() - self.org) * self.inv;
        let near = a.min(b).max_element().max(t_min);
        let far = a.max(b).min_element().min(t_max);
        (near <= far).then_some(near)
    }

    /// [`Self::hit_triangle_with`] working out the normal first (the tests' brute force).
    #[cfg(test)]
    fn hit_triangle(&self, v: &[DVec3; 3], t_min: f64, t_max: f64) -> Option<(f64, f64, DVec3)> {
        self.hit_triangle_with(v, face_normal(v), t_min, t_max)
    }

    /// Watertight two-sided test of the triangle `v` with unit normal `normal`:
    /// `(t, cos, normal)` for a hit with t_min < t < t_max.
    #[inline]
    fn hit_triangle_with(
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

/// The stop rule of a walk that lists every hit ([`Bvh::hits_in_order`]).
fn never(_: u32) -> bool {
    false
}

/// Unit normal of a triangle, by its vertices' winding.
fn face_normal(v: &[DVec3; 3]) -> DVec3 {
    (v[1] - v[0]).cross(v[2] - v[0]).normalize()
}

/// The bound a leaf's triangles are tested up to: `t_far` itself, or up to it inclusive
/// once a hit has shrunk it there (the next f64 above), so that a hit at the same
/// distance is still seen.
fn test_limit(found: bool, t_far: f64) -> f64 {
    if found {
        next_up(t_far)
    } else {
        t_far
    }
}

/// True when the triangle has (numerically) zero area or a non-finite vertex.
fn is_degenerate(v: &[DVec3; 3]) -> bool {
    let e0 = v[1] - v[0];
    let e1 = v[2] - v[0];
    let e2 = v[2] - v[1];
    let longest = e0
        .length_squared()
        .max(e1.length_squared())
        .max(e2.length_squared());
    let cross = e0.cross(e1).length();
    !(cross.is_finite() && longest.is_finite() && cross > DEGENERATE_REL * longest)
}

/// The smallest f64 above `x` (`f64::next_up` needs Rust 1.86; the crate supports 1.85).
fn next_up(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        x
    } else if x == 0.0 {
        f64::from_bits(1)
    } else if x > 0.0 {
        f64::from_bits(x.to_bits() + 1)
    } else {
        f64::from_bits(x.to_bits() - 1)
    }
}

/// Sorts hits by (t, triangle) and drops duplicates from coplanar, equally oriented
/// triangles met at the same point (shared edges and vertices).
fn sort_and_dedup(hits: &mut Vec<(Hit, DVec3)>) {
    hits.sort_by(|a, b| {
        a.0.t
            .total_cmp(&b.0.t)
            .then(a.0.triangle.cmp(&b.0.triangle))
    });
    let mut kept: Vec<(Hit, DVec3)> = Vec::with_capacity(hits.len());
    for &(h, n) in hits.iter() {
        let tol = 1e-9 * h.t.abs().max(1.0);
        let duplicate = kept
            .iter()
            .rev()
            .take_while(|(k, _)| h.t - k.t <= tol)
            .any(|(_, kn)| kn.dot(n) > 1.0 - 1e-9);
        if !duplicate {
            kept.push((h, n));
        }
    }
    *hits = kept;
}

impl Bvh {
    /// Number of triangles the BVH was built from (including degenerate ones, never hit).
    pub fn len(&self) -> usize {
        self.input_len
    }

    /// True when the BVH was built from no triangles.
    pub fn is_empty(&self) -> bool {
        self.input_len == 0
    }

    /// Number of triangles that can be hit (the input minus zero-area ones).
    pub fn hittable_len(&self) -> usize {
        self.tris.len()
    }

    /// The ray's hit on leaf-order triangle `i` within (t_min, t_max), if any.
    #[inline]
    fn hit(&self, ray: &Ray, i: usize, t_min: f64, t_max: f64) -> Option<(f64, f64, DVec3)> {
        ray.hit_triangle_with(&self.tris[i], self.normals[i], t_min, t_max)
    }

    /// Iterative near-first traversal. `leaf(leaf_index, &mut t_max)` may shrink `t_max`
    /// (closest-hit queries) and returns `false` to stop.
    #[inline]
    fn traverse(
        &self,
        ray: &Ray,
        t_min: f64,
        mut t_max: f64,
        mut leaf: impl FnMut(usize, &mut f64) -> bool,
    ) {
        if self.nodes.is_empty() || t_min.is_nan() || t_max.is_nan() || t_min >= t_max {
            return;
        }
        // Uninitialised: zeroing 2 KB per ray was a tenth of a closest-hit query.
        let mut stack = [const { MaybeUninit::<(u32, f64)>::uninit() }; STACK];
        let mut sp = 0;
        if let Some(tn) = ray.hit_box(&self.nodes[0], t_min, t_max) {
            stack[0] = MaybeUninit::new((0, tn));
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below `sp` were all written (every push writes before it
            // raises `sp`).
            #[allow(unsafe_code)]
            let (ni, tn) = unsafe { stack[sp].assume_init() };
            if tn > t_max {
                continue;
            }
            let node = &self.nodes[ni as usize];
            if node.count > 0 {
                let s = node.start as usize;
                for i in s..s + node.count as usize {
                    if !leaf(i, &mut t_max) {
                        return;
                    }
                }
            } else {
                let l = node.start;
                let hl = ray.hit_box(&self.nodes[l as usize], t_min, t_max);
                let hr = ray.hit_box(&self.nodes[l as usize + 1], t_min, t_max);
                match (hl, hr) {
                    (Some(a), Some(b)) => {
                        // Far child first so the near one is popped next.
                        let (near, far) = if a <= b {
                            ((l, a), (l + 1, b))
                        } else {
                            ((l + 1, b), (l, a))
                        };
                        stack[sp] = MaybeUninit::new(far);
                        stack[sp + 1] = MaybeUninit::new(near);
                        sp += 2;
                    }
                    (Some(a), None) => {
                        stack[sp] = MaybeUninit::new((l, a));
                        sp += 1;
                    }
                    (None, Some(b)) => {
                        stack[sp] = MaybeUninit::new((l + 1, b));
                        sp += 1;
                    }
                    (None, None) => {}
                }
            }
        }
    }

    /// Conservative region query: `false` proves that no triangle meets the convex region
    /// {x : n·x ≥ d for every (n, d) in `planes`}; `true` means some triangle may (a
    /// triangle counts as outside only when all its vertices are outside one plane).
    pub fn any_in_region(&self, planes: &[(DVec3, f64)]) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let box_outside = |n: &Node| {
            let (lo, hi) = (n.lo(), n.hi());
            planes.iter().any(|(p, d)| {
                let far = DVec3::new(
                    if p.x >= 0.0 { hi.x } else { lo.x },
                    if p.y >= 0.0 { hi.y } else { lo.y },
                    if p.z >= 0.0 { hi.z } else { lo.z },
                );
                p.dot(far) < *d
            })
        };
        let mut stack = vec![0u32];
        while let Some(ni) = stack.pop() {
            let node = &self.nodes[ni as usize];
            if box_outside(node) {
                continue;
            }
            if node.count > 0 {
                let s = node.start as usize;
                for t in &self.tris[s..s + node.count as usize] {
                    if !planes.iter().any(|(p, d)| t.iter().all(|v| p.dot(*v) < *d)) {
                        return true;
                    }
                }
            } else {
                stack.push(node.start);
                stack.push(node.start + 1);
            }
        }
        false
    }

    /// Visits every triangle hit by the ray `origin + t·dir` with `t_min < t < t_max`, in
    /// increasing `t` (ties by triangle index), calling `visit(hit)`; stops early when
    /// `visit` returns `false`. `dir` must be a unit vector (t is then in metres).
    ///
    /// Both faces count. Coplanar, equally oriented triangles met at the same point (a ray
    /// through the diagonal of a triangulated quad) are reported once.
    pub fn hits_in_order(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        visit: impl FnMut(Hit) -> bool,
    ) {
        self.hits_in_order_until(origin, dir, t_min, t_max, never, visit);
    }

    /// [`Self::hits_in_order`] for a visit that stops at the first hit on a triangle for
    /// which `stops(triangle)` holds (and may stop sooner): the same visits, but the
    /// traversal prunes beyond the nearest such hit instead of collecting every hit to
    /// `t_max`. In the rare case where that hit is a coplanar duplicate dropped from the
    /// list, the full list is walked instead, so the visits never differ.
    pub fn hits_in_order_until(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_min: f64,
        t_max: f64,
        stops: impl Fn(u32) -> bool,
        mut visit: impl FnMut(Hit) -> bool,
    ) {
        let ray = Ray::new(origin, dir);
        // Collect-then-sort: rays in buildings cross few surfaces, so this is cheaper and
        // simpler than an ordered traversal that emits hits as soon as they are final.
        let mut hits: Vec<(Hit, DVec3)> = Vec::new();
        let mut stop_t: Option<f64> = None;
        self.traverse(&ray, t_min, t_max, |i, t_far| {
            // Once a stop is found, up to it inclusive: every hit at its distance is listed.
            let limit = test_limit(stop_t.is_some(), *t_far);
            if let Some((t, cos, n)) = self.hit(&ray, i, t_min, limit) {
                let triangle = self.ids[i];
                hits.push((Hit { triangle, t, cos }, n));
                if stops(triangle) && stop_t.is_none_or(|s| t < s) {
                    stop_t = Some(t);
                    *t_far = t;
                }
            }
            true
        });
        // Every hit up to the nearest stop, and only those: a prefix of the full sorted
        // list, whose duplicates are dropped as in the full list.
        if let Some(s) = stop_t {
            hits.retain(|(h, _)| h.t <= s);
        }
        sort_and_dedup(&mut hits);
        if stop_t.is_some() && !hits.iter().any(|(h, _)| stops(h.triangle)) {
            return self.hits_in_order_until(origin, dir, t_min, t_max, never, visit);
        }
        for (h, _) in hits {
            if !visit(h) {
                return;
            }
        }
    }

    /// Every hit with `t_min < t < t_max`, in no particular order and with coplanar
    /// duplicates kept: what the coincident-face rule needs to see all of a floor and the
    /// ground plane under it. `dir` must be a unit vector.
    pub fn all_hits(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Vec<Hit> {
        let ray = Ray::new(origin, dir);
        let mut hits = Vec::new();
        self.traverse(&ray, t_min, t_max, |i, _| {
            if let Some((t, cos, _)) = self.hit(&ray, i, t_min, t_max) {
                hits.push(Hit {
                    triangle: self.ids[i],
                    t,
                    cos,
                });
            }
            true
        });
        hits
    }

    /// The nearest hit with `t_min < t < t_max` (ties by lowest triangle index), if any.
    /// `dir` must be a unit vector.
    pub fn closest_hit(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Option<Hit> {
        let ray = Ray::new(origin, dir);
        let mut best: Option<Hit> = None;
        self.traverse(&ray, t_min, t_max, |i, t_far| {
            // `t_far` shrinks to the best hit so far; an equal-t hit with a lower index can
            // still win the tie.
            let limit = test_limit(best.is_some(), *t_far);
            if let Some((t, cos, _)) = self.hit(&ray, i, t_min, limit) {
                let id = self.ids[i];
                let better = match best {
                    None => true,
                    Some(b) => t < b.t || (t == b.t && id < b.triangle),
                };
                if better {
                    best = Some(Hit {
                        triangle: id,
                        t,
                        cos,
                    });
                    *t_far = t;
                }
            }
            true
        });
        best
    }

    /// True when the ray meets any triangle with `t_min < t < t_max` (stops at the first
    /// found, in no particular order). `dir` must be a unit vector.
    pub fn any_hit(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> bool {
        let ray = Ray::new(origin, dir);
        let mut found = false;
        self.traverse(&ray, t_min, t_max, |i, _| {
            found = self.hit(&ray, i, t_min, t_max).is_some();
            !found
        });
        found
    }
}

#[path = "bvh_build.rs"]
mod build;

#[cfg(test)]
#[path = "bvh_tests.rs"]
mod tests;
