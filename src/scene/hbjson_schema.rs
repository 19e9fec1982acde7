//! The parts of honeybee-schema's `Model` (HBJSON) that daystep reads, as serde structs.
//!
//! Keys follow honeybee-schema (`honeybee_schema/model.py`, `geometry.py`,
//! `boundarycondition.py`, `radiance/properties.py`, `radiance/modifier.py`,
//! `radiance/modifierset.py`, `radiance/asset.py`, `radiance/state.py`). Child objects are
//! kept as [`Value`]s and converted one by one, so that an error names the object it is in
//! (by identifier), not just a line of a file that may be one line long. Unknown keys
//! (energy properties, display names, …) are ignored.

use serde::Deserialize;
use serde_json::Value;

/// Child objects, converted one at a time (`null` or missing reads as none).
pub(super) type Children = Option<Vec<Value>>;

/// A `Model`'s top level.
#[derive(Deserialize)]
pub(super) struct ModelJ {
    #[serde(rename = "type")]
    pub kind: Option<String>,
    pub identifier: Option<String>,
    pub units: Option<String>,
    pub tolerance: Option<f64>,
    pub rooms: Children,
    pub orphaned_faces: Children,
    pub orphaned_shades: Children,
    pub orphaned_apertures: Children,
    pub orphaned_doors: Children,
    pub shade_meshes: Children,
    pub properties: Option<ModelPropsJ>,
}

/// `Model.properties`.
#[derive(Deserialize)]
pub(super) struct ModelPropsJ {
    pub radiance: Option<Value>,
}

/// `Model.properties.radiance` (`ModelRadianceProperties`).
#[derive(Deserialize, Default)]
pub(super) struct ModelRadianceJ {
    pub global_modifier_set: Option<Value>,
    pub modifiers: Children,
    pub modifier_sets: Children,
    pub sensor_grids: Children,
    pub views: Children,
}

/// A `Face3D`: outer boundary and optional holes, model units.
#[derive(Deserialize)]
pub(super) struct Face3DJ {
    pub boundary: Vec<[f64; 3]>,
    pub holes: Option<Vec<Vec<[f64; 3]>>>,
}

/// A `Mesh3D`: vertices and faces of 3 or 4 vertex indices.
#[derive(Deserialize)]
pub(super) struct Mesh3DJ {
    pub vertices: Vec<[f64; 3]>,
    pub faces: Vec<Vec<usize>>,
}

/// A boundary condition; only its `type` matters here.
#[derive(Deserialize)]
pub(super) struct BoundaryJ {
    #[serde(rename = "type")]
    pub kind: String,
    /// For `Surface`: the adjacent sub-face/face, then its face and room.
    pub boundary_condition_objects: Option<Vec<String>>,
}

/// `properties` of any geometry object; only `radiance` is read.
#[derive(Deserialize, Default)]
pub(super) struct PropsJ {
    pub radiance: Option<RadPropsJ>,
}

/// The radiance properties of a Room, Face, Aperture, Door, Shade or ShadeMesh.
#[derive(Deserialize, Default)]
pub(super) struct RadPropsJ {
    /// The object's own modifier identifier.
    pub modifier: Option<String>,
    /// A Room's modifier set identifier.
    pub modifier_set: Option<String>,
    /// Apertures, doors and shades: the dynamic group.
    pub dynamic_group_identifier: Option<String>,
    /// Apertures, doors and shades: the group's states.
    pub states: Option<Vec<StateJ>>,
}

/// One state of a dynamic object.
#[derive(Deserialize)]
pub(super) struct StateJ {
    pub modifier: Option<String>,
}

/// A `Room`.
#[derive(Deserialize)]
pub(super) struct RoomJ {
    pub identifier: String,
    pub faces: Vec<Value>,
    pub indoor_shades: Children,
    pub outdoor_shades: Children,
    #[serde(default)]
    pub properties: PropsJ,
}

/// A `Face`.
#[derive(Deserialize)]
pub(super) struct FaceJ {
    pub identifier: String,
    pub geometry: Face3DJ,
    pub face_type: String,
    pub boundary_condition: BoundaryJ,
    pub apertures: Children,
    pub doors: Children,
    pub indoor_shades: Children,
    pub outdoor_shades: Children,
    #[serde(default)]
    pub properties: PropsJ,
}

/// An `Aperture` or a `Door` (`is_operable` only for apertures, `is_glass` only for doors).
#[derive(Deserialize)]
pub(super) struct SubFaceJ {
    pub identifier: String,
    pub geometry: Face3DJ,
    pub boundary_condition: BoundaryJ,
    #[serde(default)]
    pub is_operable: bool,
    #[serde(default)]
    pub is_glass: bool,
    pub indoor_shades: Children,
    pub outdoor_shades: Children,
    #[serde(default)]
    pub properties: PropsJ,
}

/// A `Shade`.
#[derive(Deserialize)]
pub(super) struct ShadeJ {
    pub identifier: String,
    pub geometry: Face3DJ,
    #[serde(default)]
    pub is_detached: bool,
    #[serde(default)]
    pub properties: PropsJ,
}

/// A `ShadeMesh`.
#[derive(Deserialize)]
pub(super) struct ShadeMeshJ {
    pub identifier: String,
    pub geometry: Mesh3DJ,
    #[serde(default)]
    pub is_detached: bool,
    #[serde(default)]
    pub properties: PropsJ,
}

/// A `SensorGrid`.
#[derive(Deserialize)]
pub(super) struct SensorGridJ {
    pub identifier: String,
    pub room_identifier: Option<String>,
    pub sensors: Vec<SensorJ>,
    /// One face per sensor (its cell), when the grid was made from a mesh.
    pub mesh: Option<Mesh3DJ>,
}

/// One `Sensor` of a grid: position and direction, model units.
#[derive(Deserialize)]
pub(super) struct SensorJ {
    pub pos: [f64; 3],
    pub dir: [f64; 3],
}

/// A `View` (Radiance view parameters).
#[derive(Deserialize)]
pub(super) struct ViewJ {
    pub identifier: String,
    pub room_identifier: Option<String>,
    pub position: [f64; 3],
    pub direction: [f64; 3],
    pub up_vector: [f64; 3],
    pub view_type: Option<String>,
    pub h_size: Option<f64>,
    pub v_size: Option<f64>,
    pub shift: Option<f64>,
    pub lift: Option<f64>,
    pub fore_clip: Option<f64>,
    pub aft_clip: Option<f64>,
}

/// A sub-set of a modifier set (`wall_set`, `aperture_set`, …): every key a modifier
/// identifier (abridged) or a whole modifier (full `ModifierSet`).
#[derive(Deserialize, Default, Clone)]
pub(super) struct SubSetJ {
    pub exterior_modifier: Option<Value>,
    pub interior_modifier: Option<Value>,
    pub window_modifier: Option<Value>,
    pub skylight_modifier: Option<Value>,
    pub operable_modifier: Option<Value>,
    pub exterior_glass_modifier: Option<Value>,
    pub interior_glass_modifier: Option<Value>,
    pub overhead_modifier: Option<Value>,
}

/// A `ModifierSet`, `ModifierSetAbridged` or `GlobalModifierSet`.
#[derive(Deserialize, Default, Clone)]
pub(super) struct ModifierSetJ {
    pub identifier: Option<String>,
    pub wall_set: Option<SubSetJ>,
    pub floor_set: Option<SubSetJ>,
    pub roof_ceiling_set: Option<SubSetJ>,
    pub aperture_set: Option<SubSetJ>,
    pub door_set: Option<SubSetJ>,
    pub shade_set: Option<SubSetJ>,
    /// `GlobalModifierSet` only: the modifiers it uses, in full.
    pub modifiers: Children,
    /// `GlobalModifierSet` only: the modifier of detached orphaned shades.
    pub context_modifier: Option<String>,
}

/// A Radiance modifier (`radiance/modifier.py`), by its `type`.
#[derive(Deserialize)]
#[serde(tag = "type")]
pub(super) enum ModifierJ {
    Plastic(ReflectorJ),
    Metal(ReflectorJ),
    Trans(TransJ),
    Mirror(AnyJ),
    Glass(GlassJ),
    Glow(EmitterJ),
    Light(EmitterJ),
    #[serde(rename = "BSDF")]
    Bsdf(AnyJ),
    #[serde(rename = "aBSDF")]
    ABsdf(AnyJ),
    Void(AnyJ),
}

/// `Plastic` and `Metal`.
#[derive(Deserialize)]
pub(super) struct ReflectorJ {
    pub r_reflectance: f64,
    pub g_reflectance: f64,
    pub b_reflectance: f64,
    #[serde(default)]
    pub specularity: f64,
    pub modifier: Option<Value>,
}

/// `Trans`.
#[derive(Deserialize)]
pub(super) struct TransJ {
    pub r_reflectance: f64,
    pub g_reflectance: f64,
    pub b_reflectance: f64,
    #[serde(default)]
    pub specularity: f64,
    #[serde(default)]
    pub transmitted_diff: f64,
    pub modifier: Option<Value>,
}

/// `Glass`.
#[derive(Deserialize)]
pub(super) struct GlassJ {
    pub r_transmissivity: f64,
    pub g_transmissivity: f64,
    pub b_transmissivity: f64,
    pub refraction_index: Option<f64>,
    pub modifier: Option<Value>,
}

/// `Glow` and `Light`.
#[derive(Deserialize)]
pub(super) struct EmitterJ {
    pub r_emittance: f64,
    pub g_emittance: f64,
    pub b_emittance: f64,
    #[serde(default)]
    pub max_radius: f64,
    pub modifier: Option<Value>,
}

/// A modifier daystep does not read the fields of.
#[derive(Deserialize)]
pub(super) struct AnyJ {}
