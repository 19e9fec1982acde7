//! Wavefront OBJ/MTL geometry.
//!
//! tobj does the loading proper (objects and groups, splits per material, fan triangulation).
//! Because tobj's errors carry no line numbers and its default build stores coordinates as
//! `f32` (centimetre steps at georeferenced coordinates of a few hundred kilometres), a
//! line-aware pass runs first: it validates every line it relies on, reads the vertex
//! coordinates in `f64`, parses the MTL files itself, and hands tobj a normalised copy of the
//! file in which each vertex carries its own index instead of its coordinates. tobj's output
//! then maps straight back to the exact `f64` vertices.

use super::{y_up_to_z_up, Material, Triangle};
use crate::error::{Error, Result};
use crate::files;
use crate::photometry::Rgb;
use glam::DVec3;
use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Vertex indices are handed to tobj split into two parts below 2²⁰ each, both exact in
/// `f32` (whose integers are exact up to 2²⁴).
const INDEX_SPLIT: usize = 1 << 20;

/// What [`load`] returns: `(triangles, materials, groups, warnings)`.
pub type ObjContents = (Vec<Triangle>, Vec<Material>, Vec<String>, Vec<String>);

/// Loads an OBJ file and the MTL files it names.
///
/// Returns `(triangles, materials, groups, warnings)`:
/// - triangles in the model frame, metres, Z up (a Y-up file, `y_up = true`, is converted
///   with [`y_up_to_z_up`]); polygons are fan-triangulated; `material` and `group` index the
///   two lists that follow;
/// - the materials used by at least one face, in order of first use;
/// - group names: the OBJ object/group name of each face, or its material name when the
///   file has no `o`/`g` lines at all;
/// - warnings (unknown MTL keys, each once per file; ignored transparency; missing `Kd`).
///
/// # Errors
/// [`Error::Input`] naming the file, 1-based line and offending value for a malformed or
/// non-finite vertex, a face index that is zero or out of range, a face without material,
/// `usemtl` of an undefined material, a missing `mtllib` file (named with the OBJ line), and
/// any bad MTL value (`Kd` outside [0, 1), `Tf` outside [0, 1], negative `Ke`, NaN, …);
/// [`Error::Io`] when a file cannot be read.
pub fn load(path: &Path, y_up: bool) -> Result<ObjContents> {
    let text = files::read_text(path)?;
    let pass = prepass(path, &text)?;
    build(path, pass, y_up)
}

/// What the line-aware pass learned about an OBJ file.
struct Prepass {
    /// Vertex coordinates as written (after the optional `w` division), file frame.
    positions: Vec<DVec3>,
    /// All materials defined by the file's MTL libraries (a redefinition replaces).
    materials: Vec<Material>,
    /// Material name → index into `materials`.
    by_name: HashMap<String, usize>,
    /// Material names per `mtllib` line, in order: what tobj's material loader returns.
    libs: Vec<Vec<String>>,
    /// True when the file has any `o` or `g` line.
    has_groups: bool,
    /// True when the file has any face.
    has_faces: bool,
    /// The normalised OBJ text for tobj, line for line.
    normalised: String,
    /// Non-fatal remarks.
    warnings: Vec<String>,
}

/// Validates the OBJ text line by line and builds the normalised copy for tobj.
fn prepass(path: &Path, text: &str) -> Result<Prepass> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut p = Prepass {
        positions: Vec::new(),
        materials: Vec::new(),
        by_name: HashMap::new(),
        libs: Vec::new(),
        has_groups: false,
        has_faces: false,
        normalised: String::with_capacity(text.len()),
        warnings: Vec::new(),
    };
    let (mut n_vt, mut n_vn) = (0usize, 0usize);
    let mut current_material: Option<String> = None;
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let err =
            |value: &str, message: String| Error::input(path, Some(line_no), Some(value), message);
        let trimmed = raw.trim();
        let (key, rest) = match trimmed.split_once(char::is_whitespace) {
            Some((k, r)) => (k, r.trim()),
            None => (trimmed, ""),
        };
        // Numeric lines may end in a comment; names (groups, materials, files) are kept
        // whole because they may legitimately contain `#`.
        let numbers = || rest.split('#').next().unwrap_or("").split_whitespace();
        match key {
            "v" => {
                let words: Vec<&str> = numbers().collect();
                let mut xs = Vec::with_capacity(words.len());
                for w in &words {
                    let x: f64 = w
                        .parse()
                        .map_err(|_| err(w, "vertex coordinate is not a number".into()))?;
                    if !x.is_finite() {
                        return Err(err(w, "vertex coordinate must be finite".into()));
                    }
                    xs.push(x);
                }
                // x y z, x y z w, or x y z r g b (vertex colours, ignored).
                let mut v = match xs.len() {
                    3 | 4 | 6 => DVec3::new(xs[0], xs[1], xs[2]),
                    n => {
                        return Err(err(
                            &words.join(" "),
                            format!(
                            "a vertex needs `x y z` (optionally `w` or `r g b`), found {n} numbers"
                        ),
                        ))
                    }
                };
                if xs.len() == 4 {
                    if xs[3] == 0.0 {
                        return Err(err(words[3], "vertex weight w must not be zero".into()));
                    }
                    v /= xs[3];
                    if !v.is_finite() {
                        return Err(err(
                            &words.join(" "),
                            "vertex is not finite after dividing by w".into(),
                        ));
                    }
                }
                let k = p.positions.len();
                let _ = writeln!(p.normalised, "v {} {} 0", k % INDEX_SPLIT, k / INDEX_SPLIT);
                p.positions.push(v);
                continue;
            }
            "vt" => n_vt += 1,
            "vn" => n_vn += 1,
            "f" => {
                let words: Vec<&str> = numbers().collect();
                if words.len() < 3 {
                    return Err(err(
                        rest,
                        format!("a face needs at least 3 vertices, found {}", words.len()),
                    ));
                }
                if current_material.is_none() {
                    return Err(err(
                        rest,
                        "face has no material: put `usemtl NAME` before it".into(),
                    ));
                }
                p.has_faces = true;
                p.normalised.push('f');
                for w in words {
                    let parts: Vec<&str> = w.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(err(
                            w,
                            "face vertex must be `v`, `v/vt`, `v//vn` or `v/vt/vn`".into(),
                        ));
                    }
                    let counts = [p.positions.len(), n_vt, n_vn];
                    let what = ["vertex", "texture coordinate", "normal"];
                    let mut vertex = 0;
                    for (j, part) in parts.iter().enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let x: i64 = part
                            .parse()
                            .map_err(|_| err(w, format!("{} index is not an integer", what[j])))?;
                        let resolved = resolve_index(x, counts[j]).ok_or_else(|| {
                            err(
                                w,
                                if x == 0 {
                                    format!(
                                        "{} index 0 is invalid (OBJ indices start at 1)",
                                        what[j]
                                    )
                                } else {
                                    format!(
                                        "{} index out of range: {} defined before this line",
                                        what[j], counts[j]
                                    )
                                },
                            )
                        })?;
                        if j == 0 {
                            vertex = resolved;
                        }
                    }
                    let _ = write!(p.normalised, " {}", vertex + 1);
                }
                p.normalised.push('\n');
                continue;
            }
            "o" | "g" => {
                p.has_groups = true;
                let _ = writeln!(p.normalised, "g {rest}");
                continue;
            }
            "usemtl" => {
                if rest.is_empty() {
                    return Err(err(trimmed, "usemtl needs a material name".into()));
                }
                if !p.by_name.contains_key(rest) {
                    let message = if p.libs.is_empty() {
                        "material is not defined: no `mtllib` line before this one".to_string()
                    } else {
                        "material is not defined in the file's MTL libraries".to_string()
                    };
                    return Err(err(rest, message));
                }
                current_material = Some(rest.to_owned());
                let _ = writeln!(p.normalised, "usemtl {rest}");
                continue;
            }
            "mtllib" => {
                if rest.is_empty() {
                    return Err(err(trimmed, "mtllib needs a file name".into()));
                }
                let mut names = Vec::new();
                for file in mtllib_files(dir, rest).map_err(|missing| {
                    err(
                        rest,
                        format!("material library not found: {}", missing.display()),
                    )
                })? {
                    let mtl_text = files::read_text(&file)?;
                    for m in parse_mtl(&file, &mtl_text, &mut p.warnings)? {
                        names.push(m.name.clone());
                        if let Some(&k) = p.by_name.get(&m.name) {
                            p.warnings.push(format!(
                                "{}: material `{}` is defined more than once; the last definition is used",
                                file.display(),
                                m.name
                            ));
                            p.materials[k] = m;
                        } else {
                            p.by_name.insert(m.name.clone(), p.materials.len());
                            p.materials.push(m);
                        }
                    }
                }
                // tobj's material loader gets this library's position in `libs` as its "path".
                let _ = writeln!(p.normalised, "mtllib {}", p.libs.len());
                p.libs.push(names);
                continue;
            }
            // Comments, smoothing groups, lines, points, free-form geometry: nothing tobj
            // needs; dropping them keeps its parser away from anything unvalidated.
            _ => {}
        }
        p.normalised.push('\n');
    }
    Ok(p)
}

/// Resolves a 1-based (or negative, relative) OBJ index against `count` defined items to a
/// 0-based index; `None` for 0 or out of range.
fn resolve_index(x: i64, count: usize) -> Option<usize> {
    let count = i64::try_from(count).ok()?;
    let k = if x > 0 { x - 1 } else { count + x };
    (x != 0 && (0..count).contains(&k)).then_some(k as usize)
}

/// The files of one `mtllib` line, relative to the OBJ's folder. The whole rest of the line is
/// tried first (file names may contain spaces, as tobj assumes); otherwise it is read as a
/// whitespace-separated list (as the OBJ specification allows). `Err` names a missing file.
fn mtllib_files(dir: &Path, rest: &str) -> std::result::Result<Vec<PathBuf>, PathBuf> {
    let whole = dir.join(rest);
    if whole.is_file() {
        return Ok(vec![whole]);
    }
    let parts: Vec<PathBuf> = rest.split_whitespace().map(|f| dir.join(f)).collect();
    if parts.len() > 1 {
        if let Some(missing) = parts.iter().find(|f| !f.is_file()) {
            return Err(missing.clone());
        }
        return Ok(parts);
    }
    Err(whole)
}

/// MTL keys that are valid but play no part in the simulation (no warning).
fn known_unused(key: &str) -> bool {
    matches!(
        key,
        "ka" | "ks" | "ns" | "ni" | "d" | "tr" | "illum" | "bump" | "disp" | "decal" | "refl"
    ) || key.starts_with("map_")
}

/// Parses MTL text line by line; `path` names the file in errors and warnings.
fn parse_mtl(path: &Path, text: &str, warnings: &mut Vec<String>) -> Result<Vec<Material>> {
    // (material, whether it had a Kd line)
    let mut out: Vec<(Material, bool)> = Vec::new();
    let mut warned: HashSet<String> = HashSet::new();
    let mut warn_once = |key: &str, message: String, warnings: &mut Vec<String>| {
        if warned.insert(key.to_owned()) {
            warnings.push(message);
        }
    };
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let err =
            |value: &str, message: String| Error::input(path, Some(line_no), Some(value), message);
        let trimmed = raw.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let (key, rest) = match trimmed.split_once(char::is_whitespace) {
            Some((k, r)) => (k, r.trim()),
            None => (trimmed, ""),
        };
        // Keys are matched case-insensitively: a `kd` written by some exporter must not be
        // silently ignored and turn the surface black.
        let lower = key.to_ascii_lowercase();
        if lower == "newmtl" {
            if rest.is_empty() {
                return Err(err(trimmed, "newmtl needs a material name".into()));
            }
            out.push((
                Material {
                    name: rest.to_owned(),
                    kd: Rgb::ZERO,
                    tf: Rgb::ZERO,
                    ke: Rgb::ZERO,
                },
                false,
            ));
            continue;
        }
        let values = rest.split('#').next().unwrap_or("").trim();
        match lower.as_str() {
            "kd" | "tf" | "ke" => {
                let Some((current, has_kd)) = out.last_mut() else {
                    return Err(err(trimmed, format!("`{key}` before any `newmtl`")));
                };
                let (lo, hi, closed, what) = match lower.as_str() {
                    "kd" => (
                        0.0,
                        1.0,
                        false,
                        "Kd (diffuse reflectance) must be in [0, 1)",
                    ),
                    "tf" => (0.0, 1.0, true, "Tf (transmittance) must be in [0, 1]"),
                    _ => (
                        0.0,
                        f64::INFINITY,
                        false,
                        "Ke (emitted radiance) must be finite and ≥ 0",
                    ),
                };
                let rgb = parse_rgb(values, key).map_err(|(v, m)| err(&v, m))?;
                for (c, word) in rgb.to_array().iter().zip(values.split_whitespace().cycle()) {
                    let ok = c.is_finite() && *c >= lo && (*c < hi || (closed && *c <= hi));
                    if !ok {
                        return Err(err(word, what.to_string()));
                    }
                }
                match lower.as_str() {
                    "kd" => {
                        current.kd = rgb;
                        *has_kd = true;
                    }
                    "tf" => current.tf = rgb,
                    _ => current.ke = rgb,
                }
            }
            "d" | "tr" => {
                // Transparency through dissolve is a common exporter habit for glass; say
                // that it does not make glazing here.
                let x: f64 = values
                    .split_whitespace()
                    .next()
                    .and_then(|w| w.parse().ok())
                    .unwrap_or(if lower == "d" { 1.0 } else { 0.0 });
                let transparent = if lower == "d" { x < 1.0 } else { x > 0.0 };
                if transparent {
                    warn_once(
                        &lower,
                        format!(
                            "{}:{line_no}: `{key} {values}` ignored: glazing is given by `Tf r g b`",
                            path.display()
                        ),
                        warnings,
                    );
                }
            }
            k if known_unused(k) => {}
            _ => warn_once(
                key,
                format!(
                    "{}:{line_no}: unknown MTL key `{key}` ignored",
                    path.display()
                ),
                warnings,
            ),
        }
    }
    for (m, has_kd) in &out {
        if !has_kd && !m.is_glazing() {
            warnings.push(format!(
                "{}: material `{}` has no Kd; reflectance 0 assumed",
                path.display(),
                m.name
            ));
        }
    }
    Ok(out.into_iter().map(|(m, _)| m).collect())
}

/// Parses `r g b` or a single grey value; `Err((value, message))` otherwise.
fn parse_rgb(values: &str, key: &str) -> std::result::Result<Rgb, (String, String)> {
    let words: Vec<&str> = values.split_whitespace().collect();
    let mut xs = Vec::with_capacity(3);
    for w in &words {
        let x: f64 = w.parse().map_err(|_| {
            (
                (*w).to_owned(),
                format!("`{key}` value is not a number (only `{key} r g b` or `{key} grey` are supported)"),
            )
        })?;
        xs.push(x);
    }
    match xs[..] {
        [g] => Ok(Rgb::splat(g)),
        [r, g, b] => Ok(Rgb::new(r, g, b)),
        _ => Err((
            values.to_owned(),
            format!("`{key}` needs 1 or 3 numbers, found {}", xs.len()),
        )),
    }
}

/// Runs tobj on the normalised text and maps its output back to exact vertices.
fn build(path: &Path, pass: Prepass, y_up: bool) -> Result<ObjContents> {
    if !pass.has_faces {
        return Err(Error::input(path, None, None, "the OBJ file has no faces"));
    }
    // The update fills tobj's feature-gated fields (merging, reordering) should another
    // crate in the build enable those features.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let libs = &pass.libs;
    let loader = |lib: &Path| -> tobj::MTLLoadResult {
        let names = lib
            .to_str()
            .and_then(|s| s.parse::<usize>().ok())
            .and_then(|k| libs.get(k))
            .ok_or(tobj::LoadError::OpenFileFailed)?;
        let materials = names
            .iter()
            .map(|n| tobj::Material {
                name: n.clone(),
                ..Default::default()
            })
            .collect();
        let map = names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        Ok((materials, map))
    };
    let mut reader = std::io::Cursor::new(pass.normalised.as_bytes());
    let (models, tobj_materials) = tobj::load_obj_buf(&mut reader, &options, loader)
        .map_err(|e| Error::input(path, None, None, format!("OBJ parser: {e}")))?;
    let tobj_materials = tobj_materials
        .map_err(|e| Error::Internal(format!("{}: tobj material merge: {e}", path.display())))?;

    let mut materials: Vec<Material> = Vec::new();
    let mut material_index: HashMap<usize, u32> = HashMap::new();
    let mut groups: Vec<String> = Vec::new();
    let mut group_index: HashMap<String, u32> = HashMap::new();
    let mut triangles = Vec::new();
    for model in &models {
        let mesh = &model.mesh;
        if mesh.indices.is_empty() {
            continue;
        }
        // Validated in the pre-pass: every face has a defined material.
        let internal = |what: &str| {
            Error::Internal(format!(
                "{}: {what} in model `{}`",
                path.display(),
                model.name
            ))
        };
        let ours = mesh
            .material_id
            .and_then(|id| tobj_materials.get(id))
            .and_then(|m| pass.by_name.get(&m.name))
            .copied()
            .ok_or_else(|| internal("face without a known material"))?;
        let material = match material_index.get(&ours) {
            Some(&k) => k,
            None => {
                let k =
                    u32::try_from(materials.len()).map_err(|_| internal("too many materials"))?;
                materials.push(pass.materials[ours].clone());
                material_index.insert(ours, k);
                k
            }
        };
        let group_name = if pass.has_groups {
            model.name.clone()
        } else {
            pass.materials[ours].name.clone()
        };
        let group = match group_index.get(&group_name) {
            Some(&k) => k,
            None => {
                let k = u32::try_from(groups.len()).map_err(|_| internal("too many groups"))?;
                groups.push(group_name.clone());
                group_index.insert(group_name, k);
                k
            }
        };
        let vertex = |i: u32| -> Result<DVec3> {
            let i = i as usize;
            let (lo, hi) = (
                mesh.positions.get(3 * i).copied(),
                mesh.positions.get(3 * i + 1).copied(),
            );
            let k = match (lo, hi) {
                (Some(lo), Some(hi)) => lo as usize + (hi as usize) * INDEX_SPLIT,
                _ => return Err(internal("vertex index out of range")),
            };
            let v = *pass
                .positions
                .get(k)
                .ok_or_else(|| internal("vertex index out of range"))?;
            Ok(if y_up { y_up_to_z_up(v) } else { v })
        };
        for tri in mesh.indices.chunks_exact(3) {
            triangles.push(Triangle {
                v: [vertex(tri[0])?, vertex(tri[1])?, vertex(tri[2])?],
                material,
                group,
            });
        }
    }
    Ok((triangles, materials, groups, pass.warnings))
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn tf_one_and_kd_just_below_one_are_accepted() {
        let mut w = Vec::new();
        let m = parse_mtl(Path::new("m.mtl"), "newmtl g\nTf 1 1 1\nKd 0.999\n", &mut w).unwrap();
        assert_eq!(m[0].tf, Rgb::ONE);
        assert!(w.is_empty());
    }

    #[test]
    fn unknown_mtl_key_warns_once_per_file() {
        let mut w = Vec::new();
        let text =
            "newmtl a\nKd 0.5\nPr 0.3\nmap_Kd x.png\nPr 0.2\nnewmtl b\nKd 0.1\nPr 0.1\nsheen 1\n";
        parse_mtl(Path::new("m.mtl"), text, &mut w).unwrap();
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].contains("m.mtl:3") && w[0].contains("`Pr`"), "{w:?}");
        assert!(w[1].contains("`sheen`"));
        // A second file warns again.
        parse_mtl(Path::new("n.mtl"), text, &mut w).unwrap();
        assert_eq!(w.len(), 4);
    }

    #[test]
    fn dissolve_and_missing_kd_warn() {
        let mut w = Vec::new();
        let m = parse_mtl(
            Path::new("m.mtl"),
            "newmtl a\nd 0.3\nnewmtl b\nd 0.5\nKd 0.2\n",
            &mut w,
        )
        .unwrap();
        assert_eq!(m[0].kd, Rgb::ZERO);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w.iter().any(|s| s.contains("Tf")) && w.iter().any(|s| s.contains("no Kd")));
    }

    #[test]
    fn file_without_faces_is_an_error() {
        let e = load_text("mtllib m.mtl\nv 0 0 0\n", false).unwrap_err();
        assert!(e.to_string().contains("no faces"), "{e}");
    }
}
