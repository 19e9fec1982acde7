//! L5 rays through the scene's triangles: one BVH per geometry, shared by the sensors'
//! visibility (`sensors`), the interreflection's sensor gather and glazing mirror
//! (`radiosity`) and any later renderer.
//!
//! One walk ([`Tracer::walk`]) follows a ray through glazing to its first opaque surface:
//! each pane multiplies the ray by τ(θ) ([`Material::transmittance`]), with θ measured from
//! the ray itself or from a separate incidence direction (the snapped sun: visibility
//! follows the snapped direction, the glass sees the true one). The glazing's specular
//! reflection ([`Material::specular_reflectance`]) is [`Tracer::mirror`]. Opaque surfaces
//! are two-sided occluders; which face a ray meets is reported, not acted on.

use crate::math::bvh::{Bvh, Hit};
use crate::math::frame::basis;
use crate::photometry::Rgb;
use crate::scene::{Material, Scene};
use glam::DVec3;
use std::f64::consts::PI;

/// Hits closer than this (m) to a ray's origin are ignored, so a ray does not meet the
/// surface it leaves (a sensor on a desk, a mirror or gather ray leaving a pane). One value
/// for every user, applied at the origin only: the walk does not restart at panes. Why
/// 1e-7 m: coordinates stay within ~1e3 m of the origin ([`Bvh`]), where a point on a
/// surface is off its plane by a few ulp (~1e-13 m), so a ray leaving it re-meets it at
/// t ≲ 1e-13 m / cos θ: 1e-7 m steps over that down to cos θ ≈ 1e-6, and is four orders
/// below any gap a model holds (a pane against its frame, a sensor raised off its desk:
/// millimetres). Measured when the sensors (1e-6 m) and the interreflection (1e-7 m) were
/// unified: on 1e-7 m no sensor value of the office or the building moved (bit for bit);
/// on 1e-6 m the building's indirect light moved by up to 3e-5 relative (36 of 1 620
/// sensors), from rays starting within a micrometre of another surface.
pub const T_MIN_M: f64 = 1e-7;
/// A ray crossing more glazing panes than this is absorbed (bounds the walk).
const MAX_PANES: u32 = 32;

/// Ray-casting view of a scene: BVH, unit front normals, materials. Build it once per
/// geometry and share it (`&Tracer`) between the sensors and the interreflection.
///
/// The BVH holds the model's triangles only: a back face ([`crate::scene::faces`]) is its
/// front triangle met from behind, so a ray that meets a triangle's back reports the back
/// face instead, and two-sided surfaces cost no extra ray work.
#[derive(Clone, Debug)]
pub struct Tracer {
    bvh: Bvh,
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    material: Vec<u32>,
    materials: Vec<Material>,
    /// Opposite face of each triangle (`u32::MAX`: none); see [`crate::scene::Scene::twin`].
    twin: Vec<u32>,
    /// Whether a model triangle has a coincident parallel opaque face other than its own
    /// back (a floor on the ground): only its hits need [`Self::settle`]'s second query.
    coincident: Vec<bool>,
}

/// The first triangle a ray meets ([`Tracer::first_hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstHit {
    /// Triangle hit.
    pub tri: u32,
    /// Hit point, m.
    pub point: DVec3,
    /// Cosine between the ray direction and the triangle's front normal (signed: negative
    /// on the front face).
    pub cos: f64,
    /// Whether the triangle is glazing.
    pub glazing: bool,
}

/// Where a walk ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    /// Front face of an opaque triangle at `point`; `cos` = cosine at the receiver (> 0).
    Front {
        /// Triangle hit.
        tri: u32,
        /// Hit point, m.
        point: DVec3,
        /// Cosine of incidence.
        cos: f64,
    },
    /// Back face of an opaque triangle (absorbed there).
    Back {
        /// Triangle hit.
        tri: u32,
    },
    /// Absorbed in glazing: every channel's transmission reached zero, or more than
    /// `MAX_PANES` (32) panes were crossed.
    Absorbed,
    /// Left the scene.
    Escaped,
}

impl End {
    /// The opaque triangle that stopped the ray, if any.
    pub fn stopper(&self) -> Option<u32> {
        match *self {
            End::Front { tri, .. } | End::Back { tri } => Some(tri),
            End::Absorbed | End::Escaped => None,
        }
    }
}

/// A walked ray: where it ended, the power that arrived there (RGB, in the unit of the
/// power it started with) and the power lost in glazing on the way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outcome {
    /// Where it ended.
    pub end: End,
    /// Power arriving at the end (zero when absorbed in glazing).
    pub power: Rgb,
    /// Power absorbed or reflected away by glazing on the way.
    pub glazing_loss: Rgb,
    /// Glazing panes crossed (the last one included when it absorbed the ray).
    pub panes: u32,
}

impl Outcome {
    /// The fraction (per channel) of the starting power that left the scene: the
    /// transmission to infinity; zero when an opaque surface or glazing stopped the ray.
    pub fn transmission(&self) -> Rgb {
        match self.end {
            End::Escaped => self.power,
            _ => Rgb::ZERO,
        }
    }
}

impl Tracer {
    /// Builds the BVH over the scene's triangles.
    pub fn new(scene: &Scene) -> Tracer {
        let model = &scene.triangles[..scene.input_triangles];
        let tris: Vec<[DVec3; 3]> = model.iter().map(|t| t.v).collect();
        let normals: Vec<DVec3> = scene.triangles.iter().map(|t| t.normal()).collect();
        let opaque: Vec<bool> = model
            .iter()
            .map(|t| !scene.materials[t.material as usize].is_glazing())
            .collect();
        Tracer {
            bvh: Bvh::build(&tris),
            coincident: coincident_faces(&tris, &normals, &opaque),
            normals,
            areas: scene.triangles.iter().map(|t| t.area()).collect(),
            material: scene.triangles.iter().map(|t| t.material).collect(),
            materials: scene.materials.clone(),
            twin: scene.twin.clone(),
        }
    }

    /// The face hit `h` (on a model triangle) shows to the ray: the triangle's back face
    /// when the ray meets its back and it has one.
    fn face(&self, h: Hit) -> Hit {
        match self.twin.get(h.triangle as usize) {
            // Back faces come after their model triangle: a hit already on one stays.
            Some(&t) if h.cos >= 0.0 && t != u32::MAX && t > h.triangle => Hit {
                triangle: t,
                cos: -h.cos,
                ..h
            },
            _ => h,
        }
    }

    /// Unit front normal of triangle `tri`.
    pub fn normal(&self, tri: u32) -> DVec3 {
        self.normals[tri as usize]
    }

    /// Material of triangle `tri`.
    pub fn material_of(&self, tri: u32) -> &Material {
        &self.materials[self.material[tri as usize] as usize]
    }

    /// The first triangle (opaque or glazing) the ray `origin + t·dir` (unit `dir`) meets
    /// beyond [`T_MIN_M`], or `None` when it leaves the scene.
    pub fn first_hit(&self, origin: DVec3, dir: DVec3) -> Option<FirstHit> {
        let h = self.face(self.bvh.closest_hit(origin, dir, T_MIN_M, f64::INFINITY)?);
        Some(FirstHit {
            tri: h.triangle,
            point: origin + dir * h.t,
            cos: h.cos,
            glazing: self.material_of(h.triangle).is_glazing(),
        })
    }

    /// Follows the ray `origin + t·dir` (unit `dir`) carrying `power`: each glazing pane
    /// passes it on with τ at the angle between its normal and unit `incidence`; the first
    /// opaque triangle ends it. The one walk every user shares: one ray from `origin`,
    /// every triangle beyond [`T_MIN_M`] up to the first opaque one, in order of distance
    /// ([`Bvh::hits_in_order_until`]: coplanar duplicates at a shared edge once, nothing
    /// past the first opaque hit searched). It does not restart at a pane, so an
    /// opaque triangle touching the pane (a window head met exactly at its edge) stops the
    /// ray. The interreflection's former walk restarted [`T_MIN_M`] beyond each pane and
    /// stepped over such a triangle: tried for the sensors, whose rays meet window edges
    /// exactly (grid positions, node-corner directions), it moved the sky light of 50 of
    /// the building's 1 620 sensors by up to 7e-4; the interreflection's random rays give
    /// the same values either way.
    pub fn walk(&self, origin: DVec3, dir: DVec3, incidence: DVec3, power: Rgb) -> Outcome {
        // Most rays stop at the first surface they meet: one closest-hit query, the first
        // hit of the ordered list below, settles them.
        let first = self.bvh.closest_hit(origin, dir, T_MIN_M, f64::INFINITY);
        self.walk_from(origin, dir, incidence, power, first)
    }

    /// [`Self::walk`] given the ray's closest hit `first` (what [`Bvh::closest_hit`]
    /// returned for it), so a caller that has it does not search for it again.
    fn walk_from(
        &self,
        origin: DVec3,
        dir: DVec3,
        incidence: DVec3,
        power: Rgb,
        first: Option<Hit>,
    ) -> Outcome {
        let mut out = Outcome {
            end: End::Escaped,
            power,
            glazing_loss: Rgb::ZERO,
            panes: 0,
        };
        match first {
            None => return out,
            Some(h) if !self.material_of(h.triangle).is_glazing() => {
                out.end = self.opaque_end(origin, dir, h);
                return out;
            }
            Some(_) => {}
        }
        // The walk stops at the first opaque triangle: the traversal need not look past it.
        let opaque = |t: u32| !self.material_of(t).is_glazing();
        self.bvh
            .hits_in_order_until(origin, dir, T_MIN_M, f64::INFINITY, opaque, |h| {
                let m = self.material_of(h.triangle);
                if !m.is_glazing() {
                    out.end = self.opaque_end(origin, dir, h);
                    return false;
                }
                if out.panes == MAX_PANES {
                    out.glazing_loss += out.power;
                    out.power = Rgb::ZERO;
                    out.end = End::Absorbed;
                    return false;
                }
                let tau = m.transmittance(self.normal(h.triangle).dot(incidence).abs());
                out.glazing_loss += out.power * (Rgb::ONE - tau);
                out.power *= tau;
                out.panes += 1;
                if out.power == Rgb::ZERO {
                    out.end = End::Absorbed;
                    return false;
                }
                true
            });
        out
    }

    /// Among the opaque faces coincident with hit `h` (parallel to it, within
    /// [`crate::projection::ldi::COINCIDENT_M`] beyond it), the one the LDIs show
    /// ([`crate::projection::ldi::order_coincident`]): a face towards the ray's origin before
    /// one facing away, then the smaller triangle; rounding then does not decide which of
    /// a floor and the ground plane under it a ray reads.
    fn settle(&self, origin: DVec3, dir: DVec3, h: Hit) -> Hit {
        let h = self.face(h);
        let model = |t: u32| match self.twin.get(t as usize) {
            Some(&f) if f < t => f,
            _ => t,
        };
        if !self.coincident[model(h.triangle) as usize] {
            return h;
        }
        let eps = f64::from(crate::projection::ldi::COINCIDENT_M);
        let key = |x: &Hit| (x.cos >= 0.0, self.areas[x.triangle as usize], x.triangle);
        let better = |a: &Hit, b: &Hit| {
            let (a, b) = (key(a), key(b));
            a.0.cmp(&b.0)
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
                .is_lt()
        };
        let mut best = h;
        for x in self
            .bvh
            .all_hits(origin, dir, (h.t - eps).max(T_MIN_M), h.t + eps)
        {
            let x = self.face(x);
            let parallel = self.normal(x.triangle).dot(self.normal(h.triangle)).abs() > 1.0 - 1e-9;
            if parallel && !self.material_of(x.triangle).is_glazing() && better(&x, &best) {
                best = x;
            }
        }
        best
    }

    /// Where a ray ends on the opaque triangle of hit `h`.
    fn opaque_end(&self, origin: DVec3, dir: DVec3, h: Hit) -> End {
        let h = self.face(h);
        // `cos` is dir·n: negative when the ray meets the front face.
        if h.cos < 0.0 {
            End::Front {
                tri: h.triangle,
                point: origin + dir * h.t,
                cos: -h.cos,
            }
        } else {
            End::Back { tri: h.triangle }
        }
    }

    /// [`Tracer::walk`] with the glazing's angle taken from the ray itself.
    /// A ray whose first surface is opaque ends, among coincident faces, on the one the
    /// LDIs show ([`Self::settle`]), so what a sensor's gather reads does not depend on
    /// rounding (behind glazing the plain walk decides).
    pub fn trace(&self, origin: DVec3, dir: DVec3, power: Rgb) -> Outcome {
        match self.bvh.closest_hit(origin, dir, T_MIN_M, f64::INFINITY) {
            Some(h) if !self.material_of(h.triangle).is_glazing() => Outcome {
                end: self.opaque_end(origin, dir, self.settle(origin, dir, h)),
                power,
                glazing_loss: Rgb::ZERO,
                panes: 0,
            },
            first => self.walk_from(origin, dir, dir, power, first),
        }
    }

    /// Transmission (per channel) from `origin` to infinity along unit `dir`: glazing
    /// multiplies by τ(θ), an opaque surface stops the light.
    pub fn transmission(&self, origin: DVec3, dir: DVec3) -> Rgb {
        self.trace(origin, dir, Rgb::ONE).transmission()
    }

    /// As [`Self::transmission`], with the glazing's angle of incidence taken from
    /// `incidence` instead of `dir` (the sun: visibility follows the snapped direction, the
    /// glass sees the true one).
    pub fn transmission_for(&self, origin: DVec3, dir: DVec3, incidence: DVec3) -> Rgb {
        self.walk(origin, dir, incidence, Rgb::ONE).transmission()
    }

    /// The glazing triangles the ray `origin + t·dir` crosses before anything opaque, in
    /// order; `None` when it crosses more than `max`. With them, the transmission towards a
    /// source seen along `dir` can be re-evaluated for any angle of incidence without a new
    /// ray ([`Tracer::transmission_through`]).
    pub fn panes_along(&self, origin: DVec3, dir: DVec3, max: usize) -> Option<Vec<u32>> {
        let mut panes = Vec::new();
        let mut over = false;
        self.bvh
            .hits_in_order(origin, dir, T_MIN_M, f64::INFINITY, |h| {
                if !self.material_of(h.triangle).is_glazing() {
                    return false;
                }
                if panes.len() == max {
                    over = true;
                    return false;
                }
                panes.push(h.triangle);
                true
            });
        (!over).then_some(panes)
    }

    /// Π τ(θ) over `panes` with cos θ = |n · incidence|, in order: what
    /// [`Tracer::transmission_for`] multiplies along a ray that crosses those panes and
    /// escapes.
    pub fn transmission_through(&self, panes: &[u32], incidence: DVec3) -> Rgb {
        let mut power = Rgb::ONE;
        for &p in panes {
            power *= self
                .material_of(p)
                .transmittance(self.normal(p).dot(incidence).abs());
        }
        power
    }

    /// The glazing mirror: light reaching a receiver from the point `at` on pane `tri`,
    /// travelling along unit `toward` (pane → receiver), was reflected there from the
    /// mirror direction with R(θ) ([`Material::specular_reflectance`]). Walks that
    /// direction from `at` carrying `power` × R(θ); `None` when nothing is reflected.
    pub fn mirror(&self, tri: u32, at: DVec3, toward: DVec3, power: Rgb) -> Option<Outcome> {
        let n = self.normal(tri);
        let c = toward.dot(n);
        let w = power * self.material_of(tri).specular_reflectance(c);
        if w == Rgb::ZERO {
            return None;
        }
        let dir = (n * (2.0 * c) - toward).normalize();
        Some(self.trace(at, dir, w))
    }

    /// True when no triangle can lie inside the pyramid from `apex` spanned by the unit
    /// directions `poly` (a convex spherical polygon) above the plane through `apex` with
    /// normal `n` (raised by [`T_MIN_M`]): the whole pyramid is then provably unobstructed.
    pub fn pyramid_is_empty(&self, apex: DVec3, n: DVec3, poly: &[DVec3]) -> bool {
        let centre = poly.iter().fold(DVec3::ZERO, |a, &b| a + b);
        let mut planes = Vec::with_capacity(poly.len() + 1);
        for k in 0..poly.len() {
            let mut e = poly[k].cross(poly[(k + 1) % poly.len()]);
            if e.dot(centre) < 0.0 {
                e = -e;
            }
            planes.push((e, e.dot(apex)));
        }
        planes.push((n, n.dot(apex) + T_MIN_M));
        !self.bvh.any_in_region(&planes)
    }
}

/// For each triangle, whether another opaque triangle lies in its plane (parallel, within
/// [`crate::projection::ldi::COINCIDENT_M`]) and overlaps it with positive area: a floor on
/// a ground plane, a desk on a floor. Triangles sharing only an edge (a quad's halves) do
/// not count. Sorted by plane offset, then swept along one axis, so a large flat site of
/// many triangles stays near-linear.
fn coincident_faces(tris: &[[DVec3; 3]], normals: &[DVec3], opaque: &[bool]) -> Vec<bool> {
    let eps = f64::from(crate::projection::ldi::COINCIDENT_M);
    let n = tris.len();
    let mut flag = vec![false; n];
    // Canonical normal: the largest component positive, so parallel faces facing opposite
    // ways share one plane offset.
    let canon = |m: DVec3| {
        let a = m.abs();
        let c = if a.x >= a.y && a.x >= a.z {
            m.x
        } else if a.y >= a.z {
            m.y
        } else {
            m.z
        };
        if c < 0.0 {
            -m
        } else {
            m
        }
    };
    let nc: Vec<DVec3> = (0..n).map(|i| canon(normals[i])).collect();
    let centre = |i: usize| (tris[i][0] + tris[i][1] + tris[i][2]) / 3.0;
    let offset: Vec<f64> = (0..n).map(|i| nc[i].dot(centre(i))).collect();
    let bounds = |i: usize| {
        let t = &tris[i];
        (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
    };
    let mut order: Vec<usize> = (0..n).filter(|&i| opaque[i] && nc[i].is_finite()).collect();
    order.sort_by(|&a, &b| offset[a].total_cmp(&offset[b]));
    let mut start = 0;
    while start < order.len() {
        // A run of offsets each within eps of the previous one.
        let mut end = start + 1;
        while end < order.len() && offset[order[end]] - offset[order[end - 1]] < eps {
            end += 1;
        }
        if end - start > 1 {
            let mut run: Vec<(usize, DVec3, DVec3)> = order[start..end]
                .iter()
                .map(|&i| {
                    let (lo, hi) = bounds(i);
                    (i, lo, hi)
                })
                .collect();
            run.sort_by(|a, b| a.1.x.total_cmp(&b.1.x));
            for a in 0..run.len() {
                let (i, lo_i, hi_i) = run[a];
                for &(j, lo_j, hi_j) in &run[a + 1..] {
                    if lo_j.x > hi_i.x + eps {
                        break;
                    }
                    let boxes_meet = (lo_i - DVec3::splat(eps)).cmple(hi_j).all()
                        && (lo_j - DVec3::splat(eps)).cmple(hi_i).all();
                    if boxes_meet
                        && nc[i].dot(nc[j]) > 1.0 - 1e-9
                        && (offset[i] - offset[j]).abs() < eps
                        && overlap_in_plane(&tris[i], &tris[j], nc[i])
                    {
                        flag[i] = true;
                        flag[j] = true;
                    }
                }
            }
        }
        start = end;
    }
    flag
}

/// Whether two (near-)coplanar triangles overlap with positive area in the plane with
/// unit normal `n` (separating-axis test; touching at an edge or a vertex is no overlap).
fn overlap_in_plane(a: &[DVec3; 3], b: &[DVec3; 3], n: DVec3) -> bool {
    let (u, v) = basis(n);
    let to2 = |t: &[DVec3; 3]| t.map(|p| glam::DVec2::new(u.dot(p), v.dot(p)));
    let (pa, pb) = (to2(a), to2(b));
    let scale = pa
        .iter()
        .chain(&pb)
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()))
        .max(1.0);
    let tol = 1e-9 * scale;
    for tri in [&pa, &pb] {
        for k in 0..3 {
            let e = tri[(k + 1) % 3] - tri[k];
            let axis = glam::DVec2::new(-e.y, e.x);
            let span = |t: &[glam::DVec2; 3]| {
                t.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        let x = axis.dot(*p);
                        (lo.min(x), hi.max(x))
                    })
            };
            let ((a0, a1), (b0, b1)) = (span(&pa), span(&pb));
            let tol = tol * axis.length();
            if a1 <= b0 + tol || b1 <= a0 + tol {
                return false;
            }
        }
    }
    true
}

/// Uniform barycentric coordinates on a triangle from two uniforms.
pub fn uniform_barycentric(u1: f64, u2: f64) -> [f64; 3] {
    let s = u1.sqrt();
    [1.0 - s, s * (1.0 - u2), s * u2]
}

/// A cosine-distributed unit direction about unit `n` from two uniforms, and its cosine.
pub fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> (DVec3, f64) {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let c = (1.0 - u1).max(0.0).sqrt();
    let (a, b) = basis(n);
    let d = a * (r * phi.cos()) + b * (r * phi.sin()) + n * c;
    (d.normalize(), c)
}

/// Barycentric coordinates of point `p` (assumed in the plane) on triangle `v`, clamped
/// to the triangle and renormalised.
pub fn barycentric(v: [DVec3; 3], p: DVec3) -> [f64; 3] {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let d = p - v[0];
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (dp1, dp2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    let b1 = ((d22 * dp1 - d12 * dp2) / den).max(0.0);
    let b2 = ((d11 * dp2 - d12 * dp1) / den).max(0.0);
    let b0 = (1.0 - b1 - b2).max(0.0);
    let s = b0 + b1 + b2;
    [b0 / s, b1 / s, b2 / s]
}

#[cfg(test)]
#[path = "trace_tests.rs"]
mod tests;
