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
    scene.input_triangles = n;
    scene.twin = vec![u32::MAX; n];
    // Scenes made in code may leave groups unnamed: their back faces keep the group.
    let mut back_group: Vec<u32> = (0..scene.groups.len()).map(|_| u32::MAX).collect();
    let mut back_material = vec![u32::MAX; scene.materials.len()];
    for i in 0..n {
        let t = scene.triangles[i];
        let m = &scene.materials[t.material as usize];
        if m.is_glazing() {
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
}
