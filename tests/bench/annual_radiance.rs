//! Radiance's 2-phase run of the annual bench, on the same scene and weather file, and the
//! hour-by-hour comparison of its illuminance with daystep's.

use super::*;

/// The venv's Python when it imports pyradiance.
pub(super) fn radiance_python(root: &Path) -> Option<PathBuf> {
    let py = root.join("target/radiance-venv/bin/python");
    let ok = py.exists()
        && Command::new(&py)
            .args(["-c", "import pyradiance"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
    ok.then_some(py)
}

pub(super) struct RadRun {
    /// Wall time of the python process, s (conversion, Radiance, metrics).
    pub(super) process_s: f64,
    pub(super) v: Value,
}

impl RadRun {
    pub(super) fn f(&self, key: &str) -> f64 {
        self.v[key].as_f64().unwrap_or(f64::NAN)
    }
    pub(super) fn metric(&self, key: &str) -> f64 {
        self.v["metrics"][key].as_f64().unwrap_or(f64::NAN)
    }
    pub(super) fn stage(&self, name: &str) -> f64 {
        self.v["stages"]
            .as_array()
            .and_then(|a| a.iter().find(|s| s["stage"] == name))
            .and_then(|s| s["seconds"].as_f64())
            .unwrap_or(f64::NAN)
    }
}

pub(super) fn radiance(
    py: &Path,
    root: &Path,
    o: &Opts,
    scene: &Path,
    weather: &Path,
    period: Period,
    work: &Path,
) -> RadRun {
    std::fs::create_dir_all(work).unwrap();
    let out = work.join("result.json");
    let _ = std::fs::remove_file(&out);
    let mut cmd = Command::new(py);
    cmd.arg(root.join("tests/bench/radiance/validate.py"))
        .arg("--two-phase-only")
        .arg("--scene")
        .arg(scene)
        .arg("--weather")
        .arg(weather)
        .arg("--work")
        .arg(work)
        .args(["--nproc", &o.radiance_nproc.to_string()])
        .arg("--json")
        .arg(&out)
        .args(period.radiance_args())
        .stdin(Stdio::null())
        .stdout(Stdio::null());
    if let Some(opts) = &o.radiance_opts {
        cmd.arg(format!("--dc-opts={opts}"));
    }
    let t0 = Instant::now();
    let status = cmd.status().unwrap();
    let process_s = t0.elapsed().as_secs_f64();
    assert!(
        status.success(),
        "validate.py --two-phase-only failed: {status}"
    );
    let v = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    RadRun { process_s, v }
}

/// daystep (cold run) against Radiance hour by hour: over occupied steps (8:00–17:59) and
/// sensors where Radiance > 100 lx, (mean relative difference, RMS relative difference,
/// count); `None` when the rows do not line up.
pub(super) fn hourly(ds: &DsRun, rad: &RadRun) -> Option<(f64, f64, usize)> {
    let (times, rows) =
        daystep::export::read_illuminance_csv(&ds.out.join("illuminance.csv")).ok()?;
    let bytes = std::fs::read(rad.v["illuminance_f32"].as_str()?).ok()?;
    let ill: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let rtimes = rad.v["times"].as_array()?;
    let ns = rows.first()?.len();
    if rows.len() != rtimes.len() || ill.len() != rows.len() * ns {
        return None;
    }
    let (mut sum, mut sq, mut n) = (0.0, 0.0, 0usize);
    for (k, (t, rt)) in times.iter().zip(rtimes).enumerate() {
        let t = NaiveDateTime::parse_from_str(t, daystep::export::TIME_FORMAT).ok()?;
        let (m, d, h) = (rt[0].as_u64()?, rt[1].as_u64()?, rt[2].as_f64()?);
        let th = t.hour() as f64 + t.minute() as f64 / 60.0;
        if u64::from(t.month()) != m || u64::from(t.day()) != d || (th - h).abs() > 1e-3 {
            return None;
        }
        if !(8..=17).contains(&(h.floor() as i64)) {
            continue;
        }
        for (s, &v) in rows[k].iter().enumerate() {
            let r = f64::from(ill[k * ns + s]);
            if r > 100.0 {
                let x = (v - r) / r;
                sum += x;
                sq += x * x;
                n += 1;
            }
        }
    }
    (n > 0).then(|| (100.0 * sum / n as f64, 100.0 * (sq / n as f64).sqrt(), n))
}
