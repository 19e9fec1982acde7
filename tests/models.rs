//! Honeybee models (HBJSON) in whole runs: as `geometry` in scene.toml and as the SCENE
//! argument itself, the model's grids as the sensors, a `.pts` file overriding them, the
//! sky seen through a hole in a honeybee roof against the closed-form configuration
//! factor, and the binary's exit 1 naming the file and the object.

use crate::util::*;
use daystep::scene::Scene;
use glam::DVec3;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn face(id: &str, kind: &str, bc: &str, boundary: Value) -> Value {
    json!({"type": "Face", "identifier": id, "face_type": kind,
        "boundary_condition": {"type": bc},
        "geometry": {"type": "Face3D", "boundary": boundary},
        "properties": {"type": "FacePropertiesAbridged", "radiance": {"modifier": "black"}}})
}

/// A black 10 × 10 × 3 m honeybee room (faces wound outward, honeybee's convention) whose
/// roof has a `hole` × `hole` m opening centred above (5, 5) as a Face3D hole, a grid of
/// one upward sensor on the floor below it and one beside it, and a view.
fn roof_opening(hole: f64, units: &str, k: f64) -> Value {
    let p = |x: f64, y: f64, z: f64| json!([x * k, y * k, z * k]);
    let (a, b) = (5.0 - hole / 2.0, 5.0 + hole / 2.0);
    let mut roof = face(
        "roof",
        "RoofCeiling",
        "Outdoors",
        json!([
            p(0., 0., 3.),
            p(10., 0., 3.),
            p(10., 10., 3.),
            p(0., 10., 3.)
        ]),
    );
    roof["geometry"]["holes"] = json!([[p(a, a, 3.), p(b, a, 3.), p(b, b, 3.), p(a, b, 3.)]]);
    json!({
        "type": "Model", "identifier": "opening", "units": units, "tolerance": 0.01 * k,
        "rooms": [{"type": "Room", "identifier": "room", "faces": [
            face("floor", "Floor", "Ground",
                json!([p(0., 0., 0.), p(0., 10., 0.), p(10., 10., 0.), p(10., 0., 0.)])),
            roof,
            face("south", "Wall", "Outdoors",
                json!([p(0., 0., 0.), p(10., 0., 0.), p(10., 0., 3.), p(0., 0., 3.)])),
            face("north", "Wall", "Outdoors",
                json!([p(10., 10., 0.), p(0., 10., 0.), p(0., 10., 3.), p(10., 10., 3.)])),
            face("east", "Wall", "Outdoors",
                json!([p(10., 0., 0.), p(10., 10., 0.), p(10., 10., 3.), p(10., 0., 3.)])),
            face("west", "Wall", "Outdoors",
                json!([p(0., 10., 0.), p(0., 0., 0.), p(0., 0., 3.), p(0., 10., 3.)])),
        ]}],
        "properties": {"type": "ModelProperties", "radiance": {
            "type": "ModelRadianceProperties",
            "modifiers": [{"type": "Plastic", "identifier": "black", "r_reflectance": 0.0,
                "g_reflectance": 0.0, "b_reflectance": 0.0, "specularity": 0.0,
                "roughness": 0.0}],
            "sensor_grids": [{"type": "SensorGrid", "identifier": "floor_grid",
                "room_identifier": "room",
                "sensors": [{"pos": p(5., 5., 0.), "dir": [0, 0, 1]},
                            {"pos": p(2., 2., 0.8), "dir": [0, 0, 1]}]}],
            "views": [{"type": "View", "identifier": "up", "position": p(5., 5., 1.),
                "direction": [0, 0, 1], "up_vector": [0, 1, 0], "view_type": "h",
                "h_size": 180, "v_size": 180}]
        }}
    })
}

/// Writes `model` as `model.hbjson` (and `scene` as `scene.toml` when given) into `dir`.
fn write(dir: &Path, model: &Value, scene: Option<&str>) -> (PathBuf, PathBuf) {
    let m = dir.join("model.hbjson");
    std::fs::write(&m, serde_json::to_string_pretty(model).unwrap()).unwrap();
    let s = dir.join("scene.toml");
    if let Some(text) = scene {
        std::fs::write(&s, text).unwrap();
    }
    (m, s)
}

const SITE: &str = "[site]\nlatitude = 48.1\nlongitude = 11.6\nutc_offset_h = 1\n";

#[test]
fn hbjson_as_geometry_and_as_scene() {
    let dir = tempfile::tempdir().unwrap();
    let (m, s) = write(
        dir.path(),
        &roof_opening(1.0, "Meters", 1.0),
        Some(&format!("geometry = \"model.hbjson\"\n{SITE}")),
    );
    let scene = Scene::load(&s).unwrap();
    // The model's own triangles cover floor, walls and the roof less its opening.
    let area: f64 = scene.triangles[..scene.input_triangles]
        .iter()
        .map(|t| t.area())
        .sum();
    assert!(
        (area - (100.0 + 100.0 - 1.0 + 4.0 * 30.0)).abs() < 1e-9,
        "{area}"
    );
    // The grid is the sensors, in model order.
    assert_eq!(scene.sensors.len(), 2);
    assert_eq!(scene.sensors[1].input_position, DVec3::new(2.0, 2.0, 0.8));
    assert_eq!(scene.imported.sensor_grid, [0, 0]);
    assert_eq!(scene.imported.grids[0].identifier, "floor_grid");
    assert_eq!(scene.imported.views[0].identifier, "up");
    assert!(scene.site_given());
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);

    // A .pts file replaces the grids.
    std::fs::write(dir.path().join("s.pts"), "1 1 1 0 0 1\n").unwrap();
    std::fs::write(
        &s,
        format!("geometry = \"model.hbjson\"\nsensors = \"s.pts\"\n{SITE}"),
    )
    .unwrap();
    let with_pts = Scene::load(&s).unwrap();
    assert_eq!(with_pts.sensors.len(), 1);
    assert!(with_pts.imported.sensor_grid.is_empty());

    // The model on its own: the default site, said in a warning, and the same geometry.
    let alone = Scene::load(&m).unwrap();
    assert!(!alone.site_given());
    assert_eq!(alone.triangles, scene.triangles);
    assert_eq!(alone.sensors, scene.sensors);

    // `up` does not apply to a honeybee model.
    std::fs::write(
        &s,
        format!("geometry = \"model.hbjson\"\nup = \"y\"\n{SITE}"),
    )
    .unwrap();
    let e = Scene::load(&s).unwrap_err().to_string();
    assert!(e.contains("scene.toml:2") && e.contains("Z-up"), "{e}");

    // Millimetres: the same scene.
    let (m, _) = write(dir.path(), &roof_opening(1.0, "Millimeters", 1000.0), None);
    let mm = Scene::load(&m).unwrap();
    assert_eq!(mm.triangles, alone.triangles);
    assert_eq!(mm.sensors, alone.sensors);
}

#[test]
fn uniform_sky_through_a_honeybee_roof_hole_matches_the_configuration_factor() {
    let dir = tempfile::tempdir().unwrap();
    let (m, _) = write(dir.path(), &roof_opening(1.0, "Meters", 1.0), None);
    let scene = Scene::load(&m).unwrap();
    assert_roof_opening_configuration_factor(&scene);
}

#[test]
fn the_binary_runs_an_hbjson_and_names_the_object_of_a_bad_one() {
    let dir = tempfile::tempdir().unwrap();
    let (m, _) = write(dir.path(), &roof_opening(1.0, "Meters", 1.0), None);
    let out = dir.path().join("out");
    let o = daystep(&[
        "instant",
        m.to_str().unwrap(),
        "--time",
        "2024-06-21T12:00",
        "--sky",
        "preetham",
        "--turbidity",
        "3",
        "--out",
        out.to_str().unwrap(),
        "--quality",
        "draft",
        "--no-cache",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("sensors.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2, "{csv}");

    let mut bad = roof_opening(1.0, "Meters", 1.0);
    bad["rooms"][0]["faces"][2]["geometry"]["boundary"][1][0] = json!("NaN");
    let (m, _) = write(dir.path(), &bad, None);
    let o = daystep(&[
        "instant",
        m.to_str().unwrap(),
        "--time",
        "2024-06-21T12:00",
        "--sky",
        "preetham",
        "--turbidity",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("model.hbjson") && e.contains("south"), "{e}");
}

#[test]
fn the_honeybee_sample_in_millimetres_is_the_same_scene() {
    // make_model.py wrote the millimetre copy with honeybee's own unit conversion; every
    // coordinate is the metre value × 1000 exactly, so the scenes must be identical.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/honeybee");
    let m = Scene::load(&root.join("scene.toml")).unwrap();
    let mm = Scene::load(&root.join("scene_mm.toml")).unwrap();
    assert_eq!(m.triangles.len(), mm.triangles.len());
    for (k, (a, b)) in m.triangles.iter().zip(&mm.triangles).enumerate() {
        assert_eq!(a, b, "triangle {k}");
    }
    assert_eq!(m.materials, mm.materials);
    assert_eq!(m.sensors, mm.sensors);
}
