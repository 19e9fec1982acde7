//! Light paths of operable aperture groups, as honeybee-radiance simulates them for LEED's
//! blinds: one path per aperture group, in which all other glazing (every other group's
//! and the static glazing) is black and opaque, and one for the static apertures (glazing
//! in no group), in which every group's glazing is black. Each path is its own scene
//! variant with its own cache records, evaluated over the run's steps beside the run
//! (`sequence::path_pass`). Each piece of glazing is open in exactly one path, so the sum
//! of the paths is the scene with every group open, less the light that crosses the
//! glazing of two different paths (honeybee's simplification too: docs/metrics.md).

use crate::export::grids::is_safe_identifier;
use crate::metrics::leed::DEFAULT_SHADE_TRANSMITTANCE;
use crate::photometry::Rgb;
use crate::scene::{Material, Scene};

/// Name of the static apertures' path, as honeybee names its folder.
pub const STATIC_PATH: &str = "__static_apertures__";

/// Name of the material a path gives the glazing it leaves out.
const BLACK: &str = "__daystep_closed_aperture__";

/// For each triangle, the index (into `scene.imported.aperture_groups`) of the aperture
/// group its glazing belongs to; `None` for opaque triangles and static glazing.
pub fn triangle_groups(scene: &Scene) -> Vec<Option<u32>> {
    let groups = &scene.imported.aperture_groups;
    scene
        .triangles
        .iter()
        .map(|t| {
            let m = &scene.materials[t.material as usize];
            if !m.is_glazing() {
                return None;
            }
            let member = scene.groups.get(t.group as usize)?;
            groups
                .iter()
                .position(|g| {
                    g.members.iter().any(|x| x == member)
                        && (g.materials.is_empty() || g.materials.contains(&m.name))
                })
                .map(|k| k as u32)
        })
        .collect()
}

/// The scene of one light path: all glazing but that of aperture group `keep` made black
/// and opaque (`None`: the static path, which keeps the glazing of no group and blacks
/// every group's). Everything else, the sensors and the grids included, is unchanged.
/// `None` when no glazing changes: the path is the scene itself (one group holding all
/// the glazing, or no group at all), and its run is the run's own.
pub fn path_scene(scene: &Scene, of: &[Option<u32>], keep: Option<u32>) -> Option<Scene> {
    let glazing = |t: &crate::scene::Triangle| scene.materials[t.material as usize].is_glazing();
    let closed: Vec<bool> = scene
        .triangles
        .iter()
        .zip(of)
        .map(|(t, g)| glazing(t) && *g != keep)
        .collect();
    if !closed.contains(&true) {
        return None;
    }
    let mut s = scene.clone();
    let black = s.materials.len() as u32;
    s.materials.push(Material {
        name: BLACK.into(),
        kd: Rgb::ZERO,
        tf: Rgb::ZERO,
        ke: Rgb::ZERO,
    });
    for (t, &c) in s.triangles.iter_mut().zip(&closed) {
        if c {
            t.material = black;
        }
    }
    Some(s)
}

/// One light path of a run with aperture groups.
pub struct PathVariant {
    /// The path's name: [`STATIC_PATH`] or the group's identifier.
    pub name: String,
    /// The group's shade transmittance (`None` for the static path).
    pub shade: Option<f64>,
    /// The path's scene; `None` when it is the scene itself (its values are the run's).
    pub scene: Option<Scene>,
    /// Its folder under the run's `paths/`: the name when that is a safe file name, else
    /// `group<k>`.
    pub folder: String,
}

/// The light paths of `scene`, static first, then one per aperture group in order; empty
/// without aperture groups.
pub fn variants(scene: &Scene) -> Vec<PathVariant> {
    let groups = &scene.imported.aperture_groups;
    if groups.is_empty() {
        return Vec::new();
    }
    let of = triangle_groups(scene);
    (0..=groups.len())
        .map(|k| {
            let (name, keep, shade) = if k == 0 {
                (STATIC_PATH.to_string(), None, None)
            } else {
                let g = &groups[k - 1];
                let t = g.shade_transmittance.unwrap_or(DEFAULT_SHADE_TRANSMITTANCE);
                (g.identifier.clone(), Some(k as u32 - 1), Some(t))
            };
            let folder = if is_safe_identifier(&name) {
                name.clone()
            } else {
                format!("group{k}")
            };
            PathVariant {
                scene: path_scene(scene, &of, keep),
                name,
                shade,
                folder,
            }
        })
        .collect()
}
