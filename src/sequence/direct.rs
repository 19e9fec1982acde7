//! The direct stages of a step: each source's light onto the interreflection mesh (from
//! its cached projection) and onto the sensors (from their cached responses).

use super::directions::{DirectionData, Directions};
use crate::hierarchy::Hierarchy;
use crate::photometry::{lux, Rgb};
use crate::projection::DirectionRecord;
use crate::radiosity::Transport;
use crate::scene::Scene;
use crate::sensors::SensorDirect;
use crate::sources::{Source, SourceKey};
use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex};

/// One direction's direct irradiance on the operator's mesh per unit normal irradiance:
/// (row, RGB weight) for the rows it reaches.
pub type MeshWeights = Arc<Vec<(u32, Rgb)>>;

/// Mesh weights of the directions a run has met more than once, keyed by direction and
/// LDI resolution: a sequence transfers each recurring direction at most twice. A
/// direction is kept only from its second use, so a run of one step (an instant) keeps
/// none: on the generated building its 752 directions' weights took 700 MB.
#[derive(Default)]
pub struct MeshMemo(Mutex<Memo>);

#[derive(Default)]
struct Memo {
    kept: HashMap<(SourceKey, u32), MeshWeights, ahash::RandomState>,
    seen: HashSet<(SourceKey, u32), ahash::RandomState>,
}

impl MeshMemo {
    /// The weights of `src` (projected at LDI resolution `res` into `record`) on `op`'s
    /// mesh: the record's leaf weights transferred onto a fresh hierarchy and averaged
    /// onto the rows by area.
    pub fn weights(
        &self,
        scene: &Scene,
        op: &Transport,
        src: &Source,
        res: u32,
        record: &DirectionRecord,
    ) -> MeshWeights {
        let key = (src.key, res);
        let again = {
            let mut m = self.0.lock().expect("mesh memo");
            if let Some(w) = m.kept.get(&key) {
                return w.clone();
            }
            !m.seen.insert(key)
        };
        let w: MeshWeights = Arc::new(mesh_weights(scene, op, src, record));
        if !again {
            return w;
        }
        self.0
            .lock()
            .expect("mesh memo")
            .kept
            .entry(key)
            .or_insert(w)
            .clone()
    }
}

/// The direct irradiance of `op`'s mesh per unit normal irradiance of `src`, projected into
/// `record`: the record's leaf weights transferred onto a fresh hierarchy and averaged onto
/// the rows by area; (row, RGB weight) for the rows it reaches.
pub fn mesh_weights(
    scene: &Scene,
    op: &Transport,
    src: &Source,
    record: &DirectionRecord,
) -> Vec<(u32, Rgb)> {
    let mut h = Hierarchy::new(scene);
    let unit = Source {
        normal_irradiance: Rgb::ONE,
        ..*src
    };
    let d = crate::transfer::transfer(&mut h, std::slice::from_ref(&unit), &[record]);
    let e: Vec<Rgb> = d.sun.iter().zip(&d.sky).map(|(a, b)| *a + *b).collect();
    op.mesh
        .average_onto(&h, &e)
        .into_iter()
        .enumerate()
        .filter(|(_, v)| *v != Rgb::ZERO)
        .map(|(r, v)| (r as u32, v))
        .collect()
}

/// Adds to `e` (per row of the mesh, RGB W/m²) E_n × the direction's weights of each of
/// `sources` in order (`weights[k]` those of `sources[k]`). The fixed order makes the sum
/// independent of how the weights were scheduled, and of how the sources were split into
/// calls.
pub fn add_mesh_irradiance(e: &mut [Rgb], sources: &[Source], weights: &[MeshWeights]) {
    for (src, w) in sources.iter().zip(weights) {
        for &(row, wt) in w.iter() {
            e[row as usize] += src.normal_irradiance * wt;
        }
    }
}

/// Direct irradiance of every sensor from the sources' cached responses: sky and ground
/// nodes as Σ_children L_c ⊙ response_c, the sun as E_n ⊙ transmission × cos θ (true sun
/// direction), with the visibility uncertainty and the per-child-vs-node radiance
/// difference as error terms.
pub fn sensors_from_responses(
    dirs: &Directions,
    sources: &[Source],
    data: &[Arc<DirectionData>],
) -> Vec<SensorDirect> {
    let scene = dirs.scene();
    (0..scene.sensors.len())
        .map(|k| {
            let n = scene.sensors[k].normal;
            let mut out = SensorDirect::default();
            for (s, d) in sources.iter().zip(data) {
                let r = &d.sensors[k];
                out.rays += d.rays / scene.sensors.len().max(1) as u64;
                if s.vertices.is_none() {
                    let cos = n.dot(s.true_direction);
                    if cos > 0.0 {
                        out.sun += s.normal_irradiance * dirs.sun_transmission(k, s, r) * cos;
                    }
                    continue;
                }
                for c in 0..4 {
                    let fine = s.child_radiance[c] * r.child[c];
                    out.sky += fine;
                    out.radiance_error += fine - s.radiance * r.child[c];
                    out.visibility_err_lux += lux(s.child_radiance[c]) * r.uncertainty[c];
                }
            }
            out
        })
        .collect()
}
