//! Two-sided surfaces (Radiance's default, `rtrace -bv`): every opaque triangle gets a
//! back face, the same triangle with the opposite winding, appended after the model's
//! triangles. Each face then has its own radiosity and receives what arrives on its side.
//!
//! Why a second triangle rather than a side bit on every element: the two faces lie in
//! one plane, and coincident faces already have one defined order everywhere light is
//! counted (the LDIs' `projection::ldi::order_coincident`, the tracer's settling): the
//! face towards the light or the viewer first. A back face is therefore
//! exactly a wall modelled twice, back to back, and every step downstream (projection,
//! refinement, mesh, operator, gather, cache keys) handles it without knowing.
//!
//! Glazing keeps one face (its transmission and mirror are two-sided already). An emitter's
//! back face reflects but does not emit (Radiance `light` emits from its front only).
//!
//! Only faces that can see something cost: a triangle whose back looks into a closed solid
//! (the inner face of a wall with thickness, a slab, a column, a desk) gets no back face,
//! since no light reaches it and nothing outside the solid sees it. The test
//! ([`enclosed_backs`]) is 16 fixed rays over each back's hemisphere: a cavity is a solid
//! when every ray from each of its faces meets an opaque triangle from behind (the solid's
//! other faces, whose normals point out) and no sensor looks into it; one ray that
//! escapes, or meets a front or glazing, anywhere in the cavity keeps its back faces. The
//! sample office, all of whose walls are solids, then keeps back faces only inside its
//! bottomless obstruction. A triangle with nothing behind it at all (the ground under a
//! site, [`nothing_behind`]) gets none either.

use super::{Material, Scene, Triangle};

/// Which faces of an opaque surface receive and reflect light (scene file `faces`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Faces {
    /// Both faces, each with its own radiosity (the default, as in Radiance).
    #[default]
    Both,
    /// Only the face the OBJ winding's normal points to; the back is black (closed-volume
    /// models whose back faces nobody sees).
    Front,
}

/// Suffix of a back face's group and, for emitters, of its non-emitting material.
pub const BACK_SUFFIX: &str = " (back)";

/// Appends a back face for every opaque triangle of `scene` (see the module doc) and records
/// the pairs in [`Scene::twin`]. Back faces get their own groups (`<group> (back)`), so
/// per-group outputs keep the sides apart.
pub fn add_back_faces(scene: &mut Scene) {
    let n = scene.triangles.len();
    let enclosed = enclosed_backs(scene);
    let empty_behind = nothing_behind(scene);
    scene.input_triangles = n;
    scene.twin = vec![u32::MAX; n];
    // Scenes made in code may leave groups unnamed: their back faces keep the group.
    let mut back_group: Vec<u32> = (0..scene.groups.len()).map(|_| u32::MAX).collect();
    let mut back_material = vec![u32::MAX; scene.materials.len()];
    for (i, &sealed) in enclosed.iter().enumerate().take(n) {
        let t = scene.triangles[i];
        let m = &scene.materials[t.material as usize];
        if m.is_glazing() || sealed || empty_behind[i] {
            continue;
        }
        let g = t.group as usize;
        if g >= back_group.len() {
            back_group.resize(g + 1, t.group);
            back_group[g] = t.group;
        } else if back_group[g] == u32::MAX {
            back_group[g] = scene.groups.len() as u32;
            let name = format!("{}{BACK_SUFFIX}", scene.groups[g]);
            scene.groups.push(name);
        }
        let mi = t.material as usize;
        if back_material[mi] == u32::MAX {
            back_material[mi] = if m.is_emitter() {
                let back = Material {
                    name: format!("{}{BACK_SUFFIX}", m.name),
                    ke: crate::photometry::Rgb::ZERO,
                    ..m.clone()
                };
                scene.materials.push(back);
                (scene.materials.len() - 1) as u32
            } else {
                t.material
            };
        }
        let j = scene.triangles.len() as u32;
        scene.triangles.push(Triangle {
            v: [t.v[0], t.v[2], t.v[1]],
            material: back_material[mi],
            group: back_group[g],
        });
        scene.twin[i] = j;
        scene.twin.push(i as u32);
    }
    scene.faces = Faces::Both;
}

/// For each triangle, whether nothing at all lies behind it: every corner of the bounds of
/// the geometry and the sensors is on or in front of its plane (the ground plane under a
/// site). Its back would see nothing and be seen by nothing, yet cost a fragment in every
/// pixel of every projection that crosses it.
fn nothing_behind(scene: &Scene) -> Vec<bool> {
    let (mut lo, mut hi) = scene.bounds();
    for s in &scene.sensors {
        lo = lo.min(s.position);
        hi = hi.max(s.position);
    }
    let scale = (hi - lo).max_element().max(1.0);
    scene
        .triangles
        .iter()
        .map(|t| {
            let n = t.normal();
            // The corner furthest behind the plane.
            let far = glam::DVec3::new(
                if n.x >= 0.0 { lo.x } else { hi.x },
                if n.y >= 0.0 { lo.y } else { hi.y },
                if n.z >= 0.0 { lo.z } else { hi.z },
            );
            n.dot(far - t.v[0]) >= -1e-9 * scale
        })
        .collect()
}

/// Rays per triangle of the enclosure test (a 4 × 4 stratified cosine pattern).
const ENCLOSURE_RAYS: u32 = 4;

/// For each triangle, whether its back looks into a closed solid. A triangle's back is
/// sealed when every ray of a fixed cosine pattern over its back hemisphere, from its
/// centroid, meets an opaque triangle from behind; the triangles met so are the same
/// cavity. A cavity is a solid only when all its triangles are sealed and no sensor looks
/// into it: a room modelled with its normals pointing out is sealed the same way, and its
/// window (glazing) or a sensor inside opens it.
fn enclosed_backs(scene: &Scene) -> Vec<bool> {
    use crate::math::bvh::Bvh;
    use crate::math::frame::basis;
    use glam::DVec3;
    let n = scene.triangles.len();
    let tris: Vec<[DVec3; 3]> = scene.triangles.iter().map(|t| t.v).collect();
    let bvh = Bvh::build(&tris);
    let opaque: Vec<bool> = scene
        .triangles
        .iter()
        .map(|t| !scene.materials[t.material as usize].is_glazing())
        .collect();
    let m = ENCLOSURE_RAYS;
    let pattern = |w: DVec3| {
        let (a, b) = basis(w);
        (0..m * m).map(move |k| {
            // Cell centres of a stratified grid on the unit square, cosine-mapped.
            let u1 = ((k / m) as f64 + 0.5) / m as f64;
            let u2 = ((k % m) as f64 + 0.5) / m as f64;
            let r = u1.sqrt();
            let phi = std::f64::consts::TAU * u2;
            (a * (r * phi.cos()) + b * (r * phi.sin()) + w * (1.0 - u1).sqrt()).normalize()
        })
    };
    // The opaque triangle a ray meets from behind, if that is what it meets.
    let behind = |o: DVec3, d: DVec3| match bvh.closest_hit(o, d, 1e-7, f64::INFINITY) {
        Some(h) if opaque[h.triangle as usize] && h.cos > 0.0 => Some(h.triangle as usize),
        _ => None,
    };
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut open = vec![false; n];
    for (i, t) in scene.triangles.iter().enumerate() {
        let c = t.centroid();
        for d in pattern(-t.normal()) {
            match behind(c, d) {
                Some(j) => {
                    let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                    parent[a] = b;
                }
                None => open[i] = true,
            }
        }
    }
    for s in &scene.sensors {
        for d in pattern(s.normal).chain(pattern(-s.normal)) {
            if let Some(j) = behind(s.position, d) {
                open[j] = true;
            }
        }
    }
    let mut cavity_open = vec![false; n];
    for (i, &o) in open.iter().enumerate() {
        if o {
            let r = root(&mut parent, i);
            cavity_open[r] = true;
        }
    }
    (0..n)
        .map(|i| {
            let r = root(&mut parent, i);
            !cavity_open[r]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photometry::Rgb;
    use crate::scene::synthetic::SceneBuilder;
    use glam::DVec3;

    #[test]
    fn opaque_triangles_get_a_reversed_twin_glazing_and_front_mode_do_not() {
        let mut b = SceneBuilder::new();
        let wall = b.add_opaque("wall", 0.5);
        let lamp = b.add_material(Material {
            name: "lamp".into(),
            kd: Rgb::splat(0.3),
            tf: Rgb::ZERO,
            ke: Rgb::splat(2.0),
        });
        let glass = b.add_glazing("glass", 0.7);
        let tri = [DVec3::ZERO, DVec3::X, DVec3::Y];
        b.add_triangle("w", wall, tri);
        b.add_triangle("l", lamp, tri.map(|p| p + DVec3::Z));
        b.add_triangle("g", glass, tri.map(|p| p + 2.0 * DVec3::Z));
        // Something below the lowest triangle, so its back has something to see.
        b.add_sensor(DVec3::new(0.2, 0.2, -1.0), DVec3::Z);
        let s = b.build("t").unwrap();
        assert_eq!(s.faces, Faces::Both);
        assert_eq!((s.input_triangles, s.triangles.len()), (3, 5));
        assert_eq!(s.twin, vec![3, 4, u32::MAX, 0, 1]);
        for (f, k) in [(0usize, 3usize), (1, 4)] {
            let (a, b) = (s.triangles[f], s.triangles[k]);
            assert!((a.normal() + b.normal()).length() < 1e-12);
            assert_eq!(a.area(), b.area());
            assert_eq!(
                s.groups[b.group as usize],
                format!("{}{BACK_SUFFIX}", s.groups[a.group as usize])
            );
        }
        // The lamp's back reflects like its front and emits nothing.
        let back = &s.materials[s.triangles[4].material as usize];
        assert_eq!(back.kd, Rgb::splat(0.3));
        assert_eq!(back.ke, Rgb::ZERO);
        assert_eq!(s.triangles[3].material, wall);

        let mut b = SceneBuilder::new();
        let wall = b.add_opaque("wall", 0.5);
        b.add_triangle("w", wall, tri);
        b.set_faces(Faces::Front);
        let s = b.build("t").unwrap();
        assert_eq!((s.input_triangles, s.triangles.len()), (1, 1));
        assert!(s.twin.is_empty());
    }

    #[test]
    fn a_closed_solid_gets_no_back_faces_a_room_with_a_sensor_does() {
        // A box with outward normals is a solid: nothing reaches its inside, so its faces
        // get no back faces (they would cost rows and lines and receive nothing).
        let solid = |sensor: bool| {
            let mut b = SceneBuilder::new();
            let m = b.add_opaque("m", 0.5);
            b.add_box("box", m, DVec3::ZERO, DVec3::splat(2.0));
            if sensor {
                b.add_sensor(DVec3::splat(1.0), DVec3::Z);
            }
            b.build("t").unwrap()
        };
        let s = solid(false);
        assert_eq!((s.input_triangles, s.triangles.len()), (12, 12));
        // The same box with a sensor inside is a room modelled with its normals out: its
        // inside is lit by nothing but is looked at, so every face keeps its back.
        let s = solid(true);
        assert_eq!(s.triangles.len(), 24);
        // A plate with something on each side keeps both faces; the ground under a
        // sensor has nothing behind it and gets no back face.
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("m", 0.5);
        b.add_triangle("p", m, [DVec3::ZERO, DVec3::X, DVec3::Y]);
        b.add_sensor(DVec3::new(0.2, 0.2, -1.0), DVec3::Z);
        b.add_sensor(DVec3::new(0.2, 0.2, 1.0), -DVec3::Z);
        assert_eq!(b.build("t").unwrap().triangles.len(), 2);
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("m", 0.5);
        b.add_triangle("ground", m, [DVec3::ZERO, DVec3::X, DVec3::Y]);
        b.add_sensor(DVec3::new(0.2, 0.2, 1.0), DVec3::Z);
        assert_eq!(b.build("t").unwrap().triangles.len(), 1);
    }
}
