//! Metrics against values worked out by hand in the comments.

use super::*;
use chrono::NaiveDateTime;

fn t(s: &str) -> NaiveDateTime {
    NaiveDateTime::parse_from_str(s, "%Y-%m-%dT%H:%M:%S").unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

#[track_caller]
fn assert_metrics(got: &SensorMetrics, want: [f64; 8]) {
    let g = [
        got.da,
        got.cda,
        got.udi_below,
        got.udi_within,
        got.udi_above,
        got.ase_hours,
        got.mean_lux,
        got.occupied_hours,
    ];
    assert!(
        g.iter().zip(&want).all(|(a, b)| close(*a, *b)),
        "got  {g:?}\nwant {want:?}"
    );
}

#[test]
fn occupancy_by_step_start() {
    let p = MetricParams::default();
    // Hourly steps evaluated mid-hour: the step at 7:30 starts at 7:00 (out), 8:30 → 8:00
    // (in), 17:30 → 17:00 (in: the end hour is inclusive), 18:30 → 18:00 (out).
    let hourly: Vec<bool> = ["07:30", "08:30", "12:30", "17:30", "18:30", "00:30"]
        .iter()
        .map(|h| is_occupied(t(&format!("2021-03-01T{h}:00")), 60, &p))
        .collect();
    assert_eq!(hourly, [false, true, true, true, false, false]);
    // 15-minute steps: 7:52:30 starts 7:45 (out), 8:07:30 starts 8:00 (in), 17:52:30 starts
    // 17:45 (in), 18:07:30 starts 18:00 (out).
    let quarter: Vec<bool> = ["07:52:30", "08:07:30", "17:52:30", "18:07:30"]
        .iter()
        .map(|h| is_occupied(t(&format!("2021-03-01T{h}")), 15, &p))
        .collect();
    assert_eq!(quarter, [false, true, true, false]);
    // A whole day of hourly steps: 8, 9, …, 17 → 10 occupied hours.
    let day = (0..24)
        .filter(|h| is_occupied(t("2021-03-01T00:30:00") + TimeDelta::hours(*h), 60, &p))
        .count();
    assert_eq!(day, 10);
}

/// One day, 24 hourly steps (00:30 … 23:30), three sensors.
///
/// Occupied: steps 8 … 17 (10 steps). Sun up: steps 5 … 16, so step 17 (17:30) is occupied
/// with the sun down and step 7 (7:30) is sun-up but unoccupied.
///
/// Sensor A, total lux at steps 8 … 16: 300, 299.9, 100, 99.9, 3000, 3000.1, 0, 600, 150;
/// 5000 at step 7 (unoccupied: ignored) and 500 at step 17 (sun down: counts as dark).
/// - DA (E ≥ 300): 300, 3000, 3000.1, 600 → 4 / 10 = 40 %  (exactly 300 counts).
/// - cDA: 1 + 299.9/300 + 100/300 + 99.9/300 + 1 + 1 + 0 + 1 + 150/300
///   = 4.5 + 499.8/300 → (4.5 + 1.666) / 10 = 61.66 %.
/// - UDI within (100 ≤ E ≤ 3000): 300, 299.9, 100, 3000, 600, 150 → 60 % (100 and 3000 in).
/// - UDI below: 99.9, 0 + the sun-down step 17 → 3 → 30 %.
/// - UDI above (> 3000): 3000.1 → 10 %.
/// - mean lux: (300 + 299.9 + 100 + 99.9 + 3000 + 3000.1 + 0 + 600 + 150 + 0) / 10 = 754.99.
/// - direct: 1000 at step 8 (not > 1000), 1000.1 at step 9 (counts), 5000 at steps 7
///   (unoccupied) and 17 (sun down) → ASE 1 h.
///
/// Sensor B: 500 lx at steps 8 … 12, 50 lx at 13 … 16.
/// - DA 5/10 = 50 % (exactly the sDA threshold: passes); cDA (5 + 4·50/300)/10 = 56.66 %;
///   within 50 %; below 4 + 1 dark = 50 %; above 0; mean (5·500 + 4·50)/10 = 270.
///
/// Sensor C: 10 000 lx at steps 8 … 16, direct 2000.
/// - DA 9/10 = 90 %, cDA 90 %, within 0, below 10 % (the dark step), above 90 %,
///   ASE 9 h, mean 90 000 / 10 = 9000.
fn one_day() -> (Vec<[Vec<f64>; 2]>, Vec<bool>, Vec<bool>) {
    let p = MetricParams::default();
    let times: Vec<NaiveDateTime> = (0..24)
        .map(|h| t("2021-06-21T00:30:00") + TimeDelta::hours(h))
        .collect();
    let occupied: Vec<bool> = times.iter().map(|&t| is_occupied(t, 60, &p)).collect();
    let sun_up: Vec<bool> = (0..24).map(|h| (5..=16).contains(&h)).collect();

    let mut a = vec![0.0; 24];
    a[7] = 5000.0;
    a[8..=16].copy_from_slice(&[300.0, 299.9, 100.0, 99.9, 3000.0, 3000.1, 0.0, 600.0, 150.0]);
    a[17] = 500.0;
    let mut a_dir = vec![0.0; 24];
    (a_dir[7], a_dir[8], a_dir[9], a_dir[17]) = (5000.0, 1000.0, 1000.1, 5000.0);

    let mut b = vec![0.0; 24];
    b[8..=12].fill(500.0);
    b[13..=16].fill(50.0);

    let mut c = vec![0.0; 24];
    c[8..=16].fill(10_000.0);
    let mut c_dir = vec![0.0; 24];
    c_dir[8..=16].fill(2000.0);

    (
        vec![[a, a_dir], [b, vec![0.0; 24]], [c, c_dir]],
        occupied,
        sun_up,
    )
}

fn one_day_metrics() -> Vec<SensorMetrics> {
    let p = MetricParams::default();
    let (sensors, occupied, sun_up) = one_day();
    sensors
        .iter()
        .map(|[total, direct]| sensor_metrics(total, direct, &occupied, &sun_up, 1.0, &p))
        .collect()
}

#[test]
fn one_day_by_hand() {
    let m = one_day_metrics();
    // [da, cda, below, within, above, ase h, mean lux, occupied h]
    let cda_a = 100.0 * (4.5 + 499.8 / 300.0) / 10.0;
    assert_metrics(&m[0], [40.0, cda_a, 30.0, 60.0, 10.0, 1.0, 754.99, 10.0]);
    let cda_b = 100.0 * (5.0 + 4.0 * 50.0 / 300.0) / 10.0;
    assert_metrics(&m[1], [50.0, cda_b, 50.0, 50.0, 0.0, 0.0, 270.0, 10.0]);
    assert_metrics(&m[2], [90.0, 90.0, 10.0, 0.0, 90.0, 9.0, 9000.0, 10.0]);
    for s in &m {
        assert!(close(s.udi_below + s.udi_within + s.udi_above, 100.0));
    }
}

#[test]
fn summary_of_one_day() {
    let m = one_day_metrics();
    let p = MetricParams::default();
    // A fails sDA (40 %), B passes at exactly 50 %, C passes: 2 of 3.
    let s = summary(&m, None, &p).unwrap();
    assert!(close(s.sda_percent, 200.0 / 3.0), "{s:?}");
    assert_eq!(s.ase_percent, 0.0); // 1 h and 9 h are far below 250 h
    assert!(close(s.mean_da, (40.0 + 50.0 + 90.0) / 3.0));
    assert!(close(s.mean_udi_within, (60.0 + 50.0 + 0.0) / 3.0));
    assert!(close(s.mean_lux, (754.99 + 270.0 + 9000.0) / 3.0));
    assert_eq!(
        (s.sensors, s.occupied_hours, s.area_weighted),
        (3, 10.0, false)
    );

    // Weights 1, 2, 1: the passing area is 2 + 1 of 4 → 75 %; mean DA (40 + 2·50 + 90)/4.
    let s = summary(&m, Some(&[1.0, 2.0, 1.0]), &p).unwrap();
    assert!(close(s.sda_percent, 75.0));
    assert!(close(s.mean_da, 57.5));
    assert!(s.area_weighted);

    assert!(matches!(
        summary(&m, Some(&[1.0, -2.0, 1.0]), &p),
        Err(Error::Input { .. })
    ));
    assert!(matches!(
        summary(&m, Some(&[1.0]), &p),
        Err(Error::Internal(_))
    ));
    assert_eq!(summary(&[], None, &p).unwrap().sda_percent, 0.0);
}

/// 25 days × 24 hourly steps, every occupied step sun-up: 25 × 10 = 250 occupied hours.
/// - S250: direct 1500 lx at every occupied step → 250 h ≥ 250 → fails ASE.
/// - S249: the same with one step at exactly 1000 lx (not > 1000) → 249 h → passes.
/// - S0: exactly 1000 lx at every step → 0 h.
///
/// ASE = 1 failing sensor of 3 = 33.3 %.
#[test]
fn ase_edges_over_250_hours() {
    let p = MetricParams::default();
    let n = 25 * 24;
    let times: Vec<NaiveDateTime> = (0..n)
        .map(|h| t("2021-01-01T00:30:00") + TimeDelta::hours(h as i64))
        .collect();
    let occupied: Vec<bool> = times.iter().map(|&t| is_occupied(t, 60, &p)).collect();
    let sun_up = occupied.clone();
    let total = vec![500.0; n];
    let s250: Vec<f64> = occupied
        .iter()
        .map(|&o| if o { 1500.0 } else { 0.0 })
        .collect();
    let mut s249 = s250.clone();
    let first = occupied.iter().position(|&o| o).unwrap();
    s249[first] = 1000.0;
    let s0 = vec![1000.0; n];

    let m: Vec<SensorMetrics> = [&s250, &s249, &s0]
        .iter()
        .map(|d| sensor_metrics(&total, d, &occupied, &sun_up, 1.0, &p))
        .collect();
    assert_eq!(m[0].occupied_hours, 250.0);
    assert_eq!(
        [m[0].ase_hours, m[1].ase_hours, m[2].ase_hours],
        [250.0, 249.0, 0.0]
    );
    let s = summary(&m, None, &p).unwrap();
    assert!(close(s.ase_percent, 100.0 / 3.0), "{s:?}");

    // Half-hour steps count half an hour each: 250 steps → 125 h, which passes.
    let half = sensor_metrics(&total, &s250, &occupied, &sun_up, 0.5, &p);
    assert_eq!((half.ase_hours, half.occupied_hours), (125.0, 125.0));
}

#[test]
fn sda_fraction_compares_without_rounding_loss() {
    // 11 of 20 occupied hours → DA 55 %; with sda_da_fraction 0.55 the sensor must pass,
    // although 100 × 0.55 = 55.000000000000007 in floating point.
    let p = MetricParams {
        sda_da_fraction: 0.55,
        ..MetricParams::default()
    };
    let total: Vec<f64> = (0..20).map(|i| if i < 11 { 400.0 } else { 10.0 }).collect();
    let yes = vec![true; 20];
    let m = sensor_metrics(&total, &[0.0; 20], &yes, &yes, 1.0, &p);
    assert_eq!(m.da, 55.0);
    assert_eq!(summary(&[m], None, &p).unwrap().sda_percent, 100.0);
}

#[test]
fn no_occupied_hours_gives_zeros() {
    let m = sensor_metrics(
        &[500.0],
        &[0.0],
        &[false],
        &[true],
        1.0,
        &MetricParams::default(),
    );
    assert_metrics(&m, [0.0; 8]);
}

#[test]
fn daylight_factor_percent() {
    // 200 lx inside under 10 000 lx outside → 2 %.
    assert_eq!(daylight_factor(200.0, 10_000.0), 2.0);
    assert!(daylight_factor(200.0, 0.0).is_nan());
}

#[test]
fn params_defaults_serde_and_validation() {
    let d = MetricParams::default();
    assert_eq!(
        (
            d.occupancy_start_hour,
            d.occupancy_end_hour,
            d.da_threshold_lux
        ),
        (8, 17, 300.0)
    );
    let back: MetricParams = serde_json::from_str(&serde_json::to_string(&d).unwrap()).unwrap();
    assert_eq!(back, d);
    // Fields left out keep their defaults; unknown fields are refused (typos).
    let p: MetricParams = serde_json::from_str(r#"{"da_threshold_lux": 500}"#).unwrap();
    assert_eq!((p.da_threshold_lux, p.udi_max_lux), (500.0, 3000.0));
    assert!(serde_json::from_str::<MetricParams>(r#"{"da_treshold_lux": 500}"#).is_err());
    assert!(d.validate().is_ok());
    let bad = MetricParams {
        occupancy_start_hour: 18,
        ..d.clone()
    };
    assert!(matches!(bad.validate(), Err(Error::Input { .. })));
    let bad = MetricParams {
        udi_min_lux: 4000.0,
        ..d
    };
    assert!(matches!(bad.validate(), Err(Error::Input { .. })));
}
