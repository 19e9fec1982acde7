//! `scene.toml` (serde): geometry and sensor paths, up axis, north rotation, ground
//! reflectance and site (docs/commands.md, "Inputs").
//!
//! Unknown keys are not errors but warnings, so files written for a newer daystep still load.
//! Values are read as [`toml::Spanned`] so that range errors name their line.

use super::{hbjson, obj, rad, sensors, Faces, ModelInput, Scene};
use crate::error::{Error, Result};
use crate::files;
use crate::site::Site;
use serde::Deserialize;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Text of the warning given when the scene file has no `[site]` table and
/// [`Site::default`] stands in (a weather file may give the site later).
pub const NO_SITE_WARNING: &str =
    "no [site] table: using the default site (Greenwich, UTC) unless a weather file gives one";

/// Ground reflectance when the scene file gives none (Radiance's and honeybee's 0.2).
pub const DEFAULT_GROUND_REFLECTANCE: f64 = 0.2;

/// Top-level keys of a scene file.
const KNOWN_KEYS: [&str; 8] = [
    "aperture_groups",
    "geometry",
    "faces",
    "sensors",
    "up",
    "north_deg",
    "ground_reflectance",
    "site",
];
/// Keys of the `[site]` table.
const KNOWN_SITE_KEYS: [&str; 4] = ["latitude", "longitude", "utc_offset_h", "elevation_m"];

/// The scene file as written; unknown keys are ignored by serde (and reported separately).
#[derive(Deserialize)]
struct SceneToml {
    /// One file, or a list of Radiance files read in order as one scene.
    geometry: Option<Spanned<toml::Value>>,
    sensors: Option<Spanned<String>>,
    up: Option<Spanned<String>>,
    north_deg: Option<Spanned<f64>>,
    ground_reflectance: Option<Spanned<f64>>,
    faces: Option<Spanned<String>>,
    site: Option<SiteToml>,
    aperture_groups: Option<super::aperture_groups::GroupsToml>,
}

/// The `[site]` table as written.
#[derive(Deserialize)]
struct SiteToml {
    latitude: Spanned<f64>,
    longitude: Spanned<f64>,
    utc_offset_h: Spanned<f64>,
    elevation_m: Option<Spanned<f64>>,
}

/// Loads a scene file and everything it references (docs/commands.md, "Inputs").
///
/// Paths in the file are relative to the scene file's folder. Warnings (unknown keys, a
/// missing `[site]`, unknown MTL keys, …) end up in [`Scene::warnings`], each once.
///
/// # Errors
/// [`Error::Input`] naming file, line and value: TOML syntax, a missing `geometry`, a
/// referenced file that does not exist, a value out of range (latitude outside [−90, 90],
/// longitude outside [−180, 180], `utc_offset_h` outside [−14, 14], `elevation_m` outside
/// [−1000, 10000] (the EPW header's range), `ground_reflectance` outside [0, 1), anything
/// non-finite (TOML spells `nan` and `inf`), `up` not "z" or "y", a `geometry` list that
/// is empty or holds anything but Radiance files), and every error of [`obj::load`],
/// [`hbjson::load`], [`rad::load`] and [`sensors::load`]. [`Error::Io`] when a file cannot be read.
pub fn load(path: &Path) -> Result<Scene> {
    let parsed = if is_hbjson(path) {
        model_alone(path)
    } else if rad::is_rad(path) {
        return Err(Error::input(
            path,
            None,
            None,
            "a Radiance file cannot be the scene on its own: write a scene.toml with              `geometry = [\"materials.mat\", \"scene.rad\"]` (in oconv's order) and a [site]",
        ));
    } else {
        let text = files::read_text(path)?;
        parse(path, &text)?
    };
    let mut geometry = read_geometry(&parsed.geometry, parsed.y_up)?;
    if let Some((groups, text)) = &parsed.aperture_groups {
        if !geometry.imported.aperture_groups.is_empty() {
            return Err(Error::input(
                path,
                None,
                Some("aperture_groups"),
                "the model brings its own aperture groups (HBJSON dynamic groups); remove \
                 [aperture_groups] from the scene file",
            ));
        }
        let line = |span: Range<usize>| Some(line_of(text, span.start));
        geometry.imported.aperture_groups = super::aperture_groups::resolve(
            path,
            &line,
            groups,
            &geometry.materials,
            &geometry.triangles,
            &geometry.groups,
        )?;
    }
    let sensors = match &parsed.sensors {
        Some(p) => {
            // The .pts file replaces the model's grids as the sensors.
            geometry.imported.sensor_grid.clear();
            sensors::load(p, parsed.y_up)?
        }
        None => geometry.sensors,
    };
    let input = ModelInput {
        triangles: geometry.triangles,
        materials: geometry.materials,
        groups: geometry.groups,
        sensors,
        north_deg: parsed.north_deg,
        site: parsed.site,
        ground_reflectance: parsed.ground_reflectance,
        faces: parsed.faces,
        imported: geometry.imported,
    };
    let mut scene = Scene::from_model(path, input)?;
    scene.y_up = parsed.y_up;
    let mut warnings = parsed.warnings;
    warnings.extend(geometry.warnings);
    // Each remark once, in order of appearance.
    let mut seen = std::collections::HashSet::new();
    warnings.retain(|w| seen.insert(w.clone()));
    scene.warnings.extend(warnings);
    Ok(scene)
}

/// True when `path` names a Honeybee model (`.hbjson`, or `.json` as honeybee also writes).
pub fn is_hbjson(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("hbjson") || e.eq_ignore_ascii_case("json"))
}

/// What a geometry file gives, whatever its format.
struct Geometry {
    triangles: Vec<super::Triangle>,
    materials: Vec<super::Material>,
    groups: Vec<String>,
    /// The model's own sensors (HBJSON grids), model frame.
    sensors: Vec<(glam::DVec3, glam::DVec3)>,
    imported: super::imported::Imported,
    warnings: Vec<String>,
}

/// Reads the geometry files by their extension: Radiance (`.rad`, `.mat`, all read as one
/// scene), HBJSON, else OBJ (the parser allows a list of Radiance files only).
fn read_geometry(paths: &[PathBuf], y_up: bool) -> Result<Geometry> {
    if paths.iter().all(|p| rad::is_rad(p)) {
        let r = rad::load(paths)?;
        return Ok(Geometry {
            triangles: r.triangles,
            materials: r.materials,
            groups: r.groups,
            sensors: Vec::new(),
            imported: Default::default(),
            warnings: r.warnings,
        });
    }
    let path = &paths[0];
    if is_hbjson(path) {
        let h = hbjson::load(path)?;
        return Ok(Geometry {
            triangles: h.triangles,
            materials: h.materials,
            groups: h.groups,
            sensors: h.sensors,
            imported: h.imported,
            warnings: h.warnings,
        });
    }
    let (triangles, materials, groups, warnings) = obj::load(path, y_up)?;
    Ok(Geometry {
        triangles,
        materials,
        groups,
        sensors: Vec::new(),
        imported: Default::default(),
        warnings,
    })
}

/// The scene of a model given alone: its own geometry and sensor grids, the defaults of
/// `scene.toml` for everything else, and no site (a weather file or `--site` gives it).
fn model_alone(path: &Path) -> Parsed {
    Parsed {
        geometry: vec![path.to_path_buf()],
        sensors: None,
        y_up: false,
        north_deg: 0.0,
        ground_reflectance: DEFAULT_GROUND_REFLECTANCE,
        faces: Faces::Both,
        site: Site::default(),
        warnings: vec![format!("{}: {NO_SITE_WARNING}", path.display())],
        aperture_groups: None,
    }
}

/// A validated scene file, paths resolved.
#[derive(Debug)]
struct Parsed {
    /// One file, or Radiance files in the order given.
    geometry: Vec<PathBuf>,
    sensors: Option<PathBuf>,
    y_up: bool,
    north_deg: f64,
    ground_reflectance: f64,
    faces: Faces,
    site: Site,
    warnings: Vec<String>,
    /// `[aperture_groups.*]` as written, and the scene file's text for their lines.
    aperture_groups: Option<(super::aperture_groups::GroupsToml, String)>,
}

/// The file names `geometry` gives: one string, or a non-empty list of strings that are all
/// Radiance files (`.rad`, `.mat`, read in order as one scene, as oconv takes them).
fn geometry_files(
    path: &Path,
    g: &Spanned<toml::Value>,
    at: &dyn Fn(Range<usize>) -> Option<usize>,
) -> Result<Vec<Spanned<String>>> {
    let err = |value: &str, message: &str| {
        Error::input(
            path,
            at(g.span()),
            Some(value),
            format!("`geometry`: {message}"),
        )
    };
    let one = |v: &toml::Value| {
        v.as_str()
            .map(|s| Spanned::new(g.span(), s.to_string()))
            .ok_or_else(|| err(&v.to_string(), "expected a file name (a string)"))
    };
    match g.get_ref() {
        toml::Value::Array(list) => {
            let files = list.iter().map(one).collect::<Result<Vec<_>>>()?;
            if files.is_empty() {
                return Err(err("[]", "the list is empty"));
            }
            if files.len() > 1 {
                if let Some(f) = files.iter().find(|f| !rad::is_rad(Path::new(f.get_ref()))) {
                    return Err(err(
                        f.get_ref(),
                        "a list may only hold Radiance files (.rad, .mat), read in order as \
                         one scene; an OBJ or HBJSON model is given alone, and formats cannot \
                         be mixed (a .sky file is not needed: daystep makes its own sky)",
                    ));
                }
            }
            Ok(files)
        }
        v => Ok(vec![one(v)?]),
    }
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Parses and validates scene-file text; `path` names it in errors and anchors relative
/// paths. Referenced files must exist but are not read.
fn parse(path: &Path, text: &str) -> Result<Parsed> {
    let raw: SceneToml = toml::from_str(text).map_err(|e| {
        let span = e.span();
        let line = span.clone().map(|s| line_of(text, s.start));
        // Quote the offending text when it is short and on one line, else the whole line.
        let value = span.and_then(|s| {
            let short = text
                .get(s.clone())
                .map(str::trim)
                .filter(|v| !v.is_empty() && v.len() <= 80 && !v.contains('\n'));
            short.or_else(|| {
                text.lines()
                    .nth(line_of(text, s.start) - 1)
                    .map(str::trim)
                    .filter(|v| !v.is_empty())
            })
        });
        Error::input(
            path,
            line,
            value,
            format!("invalid scene file: {}", e.message().trim()),
        )
    })?;
    let at = |span: Range<usize>| Some(line_of(text, span.start));
    let mut warnings = unknown_keys(path, text);

    let dir = path.parent().unwrap_or(Path::new(""));
    let file = |key: &str, value: &Spanned<String>| -> Result<PathBuf> {
        let resolved = dir.join(value.get_ref());
        if resolved.is_file() {
            Ok(resolved)
        } else {
            Err(Error::input(
                path,
                at(value.span()),
                Some(value.get_ref()),
                format!("{key} file not found: {}", resolved.display()),
            ))
        }
    };
    let geometry =
        match &raw.geometry {
            Some(g) => geometry_files(path, g, &at)?
                .iter()
                .map(|f| file("geometry", f))
                .collect::<Result<Vec<_>>>()?,
            None => return Err(Error::input(
                path,
                None,
                None,
                "missing required key `geometry` (the OBJ or HBJSON file, or a list of Radiance \
             files, relative to the scene file)",
            )),
        };
    let sensors = raw
        .sensors
        .as_ref()
        .map(|s| file("sensors", s))
        .transpose()?;

    let y_up = match &raw.up {
        None => false,
        Some(u) => match u.get_ref().to_ascii_lowercase().as_str() {
            "z" => false,
            "y" => true,
            _ => {
                return Err(Error::input(
                    path,
                    at(u.span()),
                    Some(u.get_ref()),
                    "`up` must be \"z\" or \"y\"",
                ))
            }
        },
    };

    if let Some(u) = raw.up.as_ref().filter(|_| y_up && is_hbjson(&geometry[0])) {
        return Err(Error::input(
            path,
            at(u.span()),
            Some(u.get_ref()),
            "`up` does not apply to a Honeybee model (HBJSON is always Z-up): remove it",
        ));
    }
    if let Some(u) = raw
        .up
        .as_ref()
        .filter(|_| y_up && rad::is_rad(&geometry[0]))
    {
        return Err(Error::input(
            path,
            at(u.span()),
            Some(u.get_ref()),
            "`up` does not apply to Radiance files (Z-up, as gensky's sky): remove it",
        ));
    }

    let faces = match &raw.faces {
        None => Faces::Both,
        Some(f) => match f.get_ref().to_ascii_lowercase().as_str() {
            "both" => Faces::Both,
            "front" => Faces::Front,
            _ => {
                return Err(Error::input(
                    path,
                    at(f.span()),
                    Some(f.get_ref()),
                    "`faces` must be \"both\" (opaque surfaces reflect on both faces, as \
                     Radiance) or \"front\" (only the face the OBJ normal points to)",
                ))
            }
        },
    };

    // A number with its allowed range (`None`: any finite value) and unit.
    let check =
        |key: &str, v: &Spanned<f64>, range: Option<(f64, f64, bool)>, unit: &str| -> Result<f64> {
            let x = *v.get_ref();
            let ok = x.is_finite()
                && range.is_none_or(|(lo, hi, closed)| x >= lo && (x < hi || (closed && x <= hi)));
            if ok {
                return Ok(x);
            }
            let message = match range {
                Some((lo, hi, true)) => format!("`{key}` must be in [{lo}, {hi}]{unit}"),
                Some((lo, hi, false)) => format!("`{key}` must be in [{lo}, {hi}){unit}"),
                None => format!("`{key}` must be a finite number{unit}"),
            };
            Err(Error::input(
                path,
                at(v.span()),
                Some(&x.to_string()),
                message,
            ))
        };
    let north_deg = raw
        .north_deg
        .as_ref()
        .map(|v| check("north_deg", v, None, " (degrees)"))
        .transpose()?
        .unwrap_or(0.0);
    let ground_reflectance = raw
        .ground_reflectance
        .as_ref()
        .map(|v| check("ground_reflectance", v, Some((0.0, 1.0, false)), ""))
        .transpose()?
        .unwrap_or(DEFAULT_GROUND_REFLECTANCE);
    let site = match &raw.site {
        Some(s) => Site {
            latitude: check(
                "site.latitude",
                &s.latitude,
                Some((-90.0, 90.0, true)),
                " degrees north",
            )?,
            longitude: check(
                "site.longitude",
                &s.longitude,
                Some((-180.0, 180.0, true)),
                " degrees east",
            )?,
            utc_offset_h: check(
                "site.utc_offset_h",
                &s.utc_offset_h,
                Some((-14.0, 14.0, true)),
                " hours east of UTC",
            )?,
            // The EPW header's range: from the Dead Sea shore to above Everest.
            elevation_m: s
                .elevation_m
                .as_ref()
                .map(|v| check("site.elevation_m", v, Some((-1000.0, 10000.0, true)), " m"))
                .transpose()?
                .unwrap_or(0.0),
        },
        None => {
            warnings.push(format!("{}: {NO_SITE_WARNING}", path.display()));
            Site::default()
        }
    };
    Ok(Parsed {
        geometry,
        sensors,
        y_up,
        north_deg,
        ground_reflectance,
        faces,
        site,
        warnings,
        aperture_groups: raw.aperture_groups.map(|g| (g, text.to_string())),
    })
}

/// Warnings for keys this version does not know (top level and in `[site]`), with the line
/// where the key is first written when it can be found.
fn unknown_keys(path: &Path, text: &str) -> Vec<String> {
    // The text already parsed as the struct, so it parses as a table too.
    let Ok(table) = text.parse::<toml::Table>() else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut report = |key: String, last: &str| {
        let line = text
            .lines()
            .position(|l| {
                l.trim_start()
                    .strip_prefix(last)
                    .is_some_and(|r| r.trim_start().starts_with('=') || r.starts_with(['.', ']']))
            })
            .map(|i| format!(":{}", i + 1))
            .unwrap_or_default();
        out.push(format!(
            "{}{line}: unknown key `{key}` ignored",
            path.display()
        ));
    };
    for (k, v) in &table {
        if !KNOWN_KEYS.contains(&k.as_str()) {
            report(k.clone(), k);
        } else if k == "site" {
            if let Some(site) = v.as_table() {
                for sk in site.keys() {
                    if !KNOWN_SITE_KEYS.contains(&sk.as_str()) {
                        report(format!("site.{sk}"), sk);
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
#[path = "scene_file_tests.rs"]
mod tests;
