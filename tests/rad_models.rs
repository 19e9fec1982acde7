//! Radiance scene files (`.rad`, `.mat`) as `geometry`: the honeybee sample written by
//! honeybee-radiance against the same model's HBJSON (areas per material, sensors), the sky
//! through a roof opening against the closed-form configuration factor, the binary's exit 1
//! naming file and line, and arbitrary or mutated .rad text (no panic, no hang, errors
//! naming the file and a line).

use crate::parsers::{
    any_text, check, check_error, check_materials, guarded, mutate_text, mutations, regex,
    CaseResult, Format, Naming, Sep,
};
use crate::util::*;
use daystep::scene::{rad, Scene};
use proptest::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn honeybee(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/honeybee")
        .join(name)
}

/// Area of the model's own triangles per material name, and per class (glazing, emitter,
/// opaque).
fn areas(s: &Scene) -> (BTreeMap<String, f64>, BTreeMap<&'static str, f64>) {
    let (mut by_name, mut by_class) = (BTreeMap::new(), BTreeMap::new());
    for t in &s.triangles[..s.input_triangles] {
        let m = &s.materials[t.material as usize];
        *by_name.entry(m.name.clone()).or_insert(0.0) += t.area();
        let class = if m.is_glazing() {
            "glazing"
        } else if m.is_emitter() {
            "emitter"
        } else {
            "opaque"
        };
        *by_class.entry(class).or_insert(0.0) += t.area();
    }
    (by_name, by_class)
}

fn same_areas<K: Ord + std::fmt::Debug>(a: &BTreeMap<K, f64>, b: &BTreeMap<K, f64>) {
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (k, x) in a {
        let y = b[k];
        assert!((x - y).abs() <= 1e-6 * y.abs(), "{k:?}: {x} vs {y}");
    }
}

#[test]
fn honeybee_rad_folder_has_the_areas_and_sensors_of_its_hbjson() {
    let from_rad = Scene::load(&honeybee("scene_rad.toml")).unwrap();
    let from_hb = Scene::load(&honeybee("scene.toml")).unwrap();
    let (rad_names, rad_classes) = areas(&from_rad);
    let (hb_names, hb_classes) = areas(&from_hb);
    same_areas(&rad_classes, &hb_classes);
    same_areas(&rad_names, &hb_names);
    assert!(rad_classes["glazing"] > 0.0);
    // Both rooms' grids (80 each) are the sensors.
    assert_eq!(from_rad.sensors.len(), 160);
    assert_eq!(from_rad.sensors.len(), from_hb.sensors.len());
    // One group per polygon identifier.
    assert!(from_rad.groups.iter().any(|g| g == "Room_West_Back"));
    assert!(from_rad.warnings.is_empty(), "{:?}", from_rad.warnings);
}

/// A black 10 × 10 × 3 m box whose roof has a `hole` × `hole` m opening above (5, 5), the
/// roof one polygon joined to its hole by a seam, as exporters write it; every surface
/// facing out (Radiance's right-hand rule).
fn roof_opening_rad(hole: f64) -> String {
    let (a, b) = (5.0 - hole / 2.0, 5.0 + hole / 2.0);
    let poly = |id: &str, pts: &[[f64; 3]]| {
        let c: Vec<String> = pts.iter().flatten().map(|x| x.to_string()).collect();
        format!("black polygon {id}\n0\n0\n{} {}\n\n", c.len(), c.join(" "))
    };
    let mut s =
        String::from("# a box with a hole in its roof\nvoid plastic black\n0\n0\n5 0 0 0 0 0\n\n");
    s += &poly(
        "floor",
        &[[0., 0., 0.], [0., 10., 0.], [10., 10., 0.], [10., 0., 0.]],
    );
    s += &poly(
        "roof",
        &[
            [0., 0., 3.],
            [10., 0., 3.],
            [10., 10., 3.],
            [0., 10., 3.],
            [0., 0., 3.],
            [a, a, 3.],
            [a, b, 3.],
            [b, b, 3.],
            [b, a, 3.],
            [a, a, 3.],
        ],
    );
    s += &poly(
        "south",
        &[[0., 0., 0.], [10., 0., 0.], [10., 0., 3.], [0., 0., 3.]],
    );
    s += &poly(
        "north",
        &[[10., 10., 0.], [0., 10., 0.], [0., 10., 3.], [10., 10., 3.]],
    );
    s += &poly(
        "east",
        &[[10., 0., 0.], [10., 10., 0.], [10., 10., 3.], [10., 0., 3.]],
    );
    s += &poly(
        "west",
        &[[0., 10., 0.], [0., 0., 0.], [0., 0., 3.], [0., 10., 3.]],
    );
    s
}

const SITE: &str = "[site]\nlatitude = 48.1\nlongitude = 11.6\nutc_offset_h = 1\n";

/// Writes the roof-opening box as `box.rad` with two sensors and a scene file.
fn write_box(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("box.rad"), roof_opening_rad(1.0)).unwrap();
    std::fs::write(dir.join("s.pts"), "5 5 0 0 0 1\n2 2 0.8 0 0 1\n").unwrap();
    let s = dir.join("scene.toml");
    std::fs::write(
        &s,
        format!("geometry = [\"box.rad\"]\nsensors = \"s.pts\"\n{SITE}"),
    )
    .unwrap();
    s
}

#[test]
fn uniform_sky_through_a_rad_roof_hole_matches_the_configuration_factor() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&write_box(dir.path())).unwrap();
    let area: f64 = scene.triangles[..scene.input_triangles]
        .iter()
        .map(|t| t.area())
        .sum();
    assert!(
        (area - (100.0 + 100.0 - 1.0 + 4.0 * 30.0)).abs() < 1e-9,
        "{area}"
    );
    // The roof faces up, out of the box.
    let roof = scene.groups.iter().position(|g| g == "roof").unwrap() as u32;
    assert!(scene.triangles[..scene.input_triangles]
        .iter()
        .filter(|t| t.group == roof)
        .all(|t| t.normal().z > 0.999));
    assert_roof_opening_configuration_factor(&scene);
}

#[test]
fn geometry_lists_hold_radiance_files_only() {
    let dir = tempfile::tempdir().unwrap();
    let s = write_box(dir.path());
    std::fs::write(dir.path().join("a.obj"), "v 0 0 0\n").unwrap();
    for (list, word) in [
        ("[\"box.rad\", \"a.obj\"]", "a.obj"),
        ("[]", "empty"),
        ("[\"box.rad\", 3]", "string"),
        ("[\"box.rad\", \"nothere.rad\"]", "not found"),
    ] {
        std::fs::write(&s, format!("\ngeometry = {list}\n{SITE}")).unwrap();
        let e = Scene::load(&s).unwrap_err().to_string();
        assert!(
            e.contains("scene.toml:2") && e.contains(word),
            "{list}: {e}"
        );
    }
    // A material file before the geometry, as oconv takes them.
    std::fs::write(
        dir.path().join("m.mat"),
        "void plastic grey 0 0 5 .5 .5 .5 0 0\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("g.rad"),
        "grey polygon p 0 0 9 0 0 0 1 0 0 0 1 0\n",
    )
    .unwrap();
    std::fs::write(&s, format!("geometry = [\"m.mat\", \"g.rad\"]\n{SITE}")).unwrap();
    let scene = Scene::load(&s).unwrap();
    assert_eq!(scene.materials[0].name, "grey");
    // In the other order the modifier is not yet defined.
    std::fs::write(&s, format!("geometry = [\"g.rad\", \"m.mat\"]\n{SITE}")).unwrap();
    let e = Scene::load(&s).unwrap_err().to_string();
    assert!(e.contains("g.rad:1") && e.contains("grey"), "{e}");
    // `up` is Z for Radiance.
    std::fs::write(&s, format!("geometry = \"g.rad\"\nup = \"y\"\n{SITE}")).unwrap();
    assert!(Scene::load(&s)
        .unwrap_err()
        .to_string()
        .contains("Radiance"));
}

#[test]
fn the_binary_exits_1_naming_file_and_line_of_a_bad_rad() {
    let dir = tempfile::tempdir().unwrap();
    let s = write_box(dir.path());
    let out = dir.path().join("out");
    let args = |s: &Path| {
        let mut v: Vec<String> = [
            "instant",
            s.to_str().unwrap(),
            "--time",
            "2024-06-21T12:00",
            "--sky",
            "cie-overcast",
            "--dhi",
            "100",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        v.push("--no-cache".into());
        v
    };
    let run_it = |s: &Path| {
        let a = args(s);
        daystep(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    // An unknown primitive on line 3 of an included file.
    std::fs::write(
        dir.path().join("box.rad"),
        "void plastic black 0 0 5 0 0 0 0 0\n!xform -t 1 0 0 ball.rad\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("ball.rad"),
        "\n\nblack sphere ball 0 0 4 0 0 0 1\n",
    )
    .unwrap();
    let o = run_it(&s);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("ball.rad:3") && e.contains("sphere"), "{e}");
    // A file including itself: exit 1 at once, no hang.
    std::fs::write(dir.path().join("box.rad"), "!xform -a 2 -t 0 0 1 box.rad\n").unwrap();
    let o = run_it(&s);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("box.rad:1"), "{}", stderr(&o));
    // A shell command is refused, never run.
    let marker = dir.path().join("ran");
    std::fs::write(
        dir.path().join("box.rad"),
        format!("!touch {}\n", marker.display()),
    )
    .unwrap();
    let o = run_it(&s);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("box.rad:1") && !marker.exists());
}

// ---------------------------------------------------------------------------------------
// Arbitrary and mutated .rad text

/// A folder with the honeybee sample's materials and surfaces as one `a.rad` and a small
/// `b.rad` it may include.
struct RadFolder {
    _dir: tempfile::TempDir,
    files: Vec<PathBuf>,
}

impl RadFolder {
    fn new() -> RadFolder {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("b.rad"),
            "generic_wall_0.50 polygon small 0 0 9 0 0 0 1 0 0 0 1 0\n",
        )
        .unwrap();
        let files = ["a.rad", "b.rad"].map(|n| dir.path().join(n)).to_vec();
        RadFolder { _dir: dir, files }
    }
    /// Writes `text` as `a.rad` and loads it (guarded), checking the outcome.
    fn load(&self, text: &str) -> CaseResult {
        let p = self.files[0].clone();
        let _ = std::fs::remove_file(&p);
        std::fs::write(&p, text).unwrap();
        match guarded(|| rad::load(std::slice::from_ref(&p)))? {
            Ok(r) => {
                for t in &r.triangles {
                    prop_assert!(t.v.iter().all(|v| v.is_finite()), "{:?}", t);
                    prop_assert!((t.material as usize) < r.materials.len());
                    prop_assert!((t.group as usize) < r.groups.len());
                }
                check_materials(&r.materials)
            }
            Err(e) => check_error(
                &e,
                &Naming {
                    files: &self.files,
                    whole_file: &[],
                    value_on_line: false,
                },
            ),
        }
    }
}

/// The honeybee sample's files, in oconv's order, as one text.
fn sample() -> String {
    let mut s = String::new();
    for f in [
        "scene/envelope.mat",
        "scene/shades.mat",
        "aperture/aperture.mat",
        "scene/envelope.rad",
        "scene/shades.rad",
        "aperture/aperture.rad",
    ] {
        let p = honeybee("rad/model").join(f);
        s += &std::fs::read_to_string(&p).unwrap();
        s.push('\n');
    }
    s
}

fn rad_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "void inherit alias polygon plastic glass glow light source sphere mirror 0 3 4 5 7 9 \
         12 -3 99999999 \"a 'b !xform",
        "\
!xform -t 1 0 0 b.rad
!xform -a 99999 -a 99999 -t 1 0 0 b.rad
!xform -i 99999 -rz 1 b.rad
!xform -mx -I -n n -m generic_wall_0.50 b.rad
!xform a.rad
!xform -a 3 a.rad
!xform nothere.rad
!xform
!cat b.rad
!cat b.rad | sh
!gensky 3 21 12
!xform -t 1 0 \\
void alias x generic_wall_0.50
x polygon y 0 0 9 0 0 0 1 0 0 0 1 0
inherit polygon z 0 0 9 0 0 0 1 0 0 0 1 0
void polygon v 0 0 9 0 0 0 1 0 0 0 1 0
void source s 0 0 4 0 0 1 0.5
void glass g 0 0 4 1 1 1 1.6
void plastic p 0 0 5 0.5 0.5 0.5 0.2 0
generic_wall_0.50 polygon big 0 0 99999999999
generic_wall_0.50 polygon nan 0 0 9 0 0 0 nan 0 0 0 1 0
generic_wall_0.50 polygon line 0 0 9 0 0 0 1 1 1 2 2 2
\"unterminated
'also",
    )
}

#[test]
fn rad_arbitrary_text() {
    let f = RadFolder::new();
    let rad_like = "((void|generic_wall_0.50|x) (plastic|polygon|glass|alias|light) [a-z]{1,3}( \
                    [-0-9.en]{1,4}){0,14}\n|!xform( -[a-z]{1,2}| [0-9.]{1,3}| b.rad| a.rad){0,6}\n){0,30}";
    check(1024, prop_oneof![any_text(), regex(rad_like)], |text| {
        f.load(&text)
    });
}

#[test]
fn rad_mutations() {
    let f = RadFolder::new();
    let sample = sample();
    assert!(rad::parse(&f.files[0], &sample).is_ok());
    let format = rad_format();
    check(2048, mutations(), |m| {
        f.load(&mutate_text(&sample, &m, &format))
    });
}
