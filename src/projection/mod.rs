//! L4 visibility along one direction (Besuievsky & Martín §5): the scene is scan-converted
//! with an orthographic camera into a Layered Depth Image; each patch's visibility ratio
//! VR = n_v/n_p drives quad-tree refinement; the result is a [`DirectionRecord`]: for every
//! lit leaf element its transfer weight (Ap/A)·VR, glazing transmission included. Direct
//! light is transmission-only: glazing's specular reflection of sun and sky onto surfaces
//! is not modelled (the interreflection, `radiosity::transport`, reflects light coming
//! from surfaces).

mod clip;
pub mod ldi;
pub mod refine;

pub use ldi::{Camera, Ldi, Reader};
pub use refine::refine_all;

use crate::hierarchy::ElementKey;
use crate::photometry::Rgb;
use crate::scene::Scene;
use glam::DVec3;

/// Knobs of the projection step; each trades discretisation error against time.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProjectionParams {
    /// LDI resolution (pixels along the longer image side) for the brightest source.
    pub max_resolution: u32,
    /// Lower bound of the resolution for dim sources.
    pub min_resolution: u32,
    /// Refine a patch when `v_min < VR < v_max` (paper: 0.05, 0.95; ours 0.02, 0.98).
    pub v_min: f64,
    /// See `v_min`.
    pub v_max: f64,
    /// Patches smaller than this (m²) are not refined.
    pub min_area_m2: f64,
    /// Partly lit patches (0 < VR < 1) larger than this (m²) are refined whatever their VR.
    /// A leaf's weight is its mean over the leaf, so an unrefined leaf with VR = 0.01 lays a
    /// lit hundredth of its area evenly over all of it: harmless to the sensors (ray cast),
    /// but the interreflection mesh took that light far from where it lands (measured on the
    /// office: 300–700 lx of sun at the back of the floor that gets none, −7 to −10 % in the
    /// sun patch, docs/design.md). At the interreflection mesh's element size the paper's
    /// thresholds take over again.
    pub partial_area_m2: f64,
    /// Deepest refinement below an input triangle.
    pub max_depth: u32,
    /// Margin (m) around the sensors' bounding box of the region of interest
    /// ([`Scene::region_of_interest`]): a scene much larger than it is projected in nested
    /// windows ([`crate::scene::context_windows`], [`project`]).
    pub margin_m: f64,
}

impl Default for ProjectionParams {
    fn default() -> Self {
        ProjectionParams {
            max_resolution: 1024,
            min_resolution: 64,
            // The paper's 0.05 / 0.95 left the office's sun patch 4.4 % RMS from converged
            // (`daystep convergence`, docs/commands.md, quality presets); 0.02 / 0.98 brings it to 0.45 % at
            // no measurable extra time.
            v_min: 0.02,
            v_max: 0.98,
            min_area_m2: 1e-3,
            partial_area_m2: 0.25,
            max_depth: 10,
            // As the interreflection's region (`TransportParams::margin_m`).
            margin_m: 6.0,
        }
    }
}

impl ProjectionParams {
    /// The finest LDI pixel worth drawing, m: a sixteenth of the edge of the largest
    /// partly lit patch left unrefined ([`Self::partial_area_m2`]), so such a patch spans
    /// 256 pixels. A small scene (a 2 m box) at `max_resolution` would draw pixels of a
    /// few millimetres, ~30 times the fragments for the same elements; the sample scenes'
    /// pixels are coarser than this (office 8 cm), so it does not bind there.
    pub fn pixel_floor_m(&self) -> f64 {
        self.partial_area_m2.max(0.0).sqrt() / 16.0
    }

    /// LDI resolution for a source: the sun at `max_resolution`, every sky and ground node
    /// at half of it (at least `min_resolution`). The paper sizes each LDI by the source's
    /// share of the irradiance (§5.1); a fixed size per kind instead makes a direction's
    /// projection the same under every sky, so a year of skies projects each node once
    /// and the cache can keep it (docs/design.md). Sensor values do not depend on it
    /// (they are ray cast); the element weights that feed interreflection do, slightly.
    pub fn resolution_for(&self, is_sun: bool) -> u32 {
        if is_sun {
            self.max_resolution
        } else {
            (self.max_resolution / 2).max(self.min_resolution)
        }
    }
}

/// Transfer weight of one lit leaf element for one direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafWeight {
    /// The element.
    pub key: ElementKey,
    /// (Ap/A)·VR with glazing transmission per channel: the element's irradiance is
    /// `E_source ⊙ weight` (W/m²).
    pub weight: Rgb,
}

/// Counters of one projection.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ProjectionStats {
    /// LDI width, pixels.
    pub width: u32,
    /// LDI height, pixels.
    pub height: u32,
    /// Pixel edge length, m.
    pub pixel_m: f64,
    /// Fragments stored in the LDI.
    pub fragments: u64,
    /// Elements whose VR was evaluated.
    pub elements_tested: u64,
    /// Elements split.
    pub elements_split: u64,
    /// Lit leaves in the record.
    pub lit_leaves: u64,
}

/// What one projection yields: everything later steps need, nothing of the LDI itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DirectionRecord {
    /// Lit leaves in key order.
    pub leaves: Vec<LeafWeight>,
    /// Counters.
    pub stats: ProjectionStats,
}

/// Per-triangle data the projection needs, computed once per scene.
#[derive(Clone, Debug)]
pub struct ProjectionScene {
    /// Vertices per triangle (scene frame, m).
    pub vertices: Vec<[DVec3; 3]>,
    /// Unit normal per triangle.
    pub normals: Vec<DVec3>,
    /// Area per triangle, m².
    pub areas: Vec<f64>,
    /// Normal-incidence transmittance per triangle (zero for opaque).
    pub glazing_tf: Vec<Rgb>,
    /// Material index per triangle (for the angular transmittance).
    pub material: Vec<u32>,
    /// Materials.
    pub materials: Vec<crate::scene::Material>,
    /// Opposite face of each triangle (`u32::MAX`: none), as [`Scene::twin`]; empty when
    /// no triangle has one. A back face is rasterised with its front triangle.
    pub twin: Vec<u32>,
    /// Bounds of all triangles (min, max; scene frame, m).
    pub bounds: (DVec3, DVec3),
    /// Nested windows from the region of interest out to the whole scene
    /// ([`crate::scene::context_windows`]); just the bounds for a scene projected whole.
    pub windows: Vec<(DVec3, DVec3)>,
}

impl ProjectionScene {
    /// Extracts what projection needs from a scene, with the nested windows around the
    /// region of interest of its sensors ([`Scene::region_of_interest`] with `margin_m`).
    pub fn with_region(scene: &Scene, margin_m: f64) -> Self {
        let mut p = ProjectionScene::new(scene);
        p.windows = crate::scene::context_windows(scene.region_of_interest(margin_m), p.bounds);
        p
    }

    /// Extracts what projection needs from a scene (the whole scene at one resolution).
    pub fn new(scene: &Scene) -> Self {
        let t = &scene.triangles;
        let bounds = scene.bounds();
        ProjectionScene {
            bounds,
            windows: vec![bounds],
            vertices: t.iter().map(|t| t.v).collect(),
            normals: t.iter().map(|t| t.normal()).collect(),
            areas: t.iter().map(|t| t.area()).collect(),
            glazing_tf: t
                .iter()
                .map(|t| scene.materials[t.material as usize].tf)
                .collect(),
            material: t.iter().map(|t| t.material).collect(),
            materials: scene.materials.clone(),
            twin: scene.twin.clone(),
        }
    }

    /// The back face of model triangle `tri`, if it has one.
    pub fn back_of(&self, tri: usize) -> Option<u32> {
        self.twin
            .get(tri)
            .copied()
            .filter(|&t| t != u32::MAX && t as usize > tri)
    }

    /// Whether `tri` is a back face (rasterised with its front triangle).
    pub fn is_back_face(&self, tri: usize) -> bool {
        self.twin.get(tri).is_some_and(|&t| (t as usize) < tri)
    }

    /// Factor a fragment of triangle `tri` applies to light travelling along `dir`:
    /// glazing τ(θ) per channel, zero when opaque.
    pub fn pass_factor(&self, tri: usize, dir: DVec3) -> Rgb {
        if self.glazing_tf[tri].max_element() <= 0.0 {
            return Rgb::ZERO;
        }
        let m = &self.materials[self.material[tri] as usize];
        m.transmittance(self.normals[tri].dot(dir).abs())
    }
}

/// Projects the scene along `dir` (unit, towards the source) at `resolution`, refines the
/// hierarchy by visibility ratio and returns the record.
///
/// A scene with nested windows ([`ProjectionScene::with_region`]) gets one LDI per window:
/// the first at `resolution` pixels across its projection, each further one at
/// [`crate::scene::WINDOW_PIXEL_GROWTH`] times the pixel of the one inside it. An element is refined against the LDI of the smallest
/// window holding it, so the room keeps its resolution whatever the site's extent and
/// the far context is still lit.
pub fn project(
    scene: &ProjectionScene,
    dir: DVec3,
    resolution: u32,
    params: &ProjectionParams,
) -> DirectionRecord {
    project_reading(scene, dir, resolution, params, Reader::Source)
}

/// [`project`] with LDIs holding what `reader` reads: [`Reader::Source`] is what
/// [`project`] uses; [`Reader::SourceUncut`] keeps the fragments beyond the window box too,
/// and must give the same record to the bit (the check that the fragments the box cut
/// drops are never read).
pub fn project_reading(
    scene: &ProjectionScene,
    dir: DVec3,
    resolution: u32,
    params: &ProjectionParams,
    reader: Reader,
) -> DirectionRecord {
    let floor = params.pixel_floor_m();
    let mut record = if scene.windows.len() <= 1 {
        let ldi = Ldi::build_floored(scene, dir, resolution, floor, reader);
        refine_all(scene, &[ldi], &[], params)
    } else {
        let first = Ldi::build_region(scene, dir, resolution, scene.windows[0], floor, reader);
        let pixel = first.camera.pixel;
        let mut ldis = vec![first];
        for (k, w) in scene.windows.iter().enumerate().skip(1) {
            let p = pixel * crate::scene::WINDOW_PIXEL_GROWTH.powi(k as i32);
            ldis.push(Ldi::build_window(
                scene,
                dir,
                p,
                *w,
                glam::DVec2::ZERO,
                reader,
            ));
        }
        refine_all(scene, &ldis, &scene.windows, params)
    };
    record.stats.lit_leaves = record.leaves.len() as u64;
    record
}
