//! The adjoint daylight coefficients against the forward solve: each sensor's response, the
//! grey operator's one channel, the sensor blocking and the batched apply bit-identical.

use super::{floor_light, furnace, small};
use crate::util::*;
use daystep::photometry::Rgb;
use daystep::radiosity::Transport;
use glam::DVec3;
use std::f64::consts::PI;

#[test]
fn adjoint_responses_equal_the_forward_solve() {
    // The furnace through the adjoint alone: the emitters' response is M/(1 − ρ) exactly.
    let scene = furnace(2.0, 0.9, 1.0);
    let t = Transport::build(&scene, &scene.sensors, &small());
    let r = t.response(u64::MAX).expect("small enough");
    let e = r.sensors_of(&r.start())[0];
    let exact = PI / (1.0 - 0.9);
    let err = (e.irradiance.x - exact).abs() / exact;
    eprintln!(
        "adjoint furnace ρ 0.9: {:.5} exact {exact:.5} rel {err:.1e}",
        e.irradiance.x
    );
    assert!(err <= 10.0 * t.params.tolerance, "{err}");

    // A coloured room lit on the floor: same sensors (value, noise and discretisation
    // estimates) as the forward solve, channel by channel, within the iteration tolerance.
    let mut b = Builder::new();
    let m = b.material("all", 0.6, 0.0);
    b.input.materials[m as usize].kd = Rgb::new(0.7, 0.5, 0.2);
    b.hrect(0.0, 4.0, 0.0, 4.0, 0.0, true, m);
    b.hrect(0.0, 4.0, 0.0, 4.0, 4.0, false, m);
    b.walls_inward(0.0, 4.0, 0.0, 4.0, 0.0, 4.0, m);
    b.sensor(DVec3::new(2.3, 1.8, 0.5), DVec3::Z);
    b.sensor(DVec3::new(0.4, 3.1, 2.5), DVec3::X);
    let scene = b.build();
    let t = Transport::build(&scene, &scene.sensors, &small());
    let light = floor_light(&t, 100.0);
    let (st, _) = t.solve(&light, None);
    let forward = t.sensors(&st);
    let r = t.response(u64::MAX).unwrap();
    let weights: Vec<(u32, Rgb)> = light
        .iter()
        .enumerate()
        .map(|(i, v)| (i as u32, *v / 100.0))
        .collect();
    let d = r.direction(&t, &weights);
    let mut acc = r.start();
    r.add(&mut acc, Rgb::splat(100.0), &d);
    let adjoint = r.sensors_of(&acc);
    assert_eq!(forward.len(), 2);
    for (a, f) in adjoint.iter().zip(&forward) {
        for c in 0..3 {
            let rel = |x: f64, y: f64| (x - y).abs() / f.irradiance[c];
            eprintln!(
                "  channel {c}: forward {:.4} adjoint {:.4} σ {:.4}/{:.4} disc {:.4}/{:.4}",
                f.irradiance[c],
                a.irradiance[c],
                f.std_err[c],
                a.std_err[c],
                f.discretisation[c],
                a.discretisation[c]
            );
            assert!(rel(a.irradiance[c], f.irradiance[c]) <= 4.0 * t.params.tolerance);
            assert!(rel(a.std_err[c], f.std_err[c]) <= 8.0 * t.params.tolerance);
            assert!(rel(a.discretisation[c], f.discretisation[c]) <= 8.0 * t.params.tolerance);
        }
    }
    // A budget below what the responses need: declined, the caller keeps the forward solve.
    assert!(t.response(1000).is_none());
}

#[test]
fn grey_daylight_coefficients_solve_one_channel_and_equal_the_forward_solve() {
    // The same room grey and coloured: the grey operator's adjoint keeps one channel (a
    // third of the bytes), and both give the forward solve's illuminance within the
    // iteration tolerance, whatever the sensor blocking.
    let room = |kd: Rgb| {
        let mut b = Builder::new();
        let m = b.material("all", 0.6, 0.0);
        b.input.materials[m as usize].kd = kd;
        b.hrect(0.0, 4.0, 0.0, 4.0, 0.0, true, m);
        b.hrect(0.0, 4.0, 0.0, 4.0, 4.0, false, m);
        b.walls_inward(0.0, 4.0, 0.0, 4.0, 0.0, 4.0, m);
        for i in 0..40 {
            let f = i as f64 / 40.0;
            b.sensor(DVec3::new(0.3 + 3.4 * f, 0.5 + 3.0 * f * f, 0.8), DVec3::Z);
        }
        b.build()
    };
    let grey = room(Rgb::splat(0.6));
    let coloured = room(Rgb::new(0.7, 0.5, 0.2));
    let tg = Transport::build(&grey, &grey.sensors, &small());
    let tc = Transport::build(&coloured, &coloured.sensors, &small());
    assert!(tg.is_grey());
    assert!(!tc.is_grey());
    assert_eq!(tg.rows(), tc.rows());
    assert_eq!(
        3 * tg.adjoint_bytes_per_sensor(),
        tc.adjoint_bytes_per_sensor()
    );
    for (t, name) in [(&tg, "grey"), (&tc, "coloured")] {
        let light = floor_light(t, 100.0);
        let (st, _) = t.solve(&light, None);
        let forward = t.sensors(&st);
        let weights: Vec<(u32, Rgb)> = light
            .iter()
            .enumerate()
            .map(|(i, v)| (i as u32, *v / 100.0))
            .collect();
        let k = forward.len();
        let whole = t.adjoint_block(0..k).apply(t, &weights);
        // Blocks of 32 and the rest: bit-identical values.
        let (a, b) = (t.adjoint_block(0..32), t.adjoint_block(32..k));
        let (va, vb) = (a.apply(t, &weights), b.apply(t, &weights));
        let parts = whole.len() / k - 1;
        for row in 0..=parts {
            for s in 0..k {
                let split = if s < 32 {
                    va[row * 32 + s]
                } else {
                    vb[row * (k - 32) + s - 32]
                };
                assert_eq!(
                    whole[row * k + s].to_bits(),
                    split.to_bits(),
                    "{name} {row} {s}"
                );
            }
        }
        // Many directions at once: each one's bytes as alone (here the floor's light and
        // the same light on half the floor).
        let half: Vec<(u32, Rgb)> = weights.iter().step_by(2).copied().collect();
        let terms = [t.direction_terms(&half), t.direction_terms(&weights)];
        let block = t.adjoint_block(0..k);
        let many = block.apply_many(t, &terms);
        assert_eq!(many[1], whole, "{name}");
        assert_eq!(many[0], block.apply(t, &half), "{name}");
        assert_ne!(many[0], many[1], "{name}");
        for (s, f) in forward.iter().enumerate() {
            let adj =
                100.0 * (0..parts).map(|p| whole[p * k + s] as f64).sum::<f64>() / parts as f64;
            let fwd = daystep::photometry::lux(f.irradiance);
            // The solves' tolerance, and the held responses' rounding (bfloat16).
            let rel =
                4.0 * t.params.tolerance + daystep::radiosity::coefficients::RESPONSE_ROUNDOFF;
            assert!(
                (adj - fwd).abs() <= rel * fwd + 1e-6,
                "{name} sensor {s}: adjoint {adj} forward {fwd}"
            );
            // The coarse level (its responses averaged over parts before they are held)
            // against the forward solve's: through |fine − coarse|, which for a grey room
            // is the same in lux as per channel.
            if name == "grey" {
                let coarse = 100.0 * whole[parts * k + s] as f64;
                let (da, df) = (
                    (adj - coarse).abs(),
                    daystep::photometry::lux(f.discretisation),
                );
                assert!(
                    (da - df).abs() <= rel * (fwd + coarse) + 1e-6,
                    "{name} sensor {s}: coarse adjoint {coarse}, |fine − coarse| {da} vs forward {df}"
                );
            }
        }
    }
}
