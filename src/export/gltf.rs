//! The solution mesh as glTF 2.0 binary (`.glb`), with one frame per timestep (issue 16),
//! written with the `gltf-json` types and the `gltf` crate's GLB container.
//!
//! Layout (what `daystep view` reads):
//! - one node and one mesh, one primitive per material; glTF's Y-up frame, metres:
//!   (x, y, z)_glTF = (east, up, −north) of the scene frame, the vertices relative to the
//!   scene's origin and the node's translation the origin (also in
//!   `asset.extras.daystep.origin`, in full precision);
//! - vertices are the mesh elements' corners welded on each plane of each material, each
//!   carrying the area-weighted mean of the elements around it (so flat surfaces shade
//!   smoothly and share their vertices); a triangle with another element's vertex on one of
//!   its edges (a T-junction) is split into a fan around its centroid through that vertex
//!   (`tjunction`), so no edge leaves a crack where neighbours meet;
//! - attributes `POSITION`, `NORMAL`, `COLOR_0` (linear radiance ÷ `radiance_scale`, in
//!   [0, 1]), `_ILLUMINANCE` (lux) and `_LUMINANCE` (cd/m²) of frame 0;
//! - `asset.extras.daystep`: `version`, `radiance_scale` (W·sr⁻¹·m⁻² per COLOR_0 unit),
//!   `frames` (label, `sun_altitude_deg` when the label is a local time and the site is
//!   known, and per primitive the accessors of COLOR_0, _ILLUMINANCE and _LUMINANCE),
//!   `sensors` (positions and per-frame lux accessors, or null);
//! - materials: base colour = Kd; glazing is blended with alpha 0.3.

use crate::error::{Error, Result};
use crate::photometry::{grey, lux, Rgb, EFFICACY_LM_PER_W};
use crate::site::Site;
use glam::DVec3;
use gltf::json;
use json::validation::{Checked, USize64};
use std::collections::HashMap;
use std::path::Path;

/// One material of the mesh.
#[derive(Clone, Debug)]
pub struct GltfMaterial {
    /// Name.
    pub name: String,
    /// Diffuse reflectance (base colour).
    pub kd: Rgb,
    /// Glazing (drawn semi-transparent).
    pub glazing: bool,
}

/// The geometry of the solution mesh, built once per run ([`SolutionGeometry::new`]).
#[derive(Clone, Debug)]
pub struct SolutionGeometry {
    /// Per primitive: material index and triangle indices into its own vertices.
    primitives: Vec<Primitive>,
    materials: Vec<GltfMaterial>,
    origin: DVec3,
    /// The site, so each frame whose label is a local time gets the sun's altitude.
    site: Option<Site>,
}

#[derive(Clone, Debug)]
struct Primitive {
    material: usize,
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    indices: Vec<u32>,
    /// Per vertex: (row, area weight) pairs it averages.
    weights: Vec<Vec<(u32, f64)>>,
}

/// One timestep's values per mesh row.
#[derive(Clone, Debug)]
pub struct GltfFrame {
    /// Label (local time).
    pub label: String,
    /// Radiance leaving each row, RGB W·sr⁻¹·m⁻².
    pub radiance: Vec<Rgb>,
    /// Irradiance received by each row, RGB W/m².
    pub irradiance: Vec<Rgb>,
    /// Illuminance at each sensor, lux (empty: none).
    pub sensor_lux: Vec<f64>,
}

/// glTF's Y-up frame from the scene's z-up one.
fn to_gltf(p: DVec3) -> [f32; 3] {
    [p.x as f32, p.z as f32, -p.y as f32]
}

impl SolutionGeometry {
    /// The mesh of rows: per row its three corners (scene frame, m), its unit normal, its
    /// area (m²) and its material; `materials` as indexed; `origin` the scene's.
    pub fn new(
        rows: &[([DVec3; 3], DVec3, f64, u32)],
        materials: Vec<GltfMaterial>,
        origin: DVec3,
    ) -> SolutionGeometry {
        let mut prims: Vec<Primitive> = Vec::new();
        let mut prim_of: HashMap<usize, usize> = HashMap::new();
        let mut welded: HashMap<(usize, [i64; 4], [i64; 3]), u32> = HashMap::new();
        // Per primitive, each vertex's plane (ids in order of first appearance).
        let mut planes: Vec<Vec<u32>> = Vec::new();
        let mut plane_id: HashMap<[i64; 4], u32> = HashMap::new();
        let q = |x: f64, s: f64| (x * s).round() as i64;
        for (r, (v, n, area, m)) in rows.iter().enumerate() {
            let m = *m as usize;
            let pi = *prim_of.entry(m).or_insert_with(|| {
                prims.push(Primitive {
                    material: m,
                    positions: Vec::new(),
                    normals: Vec::new(),
                    indices: Vec::new(),
                    weights: Vec::new(),
                });
                planes.push(Vec::new());
                prims.len() - 1
            });
            // Vertices are shared within one plane of one material only, so edges between
            // planes stay sharp.
            let plane = [q(n.x, 1e4), q(n.y, 1e4), q(n.z, 1e4), q(n.dot(v[0]), 1e3)];
            let next_id = plane_id.len() as u32;
            let id = *plane_id.entry(plane).or_insert(next_id);
            for corner in v {
                let key = (
                    pi,
                    plane,
                    [q(corner.x, 1e5), q(corner.y, 1e5), q(corner.z, 1e5)],
                );
                let p = &mut prims[pi];
                let idx = *welded.entry(key).or_insert_with(|| {
                    planes[pi].push(id);
                    p.positions.push(to_gltf(*corner));
                    p.normals.push(to_gltf(*n));
                    p.weights.push(Vec::new());
                    (p.positions.len() - 1) as u32
                });
                p.weights[idx as usize].push((r as u32, *area));
                p.indices.push(idx);
            }
        }
        for (p, plane) in prims.iter_mut().zip(&planes) {
            let (indices, centroids) =
                super::tjunction::split_t_junctions(&p.positions, plane, &p.indices);
            for corners in centroids {
                let mut at = [0.0f32; 3];
                let mut weights = Vec::new();
                for &c in &corners {
                    for (x, v) in at.iter_mut().zip(p.positions[c as usize]) {
                        *x += v / 3.0;
                    }
                    // Each corner's weights scaled to sum 1/3, so the new vertex carries
                    // the mean of the corners' values: what the triangle showed there.
                    let sum: f64 = p.weights[c as usize].iter().map(|w| w.1).sum();
                    if sum > 0.0 {
                        let own = p.weights[c as usize].iter();
                        weights.extend(own.map(|&(r, w)| (r, w / sum / 3.0)));
                    }
                }
                p.normals.push(p.normals[corners[0] as usize]);
                p.positions.push(at);
                p.weights.push(weights);
            }
            p.indices = indices;
        }
        SolutionGeometry {
            primitives: prims,
            materials,
            origin,
            site: None,
        }
    }

    /// The same geometry at `site`: each frame labelled with a local standard time
    /// (`YYYY-MM-DDTHH:MM[:SS]`) then carries the sun's apparent altitude
    /// (`sun_altitude_deg`, degrees), from which the viewer finds the frame nearest solar
    /// noon.
    pub fn with_site(mut self, site: Site) -> SolutionGeometry {
        self.site = Some(site);
        self
    }

    /// The sun's apparent altitude (degrees) at the local standard time `label`, when the
    /// site is known and the label is such a time.
    fn sun_altitude_deg(&self, label: &str) -> Option<f64> {
        let site = self.site.as_ref()?;
        let local = ["%Y-%m-%dT%H:%M:%S", "%Y-%m-%dT%H:%M"]
            .iter()
            .find_map(|f| chrono::NaiveDateTime::parse_from_str(label, f).ok())?;
        let at = crate::site::local_to_utc(local, site.utc_offset_h);
        Some(crate::site::solar_position::solar_position(at, site).altitude_deg())
    }

    /// Vertices over all primitives.
    pub fn vertices(&self) -> usize {
        self.primitives.iter().map(|p| p.positions.len()).sum()
    }

    fn vertex_values(&self, p: &Primitive, per_row: &[Rgb]) -> Vec<Rgb> {
        p.weights
            .iter()
            .map(|w| {
                let (s, a) = w.iter().fold((Rgb::ZERO, 0.0), |(s, a), &(r, x)| {
                    (s + per_row[r as usize] * x, a + x)
                });
                if a > 0.0 {
                    s / a
                } else {
                    Rgb::ZERO
                }
            })
            .collect()
    }

    /// The `.glb` of `frames` (at least one), with the sensors at `sensors` (scene frame,
    /// m; may be empty).
    ///
    /// # Errors
    /// [`Error::Internal`] when there is no frame or serialisation fails.
    pub fn encode(&self, frames: &[GltfFrame], sensors: &[DVec3]) -> Result<Vec<u8>> {
        if frames.is_empty() {
            return Err(Error::Internal(
                "a glTF file needs at least one frame".into(),
            ));
        }
        let mut root = json::Root::default();
        let mut bin: Vec<u8> = Vec::new();
        // Appends `data` as a buffer view and an accessor; returns the accessor index.
        let mut push = |root: &mut json::Root,
                        data: &[u8],
                        count: usize,
                        ty: json::accessor::Type,
                        comp: json::accessor::ComponentType,
                        target: Option<json::buffer::Target>,
                        minmax: Option<(Vec<f32>, Vec<f32>)>|
         -> json::Index<json::Accessor> {
            while bin.len() % 4 != 0 {
                bin.push(0);
            }
            let offset = bin.len();
            bin.extend_from_slice(data);
            let view = root.push(json::buffer::View {
                buffer: json::Index::new(0),
                byte_length: USize64::from(data.len()),
                byte_offset: Some(USize64::from(offset)),
                byte_stride: None,
                extensions: None,
                extras: Default::default(),
                name: None,
                target: target.map(Checked::Valid),
            });
            root.push(json::Accessor {
                buffer_view: Some(view),
                byte_offset: None,
                count: USize64::from(count),
                component_type: Checked::Valid(json::accessor::GenericComponentType(comp)),
                extensions: None,
                extras: Default::default(),
                type_: Checked::Valid(ty),
                min: minmax.as_ref().map(|m| json::Value::from(m.0.clone())),
                max: minmax.map(|m| json::Value::from(m.1)),
                name: None,
                normalized: false,
                sparse: None,
            })
        };
        let f32s = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
        let scale = frames
            .iter()
            .flat_map(|f| f.radiance.iter())
            .map(|l| l.max_element())
            .fold(1e-12, f64::max);
        use json::accessor::{ComponentType as C, Type as T};
        let vertex = Some(json::buffer::Target::ArrayBuffer);
        let mut primitives = Vec::new();
        let mut frame_acc: Vec<Vec<json::Value>> = vec![Vec::new(); frames.len()];
        for p in &self.primitives {
            let flat: Vec<f32> = p.positions.iter().flatten().copied().collect();
            let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
            for v in &p.positions {
                for k in 0..3 {
                    lo[k] = lo[k].min(v[k]);
                    hi[k] = hi[k].max(v[k]);
                }
            }
            let n = p.positions.len();
            let pos = push(
                &mut root,
                &f32s(&flat),
                n,
                T::Vec3,
                C::F32,
                vertex,
                Some((lo.to_vec(), hi.to_vec())),
            );
            let nf: Vec<f32> = p.normals.iter().flatten().copied().collect();
            let nor = push(&mut root, &f32s(&nf), n, T::Vec3, C::F32, vertex, None);
            let ib: Vec<u8> = p.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
            let idx = push(
                &mut root,
                &ib,
                p.indices.len(),
                T::Scalar,
                C::U32,
                Some(json::buffer::Target::ElementArrayBuffer),
                None,
            );
            let mut first = None;
            for (k, f) in frames.iter().enumerate() {
                let l = self.vertex_values(p, &f.radiance);
                let e = self.vertex_values(p, &f.irradiance);
                let col: Vec<f32> = l
                    .iter()
                    .flat_map(|c| (*c / scale).to_array().map(|x| x.clamp(0.0, 1.0) as f32))
                    .collect();
                let ill: Vec<f32> = e.iter().map(|x| lux(*x) as f32).collect();
                let lum: Vec<f32> = l
                    .iter()
                    .map(|x| (EFFICACY_LM_PER_W * grey(*x)) as f32)
                    .collect();
                let c = push(&mut root, &f32s(&col), n, T::Vec3, C::F32, vertex, None);
                let i = push(&mut root, &f32s(&ill), n, T::Scalar, C::F32, vertex, None);
                let m = push(&mut root, &f32s(&lum), n, T::Scalar, C::F32, vertex, None);
                frame_acc[k].push(serde_json::json!({
                    "COLOR_0": c.value(), "_ILLUMINANCE": i.value(), "_LUMINANCE": m.value()
                }));
                if k == 0 {
                    first = Some((c, i, m));
                }
            }
            let (c, i, m) = first.expect("at least one frame");
            let mut attributes = std::collections::BTreeMap::new();
            attributes.insert(Checked::Valid(json::mesh::Semantic::Positions), pos);
            attributes.insert(Checked::Valid(json::mesh::Semantic::Normals), nor);
            attributes.insert(Checked::Valid(json::mesh::Semantic::Colors(0)), c);
            attributes.insert(
                Checked::Valid(json::mesh::Semantic::Extras("ILLUMINANCE".into())),
                i,
            );
            attributes.insert(
                Checked::Valid(json::mesh::Semantic::Extras("LUMINANCE".into())),
                m,
            );
            primitives.push(json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: Default::default(),
                indices: Some(idx),
                material: Some(json::Index::new(p.material as u32)),
                mode: Checked::Valid(json::mesh::Mode::Triangles),
                targets: None,
            });
        }
        let sensors_json = if sensors.is_empty() {
            json::Value::Null
        } else {
            let flat: Vec<f32> = sensors.iter().flat_map(|p| to_gltf(*p)).collect();
            let pos = push(
                &mut root,
                &f32s(&flat),
                sensors.len(),
                T::Vec3,
                C::F32,
                None,
                None,
            );
            let lux_acc: Vec<json::Value> = frames
                .iter()
                .map(|f| {
                    let v: Vec<f32> = f.sensor_lux.iter().map(|x| *x as f32).collect();
                    push(&mut root, &f32s(&v), v.len(), T::Scalar, C::F32, None, None)
                        .value()
                        .into()
                })
                .collect();
            serde_json::json!({ "positions": pos.value(), "lux": lux_acc })
        };
        for m in &self.materials {
            let alpha = if m.glazing { 0.3 } else { 1.0 };
            let c = m.kd.to_array().map(|x| x.clamp(0.0, 1.0) as f32);
            root.push(json::Material {
                alpha_mode: Checked::Valid(if m.glazing {
                    json::material::AlphaMode::Blend
                } else {
                    json::material::AlphaMode::Opaque
                }),
                name: Some(m.name.clone()),
                pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                    base_color_factor: json::material::PbrBaseColorFactor([
                        c[0], c[1], c[2], alpha,
                    ]),
                    metallic_factor: json::material::StrengthFactor(0.0),
                    roughness_factor: json::material::StrengthFactor(1.0),
                    ..Default::default()
                },
                ..Default::default()
            });
        }
        let mesh = root.push(json::Mesh {
            extensions: None,
            extras: Default::default(),
            name: Some("daystep solution".into()),
            primitives,
            weights: None,
        });
        // The vertices are relative to the scene's origin (f32 keeps millimetres there);
        // the node's translation puts them back in the model's frame.
        let node = root.push(json::Node {
            mesh: Some(mesh),
            name: Some("solution".into()),
            translation: Some(to_gltf(self.origin)),
            ..Default::default()
        });
        root.push(json::Scene {
            extensions: None,
            extras: Default::default(),
            name: None,
            nodes: vec![node],
        });
        root.scene = Some(json::Index::new(0));
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        root.push(json::Buffer {
            byte_length: USize64::from(bin.len()),
            extensions: None,
            extras: Default::default(),
            name: None,
            uri: None,
        });
        let frames_json: Vec<json::Value> = frames
            .iter()
            .zip(frame_acc)
            .map(|(f, prims)| match self.sun_altitude_deg(&f.label) {
                Some(alt) => serde_json::json!({
                    "label": f.label, "sun_altitude_deg": alt, "primitives": prims
                }),
                None => serde_json::json!({ "label": f.label, "primitives": prims }),
            })
            .collect();
        let extras = serde_json::json!({ "daystep": {
            "version": 1,
            "radiance_scale": scale,
            "units": { "radiance": "W/(sr m2)", "illuminance": "lux", "luminance": "cd/m2" },
            "origin": [self.origin.x, self.origin.y, self.origin.z],
            "frames": frames_json,
            "sensors": sensors_json,
        }});
        root.asset = json::Asset {
            generator: Some(format!("daystep {}", env!("CARGO_PKG_VERSION"))),
            extras: Some(
                serde_json::value::to_raw_value(&extras)
                    .map_err(|e| Error::Internal(format!("glTF extras: {e}")))?,
            ),
            ..Default::default()
        };
        let text = json::serialize::to_vec(&root)
            .map_err(|e| Error::Internal(format!("glTF serialisation: {e}")))?;
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: 0,
            },
            json: std::borrow::Cow::Owned(text),
            bin: Some(std::borrow::Cow::Owned(bin)),
        };
        glb.to_vec()
            .map_err(|e| Error::Internal(format!("GLB container: {e}")))
    }

    /// [`Self::encode`] written to `path` atomically.
    ///
    /// # Errors
    /// As [`Self::encode`]; [`Error::Io`] naming `path`.
    pub fn write(&self, path: &Path, frames: &[GltfFrame], sensors: &[DVec3]) -> Result<()> {
        crate::files::write_atomic(path, &self.encode(frames, sensors)?)
    }
}

/// The solution geometry of `op`'s mesh over `scene`: one row per mesh element.
pub fn geometry_of(
    scene: &crate::scene::Scene,
    op: &crate::radiosity::Transport,
) -> SolutionGeometry {
    let mesh = &op.mesh;
    let rows: Vec<([DVec3; 3], DVec3, f64, u32)> = mesh
        .elements
        .iter()
        .zip(&mesh.area)
        .map(|(&e, &a)| {
            let el = &mesh.hierarchy.elements[e as usize];
            let t = &scene.triangles[el.key.tri as usize];
            (el.vertices, t.normal(), a, t.material)
        })
        .collect();
    let materials = scene
        .materials
        .iter()
        .map(|m| GltfMaterial {
            name: m.name.clone(),
            kd: m.reflectance(),
            glazing: m.is_glazing(),
        })
        .collect();
    SolutionGeometry::new(&rows, materials, scene.origin).with_site(scene.site)
}

/// One frame of `op`'s solution `state`: each row's radiance B/π + its emission, and its
/// irradiance (`direct`, the step's mesh direct irradiance, + the interreflected part).
pub fn frame_of(
    op: &crate::radiosity::Transport,
    state: &crate::radiosity::TransportState,
    direct: &[Rgb],
    label: String,
    sensor_lux: Vec<f64>,
) -> GltfFrame {
    let n = op.rows();
    let radiance = (0..n)
        .map(|r| op.radiosity(state, r) / std::f64::consts::PI)
        .collect();
    let irradiance = (0..n)
        .map(|r| direct.get(r).copied().unwrap_or(Rgb::ZERO) + op.indirect_irradiance(state, r))
        .collect();
    GltfFrame {
        label,
        radiance,
        irradiance,
        sensor_lux,
    }
}

#[cfg(test)]
#[path = "gltf_tests.rs"]
mod tests;
