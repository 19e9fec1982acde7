//! Run configuration: the sky of an instant and the quality presets that set every knob
//! trading error against time.

use crate::projection::ProjectionParams;
use crate::radiosity::TransportParams;
use crate::sensors::SensorParams;
use crate::sources::SkyParams;
use serde::{Deserialize, Serialize};

/// Which sky to build for an instant (`--sky`, docs/commands.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case")]
pub enum SkySpec {
    /// Perez all-weather sky with sun from direct-normal and diffuse-horizontal irradiance.
    Perez {
        /// Direct-normal irradiance, W/m².
        dni: f64,
        /// Diffuse-horizontal irradiance, W/m².
        dhi: f64,
        /// Dew point, °C (sets precipitable water in the luminous efficacy).
        dew_point_c: Option<f64>,
    },
    /// Traditional CIE overcast sky (Moon–Spencer), horizontal irradiance = `dhi`, no sun.
    CieOvercast {
        /// Diffuse-horizontal irradiance, W/m².
        dhi: f64,
    },
    /// CIE standard general sky type 1..=15 normalised to `dhi`, with sun when `dni` > 0.
    Cie {
        /// Sky type 1..=15.
        sky_type: u8,
        /// Diffuse-horizontal irradiance, W/m².
        dhi: f64,
        /// Direct-normal irradiance, W/m².
        dni: f64,
    },
    /// Preetham clear sky with sun, absolute luminance.
    Preetham {
        /// Atmospheric turbidity (valid 2..10).
        turbidity: f64,
    },
    /// No daylight.
    None,
}

impl SkySpec {
    /// Direct-normal and diffuse-horizontal irradiance (W/m²) the sky is normalised to,
    /// where it has them (Preetham's absolute sky has none).
    pub fn irradiance(&self) -> Option<(f64, f64)> {
        match *self {
            SkySpec::Perez { dni, dhi, .. } | SkySpec::Cie { dni, dhi, .. } => Some((dni, dhi)),
            SkySpec::CieOvercast { dhi } => Some((0.0, dhi)),
            SkySpec::Preetham { .. } => None,
            SkySpec::None => Some((0.0, 0.0)),
        }
    }
}

/// Every knob of a run, grouped by pipeline step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Quality {
    /// Preset name this came from.
    pub name: &'static str,
    /// Sky subdivision.
    pub sky: SkyParams,
    /// Sun snapping grid spacing, degrees.
    pub sun_spacing_deg: f64,
    /// Spacing of the grid the sun's interreflected light is interpolated on in annual
    /// runs (daylight coefficients), degrees ([`crate::sources::SunGrid`]).
    pub sun_grid_deg: f64,
    /// Depth of the sky and ground nodes whose interreflected light annual runs compute
    /// (daylight coefficients): a deeper node takes its ancestor's at this depth, and its
    /// first-order change (from the slope to the ancestor's siblings) is stated as error.
    /// Interreflection is smooth in direction; the cut refines for the direct light.
    pub indirect_depth: u32,
    /// LDI and refinement.
    pub projection: ProjectionParams,
    /// Sensor gather (direct).
    pub sensors: SensorParams,
    /// The interreflection: global-line operator, its sensor gather and its solve.
    pub transport: TransportParams,
}

impl Quality {
    /// A preset by name: `draft`, `default`, `high`, `reference`.
    pub fn preset(name: &str) -> Option<Quality> {
        let base = Quality {
            name: "default",
            sky: SkyParams::default(),
            sun_spacing_deg: 0.25,
            sun_grid_deg: 3.0,
            indirect_depth: 3,
            projection: ProjectionParams::default(),
            sensors: SensorParams::default(),
            // Measured on the office against path tracing (docs/design.md): 1 024 directions at
            // 256 px: 1.6 % RMS indirect error in 0.9 s.
            transport: TransportParams {
                directions: 1024,
                resolution: 256,
                ..TransportParams::default()
            },
        };
        let q = match name {
            "default" => base,
            "draft" => Quality {
                name: "draft",
                sky: SkyParams {
                    min_depth: 1,
                    max_depth: 3,
                    ground_horizon_depth: 3,
                    sky_horizon_depth: 3,
                    ..base.sky
                },
                sun_spacing_deg: 1.0,
                sun_grid_deg: 6.0,
                // Its deepest level: every node solved. At depth 2 (22° ancestors) the
                // stated error covered 86 % of the office's sensor-steps, not 95 %.
                indirect_depth: 3,
                // Coarse LDIs misplace the sun patch on the elements, and the indirect light
                // inherits it (measured: 16 % on the office); projections are cheap.
                projection: base.projection,
                sensors: SensorParams {
                    visibility_depth: 4,
                    visibility_tolerance: 0.02,
                    sample_angle_deg: 8.0,
                },
                // 256 directions: 4.5 % RMS indirect error on the office in 0.3 s.
                transport: TransportParams {
                    directions: 256,
                    gather_rays: 2048,
                    ..base.transport
                },
            },
            "high" => Quality {
                name: "high",
                sky: SkyParams {
                    min_depth: 3,
                    max_depth: 6,
                    min_solid_angle_sr: 5e-4,
                    max_irradiance_fraction: 0.004,
                    ground_depth: 2,
                    ground_horizon_depth: 5,
                    sky_horizon_depth: 5,
                    ..base.sky
                },
                sun_spacing_deg: 0.1,
                sun_grid_deg: 1.5,
                indirect_depth: 4,
                projection: ProjectionParams {
                    max_resolution: 2048,
                    min_resolution: 128,
                    v_min: 0.01,
                    v_max: 0.99,
                    min_area_m2: 5e-4,
                    ..base.projection
                },
                sensors: SensorParams {
                    visibility_depth: 7,
                    visibility_tolerance: 0.002,
                    sample_angle_deg: 2.0,
                },
                transport: TransportParams {
                    directions: 4096,
                    gather_rays: 16384,
                    ..base.transport
                },
            },
            "reference" => Quality {
                name: "reference",
                sky: SkyParams {
                    min_depth: 4,
                    max_depth: 7,
                    min_solid_angle_sr: 1e-4,
                    max_irradiance_fraction: 0.001,
                    ground_depth: 3,
                    ground_horizon_depth: 6,
                    sky_horizon_depth: 6,
                    ..base.sky
                },
                sun_spacing_deg: 0.05,
                sun_grid_deg: 1.0,
                indirect_depth: 5,
                projection: ProjectionParams {
                    max_resolution: 4096,
                    min_resolution: 256,
                    v_min: 0.005,
                    v_max: 0.995,
                    min_area_m2: 2.5e-4,
                    // As fine as this preset's interreflection mesh.
                    partial_area_m2: 0.1,
                    ..base.projection
                },
                sensors: SensorParams {
                    visibility_depth: 8,
                    visibility_tolerance: 0.0005,
                    sample_angle_deg: 1.0,
                },
                transport: TransportParams {
                    directions: 8192,
                    resolution: 512,
                    element_area_m2: 0.1,
                    gather_rays: 65536,
                    ..base.transport
                },
            },
            _ => return None,
        };
        Some(q)
    }

    /// The same preset with every random stream derived from `seed`.
    pub fn with_seed(mut self, seed: u64) -> Quality {
        self.transport.seed = seed;
        self
    }

    /// The same run one level coarser in every knob that affects sensors: the reference
    /// for the discretisation-error estimate.
    pub fn coarser(&self) -> Quality {
        Quality {
            sky: self.sky.coarser(),
            sun_spacing_deg: self.sun_spacing_deg * 2.0,
            sun_grid_deg: self.sun_grid_deg * 2.0,
            sensors: SensorParams {
                visibility_depth: self.sensors.visibility_depth.saturating_sub(1),
                visibility_tolerance: self.sensors.visibility_tolerance * 2.0,
                sample_angle_deg: self.sensors.sample_angle_deg * 2.0,
            },
            ..*self
        }
    }
}

impl Default for Quality {
    fn default() -> Self {
        Quality::preset("default").expect("default preset exists")
    }
}
