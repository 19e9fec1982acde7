//! Ray casts through the BVH (`math::bvh`), the sensors' inner loop: nanoseconds per
//! closest-hit and any-hit query on the generated 10 000-triangle building, rays from its
//! sensors in uniform directions over the sphere, one thread (`cargo bench --bench rays`).
//! Prints the median and range of 7 passes over the same rays. Prints only.

use daystep::math::bvh::Bvh;
use daystep::math::rng::uniform;
use glam::DVec3;
use std::time::Instant;

#[path = "../scenes/mod.rs"]
mod scenes;

/// Passes over the ray set; the median is quoted.
const PASSES: usize = 7;
/// Rays per sensor.
const PER_SENSOR: u64 = 200;

fn main() {
    let scene = scenes::multi_storey_building(10_000);
    let tris: Vec<[DVec3; 3]> = scene.triangles.iter().map(|t| t.v).collect();
    let t0 = Instant::now();
    let bvh = Bvh::build(&tris);
    let build = t0.elapsed().as_secs_f64();
    let mut rays = Vec::new();
    for (s, sn) in scene.sensors.iter().enumerate() {
        for i in 0..PER_SENSOR {
            let n = s as u64 * PER_SENSOR + i;
            let z = 2.0 * uniform(7, 0, n) - 1.0;
            let phi = std::f64::consts::TAU * uniform(7, 1, n);
            let r = (1.0 - z * z).sqrt();
            rays.push((sn.position, DVec3::new(r * phi.cos(), r * phi.sin(), z)));
        }
    }
    println!(
        "{} triangles, BVH built in {:.3} s; {} rays from {} sensors, {PASSES} passes",
        tris.len(),
        build,
        rays.len(),
        scene.sensors.len()
    );
    println!("| query | median ns/ray | min | max | hits |");
    println!("|---|---|---|---|---|");
    let time = |name: &str, f: &dyn Fn(DVec3, DVec3) -> bool| {
        let mut ns = Vec::new();
        let mut hits = 0;
        for _ in 0..PASSES {
            let t0 = Instant::now();
            hits = rays.iter().filter(|(o, d)| f(*o, *d)).count();
            ns.push(t0.elapsed().as_secs_f64() * 1e9 / rays.len() as f64);
        }
        ns.sort_by(f64::total_cmp);
        println!(
            "| {name} | {:.0} | {:.0} | {:.0} | {hits} |",
            ns[PASSES / 2],
            ns[0],
            ns[PASSES - 1]
        );
    };
    time("closest_hit", &|o, d| {
        bvh.closest_hit(o, d, 1e-6, f64::INFINITY).is_some()
    });
    time("any_hit", &|o, d| bvh.any_hit(o, d, 1e-6, f64::INFINITY));
}
