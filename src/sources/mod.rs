//! L2 the sky and sun as parallel light sources (Besuievsky & Martín §4): the sphere of
//! directions is an octahedral quadtree fixed in the scene frame, adaptively subdivided
//! where the sky is bright; each node is a parallel source with E = L̂·ω. The sun is one
//! more parallel source with its direction snapped to a fixed grid.

pub mod direction_key;
mod node_geometry;
pub mod subdivision;
pub mod sun_grid;

pub use direction_key::{SkyNodeKey, SunKey};
pub use subdivision::{node_source, sky_sources, sky_sources_levels, sun_source, SkyParams};
pub use sun_grid::SunGrid;

use crate::photometry::Rgb;
use glam::DVec3;

/// Which kind of parallel source, with its reusable direction key.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SourceKey {
    /// A sky triangle above the horizon.
    Sky(SkyNodeKey),
    /// A triangle of the uniform ground glow below the horizon.
    Ground(SkyNodeKey),
    /// The sun, snapped.
    Sun(SunKey),
    /// A vertex of the sun's interpolation grid ([`SunGrid`]): row `band`, column `index`.
    SunGrid(SunKey),
}

/// One parallel light source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Kind and direction key.
    pub key: SourceKey,
    /// Unit vector towards the source used for projection (node centre or snapped sun).
    pub direction: DVec3,
    /// Irradiance on a plane normal to `direction`, E = L̂·ω (RGB, W/m²); for the sun, the
    /// direct-normal irradiance.
    pub normal_irradiance: Rgb,
    /// Average radiance L̂ over the node (RGB, W·sr⁻¹·m⁻²); zero for the sun.
    pub radiance: Rgb,
    /// Radiance at the centres of the node's four children (split order), from which L̂ is
    /// their solid-angle-weighted mean; sensors integrate at this finer level.
    pub child_radiance: [Rgb; 4],
    /// Solid angle of the node, sr (zero for the sun).
    pub solid_angle: f64,
    /// Spherical-triangle vertices of a sky or ground node (unit vectors); `None` for the sun.
    pub vertices: Option<[DVec3; 3]>,
    /// The sun's true (unsnapped) direction; equal to `direction` for sky nodes.
    pub true_direction: DVec3,
}

impl Source {
    /// True for the sun and the vertices of its interpolation grid (projected alike).
    pub fn is_sun(&self) -> bool {
        matches!(self.key, SourceKey::Sun(_) | SourceKey::SunGrid(_))
    }
}
