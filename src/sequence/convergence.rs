//! Error against run time on the user's own scene (`daystep convergence`): for every knob
//! that trades accuracy for time, a ladder of settings from coarse to fine with every other
//! knob at the base preset; each rung is one cold instant (no cache) and its error is
//! measured against the ladder's finest rung. One more ladder runs the presets themselves
//! against `reference`.
//!
//! Error measure, per rung: over the sensors the finest rung lights (≥ 10 lx and ≥ 1 % of
//! its brightest sensor), the RMS and the largest relative difference to the finest rung;
//! next to them the median stated relative error (`lux_err / lux`) and the fraction of those
//! sensors whose difference the two runs' stated errors cover. A ladder's finest rung is not
//! converged either, so a rung's error is the part its knob contributes, not its total.
//!
//! Cost, per rung: the median CPU time (user + system, all threads of this process) of
//! several cold runs, with its spread (min–max). CPU time counts the work done, not the
//! time spent waiting for a core other processes hold, so a loaded machine moves it far
//! less than wall time (which is reported too). The repeats are interleaved (every rung
//! once, then again), so a drift in the machine's load falls on every rung alike. Two rungs
//! whose spreads overlap cost the same as far as the measurement can tell, and the
//! recommendation then takes the more accurate one: a timing difference within the noise
//! never decides it.

use super::config::{Quality, SkySpec};
use super::instant::run_instant;
use crate::error::{Error, Result};
use crate::export::plot::Curve;
use crate::scene::Scene;
use chrono::{DateTime, NaiveDateTime, Utc};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// One rung of one ladder.
#[derive(Clone, Debug, Serialize)]
pub struct Rung {
    /// Knob name (`presets` for the preset ladder).
    pub knob: String,
    /// The knob's setting, as written in `convergence.csv`.
    pub setting: String,
    /// Median wall time of the cold instant over the repeats, s.
    pub seconds: f64,
    /// Median CPU time (user + system, all threads) over the repeats, s: the cost.
    pub cpu_seconds: f64,
    /// Least CPU time of the repeats, s.
    pub cpu_seconds_min: f64,
    /// Most CPU time of the repeats, s.
    pub cpu_seconds_max: f64,
    /// Number of timed runs.
    pub repeats: usize,
    /// RMS relative difference to the ladder's finest rung (0 for that rung).
    pub rms_rel_err: f64,
    /// Largest relative difference to the finest rung.
    pub max_rel_err: f64,
    /// Median over the lit sensors of the rung's stated `lux_err / lux`.
    pub stated_rel_err: f64,
    /// Fraction of lit sensors whose difference lies within both runs' `lux_err`.
    pub covered: f64,
    /// Whether this rung has the base preset's setting of its knob.
    pub is_base: bool,
    /// Whether this rung is its ladder's finest, the reference the others are measured
    /// against (its error is 0 by construction, not measured).
    pub is_reference: bool,
}

impl Rung {
    /// True when the two rungs' timing spreads overlap: their costs are not told apart by
    /// the measurement.
    pub fn same_cost(&self, other: &Rung) -> bool {
        self.cpu_seconds_min <= other.cpu_seconds_max
            && other.cpu_seconds_min <= self.cpu_seconds_max
    }
}

/// A knob's ladder: settings from coarse to fine, each a whole [`Quality`].
pub struct Ladder {
    /// Knob name.
    pub knob: &'static str,
    /// (setting label, quality, is the base setting).
    pub rungs: Vec<(String, Quality, bool)>,
}

/// The ladders around `base` (every knob the presets set; see the module doc).
pub fn ladders(base: &Quality) -> Vec<Ladder> {
    let p = |n: &str| Quality::preset(n).expect("preset exists");
    let names = ["draft", "default", "high", "reference"];
    let mut out = Vec::new();
    let mut ladder = |knob: &'static str, rungs: Vec<(String, Quality)>| {
        let rungs = rungs
            .into_iter()
            .map(|(s, q)| {
                let is_base = q == *base;
                (s, q, is_base)
            })
            .collect();
        out.push(Ladder { knob, rungs });
    };
    ladder(
        "sky subdivision",
        names
            .iter()
            .map(|n| {
                (
                    format!("{n} sky"),
                    Quality {
                        sky: p(n).sky,
                        ..*base
                    },
                )
            })
            .collect(),
    );
    ladder(
        "sun snapping",
        [2.0, 1.0, 0.5, 0.25, 0.1, 0.05]
            .iter()
            .map(|&d| {
                (
                    format!("{d} deg"),
                    Quality {
                        sun_spacing_deg: d,
                        ..*base
                    },
                )
            })
            .collect(),
    );
    ladder(
        "LDI resolution",
        [256u32, 512, 1024, 2048, 4096]
            .iter()
            .map(|&r| {
                let mut q = *base;
                q.projection.max_resolution = r;
                q.projection.min_resolution = base.projection.min_resolution.min(r / 4);
                (format!("{r} px"), q)
            })
            .collect(),
    );
    ladder(
        "refinement thresholds",
        [4.0, 2.0, 1.0, 0.5, 0.25]
            .iter()
            .map(|&k| {
                let mut q = *base;
                // Scaled around the base (k = 1 keeps its exact values, so it is recognised).
                if k != 1.0 {
                    q.projection.v_min = base.projection.v_min * k;
                    q.projection.v_max = 1.0 - q.projection.v_min;
                    q.projection.min_area_m2 = base.projection.min_area_m2 * k;
                }
                (
                    format!(
                        "VR {}..{} {:.2e} m2",
                        q.projection.v_min, q.projection.v_max, q.projection.min_area_m2
                    ),
                    q,
                )
            })
            .collect(),
    );
    ladder(
        "sensor visibility",
        names
            .iter()
            .map(|n| {
                (
                    format!("{n} gather"),
                    Quality {
                        sensors: p(n).sensors,
                        ..*base
                    },
                )
            })
            .collect(),
    );
    ladder(
        "interreflection lines",
        [64u32, 256, 1024, 4096, 8192]
            .iter()
            .map(|&d| {
                let mut q = *base;
                q.transport.directions = d;
                (format!("{d} directions"), q)
            })
            .collect(),
    );
    ladder(
        "iteration tolerance",
        [1e-1, 1e-2, 1e-3, 1e-4]
            .iter()
            .map(|&t| {
                let mut q = *base;
                q.transport.tolerance = t;
                (format!("{t:e}"), q)
            })
            .collect(),
    );
    ladder(
        "presets",
        names
            .iter()
            .map(|n| (n.to_string(), p(n).with_seed(base.transport.seed)))
            .collect(),
    );
    out
}

/// Relative-error statistics of `x` against the finest rung `r` (lux and lux_err each).
fn compare(x: &[(f64, f64)], r: &[(f64, f64)]) -> (f64, f64, f64, f64) {
    let max_ref = r.iter().map(|v| v.0).fold(0.0, f64::max);
    let floor = (0.01 * max_ref).max(10.0);
    let (mut sq, mut worst, mut n, mut covered) = (0.0, 0.0f64, 0usize, 0usize);
    let mut stated = Vec::new();
    for (a, b) in x.iter().zip(r) {
        if b.0 < floor {
            continue;
        }
        let d = (a.0 - b.0).abs();
        sq += (d / b.0).powi(2);
        worst = worst.max(d / b.0);
        n += 1;
        covered += usize::from(d <= a.1 + b.1);
        if a.0 > 0.0 {
            stated.push(a.1 / a.0);
        }
    }
    stated.sort_by(f64::total_cmp);
    let median = stated.get(stated.len() / 2).copied().unwrap_or(0.0);
    if n == 0 {
        return (0.0, 0.0, median, 1.0);
    }
    (
        (sq / n as f64).sqrt(),
        worst,
        median,
        covered as f64 / n as f64,
    )
}

/// Runs every rung of `ladders` on one instant `repeats` times (at least once),
/// interleaved, and measures each against its ladder's finest rung.
/// `progress(done, total, knob, setting)` is called before each run.
///
/// # Errors
/// Bad time or sky parameters (as [`run_instant`]); [`Error::Internal`] when a repeat
/// gives other sensor values than the first run (the engine is deterministic).
pub fn run_convergence(
    scene: &Scene,
    utc: DateTime<Utc>,
    local: NaiveDateTime,
    spec: &SkySpec,
    ladders: &[Ladder],
    repeats: usize,
    progress: &dyn Fn(usize, usize, &str, &str),
) -> Result<Vec<Rung>> {
    let repeats = repeats.max(1);
    let rungs: Vec<(&Ladder, &(String, Quality, bool))> = ladders
        .iter()
        .flat_map(|l| l.rungs.iter().map(move |r| (l, r)))
        .collect();
    let total = rungs.len() * repeats;
    let mut values: Vec<Option<Vec<(f64, f64)>>> = vec![None; rungs.len()];
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); rungs.len()];
    let mut cpu: Vec<Vec<f64>> = vec![Vec::new(); rungs.len()];
    let mut done = 0;
    for _ in 0..repeats {
        for (k, (l, (setting, q, _))) in rungs.iter().enumerate() {
            progress(done, total, l.knob, setting);
            let (t0, c0) = (Instant::now(), cpu_seconds());
            let r = run_instant(scene, utc, local, spec, q)?;
            times[k].push(t0.elapsed().as_secs_f64());
            cpu[k].push(cpu_seconds() - c0);
            let v: Vec<(f64, f64)> = r.sensors.iter().map(|s| (s.lux, s.lux_err)).collect();
            match &values[k] {
                Some(first) if *first != v => {
                    return Err(Error::Internal(format!(
                        "convergence: {} {setting} gave other values when repeated",
                        l.knob
                    )))
                }
                Some(_) => {}
                None => values[k] = Some(v),
            }
            done += 1;
        }
    }
    progress(done, total, "", "");
    let mut out = Vec::new();
    let mut k = 0;
    for l in ladders {
        let n = l.rungs.len();
        let finest = values[k + n - 1].clone().unwrap_or_default();
        for (j, (setting, _, is_base)) in l.rungs.iter().enumerate() {
            let v = values[k + j].as_deref().unwrap_or_default();
            let (rms, max, stated, covered) = compare(v, &finest);
            let mut t = times[k + j].clone();
            t.sort_by(f64::total_cmp);
            let mut c = cpu[k + j].clone();
            c.sort_by(f64::total_cmp);
            out.push(Rung {
                knob: l.knob.into(),
                setting: setting.clone(),
                seconds: median(&t),
                cpu_seconds: median(&c),
                cpu_seconds_min: c[0],
                cpu_seconds_max: c[c.len() - 1],
                repeats: t.len(),
                rms_rel_err: rms,
                max_rel_err: max,
                stated_rel_err: stated,
                covered,
                is_base: *is_base,
                is_reference: j + 1 == n,
            });
        }
        k += n;
    }
    Ok(out)
}

/// CPU time this process has used so far (user + system, all threads), s; where the
/// system cannot tell, wall time since the first call.
fn cpu_seconds() -> f64 {
    match cpu_time::ProcessTime::try_now() {
        Ok(t) => t.as_duration().as_secs_f64(),
        Err(_) => {
            static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
            START.get_or_init(Instant::now).elapsed().as_secs_f64()
        }
    }
}

/// Median of sorted, non-empty `t`.
fn median(t: &[f64]) -> f64 {
    let n = t.len();
    if n % 2 == 1 {
        t[n / 2]
    } else {
        0.5 * (t[n / 2 - 1] + t[n / 2])
    }
}

/// The setting a ladder recommends within `target`: among the rungs within it, the
/// cheapest by median CPU time; then, among the rungs within target whose cost cannot be told
/// apart from that one's ([`Rung::same_cost`]), the most accurate (the finer on a tie).
fn pick<'a>(ladder: &[&'a Rung], target: f64) -> Option<&'a Rung> {
    let within: Vec<&Rung> = ladder
        .iter()
        .copied()
        .filter(|r| r.rms_rel_err <= target)
        .collect();
    let cheapest = within
        .iter()
        .copied()
        .min_by(|a, b| a.cpu_seconds.total_cmp(&b.cpu_seconds))?;
    within
        .iter()
        .copied()
        .filter(|r| r.same_cost(cheapest))
        .min_by(|a, b| {
            a.rms_rel_err
                .total_cmp(&b.rms_rel_err)
                .then(std::cmp::Ordering::Greater)
        })
}

/// The plot's curves: one per knob, a point per rung.
pub fn curves(rungs: &[Rung]) -> Vec<Curve> {
    let mut out: Vec<Curve> = Vec::new();
    for r in rungs {
        if out.last().is_none_or(|c| c.name != r.knob) {
            out.push(Curve {
                name: r.knob.clone(),
                points: Vec::new(),
            });
        }
        if let Some(c) = out.last_mut() {
            c.points.push(crate::export::plot::Point {
                seconds: r.cpu_seconds,
                seconds_min: r.cpu_seconds_min,
                seconds_max: r.cpu_seconds_max,
                rel_err: r.rms_rel_err,
                is_base: r.is_base,
                reference: r.is_reference.then(|| r.setting.clone()),
            });
        }
    }
    out
}

/// `convergence.csv`: `knob,setting,seconds,rms_rel_err,max_rel_err,stated_rel_err,covered,base,
/// cpu_seconds,cpu_seconds_min,cpu_seconds_max,repeats,reference` (`seconds` is the median
/// wall time, `cpu_seconds` the median CPU time, the cost; `reference` marks each ladder's
/// finest rung, whose error is 0 by construction).
pub fn csv(rungs: &[Rung]) -> String {
    let mut s = String::from(
        "knob,setting,seconds,rms_rel_err,max_rel_err,stated_rel_err,covered,base,\
         cpu_seconds,cpu_seconds_min,cpu_seconds_max,repeats,reference\n",
    );
    for r in rungs {
        s.push_str(&format!(
            "{},{},{:.4},{:.6},{:.6},{:.6},{:.4},{},{:.4},{:.4},{:.4},{},{}\n",
            r.knob,
            r.setting.replace(',', ";"),
            r.seconds,
            r.rms_rel_err,
            r.max_rel_err,
            r.stated_rel_err,
            r.covered,
            r.is_base,
            r.cpu_seconds,
            r.cpu_seconds_min,
            r.cpu_seconds_max,
            r.repeats,
            r.is_reference
        ));
    }
    s
}

/// A paragraph for the terminal: which knob limits the base preset, the cheapest rung of
/// each knob within `target` (relative RMS), and the cheapest preset within it.
pub fn recommendation(rungs: &[Rung], target: f64) -> String {
    let mut knobs: Vec<&str> = Vec::new();
    for r in rungs {
        if !knobs.contains(&r.knob.as_str()) {
            knobs.push(&r.knob);
        }
    }
    let mut worst: Option<&Rung> = None;
    let mut lines = Vec::new();
    for k in knobs.iter().filter(|k| **k != "presets") {
        let ladder: Vec<&Rung> = rungs.iter().filter(|r| r.knob == *k).collect();
        if let Some(b) = ladder.iter().find(|r| r.is_base) {
            if worst.is_none_or(|w| b.rms_rel_err > w.rms_rel_err) {
                worst = Some(b);
            }
        }
        if let Some(c) = pick(&ladder, target) {
            lines.push(format!(
                "{k}: {} ({:.1} CPU s, {:.1}–{:.1})",
                c.setting, c.cpu_seconds, c.cpu_seconds_min, c.cpu_seconds_max
            ));
        }
    }
    let mut s = String::new();
    if let Some(w) = worst {
        s.push_str(&format!(
            "The base preset's error is dominated by {} ({}: {:.1} % RMS against its finest setting); refine that knob first. ",
            w.knob,
            w.setting,
            100.0 * w.rms_rel_err
        ));
    }
    if !lines.is_empty() {
        s.push_str(&format!(
            "Cheapest setting within {:.1} % per knob (median CPU time of the repeats, spread; costs whose spreads overlap count as equal, and the more accurate is named): {}. ",
            100.0 * target,
            lines.join("; ")
        ));
    }
    let presets: Vec<&Rung> = rungs.iter().filter(|r| r.knob == "presets").collect();
    if let Some(p) = pick(&presets, target) {
        s.push_str(&format!(
            "Of the presets, `{}` is the cheapest within {:.1} % of `reference` ({:.1} % RMS, {:.1} CPU s; stated error {:.1} %, covering {:.0} % of sensors).",
            p.setting,
            100.0 * target,
            100.0 * p.rms_rel_err,
            p.cpu_seconds,
            100.0 * p.stated_rel_err,
            100.0 * p.covered
        ));
    }
    s
}

/// Writes a finished study into `out` (created if missing): `convergence.csv`,
/// `convergence.svg` (error against time per knob, titled with `scene`) and `report.json`
/// (the rungs, `instant` as described by the caller, the base preset, `target` and the
/// recommendation). `target` is the relative RMS error aimed at (0.02 = 2 %). Returns the
/// recommendation, as [`recommendation`].
///
/// # Errors
/// [`crate::Error::Io`] naming the file or folder that could not be written;
/// [`crate::Error::Internal`] when the plot or report cannot be made.
pub fn write_convergence(
    out: &Path,
    scene: &Path,
    instant: &str,
    base: &Quality,
    target: f64,
    rungs: &[Rung],
) -> Result<String> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    crate::files::write_atomic(&out.join("convergence.csv"), csv(rungs).as_bytes())?;
    let title = format!(
        "{}: error against time per knob (base `{}`, ringed)",
        scene.display(),
        base.name
    );
    crate::export::plot::error_vs_time_svg(&out.join("convergence.svg"), &title, &curves(rungs))?;
    let advice = recommendation(rungs, target);
    let report = serde_json::json!({
        "version": env!("CARGO_PKG_VERSION"),
        "scene": scene.display().to_string(),
        "instant": instant,
        "base": base.name,
        "target_rel_err": target,
        "rungs": rungs,
        "recommendation": advice,
    });
    crate::files::write_atomic(
        &out.join("report.json"),
        serde_json::to_string_pretty(&report)
            .map_err(|e| Error::Internal(format!("report: {e}")))?
            .as_bytes(),
    )?;
    Ok(advice)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_are_relative_to_the_finest_rung_over_lit_sensors() {
        let finest = [(1000.0, 10.0), (500.0, 5.0), (1.0, 0.1)];
        let x = [(1010.0, 5.0), (450.0, 60.0), (100.0, 0.0)];
        let (rms, max, stated, covered) = compare(&x, &finest);
        // The 1 lx sensor is below the floor and ignored.
        let expect = ((0.01f64.powi(2) + 0.1f64.powi(2)) / 2.0).sqrt();
        assert!((rms - expect).abs() < 1e-12);
        assert!((max - 0.1).abs() < 1e-12);
        // Both differences are covered: 10 ≤ 5 + 10 and 50 ≤ 60 + 5.
        assert_eq!(covered, 1.0);
        assert!((stated - 60.0 / 450.0).abs() < 1e-12);
    }

    #[test]
    fn every_ladder_runs_coarse_to_fine_and_marks_the_base() {
        let base = Quality::default();
        for l in ladders(&base) {
            assert!(l.rungs.len() >= 4, "{}", l.knob);
            let n_base = l.rungs.iter().filter(|r| r.2).count();
            assert_eq!(n_base, 1, "{} has {n_base} base rungs", l.knob);
        }
    }

    /// A rung timed at `s` ± 5 %.
    fn rung(knob: &str, setting: &str, s: f64, e: f64, base: bool) -> Rung {
        Rung {
            knob: knob.into(),
            setting: setting.into(),
            seconds: s,
            cpu_seconds: s,
            cpu_seconds_min: 0.95 * s,
            cpu_seconds_max: 1.05 * s,
            repeats: 3,
            rms_rel_err: e,
            max_rel_err: e,
            stated_rel_err: e,
            covered: 1.0,
            is_base: base,
            is_reference: e == 0.0,
        }
    }

    #[test]
    fn costs_within_the_timing_spread_are_equal_and_the_more_accurate_wins() {
        // The case: 1e-4 measured faster than 1e-1 by noise alone.
        let mut fine = rung("iteration tolerance", "1e-4", 5.52, 0.0, false);
        let mut coarse = rung("iteration tolerance", "1e-1", 5.79, 0.012, false);
        (fine.cpu_seconds_min, fine.cpu_seconds_max) = (5.3, 6.1);
        (coarse.cpu_seconds_min, coarse.cpu_seconds_max) = (5.4, 6.0);
        let mid = rung("iteration tolerance", "1e-2", 5.6, 0.004, true);
        let ladder = [&coarse, &mid, &fine];
        assert!(coarse.same_cost(&fine));
        assert_eq!(pick(&ladder, 0.02).unwrap().setting, "1e-4");
        // Clearly cheaper (spreads apart) and within target: the cheap one.
        let cheap = rung("sun snapping", "2 deg", 2.0, 0.015, false);
        let dear = rung("sun snapping", "0.05 deg", 9.0, 0.0, false);
        assert_eq!(pick(&[&cheap, &dear], 0.02).unwrap().setting, "2 deg");
        // Outside target: never picked, however cheap.
        assert_eq!(pick(&[&cheap, &dear], 0.01).unwrap().setting, "0.05 deg");
        // The order of the timings does not change the answer: the same pick whichever of
        // the equal-cost rungs happened to time fastest.
        (fine.cpu_seconds, coarse.cpu_seconds) = (5.9, 5.5);
        assert_eq!(pick(&[&coarse, &mid, &fine], 0.02).unwrap().setting, "1e-4");
    }

    #[test]
    fn recommendation_names_the_dominant_knob_and_the_cheapest_preset() {
        let r =
            |knob: &str, setting: &str, s: f64, e: f64, base: bool| rung(knob, setting, s, e, base);
        let rungs = [
            r("sky subdivision", "default sky", 1.0, 0.004, true),
            r("interreflection lines", "256 directions", 0.5, 0.05, false),
            r("interreflection lines", "1024 directions", 1.0, 0.015, true),
            r("presets", "draft", 0.5, 0.03, false),
            r("presets", "default", 1.0, 0.012, true),
            r("presets", "reference", 9.0, 0.0, false),
        ];
        let s = recommendation(&rungs, 0.02);
        assert!(s.contains("dominated by interreflection lines"), "{s}");
        assert!(s.contains("`default` is the cheapest"), "{s}");
    }
}
