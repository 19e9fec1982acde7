//! Unit tests of the tracer ([`super`]): sampling helpers, glazing walks, cached panes,
//! the glazing mirror.

use super::*;
use crate::math::rng::uniform;
use crate::scene::material::glass_reflectance;
use crate::scene::{ModelInput, Triangle};

#[test]
fn cosine_directions_have_mean_cosine_two_thirds() {
    // E[cos θ] under pdf cos θ/π is 2/3.
    let n = DVec3::new(0.2, -0.3, 0.9).normalize();
    let k = 20_000;
    let mut s = 0.0;
    for i in 0..k {
        let (d, c) = cosine_direction(n, uniform(1, 2, 2 * i), uniform(1, 2, 2 * i + 1));
        assert!((d.dot(n) - c).abs() < 1e-9 && c >= 0.0);
        s += c;
    }
    assert!((s / k as f64 - 2.0 / 3.0).abs() < 0.01);
}

#[test]
fn barycentric_round_trips() {
    let v = [DVec3::ZERO, DVec3::X * 2.0, DVec3::new(0.5, 1.5, 0.0)];
    let b = uniform_barycentric(0.37, 0.81);
    let p = v[0] * b[0] + v[1] * b[1] + v[2] * b[2];
    let q = barycentric(v, p);
    for k in 0..3 {
        assert!((b[k] - q[k]).abs() < 1e-12);
    }
}

/// Two horizontal glazing panes (z = 0, 1, normals up) over an opaque floor (z = −1,
/// facing up), each a 40 m square of two triangles, centred on the origin (so the
/// scene keeps these coordinates).
fn panes_over_floor() -> Scene {
    let square = |z: f64, material: u32| {
        let c = [
            DVec3::new(-20.0, -20.0, z),
            DVec3::new(20.0, -20.0, z),
            DVec3::new(20.0, 20.0, z),
            DVec3::new(-20.0, 20.0, z),
        ];
        [[c[0], c[1], c[2]], [c[0], c[2], c[3]]].map(|v| Triangle {
            v,
            material,
            group: 0,
        })
    };
    let input = ModelInput {
        materials: vec![
            Material {
                name: "floor".into(),
                kd: Rgb::splat(0.2),
                tf: Rgb::ZERO,
                ke: Rgb::ZERO,
            },
            Material {
                name: "glass".into(),
                kd: Rgb::ZERO,
                tf: Rgb::new(0.9, 0.6, 0.3),
                ke: Rgb::ZERO,
            },
        ],
        triangles: [square(-1.0, 0), square(0.0, 1), square(1.0, 1)].concat(),
        // A sensor under the floor: something behind it, so it keeps its back face.
        sensors: vec![(DVec3::new(0.0, 0.0, -2.0), DVec3::Z)],
        ..ModelInput::default()
    };
    Scene::from_model(std::path::Path::new("<t>"), input).unwrap()
}

#[test]
fn cached_panes_give_the_transmission_of_a_new_ray_at_any_incidence() {
    // Up from between the floor and the panes: both panes, then the sky. τ at another
    // angle of incidence from the cached panes equals a new ray's, bit for bit.
    let scene = panes_over_floor();
    let tracer = Tracer::new(&scene);
    let (o, d) = (
        DVec3::new(0.3, 0.2, -0.5),
        DVec3::new(0.2, -0.1, 1.0).normalize(),
    );
    let panes = tracer.panes_along(o, d, 4).expect("two panes");
    assert_eq!(panes.len(), 2);
    for inc in [
        d,
        DVec3::new(0.5, 0.4, 0.7).normalize(),
        DVec3::new(0.0, 0.99, 0.1).normalize(),
    ] {
        assert_eq!(
            tracer.transmission_through(&panes, inc),
            tracer.transmission_for(o, d, inc)
        );
    }
    assert!(
        tracer.panes_along(o, d, 1).is_none(),
        "more panes than asked for"
    );
    // Down onto the floor: no pane before the opaque floor.
    assert_eq!(
        tracer.panes_along(DVec3::new(0.0, 0.0, -0.5), -DVec3::Z, 4),
        Some(vec![])
    );
}

#[test]
fn walk_multiplies_tau_at_the_incidence_angle_and_stops_at_the_floor() {
    let scene = panes_over_floor();
    let tracer = Tracer::new(&scene);
    let glass = &scene.materials[1];
    let d = DVec3::new(0.3, 0.1, -1.0).normalize();
    // Down from above both panes: τ(θ)² with cos θ = |d·z|, ending on the floor's
    // front face at z = −1 with the ray's cosine.
    let out = tracer.trace(DVec3::new(0.0, 0.0, 3.0), d, Rgb::ONE);
    let tau = glass.transmittance(d.z.abs());
    assert!((out.power - tau * tau).abs().max_element() < 1e-15);
    assert!(
        (out.glazing_loss - (Rgb::ONE - tau * tau))
            .abs()
            .max_element()
            < 1e-15
    );
    assert_eq!(out.panes, 2);
    let End::Front { tri, point, cos } = out.end else {
        panic!("{:?}", out.end)
    };
    assert!(tri < 2 && (point.z + 1.0).abs() < 1e-12 && (cos - d.z.abs()).abs() < 1e-15);
    assert_eq!(out.transmission(), Rgb::ZERO);
    // Up through both panes to the sky, τ at a different (true sun) angle.
    let up = DVec3::new(0.0, 0.0, 1.0);
    let sun = DVec3::new(0.6, 0.0, 0.8);
    let t = tracer.transmission_for(DVec3::new(0.0, 0.0, -0.5), up, sun);
    let tau_sun = glass.transmittance(0.8);
    assert!((t - tau_sun * tau_sun).abs().max_element() < 1e-15);
    // From below the floor: the ray ends on the floor's back face, facing it.
    let out = tracer.trace(DVec3::new(0.0, 0.0, -2.0), up, Rgb::ONE);
    let End::Front { tri, cos, .. } = out.end else {
        panic!("{:?}", out.end)
    };
    assert!(tri as usize >= scene.input_triangles && scene.twin[tri as usize] < 2);
    assert!((cos - 1.0).abs() < 1e-15 && tracer.normal(tri).z < -0.999);
    // One-sided (`faces = "front"`): the floor's back is black, the ray absorbed there.
    let mut front = scene.clone();
    front.triangles.truncate(front.input_triangles);
    front.twin.clear();
    let out = Tracer::new(&front).trace(DVec3::new(0.0, 0.0, -2.0), up, Rgb::ONE);
    assert_eq!(
        out.end,
        End::Back {
            tri: out.end.stopper().unwrap()
        }
    );
    assert_eq!(
        tracer.transmission(DVec3::new(0.0, 0.0, -2.0), up),
        Rgb::ZERO
    );
}

#[test]
fn mirror_reflects_about_the_pane_normal_with_fresnel_weight() {
    let scene = panes_over_floor();
    let tracer = Tracer::new(&scene);
    // Light leaving the upper pane up and east towards a receiver above it arrived
    // heading down and east: the mirror ray goes back up and west.
    let toward = DVec3::new(0.6, 0.0, 0.8);
    let at = DVec3::new(0.0, 0.0, 1.0);
    let hit = tracer
        .first_hit(DVec3::new(0.0, 0.0, 3.0), -DVec3::Z)
        .unwrap();
    assert!(hit.glazing && (hit.point - at).length() < 1e-12);
    let out = tracer.mirror(hit.tri, at, toward, Rgb::ONE).unwrap();
    assert_eq!(out.end, End::Escaped);
    let tf = scene.materials[1].tf;
    let r = Rgb::new(
        glass_reflectance(tf.x, 0.8),
        glass_reflectance(tf.y, 0.8),
        glass_reflectance(tf.z, 0.8),
    );
    assert!((out.power - r).abs().max_element() < 1e-15);
    // Towards the pane from below (the receiver under it): the mirror ray heads down
    // to the floor, crossing the lower pane.
    let out = tracer
        .mirror(hit.tri, at, DVec3::new(0.6, 0.0, -0.8), Rgb::ONE)
        .unwrap();
    let End::Front { point, .. } = out.end else {
        panic!("{:?}", out.end)
    };
    // From (0, 0, 1) along (−0.6, 0, −0.8): the floor (z = −1) at x = −1.5.
    assert!((point - DVec3::new(-1.5, 0.0, -1.0)).length() < 1e-9);
    assert_eq!(out.panes, 1);
    let tau = scene.materials[1].transmittance(0.8);
    assert!((out.power - r * tau).abs().max_element() < 1e-15);
}
