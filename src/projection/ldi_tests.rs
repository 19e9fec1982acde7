//! Tests of the LDI ([`super`]): depth order, transmission, coincident faces.

use super::*;
use crate::scene::Material;

fn quad(z: f64, half: f64) -> [[DVec3; 3]; 2] {
    let a = DVec3::new(-half, -half, z);
    let b = DVec3::new(half, -half, z);
    let c = DVec3::new(half, half, z);
    let d = DVec3::new(-half, half, z);
    [[a, b, c], [a, c, d]]
}

pub(crate) fn scene_of(tris: Vec<([DVec3; 3], u32)>, materials: Vec<Material>) -> ProjectionScene {
    ProjectionScene {
        normals: tris
            .iter()
            .map(|(v, _)| (v[1] - v[0]).cross(v[2] - v[0]).normalize())
            .collect(),
        areas: tris
            .iter()
            .map(|(v, _)| 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length())
            .collect(),
        glazing_tf: tris
            .iter()
            .map(|(_, m)| materials[*m as usize].tf)
            .collect(),
        material: tris.iter().map(|(_, m)| *m).collect(),
        vertices: tris.into_iter().map(|(v, _)| v).collect(),
        materials,
        twin: Vec::new(),
        bounds: (DVec3::splat(-1e9), DVec3::splat(1e9)),
        windows: Vec::new(),
    }
}

#[test]
fn fragments_are_depth_ordered_and_opaque_blocks() {
    let black = Material {
        name: "black".into(),
        kd: Rgb::ZERO,
        tf: Rgb::ZERO,
        ke: Rgb::ZERO,
    };
    let mut tris = Vec::new();
    for t in quad(0.0, 2.0) {
        tris.push((t, 0));
    }
    for t in quad(1.0, 1.0) {
        tris.push((t, 0));
    }
    let s = scene_of(tris, vec![black]);
    let ldi = Ldi::build(&s, DVec3::Z, 40);
    // A pixel under the small upper quad has two fragments: upper first, lit; lower dark.
    let c = ldi.camera.to_pixel(DVec3::new(0.1, 0.1, 0.0));
    let list = ldi.pixel(c.x as u32, c.y as u32);
    assert_eq!(list.len(), 2);
    assert!(list[0].height > list[1].height);
    let (i, j) = (c.x as u32, c.y as u32);
    assert_eq!(ldi.arriving(i, j, list[0].tri), Some(Rgb::ONE));
    assert_eq!(ldi.arriving(i, j, list[1].tri), Some(Rgb::ZERO));
    // Outside the upper quad the lower one is lit.
    let c = ldi.camera.to_pixel(DVec3::new(1.8, 1.8, 0.0));
    let list = ldi.pixel(c.x as u32, c.y as u32);
    assert_eq!(list.len(), 1);
    assert_eq!(
        ldi.arriving(c.x as u32, c.y as u32, list[0].tri),
        Some(Rgb::ONE)
    );
    // Projected area from fragment counts matches the geometry (4² + 2² m²).
    let area = ldi.fragment_count() as f64 * ldi.camera.pixel.powi(2);
    assert!((area - 20.0).abs() / 20.0 < 0.05, "{area}");
}

/// A face and its back face (rasterised together): at every pixel the one facing the
/// source comes first, whichever way the light goes.
#[test]
fn a_face_and_its_back_face_order_towards_the_source() {
    let grey = Material {
        name: "grey".into(),
        kd: Rgb::splat(0.5),
        tf: Rgb::ZERO,
        ke: Rgb::ZERO,
    };
    let front = quad(0.0, 1.0);
    let mut tris: Vec<([DVec3; 3], u32)> = front.iter().map(|t| (*t, 0)).collect();
    tris.extend(front.iter().map(|t| ([t[0], t[2], t[1]], 0)));
    let mut s = scene_of(tris, vec![grey]);
    s.twin = vec![2, 3, 0, 1];
    for dir in [DVec3::Z, -DVec3::Z, DVec3::new(0.3, -0.2, 0.9).normalize()] {
        let ldi = Ldi::build(&s, dir, 20);
        let mut pairs = 0;
        for j in 0..ldi.camera.height {
            for i in 0..ldi.camera.width {
                let list = ldi.pixel(i, j);
                if list.is_empty() {
                    continue;
                }
                assert_eq!(list.len(), 2);
                assert_eq!(s.twin[list[0].tri as usize], list[1].tri);
                assert!(s.normals[list[0].tri as usize].dot(dir) > 0.0, "{dir}");
                pairs += 1;
            }
        }
        assert!(pairs > 50, "{pairs}");
    }
}

/// Each pixel's list holds exactly the faces whose triangle, rasterised on its own
/// with the image's camera, covers that pixel, at the height rasterising gives (the
/// build rasterises each triangle once and places its fragments afterwards).
#[test]
fn every_fragment_is_where_rasterising_its_triangle_puts_it() {
    let grey = Material {
        name: "grey".into(),
        kd: Rgb::splat(0.5),
        tf: Rgb::ZERO,
        ke: Rgb::ZERO,
    };
    let r = |i: u64| crate::math::rng::uniform(5, 1, i);
    let mut tris = Vec::new();
    for k in 0..200u64 {
        let c = DVec3::new(r(9 * k) * 6.0, r(9 * k + 1) * 6.0, r(9 * k + 2) * 3.0);
        let corner = |a: u64| {
            c + 2.0
                * r(9 * k + 3)
                * DVec3::new(r(9 * k + 4 + a), r(9 * k + 5 + a), r(9 * k + 6 + a))
        };
        tris.push(([corner(0), corner(1), corner(2)], 0));
    }
    let mut twin = vec![u32::MAX; tris.len()];
    for k in (0..200).step_by(2) {
        let v = tris[k].0;
        twin[k] = tris.len() as u32;
        twin.push(k as u32);
        tris.push(([v[0], v[2], v[1]], 0));
    }
    let mut s = scene_of(tris, vec![grey]);
    s.twin = twin;
    let ldi = Ldi::build(&s, DVec3::new(0.2, 0.4, 0.9).normalize(), 200);
    let cam = ldi.camera;
    let mut expected = 0;
    for k in 0..s.vertices.len() {
        let front = if s.is_back_face(k) {
            s.twin[k] as usize
        } else {
            k
        };
        let t = &s.vertices[front];
        let (p, h) = (t.map(|x| cam.to_pixel(x)), t.map(|x| cam.height_of(x)));
        raster::rasterize(p, h, cam.width, cam.height, |i, j, z| {
            expected += 1;
            let found: Vec<_> = ldi
                .pixel(i, j)
                .iter()
                .filter(|f| f.tri == k as u32)
                .collect();
            assert_eq!(found.len(), 1, "triangle {k} at {i},{j}");
            assert_eq!(found[0].height, z as f32, "triangle {k} at {i},{j}");
        });
    }
    assert_eq!(ldi.fragment_count(), expected);
    assert!(expected > 10_000, "{expected}");
}

/// The light arriving at a fragment has passed every pane in front of it: behind two
/// panes of glazing it is the product of their transmittances at that incidence, and
/// behind an opaque surface nothing. Read pixel by pixel or all at once, the same.
#[test]
fn light_arriving_behind_panes_is_the_product_of_their_transmittances() {
    let glass = |name: &str, tf: f64| Material {
        name: name.into(),
        kd: Rgb::ZERO,
        tf: Rgb::new(tf, 0.5 * tf, 0.25 * tf),
        ke: Rgb::ZERO,
    };
    let opaque = Material {
        name: "floor".into(),
        kd: Rgb::splat(0.5),
        tf: Rgb::ZERO,
        ke: Rgb::ZERO,
    };
    let materials = vec![glass("a", 0.8), glass("b", 0.6), opaque];
    // Two panes over a floor over a ground, each a quad; tilted light.
    let mut tris = Vec::new();
    for (z, m) in [(3.0, 0), (2.0, 1), (1.0, 2), (0.0, 2)] {
        tris.extend(quad(z, 2.0).map(|t| (t, m)));
    }
    let s = scene_of(tris, materials.clone());
    let dir = DVec3::new(0.3, 0.1, 1.0).normalize();
    let ldi = Ldi::build(&s, dir, 60);
    let t = |m: usize| materials[m].transmittance(dir.z);
    let expected = [Rgb::ONE, t(0), t(0) * t(1), Rgb::ZERO];
    let c = ldi.camera.to_pixel(DVec3::ZERO);
    let (i, j) = (c.x as u32, c.y as u32);
    let list = ldi.pixel(i, j);
    assert_eq!(list.len(), 4);
    for (f, want) in list.iter().zip(expected) {
        let got = ldi.arriving(i, j, f.tri).unwrap();
        assert!((got - want).abs().max_element() < 1e-6, "{got} {want}");
        assert!(got.min_element() > 0.0 || want == Rgb::ZERO);
    }
    assert_eq!(ldi.arriving(i, j, 1_000), None);
    let mut by_pixel = Vec::new();
    for j in 0..ldi.camera.height {
        for i in 0..ldi.camera.width {
            for f in ldi.pixel(i, j) {
                by_pixel.push((f.tri, ldi.arriving(i, j, f.tri).unwrap()));
            }
        }
    }
    let mut all = Vec::new();
    ldi.for_each_arrival(|f, t| all.push((f.tri, t)));
    assert_eq!(all, by_pixel);
    assert!(all.len() > 4_000, "{}", all.len());
}
