//! What an annual run is asked ([`AnnualOptions`]), how its caller steers it
//! ([`RunControl`]) and what it reports ([`AnnualReport`]); the run is
//! [`super::annual::run_annual`].

use crate::metrics::MetricParams;
use chrono::NaiveDate;
use serde::Serialize;
use std::sync::atomic::AtomicBool;

/// What an annual run is asked to do besides the defaults.
#[derive(Clone, Debug)]
pub struct AnnualOptions {
    /// First day included (local date), if not the file's first.
    pub start: Option<NaiveDate>,
    /// Last day included, if not the file's last.
    pub end: Option<NaiveDate>,
    /// Shard k of n (1-based k); (1, 1) for a whole run.
    pub shard: (u32, u32),
    /// Annual metric thresholds.
    pub metrics: MetricParams,
    /// Also write a Radiance/DAYSIM-style `illuminance.ill`.
    pub ill: bool,
    /// Daylight coefficients (the default): each sky node's and sun-grid vertex's response
    /// is computed once and cached, and a step is a sum over its sources. False makes
    /// every step a warm-started forward solve (what `--surfaces` needs).
    pub daylight_coefficients: bool,
    /// Resident memory the run may use (`None`: no cap; `--max-memory`): the daylight
    /// coefficients' adjoint blocks are sized to it
    /// ([`super::coefficients::adjoint_budget`]). Results do not depend on it.
    pub max_memory: Option<crate::memory::MemoryCap>,
    /// Also write `surfaces.csv` (per group: incident irradiance, transmitted solar power).
    pub surfaces: bool,
    /// LEED v4.1 Daylight Option 1 with operable blinds: `leed.json`, `leed_blinds.csv`,
    /// `leed_sensors.csv` (each aperture group's light path written under `paths/`).
    pub leed: bool,
    /// EN 17037 daylight provision: `en17037.json` (a whole hourly year).
    pub en17037: bool,
}

impl Default for AnnualOptions {
    fn default() -> Self {
        AnnualOptions {
            start: None,
            end: None,
            shard: (1, 1),
            metrics: MetricParams::default(),
            ill: false,
            daylight_coefficients: true,
            max_memory: None,
            surfaces: false,
            leed: false,
            en17037: false,
        }
    }
}

/// Counters and timings of an annual run (`report.json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct AnnualReport {
    /// daystep version.
    pub version: String,
    /// Scene file.
    pub scene: String,
    /// Weather file.
    pub weather: String,
    /// Quality preset.
    pub quality: String,
    /// Shard "k/n".
    pub shard: String,
    /// Timesteps in the run (this shard).
    pub steps: usize,
    /// Steps computed now (not resumed from an earlier run).
    pub computed: usize,
    /// Steps taken from the output of an interrupted earlier run.
    pub resumed: usize,
    /// Steps skipped because the sun was down and the sky dark.
    pub night: usize,
    /// Steps skipped because the weather record had missing irradiance.
    pub missing: usize,
    /// Steps with the sun above the horizon and direct-normal irradiance > 0.
    pub sun_steps: usize,
    /// Distinct directions: computed, read from the cache, reused in memory.
    pub directions: super::directions::DirectionCounts,
    /// Projection cache counters.
    pub cache: crate::cache::CacheStats,
    /// Whether the interreflection operator came from the cache (false also when the run
    /// did not need it: every daylight coefficient was cached, `coefficients`).
    pub operator_from_cache: bool,
    /// What computing (or reading) the daylight coefficients did, when the steps use them.
    pub coefficients: Option<super::coefficients::CoefficientStats>,
    /// How each step's interreflection was computed: "daylight coefficients" (per node
    /// and sun-grid vertex, computed once, [`super::coefficients`]), "forward" (a
    /// warm-started solve per step: surface output, emitters, or asked for) or "none".
    pub interreflection: String,
    /// Gauss–Seidel sweeps over all steps, and of the cold first steps of the days.
    pub sweeps: u64,
    /// Wall time per stage, s (summed over threads where stages run in parallel).
    pub stage_seconds: Vec<(String, f64)>,
    /// Wall time, s.
    pub total_seconds: f64,
    /// Median over lit sensor-steps (> 10 lx) of the stated relative error.
    pub median_relative_err: f64,
    /// 95th percentile of the same.
    pub p95_relative_err: f64,
    /// What was left out and why.
    pub skipped: Vec<String>,
    /// Warnings.
    pub warnings: Vec<String>,
    /// The imported model's grids, views and aperture groups, when it has any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<super::report::ModelReport>,
    /// What `--leed` / `--en17037` did, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compliance: Option<super::compliance::ComplianceReport>,
    /// Whether the run was stopped before its end (Ctrl-C); rerun to continue.
    pub interrupted: bool,
    /// The memory cap, the peak resident memory and each stage's peak.
    pub memory: super::report::MemoryReport,
}

/// How a caller steers a long run: `stop` is polled between batches of days (set it from
/// a Ctrl-C handler); `progress(done, total)` is called after each batch, and
/// `coefficient_progress` while the daylight coefficients are computed before the first
/// step (a cold run's longest stage: 15 minutes on a 10 000-sensor building day).
pub struct RunControl<'a> {
    /// Set to stop after the batch in flight.
    pub stop: &'a AtomicBool,
    /// Called with (steps done, steps in the run).
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Called with (direction passes done, passes in all) while the daylight coefficients
    /// are computed: one pass applies a sensor block's adjoint responses to one
    /// direction ([`super::step::Engine::prepare`]). Not called when every coefficient is
    /// cached.
    pub coefficient_progress: &'a (dyn Fn(usize, usize) + Sync),
}
