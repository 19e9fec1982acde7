//! Aperture groups named in `scene.toml` for OBJ and Radiance models
//! (`[aperture_groups.NAME]`: `materials`, optional `shade_transmittance`): which glazing
//! belongs to which operable group. HBJSON models bring their own dynamic groups.

use super::imported::ApertureGroup;
use super::{Material, Triangle};
use crate::error::{Error, Result};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use toml::Spanned;

/// One `[aperture_groups.NAME]` table as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct GroupToml {
    /// Glazing materials (MTL) or modifiers (`.rad`) of the group.
    materials: Vec<String>,
    /// The shaded state's diffuse visible transmittance, 0–1.
    shade_transmittance: Option<f64>,
}

/// The groups as written, by name, with the line of each table.
pub(super) type GroupsToml = BTreeMap<String, Spanned<GroupToml>>;

/// Checks the groups against the model's materials and lists each group's members (the
/// groups of [`super::Scene::groups`] whose triangles use its materials, in order of first
/// use), in name order.
///
/// # Errors
/// [`Error::Input`] naming the scene file, the table's line and the value: a group with
/// no materials, a material the model does not have or that is not glazing, a material in
/// two groups, a shade transmittance outside [0, 1].
pub(super) fn resolve(
    path: &Path,
    line: &dyn Fn(std::ops::Range<usize>) -> Option<usize>,
    groups: &GroupsToml,
    materials: &[Material],
    triangles: &[Triangle],
    group_names: &[String],
) -> Result<Vec<ApertureGroup>> {
    let mut owner: BTreeMap<&str, &str> = BTreeMap::new();
    let mut out = Vec::new();
    for (name, table) in groups {
        let at = line(table.span());
        let bad = |value: &str, message: String| Error::input(path, at, Some(value), message);
        let g = table.get_ref();
        if g.materials.is_empty() {
            return Err(bad(
                name,
                format!("aperture group `{name}` names no materials"),
            ));
        }
        if let Some(t) = g.shade_transmittance.filter(|t| !(0.0..=1.0).contains(t)) {
            return Err(bad(
                &t.to_string(),
                format!("aperture group `{name}`: shade_transmittance must be in [0, 1]"),
            ));
        }
        let mut ids = Vec::new();
        for m in &g.materials {
            let Some(k) = materials.iter().position(|x| &x.name == m) else {
                let glazing: Vec<&str> = materials
                    .iter()
                    .filter(|x| x.is_glazing())
                    .map(|x| x.name.as_str())
                    .collect();
                return Err(bad(
                    m,
                    format!(
                        "aperture group `{name}`: the model has no material `{m}`; its \
                         glazing materials are: {}",
                        glazing.join(", ")
                    ),
                ));
            };
            if !materials[k].is_glazing() {
                return Err(bad(
                    m,
                    format!("aperture group `{name}`: material `{m}` is not glazing"),
                ));
            }
            if let Some(other) = owner.insert(m, name) {
                return Err(bad(
                    m,
                    format!("material `{m}` is in aperture groups `{other}` and `{name}`"),
                ));
            }
            ids.push(k as u32);
        }
        let mut members: Vec<String> = Vec::new();
        for t in triangles.iter().filter(|t| ids.contains(&t.material)) {
            let member = &group_names[t.group as usize];
            if !members.contains(member) {
                members.push(member.clone());
            }
        }
        out.push(ApertureGroup {
            identifier: name.clone(),
            members,
            states: vec!["default".into(), "shade".into()],
            shade_transmittance: g.shade_transmittance,
            materials: g.materials.clone(),
        });
    }
    Ok(out)
}
