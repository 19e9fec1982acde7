//! Generated test and benchmark scenes built in code: a small builder for axis-aligned
//! architecture ([`SceneBuilder`]), the bundled side-lit office sample
//! ([`side_lit_office`]), a scalable multi-storey office building
//! ([`multi_storey_building`]) and a writer to the on-disk scene format ([`write_obj`]).
//!
//! All coordinates are metres in the model frame (x east, y north, z up).

use crate::error::Result;
use crate::files::write_atomic;
use crate::photometry::Rgb;
use crate::scene::{Material, ModelInput, Scene, Triangle};
use crate::site::Site;
use glam::{DVec2, DVec3};
use std::collections::HashMap;
use std::fmt::Write as _;
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
    /// Triangles added so far.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
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

/// Greensboro, NC (TMY3 station 723170): 36.100 N, 79.950 W, UTC−5, 273 m.
pub fn greensboro() -> Site {
    Site {
        latitude: 36.1,
        longitude: -79.95,
        utc_offset_h: -5.0,
        elevation_m: 273.0,
    }
}

/// The sample office's window in the south wall (y = 0 inner plane), model frame, m:
/// x range, z range.
pub const OFFICE_WINDOW: Rect = Rect {
    a: [1.0, 5.0],
    b: [0.9, 2.4],
};
/// Thickness of the sample office's walls, floor and ceiling, m.
pub const OFFICE_WALL: f64 = 0.2;
/// The plane of the sample office's glazing (mid-wall), y in m.
pub const OFFICE_GLAZING_Y: f64 = -0.5 * OFFICE_WALL;

/// The materials both generated offices share, in this order: floor 0.2, wall 0.5,
/// ceiling 0.8, exterior 0.35, ground 0.2 (diffuse reflectance).
fn add_office_palette(b: &mut SceneBuilder) -> [u32; 5] {
    [
        b.add_opaque("floor", 0.2),
        b.add_opaque("wall", 0.5),
        b.add_opaque("ceiling", 0.8),
        b.add_opaque("exterior", 0.35),
        b.add_opaque("ground", 0.2),
    ]
}

/// The bundled sample scene as a builder (see [`side_lit_office`]).
pub fn side_lit_office_builder() -> SceneBuilder {
    let mut b = SceneBuilder::new();
    let [floor, wall, ceiling, exterior, ground] = add_office_palette(&mut b);
    let obstruction = b.add_opaque("obstruction", 0.3);
    let glass = b.add_glazing("glass", 0.88);

    let (lo, hi) = (DVec3::ZERO, DVec3::new(6.0, 8.0, 3.0));
    let t = OFFICE_WALL;
    let window = Opening {
        face: Face::South,
        rect: OFFICE_WINDOW,
        glazing: None,
    };
    // Inner faces, one group each so they are easy to pick out.
    let none = [None; 6];
    let mut walls = none;
    walls[..4].copy_from_slice(&[Some(wall); 4]);
    b.add_shell("walls", lo, hi, true, walls, &[window]);
    let mut m = none;
    m[Face::Bottom as usize] = Some(floor);
    b.add_shell("floor", lo, hi, true, m, &[]);
    let mut m = none;
    m[Face::Top as usize] = Some(ceiling);
    b.add_shell("ceiling", lo, hi, true, m, &[]);
    // Outer faces of the 0.2 m thick envelope.
    let (olo, ohi) = (lo - DVec3::splat(t), hi + DVec3::splat(t));
    b.add_shell("exterior", olo, ohi, false, [Some(exterior); 6], &[window]);
    // The reveal, split at the mid-wall pane: room side in wall material, outside exterior.
    b.add_reveal(
        "reveal",
        wall,
        Face::South,
        0.0,
        OFFICE_GLAZING_Y,
        OFFICE_WINDOW,
    );
    b.add_reveal(
        "reveal",
        exterior,
        Face::South,
        OFFICE_GLAZING_Y,
        -t,
        OFFICE_WINDOW,
    );
    b.add_rect(
        "glazing",
        glass,
        Face::South,
        OFFICE_GLAZING_Y,
        OFFICE_WINDOW,
    );
    // Obstruction across the street: 20 m wide (centred on the room), 10 m deep, 10 m tall,
    // its north face 12 m from the façade; standing on the ground, so no bottom face.
    let (blo, bhi) = (
        DVec3::new(-7.0, -t - 22.0, 0.0),
        DVec3::new(13.0, -t - 12.0, 10.0),
    );
    let mut m = [Some(obstruction); 6];
    m[Face::Bottom as usize] = None;
    b.add_shell("obstruction", blo, bhi, false, m, &[]);
    // Ground at the floor's level, 60 m × 60 m around the room, with the building's and the
    // obstruction's footprints cut out so nothing overlaps.
    b.add_rect_with_holes(
        "ground",
        ground,
        Face::Top,
        0.0,
        Rect::new([-27.0, 33.0], [-26.0, 34.0]),
        &[
            Rect::new([olo.x, ohi.x], [olo.y, ohi.y]),
            Rect::new([blo.x, bhi.x], [blo.y, bhi.y]),
        ],
    );
    b.add_sensor_grid(DVec2::new(0.5, 0.5), DVec2::new(5.5, 7.5), 0.8, 0.5);
    b.set_site(greensboro());
    b.set_north_deg(0.0);
    b.set_ground_reflectance(0.2);
    b
}

/// The bundled sample scene (`scenes/office`): a 6 m (east–west) × 8 m (north–south) × 3 m
/// side-lit office, interior x∈[0,6], y∈[0,8], z∈[0,3] (model frame, m), 0.2 m thick
/// envelope with separate inner and outer faces, one 4 m × 1.5 m south window (sill 0.9 m)
/// glazed mid-wall with `glass` (Tf 0.88), a lined reveal, a 60 m × 60 m ground at z = 0,
/// a 10 m tall, 20 m wide block 12 m south of the façade, and 165 upward sensors at 0.8 m
/// on a 0.5 m grid. Site Greensboro NC, north along +y.
pub fn side_lit_office() -> Scene {
    side_lit_office_builder()
        .build("<synthetic side_lit_office>")
        .expect("the generated office is valid input")
}

/// Layout constants of [`multi_storey_building`], m.
const BAY: f64 = 3.0;
const STOREY: f64 = 3.5;
const CLEAR: f64 = 3.2;
const WALL: f64 = 0.2;
const SENSOR_SPACING: f64 = 2.4;
const DESK_TRIS: usize = 10;

/// Exact triangle count of the building without desks (see `add_building`).
fn building_base_triangles(floors: usize, nx: usize, ny: usize) -> usize {
    let s = nx + ny;
    let partitions = (nx - 1) / 2;
    // Per storey: room 4s + 28, reveals and glazing 20s, partitions 12 per line; outer
    // shell 4F(s + 4) + 12; ground with the footprint cut out 8.
    floors * (24 * s + 28 + 12 * partitions) + 4 * floors * (s + 4) + 12 + 8
}

/// Adds the building; returns nothing. `desks[i]` desks on floor i.
fn add_building(b: &mut SceneBuilder, floors: usize, nx: usize, ny: usize, desks: &[usize]) {
    let [floor, wall, ceiling, exterior, ground] = add_office_palette(b);
    let partition = b.add_opaque("partition", 0.6);
    let furniture = b.add_opaque("furniture", 0.4);
    let glass = b.add_glazing("glass", 0.88);
    let (w, d) = (nx as f64 * BAY, ny as f64 * BAY);
    let height = floors as f64 * STOREY;
    // One window per bay on every façade, sill 0.9 m, 1.8 m × 1.5 m.
    let windows_on = |face: Face, z0: f64| -> Vec<Opening> {
        let n = if face.axis() == 0 { ny } else { nx };
        (0..n)
            .map(|j| Opening {
                face,
                rect: Rect::new(
                    [j as f64 * BAY + 0.6, j as f64 * BAY + 2.4],
                    [z0 + 0.9, z0 + 2.4],
                ),
                glazing: None,
            })
            .collect()
    };
    let facades = [Face::West, Face::East, Face::South, Face::North];
    let mut all_windows = Vec::new();
    let mut obstacles: Vec<(DVec3, DVec3)> = Vec::new();
    for (i, &n_desks) in desks.iter().enumerate().take(floors) {
        let z0 = i as f64 * STOREY;
        let windows: Vec<Opening> = facades.iter().flat_map(|&f| windows_on(f, z0)).collect();
        let (lo, hi) = (DVec3::new(0.0, 0.0, z0), DVec3::new(w, d, z0 + CLEAR));
        let room = RoomMaterials {
            floor,
            walls: wall,
            ceiling,
        };
        b.add_room("rooms", lo, hi, room, &windows);
        for o in &windows {
            let f = o.face;
            let inner = if f.sign() > 0.0 {
                hi[f.axis()]
            } else {
                lo[f.axis()]
            };
            let outer = inner + f.sign() * WALL;
            b.add_reveal("reveals", exterior, f, inner, outer, o.rect);
            let mid = inner + f.sign() * 0.5 * WALL;
            b.add_rect("glazing", glass, f, mid, o.rect);
        }
        all_windows.extend(windows);
        // Partitions every second bay line, from each long façade to a 0.2·d corridor;
        // three faces (the end against the wall and top/bottom are hidden).
        for k in 1..=(nx - 1) / 2 {
            let x = 2.0 * k as f64 * BAY;
            for (y0, y1, open_end) in [(0.0, 0.4 * d, Face::North), (0.6 * d, d, Face::South)] {
                let plo = DVec3::new(x - 0.05, y0, z0);
                let phi = DVec3::new(x + 0.05, y1, z0 + CLEAR);
                let mut m = [None; 6];
                m[Face::West as usize] = Some(partition);
                m[Face::East as usize] = Some(partition);
                m[open_end as usize] = Some(partition);
                b.add_shell("partitions", plo, phi, false, m, &[]);
                obstacles.push((plo, phi));
            }
        }
        // Desks (1.4 × 0.6 × 0.75 m, no bottom face): two slots per bay cell, filled
        // cell by cell so a few desks spread over the floor.
        let cells = nx * ny;
        for k in 0..n_desks.min(2 * cells) {
            let (cell, slot) = (k % cells, k / cells);
            let cx = (cell % nx) as f64 * BAY + 1.5;
            let cy = (cell / nx) as f64 * BAY + 1.5 + if slot == 0 { -0.35 } else { 0.35 };
            let dlo = DVec3::new(cx - 0.7, cy - 0.3, z0);
            let dhi = DVec3::new(cx + 0.7, cy + 0.3, z0 + 0.75);
            let mut m = [Some(furniture); 6];
            m[Face::Bottom as usize] = None;
            b.add_shell("furniture", dlo, dhi, false, m, &[]);
        }
    }
    let olo = DVec3::new(-WALL, -WALL, -0.3);
    let ohi = DVec3::new(w + WALL, d + WALL, height);
    b.add_shell(
        "exterior",
        olo,
        ohi,
        false,
        [Some(exterior); 6],
        &all_windows,
    );
    b.add_rect_with_holes(
        "ground",
        ground,
        Face::Top,
        0.0,
        Rect::new([-30.0, w + 30.0], [-30.0, d + 30.0]),
        &[Rect::new([olo.x, ohi.x], [olo.y, ohi.y])],
    );
    // Sensors at 0.8 m on every floor, skipping any inside a partition.
    for i in 0..floors {
        let z = i as f64 * STOREY + 0.8;
        let mut y = 0.5;
        while y <= d - 0.5 + 1e-9 {
            let mut x = 0.5;
            while x <= w - 0.5 + 1e-9 {
                let p = DVec3::new(x, y, z);
                let inside = obstacles
                    .iter()
                    .any(|(lo, hi)| p.cmpge(*lo - 0.01).all() && p.cmple(*hi + 0.01).all());
                if !inside {
                    b.add_sensor(p, DVec3::Z);
                }
                x += SENSOR_SPACING;
            }
            y += SENSOR_SPACING;
        }
    }
}

/// A generated office building for benchmarks: storeys of 3.5 m (3.2 m clear, 0.3 m
/// slabs) on a grid of 3 m bays, one glazed 1.8 m × 1.5 m window per bay on all four façades
/// (lined reveals, mid-wall glazing), 0.2 m walls with inner and outer faces, partitions,
/// desks, and a ground at z = 0 reaching 30 m around it. The numbers of floors, bays and
/// desks are chosen so the triangle count is within 10 % of `target_triangles` for targets
/// of 200 and above (the smallest building has 176). Sensors face up 0.8 m above every
/// floor on a 2.4 m grid (1 620 for 10 000 triangles). Deterministic. Site Greensboro NC.
pub fn multi_storey_building(target_triangles: usize) -> Scene {
    let target = target_triangles.max(1);
    let mut floors = ((target as f64).sqrt() / 10.0).round().clamp(1.0, 50.0) as usize;
    // Small targets: fewer floors, so that the smallest plan (2 × 2 bays) still fits.
    while floors > 1 && building_base_triangles(floors, 2, 2) > target {
        floors -= 1;
    }
    // Bays: the base (everything but desks) near 70 % of the target, desks filling the rest.
    let mut best: Option<(f64, usize, usize)> = None;
    for nx in 2..=200usize {
        let ny = nx.div_ceil(2).max(2);
        let base = building_base_triangles(floors, nx, ny);
        let capacity = base + DESK_TRIS * 2 * nx * ny * floors;
        let feasible = base <= target && capacity >= target;
        let score = (base as f64 / target as f64 - 0.7).abs() + if feasible { 0.0 } else { 10.0 };
        if best.is_none_or(|(s, _, _)| score < s) {
            best = Some((score, nx, ny));
        }
    }
    let (_, nx, ny) = best.expect("at least one candidate");
    let base = building_base_triangles(floors, nx, ny);
    let total_desks = (target.saturating_sub(base) + DESK_TRIS / 2) / DESK_TRIS;
    let desks: Vec<usize> = (0..floors)
        .map(|i| total_desks / floors + usize::from(i < total_desks % floors))
        .collect();
    let mut b = SceneBuilder::new();
    add_building(&mut b, floors, nx, ny, &desks);
    b.set_site(greensboro());
    b.set_ground_reflectance(0.2);
    b.build(&format!(
        "<synthetic multi_storey_building {target_triangles}>"
    ))
    .expect("the generated building is valid input")
}

/// Formats a model-frame coordinate: values within rounding of a multiple of 1e-9 m are
/// snapped to it, so `model − origin + origin` prints as the model value (−0.2, not
/// −0.20000000000000018); everything else prints in full (`{}` round-trips f64).
fn coord(x: f64) -> f64 {
    let r = (x * 1e9).round() / 1e9;
    if (r - x).abs() <= 1e-12 * x.abs().max(1.0) {
        r
    } else {
        x
    }
}

/// Writes `scene` in the on-disk format of `/work/shared/INTERFACE.md` into `dir`:
/// `<stem>.obj` (one `g` per group run, `usemtl` per material, shared vertices),
/// `<stem>.mtl` (`Kd`, plus `Tf`/`Ke` where non-zero), `<stem>.pts` (x y z dx dy dz per
/// sensor) and `scene.toml` (relative paths, `up = "z"`, `north_deg = 0`, ground
/// reflectance, `[site]`). Coordinates are in the true-north (ENU) model frame: the scene's
/// origin is added back and, since a [`Scene`] is already rotated to true north, the file
/// says `north_deg = 0`. Every file is written atomically.
///
/// # Errors
/// [`crate::Error::Io`] when a file cannot be written.
pub fn write_obj(scene: &Scene, dir: &Path, stem: &str) -> Result<()> {
    let o = scene.origin;
    let name = |s: &str| s.replace(char::is_whitespace, "_");
    // OBJ.
    let mut obj = String::new();
    let _ = writeln!(obj, "# daystep synthetic scene {}", scene.path.display());
    let _ = writeln!(obj, "# metres, z up, x east, y north");
    let _ = writeln!(obj, "mtllib {stem}.mtl");
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    let mut faces = String::new();
    let mut current: Option<(u32, u32)> = None;
    for t in &scene.triangles {
        if current != Some((t.group, t.material)) {
            let group = scene
                .groups
                .get(t.group as usize)
                .map_or("default", String::as_str);
            let _ = writeln!(faces, "g {}", name(group));
            let _ = writeln!(
                faces,
                "usemtl {}",
                name(&scene.materials[t.material as usize].name)
            );
            current = Some((t.group, t.material));
        }
        let mut ids = [0usize; 3];
        for (k, v) in t.v.iter().enumerate() {
            let p = [coord(v.x + o.x), coord(v.y + o.y), coord(v.z + o.z)];
            let key = p.map(f64::to_bits);
            let next = index.len() + 1;
            ids[k] = *index.entry(key).or_insert_with(|| {
                let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
                next
            });
        }
        let _ = writeln!(faces, "f {} {} {}", ids[0], ids[1], ids[2]);
    }
    obj.push_str(&faces);
    // MTL.
    let mut mtl =
        String::from("# daystep synthetic materials: Kd reflectance, Tf glazing transmittance\n");
    for m in &scene.materials {
        let _ = writeln!(mtl, "\nnewmtl {}", name(&m.name));
        let _ = writeln!(mtl, "Kd {} {} {}", m.kd.x, m.kd.y, m.kd.z);
        if m.tf != Rgb::ZERO {
            let _ = writeln!(mtl, "Tf {} {} {}", m.tf.x, m.tf.y, m.tf.z);
        }
        if m.ke != Rgb::ZERO {
            let _ = writeln!(mtl, "Ke {} {} {}", m.ke.x, m.ke.y, m.ke.z);
        }
    }
    // Sensors.
    let mut pts = String::new();
    for s in &scene.sensors {
        let p = s.position + o;
        let n = s.normal;
        let _ = writeln!(
            pts,
            "{} {} {} {} {} {}",
            coord(p.x),
            coord(p.y),
            coord(p.z),
            coord(n.x),
            coord(n.y),
            coord(n.z)
        );
    }
    // Scene file; `{:?}` keeps a decimal point so TOML reads floats.
    let site = &scene.site;
    let toml = format!(
        "# daystep scene: {}\ngeometry = \"{stem}.obj\"\nsensors = \"{stem}.pts\"\nup = \"z\"\n\
         north_deg = 0.0\nground_reflectance = {:?}\n\n[site]\nlatitude = {:?}\n\
         longitude = {:?}\nutc_offset_h = {:?}\nelevation_m = {:?}\n",
        scene.path.display(),
        scene.ground_reflectance,
        site.latitude,
        site.longitude,
        site.utc_offset_h,
        site.elevation_m,
    );
    write_atomic(&dir.join(format!("{stem}.obj")), obj.as_bytes())?;
    write_atomic(&dir.join(format!("{stem}.mtl")), mtl.as_bytes())?;
    write_atomic(&dir.join(format!("{stem}.pts")), pts.as_bytes())?;
    write_atomic(&dir.join("scene.toml"), toml.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::bvh::Bvh;

    fn model(scene: &Scene, p: DVec3) -> DVec3 {
        p + scene.origin
    }

    fn group_of<'a>(scene: &'a Scene, t: &Triangle) -> &'a str {
        &scene.groups[t.group as usize]
    }

    #[test]
    fn rect_faces_point_where_asked() {
        for face in Face::ALL {
            let mut b = SceneBuilder::new();
            let m = b.add_opaque("m", 0.5);
            b.add_rect("g", m, face, 1.0, Rect::new([0.0, 2.0], [0.0, 1.0]));
            let s = b.build("t").unwrap();
            assert_eq!(s.triangles.len(), 2);
            for t in &s.triangles {
                assert!((t.normal() - face.normal()).length() < 1e-12, "{face:?}");
            }
            let area: f64 = s.triangles.iter().map(Triangle::area).sum();
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
        for t in &s.triangles {
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
        assert_eq!(s.triangles.len(), 4);
        let area: f64 = s.triangles.iter().map(Triangle::area).sum();
        assert!((area - 1.5 * 3f64.sqrt()).abs() < 1e-12);
        assert!(s.triangles.iter().all(|t| t.normal().z > 0.999));
    }

    #[test]
    fn office_counts_areas_and_normals() {
        let s = side_lit_office();
        assert_eq!(s.dropped_degenerate, 0);
        assert_eq!(s.sensors.len(), 11 * 15);
        assert!(
            (50..1000).contains(&s.triangles.len()),
            "{}",
            s.triangles.len()
        );
        assert_eq!(s.site, greensboro());
        let room_centre = DVec3::new(3.0, 4.0, 1.5);
        let building_centre = room_centre;
        let block_centre = DVec3::new(3.0, -17.2, 5.0);
        let window_axis = |p: DVec3| DVec3::new(3.0, p.y, 1.65);
        let mut area_by_group: HashMap<&str, f64> = HashMap::new();
        for t in &s.triangles {
            assert!(t.area() > 1e-3, "{t:?}");
            let n = t.normal();
            let c = model(&s, t.centroid());
            let g = group_of(&s, t);
            *area_by_group.entry(g).or_default() += t.area();
            let ok = match g {
                "floor" => (n - DVec3::Z).length() < 1e-12,
                "ceiling" => (n + DVec3::Z).length() < 1e-12,
                "walls" => (room_centre - c).dot(n) > 0.0,
                "exterior" => (c - building_centre).dot(n) > 0.0,
                "reveal" => (window_axis(c) - c).dot(n) > 0.0,
                "glazing" => (n + DVec3::Y).length() < 1e-12,
                "ground" => (n - DVec3::Z).length() < 1e-12,
                "obstruction" => (c - block_centre).dot(n) > 0.0,
                other => panic!("unexpected group {other}"),
            };
            assert!(ok, "group {g}: normal {n} at {c}");
        }
        let near = |g: &str, want: f64| {
            let a = area_by_group[g];
            assert!((a - want).abs() < 1e-9, "{g}: {a} vs {want}");
        };
        near("floor", 48.0);
        near("ceiling", 48.0);
        near("glazing", 6.0);
        near("walls", 2.0 * 3.0 * (6.0 + 8.0) - 6.0);
        near("reveal", 2.0 * 0.2 * (4.0 + 1.5));
        near("ground", 3600.0 - 6.4 * 8.4 - 200.0);
    }

    /// Unit directions spread over the sphere (Fibonacci lattice).
    fn sphere_dirs(n: usize) -> Vec<DVec3> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect()
    }

    #[test]
    fn office_room_is_closed_except_through_the_glazing() {
        let s = side_lit_office();
        let tris: Vec<[DVec3; 3]> = s.triangles.iter().map(|t| t.v).collect();
        let bvh = Bvh::build(&tris);
        let glass = s.materials.iter().position(|m| m.name == "glass").unwrap() as u32;
        let w = OFFICE_WINDOW;
        let mut origins = vec![DVec3::new(3.0, 4.0, 1.5), DVec3::new(0.3, 0.2, 2.9)];
        origins.extend(s.sensors.iter().step_by(7).map(|x| model(&s, x.position)));
        let mut dirs = sphere_dirs(4000);
        let mut through_glass = 0;
        for (i, &o) in origins.iter().enumerate() {
            if i < 2 {
                // Aim exactly at the window's corners and edges, where leaks would show.
                for (x, z) in [
                    (w.a[0], w.b[0]),
                    (w.a[1], w.b[1]),
                    (3.0, w.b[0]),
                    (w.a[0], 1.65),
                ] {
                    for y in [0.0, OFFICE_GLAZING_Y, -OFFICE_WALL] {
                        dirs.push((DVec3::new(x, y, z) - o).normalize());
                    }
                }
            }
            let o_scene = o - s.origin;
            for &d in &dirs {
                let h = bvh
                    .closest_hit(o_scene, d, 1e-9, f64::INFINITY)
                    .unwrap_or_else(|| panic!("ray from {o} along {d} escapes"));
                let t = &s.triangles[h.triangle as usize];
                let p = model(&s, o_scene + h.t * d);
                if t.material == glass {
                    through_glass += 1;
                    assert!((p.y - OFFICE_GLAZING_Y).abs() < 1e-9, "{p}");
                    assert!(
                        p.x >= w.a[0] - 1e-9
                            && p.x <= w.a[1] + 1e-9
                            && p.z >= w.b[0] - 1e-9
                            && p.z <= w.b[1] + 1e-9,
                        "glazing hit outside the window at {p}"
                    );
                } else {
                    let g = group_of(&s, t);
                    assert!(
                        matches!(g, "floor" | "ceiling" | "walls" | "reveal"),
                        "ray from {o} along {d} first meets {g} at {p}"
                    );
                    assert!(h.cos < 0.0, "seen from behind: {g} at {p}");
                }
            }
        }
        assert!(through_glass > 100, "{through_glass}");
    }

    #[test]
    fn building_hits_its_triangle_target() {
        for target in [200, 300, 600, 1_000, 3_000, 10_000, 25_000, 100_000] {
            let s = multi_storey_building(target);
            let n = s.triangles.len();
            assert!(
                (n as f64 - target as f64).abs() <= 0.1 * target as f64,
                "target {target}: {n}"
            );
            assert_eq!(s.dropped_degenerate, 0);
            assert!(s.has_glazing());
            if target == 10_000 {
                assert!(
                    (1500..=1700).contains(&s.sensors.len()),
                    "{}",
                    s.sensors.len()
                );
            }
        }
    }

    #[test]
    fn building_base_count_formula_matches_geometry() {
        for (floors, nx, ny) in [(1, 2, 2), (2, 5, 3), (3, 8, 4)] {
            let mut b = SceneBuilder::new();
            add_building(&mut b, floors, nx, ny, &vec![0; floors]);
            assert_eq!(b.triangle_count(), building_base_triangles(floors, nx, ny));
            let mut b = SceneBuilder::new();
            add_building(&mut b, floors, nx, ny, &vec![3; floors]);
            assert_eq!(
                b.triangle_count(),
                building_base_triangles(floors, nx, ny) + 3 * floors * DESK_TRIS
            );
        }
    }

    #[test]
    fn building_sensors_see_a_ceiling_above_and_a_floor_or_desk_below() {
        let s = multi_storey_building(3_000);
        let tris: Vec<[DVec3; 3]> = s.triangles.iter().map(|t| t.v).collect();
        let bvh = Bvh::build(&tris);
        for x in &s.sensors {
            let up = bvh
                .closest_hit(x.position, DVec3::Z, 0.0, f64::INFINITY)
                .unwrap();
            let t = &s.triangles[up.triangle as usize];
            assert_eq!(s.materials[t.material as usize].name, "ceiling");
            assert!((up.t - (CLEAR - 0.8)).abs() < 1e-9);
            let down = bvh
                .closest_hit(x.position, -DVec3::Z, 0.0, f64::INFINITY)
                .unwrap();
            let name = &s.materials[s.triangles[down.triangle as usize].material as usize].name;
            assert!(name == "floor" || name == "furniture", "{name}");
            assert!(down.cos < 0.0);
        }
    }

    /// Minimal OBJ reader for the test (the real parser lives elsewhere): triangles only.
    fn read_obj_triangles(text: &str) -> Vec<[DVec3; 3]> {
        let mut v = Vec::new();
        let mut out = Vec::new();
        for line in text.lines() {
            let mut it = line.split_whitespace();
            match it.next() {
                Some("v") => {
                    let c: Vec<f64> = it.map(|x| x.parse().unwrap()).collect();
                    v.push(DVec3::new(c[0], c[1], c[2]));
                }
                Some("f") => {
                    let i: Vec<usize> = it.map(|x| x.parse().unwrap()).collect();
                    assert_eq!(i.len(), 3);
                    out.push([v[i[0] - 1], v[i[1] - 1], v[i[2] - 1]]);
                }
                _ => {}
            }
        }
        out
    }

    #[test]
    fn write_obj_round_trips_counts_and_coordinates() {
        let s = side_lit_office();
        let dir = tempfile::tempdir().unwrap();
        write_obj(&s, dir.path(), "office").unwrap();
        let read = |n: &str| std::fs::read_to_string(dir.path().join(n)).unwrap();
        let obj = read("office.obj");
        let tris = read_obj_triangles(&obj);
        assert_eq!(tris.len(), s.triangles.len());
        for (a, b) in tris.iter().zip(&s.triangles) {
            for (p, q) in a.iter().zip(b.v) {
                assert!((*p - model(&s, q)).length() < 1e-9);
            }
        }
        assert!(obj.contains("\ng glazing\nusemtl glass\n"));
        let pts = read("office.pts");
        assert_eq!(pts.lines().count(), s.sensors.len());
        assert_eq!(pts.lines().next().unwrap(), "0.5 0.5 0.8 0 0 1");
        let mtl = read("office.mtl");
        assert_eq!(mtl.matches("newmtl ").count(), s.materials.len());
        assert!(mtl.contains("newmtl glass\nKd 0 0 0\nTf 0.88 0.88 0.88\n"));
        assert!(mtl.contains("newmtl ceiling\nKd 0.8 0.8 0.8\n"));
        let toml: toml::Value = toml::from_str(&read("scene.toml")).unwrap();
        assert_eq!(toml["geometry"].as_str(), Some("office.obj"));
        assert_eq!(toml["sensors"].as_str(), Some("office.pts"));
        assert_eq!(toml["up"].as_str(), Some("z"));
        assert_eq!(toml["north_deg"].as_float(), Some(0.0));
        assert_eq!(toml["ground_reflectance"].as_float(), Some(0.2));
        assert_eq!(toml["site"]["latitude"].as_float(), Some(36.1));
        assert_eq!(toml["site"]["longitude"].as_float(), Some(-79.95));
        assert_eq!(toml["site"]["utc_offset_h"].as_float(), Some(-5.0));
        assert_eq!(toml["site"]["elevation_m"].as_float(), Some(273.0));
    }

    fn bundled_dir() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office")
    }

    #[test]
    fn bundled_office_matches_the_generator() {
        let s = side_lit_office();
        let dir = tempfile::tempdir().unwrap();
        write_obj(&s, dir.path(), "office").unwrap();
        for name in ["scene.toml", "office.obj", "office.mtl", "office.pts"] {
            let fresh = std::fs::read(dir.path().join(name)).unwrap();
            let bundled = std::fs::read(bundled_dir().join(name)).unwrap_or_default();
            assert!(
                fresh == bundled,
                "scenes/office/{name} is stale: run `cargo test --lib -- --ignored \
                 scene::synthetic::tests::write_bundled_office`"
            );
        }
    }

    /// Prints BVH build and per-ray timings on `multi_storey_building(10_000)` (run with
    /// `cargo test --release --lib -- --ignored --nocapture bvh_timing_report`; no asserts).
    #[test]
    #[ignore]
    fn bvh_timing_report() {
        let s = multi_storey_building(10_000);
        let tris: Vec<[DVec3; 3]> = s.triangles.iter().map(|t| t.v).collect();
        let t0 = std::time::Instant::now();
        let bvh = Bvh::build(&tris);
        let build = t0.elapsed();
        let dirs = sphere_dirs(256);
        let up: Vec<DVec3> = dirs
            .iter()
            .map(|d| DVec3::new(d.x, d.y, d.z.abs()))
            .collect();
        let (mut rays, mut hits, mut found) = (0usize, 0usize, 0usize);
        let t0 = std::time::Instant::now();
        for x in &s.sensors {
            for &d in &up {
                rays += 1;
                // Stop at the first opaque hit, as sensor visibility does.
                bvh.hits_in_order(x.position, d, 1e-6, f64::INFINITY, |h| {
                    hits += 1;
                    s.materials[s.triangles[h.triangle as usize].material as usize].is_glazing()
                });
            }
        }
        let ordered = t0.elapsed();
        let t0 = std::time::Instant::now();
        for x in &s.sensors {
            for &d in &up {
                found += usize::from(bvh.any_hit(x.position, d, 1e-6, f64::INFINITY));
            }
        }
        let any = t0.elapsed();
        println!(
            "{} triangles, {} sensors: build {:?}; hits_in_order {:.2} µs/ray ({} rays, {:.2} \
             hits/ray); any_hit {:.2} µs/ray ({found} blocked)",
            s.triangles.len(),
            s.sensors.len(),
            build,
            ordered.as_secs_f64() * 1e6 / rays as f64,
            rays,
            hits as f64 / rays as f64,
            any.as_secs_f64() * 1e6 / rays as f64,
        );
        let o = side_lit_office();
        println!(
            "office: {} triangles, {} sensors",
            o.triangles.len(),
            o.sensors.len()
        );
    }

    /// Regenerates the bundled sample `scenes/office` (run explicitly with `--ignored`).
    #[test]
    #[ignore]
    fn write_bundled_office() {
        write_obj(&side_lit_office(), &bundled_dir(), "office").unwrap();
    }
}
