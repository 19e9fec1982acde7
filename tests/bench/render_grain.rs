//! Grain of `daystep render` at the default quality (issue 29): for the sample office, the
//! per-pixel stated relative error (the EXR's `err` over the pixel's value) of a default
//! frame, and the frame's wall-clock time. Not a CI test.
//!
//!     cargo bench --bench render_grain [-- --runs N] [--out DIR] [--view "OPTIONS"] [--gather N]
//!         [--exe PATH]   (another daystep binary, e.g. an earlier commit's, to compare)
//!
//! Each case is one `daystep render` of scenes/office/scene.toml, 640 × 480, a Perez sky from
//! the office's weather file (21 March, the records of 11:30 and 12:30 local standard time:
//! DNI, DHI and dew point as the file gives them), without the projection cache (so each run
//! traces its camera and solves its operator as a first run does). Printed per case: the
//! median over runs of the wall-clock and the CPU seconds, and of the one image the median and 95th
//! percentile of err/value over lit pixels (valid, value > 0) and the fraction of lit
//! pixels whose err/value is above 10 %. The image is the same bit for bit on every run.

use daystep::render::exr::read_exr;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

/// The view of the figures: from the back of the room towards the window wall (the
/// render bench's first view, tests/bench/render/rpict.py).
const VIEW: &str = "-vtv -vp 3 7.5 1.5 -vd 0 -1 -0.1 -vu 0 0 1 -vh 70 -vv 50";

/// (label, `--time`, DNI W/m², DHI W/m², dew point °C) from scenes/office/weather.epw
/// (records 1990-03-21 hours 12 and 13, the hours ending at 12:00 and 13:00).
const CASES: [(&str, &str, &str, &str, &str); 2] = [
    ("11:30", "2021-03-21T11:30", "978", "86", "-5.0"),
    ("12:30", "2021-03-21T12:30", "984", "88", "-4.4"),
];

/// CPU seconds (user + system) used so far by this process's waited-for children: on a
/// shared machine this moves less with other load than the wall clock does.
fn children_cpu_seconds() -> f64 {
    // SAFETY: getrusage only writes the struct it is given.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut u) };
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    s(u.ru_utime) + s(u.ru_stime)
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let exe = PathBuf::from(env!("CARGO_BIN_EXE_daystep"));
    let mut args = std::env::args().skip(1);
    let mut exe = exe;
    let (mut runs, mut out, mut view, mut extra) = (
        3usize,
        root.join("target/render-grain"),
        VIEW.to_string(),
        Vec::<String>::new(),
    );
    while let Some(a) = args.next() {
        match a.as_str() {
            "--runs" => runs = args.next().and_then(|v| v.parse().ok()).unwrap_or(3),
            "--out" => out = PathBuf::from(args.next().expect("--out DIR")),
            "--view" => view = args.next().expect("--view OPTIONS"),
            "--exe" => exe = PathBuf::from(args.next().expect("--exe PATH")),
            "--gather" | "--samples" => {
                extra.push(a.clone());
                extra.push(args.next().expect("a count"));
            }
            "--bench" => {}
            other => panic!("unknown option {other}"),
        }
    }
    println!("view `{view}`, 640×480, {runs} runs, extra options {extra:?}\n");
    println!("`{}`\n", exe.display());
    println!(
        "| time | wall s (median) | CPU s (median) | median err/value | p95 err/value | \
         lit pixels > 10 % |"
    );
    println!("|---|---|---|---|---|---|");
    for (label, time, dni, dhi, dew) in CASES {
        let dir = out.join(label.replace(':', ""));
        let (mut seconds, mut cpu) = (Vec::new(), Vec::new());
        for _ in 0..runs {
            let _ = std::fs::remove_dir_all(&dir);
            let (t0, c0) = (Instant::now(), children_cpu_seconds());
            let status = Command::new(&exe)
                .arg("render")
                .arg(root.join("scenes/office/scene.toml"))
                .args(["--view", &view, "-x", "640", "-y", "480"])
                .args(["--time", time, "--sky", "perez", "--dni", dni, "--dhi", dhi])
                .args(["--dew-point", dew, "--no-cache", "--out"])
                .arg(&dir)
                .args(&extra)
                .stderr(std::process::Stdio::null())
                .stdout(std::process::Stdio::null())
                .status()
                .expect("daystep runs");
            assert!(status.success(), "daystep render failed");
            seconds.push(t0.elapsed().as_secs_f64());
            cpu.push(children_cpu_seconds() - c0);
        }
        seconds.sort_by(f64::total_cmp);
        cpu.sort_by(f64::total_cmp);
        let exr = std::fs::read_dir(&dir)
            .expect("output folder")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .find(|p| p.extension().is_some_and(|x| x == "exr"))
            .expect("an .exr");
        let img = read_exr(&exr).expect("readable .exr");
        let mut rel: Vec<f64> = (0..img.rgb.len())
            .filter(|&i| img.valid[i])
            .filter_map(|i| {
                let v = daystep::photometry::grey(img.rgb[i]);
                (v > 0.0).then(|| img.err[i] / v)
            })
            .collect();
        rel.sort_by(f64::total_cmp);
        let above = rel.iter().filter(|&&r| r > 0.10).count() as f64 / rel.len() as f64;
        println!(
            "| {label} | {:.2} | {:.2} | {:.1} % | {:.1} % | {:.1} % |",
            quantile(&seconds, 0.5),
            quantile(&cpu, 0.5),
            100.0 * quantile(&rel, 0.5),
            100.0 * quantile(&rel, 0.95),
            100.0 * above
        );
    }
}
