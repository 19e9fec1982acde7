//! Honeybee models (HBJSON, honeybee-schema `Model`) as a geometry source: rooms, faces,
//! apertures, doors, shades and shade meshes, with their Radiance modifiers, sensor grids,
//! views and aperture groups (docs/models.md).
//!
//! Geometry follows honeybee-radiance's Radiance writer (`honeybee_radiance/writer.py`,
//! `model_to_rad`, and `ModelRadianceProperties.faces_by_blk`), so that daystep reads the
//! same scene Radiance gets from honeybee:
//! - apertures and doors are cut out of their face (the face's "punched" geometry) and
//!   added as polygons of their own;
//! - `AirBoundary` faces are left out (honeybee gives them the fully transparent
//!   `air_boundary` modifier and writes no geometry for them);
//! - a face with a `Surface` boundary condition (an interior face shared by two rooms)
//!   appears in the model once per room: both are kept, the second of each pair moved
//!   back by twice the model's tolerance against its normal, and the interior apertures
//!   and doors are taken from the first only;
//! - objects with a dynamic group are kept in their default state and listed in
//!   [`Imported::aperture_groups`].

use super::hbjson_modifiers::{Modifiers, Slot, Who};
use super::hbjson_schema::*;
use super::imported::{ApertureGroup, GridInfo, ImportCounts, Imported, NamedView};
use super::polygon::{encloses, newell_normal, triangulate, PolygonIssue};
use super::view::{View, ViewType};
use super::{Material, Triangle};
use crate::error::{Error, Result};
use crate::files;
use glam::DVec3;
use serde::de::DeserializeOwned;
use serde_json::Value;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Detailed warnings of one kind of bad geometry listed before the rest are only counted.
const DETAILED_WARNINGS: usize = 50;

/// What [`load`] returns.
#[derive(Clone, Debug, Default)]
pub struct HbjsonContents {
    /// Triangles in the model frame, metres, Z up; `group` indexes `groups`.
    pub triangles: Vec<Triangle>,
    /// Materials used, in order of first use.
    pub materials: Vec<Material>,
    /// Identifier of each object that made triangles (one group per object).
    pub groups: Vec<String>,
    /// The sensors of all grids, in model order: (position m, direction), model frame.
    pub sensors: Vec<(DVec3, DVec3)>,
    /// Rooms, grids (with [`Imported::sensor_grid`] for `sensors`), views, aperture groups,
    /// bad-geometry counts.
    pub imported: Imported,
    /// Approximations and bad geometry, each naming the object.
    pub warnings: Vec<String>,
}

/// Loads an HBJSON file.
///
/// # Errors
/// [`Error::Input`] naming the file and the object's identifier (or its position when it
/// has none) for malformed JSON (with line and column), a value of the wrong type, a
/// missing identifier, unknown units, non-finite coordinates, an unknown face type, a
/// room referring to an undefined modifier set, and any modifier daystep cannot model
/// (docs/models.md); [`Error::Io`] when the file cannot be read.
pub fn load(path: &Path) -> Result<HbjsonContents> {
    let text = files::read_text(path)?;
    parse(path, &text)
}

/// How the model's units become metres: multiplied, or divided (exact for decimal
/// millimetres and centimetres: 1234 / 1000 rounds to the same double as 1.234).
#[derive(Clone, Copy)]
enum Units {
    Times(f64),
    Over(f64),
}

impl Units {
    fn m(self, x: f64) -> f64 {
        match self {
            Units::Times(k) => x * k,
            Units::Over(k) => x / k,
        }
    }
}

/// Parses HBJSON text; `path` names it in errors.
///
/// # Errors
/// As [`load`].
pub fn parse(path: &Path, text: &str) -> Result<HbjsonContents> {
    let value: Value = serde_json::from_str(text).map_err(|e| {
        let line = text.lines().nth(e.line().saturating_sub(1)).map(str::trim);
        let value = line.filter(|l| !l.is_empty() && l.len() <= 80);
        Error::input(
            path,
            Some(e.line()),
            value,
            format!(
                "invalid JSON at line {}, column {}: {e}",
                e.line(),
                e.column()
            ),
        )
    })?;
    let model_id = value
        .get("identifier")
        .and_then(Value::as_str)
        .map(str::to_owned);
    let model: ModelJ = serde_json::from_value(value).map_err(|e| {
        Error::input(
            path,
            None,
            model_id.as_deref(),
            format!("not a honeybee Model: {e}"),
        )
    })?;
    let model_name = model.identifier.clone().unwrap_or_default();
    if let Some(k) = model.kind.as_deref().filter(|k| *k != "Model") {
        return Err(Error::input(
            path,
            None,
            Some(k),
            format!("this is a honeybee {k}, not a Model: export the whole model"),
        ));
    }
    let units = match model.units.as_deref().unwrap_or("Meters") {
        "Meters" => Units::Times(1.0),
        "Millimeters" => Units::Over(1000.0),
        "Centimeters" => Units::Over(100.0),
        "Feet" => Units::Times(0.3048),
        "Inches" => Units::Times(0.0254),
        other => {
            return Err(Error::input(
                path,
                None,
                Some(other),
                format!(
                    "Model `{model_name}`: unknown units; honeybee's are Meters, \
                     Millimeters, Centimeters, Feet and Inches"
                ),
            ))
        }
    };
    let tolerance = model.tolerance.unwrap_or(0.01);
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(Error::input(
            path,
            None,
            Some(&tolerance.to_string()),
            format!("Model `{model_name}`: tolerance must be a finite number ≥ 0"),
        ));
    }
    let radiance: ModelRadianceJ = match model.properties.and_then(|p| p.radiance) {
        None | Some(Value::Null) => ModelRadianceJ::default(),
        Some(v) => serde_json::from_value(v).map_err(|e| {
            Error::input(
                path,
                None,
                Some(&model_name),
                format!("Model `{model_name}`: invalid properties.radiance: {e}"),
            )
        })?,
    };
    let modifiers = Modifiers::new(
        path,
        radiance.modifiers.unwrap_or_default(),
        radiance.modifier_sets.unwrap_or_default(),
        radiance.global_modifier_set,
    )?;
    let mut b = Builder {
        path: path.to_path_buf(),
        model: model_name.clone(),
        units,
        tol_m: units.m(tolerance),
        mods: modifiers,
        out: HbjsonContents::default(),
        group_room: Vec::new(),
        surface_partners: HashSet::new(),
        group_of: HashMap::new(),
        detailed: [0; 4],
    };
    for (k, room) in model.rooms.unwrap_or_default().into_iter().enumerate() {
        b.room(room, k)?;
    }
    for (k, f) in model
        .orphaned_faces
        .unwrap_or_default()
        .into_iter()
        .enumerate()
    {
        let ctx = || format!("orphaned face {}", k + 1);
        b.face(f, None, &ctx)?;
    }
    for (k, a) in model
        .orphaned_apertures
        .unwrap_or_default()
        .into_iter()
        .enumerate()
    {
        let ctx = || format!("orphaned aperture {}", k + 1);
        let s: SubFaceJ = b.parse(a, "Aperture", &ctx)?;
        b.sub_face(s, SubKind::Aperture, "Wall", None)?;
    }
    for (k, d) in model
        .orphaned_doors
        .unwrap_or_default()
        .into_iter()
        .enumerate()
    {
        let ctx = || format!("orphaned door {}", k + 1);
        let s: SubFaceJ = b.parse(d, "Door", &ctx)?;
        b.sub_face(s, SubKind::Door, "Wall", None)?;
    }
    for (k, s) in model
        .orphaned_shades
        .unwrap_or_default()
        .into_iter()
        .enumerate()
    {
        let ctx = || format!("orphaned shade {}", k + 1);
        b.shade(s, None, Parent::Orphan, false, &ctx)?;
    }
    for (k, s) in model
        .shade_meshes
        .unwrap_or_default()
        .into_iter()
        .enumerate()
    {
        let ctx = || format!("shade mesh {}", k + 1);
        b.shade_mesh(s, &ctx)?;
    }
    for (k, g) in radiance
        .sensor_grids
        .unwrap_or_default()
        .into_iter()
        .enumerate()
    {
        let ctx = || format!("sensor grid {}", k + 1);
        b.grid(g, &ctx)?;
    }
    for (k, v) in radiance.views.unwrap_or_default().into_iter().enumerate() {
        let ctx = || format!("view {}", k + 1);
        b.view(v, &ctx)?;
    }
    b.finish()
}

/// Which counted kind of bad geometry (index into `Builder::detailed`).
const ZERO: usize = 0;
const WARP: usize = 1;
const CROSS: usize = 2;
const OUTSIDE: usize = 3;

/// Apertures and doors.
#[derive(Clone, Copy, PartialEq)]
enum SubKind {
    Aperture,
    Door,
}

/// What a shade hangs on: decides its default modifier.
#[derive(Clone, Copy)]
enum Parent<'a> {
    /// An orphaned shade.
    Orphan,
    /// A shade of a room or of one of its faces or sub-faces (the room's set, if any).
    Set(Option<&'a str>),
}

struct Builder {
    path: PathBuf,
    /// The model's identifier.
    model: String,
    units: Units,
    tol_m: f64,
    mods: Modifiers,
    out: HbjsonContents,
    group_room: Vec<Option<u32>>,
    /// Identifiers of the partners of interior faces already read.
    surface_partners: HashSet<String>,
    /// Aperture group identifier → index into `out.imported.aperture_groups`.
    group_of: HashMap<String, usize>,
    /// Detailed warnings given so far per kind (ZERO, WARP, CROSS, OUTSIDE).
    detailed: [usize; 4],
}

impl Builder {
    /// Converts one object, naming it by identifier (or by `ctx` when it has none).
    fn parse<T: DeserializeOwned>(
        &self,
        v: Value,
        kind: &str,
        ctx: &dyn Fn() -> String,
    ) -> Result<T> {
        let id = v
            .get("identifier")
            .and_then(Value::as_str)
            .map(str::to_owned);
        serde_json::from_value(v).map_err(|e| match &id {
            Some(id) => Error::input(&self.path, None, Some(id), format!("{kind} `{id}`: {e}")),
            None => Error::input(
                &self.path,
                None,
                None,
                format!("{kind} ({}) has no valid identifier: {e}", ctx()),
            ),
        })
    }

    fn bad(&self, who: Who, message: impl std::fmt::Display) -> Error {
        let (id, kind) = who;
        Error::input(
            &self.path,
            None,
            Some(id),
            format!("{kind} `{id}`: {message}"),
        )
    }

    /// A point in metres; an error naming `who` when it is not finite.
    fn point(&self, p: [f64; 3], who: Who) -> Result<DVec3> {
        let v = DVec3::from_array(p.map(|x| self.units.m(x)));
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.bad(who, format!("coordinate {p:?} is not a finite number")))
        }
    }

    fn ring(&self, r: &[[f64; 3]], who: Who) -> Result<Vec<DVec3>> {
        r.iter().map(|p| self.point(*p, who)).collect()
    }

    /// Boundary and holes of a `Face3D`, metres.
    fn face3d(&self, g: &Face3DJ, who: Who) -> Result<(Vec<DVec3>, Vec<Vec<DVec3>>)> {
        let boundary = self.ring(&g.boundary, who)?;
        let holes = g
            .holes
            .iter()
            .flatten()
            .map(|h| self.ring(h, who))
            .collect::<Result<Vec<_>>>()?;
        Ok((boundary, holes))
    }

    /// A warning of counted kind `kind`; after [`DETAILED_WARNINGS`] of a kind only counted.
    fn count(&mut self, kind: usize, message: String) {
        let c = &mut self.out.imported.counts;
        match kind {
            ZERO => c.zero_area += 1,
            WARP => c.non_planar += 1,
            CROSS => c.self_intersecting += 1,
            _ => c.apertures_outside_parent += 1,
        }
        self.detailed[kind] += 1;
        if self.detailed[kind] <= DETAILED_WARNINGS {
            self.out
                .warnings
                .push(format!("{}: {message}", self.path.display()));
        }
    }

    /// Triangulates a polygon and adds it as object `who` (a group of its own) of `room`.
    fn polygon(
        &mut self,
        boundary: &[DVec3],
        holes: &[Vec<DVec3>],
        material: u32,
        who: Who,
        room: Option<u32>,
    ) {
        let t = triangulate(boundary, holes, self.tol_m);
        let (id, kind) = who;
        for issue in &t.issues {
            match issue {
                PolygonIssue::ZeroArea => {
                    self.count(ZERO, format!("{kind} `{id}` encloses no area: left out"))
                }
                PolygonIssue::NonPlanar { deviation_m } => self.count(
                    WARP,
                    format!(
                        "{kind} `{id}` is not planar: a vertex lies {deviation_m:.4} m from its \
                         plane (tolerance {} m); triangulated on its projection",
                        self.tol_m
                    ),
                ),
                PolygonIssue::SelfIntersecting => self.count(
                    CROSS,
                    format!(
                        "{kind} `{id}` has a self-intersecting outline: the triangles may not \
                         cover what was meant"
                    ),
                ),
            }
        }
        if t.triangles.is_empty() {
            return;
        }
        let group = self.out.groups.len() as u32;
        self.out.groups.push(id.to_string());
        self.group_room.push(room);
        self.out.triangles.extend(
            t.triangles
                .into_iter()
                .map(|v| Triangle { v, material, group }),
        );
    }

    /// The material of an object: its own modifier, else `fallback`'s.
    fn material(&mut self, own: Option<&str>, fallback: String, who: Who) -> Result<u32> {
        let id = own.map(str::to_owned).unwrap_or(fallback);
        self.mods.material(&id, who)
    }

    fn room(&mut self, v: Value, k: usize) -> Result<()> {
        let ctx = || format!("room {}", k + 1);
        let room: RoomJ = self.parse(v, "Room", &ctx)?;
        let who: Who = (&room.identifier, "Room");
        let set = room
            .properties
            .radiance
            .as_ref()
            .and_then(|r| r.modifier_set.clone());
        if let Some(s) = &set {
            if !self.mods.has_set(s) {
                return Err(self.bad(
                    who,
                    format!(
                        "modifier set `{s}` is not defined in properties.radiance.modifier_sets"
                    ),
                ));
            }
        }
        let index = self.out.imported.rooms.len() as u32;
        self.out.imported.rooms.push(room.identifier.clone());
        let r = Some((index, set.as_deref()));
        for (j, f) in room.faces.into_iter().enumerate() {
            let ctx = || format!("face {} of room `{}`", j + 1, room.identifier);
            self.face(f, r, &ctx)?;
        }
        let shades = room.indoor_shades.into_iter().flatten().map(|s| (s, true));
        let shades = shades.chain(
            room.outdoor_shades
                .into_iter()
                .flatten()
                .map(|s| (s, false)),
        );
        for (j, (s, indoor)) in shades.enumerate() {
            let ctx = || format!("shade {} of room `{}`", j + 1, room.identifier);
            self.shade(s, Some(index), Parent::Set(set.as_deref()), indoor, &ctx)?;
        }
        Ok(())
    }

    /// One face, its apertures, doors and shades; `room` is (index, modifier set).
    fn face(
        &mut self,
        v: Value,
        room: Option<(u32, Option<&str>)>,
        ctx: &dyn Fn() -> String,
    ) -> Result<()> {
        let f: FaceJ = self.parse(v, "Face", ctx)?;
        let who: Who = (&f.identifier, "Face");
        let (room_index, set) = room.map_or((None, None), |(i, s)| (Some(i), s));
        let exterior = f.boundary_condition.kind == "Outdoors";
        let slot = match (f.face_type.as_str(), exterior) {
            ("Wall", true) => Some(Slot::WallExterior),
            ("Wall", false) => Some(Slot::WallInterior),
            ("Floor", true) => Some(Slot::FloorExterior),
            ("Floor", false) => Some(Slot::FloorInterior),
            ("RoofCeiling", true) => Some(Slot::RoofExterior),
            ("RoofCeiling", false) => Some(Slot::RoofInterior),
            ("AirBoundary", _) => None,
            (other, _) => {
                return Err(self.bad(
                    who,
                    format!(
                        "unknown face_type `{other}` (honeybee's are Wall, Floor, RoofCeiling \
                         and AirBoundary)"
                    ),
                ))
            }
        };
        let (boundary, mut holes) = self.face3d(&f.geometry, who)?;
        // The second face of an interior pair: moved back, its sub-faces left to the first.
        let mut second = false;
        if f.boundary_condition.kind == "Surface" {
            if self.surface_partners.contains(&f.identifier) {
                second = true;
            } else if let Some(other) = f
                .boundary_condition
                .boundary_condition_objects
                .as_ref()
                .and_then(|o| o.first())
            {
                self.surface_partners.insert(other.clone());
            }
        }
        let parent_type = f.face_type.clone();
        let subs = f
            .apertures
            .into_iter()
            .flatten()
            .map(|a| (a, SubKind::Aperture))
            .chain(f.doors.into_iter().flatten().map(|d| (d, SubKind::Door)));
        let mut kept = Vec::new();
        for (j, (v, kind)) in subs.enumerate() {
            let name = if kind == SubKind::Aperture {
                "Aperture"
            } else {
                "Door"
            };
            let ctx = || format!("sub-face {} of face `{}`", j + 1, f.identifier);
            let s: SubFaceJ = self.parse(v, name, &ctx)?;
            let (outline, _) = self.face3d(&s.geometry, (&s.identifier, name))?;
            if encloses(&boundary, &holes, &outline, self.tol_m) {
                holes.push(outline);
            } else {
                self.count(
                    OUTSIDE,
                    format!(
                        "{name} `{}` is not inside its face `{}` (plane or outline): not cut \
                         out of the face",
                        s.identifier, f.identifier
                    ),
                );
            }
            kept.push((s, kind));
        }
        if let Some(slot) = slot {
            let own = f
                .properties
                .radiance
                .as_ref()
                .and_then(|r| r.modifier.clone());
            let fallback = self.mods.set_modifier(set, slot);
            let material = self.material(own.as_deref(), fallback, who)?;
            if second && self.tol_m > 0.0 {
                let shift = newell_normal(&boundary).unwrap_or(DVec3::ZERO) * (-2.0 * self.tol_m);
                let moved: Vec<DVec3> = boundary.iter().map(|p| *p + shift).collect();
                let moved_holes: Vec<Vec<DVec3>> = holes
                    .iter()
                    .map(|h| h.iter().map(|p| *p + shift).collect())
                    .collect();
                self.polygon(&moved, &moved_holes, material, who, room_index);
            } else {
                self.polygon(&boundary, &holes, material, who, room_index);
            }
        }
        if !second {
            for (s, kind) in kept {
                self.sub_face(s, kind, &parent_type, room)?;
            }
        }
        let shades = f.indoor_shades.into_iter().flatten().map(|s| (s, true));
        let shades = shades.chain(f.outdoor_shades.into_iter().flatten().map(|s| (s, false)));
        for (j, (s, indoor)) in shades.enumerate() {
            let ctx = || format!("shade {} of face `{}`", j + 1, f.identifier);
            self.shade(s, room_index, Parent::Set(set), indoor, &ctx)?;
        }
        Ok(())
    }

    /// An aperture or door with its shades; `room` is (index, modifier set), `None` for
    /// orphans (whose default modifier comes from the global set).
    fn sub_face(
        &mut self,
        s: SubFaceJ,
        kind: SubKind,
        parent_type: &str,
        room: Option<(u32, Option<&str>)>,
    ) -> Result<()> {
        let name = if kind == SubKind::Aperture {
            "Aperture"
        } else {
            "Door"
        };
        let who: Who = (&s.identifier, name);
        let (room_index, set) = room.map_or((None, None), |(i, s)| (Some(i), s));
        let outdoors = match s.boundary_condition.kind.as_str() {
            "Outdoors" => true,
            "Surface" => false,
            other => {
                return Err(self.bad(
                    who,
                    format!("boundary condition `{other}`: an {name} is Outdoors or Surface"),
                ))
            }
        };
        let slot = match (kind, outdoors) {
            (SubKind::Aperture, true) if s.is_operable => Slot::Operable,
            (SubKind::Aperture, true) if parent_type == "Wall" => Slot::Window,
            (SubKind::Aperture, true) => Slot::Skylight,
            (SubKind::Aperture, false) => Slot::ApertureInterior,
            (SubKind::Door, true) if s.is_glass => Slot::DoorExteriorGlass,
            (SubKind::Door, true) if parent_type == "Wall" => Slot::DoorExterior,
            (SubKind::Door, true) => Slot::DoorOverhead,
            (SubKind::Door, false) if s.is_glass => Slot::DoorInteriorGlass,
            (SubKind::Door, false) => Slot::DoorInterior,
        };
        let rad = s.properties.radiance.as_ref();
        let own = rad.and_then(|r| r.modifier.clone());
        let fallback = self.mods.set_modifier(set, slot);
        let material = self.material(own.as_deref(), fallback, who)?;
        if let Some(r) = rad {
            self.dynamic_group(&s.identifier, r);
        }
        let (boundary, holes) = self.face3d(&s.geometry, who)?;
        self.polygon(&boundary, &holes, material, who, room_index);
        let shades = s.indoor_shades.into_iter().flatten().map(|v| (v, true));
        let shades = shades.chain(s.outdoor_shades.into_iter().flatten().map(|v| (v, false)));
        for (j, (v, indoor)) in shades.enumerate() {
            let ctx = || format!("shade {} of {name} `{}`", j + 1, s.identifier);
            self.shade(v, room_index, Parent::Set(set), indoor, &ctx)?;
        }
        Ok(())
    }
}

#[path = "hbjson_assets.rs"]
mod assets;

#[cfg(test)]
#[path = "hbjson_tests.rs"]
mod tests;
