//! The binary end to end: outputs, exit codes, and messages that name file, line and value.

use crate::util::{daystep, office, stderr};
use std::path::Path;

#[test]
fn instant_on_the_sample_office_writes_sensors_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = daystep(&[
        "instant",
        office().to_str().unwrap(),
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "perez",
        "--dni",
        "700",
        "--dhi",
        "120",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("sensors.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(lines
        .next()
        .unwrap()
        .starts_with("sensor,x,y,z,lux,lux_err"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let pts = std::fs::read_to_string(office().with_file_name("office.pts")).unwrap();
    let n_pts = pts
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .count();
    assert_eq!(rows.len(), n_pts);
    // Noon at the equinox through a south window: some sensors see the sun, many see sky;
    // deep points see only the obstruction (zero direct light).
    assert!(rows
        .iter()
        .all(|r| r[4].is_finite() && r[4] >= 0.0 && r[5] >= 0.0));
    assert!(rows.iter().filter(|r| r[7] > 0.0).count() > rows.len() / 3);
    assert!(
        rows.iter().any(|r| r[6] > 0.0),
        "no sun patch on the work plane"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert!(
        report["counts"]["elements_after"].as_u64().unwrap()
            > report["counts"]["elements_before"].as_u64().unwrap()
    );
    assert!(report["stage_seconds"].as_array().unwrap().len() >= 5);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    // Without a cache: a run that read the other run's records would compare them with
    // themselves.
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(threads);
        let o = daystep(&[
            "--threads",
            threads,
            "instant",
            office().to_str().unwrap(),
            "--time",
            "2024-06-21T15:00",
            "--sky",
            "preetham",
            "--turbidity",
            "3",
            "--out",
            out.to_str().unwrap(),
            "--quality",
            "draft",
            "--no-cache",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        outputs.push(std::fs::read(out.join("sensors.csv")).unwrap());
    }
    assert_eq!(outputs[0], outputs[1]);
}

#[test]
fn bad_input_exits_1_naming_the_file_line_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("scene.toml"),
        "geometry = \"m.obj\"\n[site]\nlatitude = 40\nlongitude = 0\nutc_offset_h = 0\n",
    )
    .unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\n").unwrap();
    std::fs::write(
        d.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 nan\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    )
    .unwrap();
    let scene = d.join("scene.toml");
    let args = |s: &Path| {
        vec![
            "instant".to_string(),
            s.to_string_lossy().into_owned(),
            "--time".into(),
            "2024-06-21T12:00".into(),
            "--sky".into(),
            "cie-overcast".into(),
            "--dhi".into(),
            "100".into(),
            "--out".into(),
            d.join("out").to_string_lossy().into_owned(),
        ]
    };
    let run = |a: Vec<String>| daystep(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(args(&scene));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("m.obj:3") && stderr(&o).to_lowercase().contains("nan"),
        "{}",
        stderr(&o)
    );

    let o = run(args(&d.join("missing.toml")));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("missing.toml"), "{}", stderr(&o));

    std::fs::write(
        d.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl a\nKd 1.0 0.5 0.5\n").unwrap();
    let o = run(args(&scene));
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("m.mtl:2"), "{}", stderr(&o));

    let o = daystep(&[
        "instant",
        scene.to_str().unwrap(),
        "--time",
        "noon",
        "--sky",
        "none",
        "--out",
        "x",
    ]);
    assert_eq!(o.status.code(), Some(1));
    let o = daystep(&[
        "instant",
        scene.to_str().unwrap(),
        "--time",
        "2024-01-01T12:00",
        "--sky",
        "perez",
        "--out",
        "x",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--dni"), "{}", stderr(&o));
}

#[test]
fn convergence_ladder_writes_csv_plot_and_advice() {
    // One ladder (the Gauss–Seidel tolerance) on the office at draft quality: the loosest
    // tolerance must differ more from the finest than the base tolerance does, the finest
    // rung differs by nothing, and the plot and recommendation are written.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("conv");
    let o = daystep(&[
        "convergence",
        office().to_str().unwrap(),
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "cie-overcast",
        "--dhi",
        "100",
        "--quality",
        "draft",
        "--knobs",
        "iteration tolerance",
        "--repeats",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("convergence.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 4, "{csv}");
    let rms: Vec<f64> = rows.iter().map(|r| r[3].parse().unwrap()).collect();
    assert_eq!(rms[3], 0.0);
    assert!(rms[0] > rms[2], "{rms:?}");
    assert_eq!(rows.iter().filter(|r| r[7] == "true").count(), 1);
    // Each rung timed twice: the median CPU time lies within its spread; only the finest rung is
    // the reference, and the plot labels it rather than drawing its zero.
    for r in &rows {
        let (t, lo, hi): (f64, f64, f64) = (
            r[8].parse().unwrap(),
            r[9].parse().unwrap(),
            r[10].parse().unwrap(),
        );
        assert!(0.0 < lo && lo <= t && t <= hi, "{r:?}");
        assert_eq!(r[11], "2");
    }
    let refs: Vec<bool> = rows.iter().map(|r| r[12] == "true").collect();
    assert_eq!(refs, [false, false, false, true]);
    let svg = std::fs::read_to_string(out.join("convergence.svg")).unwrap();
    assert!(
        svg.contains("iteration tolerance") && svg.contains("ref: 1e-4"),
        "{svg}"
    );
    assert!(!String::from_utf8_lossy(&o.stdout).trim().is_empty());
    // An unknown knob is a usage error naming the choices.
    let o = daystep(&[
        "convergence",
        office().to_str().unwrap(),
        "--weather",
        office().with_file_name("weather.epw").to_str().unwrap(),
        "--knobs",
        "colour",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("sun snapping"), "{}", stderr(&o));
}

/// The write end of a pipe whose reader has already gone: the standard input of a process
/// that has exited without reading it. Writes to it fail with EPIPE, deterministically.
fn pipe_without_reader() -> std::process::Stdio {
    use std::process::{Command, Stdio};
    let mut reader = Command::new(env!("CARGO_BIN_EXE_daystep"))
        .arg("--version")
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("the binary runs");
    let write_end = reader.stdin.take().expect("piped stdin");
    assert!(reader.wait().unwrap().success());
    write_end.into()
}

#[test]
fn a_closed_stdout_is_a_quiet_success() {
    // `daystep cache stats | head -0`: the reader has gone before the report is written.
    let dir = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_daystep"))
        .args(["cache", "stats", "--cache", dir.path().to_str().unwrap()])
        .stdout(pipe_without_reader())
        .output()
        .expect("the binary runs");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}

#[test]
fn a_closed_stderr_does_not_change_the_exit_code() {
    // The error message cannot be shown, but the bad input still exits 1 (not a panic's 101).
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.toml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_daystep"))
        .args(["instant", missing.to_str().unwrap()])
        .args(["--time", "2024-06-21T12:00", "--sky", "none", "--out"])
        .arg(dir.path().join("out"))
        .stderr(pipe_without_reader())
        .output()
        .expect("the binary runs");
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty());
}

#[test]
fn render_writes_its_files_and_refuses_bad_cameras_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scene = office();
    let base = [
        "render",
        scene.to_str().unwrap(),
        "-x",
        "24",
        "-y",
        "24",
        "--samples",
        "1",
        "--gather",
        "4",
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "perez",
        "--dni",
        "700",
        "--dhi",
        "120",
        "--quality",
        "draft",
        "--no-cache",
        "--out",
        out.to_str().unwrap(),
    ];
    let fisheye = "-vta -vp 3 4 1.2 -vd 0 -1 0 -vu 0 0 1 -vh 180 -vv 180";
    let mut args = base.to_vec();
    args.extend(["--view", fisheye, "--falsecolor", "--hdr", "--glare"]);
    let o = daystep(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in [
        "20240321_1200.exr",
        "20240321_1200.png",
        "20240321_1200_falsecolor.png",
        "20240321_1200.hdr",
        "frames.csv",
        "report.json",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let csv = std::fs::read_to_string(out.join("frames.csv")).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    // Count from the right: the quoted sky column may hold commas.
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let from_right = header.len() - header.iter().position(|c| *c == "dgp").unwrap();
    let dgp: f64 = row[row.len() - from_right].parse().unwrap();
    assert!((0.0..=1.0).contains(&dgp), "dgp {dgp}");
    // Glare of a perspective view, no camera at all, a view value that is not a number.
    for (extra, flag) in [
        (
            vec!["--view", "-vtv -vp 3 4 1.2 -vd 0 -1 0", "--glare"],
            "--glare",
        ),
        (vec![], "--view"),
        (vec!["--view", "-vtv -vp 3 x 1.2"], "-vp"),
    ] {
        let mut args = base.to_vec();
        args.extend(extra);
        let o = daystep(&args);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains(flag), "{flag}: {}", stderr(&o));
    }
}
