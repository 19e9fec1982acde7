//! Coincident faces, as exported models have them: a floor lying on a ground plane, a
//! desk on a floor, two walls back to back. The rule (`projection::ldi::order_coincident`,
//! `trace::Tracer::trace`): faces within 0.5 mm along a line are one surface; a face
//! towards the line's origin comes before one facing away, and among faces facing the same
//! way the smaller triangle shows. Each case checks that no light leaks and that rounding
//! does not decide what a sensor or an element sees.

use crate::util::*;
use daystep::photometry::{lux, Rgb};
use daystep::radiosity::{Transport, TransportParams, TransportState};
use daystep::scene::Scene;
use glam::DVec3;

fn params() -> TransportParams {
    TransportParams {
        directions: 256,
        resolution: 128,
        gather_rays: 16384,
        ..TransportParams::default()
    }
}

fn solved(scene: &Scene) -> (Transport, TransportState) {
    let t = Transport::build(scene, &scene.sensors, &params());
    let (st, _) = t.solve(&vec![Rgb::ZERO; t.rows()], None);
    (t, st)
}

/// Area-weighted mean radiosity (grey, W/m²) of the rows of triangles `tris` whose centre
/// satisfies `keep`.
fn mean_b(t: &Transport, st: &TransportState, tris: &[u32], keep: impl Fn(DVec3) -> bool) -> f64 {
    let (mut sum, mut area) = (0.0, 0.0);
    for r in 0..t.rows() {
        let el = &t.mesh.hierarchy.elements[t.mesh.elements[r] as usize];
        let c = (el.vertices[0] + el.vertices[1] + el.vertices[2]) / 3.0;
        if tris.contains(&el.key.tri) && keep(c) {
            sum += t.radiosity(st, r).x * t.mesh.area[r];
            area += t.mesh.area[r];
        }
    }
    sum / area
}

/// An emitting 2 × 2 m panel facing down 1 m above a 4 × 4 m grey floor (ρ 0.5) at
/// z = 0.3 m; a sensor 0.5 m above the floor's centre looking down reads the floor. With
/// `ground`, a black 40 × 40 m ground plane facing up lies exactly in the floor's plane,
/// listed first (so index order alone would show the ground).
fn floor_scene(ground: bool) -> Scene {
    let mut b = Builder::new();
    let z = 0.3;
    if ground {
        let g = b.material("ground", 0.0, 0.0);
        b.hrect(-20.0, 20.0, -20.0, 20.0, z, true, g);
    }
    let lamp = b.material("lamp", 0.0, 0.0);
    b.input.materials[lamp as usize].ke = Rgb::splat(10.0);
    let floor = b.material("floor", 0.5, 0.0);
    b.hrect(-1.0, 1.0, -1.0, 1.0, z + 1.0, false, lamp);
    b.hrect(-2.0, 2.0, -2.0, 2.0, z, true, floor);
    b.sensor(DVec3::new(0.1, -0.05, z + 0.5), -DVec3::Z);
    b.build()
}

#[test]
fn a_floor_on_the_ground_plane_reads_as_the_floor() {
    // A black ground under the floor changes nothing the sensor can see: the floor shows
    // (the smaller face) and keeps all its light. Before the rule, rounding split the
    // floor's lines and the sensor's rays between the two: the sensor read 30 % low.
    let (ta, sa) = solved(&floor_scene(false));
    let (tb, sb) = solved(&floor_scene(true));
    let (a, b) = (ta.sensors(&sa)[0], tb.sensors(&sb)[0]);
    let (la, lb) = (lux(a.irradiance), lux(b.irradiance));
    // Noise only: the floor's mesh is the same in both scenes, so the discretisation
    // estimate is common to them.
    let sigma = (lux(a.std_err).powi(2) + lux(b.std_err).powi(2)).sqrt();
    let allowed = 4.0 * sigma;
    eprintln!("floor alone {la:.1} lx, on a black ground {lb:.1} lx, allowed {allowed:.1}");
    assert!(
        (la - lb).abs() <= allowed,
        "{la} vs {lb} (allowed {allowed})"
    );
    // The floor's own radiosity (its triangles are the last two in each scene).
    let floor = |t: &Transport, st: &TransportState| mean_b(t, st, &floor_tris(t), |_| true);
    let (fa, fb) = (floor(&ta, &sa), floor(&tb, &sb));
    eprintln!("floor B alone {fa:.4}, on the ground {fb:.4}");
    assert!((fa - fb).abs() <= 0.03 * fa, "floor B {fa} vs {fb}");
}

/// The indices of the floor's two triangles: the last two input triangles.
fn floor_tris(t: &Transport) -> Vec<u32> {
    let roots = t
        .mesh
        .hierarchy
        .elements
        .iter()
        .filter(|e| e.parent.is_none())
        .count() as u32;
    vec![roots - 2, roots - 1]
}

#[test]
fn a_desk_on_the_floor_keeps_the_floor_under_it_dark() {
    // A 1 × 1 × 0.7 m desk (closed box, outward faces) stands on a 4 × 4 m floor; its bottom
    // face lies in the floor's plane, facing down onto it. The lamp above lights the floor
    // around the desk; the floor under the desk sees only the desk's bottom and must
    // receive nothing.
    let mut b = Builder::new();
    let floor = b.material("floor", 0.5, 0.0);
    b.hrect(-2.0, 2.0, -2.0, 2.0, 0.0, true, floor);
    let desk = b.material("desk", 0.5, 0.0);
    b.hrect(-0.5, 0.5, -0.5, 0.5, 0.7, true, desk);
    b.hrect(-0.5, 0.5, -0.5, 0.5, 0.0, false, desk);
    outward_walls(&mut b, (-0.5, 0.5, -0.5, 0.5, 0.0, 0.7), desk);
    let lamp = b.material("lamp", 0.0, 0.0);
    b.input.materials[lamp as usize].ke = Rgb::splat(10.0);
    b.hrect(-1.5, 1.5, -1.5, 1.5, 2.0, false, lamp);
    let scene = b.build();
    let (t, st) = solved(&scene);
    let under = |c: DVec3| c.x.abs() < 0.45 && c.y.abs() < 0.45;
    let around = |c: DVec3| c.x.abs() > 1.0 || c.y.abs() > 1.0;
    let (b_under, b_around) = (
        mean_b(&t, &st, &[0, 1], under),
        mean_b(&t, &st, &[0, 1], around),
    );
    eprintln!("floor under the desk B {b_under:.2e}, around it {b_around:.3}");
    assert!(b_around > 1.0);
    assert!(
        b_under <= 1e-3 * b_around,
        "light leaks under the desk: {b_under}"
    );
}

/// Four vertical faces of the box `(x0, x1, y0, y1, z0, z1)`, facing out.
fn outward_walls(
    b: &mut Builder,
    (x0, x1, y0, y1, z0, z1): (f64, f64, f64, f64, f64, f64),
    m: u32,
) {
    let p = DVec3::new;
    b.quad(
        [p(x0, y0, z0), p(x1, y0, z0), p(x1, y0, z1), p(x0, y0, z1)],
        m,
    ); // -y
    b.quad(
        [p(x1, y1, z0), p(x0, y1, z0), p(x0, y1, z1), p(x1, y1, z1)],
        m,
    ); // +y
    b.quad(
        [p(x0, y1, z0), p(x0, y0, z0), p(x0, y0, z1), p(x0, y1, z1)],
        m,
    ); // -x
    b.quad(
        [p(x1, y0, z0), p(x1, y1, z0), p(x1, y1, z1), p(x1, y0, z1)],
        m,
    ); // +x
}

#[test]
fn two_walls_back_to_back_let_no_light_through() {
    // One 4 m wall modelled twice in the plane x = 0.37, one face towards −x and one
    // towards +x; a lamp lights the −x side. The +x face and a sensor facing it on the
    // +x side must receive nothing.
    let mut b = Builder::new();
    let wall = b.material("wall", 0.5, 0.0);
    let p = DVec3::new;
    let x = 0.37;
    // Facing −x (towards the lamp).
    b.quad(
        [
            p(x, -2.0, 0.0),
            p(x, -2.0, 3.0),
            p(x, 2.0, 3.0),
            p(x, 2.0, 0.0),
        ],
        wall,
    );
    // Facing +x (the dark side).
    b.quad(
        [
            p(x, 2.0, 0.0),
            p(x, 2.0, 3.0),
            p(x, -2.0, 3.0),
            p(x, -2.0, 0.0),
        ],
        wall,
    );
    let lamp = b.material("lamp", 0.0, 0.0);
    b.input.materials[lamp as usize].ke = Rgb::splat(10.0);
    // A lamp 1 m away on the −x side, facing +x.
    b.quad(
        [
            p(x - 1.0, 1.0, 0.5),
            p(x - 1.0, 1.0, 2.5),
            p(x - 1.0, -1.0, 2.5),
            p(x - 1.0, -1.0, 0.5),
        ],
        lamp,
    );
    b.sensor(p(x + 0.5, 0.1, 1.5), -DVec3::X);
    let scene = b.build();
    assert!(scene.triangles[0].normal().x < 0.0 && scene.triangles[2].normal().x > 0.0);
    assert!(
        scene.triangles[4].normal().x > 0.0,
        "the lamp faces the wall"
    );
    let (t, st) = solved(&scene);
    let lit = mean_b(&t, &st, &[0, 1], |_| true);
    let dark = mean_b(&t, &st, &[2, 3], |_| true);
    let s = lux(t.sensors(&st)[0].irradiance);
    eprintln!("lit face B {lit:.3}, dark face B {dark:.2e}, dark-side sensor {s:.2e} lx");
    assert!(lit > 1.0);
    assert!(dark <= 1e-3 * lit, "light leaks through the wall: {dark}");
    assert!(
        s <= 1e-3 * lux(Rgb::splat(lit)),
        "the dark-side sensor reads {s} lx"
    );
}
