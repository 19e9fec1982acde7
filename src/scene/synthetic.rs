//! A builder for scenes in code ([`SceneBuilder`]): materials, polygons, axis-aligned
//! rectangles with holes, boxes, rooms with openings and reveals, sensor grids, site. The
//! concrete test and benchmark scenes built with it (the bundled side-lit office, the
//! multi-storey building) live with the tests (`tests/scenes/`).
//!
//! All coordinates are metres in the model frame (x east, y north, z up).

use crate::error::Result;
use crate::photometry::Rgb;
use crate::scene::{Faces, Material, ModelInput, Scene, Triangle};
use crate::site::Site;
use glam::{DVec2, DVec3};
use std::collections::HashMap;
use std::path::Path;

/// One of the six axis directions; names a face of an axis-aligned box by its outward
/// normal, and the direction an axis-aligned rectangle faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Face {
    /// −x.
    West,
    /// +x.
    East,
    /// −y.
    South,
    /// +y.
    North,
    /// −z (a floor's underside, a box's bottom).
    Bottom,
    /// +z.
    Top,
}

impl Face {
    /// All six, in the order used by [`SceneBuilder::add_shell`]'s material array.
    pub const ALL: [Face; 6] = [
        Face::West,
        Face::East,
        Face::South,
        Face::North,
        Face::Bottom,
        Face::Top,
    ];

    /// The face pointing along `axis` (0 x, 1 y, 2 z) in the positive or negative sense.
    pub fn from_axis(axis: usize, positive: bool) -> Face {
        Face::ALL[2 * axis + positive as usize]
    }
    /// Axis the face is perpendicular to: 0 x, 1 y, 2 z.
    pub fn axis(self) -> usize {
        self as usize / 2
    }
    /// +1 for East, North, Top; −1 otherwise.
    pub fn sign(self) -> f64 {
        if self as usize % 2 == 1 {
            1.0
        } else {
            -1.0
        }
    }
    /// Unit normal.
    pub fn normal(self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.axis()] = self.sign();
        n
    }
    /// The face pointing the other way.
    pub fn opposite(self) -> Face {
        Face::from_axis(self.axis(), self.sign() < 0.0)
    }
    /// The two in-plane axes (a, b) in increasing order: x-faces (y, z), y-faces (x, z),
    /// z-faces (x, y). [`Rect`]s on this face are given in these coordinates.
    pub fn plane_axes(self) -> (usize, usize) {
        match self.axis() {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        }
    }
}

/// An axis-aligned rectangle in a face's in-plane coordinates (see [`Face::plane_axes`]),
/// metres: `a = [min, max]` along the first in-plane axis, `b` along the second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Range along the first in-plane axis, m.
    pub a: [f64; 2],
    /// Range along the second in-plane axis, m.
    pub b: [f64; 2],
}

impl Rect {
    /// A rectangle from its two ranges (each `[min, max]`, m).
    pub fn new(a: [f64; 2], b: [f64; 2]) -> Rect {
        Rect { a, b }
    }
    fn is_empty(&self) -> bool {
        !(self.a[1] > self.a[0] && self.b[1] > self.b[0])
    }
    fn intersect(&self, o: &Rect) -> Rect {
        Rect {
            a: [self.a[0].max(o.a[0]), self.a[1].min(o.a[1])],
            b: [self.b[0].max(o.b[0]), self.b[1].min(o.b[1])],
        }
    }
    fn contains(&self, a: f64, b: f64) -> bool {
        a > self.a[0] && a < self.a[1] && b > self.b[0] && b < self.b[1]
    }
}

/// A rectangular opening in one face of a shell ([`SceneBuilder::add_shell`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Opening {
    /// The face it is cut in, named by the face's outward direction from the box.
    pub face: Face,
    /// Its extent in the face's in-plane coordinates, m.
    pub rect: Rect,
    /// Glazing material filling the opening (a quad in the face's plane, facing away from
    /// the box), or `None` to leave it open.
    pub glazing: Option<u32>,
}

/// Materials of a room's inner faces ([`SceneBuilder::add_room`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RoomMaterials {
    /// Floor (the face at the box's bottom, facing up).
    pub floor: u32,
    /// The four walls.
    pub walls: u32,
    /// Ceiling (facing down).
    pub ceiling: u32,
}

/// Builds a [`Scene`] in code: materials, planar polygons, boxes, rooms with openings,
/// sensors, site. Every add-call takes a group name (OBJ `g`); triangles keep insertion order.
#[derive(Clone, Debug)]
pub struct SceneBuilder {
    triangles: Vec<Triangle>,
    materials: Vec<Material>,
    groups: Vec<String>,
    group_index: HashMap<String, u32>,
    sensors: Vec<(DVec3, DVec3)>,
    site: Site,
    north_deg: f64,
    ground_reflectance: f64,
    faces: Faces,
}

impl Default for SceneBuilder {
    fn default() -> Self {
        SceneBuilder::new()
    }
}

impl SceneBuilder {
    /// An empty scene at the default site (Greenwich), north along +y, ground reflectance 0.2.
    pub fn new() -> SceneBuilder {
        SceneBuilder {
            triangles: Vec::new(),
            materials: Vec::new(),
            groups: Vec::new(),
            group_index: HashMap::new(),
            sensors: Vec::new(),
            site: Site::default(),
            north_deg: 0.0,
            ground_reflectance: 0.2,
            faces: Faces::Both,
        }
    }

    /// Adds a material; returns its index.
    pub fn add_material(&mut self, material: Material) -> u32 {
        self.materials.push(material);
        (self.materials.len() - 1) as u32
    }

    /// Adds a grey opaque diffuse material with reflectance `kd` in [0, 1); returns its index.
    pub fn add_opaque(&mut self, name: &str, kd: f64) -> u32 {
        self.add_material(Material {
            name: name.to_owned(),
            kd: Rgb::splat(kd),
            tf: Rgb::ZERO,
            ke: Rgb::ZERO,
        })
    }

    /// Adds a neutral glazing material with normal-incidence transmittance `tf` in (0, 1);
    /// returns its index.
    pub fn add_glazing(&mut self, name: &str, tf: f64) -> u32 {
        self.add_material(Material {
            name: name.to_owned(),
            kd: Rgb::ZERO,
            tf: Rgb::splat(tf),
            ke: Rgb::ZERO,
        })
    }

    fn group(&mut self, name: &str) -> u32 {
        if let Some(&g) = self.group_index.get(name) {
            return g;
        }
        let g = self.groups.len() as u32;
        self.groups.push(name.to_owned());
        self.group_index.insert(name.to_owned(), g);
        g
    }

    /// Adds one triangle, vertices counter-clockwise seen from its front (m).
    pub fn add_triangle(&mut self, group: &str, material: u32, v: [DVec3; 3]) {
        let group = self.group(group);
        self.triangles.push(Triangle { v, material, group });
    }

    /// Adds a planar convex polygon given counter-clockwise seen from its front (the side
    /// its normal points to), triangulated as a fan from the first vertex.
    pub fn add_polygon(&mut self, group: &str, material: u32, vertices: &[DVec3]) {
        for k in 1..vertices.len().saturating_sub(1) {
            self.add_triangle(group, material, [vertices[0], vertices[k], vertices[k + 1]]);
        }
    }

    /// Adds a planar quad (two triangles), counter-clockwise seen from its front.
    pub fn add_quad(&mut self, group: &str, material: u32, v: [DVec3; 4]) {
        self.add_polygon(group, material, &v);
    }

    /// Adds an axis-aligned rectangle in the plane `coordinate[facing.axis()] = at`, facing
    /// `facing`, spanning `rect` in the face's in-plane coordinates. Empty rectangles add
    /// nothing.
    pub fn add_rect(&mut self, group: &str, material: u32, facing: Face, at: f64, rect: Rect) {
        if rect.is_empty() {
            return;
        }
        let (pa, pb) = facing.plane_axes();
        let p = |a: f64, b: f64| {
            let mut v = DVec3::ZERO;
            v[facing.axis()] = at;
            v[pa] = a;
            v[pb] = b;
            v
        };
        let mut q = [
            p(rect.a[0], rect.b[0]),
            p(rect.a[1], rect.b[0]),
            p(rect.a[1], rect.b[1]),
            p(rect.a[0], rect.b[1]),
        ];
        // Counter-clockwise in (a, b) faces along ê_a × ê_b; reverse if that is the wrong way.
        if (q[1] - q[0]).cross(q[3] - q[0]).dot(facing.normal()) < 0.0 {
            q.reverse();
        }
        self.add_quad(group, material, q);
    }

    /// Adds an axis-aligned rectangle like [`SceneBuilder::add_rect`] with rectangular
    /// holes cut out: the remainder is split into rectangles (a grid on all hole edges,
    /// cells merged along the first in-plane axis). Holes are clipped to the rectangle.
    pub fn add_rect_with_holes(
        &mut self,
        group: &str,
        material: u32,
        facing: Face,
        at: f64,
        rect: Rect,
        holes: &[Rect],
    ) {
        for piece in rect_minus_holes(rect, holes) {
            self.add_rect(group, material, facing, at, piece);
        }
    }

    /// Adds the faces of the axis-aligned box `lo..hi`: `materials[k]` for face
    /// [`Face::ALL`]`[k]` (`None` leaves that face out); faces point out of the box, or into
    /// it when `inward` (a room seen from inside). `openings` are cut in their faces; a
    /// glazed opening gets a glazing quad in the face's plane facing away from the box.
    pub fn add_shell(
        &mut self,
        group: &str,
        lo: DVec3,
        hi: DVec3,
        inward: bool,
        materials: [Option<u32>; 6],
        openings: &[Opening],
    ) {
        for (k, face) in Face::ALL.into_iter().enumerate() {
            let Some(material) = materials[k] else {
                continue;
            };
            let axis = face.axis();
            let at = if face.sign() > 0.0 {
                hi[axis]
            } else {
                lo[axis]
            };
            let (pa, pb) = face.plane_axes();
            let whole = Rect::new([lo[pa], hi[pa]], [lo[pb], hi[pb]]);
            let holes: Vec<Rect> = openings
                .iter()
                .filter(|o| o.face == face)
                .map(|o| o.rect)
                .collect();
            let facing = if inward { face.opposite() } else { face };
            self.add_rect_with_holes(group, material, facing, at, whole, &holes);
            for o in openings.iter().filter(|o| o.face == face) {
                if let Some(glass) = o.glazing {
                    self.add_rect(group, glass, face, at, o.rect.intersect(&whole));
                }
            }
        }
    }

    /// Adds a closed axis-aligned box `lo..hi` (m) with outward-facing faces.
    pub fn add_box(&mut self, group: &str, material: u32, lo: DVec3, hi: DVec3) {
        self.add_shell(group, lo, hi, false, [Some(material); 6], &[]);
    }

    /// Adds an axis-aligned room `lo..hi` (m) seen from inside: floor facing up, ceiling
    /// down, walls into the room, with `openings` cut in its faces (see
    /// [`SceneBuilder::add_shell`]; glazing faces out of the room).
    pub fn add_room(
        &mut self,
        group: &str,
        lo: DVec3,
        hi: DVec3,
        materials: RoomMaterials,
        openings: &[Opening],
    ) {
        let w = Some(materials.walls);
        let mats = [w, w, w, w, Some(materials.floor), Some(materials.ceiling)];
        self.add_shell(group, lo, hi, true, mats, openings);
    }

    /// Adds the reveal of an opening through a wall perpendicular to `face`'s axis, between
    /// the planes `from` and `to` along that axis: the four faces (two jambs, sill, head)
    /// lining the tunnel, each facing into the opening.
    pub fn add_reveal(
        &mut self,
        group: &str,
        material: u32,
        face: Face,
        from: f64,
        to: f64,
        opening: Rect,
    ) {
        let axis = face.axis();
        let depth = [from.min(to), from.max(to)];
        let (pa, pb) = face.plane_axes();
        // ranges[k]: extent along axis k of the face being added.
        let mut ranges = [[0.0; 2]; 3];
        ranges[axis] = depth;
        ranges[pa] = opening.a;
        ranges[pb] = opening.b;
        for (side_axis, side) in [(pa, opening.a), (pb, opening.b)] {
            for (end, positive) in [(side[0], true), (side[1], false)] {
                let facing = Face::from_axis(side_axis, positive);
                let (qa, qb) = facing.plane_axes();
                self.add_rect(
                    group,
                    material,
                    facing,
                    end,
                    Rect::new(ranges[qa], ranges[qb]),
                );
            }
        }
    }

    /// Adds a sensor at `position` (m) whose receiving plane faces `direction`.
    pub fn add_sensor(&mut self, position: DVec3, direction: DVec3) {
        self.sensors.push((position, direction));
    }

    /// Adds an upward-facing sensor grid at height `z` (m) over the horizontal rectangle
    /// `min..max` (x, y), points `spacing` m apart starting at `min` (inclusive, and
    /// including `max` where it falls on the grid); returns the number added.
    pub fn add_sensor_grid(&mut self, min: DVec2, max: DVec2, z: f64, spacing: f64) -> usize {
        let steps = |lo: f64, hi: f64| ((hi - lo) / spacing + 1e-9).floor().max(-1.0) as i64 + 1;
        let (nx, ny) = (steps(min.x, max.x), steps(min.y, max.y));
        for j in 0..ny {
            for i in 0..nx {
                let p = DVec3::new(min.x + i as f64 * spacing, min.y + j as f64 * spacing, z);
                self.add_sensor(p, DVec3::Z);
            }
        }
        (nx.max(0) * ny.max(0)) as usize
    }

    /// Sets the site.
    pub fn set_site(&mut self, site: Site) {
        self.site = site;
    }
    /// Sets the rotation from the model's +y to true north, degrees clockwise from above.
    pub fn set_north_deg(&mut self, north_deg: f64) {
        self.north_deg = north_deg;
    }
    /// Sets the reflectance of the ground below the horizon, [0, 1).
    pub fn set_ground_reflectance(&mut self, rho: f64) {
        self.ground_reflectance = rho;
    }
    /// Sets which faces of opaque surfaces reflect (default [`Faces::Both`]).
    pub fn set_faces(&mut self, faces: Faces) {
        self.faces = faces;
    }
    /// Triangles added so far.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
    /// The triangles added so far, model frame, as drawn (before [`Scene::from_model`]
    /// cuts or drops any).
    pub fn triangles(&self) -> &[Triangle] {
        &self.triangles
    }
    /// Sensors added so far.
    pub fn sensor_count(&self) -> usize {
        self.sensors.len()
    }

    /// Converts to a [`Scene`] via [`Scene::from_model`]; `label` becomes the scene's
    /// pseudo-path (used in messages).
    ///
    /// # Errors
    /// Those of [`Scene::from_model`] (non-finite input, bad ground reflectance, …).
    pub fn build(self, label: &str) -> Result<Scene> {
        Scene::from_model(
            Path::new(label),
            ModelInput {
                triangles: self.triangles,
                materials: self.materials,
                groups: self.groups,
                sensors: self.sensors,
                north_deg: self.north_deg,
                site: self.site,
                ground_reflectance: self.ground_reflectance,
                faces: self.faces,
                imported: Default::default(),
            },
        )
    }
}

/// `rect` minus `holes`, as rectangles: a grid on all edges, cells inside no hole kept and
/// merged into runs along `a` within each `b` strip.
fn rect_minus_holes(rect: Rect, holes: &[Rect]) -> Vec<Rect> {
    if rect.is_empty() {
        return Vec::new();
    }
    let holes: Vec<Rect> = holes
        .iter()
        .map(|h| h.intersect(&rect))
        .filter(|h| !h.is_empty())
        .collect();
    let breaks = |sel: fn(&Rect) -> [f64; 2]| {
        let mut v: Vec<f64> = std::iter::once(sel(&rect))
            .chain(holes.iter().map(sel))
            .flatten()
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let (aa, bb) = (breaks(|r| r.a), breaks(|r| r.b));
    let mut out = Vec::new();
    for bw in bb.windows(2) {
        let bm = 0.5 * (bw[0] + bw[1]);
        let mut run: Option<f64> = None;
        for aw in aa.windows(2) {
            let covered = holes.iter().any(|h| h.contains(0.5 * (aw[0] + aw[1]), bm));
            match (covered, run) {
                (false, None) => run = Some(aw[0]),
                (true, Some(a0)) => {
                    out.push(Rect::new([a0, aw[0]], [bw[0], bw[1]]));
                    run = None;
                }
                _ => {}
            }
        }
        if let Some(a0) = run {
            out.push(Rect::new([a0, rect.a[1]], [bw[0], bw[1]]));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rect_faces_point_where_asked() {
        for face in Face::ALL {
            let mut b = SceneBuilder::new();
            let m = b.add_opaque("m", 0.5);
            b.add_rect("g", m, face, 1.0, Rect::new([0.0, 2.0], [0.0, 1.0]));
            let s = b.build("t").unwrap();
            assert_eq!(s.input_triangles, 2);
            for t in &s.triangles[..2] {
                assert!((t.normal() - face.normal()).length() < 1e-12, "{face:?}");
            }
            let area: f64 = s.triangles[..2].iter().map(Triangle::area).sum();
            assert!((area - 2.0).abs() < 1e-12);
        }
    }

    #[test]
    fn room_with_opening_has_the_right_area_and_orientation() {
        let mut b = SceneBuilder::new();
        let m = RoomMaterials {
            floor: b.add_opaque("floor", 0.2),
            walls: b.add_opaque("wall", 0.5),
            ceiling: b.add_opaque("ceiling", 0.8),
        };
        let glass = b.add_glazing("glass", 0.8);
        let hole = Rect::new([1.0, 2.0], [0.5, 1.5]);
        let openings = [
            Opening {
                face: Face::East,
                rect: hole,
                glazing: Some(glass),
            },
            Opening {
                face: Face::Top,
                rect: Rect::new([1.0, 2.0], [1.0, 2.0]),
                glazing: None,
            },
        ];
        let (lo, hi) = (DVec3::ZERO, DVec3::new(3.0, 4.0, 2.0));
        b.add_room("room", lo, hi, m, &openings);
        let s = b.build("t").unwrap();
        let centre = (lo + hi) * 0.5 - s.origin;
        let mut opaque = 0.0;
        let mut glazed = 0.0;
        for t in &s.triangles[..s.input_triangles] {
            let n = t.normal();
            if t.material == glass {
                glazed += t.area();
                assert!(
                    (n - DVec3::X).length() < 1e-12,
                    "glazing faces out of the room"
                );
            } else {
                opaque += t.area();
                assert!(
                    (centre - t.centroid()).dot(n) > 0.0,
                    "inner faces face the room"
                );
            }
        }
        let total = 2.0 * (3.0 * 4.0 + 3.0 * 2.0 + 4.0 * 2.0);
        assert!((opaque - (total - 2.0)).abs() < 1e-12, "{opaque}");
        assert!((glazed - 1.0).abs() < 1e-12);
        // A polygon fan: a regular hexagon of unit circumradius.
        let mut b = SceneBuilder::new();
        let m = b.add_opaque("m", 0.5);
        let hex: Vec<DVec3> = (0..6)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 6.0;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        b.add_polygon("hex", m, &hex);
        let s = b.build("t").unwrap();
        assert_eq!(s.input_triangles, 4);
        let model = &s.triangles[..4];
        let area: f64 = model.iter().map(Triangle::area).sum();
        assert!((area - 1.5 * 3f64.sqrt()).abs() < 1e-12);
        assert!(model.iter().all(|t| t.normal().z > 0.999));
    }
}
