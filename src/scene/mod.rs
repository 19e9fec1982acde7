//! L1 input geometry and materials: a scene file, its OBJ/MTL geometry and its sensors,
//! converted to one frame: metres, right-handed, x east, y north, z up, with a local origin
//! subtracted so far-from-origin models keep full precision.

pub mod material;
pub mod obj;
pub mod scene_file;
pub mod sensors;
pub mod synthetic;

use crate::error::Result;
use crate::site::Site;
use glam::DVec3;
use std::path::{Path, PathBuf};

pub use material::Material;

/// One input triangle in the scene frame (metres, origin-subtracted, ENU).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Vertices, counter-clockwise seen from the front (the side the normal points to).
    pub v: [DVec3; 3],
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Index into [`Scene::groups`] (OBJ group or object; material name where none).
    pub group: u32,
}

impl Triangle {
    /// Unnormalised normal: (v1 − v0) × (v2 − v0), length = 2 × area.
    pub fn cross(&self) -> DVec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
    /// Area, m².
    pub fn area(&self) -> f64 {
        0.5 * self.cross().length()
    }
    /// Unit front-face normal (NaN for a zero-area triangle).
    pub fn normal(&self) -> DVec3 {
        self.cross().normalize()
    }
    /// Vertex centroid, scene frame.
    pub fn centroid(&self) -> DVec3 {
        (self.v[0] + self.v[1] + self.v[2]) / 3.0
    }
}

/// An illuminance sensor (one line of a Radiance .pts file).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    /// Position in the scene frame (metres, origin-subtracted, ENU).
    pub position: DVec3,
    /// Unit normal of the sensor's receiving plane, scene frame.
    pub normal: DVec3,
    /// Position as written in the .pts file (model frame), for output.
    pub input_position: DVec3,
}

/// A loaded scene, ready for the pipeline.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The scene file it came from (or a descriptive pseudo-path for generated scenes).
    pub path: PathBuf,
    /// All triangles with positive area.
    pub triangles: Vec<Triangle>,
    /// Materials referenced by triangles.
    pub materials: Vec<Material>,
    /// Group names referenced by triangles.
    pub groups: Vec<String>,
    /// Sensors in .pts order.
    pub sensors: Vec<Sensor>,
    /// Where the building stands.
    pub site: Site,
    /// Reflectance of the ground below the horizon (seen as a uniform glow), [0, 1).
    pub ground_reflectance: f64,
    /// Scene-frame origin in the converted (ENU) model frame, metres: model = scene + origin.
    pub origin: DVec3,
    /// Number of zero-area input triangles dropped.
    pub dropped_degenerate: usize,
    /// Non-fatal remarks about the input (unknown MTL keys, …), each once.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Loads `scene.toml` and everything it references.
    ///
    /// # Errors
    /// [`crate::Error::Input`] naming file, line and value for any bad input.
    pub fn load(path: &Path) -> Result<Scene> {
        scene_file::load(path)
    }

    /// True when any material is glazing (has non-zero `Tf`).
    pub fn has_glazing(&self) -> bool {
        self.materials.iter().any(Material::is_glazing)
    }

    /// Axis-aligned bounds of all triangles (scene frame): (min, max).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for v in t.v {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        (lo, hi)
    }
}
