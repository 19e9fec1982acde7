//! L1 input geometry and materials: a scene file, its OBJ/MTL geometry and its sensors,
//! converted to one frame: metres, right-handed, x east, y north, z up, with a local origin
//! subtracted so far-from-origin models keep full precision.

mod aperture_groups;
pub mod faces;
pub mod grids;
pub mod hbjson;
mod hbjson_modifiers;
mod hbjson_schema;
pub mod imported;
pub mod junctions;
pub mod material;
pub mod obj;
pub mod polygon;
mod mtl;
pub mod rad;
mod rad_lexer;
mod rad_xform;
pub mod scene_file;
pub mod sensors;
pub mod synthetic;
pub mod view;

use crate::error::Result;
use crate::site::Site;
use glam::DVec3;
use std::path::{Path, PathBuf};

pub use faces::Faces;
pub use grids::SensorGrid;
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
    /// All triangles with positive area: the model's (`..input_triangles`), then the back
    /// faces [`faces::add_back_faces`] made (`input_triangles..`).
    pub triangles: Vec<Triangle>,
    /// Number of the model's own triangles (the rest are back faces).
    pub input_triangles: usize,
    /// Which faces reflect ([`Faces`]).
    pub faces: Faces,
    /// The opposite face of each triangle (`u32::MAX` for none: glazing, or `faces =
    /// "front"`). Empty when no triangle has one.
    pub twin: Vec<u32>,
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
    /// The model's north rotation (`north_deg`, degrees) applied before the origin.
    pub north_deg: f64,
    /// Whether the model files were Y-up (converted by [`y_up_to_z_up`] when read).
    pub y_up: bool,
    /// Number of degenerate input triangles dropped (zero area, or an area too small or too
    /// large for `f64` to give a unit normal).
    pub dropped_degenerate: usize,
    /// What cutting surfaces along the feet of walls standing on them did
    /// ([`junctions::split_at_junctions`]).
    pub junctions: junctions::JunctionReport,
    /// What the model file gave besides geometry (HBJSON: rooms, sensor grids with the
    /// grid of each sensor, named views, aperture groups, counts of bad geometry); empty
    /// for OBJ.
    pub imported: imported::Imported,
    /// Non-fatal remarks about the input (unknown MTL keys, …), each once.
    pub warnings: Vec<String>,
    /// The model's named sensor grids with their sensors, in model order (empty unless the
    /// model's grids are the sensors); `--grids` narrows them.
    pub grids: Vec<SensorGrid>,
}

impl Scene {
    /// A direction given in the model's files (as a `.pts` direction or a view's `-vd`)
    /// in the scene frame: Y-up converted, rotated by `north_deg`.
    pub fn direction_from_model(&self, d: DVec3) -> DVec3 {
        let d = if self.y_up { y_up_to_z_up(d) } else { d };
        let (s, c) = self.north_deg.to_radians().sin_cos();
        DVec3::new(c * d.x - s * d.y, s * d.x + c * d.y, d.z)
    }

    /// A point given in the model's files (m, as a `.pts` position or a view's `-vp`) in
    /// the scene frame: converted as [`Self::direction_from_model`], then the origin
    /// subtracted.
    pub fn point_from_model(&self, p: DVec3) -> DVec3 {
        self.direction_from_model(p) - self.origin
    }

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

    /// Puts the scene at `site` when its file gave none ([`Self::site_given`]), with a
    /// warning saying where the site came from (`source`, e.g. the weather file's path);
    /// a scene with its own site is left as it is. Returns whether the site was taken.
    pub fn take_site_if_missing(&mut self, site: Site, source: &str) -> bool {
        if self.site_given() {
            return false;
        }
        self.warnings
            .retain(|w| !w.contains(scene_file::NO_SITE_WARNING));
        self.warnings.push(format!(
            "{}: no site in the scene: using {source}'s (latitude {:.4}°, longitude {:.4}°, \
             UTC{:+})",
            self.path.display(),
            site.latitude,
            site.longitude,
            site.utc_offset_h
        ));
        self.site = site;
        true
    }

    /// False when the scene file had no `[site]` table and [`Site::default`] stands in, so a
    /// weather file's site should be used instead (without a disagreement warning).
    pub fn site_given(&self) -> bool {
        !self
            .warnings
            .iter()
            .any(|w| w.contains(scene_file::NO_SITE_WARNING))
    }

    /// The region of interest: the sensors' bounding box grown by `margin_m` on every side,
    /// clipped to the geometry's bounds (scene frame, m). The whole bounds when there are no
    /// sensors. Projections and the interreflection resolve it finely, whatever the
    /// extent of the site around it.
    pub fn region_of_interest(&self, margin_m: f64) -> (DVec3, DVec3) {
        region_around(&self.sensors, self.bounds(), margin_m)
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

/// The bounding box of `sensors` grown by `margin_m`, clipped to `bounds` (min, max; scene
/// frame, m); `bounds` itself when there are no sensors or no geometry.
pub fn region_around(sensors: &[Sensor], bounds: (DVec3, DVec3), margin_m: f64) -> (DVec3, DVec3) {
    let (lo, hi) = bounds;
    if sensors.is_empty() || !lo.is_finite() || !hi.is_finite() {
        return bounds;
    }
    let m = DVec3::splat(margin_m.max(0.0));
    let (a, b) = sensors.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(a, b), s| (a.min(s.position), b.max(s.position)),
    );
    ((a - m).max(lo), (b + m).min(hi))
}

/// How much larger than the region of interest (by diameter) a scene may be before the
/// projections and the interreflection's lines resolve the region separately: the first
/// [`context_windows`] window is the region grown this many times. The presets were
/// calibrated on the sample office, whose scene is 3.2 region diameters across; a site of
/// any extent beyond that no longer coarsens the room (issue 13).
pub const CONTEXT_DIAMETERS: f64 = 4.0;

/// Nested boxes (min, max; scene frame, m) from the region of interest out to the whole
/// scene: the cube around the region's centre whose half-edge is [`CONTEXT_DIAMETERS`]
/// times the region's largest half-extent, then doubled
/// each time, each clipped to `bounds`, the last one `bounds` itself. One box when the
/// first already holds the whole scene. A projection or a set of lines covers box k at
/// [`WINDOW_PIXEL_GROWTH`]^k times the pixel of box 0, and an element is resolved in the smallest box holding
/// it: far context costs a few coarse images, its elements grow with their distance too.
///
/// The pixel of window k is [`WINDOW_PIXEL_GROWTH`]^k times window 0's.
pub fn context_windows(region: (DVec3, DVec3), bounds: (DVec3, DVec3)) -> Vec<(DVec3, DVec3)> {
    let inside =
        |a: (DVec3, DVec3), b: (DVec3, DVec3)| a.0.cmpge(b.0).all() && a.1.cmple(b.1).all();
    if !(region.0.is_finite() && region.1.is_finite() && inside(region, bounds)) {
        return vec![bounds];
    }
    // Cubes: a flat region (sensors in one plane, clipped to a flat site) still grows in
    // every direction.
    let c = (region.0 + region.1) * 0.5;
    let mut half =
        DVec3::splat(((region.1 - region.0) * 0.5).max_element().max(1e-3)) * CONTEXT_DIAMETERS;
    let mut out = Vec::new();
    loop {
        let w = ((c - half).max(bounds.0), (c + half).min(bounds.1));
        if inside(bounds, w) || out.len() >= 24 {
            out.push(bounds);
            return out;
        }
        out.push(w);
        half *= 2.0;
    }
}

/// How much coarser each [`context_windows`] window's pixel (or line spacing) is than the
/// one inside it. Windows double in size, so a growth of 4 gives window k a quarter of the
/// pixels of window k − 1 and all of them together 4/3 of window 0's: the office on a 1 km
/// ground measured 5.5× the fragments of the office on its own site with a growth of 2
/// (each of its five windows a full image). Far elements grow with their distance
/// (0.1·d², an edge of ~0.45 d), so window k's smallest still spans 0.23 × resolution / 2^k
/// pixels: 14 at the fourth window of a 256-pixel bundle.
pub const WINDOW_PIXEL_GROWTH: f64 = 4.0;

/// Index of the smallest of `windows` ([`context_windows`]) holding the triangle `v`.
pub fn window_of(windows: &[(DVec3, DVec3)], v: &[DVec3; 3]) -> usize {
    let (a, b) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
    windows
        .iter()
        .position(|w| a.cmpge(w.0).all() && b.cmple(w.1).all())
        .unwrap_or(windows.len().saturating_sub(1))
}

/// Geometry in the model frame (Z up, +Y = model north, metres), before conversion.
#[derive(Clone, Debug, Default)]
pub struct ModelInput {
    /// Triangles in the model frame (Z up). Use [`y_up_to_z_up`] first for Y-up files.
    pub triangles: Vec<Triangle>,
    /// Materials referenced by triangles.
    pub materials: Vec<Material>,
    /// Group names referenced by triangles.
    pub groups: Vec<String>,
    /// Sensors as (position, direction) in the model frame (Z up).
    pub sensors: Vec<(DVec3, DVec3)>,
    /// Rotation from the model's +Y to true north, degrees clockwise seen from above.
    pub north_deg: f64,
    /// The site.
    pub site: Site,
    /// Ground reflectance, [0, 1).
    pub ground_reflectance: f64,
    /// Which faces of opaque surfaces reflect.
    pub faces: Faces,
    /// What the model file gave besides geometry ([`Scene::imported`]);
    /// `imported.sensor_grid` is empty or has one entry per sensor.
    pub imported: imported::Imported,
}

/// Converts a Y-up point to Z-up: (x, y, z) → (x, −z, y) (glTF/Blender convention).
pub fn y_up_to_z_up(p: DVec3) -> DVec3 {
    DVec3::new(p.x, -p.z, p.y)
}

impl Scene {
    /// Builds a scene from model-frame input: rotates model north onto true north, moves
    /// the origin to the centre of the bounds (so coordinates far from the origin keep
    /// precision), drops degenerate triangles (counted), checks that everything is finite
    /// and, for [`Faces::Both`], adds the back faces ([`faces::add_back_faces`]).
    ///
    /// # Errors
    /// [`crate::Error::Input`] for non-finite coordinates (or coordinates so near `f64::MAX`
    /// that rotating them or moving them to the origin overflows), a zero sensor direction,
    /// a material index out of range, or a ground reflectance outside [0, 1).
    pub fn from_model(path: &Path, input: ModelInput) -> Result<Scene> {
        use crate::error::Error;
        if !(0.0..1.0).contains(&input.ground_reflectance) {
            return Err(Error::input(
                path,
                None,
                Some(&input.ground_reflectance.to_string()),
                "ground_reflectance must be in [0, 1)",
            ));
        }
        if !input.north_deg.is_finite() {
            return Err(Error::input(
                path,
                None,
                Some(&input.north_deg.to_string()),
                "north_deg must be finite",
            ));
        }
        let (s, c) = input.north_deg.to_radians().sin_cos();
        // Counter-clockwise by north_deg maps the model's north (clockwise from +Y) onto +Y.
        let rot = |p: DVec3| DVec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
        // A point as quoted in errors: exponent form stays short even near f64::MAX.
        let exp = |p: DVec3| format!("{:e} {:e} {:e}", p.x, p.y, p.z);
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for (i, t) in input.triangles.iter().enumerate() {
            if (t.material as usize) >= input.materials.len() {
                return Err(Error::Internal(format!(
                    "triangle {i} refers to material {} of {}",
                    t.material,
                    input.materials.len()
                )));
            }
            for v in t.v {
                if !v.is_finite() {
                    return Err(Error::input(
                        path,
                        None,
                        Some(&format!("{v}")),
                        format!("triangle {i} has a non-finite vertex"),
                    ));
                }
                let w = rot(v);
                if !w.is_finite() {
                    return Err(Error::input(
                        path,
                        None,
                        Some(&exp(v)),
                        format!("triangle {i} has a vertex too far out to rotate by north_deg"),
                    ));
                }
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        let origin = if input.triangles.is_empty() {
            DVec3::ZERO
        } else {
            // Halves first: `lo + hi` overflows for coordinates beyond f64::MAX / 2.
            (lo * 0.5 + hi * 0.5).round()
        };
        let mut dropped = 0;
        let triangles: Vec<Triangle> = input
            .triangles
            .iter()
            .filter_map(|t| {
                let moved = Triangle {
                    v: t.v.map(|v| rot(v) - origin),
                    ..*t
                };
                let n = moved.cross();
                // Zero, subnormal or infinite: no exact unit normal (or finite area).
                if n.length_squared().is_normal() {
                    Some(moved)
                } else {
                    dropped += 1;
                    None
                }
            })
            .collect();
        let (triangles, junctions) =
            junctions::split_at_junctions(triangles, input.faces == Faces::Both);
        let mut sensors = Vec::with_capacity(input.sensors.len());
        for (k, (p, d)) in input.sensors.iter().enumerate() {
            if !p.is_finite() || !d.is_finite() || d.length_squared() == 0.0 {
                return Err(Error::input(
                    path,
                    Some(k + 1),
                    Some(&format!("{p} {d}")),
                    "sensor needs a finite position and a non-zero finite direction",
                ));
            }
            let position = rot(*p) - origin;
            if !position.is_finite() {
                return Err(Error::input(
                    path,
                    None,
                    Some(&exp(*p)),
                    format!(
                        "sensor {} is too far from the geometry: its position overflows in the \
                         scene frame",
                        k + 1
                    ),
                ));
            }
            sensors.push(Sensor {
                position,
                normal: rot(*d).normalize(),
                input_position: *p,
            });
        }
        if !input.imported.sensor_grid.is_empty()
            && input.imported.sensor_grid.len() != input.sensors.len()
        {
            return Err(Error::Internal(format!(
                "{} sensors but {} sensor grid indices",
                input.sensors.len(),
                input.imported.sensor_grid.len()
            )));
        }
        let input_triangles = triangles.len();
        let mut scene = Scene {
            path: path.to_path_buf(),
            triangles,
            input_triangles,
            faces: Faces::Front,
            twin: Vec::new(),
            materials: input.materials,
            groups: input.groups,
            sensors,
            site: input.site,
            ground_reflectance: input.ground_reflectance,
            origin,
            north_deg: input.north_deg,
            y_up: false,
            dropped_degenerate: dropped,
            junctions,
            imported: input.imported,
            warnings: Vec::new(),
            grids: Vec::new(),
        };
        scene.grids = grids::from_imported(&scene.imported);
        if input.faces == Faces::Both {
            faces::add_back_faces(&mut scene);
        }
        Ok(scene)
    }
}
