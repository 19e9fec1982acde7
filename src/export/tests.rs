//! Writers against literal expected text; readers and merge against hand-made series.

use super::*;
use crate::error::input_parts;
use chrono::TimeDelta;

#[test]
fn values_are_written_as_the_exactly_rounded_decimal() {
    // Against the general formatting: random magnitudes and signs, decimal ties (x.xxx5,
    // whose binary value falls either side), and the edges.
    let mut i = 0u64;
    let mut next = move || {
        i += 1;
        crate::math::rng::mix64(i)
    };
    let mut values = vec![
        0.0,
        -0.0,
        1e-9,
        -1e-9,
        0.0005,
        -0.0005,
        0.0015,
        2.5e-4,
        999_999.999_5,
        1e6,
        1e12,
        -3.4e7,
        123.4565,
        0.1,
        0.7,
    ];
    for _ in 0..200_000 {
        let m = (next() % 1_000_000_000) as f64;
        let scale = [1e-6, 1e-3, 1.0, 1e3][(next() % 4) as usize];
        // Every other value on a decimal tie at the fourth place.
        let tie = (next() % 2) as f64 * 5e-4;
        let v = m * scale / 1000.0 + tie;
        values.push(if next() % 3 == 0 { -v } else { v });
    }
    for v in values {
        let f = format!("{v:.3}");
        let want = if f == "-0.000" {
            "0.000".to_string()
        } else {
            f
        };
        assert_eq!(format_value(v), want, "{v:e}");
        let read: f64 = want.parse().unwrap();
        assert_eq!(
            written_value(v).to_bits(),
            read.to_bits(),
            "{v:e} read back"
        );
    }
}

fn t(s: &str) -> NaiveDateTime {
    NaiveDateTime::parse_from_str(s, TIME_FORMAT).unwrap()
}

/// Two steps, two sensors: 12.3456 rounds to 12.346, −0 is written 0.000.
fn two_rows() -> (Vec<NaiveDateTime>, Vec<Vec<f64>>) {
    (
        vec![t("2021-01-01T00:30:00"), t("2021-01-01T01:30:00")],
        vec![vec![0.0, 12.3456], vec![-0.0, 1000.0]],
    )
}

const TWO_ROWS_CSV: &str = "time,s0,s1\n\
    2021-01-01T00:30:00,0.000,12.346\n\
    2021-01-01T01:30:00,0.000,1000.000\n";

#[test]
fn illuminance_csv_text_is_fixed_format() {
    let (times, rows) = two_rows();
    assert_eq!(illuminance_csv_text(&times, &rows).unwrap(), TWO_ROWS_CSV);
    assert!(matches!(
        illuminance_csv_text(&times, &[vec![1.0, f64::NAN], vec![0.0, 0.0]]),
        Err(Error::Numerical(_))
    ));
    assert!(matches!(
        illuminance_csv_text(&times, &[vec![1.0, 2.0], vec![0.0]]),
        Err(Error::Internal(_))
    ));
    assert!(matches!(
        illuminance_csv_text(&times[..1], &rows),
        Err(Error::Internal(_))
    ));
}

#[test]
fn illuminance_csv_reads_back_and_names_bad_lines() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("illuminance.csv");
    let (times, rows) = two_rows();
    write_illuminance_csv(&p, &times, &rows).unwrap();
    let (got_times, got_rows) = read_illuminance_csv(&p).unwrap();
    assert_eq!(got_times, ["2021-01-01T00:30:00", "2021-01-01T01:30:00"]);
    assert_eq!(got_rows, [vec![0.0, 12.346], vec![0.0, 1000.0]]);
    // Row by row: the same times and values.
    let streamed = |p: &Path| -> crate::error::Result<(Vec<String>, Vec<Vec<f64>>)> {
        let mut r = IlluminanceRows::open(p)?;
        let (mut ts, mut rs, mut v) = (Vec::new(), Vec::new(), Vec::new());
        while let Some(t) = r.next_row(&mut v)? {
            ts.push(t);
            rs.push(v.clone());
        }
        Ok((ts, rs))
    };
    assert_eq!(streamed(&p).unwrap(), (got_times, got_rows));

    for (text, line, value) in [
        (
            "time,s0\n2021-01-01T00:30:00,1.0\n2021-01-01T01:30:00,abc\n",
            3,
            "abc",
        ),
        ("time,s0\n2021-01-01T00:30:00,NaN\n", 2, "NaN"),
        (
            "time,s0\n2021-01-01T00:30:00,1,2\n",
            2,
            "2021-01-01T00:30:00,1,2",
        ),
        ("time,s0\n2021-13-01T00:30:00,1\n", 2, "2021-13-01T00:30:00"),
        ("when,s0\n", 1, "when,s0"),
    ] {
        std::fs::write(&p, text).unwrap();
        for err in [
            read_illuminance_csv(&p).unwrap_err(),
            streamed(&p).unwrap_err(),
        ] {
            let (shown, path, got_line, got_value) = input_parts(err);
            assert_eq!(
                (path.as_path(), got_line, got_value.as_deref()),
                (p.as_path(), Some(line), Some(value)),
                "{shown}"
            );
        }
    }
}

#[test]
fn streaming_writer_resumes_after_a_cut_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out/illuminance.csv");
    let (mut times, mut rows) = two_rows();
    let mut w = IlluminanceWriter::create(&p, 2).unwrap();
    w.append(times[0], &rows[0]).unwrap();
    w.append(times[1], &rows[1]).unwrap();
    w.checkpoint().unwrap();
    drop(w);
    assert!(!p.exists(), "the output appears only when finished");
    // An interruption in the middle of the third row.
    let partial = IlluminanceWriter::partial_path(&p);
    assert_eq!(partial, dir.path().join("out/illuminance.csv.partial"));
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&partial)
        .unwrap();
    f.write_all(b"2021-01-01T02:30:00,5.0").unwrap();
    drop(f);

    // The wrong sensor count is refused, naming the partial file's header.
    let (_, path, line, _) = input_parts(IlluminanceWriter::resume(&p, 3).err().unwrap());
    assert_eq!((path, line), (partial.clone(), Some(1)));

    let (mut w, done) = IlluminanceWriter::resume(&p, 2).unwrap();
    assert_eq!(done, ["2021-01-01T00:30:00", "2021-01-01T01:30:00"]);
    times.push(t("2021-01-01T02:30:00"));
    rows.push(vec![5.0, 0.25]);
    w.append(times[2], &rows[2]).unwrap();
    assert!(matches!(
        w.append(times[2], &[1.0]),
        Err(Error::Internal(_))
    ));
    w.finish().unwrap();
    assert_eq!(
        std::fs::read_to_string(&p).unwrap(),
        format!("{TWO_ROWS_CSV}2021-01-01T02:30:00,5.000,0.250\n")
    );
    assert!(!partial.exists());
}

#[test]
fn ill_lines_are_month_day_decimal_hour() {
    let (mut times, rows) = two_rows();
    times[1] = t("2021-07-04T12:07:30"); // 12 + 7.5/60 = 12.125 h
    assert_eq!(
        ill_text(&times, &rows).unwrap(),
        "1 1 0.500 0.000 12.346\n7 4 12.125 0.000 1000.000\n"
    );
}

#[test]
fn metrics_csv_rows_per_sensor() {
    let m = SensorMetrics {
        da: 40.0,
        cda: 100.0 / 3.0,
        udi_below: 30.0,
        udi_within: 60.0,
        udi_above: 10.0,
        ase_hours: 1.0,
        mean_lux: 754.99,
        occupied_hours: 10.0,
    };
    assert_eq!(
        metrics_csv_text(&[m.clone(), m], None),
        "sensor,da,cda,udi_below,udi_within,udi_above,ase_hours,mean_lux\n\
         s0,40.000,33.333,30.000,60.000,10.000,1.000,754.990\n\
         s1,40.000,33.333,30.000,60.000,10.000,1.000,754.990\n"
    );
}

#[test]
fn summary_json_has_params_and_definitions() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("summary.json");
    let params = MetricParams {
        da_threshold_lux: 500.0,
        ..MetricParams::default()
    };
    let s = Summary {
        sda_percent: 75.0,
        ase_percent: 12.5,
        mean_da: 57.5,
        mean_cda: 60.0,
        mean_udi_below: 20.0,
        mean_udi_within: 50.0,
        mean_udi_above: 30.0,
        mean_ase_hours: 100.0,
        mean_lux: 800.0,
        sensors: 4,
        occupied_hours: 3650.0,
        area_weighted: false,
    };
    write_summary_json(&p, &s, &params).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.ends_with("}\n"));
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["summary"]["sda_percent"], 75.0);
    assert_eq!(v["summary"]["sensors"], 4);
    assert_eq!(v["params"]["da_threshold_lux"], 500.0);
    assert_eq!(v["params"]["occupancy_end_hour"], 17);
    let da = v["definitions"]["da"].as_str().unwrap();
    assert!(da.contains(">= 500 lx"), "{da}");
    for key in [
        "cda",
        "udi_below",
        "udi_within",
        "udi_above",
        "ase_hours",
        "sda_percent",
        "ase_percent",
    ] {
        assert!(v["definitions"][key].is_string(), "{key}");
    }
    let back: MetricParams = serde_json::from_value(v["params"].clone()).unwrap();
    assert_eq!(back, params);
}

#[test]
fn surfaces_csv_header_by_group_kind() {
    let groups = [
        SurfaceGroup {
            name: "floor".into(),
            glazing: false,
        },
        SurfaceGroup {
            name: "south_window".into(),
            glazing: true,
        },
    ];
    let times = [t("2021-06-21T12:30:00")];
    assert_eq!(
        surfaces_csv_text(&groups, &times, &[vec![410.5, 1234.0]]).unwrap(),
        "time,floor_irradiance_w_m2,south_window_transmitted_w\n\
         2021-06-21T12:30:00,410.500,1234.000\n"
    );
    let bad = [SurfaceGroup {
        name: "a,b".into(),
        glazing: false,
    }];
    let (_, _, _, value) = input_parts(surfaces_csv_text(&bad, &times, &[vec![1.0]]).unwrap_err());
    assert_eq!(value.as_deref(), Some("a,b"));
}

/// Six hourly steps, two sensors; shard k of 3 holds steps k and k + 3.
fn series() -> (Vec<NaiveDateTime>, Vec<Vec<f64>>) {
    let times = (0..6)
        .map(|h| t("2021-03-21T06:30:00") + TimeDelta::hours(h))
        .collect();
    let rows = (0..6)
        .map(|h| vec![h as f64 * 100.5, 7.125 - h as f64])
        .collect();
    (times, rows)
}

fn write_shards(dir: &Path) -> Vec<PathBuf> {
    let (times, rows) = series();
    (0..3)
        .map(|k| {
            let p = dir.join(format!("shard{k}/illuminance.csv"));
            let idx = [k, k + 3];
            let ts: Vec<_> = idx.iter().map(|&i| times[i]).collect();
            let rs: Vec<_> = idx.iter().map(|&i| rows[i].clone()).collect();
            write_illuminance_csv(&p, &ts, &rs).unwrap();
            p
        })
        .collect()
}

#[test]
fn merged_shards_equal_a_single_run() {
    let dir = tempfile::tempdir().unwrap();
    let shards = write_shards(dir.path());
    let (times, rows) = series();
    let single = illuminance_csv_text(&times, &rows).unwrap();
    let out = dir.path().join("merged/illuminance.csv");
    // Any order of parts gives the same bytes.
    merge_illuminance(
        &[shards[2].clone(), shards[0].clone(), shards[1].clone()],
        &out,
    )
    .unwrap();
    assert_eq!(std::fs::read_to_string(&out).unwrap(), single);
    assert!(
        single.contains("\n2021-03-21T11:30:00,502.500,2.125\n"),
        "{single}"
    );
}

#[test]
fn merge_refuses_mismatched_duplicate_or_missing_rows() {
    let dir = tempfile::tempdir().unwrap();
    let shards = write_shards(dir.path());
    let out = dir.path().join("merged.csv");

    // A shard of a 3-sensor run.
    let other = dir.path().join("other.csv");
    write_illuminance_csv(&other, &[t("2021-03-21T12:30:00")], &[vec![1.0, 2.0, 3.0]]).unwrap();
    let (_, path, line, value) =
        input_parts(merge_illuminance(&[shards[0].clone(), other.clone()], &out).unwrap_err());
    assert_eq!(
        (path, line, value.as_deref()),
        (other, Some(1), Some("time,s0,s1,s2"))
    );

    // Shard 1 given twice: its first row (line 2, 07:30) is a duplicate.
    let copy = dir.path().join("copy.csv");
    std::fs::copy(&shards[1], &copy).unwrap();
    let parts = [
        shards[0].clone(),
        shards[1].clone(),
        shards[2].clone(),
        copy.clone(),
    ];
    let (shown, path, line, value) = input_parts(merge_illuminance(&parts, &out).unwrap_err());
    assert_eq!(
        (path, line, value.as_deref()),
        (copy, Some(2), Some("2021-03-21T07:30:00")),
        "{shown}"
    );

    // Shard 1 left out: 07:30 and 10:30 are missing; the gap shows at shard 2's 08:30.
    let (shown, path, line, value) =
        input_parts(merge_illuminance(&[shards[0].clone(), shards[2].clone()], &out).unwrap_err());
    assert_eq!(
        (path, line, value.as_deref()),
        (shards[2].clone(), Some(2), Some("2021-03-21T08:30:00")),
        "{shown}"
    );
    assert!(!out.exists());
}
