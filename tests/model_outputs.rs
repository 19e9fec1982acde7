//! A Honeybee model's grids, views and site through the binary: the sample model made by
//! honeybee's own library (scenes/honeybee) given alone, its grids in every output, grid
//! selection, per-grid metrics recomputed from the per-sensor table, named views.

use crate::util::{daystep, stderr};
use std::path::{Path, PathBuf};

fn model(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/honeybee")
        .join(name)
}

/// The sample model's site (scenes/honeybee/scene.toml's), for `--site`.
const SITE: &str = "36.1,-79.95,-5,273";

fn instant(out: &Path, extra: &[&str]) -> std::process::Output {
    let m = model("model.hbjson");
    let mut args = vec![
        "instant",
        m.to_str().unwrap(),
        "--site",
        SITE,
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "cie-overcast",
        "--dhi",
        "100",
        "--quality",
        "draft",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    daystep(&args)
}

/// (grid, lux, lux_err) of each row of a sensors.csv with a grid column.
fn rows(out: &Path) -> Vec<(String, f64, f64)> {
    let csv = std::fs::read_to_string(out.join("sensors.csv")).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(head.last(), Some(&"grid"), "{head:?}");
    lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (
                c[c.len() - 1].to_string(),
                c[4].parse().unwrap(),
                c[5].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_model_alone_runs_with_its_grids_as_sensors_and_a_grid_selection_agrees() {
    let dir = tempfile::tempdir().unwrap();
    let all = dir.path().join("all");
    let o = instant(&all, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r = rows(&all);
    // make_model.py: two rooms of 6 m × 5 m, a 0.5 m grid 0.5 m from the walls: 8 × 10.
    assert_eq!(r.len(), 160);
    assert!(r[..80].iter().all(|(g, _, _)| g == "Room_West_Grid"));
    assert!(r[80..].iter().all(|(g, _, _)| g == "Room_East_Grid"));
    // Daylight reaches every sensor of a side-lit room under an overcast sky.
    assert!(r.iter().all(|(_, lux, _)| *lux > 0.0));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(all.join("report.json")).unwrap()).unwrap();
    let grids = report["model"]["sensor_grids"].as_array().unwrap();
    assert_eq!(grids.len(), 2);
    assert_eq!(grids[1]["identifier"], "Room_East_Grid");
    assert_eq!(grids[1]["sensors"], 80);
    let views = report["model"]["views"].as_array().unwrap();
    assert!(views.iter().any(|v| v == "West_Inside"), "{views:?}");
    // The site came from --site, not from Greenwich.
    let warned = report["warnings"].as_array().unwrap();
    assert!(
        !warned
            .iter()
            .any(|w| w.as_str().unwrap().contains("Greenwich")),
        "{warned:?}"
    );

    // Only the east room: its 80 sensors, the same values within both stated errors (the
    // refinement follows the sensors, so the runs are not bit-identical).
    let east = dir.path().join("east");
    let o = instant(&east, &["--grids", "Room_East*"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = rows(&east);
    assert_eq!(e.len(), 80);
    for ((g, lux, err), (g0, lux0, err0)) in e.iter().zip(&r[80..]) {
        assert_eq!(g, g0);
        assert!(
            (lux - lux0).abs() <= err + err0,
            "{lux} ± {err} against {lux0} ± {err0}"
        );
    }

    // A pattern that matches nothing names the grids there are.
    let o = instant(&dir.path().join("none"), &["--grids", "Core*"]);
    assert_eq!(o.status.code(), Some(1));
    let msg = stderr(&o);
    assert!(
        msg.contains("--grids") && msg.contains("Room_West_Grid"),
        "{msg}"
    );
}

#[test]
fn a_day_writes_grids_and_per_grid_metrics_that_the_sensor_table_reproduces() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("day");
    let weather = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw");
    let m = model("scene.toml");
    let o = daystep(&[
        "annual",
        m.to_str().unwrap(),
        "--weather",
        weather.to_str().unwrap(),
        "--start",
        "2024-06-21",
        "--end",
        "2024-06-21",
        "--quality",
        "draft",
        "--ill",
        "--no-cache",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let grids: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("grids.json")).unwrap()).unwrap();
    assert_eq!(grids["grids"].as_array().unwrap().len(), 2);
    // One .ill per grid with its 80 columns after month, day and hour.
    for g in ["Room_West_Grid", "Room_East_Grid"] {
        let ill = std::fs::read_to_string(out.join("grids").join(format!("{g}.ill"))).unwrap();
        let first = ill.lines().next().unwrap();
        assert_eq!(first.split_whitespace().count(), 3 + 80, "{g}");
    }
    // Per-grid sDA and mean DA recomputed from metrics.csv's rows of that grid.
    let metrics = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
    let mut lines = metrics.lines();
    assert!(lines.next().unwrap().ends_with(",grid"));
    let per: Vec<(f64, String)> = lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[1].parse().unwrap(), c[c.len() - 1].to_string())
        })
        .collect();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for g in ["Room_West_Grid", "Room_East_Grid"] {
        let da: Vec<f64> = per
            .iter()
            .filter(|(_, id)| id == g)
            .map(|(d, _)| *d)
            .collect();
        assert_eq!(da.len(), 80);
        // metrics.csv rounds DA to 3 decimals: compare the mean to that precision.
        let mean = da.iter().sum::<f64>() / 80.0;
        let s = &summary["grids"][g]["summary"];
        let s = if s.is_null() { &summary["grids"][g] } else { s };
        assert!(
            (s["mean_da"].as_f64().unwrap() - mean).abs() < 1e-3,
            "{g}: {s}"
        );
        let sda = 100.0 * da.iter().filter(|d| **d >= 50.0).count() as f64 / 80.0;
        assert!(
            (s["sda_percent"].as_f64().unwrap() - sda).abs() < 1e-9,
            "{g}"
        );
    }
    assert!(summary["rooms"]["Room_West"].is_object(), "{summary}");
}

#[test]
fn a_named_view_is_the_view_file_honeybee_wrote_for_it() {
    let dir = tempfile::tempdir().unwrap();
    let m = model("scene.toml");
    let vf = model("rad/model/view/West_Inside.vf");
    let render = |out: &Path, camera: &[&str]| {
        let mut args = vec![
            "render",
            m.to_str().unwrap(),
            "-x",
            "24",
            "-y",
            "18",
            "--samples",
            "1",
            "--time",
            "2024-03-21T12:00",
            "--sky",
            "cie-overcast",
            "--dhi",
            "100",
            "--quality",
            "draft",
            "--no-cache",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(camera);
        let o = daystep(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        // Named by local standard time; the .exr holds the radiance and its error (its
        // header also holds the command line, which differs).
        let img = daystep::render::exr::read_exr(&out.join("20240321_1200.exr")).unwrap();
        (img.rgb, img.err)
    };
    let named = render(&dir.path().join("named"), &["--view-name", "West_Inside"]);
    let file = render(&dir.path().join("file"), &["--vf", vf.to_str().unwrap()]);
    assert!(!named.0.is_empty());
    assert_eq!(named, file);
    let o = daystep(&[
        "render",
        m.to_str().unwrap(),
        "--view-name",
        "Nope",
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "cie-overcast",
        "--dhi",
        "100",
        "--out",
        dir.path().join("x").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("West_Inside"), "{}", stderr(&o));
}
