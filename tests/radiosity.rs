//! Hierarchical Monte Carlo radiosity against closed forms (validation_cases.md §2.2–2.3):
//! furnace, configuration factor, Sumpner room, energy balance, thread independence.

use crate::util::*;
use daystep::hierarchy::Hierarchy;
use daystep::photometry::Rgb;
use daystep::radiosity::{
    gather_sensor, solve, warm_start, RadiosityParams, RadiosityState, StopReason, Tracer,
};
use daystep::scene::Scene;
use glam::DVec3;
use std::f64::consts::PI;

/// Closed cube [0,s]³ with inward faces, one material of reflectance `rho` emitting `ke`.
fn furnace(s: f64, rho: f64, ke: f64) -> Scene {
    let mut b = Builder::new();
    let m = b.material("wall", rho, 0.0);
    b.input.materials[m as usize].ke = Rgb::splat(ke);
    b.hrect(0.0, s, 0.0, s, 0.0, true, m);
    b.hrect(0.0, s, 0.0, s, s, false, m);
    b.walls_inward(0.0, s, 0.0, s, 0.0, s, m);
    b.build()
}

fn cold(
    scene: &Scene,
    direct: &[Rgb],
    p: &RadiosityParams,
) -> (RadiosityState, Tracer, daystep::radiosity::SolveReport) {
    let tracer = Tracer::new(scene);
    let mut st = RadiosityState::new(scene, Hierarchy::new(scene), direct);
    let r = solve(&mut st, &tracer, p);
    (st, tracer, r)
}

fn furnace_case(rho: f64, p: &RadiosityParams, tol: f64) {
    let m = 1.0;
    let scene = furnace(2.0, rho, m);
    let (st, tracer, rep) = cold(&scene, &[], p);
    let exact = PI * m / (1.0 - rho);
    let (mean, _) = st.area_mean(|i| st.radiosity(i));
    // Sensor near the centre, tilted: it reads E = B.
    let c = scene.triangles.iter().map(|t| t.centroid()).sum::<DVec3>() / 12.0;
    let g = gather_sensor(
        &st,
        &tracer,
        c + DVec3::new(0.1, -0.2, 0.05),
        DVec3::new(0.3, 0.2, 0.9),
        40_000,
        7,
    );
    let e = g.irradiance.x;
    let err = (e - exact).abs() / exact;
    eprintln!(
        "furnace rho {rho}: stop {:?} lines {} batches {} iters {} {:.2}s leaves {} est_err {:.4} | area-mean B {:.5} sensor E {:.5} ± {:.5} exact {:.5} rel err {:.5}",
        rep.stop, rep.lines, rep.batches, rep.iterations, rep.seconds, rep.leaves, rep.estimated_error,
        mean.x, e, g.std_err.x, exact, err
    );
    assert!(err <= tol, "sensor error {err} > {tol}");
    assert!(
        (mean.x - exact).abs() / exact <= tol,
        "area mean {} vs {exact}",
        mean.x
    );
    // The stated 1σ error covers the true one at 3σ.
    assert!(
        (e - exact).abs() <= 3.0 * g.std_err.x + 1e-9 * exact,
        "stated {} does not cover {}",
        g.std_err.x,
        (e - exact).abs()
    );
    // Per-leaf errors are covered by their stated σ: with M batches the normalised error
    // follows Student's t with M − 1 degrees of freedom (P(|t₇| > 3) ≈ 2 %), so allow
    // 6 % of the leaves beyond 3σ and none beyond 8σ.
    let (mut out, mut n) = (0, 0);
    for i in st.hierarchy().leaves() {
        let (b, s) = (st.radiosity(i).x, st.radiosity_std_err(i).x);
        n += 1;
        out += usize::from((b - exact).abs() > 3.0 * s + 1e-9 * exact);
        assert!(
            (b - exact).abs() <= 8.0 * s + 1e-9 * exact,
            "leaf {i}: {b} ± {s} vs {exact}"
        );
    }
    eprintln!("  leaves beyond 3σ: {out} of {n}");
    assert!(
        out as f64 <= 0.06 * n as f64,
        "{out} of {n} leaves beyond 3σ"
    );
}

#[test]
fn furnace_rho_05_and_09() {
    let p = RadiosityParams {
        target_rel_error: 0.01,
        a_min: 0.1,
        ..Default::default()
    };
    furnace_case(0.5, &p, 0.005);
    furnace_case(0.9, &p, 0.005);
}

#[test]
fn furnace_rho_099_with_bounded_budget() {
    let p = RadiosityParams {
        target_rel_error: 0.001, // not reachable within the budget: the budget stops it
        max_lines: 4_000_000,
        lines_per_step: 3_000,
        min_lines_per_step: 64,
        a_min: 0.1,
        ..Default::default()
    };
    furnace_case(0.99, &p, 0.02);
}

#[test]
fn budget_stop_is_reported_and_bounded() {
    let p = RadiosityParams {
        target_rel_error: 1e-6,
        max_lines: 300_000,
        lines_per_step: 3_000,
        ..Default::default()
    };
    let scene = furnace(2.0, 0.99, 1.0);
    let (_, _, rep) = cold(&scene, &[], &p);
    assert_eq!(rep.stop, Some(StopReason::LineBudget));
    assert!(rep.lines <= p.max_lines, "{} lines", rep.lines);
    assert!(rep.estimated_error > 1e-6);
}

#[test]
fn configuration_factor_of_an_emitting_square() {
    // Unit square at height 1 facing down, one corner above the sensor; nothing reflects.
    let m = 2.0;
    let mut b = Builder::new();
    let lamp = b.material("lamp", 0.0, 0.0);
    b.input.materials[lamp as usize].ke = Rgb::splat(m);
    b.hrect(0.0, 1.0, 0.0, 1.0, 1.0, false, lamp);
    let scene = b.build();
    let (st, tracer, rep) = cold(&scene, &[], &RadiosityParams::default());
    let f = f_parallel(1.0, 1.0, 1.0);
    assert!((f - 0.138532).abs() < 1e-6);
    let exact = PI * m * f;
    let g = gather_sensor(&st, &tracer, -scene.origin, DVec3::Z, 200_000, 3);
    let err = (g.irradiance.x - exact).abs();
    eprintln!(
        "configuration factor: E {:.5} ± {:.5} exact {exact:.5} rel err {:.5}; energy {:?}",
        g.irradiance.x,
        g.std_err.x,
        err / exact,
        rep.energy
    );
    assert!(err <= 0.01 * exact && err <= 3.0 * g.std_err.x);
    // Everything emitted escapes.
    assert!((rep.energy.escaped.x - rep.energy.emitted.x).abs() <= 1e-9 * rep.energy.emitted.x);
}

/// Closed 4 × 4 × 4 m room (CIE 171 TC 5.8 case 5.8 geometry): floor, walls, ceiling.
fn room(floor: f64, walls: f64, ceiling: f64) -> Scene {
    let mut b = Builder::new();
    let (mf, mw, mc) = (
        b.material("floor", floor, 0.0),
        b.material("walls", walls, 0.0),
        b.material("ceiling", ceiling, 0.0),
    );
    b.hrect(0.0, 4.0, 0.0, 4.0, 0.0, true, mf); // triangles 0, 1
    b.hrect(0.0, 4.0, 0.0, 4.0, 4.0, false, mc);
    b.walls_inward(0.0, 4.0, 0.0, 4.0, 0.0, 4.0, mw);
    b.build()
}

/// Direct irradiance `e` on the floor only.
fn floor_direct(scene: &Scene, e: f64) -> Vec<Rgb> {
    (0..scene.triangles.len())
        .map(|i| if i < 2 { Rgb::splat(e) } else { Rgb::ZERO })
        .collect()
}

#[test]
fn closed_room_matches_sumpner() {
    // ρ̄ = (16·0.5 + 64·0.4 + 16·0.9)/96 = 0.5, floor reflectance = ρ̄ so both forms of
    // the formula agree: E_ir = Φ ρ̄ /(S_T (1 − ρ̄)).
    let scene = room(0.5, 0.4, 0.9);
    let ed = 100.0;
    let phi = ed * 16.0;
    let rho_bar: f64 = (16.0 * 0.5 + 64.0 * 0.4 + 16.0 * 0.9) / 96.0;
    assert!((rho_bar - 0.5).abs() < 1e-12);
    let sumpner = phi * rho_bar / (96.0 * (1.0 - rho_bar));
    let p = RadiosityParams {
        target_rel_error: 0.03,
        ..Default::default()
    };
    let (st, _, rep) = cold(&scene, &floor_direct(&scene, ed), &p);
    let (mean, area) = st.area_mean(|i| st.indirect_irradiance(i));
    let rel = (mean.x - sumpner).abs() / sumpner;
    eprintln!(
        "Sumpner room: area {area:.1} mean E_ir {:.4} Sumpner {sumpner:.4} rel diff {rel:.4}; {} lines {} batches {:.2}s leaves {} est {:.4}",
        mean.x, rep.lines, rep.batches, rep.seconds, rep.leaves, rep.estimated_error
    );
    assert!((area - 96.0).abs() < 1e-9);
    assert!(rel < 0.03, "room-average E_ir off Sumpner by {rel}");
}

#[test]
fn uniform_closed_room_is_exact_and_warm_start_follows_a_change() {
    // Uniform ρ in a closed room: energy conservation makes Sumpner exact,
    // mean E_ir = ρΦ/(S_T(1 − ρ)).
    let rho = 0.6;
    let scene = room(rho, rho, rho);
    let exact = |ed: f64| rho * ed * 16.0 / (96.0 * (1.0 - rho));
    let p = RadiosityParams {
        target_rel_error: 0.03,
        ..Default::default()
    };
    let (st, tracer, rep) = cold(&scene, &floor_direct(&scene, 100.0), &p);
    let (m1, _) = st.area_mean(|i| st.indirect_irradiance(i));
    assert!(
        (m1.x - exact(100.0)).abs() <= 1e-3 * exact(100.0),
        "{} vs {}",
        m1.x,
        exact(100.0)
    );
    // Next "hour": 20 % more light on the floor. Warm start shoots only the change.
    let h = Hierarchy::new(&scene);
    let (st2, rep2) = warm_start(&st, &tracer, &h, &floor_direct(&scene, 120.0), &p);
    let (m2, _) = st2.area_mean(|i| st2.indirect_irradiance(i));
    eprintln!(
        "warm start: cold {} lines, warm {} lines (warm = {}), mean E_ir {:.4} exact {:.4}",
        rep.lines,
        rep2.lines,
        rep2.warm,
        m2.x,
        exact(120.0)
    );
    assert!(rep2.warm);
    assert!(rep2.lines < rep.lines);
    assert!((m2.x - exact(120.0)).abs() <= 1e-3 * exact(120.0));
    // A point sensor agrees within its stated error, and σ grew less than a cold solve's.
    let g = gather_sensor(
        &st2,
        &tracer,
        DVec3::new(0.3, -0.2, 0.5),
        DVec3::Z,
        20_000,
        1,
    );
    let g_cold = {
        let mut c =
            RadiosityState::new(&scene, Hierarchy::new(&scene), &floor_direct(&scene, 120.0));
        solve(&mut c, &tracer, &p);
        gather_sensor(&c, &tracer, DVec3::new(0.3, -0.2, 0.5), DVec3::Z, 20_000, 1)
    };
    let d = (g.irradiance.x - g_cold.irradiance.x).abs();
    eprintln!(
        "  sensor warm {:.4} ± {:.4}, cold {:.4} ± {:.4}",
        g.irradiance.x, g.std_err.x, g_cold.irradiance.x, g_cold.std_err.x
    );
    assert!(d <= 3.0 * (g.std_err.x.powi(2) + g_cold.std_err.x.powi(2)).sqrt());
    // Drift guard: with reanchor_every = 0 the warm start re-solves cold.
    let p0 = RadiosityParams {
        reanchor_every: 0,
        ..p
    };
    let (_, rep3) = warm_start(&st, &tracer, &h, &floor_direct(&scene, 120.0), &p0);
    assert!(!rep3.warm);
}

/// An open, coloured, glazed scene with an emitter: a room whose roof is half glazing and
/// half missing.
fn open_scene() -> Scene {
    let mut b = Builder::new();
    let floor = b.material("floor", 0.5, 0.0);
    b.input.materials[floor as usize].kd = Rgb::new(0.7, 0.5, 0.2);
    let walls = b.material("walls", 0.8, 0.0);
    let glass = b.material("glass", 0.0, 0.8);
    let lamp = b.material("lamp", 0.3, 0.0);
    b.input.materials[lamp as usize].ke = Rgb::new(5.0, 4.0, 3.0);
    b.hrect(0.0, 3.0, 0.0, 3.0, 0.0, true, floor);
    b.walls_inward(0.0, 3.0, 0.0, 3.0, 0.0, 2.5, walls);
    b.hrect(0.0, 1.5, 0.0, 3.0, 2.5, false, glass);
    b.hrect(1.0, 2.0, 1.0, 2.0, 2.0, false, lamp); // a panel below the roof, facing down
    b.build()
}

#[test]
fn energy_balance_within_noise() {
    let scene = open_scene();
    let direct: Vec<Rgb> = (0..scene.triangles.len())
        .map(|i| {
            if i < 2 {
                Rgb::new(200.0, 180.0, 150.0)
            } else {
                Rgb::ZERO
            }
        })
        .collect();
    let (_, _, rep) = cold(
        &scene,
        &direct,
        &RadiosityParams {
            target_rel_error: 0.05,
            ..Default::default()
        },
    );
    let e = rep.energy;
    let input = e.daylight_in + e.emitted;
    eprintln!("energy: {e:?}");
    assert!(e.escaped.min_element() > 0.0 && e.absorbed.min_element() > 0.0);
    for c in 0..3 {
        assert!(
            e.residual[c].abs() <= 4.0 * e.residual_std_err[c] + 1e-9 * input[c],
            "channel {c}: residual {} ± {}",
            e.residual[c],
            e.residual_std_err[c]
        );
        // And small: the noise of the balance is a small fraction of the input.
        assert!(e.residual_std_err[c] <= 0.01 * input[c]);
    }
}

#[test]
fn bit_identical_for_one_and_two_threads() {
    let scene = open_scene();
    let direct: Vec<Rgb> = (0..scene.triangles.len())
        .map(|i| if i < 2 { Rgb::splat(100.0) } else { Rgb::ZERO })
        .collect();
    let p = RadiosityParams {
        max_lines: 400_000,
        target_rel_error: 0.0,
        ..Default::default()
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (st, tracer, rep) = cold(&scene, &direct, &p);
            let b: Vec<[u64; 3]> = (0..st.hierarchy().elements.len() as u32)
                .map(|i| st.radiosity(i).to_array().map(f64::to_bits))
                .collect();
            let g = gather_sensor(&st, &tracer, DVec3::new(0.1, 0.2, -0.3), DVec3::Z, 5_000, 9);
            (
                b,
                rep.lines,
                rep.leaves,
                g.irradiance.to_array().map(f64::to_bits),
            )
        })
    };
    let (a, b) = (run(1), run(2));
    assert!(a.1 > 0 && a.2 > scene.triangles.len());
    assert_eq!(a, b);
}
