//! EN 17037 daylight provision against values worked out by hand in the comments.

use super::*;

#[test]
fn levels_on_a_graded_room() {
    // 20 sensors, 2200 sun-up steps all in the daylight hours (≥ 2190 = half of 4380).
    // Sensor s holds 100·(s+1) lux throughout: it meets E_T when 100·(s+1) ≥ E_T.
    // minimum: target 300 → s ≥ 2: 18/20 = 90 % ✓ (≥ 50); minimum 100 → 20/20 = 100 % ✓.
    // medium: target 500 → s ≥ 4: 80 % ✓; minimum 300 → 90 % ✗ (< 95).
    // high: target 750 → s ≥ 7 (800 lx): 13/20 = 65 % ✓; minimum 500 → 80 % ✗.
    let (n, steps) = (20, 2200);
    let total: Vec<f32> = (0..steps * n).map(|i| 100.0 * (i % n + 1) as f32).collect();
    let daylight = vec![true; steps];
    let g = En17037Grid {
        name: "room",
        sensors: n,
        areas: None,
        total: &total,
    };
    let r = en17037(&[g], &daylight, 4380).unwrap();
    let l = &r.grids[0].levels;
    let row = |l: &Level| {
        (
            l.target_lux,
            l.target_area_pct,
            l.target_pass,
            l.minimum_lux,
            l.minimum_area_pct,
            l.minimum_pass,
        )
    };
    assert_eq!(row(&l.minimum), (300.0, 90.0, true, 100.0, 100.0, true));
    assert_eq!(row(&l.medium), (500.0, 80.0, true, 300.0, 90.0, false));
    assert_eq!(row(&l.high), (750.0, 65.0, true, 500.0, 80.0, false));
    assert_eq!(
        r.levels, r.grids[0].levels,
        "one grid: the total is the grid"
    );
}

#[test]
fn half_the_daylight_hours_inclusive() {
    // One sensor at exactly 300 lx (≥ counts) for 2190 daylight steps: 2190/4380 = 50 % →
    // meets; for 2189 steps it does not. Steps outside the daylight hours never count.
    for (lit, pass) in [(2190usize, true), (2189, false)] {
        let steps = 2300;
        let total: Vec<f32> = (0..steps)
            .map(|t| if t < lit { 300.0 } else { 0.0 })
            .collect();
        let mut daylight = vec![true; steps];
        // a bright step outside the schedule
        let mut total = total;
        total.push(1e5);
        daylight.push(false);
        let g = En17037Grid {
            name: "r",
            sensors: 1,
            areas: None,
            total: &total,
        };
        let r = en17037(&[g], &daylight, 4380).unwrap();
        assert_eq!(r.levels.minimum.target_pass, pass);
        assert_eq!(
            r.levels.minimum.target_area_pct,
            if pass { 100.0 } else { 0.0 }
        );
    }
}

#[test]
fn grids_combine_by_count_or_area() {
    // A: 1 sensor always 1000 lx (meets all); B: 3 sensors always 0 lx.
    // By count: target 300 share = (100·1 + 0·3) / 4 = 25 %. With areas A 3 m², B 1 m²:
    // (100·3 + 0·1) / 4 = 75 % → passes.
    let a = vec![1000.0f32; 2190];
    let b = vec![0.0f32; 2190 * 3];
    let d = vec![true; 2190];
    let mut ga = En17037Grid {
        name: "A",
        sensors: 1,
        areas: None,
        total: &a,
    };
    let mut gb = En17037Grid {
        name: "B",
        sensors: 3,
        areas: None,
        total: &b,
    };
    let r = en17037(&[ga, gb], &d, 4380).unwrap();
    assert_eq!(r.levels.minimum.target_area_pct, 25.0);
    assert!(!r.levels.minimum.target_pass);
    ga.areas = Some(&[3.0]);
    gb.areas = Some(&[0.5, 0.25, 0.25]);
    let r = en17037(&[ga, gb], &d, 4380).unwrap();
    assert!(r.area_weighted);
    assert_eq!(r.levels.minimum.target_area_pct, 75.0);
    assert!(r.levels.minimum.target_pass);
}

#[test]
fn daylight_hours_top_half_ties_earlier() {
    // Even hours bright, odd dark: exactly the 4380 even hours.
    let v: Vec<f64> = (0..8760)
        .map(|h| if h % 2 == 0 { 5000.0 } else { 0.0 })
        .collect();
    let f = daylight_hours(&v).unwrap();
    assert!(f.iter().enumerate().all(|(h, d)| *d == (h % 2 == 0)));
    // All equal: a stable sort keeps hour order, so the first 4380 hours.
    let f = daylight_hours(&vec![1.0; 8760]).unwrap();
    assert!(f[..4380].iter().all(|d| *d) && !f[4380..].iter().any(|d| *d));
    assert!(daylight_hours(&[1.0; 10]).is_err());
}

#[test]
fn refusals() {
    let t = [f32::NAN];
    let d = [true];
    let g = En17037Grid {
        name: "nanroom",
        sensors: 1,
        areas: None,
        total: &t,
    };
    let e = en17037(&[g], &d, 4380).unwrap_err().to_string();
    assert!(e.contains("nanroom") && e.contains("not a finite"), "{e}");
    let ok = [1.0f32];
    let g = En17037Grid {
        name: "r",
        sensors: 1,
        areas: None,
        total: &ok,
    };
    assert!(en17037(&[g], &d, 3650)
        .unwrap_err()
        .to_string()
        .contains("4380"));
    assert!(en17037(&[], &d, 4380).is_err());
    let g = En17037Grid {
        name: "none",
        sensors: 0,
        areas: None,
        total: &[],
    };
    assert!(en17037(&[g], &d, 4380)
        .unwrap_err()
        .to_string()
        .contains("none"));
    // No sun-up steps at all: nothing meets anything.
    let g = En17037Grid {
        name: "r",
        sensors: 1,
        areas: None,
        total: &[],
    };
    let r = en17037(&[g], &[], 4380).unwrap();
    assert_eq!(r.levels.high.minimum_area_pct, 0.0);
}

#[test]
fn json_keys_are_the_contracts() {
    let t = [0.0f32];
    let g = En17037Grid {
        name: "r",
        sensors: 1,
        areas: None,
        total: &t,
    };
    let v = serde_json::to_value(en17037(&[g], &[true], 4380).unwrap()).unwrap();
    for level in ["minimum", "medium", "high"] {
        for k in [
            "target_lux",
            "target_area_pct",
            "target_pass",
            "minimum_lux",
            "minimum_area_pct",
            "minimum_pass",
        ] {
            assert!(v[level].get(k).is_some(), "{level}.{k}");
            assert!(
                v["grids"][0][level].get(k).is_some(),
                "grids[0].{level}.{k}"
            );
        }
    }
}
