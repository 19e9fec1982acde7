//! The run report (`report.json`): stage times, counts, what was skipped and why.

use serde::Serialize;
use std::time::Instant;

/// Wall time of each pipeline stage, seconds, in the order they ran.
#[derive(Clone, Debug, Default, Serialize)]
pub struct StageTimes(pub Vec<(String, f64)>);

impl StageTimes {
    /// Runs `f`, adding its wall time to the stage `name`.
    pub fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let t0 = Instant::now();
        let r = f();
        self.add(name, t0.elapsed().as_secs_f64());
        r
    }
    /// Adds `seconds` to the stage `name` (appended when new): a sequence's stages sum
    /// over its steps.
    pub fn add(&mut self, name: &str, seconds: f64) {
        match self.0.iter_mut().find(|(n, _)| n == name) {
            Some((_, v)) => *v += seconds,
            None => self.0.push((name.to_owned(), seconds)),
        }
    }
    /// Adds every stage of `other` ([`Self::add`]).
    pub fn merge(&mut self, other: &StageTimes) {
        for (n, s) in &other.0 {
            self.add(n, *s);
        }
    }
    /// Sum of all stages, seconds.
    pub fn total(&self) -> f64 {
        self.0.iter().map(|(_, t)| t).sum()
    }
}

/// Memory of a run (`report.json` `memory`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct MemoryReport {
    /// The cap the run was given, bytes (0: none).
    pub max_memory_bytes: u64,
    /// Where the cap came from (`--max-memory 4G`, `80 % of MemAvailable`).
    pub max_memory_from: String,
    /// Peak resident memory of the process, bytes (Linux `VmHWM`; 0 where it cannot be
    /// read).
    pub peak_bytes: u64,
    /// Peak resident memory per stage (set-up stages, then the caller's), bytes; a stage
    /// includes the stages run inside it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub stage_peak_bytes: Vec<(String, u64)>,
}

impl MemoryReport {
    /// The report of a run capped at `cap` (bytes, 0: none; `from`: where the cap came
    /// from), with the stages `peaks` measured.
    pub fn of(cap: u64, from: &str, peaks: Option<&crate::memory::StagePeaks>) -> MemoryReport {
        MemoryReport {
            max_memory_bytes: cap,
            max_memory_from: from.to_owned(),
            peak_bytes: crate::memory::peak_resident_bytes().unwrap_or(0),
            stage_peak_bytes: peaks.map(|p| p.stages()).unwrap_or_default(),
        }
    }
}

/// Sun details of an instant.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SunReport {
    /// Apparent altitude, degrees.
    pub altitude_deg: f64,
    /// Azimuth clockwise from north, degrees.
    pub azimuth_deg: f64,
    /// Whether the sun was used as a source.
    pub used: bool,
    /// Angle between the true and the snapped sun direction, degrees.
    pub snapping_error_deg: f64,
    /// Largest shadow-edge shift the snapping can cause across the scene, m
    /// (scene diagonal × snapping error).
    pub max_shadow_shift_m: f64,
}

/// Counts of one run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Counts {
    /// Sky-triangle sources.
    pub sky_sources: usize,
    /// Ground-glow sources.
    pub ground_sources: usize,
    /// 1 when the sun was a source.
    pub sun_sources: usize,
    /// Sources left out for negligible energy.
    pub negligible_sources: usize,
    /// LDIs built (one per source).
    pub ldis_built: usize,
    /// LDIs reused from a cache.
    pub ldis_reused: usize,
    /// Total LDI pixels.
    pub ldi_pixels: u64,
    /// Total LDI fragments.
    pub ldi_fragments: u64,
    /// Largest LDI (width × height).
    pub ldi_max_size: (u32, u32),
    /// Faces before refinement: the model's triangles plus their back faces.
    pub elements_before: usize,
    /// Back faces added for two-sided surfaces (`faces = "both"`, the default).
    pub back_faces: usize,
    /// Leaves of the refined hierarchy (elements after refinement).
    pub elements_after: usize,
    /// Leaves after the sun's projection alone.
    pub elements_after_sun: usize,
    /// Patch splits summed over all projections.
    pub splits: u64,
    /// Sensors.
    pub sensors: usize,
    /// Rays cast for sensors (fine + coarse estimate).
    pub sensor_rays: u64,
    /// Zero-area input triangles dropped.
    pub degenerate_triangles_dropped: usize,
    /// Input triangles cut where walls stand on them, so that no mesh element spans a
    /// wall's foot.
    pub junction_triangles_cut: usize,
    /// Triangles added by those cuts (included in `elements_before`).
    pub junction_triangles_added: usize,
    /// Interreflection operators read from the cache instead of built.
    pub operators_reused: usize,
}

/// What an imported model brought besides geometry (`report.json` `model`): its sensor
/// grids, views and aperture groups.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ModelReport {
    /// Sensor grids of the run, in sensor order: identifier, room, number of sensors.
    pub sensor_grids: Vec<GridReport>,
    /// Identifiers of the model's views (`render --view-name`).
    pub views: Vec<String>,
    /// Aperture groups: identifier, the identifiers of their apertures, and their states'
    /// modifiers (`"default"`: the aperture's own).
    pub aperture_groups: Vec<ApertureGroupReport>,
    /// Rooms of the model, in model order.
    pub rooms: Vec<String>,
    /// Bad geometry met on import (each also a warning naming the object).
    pub bad_geometry: BadGeometryReport,
}

/// One aperture group in [`ModelReport`].
#[derive(Clone, Debug, Default, Serialize)]
pub struct ApertureGroupReport {
    /// The group's identifier.
    pub identifier: String,
    /// Identifiers of its apertures, in model order.
    pub members: Vec<String>,
    /// Its states' modifiers, in order.
    pub states: Vec<String>,
    /// The shaded state's diffuse visible transmittance, where the scene file gives it.
    pub shade_transmittance: Option<f64>,
}

/// Counts of bad geometry in [`ModelReport`].
#[derive(Clone, Debug, Default, Serialize)]
pub struct BadGeometryReport {
    /// Polygons enclosing no area.
    pub zero_area: usize,
    /// Polygons further from planar than the model's tolerance.
    pub non_planar: usize,
    /// Polygons whose outline crosses itself.
    pub self_intersecting: usize,
    /// Apertures and doors not inside their parent face.
    pub apertures_outside_parent: usize,
}

/// One sensor grid in [`ModelReport`].
#[derive(Clone, Debug, Default, Serialize)]
pub struct GridReport {
    /// The grid's identifier.
    pub identifier: String,
    /// Its room, where the model says.
    pub room: Option<String>,
    /// Its number of sensors.
    pub sensors: usize,
}

impl ModelReport {
    /// The scene's grids, views and aperture groups; `None` when it has none of them.
    pub fn of(scene: &crate::scene::Scene) -> Option<ModelReport> {
        let m = &scene.imported;
        if scene.grids.is_empty() && *m == Default::default() {
            return None;
        }
        let c = m.counts;
        Some(ModelReport {
            sensor_grids: scene
                .grids
                .iter()
                .map(|g| GridReport {
                    identifier: g.identifier.clone(),
                    room: g.room.clone(),
                    sensors: g.sensors.len(),
                })
                .collect(),
            views: m.views.iter().map(|v| v.identifier.clone()).collect(),
            aperture_groups: m
                .aperture_groups
                .iter()
                .map(|g| ApertureGroupReport {
                    identifier: g.identifier.clone(),
                    members: g.members.clone(),
                    states: g.states.clone(),
                    shade_transmittance: g.shade_transmittance,
                })
                .collect(),
            rooms: m.rooms.clone(),
            bad_geometry: BadGeometryReport {
                zero_area: c.zero_area,
                non_planar: c.non_planar,
                self_intersecting: c.self_intersecting,
                apertures_outside_parent: c.apertures_outside_parent,
            },
        })
    }
}

/// Everything `report.json` says about a run.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    /// daystep version.
    pub version: String,
    /// Command or API entry point.
    pub command: String,
    /// Scene file.
    pub scene: String,
    /// Local standard time of the instant.
    pub time_local: String,
    /// The instant in UTC (RFC 3339).
    pub time_utc: String,
    /// Sky description.
    pub sky: String,
    /// Quality preset name.
    pub quality: String,
    /// Sun details.
    pub sun: SunReport,
    /// Counts.
    pub counts: Counts,
    /// Stage wall times, seconds.
    pub stage_seconds: StageTimes,
    /// Total wall time, seconds.
    pub total_seconds: f64,
    /// Steps left out and why.
    pub skipped: Vec<String>,
    /// Non-fatal remarks.
    pub warnings: Vec<String>,
    /// The imported model's grids, views and aperture groups, when it has any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<ModelReport>,
    /// How `lux_err` is estimated.
    pub error_model: String,
    /// Projection cache counters (hits, misses, rebuilds, bytes mapped), when a run went
    /// through a cache store.
    pub cache: Option<crate::cache::CacheStats>,
    /// The global-line operator's build counters, when that solver ran.
    pub transport: Option<crate::radiosity::TransportStats>,
    /// The global-line solve (sweeps, iteration error), when that solver ran.
    pub transport_solve: Option<crate::radiosity::TransportReport>,
    /// Largest `lux_err` over sensors, lux.
    pub max_lux_err: f64,
    /// Largest `lux_err / lux` over sensors with lux > 1.
    pub max_relative_err: f64,
    /// The memory cap and the peak resident memory (set by the caller that knows the
    /// cap).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<MemoryReport>,
}
