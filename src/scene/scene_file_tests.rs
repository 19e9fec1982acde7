//! Unit tests of the scene file ([`super`]): keys, paths, geometry lists, site values,
//! and errors that name the file, line and value.

use super::*;
use glam::DVec3;

const MTL: &str = "newmtl wall\nKd 0.5 0.5 0.5\nnewmtl glass\nTf 0.88 0.88 0.88\n";
const OBJ: &str = "\
mtllib m.mtl
v 0 0 0
v 10 0 0
v 10 1 0
v 0 1 0
g floor
usemtl wall
f 1 2 3 4
g window
usemtl glass
f 1 2 4
";
const SITE: &str =
    "[site]\nlatitude = 37.42\nlongitude = -5.90\nutc_offset_h = 1\nelevation_m = 31.0\n";

/// Writes the model, sensors and `scene` text into a temporary folder and loads it.
fn load_scene(scene: &str) -> (tempfile::TempDir, Result<Scene>) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.mtl"), MTL).unwrap();
    std::fs::create_dir(dir.path().join("geo")).unwrap();
    std::fs::write(dir.path().join("geo/m.mtl"), MTL).unwrap();
    std::fs::write(dir.path().join("geo/a.obj"), OBJ).unwrap();
    std::fs::write(
        dir.path().join("s.pts"),
        "1 0 0.8 1 0 0\n# c\n2 0 0.8 0 0 1\n",
    )
    .unwrap();
    let p = dir.path().join("scene.toml");
    std::fs::write(&p, scene).unwrap();
    let r = load(&p);
    (dir, r)
}

fn input_error(e: Error) -> (String, Option<usize>, Option<String>) {
    let (shown, _, line, value) = crate::error::input_parts(e);
    (shown, line, value)
}

#[test]
fn valid_scene_loads_everything() {
    let (_d, r) = load_scene(&format!(
        "geometry = \"geo/a.obj\"\nsensors = \"s.pts\"\nground_reflectance = 0.3\n{SITE}"
    ));
    let s = r.unwrap();
    assert_eq!(s.input_triangles, 3);
    // Two-sided by default; the floor is the lowest surface, with nothing behind it, so
    // it gets no back face (and the window, glazing, has none).
    assert_eq!(s.faces, Faces::Both);
    assert_eq!(s.triangles.len(), 3);
    assert_eq!(s.materials.len(), 2);
    assert!(s.has_glazing());
    assert_eq!(s.groups, ["floor", "window"]);
    assert_eq!(s.sensors.len(), 2);
    assert_eq!(
        s.site,
        Site {
            latitude: 37.42,
            longitude: -5.90,
            utc_offset_h: 1.0,
            elevation_m: 31.0
        }
    );
    assert_eq!(s.ground_reflectance, 0.3);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // Model coordinates are recovered with the origin (north_deg 0: no rotation).
    assert_eq!(s.triangles[0].v[1] + s.origin, DVec3::new(10.0, 0.0, 0.0));
    assert_eq!(s.sensors[0].input_position, DVec3::new(1.0, 0.0, 0.8));
    assert_eq!(s.sensors[0].normal, DVec3::X);
}

#[test]
fn defaults_and_missing_site_warn() {
    let (_d, r) = load_scene("geometry = \"geo/a.obj\"\n");
    let s = r.unwrap();
    assert_eq!(s.site, Site::default());
    assert_eq!(s.ground_reflectance, 0.2);
    assert!(s.sensors.is_empty());
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains(NO_SITE_WARNING));
    assert!(!s.site_given());
    let (_d, r) = load_scene(&format!("geometry = \"geo/a.obj\"\n{SITE}"));
    assert!(r.unwrap().site_given());
}

#[test]
fn unknown_keys_warn_but_load() {
    let (_d, r) = load_scene(&format!(
        "geometry = \"geo/a.obj\"\nfuture_option = 3\n{SITE}timezone_name = \"x\"\n"
    ));
    let s = r.unwrap();
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains(":2: unknown key `future_option`"),
        "{:?}",
        s.warnings
    );
    assert!(
        s.warnings[1].contains("`site.timezone_name`"),
        "{:?}",
        s.warnings
    );
}

#[test]
fn north_deg_90_turns_model_x_to_true_north() {
    let (_d, r) = load_scene(&format!(
        "geometry = \"geo/a.obj\"\nsensors = \"s.pts\"\nnorth_deg = 90\n{SITE}"
    ));
    let s = r.unwrap();
    // Sensor 0 looks along model +X: in the scene frame it looks north (+Y).
    assert!(
        (s.sensors[0].normal - DVec3::Y).length() < 1e-12,
        "{}",
        s.sensors[0].normal
    );
    // The model point (10, 0, 0) lies 10 m north of the model point (0, 0, 0).
    let t = &s.triangles[0];
    let d = t.v[1] - t.v[0];
    assert!((d - DVec3::new(0.0, 10.0, 0.0)).length() < 1e-12, "{d}");
    // Model +Y points west.
    let d = t.v[2] - t.v[1];
    assert!((d - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-12, "{d}");
}

#[test]
fn y_up_applies_to_geometry_and_sensors() {
    let (_d, r) = load_scene(&format!(
        "geometry = \"geo/a.obj\"\nsensors = \"s.pts\"\nup = \"y\"\n{SITE}"
    ));
    let s = r.unwrap();
    // File sensor (1, 0, 0.8) looking +X → model (1, −0.8, 0); direction (0,0,1) → (0,−1,0).
    assert_eq!(s.sensors[0].input_position, DVec3::new(1.0, -0.8, 0.0));
    assert_eq!(s.sensors[1].normal, DVec3::new(0.0, -1.0, 0.0));
    // The floor quad (in the file's XY plane) now stands in the XZ plane, facing −Y.
    assert!((s.triangles[0].normal() - DVec3::new(0.0, -1.0, 0.0)).length() < 1e-12);
}

#[test]
fn errors_name_scene_file_line_and_value() {
    let g = "geometry = \"geo/a.obj\"\n";
    let cases: Vec<(String, Option<usize>, Option<&str>)> = vec![
        (
            format!("{g}[site]\nlatitude = 91\nlongitude = 0\nutc_offset_h = 0\n"),
            Some(3),
            Some("91"),
        ),
        (
            format!("{g}[site]\nlatitude = 0\nlongitude = 200\nutc_offset_h = 0\n"),
            Some(4),
            Some("200"),
        ),
        (
            format!("{g}[site]\nlatitude = 0\nlongitude = 0\nutc_offset_h = -15\n"),
            Some(5),
            Some("-15"),
        ),
        (
            format!("{g}[site]\nlatitude = nan\nlongitude = 0\nutc_offset_h = 0\n"),
            Some(3),
            Some("NaN"),
        ),
        (format!("{g}north_deg = inf\n"), Some(2), Some("inf")),
        (
            format!("{g}[site]\nlatitude = 0\nlongitude = -inf\nutc_offset_h = 0\n"),
            Some(4),
            Some("-inf"),
        ),
        (
            format!("{g}[site]\nlatitude = 0\nlongitude = 0\nutc_offset_h = nan\n"),
            Some(5),
            Some("NaN"),
        ),
        (
            format!(
                "{g}[site]\nlatitude = 0\nlongitude = 0\nutc_offset_h = 0\nelevation_m = nan\n"
            ),
            Some(6),
            Some("NaN"),
        ),
        (
            format!("{g}ground_reflectance = -nan\n"),
            Some(2),
            Some("NaN"),
        ),
        (format!("{g}ground_reflectance = 1.0\n"), Some(2), Some("1")),
        (format!("{g}up = \"x\"\n"), Some(2), Some("x")),
        (
            format!("{g}sensors = \"none.pts\"\n"),
            Some(2),
            Some("none.pts"),
        ),
        (
            "\n\ngeometry = \"nothere.obj\"\n".into(),
            Some(3),
            Some("nothere.obj"),
        ),
        ("sensors = \"s.pts\"\n".into(), None, None),
    ];
    for (text, line, value) in cases {
        let (_d, r) = load_scene(&text);
        let (shown, l, v) = input_error(r.unwrap_err());
        assert!(shown.contains("scene.toml"), "{shown}");
        assert_eq!(l, line, "{shown}");
        assert_eq!(v.as_deref(), value, "{shown}");
    }
}

#[test]
fn elevation_beyond_any_site_is_refused() {
    let site = |e: &str| {
        format!(
            "geometry = \"geo/a.obj\"\n[site]\nlatitude = 0\nlongitude = 0\n\
             utc_offset_h = 0\nelevation_m = {e}\n"
        )
    };
    for bad in ["1e6", "-5000", "10000.5"] {
        let (_d, r) = load_scene(&site(bad));
        let (shown, line, _) = input_error(r.unwrap_err());
        assert_eq!(line, Some(6), "{shown}");
        assert!(shown.contains("site.elevation_m"), "{shown}");
    }
    for good in ["8849", "-430", "0"] {
        let (_d, r) = load_scene(&site(good));
        assert_eq!(r.unwrap().site.elevation_m, good.parse::<f64>().unwrap());
    }
}

#[test]
fn toml_syntax_error_reports_line() {
    let (_d, r) = load_scene("geometry = \"geo/a.obj\"\n\nnorth_deg = = 3\n");
    let (shown, line, value) = input_error(r.unwrap_err());
    assert_eq!(line, Some(3), "{shown}");
    assert!(value.is_some_and(|v| v.contains('=')), "{shown}");
    assert!(shown.contains("scene.toml:3:"), "{shown}");
    // A wrong type is reported at its line too.
    let (_d, r) = load_scene("geometry = \"geo/a.obj\"\nnorth_deg = \"east\"\n");
    let (shown, line, _) = input_error(r.unwrap_err());
    assert_eq!(line, Some(2), "{shown}");
    // And a missing site field at the [site] table.
    let (_d, r) = load_scene("geometry = \"geo/a.obj\"\n[site]\nlatitude = 1\n");
    let (shown, line, _) = input_error(r.unwrap_err());
    assert!(line.is_some() && shown.contains("longitude"), "{shown}");
}

#[test]
fn errors_from_referenced_files_propagate() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.obj"), "v 0 0 NaN\n").unwrap();
    let p = dir.path().join("scene.toml");
    std::fs::write(&p, "geometry = \"a.obj\"\n").unwrap();
    let (shown, line, value) = input_error(load(&p).unwrap_err());
    assert!(shown.contains("a.obj:1:"), "{shown}");
    assert_eq!((line, value.as_deref()), (Some(1), Some("NaN")));
}

#[test]
fn aperture_groups_name_glazing_materials_and_list_their_members() {
    let geometry = "geometry = \"geo/a.obj\"\n";
    let (_d, r) = load_scene(&format!(
        "{geometry}[aperture_groups.south]\nmaterials = [\"glass\"]\nshade_transmittance = 0.05\n"
    ));
    let s = r.unwrap();
    let g = &s.imported.aperture_groups;
    assert_eq!(g.len(), 1);
    assert_eq!(g[0].identifier, "south");
    // The OBJ group whose triangles use the glass.
    assert_eq!(g[0].members, ["window"]);
    assert_eq!(g[0].shade_transmittance, Some(0.05));
    // Errors name the scene file, the table's line and the value.
    let cases = [
        ("[aperture_groups.s]\nmaterials = [\"wall\"]\n", "wall", "not glazing"),
        ("[aperture_groups.s]\nmaterials = [\"steel\"]\n", "steel", "glass"),
        ("[aperture_groups.s]\nmaterials = []\n", "s", "no materials"),
        (
            "[aperture_groups.s]\nmaterials = [\"glass\"]\nshade_transmittance = 1.5\n",
            "1.5",
            "[0, 1]",
        ),
        (
            "[aperture_groups.a]\nmaterials = [\"glass\"]\n[aperture_groups.b]\nmaterials = [\"glass\"]\n",
            "glass",
            "`a` and `b`",
        ),
    ];
    for (table, value, says) in cases {
        let (_d, r) = load_scene(&format!("{geometry}{table}"));
        let (shown, line, v) = input_error(r.unwrap_err());
        assert_eq!(v.as_deref(), Some(value), "{shown}");
        assert!(line.is_some_and(|l| l >= 2), "{shown}");
        assert!(
            shown.contains("scene.toml") && shown.contains(says),
            "{shown}"
        );
    }
    // A key the table does not know is a syntax-level error naming its line.
    let (_d, r) = load_scene(&format!(
        "{geometry}[aperture_groups.s]\nmaterials = [\"glass\"]\nshade = 0.1\n"
    ));
    let (shown, line, _) = input_error(r.unwrap_err());
    assert_eq!(line, Some(4), "{shown}");
}
