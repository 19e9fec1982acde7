//! Unit tests of the HBJSON reader ([`super`]): a one-room box with a window, its overhang
//! and a context shade, against closed-form counts and areas; units; honeybee's default
//! modifiers and the conversion of user modifiers; modifier sets; interior faces; bad
//! geometry counted; and errors that name the file and the object.

use super::*;
use crate::photometry::Rgb;
use crate::scene::material::glass_transmittance_from_transmissivity;
use proptest::prelude::*;
use serde_json::json;

/// A point given in millimetres, written in the model's units: metres as the decimal
/// value (mm / 1000, the double nearest to the decimal), millimetres as the integer.
fn pt(mm: [i64; 3], units: &str) -> Value {
    let k = match units {
        "Millimeters" => 1.0,
        _ => 1000.0,
    };
    json!(mm.map(|x| x as f64 / k))
}

fn ring(mm: &[[i64; 3]], units: &str) -> Value {
    Value::Array(mm.iter().map(|p| pt(*p, units)).collect())
}

fn face3d(mm: &[[i64; 3]], units: &str) -> Value {
    json!({"type": "Face3D", "boundary": ring(mm, units)})
}

const FLOOR: [[i64; 3]; 4] = [[0, 0, 0], [0, 6000, 0], [4000, 6000, 0], [4000, 0, 0]];
const ROOF: [[i64; 3]; 4] = [
    [0, 0, 3000],
    [4000, 0, 3000],
    [4000, 6000, 3000],
    [0, 6000, 3000],
];
const SOUTH: [[i64; 3]; 4] = [[0, 0, 0], [4000, 0, 0], [4000, 0, 3000], [0, 0, 3000]];
const NORTH: [[i64; 3]; 4] = [
    [4000, 6000, 0],
    [0, 6000, 0],
    [0, 6000, 3000],
    [4000, 6000, 3000],
];
const EAST: [[i64; 3]; 4] = [
    [4000, 0, 0],
    [4000, 6000, 0],
    [4000, 6000, 3000],
    [4000, 0, 3000],
];
const WEST: [[i64; 3]; 4] = [[0, 6000, 0], [0, 0, 0], [0, 0, 3000], [0, 6000, 3000]];
const WINDOW: [[i64; 3]; 4] = [
    [1000, 0, 1000],
    [3000, 0, 1000],
    [3000, 0, 2000],
    [1000, 0, 2000],
];
const OVERHANG: [[i64; 3]; 4] = [
    [1000, 0, 2200],
    [3000, 0, 2200],
    [3000, -1000, 2200],
    [1000, -1000, 2200],
];
const CONTEXT: [[i64; 3]; 4] = [
    [10000, -5000, 0],
    [14000, -5000, 0],
    [14000, -5000, 5000],
    [10000, -5000, 5000],
];

fn face(id: &str, kind: &str, bc: &str, mm: &[[i64; 3]], units: &str) -> Value {
    json!({"type": "Face", "identifier": id, "face_type": kind,
        "boundary_condition": {"type": bc}, "geometry": face3d(mm, units),
        "properties": {"type": "FacePropertiesAbridged"}})
}

/// The box: 4 × 6 × 3 m, a 2 × 1 m window in the south wall with a 2 × 1 m overhang, a
/// detached 4 × 5 m context shade, a grid of two sensors and one view.
fn model(units: &str) -> Value {
    let mut south = face("south", "Wall", "Outdoors", &SOUTH, units);
    south["apertures"] = json!([{"type": "Aperture", "identifier": "window",
        "geometry": face3d(&WINDOW, units), "boundary_condition": {"type": "Outdoors"},
        "outdoor_shades": [{"type": "Shade", "identifier": "overhang",
            "geometry": face3d(&OVERHANG, units)}]}]);
    json!({
        "type": "Model", "identifier": "box", "units": units,
        "tolerance": if units == "Millimeters" { 10.0 } else { 0.01 },
        "rooms": [{"type": "Room", "identifier": "room", "faces": [
            face("floor", "Floor", "Ground", &FLOOR, units),
            face("roof", "RoofCeiling", "Outdoors", &ROOF, units),
            south,
            face("north", "Wall", "Outdoors", &NORTH, units),
            face("east", "Wall", "Outdoors", &EAST, units),
            face("west", "Wall", "Outdoors", &WEST, units),
        ], "properties": {"type": "RoomPropertiesAbridged"}}],
        "orphaned_shades": [{"type": "Shade", "identifier": "context",
            "geometry": face3d(&CONTEXT, units), "is_detached": true}],
        "properties": {"type": "ModelProperties", "radiance": {
            "type": "ModelRadianceProperties",
            "sensor_grids": [{"type": "SensorGrid", "identifier": "grid1",
                "room_identifier": "room", "sensors": [
                    {"pos": pt([2000, 3000, 800], units), "dir": [0, 0, 1]},
                    {"pos": pt([2000, 1000, 800], units), "dir": [0, 0, 1]}]}],
            "views": [{"type": "View", "identifier": "inside",
                "position": pt([2000, 5000, 1500], units), "direction": [0, -1, 0],
                "up_vector": [0, 0, 1], "h_size": 60, "v_size": 40}]
        }}
    })
}

fn read(v: &Value) -> Result<HbjsonContents> {
    parse(Path::new("m.hbjson"), &v.to_string())
}

/// Area of each group's triangles, by identifier.
fn areas(h: &HbjsonContents) -> HashMap<String, f64> {
    let mut out = HashMap::new();
    for t in &h.triangles {
        let a = 0.5 * (t.v[1] - t.v[0]).cross(t.v[2] - t.v[0]).length();
        *out.entry(h.groups[t.group as usize].clone()).or_insert(0.0) += a;
    }
    out
}

/// The material of group `id`'s triangles.
fn material_of<'a>(h: &'a HbjsonContents, id: &str) -> &'a Material {
    let g = h.groups.iter().position(|g| g == id).unwrap() as u32;
    let t = h.triangles.iter().find(|t| t.group == g).unwrap();
    &h.materials[t.material as usize]
}

fn input_error(r: Result<HbjsonContents>) -> (String, Option<usize>, Option<String>) {
    let (shown, path, line, value) = crate::error::input_parts(r.unwrap_err());
    assert_eq!(path, Path::new("m.hbjson"), "{shown}");
    (shown, line, value)
}

#[test]
fn box_has_its_triangles_areas_and_honeybee_defaults() {
    let h = read(&model("Meters")).unwrap();
    // 2 per rectangle; the south wall with its window hole: 8 vertices, 8 triangles.
    assert_eq!(h.triangles.len(), 2 * 5 + 8 + 3 * 2);
    let a = areas(&h);
    let want = [
        ("floor", 24.0),
        ("roof", 24.0),
        ("south", 12.0 - 2.0),
        ("north", 12.0),
        ("east", 18.0),
        ("west", 18.0),
        ("window", 2.0),
        ("overhang", 2.0),
        ("context", 20.0),
    ];
    assert_eq!(a.len(), want.len(), "{a:?}");
    for (id, area) in want {
        assert!((a[id] - area).abs() < 1e-12, "{id}: {}", a[id]);
    }
    // Outward normals, as the model winds them.
    let normal = |id: &str| {
        let g = h.groups.iter().position(|g| g == id).unwrap() as u32;
        let t = h.triangles.iter().find(|t| t.group == g).unwrap();
        t.normal()
    };
    assert!((normal("floor") + DVec3::Z).length() < 1e-12);
    assert!((normal("south") + DVec3::Y).length() < 1e-12);
    assert!((normal("window") + DVec3::Y).length() < 1e-12);
    // honeybee-radiance's generic modifier set.
    let kd = |id: &str| material_of(&h, id).kd;
    assert_eq!(kd("floor"), Rgb::splat(0.2));
    assert_eq!(kd("roof"), Rgb::splat(0.8));
    assert_eq!(kd("south"), Rgb::splat(0.5));
    assert_eq!(kd("overhang"), Rgb::splat(0.35));
    assert_eq!(kd("context"), Rgb::splat(0.2));
    let glass = material_of(&h, "window");
    assert_eq!(glass.name, "generic_exterior_window_vis_0.64");
    // honeybee wrote the transmissivity with Radiance's ten-digit formula: within 1e-7.
    assert!((glass.tf.x - 0.64).abs() < 1e-7, "{}", glass.tf);
    assert!(h.warnings.is_empty(), "{:?}", h.warnings);
    // Extras.
    let i = &h.imported;
    assert_eq!(i.rooms, ["room"]);
    assert_eq!(i.group_room.len(), h.groups.len());
    let room_of = |id: &str| i.group_room[h.groups.iter().position(|g| g == id).unwrap()];
    assert_eq!(room_of("overhang"), Some(0));
    assert_eq!(room_of("context"), None);
    assert_eq!(i.grids.len(), 1);
    assert_eq!(i.grids[0].room.as_deref(), Some("room"));
    assert_eq!(i.sensor_grid, [0, 0]);
    assert_eq!(h.sensors[1], (DVec3::new(2.0, 1.0, 0.8), DVec3::Z));
    assert_eq!(i.views.len(), 1);
    let v = &i.views[0].view;
    assert_eq!(
        (v.vp, v.vd, v.vh, v.vv),
        (DVec3::new(2.0, 5.0, 1.5), -DVec3::Y, 60.0, 40.0)
    );
    assert_eq!(i.counts, ImportCounts::default());
}

#[test]
fn millimeters_give_the_same_triangles_and_other_units_scale() {
    let m = read(&model("Meters")).unwrap();
    let mm = read(&model("Millimeters")).unwrap();
    assert_eq!(m.triangles, mm.triangles);
    assert_eq!(m.sensors, mm.sensors);
    assert_eq!(m.imported.views, mm.imported.views);
    // Metre coordinates read as feet, inches or centimetres scale by the unit.
    for (units, k) in [("Feet", 0.3048), ("Inches", 0.0254), ("Centimeters", 0.01)] {
        let mut v = model("Meters");
        v["units"] = json!(units);
        let h = read(&v).unwrap();
        assert_eq!(h.triangles.len(), m.triangles.len());
        for (a, b) in h.triangles.iter().zip(&m.triangles) {
            for (p, q) in a.v.iter().zip(&b.v) {
                assert!((*p - *q * k).length() < 1e-12, "{units}: {p} vs {q}");
            }
        }
    }
}

#[test]
fn unknown_units_are_refused() {
    let mut v = model("Meters");
    v["units"] = json!("Furlongs");
    let (shown, _, value) = input_error(read(&v));
    assert_eq!(value.as_deref(), Some("Furlongs"), "{shown}");
    assert!(
        shown.contains("m.hbjson") && shown.contains("box"),
        "{shown}"
    );
}

/// The model with `modifiers` defined and the window given modifier `id`.
fn with_window_modifier(modifiers: Value, id: &str) -> Value {
    let mut v = model("Meters");
    v["properties"]["radiance"]["modifiers"] = modifiers;
    v["rooms"][0]["faces"][2]["apertures"][0]["properties"] =
        json!({"type": "AperturePropertiesAbridged", "radiance": {"modifier": id}});
    v
}

#[test]
fn user_modifiers_convert_or_are_refused_naming_object_and_modifier() {
    // Glass: Radiance's transmissivity for a transmittance of 0.7, from its formula.
    let tn = 0.7_f64;
    let t = ((0.8402528435 + 0.0072522239 * tn * tn).sqrt() - 0.9166530661) / 0.0036261119 / tn;
    let glass = json!([{"type": "Glass", "identifier": "g70", "r_transmissivity": t,
        "g_transmissivity": t, "b_transmissivity": t, "refraction_index": null}]);
    let h = read(&with_window_modifier(glass, "g70")).unwrap();
    let m = material_of(&h, "window");
    assert!((m.tf.x - 0.7).abs() < 1e-8, "{}", m.tf);
    assert_eq!(m.tf.x, glass_transmittance_from_transmissivity(t));
    // Plastic with some specularity: c (1 − s) + s, listed as an approximation.
    let plastic = json!([{"type": "Plastic", "identifier": "p", "r_reflectance": 0.3,
        "g_reflectance": 0.4, "b_reflectance": 0.5, "specularity": 0.05, "roughness": 0.1}]);
    let h = read(&with_window_modifier(plastic, "p")).unwrap();
    let kd = material_of(&h, "window").kd;
    let want = Rgb::new(0.3, 0.4, 0.5) * 0.95 + Rgb::splat(0.05);
    assert!((kd - want).length() < 1e-15, "{kd}");
    assert_eq!(h.warnings.len(), 1, "{:?}", h.warnings);
    assert!(h.warnings[0].contains("`p`") && h.warnings[0].contains("specular"));
    // What daystep cannot model is an error naming the window and the modifier.
    let refused = [
        json!({"type": "Metal", "identifier": "x", "r_reflectance": 0.8, "g_reflectance": 0.8,
            "b_reflectance": 0.8, "specularity": 0.9, "roughness": 0.05}),
        json!({"type": "Trans", "identifier": "x", "r_reflectance": 0.5, "g_reflectance": 0.5,
            "b_reflectance": 0.5, "specularity": 0.0, "roughness": 0.0,
            "transmitted_diff": 0.3, "transmitted_spec": 0.1}),
        json!({"type": "Mirror", "identifier": "x", "r_reflectance": 0.9,
            "g_reflectance": 0.9, "b_reflectance": 0.9}),
        json!({"type": "BSDF", "identifier": "x", "bsdf_data": "<xml/>",
            "up_orientation": [0, 0, 1], "thickness": 0}),
        json!({"type": "Plastic", "identifier": "x", "r_reflectance": 0.5,
            "g_reflectance": 0.5, "b_reflectance": 0.5, "specularity": 0.3}),
        json!({"type": "Plastic", "identifier": "x", "r_reflectance": 1.5,
            "g_reflectance": 0.5, "b_reflectance": 0.5}),
        json!({"type": "Plastic", "identifier": "x", "r_reflectance": 0.5,
            "g_reflectance": 0.5, "b_reflectance": 0.5,
            "modifier": {"type": "Plastic", "identifier": "y", "r_reflectance": 0.5,
            "g_reflectance": 0.5, "b_reflectance": 0.5}}),
        json!({"type": "Pattern", "identifier": "x"}),
    ];
    for m in refused {
        let (shown, _, value) = input_error(read(&with_window_modifier(json!([m]), "x")));
        assert_eq!(value.as_deref(), Some("window"), "{shown}");
        assert!(shown.contains("`x`"), "{shown}");
    }
    // An undefined modifier too.
    let (shown, _, _) = input_error(read(&with_window_modifier(json!([]), "nowhere")));
    assert!(
        shown.contains("`nowhere`") && shown.contains("window"),
        "{shown}"
    );
}

#[test]
fn room_modifier_set_then_global_defaults() {
    let mut v = model("Meters");
    v["properties"]["radiance"]["modifiers"] = json!([{"type": "Plastic",
        "identifier": "dark_wall", "r_reflectance": 0.3, "g_reflectance": 0.3,
        "b_reflectance": 0.3}]);
    v["properties"]["radiance"]["modifier_sets"] = json!([{"type": "ModifierSetAbridged",
        "identifier": "set", "wall_set": {"exterior_modifier": "dark_wall"},
        "aperture_set": {"window_modifier": "generic_interior_window_vis_0.88"}}]);
    v["rooms"][0]["properties"]["radiance"] = json!({"modifier_set": "set"});
    let h = read(&v).unwrap();
    assert_eq!(material_of(&h, "north").kd, Rgb::splat(0.3));
    assert_eq!(material_of(&h, "floor").kd, Rgb::splat(0.2));
    let tf = material_of(&h, "window").tf.x;
    assert!((tf - 0.88).abs() < 1e-7, "{tf}");
    // A set that does not exist names the room.
    v["rooms"][0]["properties"]["radiance"] = json!({"modifier_set": "missing"});
    let (shown, _, value) = input_error(read(&v));
    assert_eq!(value.as_deref(), Some("room"), "{shown}");
}

#[test]
fn air_boundaries_are_left_out_and_interior_pairs_kept_apart() {
    let mut v = model("Meters");
    v["rooms"][0]["faces"][3]["face_type"] = json!("AirBoundary");
    let h = read(&v).unwrap();
    assert!(!h.groups.iter().any(|g| g == "north"));
    // Two rooms sharing x = 4 m: the first room's east wall is kept in place, the second
    // room's west wall 2 × tolerance into its own room, with the same interior modifier.
    let mut v = model("Meters");
    let east = [
        [4000, 0, 0],
        [4000, 6000, 0],
        [4000, 6000, 3000],
        [4000, 0, 3000],
    ];
    let west_b = [
        [4000, 6000, 0],
        [4000, 0, 0],
        [4000, 0, 3000],
        [4000, 6000, 3000],
    ];
    let mut a_east = face("east", "Wall", "Surface", &east, "Meters");
    a_east["boundary_condition"]["boundary_condition_objects"] = json!(["b_west", "b"]);
    a_east["apertures"] = json!([{"type": "Aperture", "identifier": "a_door_glass",
        "geometry": face3d(&[[4000, 1000, 0], [4000, 2000, 0], [4000, 2000, 2000],
            [4000, 1000, 2000]], "Meters"),
        "boundary_condition": {"type": "Surface",
            "boundary_condition_objects": ["b_glass", "b_west", "b"]}}]);
    let mut b_west = face("b_west", "Wall", "Surface", &west_b, "Meters");
    b_west["boundary_condition"]["boundary_condition_objects"] = json!(["east", "room"]);
    b_west["apertures"] = json!([{"type": "Aperture", "identifier": "b_glass",
        "geometry": face3d(&[[4000, 2000, 0], [4000, 1000, 0], [4000, 1000, 2000],
            [4000, 2000, 2000]], "Meters"),
        "boundary_condition": {"type": "Surface",
            "boundary_condition_objects": ["a_door_glass", "east", "room"]}}]);
    v["rooms"][0]["faces"][4] = a_east;
    v["rooms"]
        .as_array_mut()
        .unwrap()
        .push(json!({"type": "Room", "identifier": "b",
        "faces": [b_west]}));
    let h = read(&v).unwrap();
    let xs = |id: &str| -> Vec<f64> {
        let g = h.groups.iter().position(|g| g == id).unwrap() as u32;
        h.triangles
            .iter()
            .filter(|t| t.group == g)
            .flat_map(|t| t.v.map(|p| p.x))
            .collect()
    };
    assert!(xs("east").iter().all(|x| *x == 4.0));
    assert!(
        xs("b_west").iter().all(|x| (x - 4.02).abs() < 1e-12),
        "{:?}",
        xs("b_west")
    );
    let a = areas(&h);
    assert!((a["east"] - 16.0).abs() < 1e-12 && (a["b_west"] - 16.0).abs() < 1e-12);
    // The interior aperture once, from the first face, with honeybee's interior window.
    assert!(a.contains_key("a_door_glass") && !a.contains_key("b_glass"));
    assert!((material_of(&h, "a_door_glass").tf.x - 0.88).abs() < 1e-7);
    assert_eq!(
        h.imported.group_room[h.groups.iter().position(|g| g == "b_west").unwrap()],
        Some(1)
    );
}

#[test]
fn bad_geometry_is_counted_and_named() {
    let mut v = model("Meters");
    // The window moved 0.5 m out of its wall's plane.
    v["rooms"][0]["faces"][2]["apertures"][0]["geometry"] = face3d(
        &[
            [1000, -500, 1000],
            [3000, -500, 1000],
            [3000, -500, 2000],
            [1000, -500, 2000],
        ],
        "Meters",
    );
    // A zero-area shade and a bow-tie shade.
    v["orphaned_shades"] = json!([
        {"type": "Shade", "identifier": "flat", "geometry":
            face3d(&[[0, 0, 0], [1000, 0, 0], [2000, 0, 0]], "Meters")},
        {"type": "Shade", "identifier": "bowtie", "geometry":
            face3d(&[[0, 0, 5000], [4000, 2000, 5000], [4000, 0, 5000], [0, 4000, 5000]],
            "Meters")},
        {"type": "Shade", "identifier": "warped", "geometry":
            face3d(&[[0, 0, 6000], [1000, 0, 6000], [1000, 1000, 6500], [0, 1000, 6000]],
            "Meters")}
    ]);
    let h = read(&v).unwrap();
    let c = h.imported.counts;
    assert_eq!(
        (
            c.apertures_outside_parent,
            c.zero_area,
            c.self_intersecting,
            c.non_planar
        ),
        (1, 1, 1, 1)
    );
    for id in ["`window`", "`flat`", "`bowtie`", "`warped`"] {
        assert!(
            h.warnings.iter().any(|w| w.contains(id)),
            "{id}: {:?}",
            h.warnings
        );
    }
    // The wall keeps its full area: the window was not cut out of it.
    assert!((areas(&h)["south"] - 12.0).abs() < 1e-12);
}

#[test]
fn aperture_groups_are_listed() {
    let mut v = model("Meters");
    v["rooms"][0]["faces"][2]["apertures"][0]["properties"] = json!({"radiance": {
        "dynamic_group_identifier": "south_blinds",
        "states": [{"modifier": "generic_exterior_window_vis_0.64"}, {"modifier": "black"}]}});
    let h = read(&v).unwrap();
    let g = &h.imported.aperture_groups;
    assert_eq!(g.len(), 1);
    assert_eq!(g[0].identifier, "south_blinds");
    assert_eq!(g[0].members, ["window"]);
    assert_eq!(g[0].states, ["generic_exterior_window_vis_0.64", "black"]);
}

#[test]
fn malformed_input_names_file_and_object() {
    // JSON syntax: line and column.
    let (shown, line, _) = input_error(parse(Path::new("m.hbjson"), "{\n\"type\": \"Model\",\n]"));
    assert_eq!(line, Some(3), "{shown}");
    assert!(shown.contains("column"), "{shown}");
    // A number too large for a double.
    let text = model("Meters").to_string().replacen("4.0", "1e999", 1);
    let (shown, line, _) = input_error(parse(Path::new("m.hbjson"), &text));
    assert!(line.is_some() && shown.contains("out of range"), "{shown}");
    // A coordinate given as text ("NaN"), a missing identifier, a wrong type.
    let mut v = model("Meters");
    v["rooms"][0]["faces"][1]["geometry"]["boundary"][0][0] = json!("NaN");
    let (shown, _, value) = input_error(read(&v));
    assert_eq!(value.as_deref(), Some("roof"), "{shown}");
    let mut v = model("Meters");
    v["rooms"][0]["faces"][1]
        .as_object_mut()
        .unwrap()
        .remove("identifier");
    let (shown, _, _) = input_error(read(&v));
    assert!(shown.contains("face 2 of room `room`"), "{shown}");
    let mut v = model("Meters");
    v["rooms"][0]["faces"] = json!("none");
    let (shown, _, value) = input_error(read(&v));
    assert_eq!(value.as_deref(), Some("room"), "{shown}");
    let mut v = model("Meters");
    v["rooms"][0]["faces"][0]["face_type"] = json!("Ceiling");
    let (shown, _, value) = input_error(read(&v));
    assert_eq!(value.as_deref(), Some("floor"), "{shown}");
    // A sensor pointing nowhere.
    let mut v = model("Meters");
    v["properties"]["radiance"]["sensor_grids"][0]["sensors"][0]["dir"] = json!([0, 0, 0]);
    let (shown, _, value) = input_error(read(&v));
    assert_eq!(value.as_deref(), Some("grid1"), "{shown}");
    // Not a model, and an empty one.
    let (shown, _, value) = input_error(read(&json!({"type": "Room", "identifier": "r"})));
    assert_eq!(value.as_deref(), Some("Room"), "{shown}");
    let (shown, _, value) = input_error(read(&json!({"type": "Model", "identifier": "e"})));
    assert!(
        shown.contains("no geometry") && value.as_deref() == Some("e"),
        "{shown}"
    );
    let (shown, _, _) = input_error(read(&json!([1, 2])));
    assert!(shown.contains("not a honeybee Model"), "{shown}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn mutated_models_never_panic(cut in 0.0..1.0f64, at in 0.0..1.0f64, byte in 0u8..128) {
        let text = model("Meters").to_string();
        let n = text.len();
        // Truncated anywhere, or one byte replaced anywhere: an input error or a model.
        let truncated = &text[..((cut * n as f64) as usize).min(n)];
        let r = parse(Path::new("m.hbjson"), truncated);
        let ok = r.is_ok() || matches!(r, Err(Error::Input { .. }));
        prop_assert!(ok);
        let mut bytes = text.into_bytes();
        let k = ((at * n as f64) as usize).min(n - 1);
        bytes[k] = byte;
        if let Ok(s) = String::from_utf8(bytes) {
            let r = parse(Path::new("m.hbjson"), &s);
            let ok = r.is_ok() || matches!(r, Err(Error::Input { .. }));
        prop_assert!(ok);
        }
    }
}

#[test]
fn grid_meshes_give_each_sensor_its_cells_area_in_square_metres() {
    // Two cells, 2 m × 2 m (a quad) and half of it (a triangle), in mm and in m.
    for units in ["Meters", "Millimeters"] {
        let mut m = model(units);
        let mesh = json!({"type": "Mesh3D", "vertices": [
            pt([1000, 2000, 800], units), pt([3000, 2000, 800], units),
            pt([3000, 4000, 800], units), pt([1000, 4000, 800], units),
            pt([1000, 0, 800], units)],
            "faces": [[0, 1, 2, 3], [0, 4, 1]]});
        m["properties"]["radiance"]["sensor_grids"][0]["mesh"] = mesh;
        let h = read(&m).unwrap();
        let a = h.imported.grids[0]
            .areas
            .clone()
            .expect("areas from the mesh");
        assert_eq!(a.len(), 2);
        assert!(
            (a[0] - 4.0).abs() < 1e-9 && (a[1] - 2.0).abs() < 1e-9,
            "{units}: {a:?}"
        );
    }
    // A mesh with another face count than sensors: no areas, and a warning says so.
    let mut m = model("Meters");
    m["properties"]["radiance"]["sensor_grids"][0]["mesh"] = json!({"type": "Mesh3D", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
               "faces": [[0, 1, 2]]});
    let h = read(&m).unwrap();
    assert_eq!(h.imported.grids[0].areas, None);
    assert!(
        h.warnings
            .iter()
            .any(|w| w.contains("1 faces for 2 sensors")),
        "{:?}",
        h.warnings
    );
}
