//! Wavefront MTL material libraries, read line by line into [`Material`]s for the OBJ
//! loader ([`super::obj`]): `Kd`, `Tf` and `Ke` with their ranges checked and errors naming
//! file, line and value; keys matched case-insensitively; dissolve (`d`, `Tr`) and unknown
//! keys warned about once per file; keys that play no part in the simulation ignored.

use super::Material;
use crate::error::{Error, Result};
use crate::photometry::Rgb;
use std::collections::HashSet;
use std::path::Path;

/// MTL keys that are valid but play no part in the simulation (no warning).
fn known_unused(key: &str) -> bool {
    matches!(
        key,
        "ka" | "ks" | "ns" | "ni" | "d" | "tr" | "illum" | "bump" | "disp" | "decal" | "refl"
    ) || key.starts_with("map_")
}

/// Parses MTL text line by line; `path` names the file in errors and warnings.
pub(super) fn parse_mtl(
    path: &Path,
    text: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<Material>> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
