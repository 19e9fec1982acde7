//! L2 sky models: radiance arriving from any direction for one instant, plus the sun as a
//! parallel source. Units are Radiance's: RGB radiance in W·sr⁻¹·m⁻², illuminance =
//! 179 lm/W × (0.265 R + 0.670 G + 0.065 B). Below the horizon every sky shows a uniform
//! ground glow of luminance ρ_g·E_h/π, E_h the global horizontal irradiance (sky + sun).

pub mod cie;
pub mod perez;
pub mod preetham;

use crate::photometry::Rgb;
use glam::DVec3;

/// Radiance distribution of the sky above the horizon.
pub trait SkyDistribution: Send + Sync {
    /// RGB radiance (W·sr⁻¹·m⁻²) arriving from unit direction `dir` with `dir.z > 0`
    /// (scene frame: x east, y north, z up; `dir` points towards the sky).
    fn radiance(&self, dir: DVec3) -> Rgb;
}

/// The sun as a parallel source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector towards the sun's centre, scene frame.
    pub direction: DVec3,
    /// Irradiance on a plane normal to the sun's direction (RGB, W/m²).
    pub normal_irradiance: Rgb,
}

/// The whole sky for one instant.
pub struct Sky {
    /// Radiance above the horizon; `None` for a dark sky.
    pub distribution: Option<Box<dyn SkyDistribution>>,
    /// The sun, when above the horizon and with non-zero irradiance.
    pub sun: Option<Sun>,
    /// Uniform radiance below the horizon (RGB, W·sr⁻¹·m⁻²).
    pub ground_radiance: Rgb,
    /// Short description, e.g. `perez dni=700 dhi=100`.
    pub description: String,
    /// Non-fatal remarks (clamped turbidity, sun below horizon, …).
    pub warnings: Vec<String>,
}

impl Sky {
    /// A sky that emits nothing.
    pub fn none() -> Sky {
        Sky {
            distribution: None,
            sun: None,
            ground_radiance: Rgb::ZERO,
            description: "none".into(),
            warnings: Vec::new(),
        }
    }

    /// RGB radiance from unit direction `dir`: the sky above the horizon, ground glow below.
    pub fn radiance(&self, dir: DVec3) -> Rgb {
        if dir.z > 0.0 {
            self.distribution
                .as_ref()
                .map_or(Rgb::ZERO, |d| d.radiance(dir))
        } else {
            self.ground_radiance
        }
    }
}
