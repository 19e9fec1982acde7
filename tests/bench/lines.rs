//! Global-line bundles (`radiosity::Transport`): error against time of the indirect
//! illuminance at the sensors, on the sample office and the generated 10 000-triangle
//! building, direct light from one Perez instant (`cargo bench --bench lines`). The
//! reference is independent of the operator: plain path tracing on the same direct-irradiance field (every bounce re-traced,
//! no mesh, no form factors) at a subset of the sensors. Then a day of 15-minute
//! warm-started transport steps against cold ones. Prints only.

use daystep::photometry::{lux, Rgb};
use daystep::radiosity::{Transport, TransportParams};
use daystep::scene::Scene;
use daystep::sequence::instant::{build_sky, run_sky};
use daystep::sequence::{Quality, SkySpec};
use daystep::site::{parse_time, solar_position::solar_position};
use daystep::trace::Tracer;
use std::path::Path;
use std::time::Instant;

#[path = "../scenes/mod.rs"]
mod scenes;

fn direct(scene: &Scene, time: &str) -> (daystep::hierarchy::Hierarchy, Vec<Rgb>) {
    let (utc, local) = parse_time(time, scene.site.utc_offset_h).unwrap();
    let sun = solar_position(utc, &scene.site);
    let spec = SkySpec::Perez {
        dni: 750.0,
        dhi: 110.0,
        dew_point_c: None,
    };
    use chrono::Datelike;
    let sky = build_sky(&spec, &sun, local.ordinal(), scene.ground_reflectance).unwrap();
    let r = run_sky(scene, &sky, &Quality::default(), &mut Default::default());
    let e = r
        .direct
        .sun
        .iter()
        .zip(&r.direct.sky)
        .map(|(a, b)| *a + *b)
        .collect();
    (r.hierarchy, e)
}

/// Indirect illuminance at `sensors` (indices) by path tracing: cosine-sampled bounces,
/// each adding ρ·E_direct at the hit (the direct field of hierarchy `h`), RGB throughput.
fn path_traced(
    scene: &Scene,
    h: &daystep::hierarchy::Hierarchy,
    e: &[Rgb],
    tracer: &Tracer,
    sensors: &[usize],
    paths: u64,
) -> Vec<f64> {
    use daystep::math::rng::uniform;
    use daystep::trace::{barycentric, cosine_direction, End};
    use rayon::prelude::*;
    let leaf = |tri: u32, y: glam::DVec3| -> Rgb {
        let mut i = tri;
        let mut b = barycentric(scene.triangles[tri as usize].v, y);
        while let Some(fc) = h.elements[i as usize].first_child {
            i = fc + daystep::hierarchy::child_of(&mut b) as u32;
        }
        e[i as usize]
    };
    sensors
        .par_iter()
        .map(|&k| {
            let s = &scene.sensors[k];
            let mut sum = Rgb::ZERO;
            for p in 0..paths {
                let (mut x, mut n, mut w) = (s.position, s.normal, Rgb::ONE);
                let stream = 1000 + k as u64;
                for depth in 0..64u64 {
                    let (d, _) = cosine_direction(
                        n,
                        uniform(p, stream, 2 * depth),
                        uniform(p, stream, 2 * depth + 1),
                    );
                    let out = tracer.trace(x, d, Rgb::ONE);
                    let End::Front { tri, point, .. } = out.end else {
                        break;
                    };
                    let m = &scene.materials[scene.triangles[tri as usize].material as usize];
                    let rho = m.reflectance();
                    w *= out.power * rho;
                    sum += w * leaf(tri, point);
                    if w.max_element() < 1e-5 {
                        break;
                    }
                    x = point;
                    n = scene.triangles[tri as usize].normal();
                }
            }
            lux(sum / paths as f64)
        })
        .collect()
}

/// RMS and max relative difference over sensors with a reference above 1 lx.
fn err(a: &[f64], r: &[f64]) -> (f64, f64) {
    let (mut s, mut m, mut n) = (0.0, 0.0f64, 0);
    for (x, y) in a.iter().zip(r) {
        if *y > 1.0 {
            let d = (x - y) / y;
            s += d * d;
            m = m.max(d.abs());
            n += 1;
        }
    }
    ((s / n.max(1) as f64).sqrt(), m)
}

fn bench(name: &str, scene: &Scene, stride: usize, paths: u64) {
    let (h, e) = direct(scene, "2024-06-21T15:00");
    let tracer = Tracer::new(scene);
    let subset: Vec<usize> = (0..scene.sensors.len()).step_by(stride).collect();
    println!(
        "\n## {name}: {} triangles, {} sensors ({} compared)",
        scene.triangles.len(),
        scene.sensors.len(),
        subset.len()
    );
    let t0 = Instant::now();
    let reference = path_traced(scene, &h, &e, &tracer, &subset, paths);
    let mean_ref = reference.iter().sum::<f64>() / reference.len() as f64;
    println!(
        "reference: path tracing, {paths} paths per sensor, {:.1} s; mean indirect {mean_ref:.1} lx (1σ ≈ {:.2} %)",
        t0.elapsed().as_secs_f64(),
        100.0 / (paths as f64).sqrt()
    );
    let pick = |v: &[f64]| subset.iter().map(|&k| v[k]).collect::<Vec<f64>>();
    println!("| method | setting | s | RMS rel. error | max rel. error | stated RMS |\n|---|---|---|---|---|---|");
    for (dirs, res, area) in [
        (64u32, 512u32, 0.25),
        (256, 256, 0.25),
        (256, 512, 0.25),
        (1024, 256, 0.25),
        (1024, 512, 0.25),
        (4096, 256, 0.25),
    ] {
        let p = TransportParams {
            directions: dirs,
            resolution: res,
            element_area_m2: area,
            ..TransportParams::default()
        };
        let t0 = Instant::now();
        let t = Transport::build(scene, &scene.sensors, &p);
        let tb = t0.elapsed().as_secs_f64();
        let (st, rep) = t.solve(&t.mesh.average_onto(&h, &e), None);
        let out = t.sensors(&st);
        let s = t0.elapsed().as_secs_f64();
        let v: Vec<f64> = out.iter().map(|o| lux(o.irradiance)).collect();
        let (r, m) = err(&pick(&v), &reference);
        let stated = subset
            .iter()
            .zip(&reference)
            .map(|(&k, y)| ((lux(out[k].std_err) + lux(out[k].discretisation)) / y).powi(2))
            .sum::<f64>()
            / subset.len() as f64;
        println!(
            "| global lines | {dirs} dirs, {res} px, {area} m² ({} rows, {} links, {:.0} M lines) | {s:.2} (build {tb:.2}, solve {:.3}) | {r:.4} | {m:.4} | {:.4} |",
            t.stats.rows,
            t.stats.links,
            t.stats.lines as f64 / 1e6,
            rep.seconds,
            stated.sqrt()
        );
    }
}

/// 96 fifteen-minute steps of a clear day: warm-started transport solves against cold
/// ones on the same operator.
fn day(scene: &Scene) {
    let t = Transport::build(scene, &scene.sensors, &TransportParams::default());
    let (mut warm_s, mut cold_s, mut worst) = (0.0, 0.0, 0.0f64);
    let mut prev = None;
    let mut steps = 0;
    for k in 0..96 {
        let (hh, mm) = (k / 4, (k % 4) * 15);
        let time = format!("2024-06-21T{hh:02}:{mm:02}");
        let (h, e) = direct(scene, &time);
        let mesh_e = t.mesh.average_onto(&h, &e);
        let (cold, rc) = t.solve(&mesh_e, None);
        let (warm, rw) = t.solve(&mesh_e, prev.as_ref());
        cold_s += rc.seconds;
        warm_s += rw.seconds;
        let (a, b) = (t.sensors(&warm), t.sensors(&cold));
        for (x, y) in a.iter().zip(&b) {
            let (x, y) = (lux(x.irradiance), lux(y.irradiance));
            if y > 1.0 {
                worst = worst.max((x - y).abs() / y);
            }
        }
        prev = Some(warm);
        steps += 1;
    }
    println!(
        "\nday of {steps} 15-minute steps (office, transport default): cold solves {:.3} s total, warm {:.3} s total (ratio {:.2}); worst warm-vs-cold sensor difference {worst:.2e} (tolerance {})",
        cold_s,
        warm_s,
        warm_s / cold_s,
        t.params.tolerance
    );
}

fn main() {
    let office = Scene::load(Path::new("scenes/office/scene.toml")).expect("sample office");
    bench("sample office", &office, 8, 200_000);
    day(&office);
    if std::env::args().any(|a| a == "--office-only") {
        return;
    }
    // The default operator of the building (element size bounded by `max_rows`).
    bench(
        "multi-storey building 10k",
        &scenes::multi_storey_building(10_000),
        80,
        50_000,
    );
}
