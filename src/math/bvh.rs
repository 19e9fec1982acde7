//! Bounding-volume hierarchy over triangles for exact ray casts (sensor visibility).
//!
//! * Build: binned surface-area heuristic (16 bins, all three axes) over triangle centroids,
//!   falling back to a median split when the heuristic cannot separate the triangles or the
//!   tree grows too deep; the binary tree is then collapsed into a 4-wide one (each node
//!   holds its up to four children's boxes side by side, so one visit tests four boxes), in
//!   one flat array; triangles are copied into leaf order so a leaf reads contiguous memory.
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

/// Traversal stack capacity: a visit pushes at most four children and pops one, and the
/// 4-wide depth is at most the binary depth (≤ 40 + 32 for any u32 triangle count), so
/// 3 × 72 + 1 entries suffice.
const STACK: usize = 256;
/// Hits with |cos| at or below this are treated as parallel (no hit).
const GRAZING_COS: f64 = 1e-12;
/// A triangle whose |cross| ≤ this × (longest edge)² is numerically degenerate: its normal
/// is rounding noise. A 1e-10 m² sliver with 1 m edges is 1e4 times above the threshold.
const DEGENERATE_REL: f64 = 64.0 * f64::EPSILON;

/// Marks an unused child slot of a [`Node`].
const EMPTY: u32 = u32::MAX;

/// A node of the flat 4-wide hierarchy: up to four children side by side. Child `j` is an
/// inner node (`count[j] == 0`, `child[j]` its index in the node array), a leaf
/// (`count[j] > 0` triangles from `child[j]`, leaf order) or unused (`count[j] == EMPTY`).
///
/// The boxes are kept in f32, rounded outwards, and widened to f64 for the slab test: 128
/// bytes a node, two cache lines. A box that only grows can only let more triangles be
/// tested, and every query's answer is a function of the hits alone (the nearest by (t,
/// index), or all of them sorted), so the answers are the same bits as with f64 boxes and
/// whatever the order the children are visited in.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    /// The children's boxes: lower corners (`corners[0]`) and upper (`corners[1]`), by
    /// axis then child, m.
    corners: [[[f32; 4]; 3]; 2],
    child: [u32; 4],
    count: [u32; 4],
}

impl Default for Node {
    fn default() -> Node {
        Node {
            corners: [[[0.0; 4]; 3]; 2],
            child: [0; 4],
            count: [EMPTY; 4],
        }
    }
}

impl Node {
    /// Lower corner of child `j`'s box, m.
    #[inline]
    fn lo(&self, j: usize) -> DVec3 {
        DVec3::new(
            self.corners[0][0][j] as f64,
            self.corners[0][1][j] as f64,
            self.corners[0][2][j] as f64,
        )
    }

    /// Upper corner of child `j`'s box, m.
    #[inline]
    fn hi(&self, j: usize) -> DVec3 {
        DVec3::new(
            self.corners[1][0][j] as f64,
            self.corners[1][1][j] as f64,
            self.corners[1][2][j] as f64,
        )
    }
}

/// The smaller of `a` and `b` (`b` when either is NaN): what one `minpd` computes. With
/// `f64::min`'s NaN rule the rays bench ran 1.19× the instructions (cachegrind).
#[inline(always)]
fn min(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of `a` and `b` (`b` when either is NaN), as [`min`].
#[inline(always)]
fn max(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
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
    /// (closest-hit queries) and returns `false` to stop. Compiled for baseline x86-64 and
    /// again with AVX2, chosen at run time: with AVX2 the four slab tests of a node are
    /// one 4-wide f64 operation each. The same operations in the same order either way.
    #[inline]
    #[allow(unsafe_code)] // calling the AVX2 build once the CPU is known to have AVX2
    fn traverse(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        leaf: impl FnMut(usize, &mut f64) -> bool,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.traverse_avx2(ray, t_min, t_max, leaf) };
        }
        self.traverse_any(ray, t_min, t_max, leaf)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn traverse_avx2(
        &self,
        ray: &Ray,
        t_min: f64,
        t_max: f64,
        leaf: impl FnMut(usize, &mut f64) -> bool,
    ) {
        self.traverse_any(ray, t_min, t_max, leaf)
    }

    #[inline(always)]
    fn traverse_any(
        &self,
        ray: &Ray,
        t_min: f64,
        mut t_max: f64,
        mut leaf: impl FnMut(usize, &mut f64) -> bool,
    ) {
        if self.nodes.is_empty() || t_min.is_nan() || t_max.is_nan() || t_min >= t_max {
            return;
        }
        // Entries (child, count, entry distance), as a node's slots. Uninitialised: zeroing
        // the stack per ray was a tenth of a closest-hit query.
        let mut stack = [const { MaybeUninit::<(u32, u32, f64)>::uninit() }; STACK];
        let mut sp = 0;
        // The entry visited next: the nearest child met, which skips the stack.
        let mut next = Some((0, 0, t_min));
        loop {
            let (c, count, tn) = match next.take() {
                Some(e) => e,
                None if sp > 0 => {
                    sp -= 1;
                    // SAFETY: entries below `sp` were all written (every push writes
                    // before it raises `sp`).
                    #[allow(unsafe_code)]
                    unsafe {
                        stack[sp].assume_init()
                    }
                }
                None => return,
            };
            if tn > t_max {
                continue;
            }
            if count > 0 {
                let s = c as usize;
                for i in s..s + count as usize {
                    if !leaf(i, &mut t_max) {
                        return;
                    }
                }
                continue;
            }
            let node = &self.nodes[c as usize];
            let (near, hit) = ray.hit_boxes(node, t_min, t_max);
            // The children met, farthest first: all but the nearest are pushed, so it is
            // popped after the nearest's subtree.
            let mut met = [(0.0, 0usize); 4];
            let mut m = 0;
            for j in 0..4 {
                if hit[j] {
                    let mut k = m;
                    while k > 0 && met[k - 1].0 < near[j] {
                        met[k] = met[k - 1];
                        k -= 1;
                    }
                    met[k] = (near[j], j);
                    m += 1;
                }
            }
            if m == 0 {
                continue;
            }
            for &(t, j) in &met[..m - 1] {
                stack[sp] = MaybeUninit::new((node.child[j], node.count[j], t));
                sp += 1;
            }
            let (t, j) = met[m - 1];
            next = Some((node.child[j], node.count[j], t));
        }
    }

    /// Conservative region query: `false` proves that no triangle meets the convex region
    /// {x : n·x ≥ d for every (n, d) in `planes`}; `true` means some triangle may (a
    /// triangle counts as outside only when all its vertices are outside one plane).
    pub fn any_in_region(&self, planes: &[(DVec3, f64)]) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let box_outside = |n: &Node, j: usize| {
            let (lo, hi) = (n.lo(j), n.hi(j));
            planes.iter().any(|(p, d)| {
                let far = DVec3::new(
                    if p.x >= 0.0 { hi.x } else { lo.x },
                    if p.y >= 0.0 { hi.y } else { lo.y },
                    if p.z >= 0.0 { hi.z } else { lo.z },
                );
                p.dot(far) < *d
            })
        };
        // Entries (child, count), as a node's slots.
        let mut stack = vec![(0u32, 0u32)];
        while let Some((c, count)) = stack.pop() {
            if count > 0 {
                let s = c as usize;
                for t in &self.tris[s..s + count as usize] {
                    if !planes.iter().any(|(p, d)| t.iter().all(|v| p.dot(*v) < *d)) {
                        return true;
                    }
                }
                continue;
            }
            let node = &self.nodes[c as usize];
            for j in 0..4 {
                if node.count[j] != EMPTY && !box_outside(node, j) {
                    stack.push((node.child[j], node.count[j]));
                }
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

#[path = "bvh_ray.rs"]
mod ray;
use ray::Ray;

#[cfg(test)]
#[path = "bvh_tests.rs"]
mod tests;
