//! Honeybee Radiance modifiers → daystep [`Material`]s, and the choice of modifier for an
//! object: its own, else its room's modifier set, else the model's global set, else
//! honeybee's generic defaults (docs/models.md has the table and the rules).
//!
//! The defaults are honeybee-radiance's: `honeybee_radiance/lib/modifiers.py` names them,
//! `honeybee_radiance/modifierset.py` (`_default_modifiers`) assigns them to the sets, and
//! honeybee-standards' `honeybee_standards/radiance_default.json` gives their values.

use super::hbjson_schema::{ModifierJ, ModifierSetJ, SubSetJ};
use super::material::glass_transmittance_from_transmissivity;
use super::Material;
use crate::error::{Error, Result};
use crate::photometry::Rgb;
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The largest specularity of `plastic` and `metal` daystep approximates (reflected
/// diffusely); Radiance's reference manual calls plastic specularity above 0.1
/// unrealistic, and above it the reflection is directional enough to matter.
pub const MAX_SPECULARITY: f64 = 0.1;

/// The refractive index daystep's glazing has (Radiance `glass` default).
const GLASS_INDEX: f64 = super::material::GLASS_INDEX;

/// Where in a modifier set an object's modifier comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Slot {
    WallExterior,
    WallInterior,
    FloorExterior,
    FloorInterior,
    RoofExterior,
    RoofInterior,
    Window,
    Skylight,
    Operable,
    ApertureInterior,
    DoorExterior,
    DoorInterior,
    DoorExteriorGlass,
    DoorInteriorGlass,
    DoorOverhead,
    ShadeExterior,
    ShadeInterior,
}

/// Honeybee's generic visible modifier set (`_default_modifiers` of
/// honeybee_radiance/modifierset.py): the modifier of each slot no set overrides.
const GENERIC_SET: [(Slot, &str); 17] = [
    (Slot::WallExterior, "generic_wall_0.50"),
    (Slot::WallInterior, "generic_wall_0.50"),
    (Slot::FloorExterior, "generic_floor_0.20"),
    (Slot::FloorInterior, "generic_floor_0.20"),
    (Slot::RoofExterior, "generic_ceiling_0.80"),
    (Slot::RoofInterior, "generic_ceiling_0.80"),
    (Slot::Window, "generic_exterior_window_vis_0.64"),
    (Slot::Skylight, "generic_exterior_window_vis_0.64"),
    (Slot::Operable, "generic_exterior_window_vis_0.64"),
    (Slot::ApertureInterior, "generic_interior_window_vis_0.88"),
    (Slot::DoorExterior, "generic_opaque_door_0.50"),
    (Slot::DoorInterior, "generic_opaque_door_0.50"),
    (Slot::DoorExteriorGlass, "generic_exterior_window_vis_0.64"),
    (Slot::DoorInteriorGlass, "generic_interior_window_vis_0.88"),
    (Slot::DoorOverhead, "generic_opaque_door_0.50"),
    (Slot::ShadeExterior, "generic_exterior_shade_0.35"),
    (Slot::ShadeInterior, "generic_interior_shade_0.50"),
];

/// Honeybee's modifier for detached orphaned shades (context).
pub(super) const GENERIC_CONTEXT: &str = "generic_context_0.20";

/// A modifier of honeybee's library: grey plastic of this reflectance, or glass of this
/// transmissivity (Radiance's argument, as honeybee writes it).
enum Lib {
    Plastic(f64),
    Glass(f64),
}

/// honeybee-standards' radiance_default.json, the modifiers honeybee-radiance loads as
/// its library (identifier, value).
const LIBRARY: [(&str, Lib); 17] = [
    ("generic_floor_0.20", Lib::Plastic(0.2)),
    ("generic_wall_0.50", Lib::Plastic(0.5)),
    ("generic_ceiling_0.80", Lib::Plastic(0.8)),
    ("generic_opaque_door_0.50", Lib::Plastic(0.5)),
    ("generic_interior_shade_0.50", Lib::Plastic(0.5)),
    ("generic_exterior_shade_0.35", Lib::Plastic(0.35)),
    ("generic_context_0.20", Lib::Plastic(0.2)),
    (
        "generic_interior_window_vis_0.88",
        Lib::Glass(0.958_415_432_861_059_6),
    ),
    (
        "generic_exterior_window_vis_0.64",
        Lib::Glass(0.697_576_181_538_433_1),
    ),
    (
        "generic_exterior_screened_window_vis_0.32",
        Lib::Glass(0.349_018_950_910_318_54),
    ),
    (
        "generic_interior_window_sol_0.77",
        Lib::Glass(0.838_940_544_725_175_7),
    ),
    (
        "generic_exterior_window_sol_0.37",
        Lib::Glass(0.403_523_157_288_518_2),
    ),
    (
        "generic_exterior_screened_window_sol_0.19",
        Lib::Glass(0.207_259_590_623_409_8),
    ),
    ("generic_floor_exterior_side_0.50", Lib::Plastic(0.5)),
    ("generic_wall_exterior_side_0.35", Lib::Plastic(0.35)),
    ("generic_ceiling_exterior_side_0.35", Lib::Plastic(0.35)),
    ("black", Lib::Plastic(0.0)),
];

/// The library modifier `id` as honeybee writes it in a model, if there is one.
fn library(id: &str) -> Option<Value> {
    LIBRARY
        .iter()
        .find(|(k, _)| *k == id)
        .map(|(k, m)| match m {
            Lib::Plastic(r) => json!({"type": "Plastic", "identifier": k, "r_reflectance": r,
            "g_reflectance": r, "b_reflectance": r, "specularity": 0.0, "roughness": 0.0}),
            Lib::Glass(t) => json!({"type": "Glass", "identifier": k, "r_transmissivity": t,
            "g_transmissivity": t, "b_transmissivity": t}),
        })
}

/// A modifier set resolved to identifiers, slot by slot (missing slots fall back).
type SetSlots = HashMap<Slot, String>;

/// The model's modifiers and modifier sets, and the materials made of those used so far.
pub(super) struct Modifiers {
    path: PathBuf,
    /// Every modifier the model defines, by identifier, as written.
    defs: HashMap<String, Value>,
    /// The model's modifier sets, by identifier.
    sets: HashMap<String, SetSlots>,
    /// The global set: the model's `global_modifier_set` over honeybee's generic set.
    global: SetSlots,
    /// The modifier of detached orphaned shades.
    context: String,
    /// Modifier identifier → index into `materials`.
    index: HashMap<String, u32>,
    /// Materials in order of first use.
    pub materials: Vec<Material>,
    /// Approximations made, one per modifier.
    pub warnings: Vec<String>,
}

/// An object's identifier and what it is ("Face", "Aperture", …), for messages.
pub(super) type Who<'a> = (&'a str, &'a str);

impl Modifiers {
    /// Reads the modifiers, modifier sets and global set of `ModelRadianceProperties`.
    ///
    /// # Errors
    /// [`Error::Input`] for a modifier or set that is not an object with an identifier, or
    /// a set whose entries are neither identifiers nor modifiers.
    pub fn new(
        path: &Path,
        modifiers: Vec<Value>,
        sets: Vec<Value>,
        global: Option<Value>,
    ) -> Result<Modifiers> {
        let mut m = Modifiers {
            path: path.to_path_buf(),
            defs: HashMap::new(),
            sets: HashMap::new(),
            global: GENERIC_SET
                .iter()
                .map(|(s, id)| (*s, id.to_string()))
                .collect(),
            context: GENERIC_CONTEXT.to_string(),
            index: HashMap::new(),
            materials: Vec::new(),
            warnings: Vec::new(),
        };
        for (k, v) in modifiers.into_iter().enumerate() {
            m.define(
                v,
                &format!("modifier {} of properties.radiance.modifiers", k + 1),
            )?;
        }
        if let Some(g) = global {
            let set: ModifierSetJ = serde_json::from_value(g).map_err(|e| {
                m.err(
                    "global_modifier_set",
                    format!("invalid global_modifier_set: {e}"),
                )
            })?;
            for (k, v) in set
                .modifiers
                .clone()
                .unwrap_or_default()
                .into_iter()
                .enumerate()
            {
                m.define(v, &format!("modifier {} of global_modifier_set", k + 1))?;
            }
            if let Some(c) = &set.context_modifier {
                m.context = c.clone();
            }
            let slots = m.slots(&set, "global_modifier_set")?;
            m.global.extend(slots);
        }
        for (k, v) in sets.into_iter().enumerate() {
            let where_ = format!(
                "modifier set {} of properties.radiance.modifier_sets",
                k + 1
            );
            let set: ModifierSetJ = serde_json::from_value(v)
                .map_err(|e| m.err(&where_, format!("invalid modifier set: {e}")))?;
            let Some(id) = set.identifier.clone() else {
                return Err(m.err(&where_, "modifier set has no identifier"));
            };
            let slots = m.slots(&set, &id)?;
            m.sets.insert(id, slots);
        }
        Ok(m)
    }

    fn err(&self, value: &str, message: impl Into<String>) -> Error {
        Error::input(&self.path, None, Some(value), message)
    }

    /// Records a modifier definition by its identifier.
    fn define(&mut self, v: Value, where_: &str) -> Result<String> {
        let Some(id) = v
            .get("identifier")
            .and_then(Value::as_str)
            .map(str::to_owned)
        else {
            return Err(self.err(where_, "modifier has no identifier"));
        };
        self.defs.insert(id.clone(), v);
        Ok(id)
    }

    /// The slots a set gives (identifiers; whole modifiers are defined on the way).
    fn slots(&mut self, set: &ModifierSetJ, set_id: &str) -> Result<SetSlots> {
        let mut out = SetSlots::new();
        let mut put = |m: &mut Modifiers, slot: Slot, v: &Option<Value>| -> Result<()> {
            match v {
                None | Some(Value::Null) => Ok(()),
                Some(Value::String(id)) => {
                    out.insert(slot, id.clone());
                    Ok(())
                }
                Some(obj @ Value::Object(_)) => {
                    let id = m.define(obj.clone(), set_id)?;
                    out.insert(slot, id);
                    Ok(())
                }
                Some(other) => Err(m.err(
                    set_id,
                    format!("modifier set entry {other} is neither an identifier nor a modifier"),
                )),
            }
        };
        let none = SubSetJ::default();
        let w = set.wall_set.as_ref().unwrap_or(&none);
        let f = set.floor_set.as_ref().unwrap_or(&none);
        let r = set.roof_ceiling_set.as_ref().unwrap_or(&none);
        let a = set.aperture_set.as_ref().unwrap_or(&none);
        let d = set.door_set.as_ref().unwrap_or(&none);
        let s = set.shade_set.as_ref().unwrap_or(&none);
        for (slot, v) in [
            (Slot::WallExterior, &w.exterior_modifier),
            (Slot::WallInterior, &w.interior_modifier),
            (Slot::FloorExterior, &f.exterior_modifier),
            (Slot::FloorInterior, &f.interior_modifier),
            (Slot::RoofExterior, &r.exterior_modifier),
            (Slot::RoofInterior, &r.interior_modifier),
            (Slot::Window, &a.window_modifier),
            (Slot::Skylight, &a.skylight_modifier),
            (Slot::Operable, &a.operable_modifier),
            (Slot::ApertureInterior, &a.interior_modifier),
            (Slot::DoorExterior, &d.exterior_modifier),
            (Slot::DoorInterior, &d.interior_modifier),
            (Slot::DoorExteriorGlass, &d.exterior_glass_modifier),
            (Slot::DoorInteriorGlass, &d.interior_glass_modifier),
            (Slot::DoorOverhead, &d.overhead_modifier),
            (Slot::ShadeExterior, &s.exterior_modifier),
            (Slot::ShadeInterior, &s.interior_modifier),
        ] {
            put(self, slot, v)?;
        }
        Ok(out)
    }

    /// True when the model defines a modifier set `id`.
    pub fn has_set(&self, id: &str) -> bool {
        self.sets.contains_key(id)
    }

    /// The modifier identifier of `slot` in set `set` (a room's), falling back to the
    /// global set.
    pub fn set_modifier(&self, set: Option<&str>, slot: Slot) -> String {
        set.and_then(|s| self.sets.get(s))
            .and_then(|s| s.get(&slot))
            .or_else(|| self.global.get(&slot))
            .cloned()
            .unwrap_or_default()
    }

    /// The modifier of detached orphaned shades.
    pub fn context(&self) -> String {
        self.context.clone()
    }

    /// The material index of modifier `id`, used by object `who`, converting it on first
    /// use.
    ///
    /// # Errors
    /// [`Error::Input`] naming the object and the modifier when the modifier is not
    /// defined, malformed, or something daystep cannot model (docs/models.md).
    pub fn material(&mut self, id: &str, who: Who) -> Result<u32> {
        if let Some(&k) = self.index.get(id) {
            return Ok(k);
        }
        let (object, kind) = who;
        let fail = |m: &Modifiers, msg: String| {
            Error::input(
                &m.path,
                None,
                Some(object),
                format!("{kind} `{object}`: modifier `{id}` {msg}"),
            )
        };
        let Some(v) = self.defs.get(id).cloned().or_else(|| library(id)) else {
            return Err(fail(
                self,
                "is not defined in properties.radiance.modifiers nor in honeybee's library".into(),
            ));
        };
        let parsed: ModifierJ =
            serde_json::from_value(v).map_err(|e| fail(self, format!("is malformed: {e}")))?;
        let (material, warning) = convert(id, parsed).map_err(|msg| fail(self, msg))?;
        if let Some(w) = warning {
            self.warnings
                .push(format!("{}: modifier `{id}` {w}", self.path.display()));
        }
        let k = self.materials.len() as u32;
        self.materials.push(material);
        self.index.insert(id.to_string(), k);
        Ok(k)
    }
}

/// True when a modifier's own `modifier` is absent or void.
fn unmodified(m: &Option<Value>) -> bool {
    match m {
        None | Some(Value::Null) => true,
        Some(Value::String(s)) => s == "void",
        Some(v) => v.get("type").and_then(Value::as_str) == Some("Void"),
    }
}

/// Checks three channel values are finite and in [0, 1].
fn channels(name: &str, c: [f64; 3]) -> std::result::Result<Rgb, String> {
    if c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
        Ok(Rgb::from_array(c))
    } else {
        Err(format!("has {name} {c:?}: each must be a number in [0, 1]"))
    }
}

/// A diffuse reflector of total reflectance `kd` (must stay below 1, as MTL `Kd`).
fn opaque(id: &str, kd: Rgb) -> std::result::Result<Material, String> {
    if kd.max_element() >= 1.0 {
        return Err(format!(
            "reflects {:?} in total: a reflectance must be below 1",
            kd.to_array()
        ));
    }
    Ok(Material {
        name: id.to_string(),
        kd,
        tf: Rgb::ZERO,
        ke: Rgb::ZERO,
    })
}

/// The material of one modifier and the approximation made, if any; `Err` says why it
/// cannot be modelled.
pub(super) fn convert(
    id: &str,
    m: ModifierJ,
) -> std::result::Result<(Material, Option<String>), String> {
    let modified = "is itself modified by another modifier (a pattern, texture or mixture), \
                    which daystep cannot model; remove the modifier chain";
    let too_specular = |kind: &str, s: f64| {
        format!(
            "is {kind} with specularity {s}: daystep reflects diffusely only and refuses \
             specularity above {MAX_SPECULARITY}; use a lower specularity (the total \
             reflectance is kept) or a diffuse modifier"
        )
    };
    // Plastic and metal share a body below; which one it is, before `m` is taken apart.
    let metal = matches!(m, ModifierJ::Metal(_));
    match m {
        ModifierJ::Plastic(p) | ModifierJ::Metal(p) if !unmodified(&p.modifier) => {
            Err(modified.into())
        }
        ModifierJ::Plastic(p) | ModifierJ::Metal(p) => {
            let kind = if metal { "metal" } else { "plastic" };
            let c = channels(
                "reflectance",
                [p.r_reflectance, p.g_reflectance, p.b_reflectance],
            )?;
            let s = p.specularity;
            if !(s.is_finite() && s >= 0.0) {
                return Err(format!(
                    "has specularity {s}: it must be a number in [0, 1]"
                ));
            }
            if s > MAX_SPECULARITY {
                return Err(too_specular(kind, s));
            }
            // Radiance plastic reflects c (1 − s) diffusely and s specularly (white
            // highlights); metal reflects c (1 − s) and c s (coloured ones).
            let total = if metal {
                c
            } else {
                c * (1.0 - s) + Rgb::splat(s)
            };
            let m = opaque(id, total)?;
            let w = (s > 0.0).then(|| {
                format!(
                    "({kind}, specularity {s}): its specular part is reflected diffusely \
                     (total reflectance kept)"
                )
            });
            Ok((m, w))
        }
        ModifierJ::Trans(t) => {
            if !unmodified(&t.modifier) {
                return Err(modified.into());
            }
            let c = channels(
                "reflectance",
                [t.r_reflectance, t.g_reflectance, t.b_reflectance],
            )?;
            let s = t.specularity;
            if t.transmitted_diff != 0.0 {
                return Err(format!(
                    "is trans (translucent) with transmitted_diff {}: daystep does not \
                     model diffuse transmission; use glass for a clear pane, or plastic \
                     for an opaque surface",
                    t.transmitted_diff
                ));
            }
            if !(s.is_finite() && (0.0..=MAX_SPECULARITY).contains(&s)) {
                return Err(too_specular("trans", s));
            }
            let m = opaque(id, c * (1.0 - s) + Rgb::splat(s))?;
            Ok((
                m,
                Some(
                    "(trans with transmitted_diff 0): read as plastic, it transmits nothing".into(),
                ),
            ))
        }
        ModifierJ::Mirror(_) => Err("is a mirror: daystep has no specular reflection on \
                                     opaque surfaces; use plastic of the same reflectance \
                                     (a diffuse approximation) if that is acceptable"
            .into()),
        ModifierJ::Glass(g) => {
            if !unmodified(&g.modifier) {
                return Err(modified.into());
            }
            let t = channels(
                "transmissivity",
                [g.r_transmissivity, g.g_transmissivity, g.b_transmissivity],
            )?;
            let tf = Rgb::from_array(t.to_array().map(glass_transmittance_from_transmissivity));
            let mut notes = Vec::new();
            if let Some(n) = g
                .refraction_index
                .filter(|n| *n != 0.0 && *n != GLASS_INDEX)
            {
                notes.push(format!(
                    "has refraction index {n}: daystep's glazing has {GLASS_INDEX}"
                ));
            }
            if tf.max_element() <= 0.0 {
                notes.push("transmits nothing: read as a black opaque surface".into());
            }
            let m = Material {
                name: id.to_string(),
                kd: Rgb::ZERO,
                tf,
                ke: Rgb::ZERO,
            };
            Ok((
                m,
                (!notes.is_empty()).then(|| format!("(glass) {}", notes.join("; "))),
            ))
        }
        ModifierJ::Glow(e) | ModifierJ::Light(e) => {
            if !unmodified(&e.modifier) {
                return Err(modified.into());
            }
            let k = [e.r_emittance, e.g_emittance, e.b_emittance];
            if !k.iter().all(|x| x.is_finite() && *x >= 0.0) {
                return Err(format!(
                    "has emittance {k:?}: each must be a finite number ≥ 0"
                ));
            }
            let m = Material {
                name: id.to_string(),
                kd: Rgb::ZERO,
                tf: Rgb::ZERO,
                ke: Rgb::from_array(k),
            };
            let w = (e.max_radius > 0.0).then(|| {
                format!(
                    "(glow, max_radius {}): emits at any distance (max_radius ignored)",
                    e.max_radius
                )
            });
            Ok((m, w))
        }
        ModifierJ::Bsdf(_) | ModifierJ::ABsdf(_) => Err("is a BSDF: daystep models clear \
                                                         glazing (glass) only; replace it by \
                                                         glass of the same visible \
                                                         transmittance"
            .into()),
        ModifierJ::Void(_) => Err("is void: the object would not exist in Radiance; remove \
                                   the object instead"
            .into()),
    }
}
