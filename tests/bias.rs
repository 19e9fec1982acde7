//! Ground glow deep in a building, against an independent path tracer.
//!
//! daystep splits the uniform ground glow below the horizon into parallel sources, each
//! shining along its triangle's centre. At a coarse ground depth every source is steep
//! (at depth 1 the shallowest centres lie 16° below the horizon), so the glow that enters a window
//! climbs to the ceiling within a few metres of it. The real glow arrives from every
//! direction below the horizon, and the part from just below it travels almost level: it
//! lands on the ceiling and the back wall far inside, and passes through a door into the
//! room behind. A deep room with a door to a back room, lit by the ground glow alone,
//! shows the difference where only interreflected light arrives: a sensor behind the door
//! is lit by ceiling and walls the level glow reaches and the steep sources do not.
//!
//! The reference traces paths from the sensors with nothing of daystep's but its ray
//! caster: cosine-distributed bounces that survive with probability ρ, and at every vertex
//! the glow sampled through the window, so every direction below the horizon counts with
//! its own angle. Its standard error comes from the paths' sample variance. daystep is
//! the mean of eight seeds of the `default` preset, held to its own stated error
//! (`lux_err`) plus three standard errors of the reference; nothing here is copied from
//! daystep's output.
//!
//! Seen when this was written: at the default ground depth (1: sixteen triangles), 5 m
//! from the window daystep read about 9 % high (the near ceiling too bright) and 10 m in,
//! behind the door, about 36 % low, against tolerances of about 4.5 and 10.5 %; both rows
//! agreed within 5 % at depth 2 and within 2.5 % at depth 3.
//!
//! A sensor 0.1 m from the back wall read 15.8 % low at the horizon depth 3 (stated error
//! 11 %, eight seeds; path tracing 3.32 ± 0.05 lx), 8.3 % low at depth 4 (stated 20 %)
//! and 1.5 % low at depth 5: the wall beside it held the coarse faces' bands of light.

use crate::util::*;
use daystep::scene::Scene;
use daystep::sequence::{Quality, SensorValue};
use daystep::trace::Tracer;
use glam::DVec3;
use rayon::prelude::*;

/// Ground radiance, W·sr⁻¹·m⁻² (a ground of reflectance 0.2 under about 15 klx).
const GROUND: f64 = 5.0;

/// The vertical rectangle in the plane y = `y`, x ∈ [x0, x1], z ∈ [z0, z1], facing +y
/// (`plus`) or −y.
fn wall_y(b: &mut Builder, y: f64, (x0, x1): (f64, f64), (z0, z1): (f64, f64), plus: bool, m: u32) {
    let p = |x, z| DVec3::new(x, y, z);
    let q = [p(x0, z0), p(x0, z1), p(x1, z1), p(x1, z0)];
    if plus {
        b.quad(q, m)
    } else {
        b.quad([q[0], q[3], q[2], q[1]], m)
    }
}

/// The vertical rectangle in the plane x = `x`, y ∈ [y0, y1], z ∈ [z0, z1], facing +x
/// (`plus`) or −x.
fn wall_x(b: &mut Builder, x: f64, (y0, y1): (f64, f64), (z0, z1): (f64, f64), plus: bool, m: u32) {
    let p = |y, z| DVec3::new(x, y, z);
    let q = [p(y0, z0), p(y1, z0), p(y1, z1), p(y0, z1)];
    if plus {
        b.quad(q, m)
    } else {
        b.quad([q[0], q[3], q[2], q[1]], m)
    }
}

const W: f64 = 4.0; // width (x), m
const D: f64 = 12.0; // depth (y), m
const H: f64 = 3.0; // height, m
const PARTITION: f64 = 6.0; // y of the wall between the front and the back room
/// The window in the south wall (y = 0): x ∈ [x0, x1], z ∈ [z0, z1], m.
const WINDOW: (f64, f64, f64, f64) = (0.3, W - 0.3, 0.8, 2.8);

/// A 4 × 12 × 3 m room, open to the south (y = 0) by a 3.4 × 2 m window without glass, cut
/// in two at y = 6 by a partition with a 1 × 2.1 m door. Sensors 0.8 m above the floor,
/// facing up, in the rows of [`GROUPS`]: none sees the glow itself, only the surfaces it
/// lights. Nothing stands outside, so below the horizon the window shows the glow alone.
fn deep_rooms() -> Scene {
    let mut b = Builder::new();
    let floor = b.material("floor", 0.25, 0.0);
    let ceiling = b.material("ceiling", 0.8, 0.0);
    let wall = b.material("wall", 0.6, 0.0);
    b.hrect(0.0, W, 0.0, D, 0.0, true, floor);
    b.hrect(0.0, W, 0.0, D, H, false, ceiling);
    let (wx0, wx1, wz0, wz1) = WINDOW;
    wall_y(&mut b, 0.0, (0.0, W), (0.0, wz0), true, wall);
    wall_y(&mut b, 0.0, (0.0, W), (wz1, H), true, wall);
    wall_y(&mut b, 0.0, (0.0, wx0), (wz0, wz1), true, wall);
    wall_y(&mut b, 0.0, (wx1, W), (wz0, wz1), true, wall);
    wall_y(&mut b, D, (0.0, W), (0.0, H), false, wall);
    wall_x(&mut b, 0.0, (0.0, D), (0.0, H), true, wall);
    wall_x(&mut b, W, (0.0, D), (0.0, H), false, wall);
    // Partition (one surface, lit on both faces) around the door x ∈ [1.5, 2.5], z < 2.1.
    let (dx0, dx1, dz) = (1.5, 2.5, 2.1);
    wall_y(&mut b, PARTITION, (0.0, dx0), (0.0, H), false, wall);
    wall_y(&mut b, PARTITION, (dx1, W), (0.0, H), false, wall);
    wall_y(&mut b, PARTITION, (dx0, dx1), (dz, H), false, wall);
    for (y, _) in GROUPS {
        for x in [1.0, 2.0, 3.0] {
            b.sensor(DVec3::new(x, y, 0.8), DVec3::Z);
        }
    }
    b.sensor(BESIDE_WALL, DVec3::Z);
    b.build()
}

/// A sensor 0.1 m from the back wall, facing the door 5.9 m away: half of what it sees is
/// the wall beside it, lit by the glow that passed the window and the door. A parallel
/// source images the door on that wall displaced by the source's angular size times the
/// throw, so coarse horizon faces put bands of light on the wall where the path tracer
/// finds a smooth gradient, and the sensor reads what the band beside it holds.
const BESIDE_WALL: DVec3 = DVec3::new(2.0, D - 0.1, 0.8);

/// Paths traced for [`BESIDE_WALL`] (its mean to about 1.5 %).
const BESIDE_WALL_PATHS: u64 = 1_000_000;

/// Largest low reading allowed beside the wall (issue 23: no sensor more than 10 % low).
const MAX_LOW: f64 = 0.10;

/// Sensor rows (distance from the window, m) and the paths traced per sensor in each:
/// 5 m into the front room, where the steep sources put too much light on the ceiling near
/// the window, and 10 m, in the back room. The back room is lit a thirtieth as much, and
/// only few paths from it find the door, so it needs more paths for the same relative
/// error (≤ 1 % for the row's mean).
const GROUPS: [(f64, u64); 2] = [(5.0, 200_000), (10.0, 1_000_000)];

/// Illuminance (lux) at each sensor and its standard error, by path tracing under a
/// uniform ground glow of radiance `ground` and a black sky. At each vertex the glow is
/// sampled through the window (a uniform point on the opening; the window is the room's
/// only opening, so a bounce ray that escapes is not counted again); the walk goes on with
/// a cosine-distributed direction and survives with probability ρ: unbiased, and with no
/// weights that grow.
fn path_traced(
    scene: &Scene,
    ground: f64,
    sensors: std::ops::Range<usize>,
    paths: u64,
) -> Vec<(f64, f64)> {
    use daystep::math::rng::uniform;
    use daystep::trace::cosine_direction;
    let tracer = Tracer::new(scene);
    let (wx0, wx1, wz0, wz1) = WINDOW;
    let area = (wx1 - wx0) * (wz1 - wz0);
    // The window's corner and sides in the scene frame (the model's origin subtracted).
    let corner = scene.point_from_model(DVec3::new(wx0, 0.0, wz0));
    let (along, up) = (DVec3::X * (wx1 - wx0), DVec3::Z * (wz1 - wz0));
    // Irradiance at `x` (normal `n`) from the glow through the window, one sample.
    let through_window = |x: DVec3, n: DVec3, u1: f64, u2: f64| -> f64 {
        let w = corner + along * u1 + up * u2;
        let v = w - x;
        let r2 = v.length_squared();
        let d = v / r2.sqrt();
        let cos_x = n.dot(d);
        if cos_x <= 0.0 || d.z >= 0.0 || tracer.first_hit(x, d).is_some() {
            return 0.0;
        }
        ground * area * cos_x * (-d.y) / r2
    };
    const CHUNKS: u64 = 64;
    const DIMS: u64 = 5;
    sensors
        .map(|k| {
            let s = &scene.sensors[k];
            let stream = k as u64;
            // Per chunk: Σ x and Σ x² of the path values (irradiance, W/m²).
            let (sum, sum2) = (0..CHUNKS)
                .into_par_iter()
                .map(|c| {
                    let (mut a, mut a2) = (0.0, 0.0);
                    for p in (c * paths / CHUNKS)..((c + 1) * paths / CHUNKS) {
                        let u = |bounce: u64, i: u64| uniform(p, stream, DIMS * bounce + i);
                        let (mut x, mut n) = (s.position, s.normal);
                        let mut value = through_window(x, n, u(0, 3), u(0, 4));
                        for bounce in 0..10_000u64 {
                            let (d, _) = cosine_direction(n, u(bounce, 0), u(bounce, 1));
                            let Some(hit) = tracer.first_hit(x, d) else {
                                break;
                            };
                            // A face met from behind with no back face of its own absorbs.
                            if hit.cos >= 0.0 {
                                break;
                            }
                            let rho = tracer.material_of(hit.tri).reflectance().x;
                            x = hit.point;
                            n = tracer.normal(hit.tri);
                            value += rho * through_window(x, n, u(bounce + 1, 3), u(bounce + 1, 4));
                            if u(bounce, 2) >= rho {
                                break;
                            }
                        }
                        a += value;
                        a2 += value * value;
                    }
                    (a, a2)
                })
                .reduce(|| (0.0, 0.0), |p, q| (p.0 + q.0, p.1 + q.1));
            let nf = paths as f64;
            let mean = sum / nf;
            let var = (sum2 / nf - mean * mean).max(0.0) * nf / (nf - 1.0);
            (lux_of(mean), lux_of((var / nf).sqrt()))
        })
        .collect()
}

/// Runs of independent seeds averaged: the global lines' noise shrinks by √8, which keeps
/// the comparison of the back room (a few lux, a few percent of noise per run) and of the
/// sensor beside its wall (about 10 % per run) sharp.
const SEEDS: u64 = 8;

/// Mean over the sensors `sensors` and the runs of their `lux` and of their `lux_err`.
fn seed_mean(runs: &[Vec<SensorValue>], sensors: std::ops::Range<usize>) -> (f64, f64) {
    let n = (sensors.len() * runs.len()) as f64;
    let values = || runs.iter().flat_map(|v| &v[sensors.clone()]);
    (
        values().map(|s| s.lux).sum::<f64>() / n,
        values().map(|s| s.lux_err).sum::<f64>() / n,
    )
}

#[test]
fn ground_glow_deep_inside_matches_path_tracing() {
    let scene = deep_rooms();
    let sky = sky_of(None, None, GROUND);
    let q = Quality::preset("default").unwrap();
    let runs: Vec<Vec<SensorValue>> = (0..SEEDS)
        .map(|s| run(&scene, &sky, &q.with_seed(q.transport.seed + s)).sensors)
        .collect();
    let mut failed = vec![];
    for (g, (y, paths)) in GROUPS.into_iter().enumerate() {
        let row = 3 * g..3 * g + 3;
        let n = row.len() as f64;
        let reference = path_traced(&scene, GROUND, row.clone(), paths);
        let r = reference.iter().map(|x| x.0).sum::<f64>() / n;
        let r_se = reference.iter().map(|x| x.1 * x.1).sum::<f64>().sqrt() / n;
        // The row's mean over the sensors and the seeds, and its mean stated error.
        let (got, stated) = seed_mean(&runs, row.clone());
        // The reference at three standard errors, daystep within its own stated error
        // (noise of the lines, mesh discretisation, iteration; a mean of seeds is, if
        // anything, closer than one run).
        let tol = 3.0 * r_se + stated;
        let line = format!(
            "{y} m from the window: daystep {got:.2} lx (stated ± {stated:.2}), path tracing \
             {r:.2} ± {r_se:.3} lx, difference {:+.1} %, tolerance {:.1} %",
            100.0 * (got / r - 1.0),
            100.0 * tol / r
        );
        eprintln!("{line}");
        if (got - r).abs() > tol {
            failed.push(line);
        }
    }
    // The sensor beside the back wall: within its stated error and not more than 10 % low,
    // each with three standard errors of the reference.
    let k = 3 * GROUPS.len();
    let (r, r_se) = path_traced(&scene, GROUND, k..k + 1, BESIDE_WALL_PATHS)[0];
    let (got, stated) = seed_mean(&runs, k..k + 1);
    let line = format!(
        "0.1 m from the back wall: daystep {got:.2} lx (stated ± {stated:.2}), path tracing \
         {r:.2} ± {r_se:.3} lx, difference {:+.1} %",
        100.0 * (got / r - 1.0)
    );
    eprintln!("{line}");
    if (got - r).abs() > 3.0 * r_se + stated || got < (1.0 - MAX_LOW) * r - 3.0 * r_se {
        failed.push(line);
    }
    assert!(
        failed.is_empty(),
        "ground glow off deep inside:\n{}",
        failed.join("\n")
    );
}
