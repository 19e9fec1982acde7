//! Benchmark of the HMC radiosity solver (`cargo bench --bench radiosity`): error against
//! time for cold solves at several line budgets, on the sample office and a generated
//! 10 000-triangle building, direct light from one Perez instant. The reference is a long
//! solve (4× the largest budget, another seed); the "true" error is the area-weighted RMS
//! relative difference of leaf radiosity (on the reference's leaves) to it. Prints only.

use daystep::photometry::grey;
use daystep::radiosity::{solve, RadiosityParams, RadiosityState, Tracer};
use daystep::scene::{synthetic, Scene};
use daystep::sequence::{run_instant, SkySpec};
use daystep::site::parse_time;
use std::path::Path;

fn state_for(scene: &Scene) -> (RadiosityState, Tracer) {
    let (utc, local) = parse_time("2024-06-21T15:00", scene.site.utc_offset_h).unwrap();
    let spec = SkySpec::Perez {
        dni: 750.0,
        dhi: 110.0,
        dew_point_c: None,
    };
    let r = run_instant(scene, utc, local, &spec, &Default::default()).unwrap();
    let st = RadiosityState::from_direct(scene, r.hierarchy.clone(), &r.direct);
    (st, Tracer::new(scene))
}

/// Area-weighted RMS relative difference of `a` to `reference` over the reference's
/// leaves (located in `a` by key; missing ones via their nearest ancestor).
fn rms_rel(a: &RadiosityState, reference: &RadiosityState) -> f64 {
    let h = reference.hierarchy();
    let (mut num, mut den) = (0.0, 0.0);
    for i in h.leaves() {
        let el = &h.elements[i as usize];
        let mut key = el.key;
        let j = loop {
            if let Some(j) = a.hierarchy().get(key) {
                break j;
            }
            key = key.parent().unwrap();
        };
        let r = grey(reference.radiosity(i));
        let d = grey(a.radiosity(j)) - r;
        num += el.area * d * d;
        den += el.area * r * r;
    }
    (num / den.max(1e-300)).sqrt()
}

fn bench(name: &str, scene: &Scene) {
    let (base, tracer) = state_for(scene);
    println!(
        "\n## {name}: {} triangles, {} elements after the direct shoot",
        scene.triangles.len(),
        base.hierarchy().elements.len()
    );
    let budgets = [250_000u64, 1_000_000, 4_000_000];
    let mut reference = base.clone();
    let rp = RadiosityParams {
        target_rel_error: 0.0,
        max_lines: 4 * budgets[budgets.len() - 1],
        max_seconds: 600.0,
        seed: 12345,
        ..Default::default()
    };
    let rr = solve(&mut reference, &tracer, &rp);
    println!(
        "reference: {} lines, {} batches, {:.2} s, leaves {}, estimated error {:.4}, energy residual {:?} ± {:?}",
        rr.lines, rr.batches, rr.seconds, rr.leaves, rr.estimated_error, rr.energy.residual, rr.energy.residual_std_err
    );
    println!("| max lines | lines | batches | s | leaves | estimated error | error vs reference | stop |\n|---|---|---|---|---|---|---|---|");
    for &b in &budgets {
        let mut st = base.clone();
        let p = RadiosityParams {
            target_rel_error: 0.0,
            max_lines: b,
            lines_per_step: (b / 40).max(1000),
            max_seconds: 600.0,
            ..Default::default()
        };
        let r = solve(&mut st, &tracer, &p);
        println!(
            "| {b} | {} | {} | {:.3} | {} | {:.4} | {:.4} | {:?} |",
            r.lines,
            r.batches,
            r.seconds,
            r.leaves,
            r.estimated_error,
            rms_rel(&st, &reference),
            r.stop
        );
    }
}

fn main() {
    let office = Scene::load(Path::new("scenes/office/scene.toml")).expect("sample office");
    bench("sample office", &office);
    bench(
        "multi-storey building 10k",
        &synthetic::multi_storey_building(10_000),
    );
}
