//! The types a timestep's callers pass and get back ([`super::step`]): the run's options,
//! the step's time and what one step produces.

use super::estimate::SensorValue;
use super::report::Report;
use crate::hierarchy::Hierarchy;
use crate::photometry::Rgb;
use crate::radiosity::TransportState;
use crate::sky::Sky;
use crate::sources::Source;
use crate::transfer::DirectIrradiance;
use chrono::{DateTime, NaiveDateTime, Utc};

/// What a run asks of its steps besides sensor values.
#[derive(Clone, Copy, Debug, Default)]
pub struct EngineOptions {
    /// Per-group surface irradiance and transmitted power (`surfaces.csv`): needs the mesh
    /// solution, so every step solves forward.
    pub surfaces: bool,
    /// Resident memory the run may use, bytes (0: no cap; `--max-memory`). The daylight
    /// coefficients' adjoint blocks are sized to what is left of it
    /// ([`super::step::Engine::prepare`]); results do not depend on it.
    pub max_memory_bytes: u64,
    /// The user gave the cap (`--max-memory`): the adjoint blocks may fill it. Under the
    /// machine's default cap they stop at [`super::coefficients::RESPONSE_MAX_BYTES`].
    pub max_memory_given: bool,
    /// Do not read or build the interreflection operator in [`super::step::Engine::new`]:
    /// [`super::step::Engine::prepare`] reads it only when some daylight coefficients are missing (a
    /// warm annual run never needs it), or when the steps will solve forward after all.
    pub defer_operator: bool,
    /// Every step's mesh solution is wanted (renders gather from it): the operator is
    /// built even without sensors, and steps solve forward.
    pub mesh_solution: bool,
    /// Only the values, no error estimate: daylight-coefficient steps skip the coarser
    /// level (its sources, sun and sky responses) and every sum that feeds only the error,
    /// and keep only the coefficients the values need, so `lux_err` is not stated (0). The
    /// light paths of `annual --leed`, whose run states the error.
    pub values_only: bool,
    /// A step asked for its refined elements only counts them
    /// ([`crate::hierarchy::union_leaf_count`]) and returns none: `daystep instant` reports
    /// the count and writes nothing per element, and the arena took a quarter of a large
    /// building's instant (230 MB of 920 MB on the corridor building).
    pub count_elements_only: bool,
}

/// When a step is: the instant in UTC and the site's local standard time.
#[derive(Clone, Copy, Debug)]
pub struct StepTime {
    /// The instant, UTC.
    pub utc: DateTime<Utc>,
    /// Local standard time of the site (day of year for the sky models).
    pub local: NaiveDateTime,
}

/// Everything one step produces.
pub struct Step {
    /// Per sensor, in .pts order.
    pub sensors: Vec<SensorValue>,
    /// The interreflection solution, to warm-start the next step (forward solves only).
    pub state: Option<TransportState>,
    /// Per-group surface values of the step ([`super::surfaces::SurfaceMap::values`]; empty unless asked).
    pub surfaces: Vec<f64>,
    /// The sky of the step, when [`super::step::Engine::step`] built it.
    pub sky: Option<Sky>,
    /// The sources used.
    pub sources: Vec<Source>,
    /// The refined element hierarchy and each element's direct irradiance, when asked
    /// (`detail`).
    pub elements: Option<(Hierarchy, DirectIrradiance)>,
    /// Per sensor, the stated error of interpolating the sun's interreflected light on
    /// the sun grid, lux (included in `lux_err`; empty for forward steps).
    pub sun_interpolation_err: Vec<f64>,
    /// The step's report: sun, counts, stage times, what was skipped, the solve.
    pub report: Report,
    /// Per mesh row, the direct irradiance (RGB W/m²) the solve started from, when
    /// [`EngineOptions::mesh_solution`] asked for the mesh solution (else empty).
    pub mesh_direct: Vec<Rgb>,
}
