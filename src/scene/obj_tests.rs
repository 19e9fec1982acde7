//! Unit tests of the OBJ loader ([`super`]): groups, materials, triangulation, frames,
//! `f64` precision, large index counts, and errors that name file, line and value.

use super::*;
use crate::photometry::Rgb;

const MTL: &str = "\
# materials
newmtl wall
Kd 0.5 0.5 0.5
Ka 0.1 0.1 0.1
Ns 10
illum 2
newmtl glass
Kd 0.1
Tf 0.88 0.88 0.88
newmtl lamp
Kd 0.2 0.3 0.4
Ke 10 10 10
newmtl unused
Kd 0.9
";

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Writes `obj` (and the standard MTL as `m.mtl`) and loads it.
fn load_text(obj: &str, y_up: bool) -> Result<ObjContents> {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "m.mtl", MTL);
    let p = write(dir.path(), "a.obj", obj);
    load(&p, y_up)
}

fn input_error(e: Error) -> (String, PathBuf, Option<usize>, Option<String>) {
    crate::error::input_parts(e)
}

const BOX: &str = "\
mtllib m.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
o floor
usemtl wall
f 1 2 3 4
g window
usemtl glass
f 1/1 2/1/1 5
f -5//1 -4 -1
usemtl lamp
f 2 3 5
";

#[test]
fn loads_groups_materials_and_triangulates_quads() {
    let (tris, mats, groups, warnings) =
        load_text(&format!("vt 0 0\nvn 0 0 1\n{BOX}"), false).unwrap();
    assert_eq!(tris.len(), 5);
    let names: Vec<_> = mats.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["wall", "glass", "lamp"]);
    assert_eq!(groups, ["floor", "window"]);
    // The quad becomes two triangles of the floor, counter-clockwise kept.
    assert_eq!(
        tris[0].v,
        [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)]
    );
    assert_eq!(
        tris[1].v,
        [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]
    );
    assert!(tris[..2]
        .iter()
        .all(|t| t.group == 0 && t.material == 0 && t.normal() == DVec3::Z));
    // Negative (relative) indices.
    assert_eq!(tris[3].v, [DVec3::ZERO, DVec3::X, DVec3::Z]);
    assert_eq!((tris[4].material, tris[4].group), (2, 1));
    assert!(mats[1].is_glazing() && mats[1].reflectance() == Rgb::ZERO);
    assert_eq!(mats[1].kd, Rgb::splat(0.1));
    assert!(mats[2].is_emitter() && mats[2].ke == Rgb::splat(10.0));
    assert_eq!(mats[0].kd, Rgb::splat(0.5));
    assert!(warnings.is_empty(), "{warnings:?}");
}

#[test]
fn groups_fall_back_to_material_names() {
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl wall\nf 1 2 3\nusemtl lamp\nf 1 2 3\nusemtl wall\nf 3 2 1\n";
    let (tris, mats, groups, _) = load_text(obj, false).unwrap();
    assert_eq!(groups, ["wall", "lamp"]);
    assert_eq!(mats.len(), 2);
    assert_eq!(tris.iter().map(|t| t.group).collect::<Vec<_>>(), [0, 1, 0]);
}

#[test]
fn polygons_fan_triangulate_and_w_divides() {
    let obj = "mtllib m.mtl\nv 0 0 0 2\nv 2 0 0 2\nv 2 2 0\nv 1 3 0 1 0.5 0.5\nv 0 2 0\nusemtl wall\nf 1 2 3 4 5\n";
    let (tris, ..) = load_text(obj, false).unwrap();
    assert_eq!(tris.len(), 3);
    assert_eq!(tris[0].v[1], DVec3::X);
    assert!(tris.iter().all(|t| t.v[0] == DVec3::ZERO));
    let area: f64 = tris.iter().map(Triangle::area).sum();
    // Pentagon (0,0) (1,0) (2,2) (1,3) (0,2): shoelace area 4.
    assert!((area - 4.0).abs() < 1e-12, "{area}");
}

#[test]
fn y_up_maps_x_y_z_to_x_minus_z_y() {
    let obj = "mtllib m.mtl\nv 1 2 3\nv 4 5 6\nv 7 8 10\nusemtl wall\nf 1 2 3\n";
    let (tris, ..) = load_text(obj, true).unwrap();
    assert_eq!(
        tris[0].v,
        [
            DVec3::new(1.0, -3.0, 2.0),
            DVec3::new(4.0, -6.0, 5.0),
            DVec3::new(7.0, -10.0, 8.0)
        ]
    );
}

#[test]
fn coordinates_keep_f64_precision() {
    // A georeferenced model: f32 would round these to a multiple of 0.5 m.
    let obj = "mtllib m.mtl\nv 4500000.123 300000.456 0\nv 4500001.123 300000.456 0\nv 4500000.123 300001.456 0.001\nusemtl wall\nf 1 2 3\n";
    let (tris, ..) = load_text(obj, false).unwrap();
    assert_eq!(tris[0].v[0], DVec3::new(4500000.123, 300000.456, 0.0));
    assert_eq!(tris[0].v[2].z, 0.001);
}

#[test]
fn vertex_indices_beyond_the_split_map_back() {
    // More than 2²⁰ vertices, so the index handed to tobj needs its high part.
    let mut obj = String::from("mtllib m.mtl\n");
    for k in 0..INDEX_SPLIT + 3 {
        let _ = writeln!(obj, "v {k} 0 {}", k % 2);
    }
    obj.push_str("usemtl wall\nf -3 -2 -1\nf 1 2 3\n");
    let (tris, ..) = load_text(&obj, false).unwrap();
    let k = INDEX_SPLIT as f64;
    assert_eq!(tris[0].v[0], DVec3::new(k, 0.0, 0.0));
    assert_eq!(tris[0].v[2], DVec3::new(k + 2.0, 0.0, 0.0));
    assert_eq!(tris[0].v[1], DVec3::new(k + 1.0, 0.0, 1.0));
    assert_eq!(tris[1].v[1], DVec3::new(1.0, 0.0, 1.0));
}

#[test]
fn obj_errors_name_file_line_and_value() {
    let head = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: &[(&str, usize, &str)] = &[
        ("v 1 NaN 0\n", 5, "NaN"),
        ("v 1 inf 0\n", 5, "inf"),
        ("v 1 2\n", 5, "1 2"),
        ("v 1 x 2\n", 5, "x"),
        ("usemtl wall\nf 1 2 4\n", 6, "4"),
        ("usemtl wall\nf 1 0 2\n", 6, "0"),
        ("usemtl wall\nf 1 2 -4\n", 6, "-4"),
        ("usemtl wall\nf 1 2/5 3\n", 6, "2/5"),
        ("usemtl wall\nf 1 2\n", 6, "1 2"),
        ("f 1 2 3\n", 5, "1 2 3"),
        ("usemtl marble\nf 1 2 3\n", 5, "marble"),
    ];
    for (tail, line, value) in cases {
        let (shown, path, l, v) =
            input_error(load_text(&format!("{head}{tail}"), false).unwrap_err());
        assert!(path.ends_with("a.obj"), "{shown}");
        assert_eq!(l, Some(*line), "{shown}");
        assert_eq!(v.as_deref(), Some(*value), "{shown}");
        assert!(shown.contains(&format!("a.obj:{line}:")), "{shown}");
    }
}

#[test]
fn missing_mtl_names_obj_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "a.obj", "# x\nmtllib nothere.mtl\nv 0 0 0\n");
    let (shown, path, line, value) = input_error(load(&p, false).unwrap_err());
    assert!(path.ends_with("a.obj") && line == Some(2), "{shown}");
    assert_eq!(value.as_deref(), Some("nothere.mtl"));
    assert!(shown.contains("nothere.mtl"));
}

#[test]
fn several_libraries_on_one_line_and_mtl_with_spaces() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "one.mtl", "newmtl a\nKd 0.1 0.2 0.3\n");
    write(dir.path(), "two words.mtl", "newmtl b\nKd 0.4\n");
    write(dir.path(), "three.mtl", "newmtl c\nKd 0.5\n");
    let p = write(
        dir.path(),
        "a.obj",
        "mtllib one.mtl three.mtl\nmtllib two words.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl b\nf 1 2 3\nusemtl c\nf 1 2 3\nusemtl a\nf 1 2 3\n",
    );
    let (_, mats, ..) = load(&p, false).unwrap();
    let names: Vec<_> = mats.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["b", "c", "a"]);
    assert_eq!(mats[2].kd, Rgb::new(0.1, 0.2, 0.3));
}

#[test]
fn mtl_errors_name_file_line_and_value() {
    let cases: &[(&str, usize, &str)] = &[
        ("newmtl a\nKd 1.0 0.5 0.5\n", 2, "1.0"),
        ("newmtl a\nKd 0.5 -0.1 0.5\n", 2, "-0.1"),
        ("newmtl a\n\nKd 0.5 0.5 NaN\n", 3, "NaN"),
        ("newmtl a\nKd 1\n", 2, "1"),
        ("newmtl a\nKd 0.5 0.5\n", 2, "0.5 0.5"),
        ("newmtl a\nKd spectral x.rfl\n", 2, "spectral"),
        ("newmtl a\nTf 0.5 1.5 0.5\n", 2, "1.5"),
        ("newmtl a\nKe -1 0 0\n", 2, "-1"),
        ("newmtl a\nKe inf 0 0\n", 2, "inf"),
        ("Kd 0.5\n", 1, "Kd 0.5"),
    ];
    for (mtl, line, value) in cases {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "m.mtl", mtl);
        let p = write(dir.path(), "a.obj", "mtllib m.mtl\n");
        let (shown, path, l, v) = input_error(load(&p, false).unwrap_err());
        assert!(path.ends_with("m.mtl"), "{shown}");
        assert_eq!(l, Some(*line), "{shown}");
        assert_eq!(v.as_deref(), Some(*value), "{shown}");
    }
}

#[test]
fn file_without_faces_is_an_error() {
    let e = load_text("mtllib m.mtl\nv 0 0 0\n", false).unwrap_err();
    assert!(e.to_string().contains("no faces"), "{e}");
}
