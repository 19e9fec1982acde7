//! Every number a user types is checked (issue 22): the binary refuses a non-finite or
//! out-of-range flag, a view file that sets no view, and a scene-file number out of range
//! with exit 1, naming the flag or the file, key and value, before any work: no output
//! folder and no cache folder is made. (Each flag's range is checked for all flags at once
//! by the unit tests of `cli::args`, which walk the whole command.)

use crate::util::{daystep, office, stderr};
use std::path::PathBuf;

/// A scratch folder with a tiny uniform HDR sky image, an output and a cache path.
struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    fn new() -> Scratch {
        let dir = tempfile::tempdir().unwrap();
        let mut im = daystep::render::image::Image::new(8, 4, daystep::render::Quantity::Radiance);
        im.rgb
            .iter_mut()
            .for_each(|p| *p = glam::DVec3::splat(10.0));
        daystep::render::rgbe::write_hdr(&dir.path().join("sky.hdr"), &im, None).unwrap();
        Scratch { dir }
    }
    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
    fn s(&self, name: &str) -> String {
        self.path(name).to_string_lossy().into_owned()
    }
}

/// Runs `args`; asserts exit 1, that standard error names every one of `named`, and that
/// nothing was started: neither `out` nor `cache` of the scratch folder exists.
fn refused(t: &Scratch, args: &[String], named: &[&str]) {
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = daystep(&a);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{a:?}: {err}");
    for n in named {
        assert!(err.contains(n), "{a:?}: {n:?} not named in: {err}");
    }
    for made in ["out", "cache"] {
        assert!(!t.path(made).exists(), "{a:?} made {made}/ before refusing");
    }
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// `instant` on the office at draft quality, writing into the scratch folder, then `extra`.
fn instant(t: &Scratch, extra: &[&str]) -> Vec<String> {
    let mut a = strings(&[
        "instant",
        office().to_str().unwrap(),
        "--time",
        "2024-03-21T12:00",
    ]);
    a.extend(strings(&[
        "--quality",
        "draft",
        "--out",
        &t.s("out"),
        "--cache",
        &t.s("cache"),
    ]));
    a.extend(strings(extra));
    a
}

/// A 16 × 16 `render` of the office at noon under a CIE overcast sky, then `extra` (which
/// may give its own -x, -y, --samples).
fn render(t: &Scratch, extra: &[&str]) -> Vec<String> {
    let mut a = strings(&["render", office().to_str().unwrap()]);
    for (flag, v) in [("-x", "16"), ("-y", "16"), ("--samples", "1")] {
        if !extra.contains(&flag) {
            a.extend(strings(&[flag, v]));
        }
    }
    a.extend(strings(&["--gather", "4", "--quality", "draft"]));
    a.extend(strings(&[
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "cie-overcast",
    ]));
    a.extend(strings(&[
        "--dhi",
        "100",
        "--out",
        &t.s("out"),
        "--cache",
        &t.s("cache"),
    ]));
    a.extend(strings(extra));
    a
}

#[test]
fn rotate_nan_or_inf_exits_1_naming_rotate() {
    // Was accepted: every direction read the image's first column and report.json said
    // "rotated NaN°".
    let t = Scratch::new();
    let sky = t.s("sky.hdr");
    for bad in ["NaN", "inf", "-inf", "1e400", "1e300"] {
        let rotate = format!("--rotate={bad}");
        let a = instant(&t, &["--sky", "image", "--image", &sky, &rotate]);
        refused(&t, &a, &["--rotate", bad]);
        let mut a = render(&t, &["--view", "-vta -vp 3 4 1.2 -vd 0 0 1 -vu 0 1 0"]);
        let at = a.iter().position(|s| s == "cie-overcast").unwrap();
        a[at] = "image".into();
        a.extend(strings(&["--image", &sky, &rotate]));
        refused(&t, &a, &["--rotate", bad]);
    }
}

#[test]
fn an_empty_view_file_exits_1_naming_the_file() {
    // Was accepted: the camera sat at the origin looking along +y; rpict says "bad view
    // file". Also through the --view-file spelling of --vf, and for a --view that sets
    // nothing.
    let t = Scratch::new();
    let vf = t.path("empty.vf");
    for (text, flag) in [
        ("", "--vf"),
        ("# saved by nobody\n\n", "--view-file"),
        ("rvu -x 800 -y 600\n", "--vf"),
    ] {
        std::fs::write(&vf, text).unwrap();
        let a = render(&t, &[flag, vf.to_str().unwrap()]);
        refused(&t, &a, &["empty.vf", "bad view file"]);
    }
    for view in ["", "rvu", "-x 800"] {
        let a = render(&t, &["--view", view]);
        refused(&t, &a, &["--view", "bad view file"]);
    }
}

#[test]
fn out_of_range_flags_exit_1_naming_the_flag_before_any_work() {
    let t = Scratch::new();
    let cases: Vec<(Vec<String>, &[&str])> = vec![
        // A negative irradiance was refused only once the sky was built.
        (
            instant(&t, &["--sky", "perez", "--dni=-5", "--dhi", "100"]),
            &["--dni", "-5"],
        ),
        // Lux given for W/m².
        (
            instant(&t, &["--sky", "cie-overcast", "--dhi", "20000"]),
            &["--dhi", "20000", "2000"],
        ),
        (
            instant(
                &t,
                &[
                    "--sky",
                    "perez",
                    "--dni",
                    "800",
                    "--dhi",
                    "100",
                    "--dew-point",
                    "nan",
                ],
            ),
            &["--dew-point", "nan"],
        ),
        // Was clamped to 2 with a warning.
        (
            instant(&t, &["--sky", "preetham", "--turbidity", "1.5"]),
            &["--turbidity", "1.5"],
        ),
        (
            instant(&t, &["--sky", "cie", "--type", "16", "--dhi", "100"]),
            &["--type", "16"],
        ),
        // Was accepted: every falsecolor value was over the scale.
        (
            render(
                &t,
                &[
                    "--view",
                    "-vtv -vp 3 4 1.2 -vd 0 -1 0",
                    "--falsecolor",
                    "--scale",
                    "0",
                ],
            ),
            &["--scale", "0"],
        ),
        (
            render(&t, &["--view", "-vtv -vp 3 4 1.2 -vd 0 -1 0", "-x", "0"]),
            &["-x", "0"],
        ),
        (
            render(
                &t,
                &[
                    "--view",
                    "-vtv -vp 3 4 1.2 -vd 0 -1 0",
                    "-x",
                    "20000",
                    "-y",
                    "20000",
                ],
            ),
            &["-x", "20000"],
        ),
        // Was refused only after the frame had been rendered.
        (
            render(
                &t,
                &[
                    "--view",
                    "-vta -vd 0 0 1 -vu 0 1 0",
                    "--glare",
                    "--glare-threshold",
                    "nan",
                ],
            ),
            &["--glare-threshold", "nan"],
        ),
        // Was silently 1.
        (
            render(
                &t,
                &["--view", "-vtv -vp 3 4 1.2 -vd 0 -1 0", "--samples", "0"],
            ),
            &["--samples", "0"],
        ),
        (
            render(
                &t,
                &["--view", "-vtv -vp 3 4 1.2 -vd 0 -1 0", "--exposure", "inf"],
            ),
            &["--exposure", "inf"],
        ),
        (
            render(&t, &["--view", "-vtv -vp 3 4 1.2 -vd nan 1 0"]),
            &["<argument --view>", "nan"],
        ),
    ];
    for (args, named) in &cases {
        refused(&t, args, named);
    }
    // Was silently one thread.
    let mut a = strings(&["--threads", "0"]);
    a.extend(instant(&t, &["--sky", "none"]));
    refused(&t, &a, &["--threads", "0"]);
    // The metric thresholds of annual and merge, also as a pair.
    let weather = office().with_file_name("weather.epw");
    let annual = |extra: &[&str]| {
        let mut a = strings(&["annual", office().to_str().unwrap()]);
        a.extend(strings(&[
            "--weather",
            weather.to_str().unwrap(),
            "--out",
            &t.s("out"),
        ]));
        a.extend(strings(&[
            "--cache",
            &t.s("cache"),
            "--start",
            "2024-03-21",
        ]));
        a.extend(strings(&["--end", "2024-03-21"]));
        a.extend(strings(extra));
        a
    };
    refused(
        &t,
        &annual(&["--sda-fraction", "0"]),
        &["--sda-fraction", "0"],
    );
    refused(
        &t,
        &annual(&["--da-threshold", "inf"]),
        &["--da-threshold", "inf"],
    );
    refused(
        &t,
        &annual(&["--occupancy-end", "24"]),
        &["--occupancy-end", "24"],
    );
    refused(
        &t,
        &annual(&["--udi-min", "5000"]),
        &["--udi-min", "5000", "--udi-max"],
    );
    let merge = strings(&["merge", &t.s("a"), "--out", &t.s("out"), "--udi-max", "-1"]);
    refused(&t, &merge, &["--udi-max", "-1"]);
}

#[test]
fn scene_file_numbers_out_of_range_exit_1_naming_file_line_and_key() {
    let t = Scratch::new();
    let d = t.dir.path();
    std::fs::write(d.join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\n").unwrap();
    std::fs::write(
        d.join("m.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    )
    .unwrap();
    for (site, line, key, value) in [
        (
            "latitude = nan\nlongitude = 0\nutc_offset_h = 0\n",
            3,
            "site.latitude",
            "NaN",
        ),
        (
            "latitude = 0\nlongitude = inf\nutc_offset_h = 0\n",
            4,
            "site.longitude",
            "inf",
        ),
        // Was accepted: any finite elevation, also a million metres.
        (
            "latitude = 0\nlongitude = 0\nutc_offset_h = 0\nelevation_m = 1e6\n",
            6,
            "site.elevation_m",
            "1000000",
        ),
    ] {
        let scene = d.join("scene.toml");
        std::fs::write(&scene, format!("geometry = \"m.obj\"\n[site]\n{site}")).unwrap();
        let mut a = strings(&[
            "instant",
            scene.to_str().unwrap(),
            "--time",
            "2024-03-21T12:00",
        ]);
        a.extend(strings(&["--sky", "cie-overcast", "--dhi", "100"]));
        a.extend(strings(&["--out", &t.s("out"), "--cache", &t.s("cache")]));
        refused(&t, &a, &[&format!("scene.toml:{line}"), key, value]);
    }
}
