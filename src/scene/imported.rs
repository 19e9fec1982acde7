//! What a model file holds besides triangles and materials (HBJSON today): rooms, named
//! sensor grids, named views, aperture groups, and counts of the bad geometry met on import.
//! Kept in [`super::Scene::imported`] for the outputs (a `grid` column in `sensors.csv`,
//! per-grid results, `render --view-name`, `report.json`).

use super::view::View;

/// A named sensor grid of the model (honeybee `SensorGrid`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridInfo {
    /// The grid's identifier.
    pub identifier: String,
    /// The identifier of the room the grid belongs to, where the model says.
    pub room: Option<String>,
    /// Number of sensors in the grid.
    pub sensors: usize,
    /// Area of each sensor's cell, m², from the grid's mesh (one face per sensor), when it
    /// has one: LEED and EN 17037 then weight by area, as honeybee does.
    pub areas: Option<Vec<f64>>,
}

/// A named view of the model (honeybee `View`).
#[derive(Clone, Debug, PartialEq)]
pub struct NamedView {
    /// The view's identifier (`render --view-name`).
    pub identifier: String,
    /// The identifier of the room the view belongs to, where the model says.
    pub room: Option<String>,
    /// The camera in the model frame (metres, Z up), as a `.vf` file would give it.
    pub view: View,
}

/// Apertures (or doors, or shades) that operate together (honeybee
/// `dynamic_group_identifier`), with the states the model gives them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ApertureGroup {
    /// The dynamic group identifier.
    pub identifier: String,
    /// Identifiers of the group's objects, in model order.
    pub members: Vec<String>,
    /// The states of the group's first member that has any, in order: each state's
    /// modifier identifier (honeybee states have no names of their own; `"default"` for a
    /// state that keeps the object's own modifier). The scene holds every member in its
    /// default modifier.
    pub states: Vec<String>,
    /// The shaded state's diffuse visible transmittance, where `scene.toml` gives it
    /// (`[aperture_groups.NAME] shade_transmittance`); `None`: the default.
    pub shade_transmittance: Option<f64>,
    /// The glazing materials that make the group, when `scene.toml` defines it by
    /// material: only its members' triangles of these materials belong to it. Empty: every
    /// glazing triangle of its members (HBJSON).
    pub materials: Vec<String>,
}

/// Bad geometry met while importing, each also listed in the scene's warnings with the
/// object's identifier (or file line).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImportCounts {
    /// Polygons enclosing no area (no triangles made).
    pub zero_area: usize,
    /// Polygons with a vertex further from their plane than the model's tolerance.
    pub non_planar: usize,
    /// Polygons whose outline crosses itself.
    pub self_intersecting: usize,
    /// Apertures and doors not inside their parent face (not cut out of it).
    pub apertures_outside_parent: usize,
}

/// Everything a model file gives beyond geometry and materials (empty for OBJ).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Imported {
    /// Room identifiers, in model order.
    pub rooms: Vec<String>,
    /// For each group of [`super::Scene::groups`]: index into `rooms` of the room it
    /// belongs to (`None`: not in a room, or the format has no rooms). Empty when the
    /// model has no rooms.
    pub group_room: Vec<Option<u32>>,
    /// The model's sensor grids, in model order.
    pub grids: Vec<GridInfo>,
    /// For each sensor of [`super::Scene::sensors`]: index into `grids`. Empty when the
    /// sensors did not come from the model's grids.
    pub sensor_grid: Vec<u32>,
    /// The model's named views, in model order.
    pub views: Vec<NamedView>,
    /// The model's aperture groups, in order of first appearance.
    pub aperture_groups: Vec<ApertureGroup>,
    /// Counts of bad geometry.
    pub counts: ImportCounts,
}
