//! Wavefront OBJ/MTL geometry.
//!
//! tobj does the loading proper (objects and groups, splits per material, fan triangulation).
//! Because tobj's errors carry no line numbers and its default build stores coordinates as
//! `f32` (centimetre steps at georeferenced coordinates of a few hundred kilometres), a
//! line-aware pass runs first: it validates every line it relies on, reads the vertex
//! coordinates in `f64`, parses the MTL files itself (with the private sibling module
//! `mtl`), and hands tobj a normalised copy of the file in which each vertex carries its own
//! index instead of its coordinates. tobj's output then maps straight back to the exact
//! `f64` vertices.

use super::mtl::parse_mtl;
use super::{y_up_to_z_up, Material, Triangle};
use crate::error::{Error, Result};
use crate::files;
use glam::DVec3;
use std::collections::HashMap;
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
#[path = "obj_tests.rs"]
mod tests;
