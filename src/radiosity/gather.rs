//! The sensor gather: each sensor's indirect irradiance as a sparse row over the mesh's
//! radiosities (cosine rays through the run's [`Tracer`], with the glazing mirror), and
//! how the sensors read the solved parts (mean, noise, discretisation).

use super::mesh::Mesh;
use super::solve::TransportState;
use super::sparse::Sparse;
use super::transport::Transport;
use crate::math::rng::{mix64, uniform};
use crate::photometry::Rgb;
use crate::scene::Sensor;
use crate::trace::{barycentric, cosine_direction, End, Outcome, Tracer};
use rayon::prelude::*;

/// A sensor's indirect irradiance from the transport solution.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TransportSensor {
    /// Mean over parts, RGB W/m².
    pub irradiance: Rgb,
    /// 1σ standard error of the mean over parts, RGB W/m².
    pub std_err: Rgb,
    /// |fine − one level coarser| (mean over parts), RGB W/m².
    pub discretisation: Rgb,
}

impl Transport {
    /// Indirect irradiance at every sensor given to [`Transport::build`], in order.
    pub fn sensors(&self, state: &TransportState) -> Vec<TransportSensor> {
        let k = self.parts.first().map_or(0, |p| p.g.rows());
        let n = self.parts.len() as f64;
        (0..k)
            .map(|s| {
                let fine: Vec<Rgb> = self
                    .parts
                    .iter()
                    .zip(&state.b)
                    .map(|(p, b)| p.g.row_dot(s, b))
                    .collect();
                let coarse: Rgb = self
                    .parts
                    .iter()
                    .zip(&state.b_coarse)
                    .map(|(p, b)| p.g_coarse.row_dot(s, b))
                    .fold(Rgb::ZERO, |a, x| a + x)
                    / n;
                TransportSensor::from_parts(&fine, coarse)
            })
            .collect()
    }
}

impl TransportSensor {
    /// A sensor's estimate from its per-part fine values and the mean coarse value: mean,
    /// standard error of the mean over parts, |mean − coarse|.
    pub fn from_parts(fine: &[Rgb], coarse: Rgb) -> TransportSensor {
        let n = fine.len() as f64;
        let mean = fine.iter().fold(Rgb::ZERO, |a, x| a + *x) / n;
        let var = fine
            .iter()
            .fold(Rgb::ZERO, |a, x| a + (*x - mean) * (*x - mean))
            / (n - 1.0)
            / n;
        TransportSensor {
            irradiance: mean,
            std_err: super::sqrt3(var),
            discretisation: (mean - coarse).abs(),
        }
    }
}

/// The sensor gather: `rays` jittered-stratified cosine rays per sensor; a ray through
/// glazing keeps τ(θ); one reaching a front face adds τ/rays to G[sensor, row]. At the
/// first pane a ray meets (only the first: second reflections, R² ≈ 1 %, are left out) the
/// mirror direction is traced too, with weight R(θ), and adds R·τ_after/rays where it
/// reaches a front face.
pub(super) fn gather(
    tracer: &Tracer,
    mesh: &Mesh,
    sensors: &[Sensor],
    rays: u32,
    seed: u64,
) -> Sparse {
    let m = (rays as f64).sqrt().ceil() as u64;
    let per: Vec<Vec<(u32, [f32; 3])>> = sensors
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let stream = mix64(seed ^ (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut acc: std::collections::BTreeMap<u32, Rgb> = Default::default();
            let n = s.normal.normalize();
            for i in 0..m {
                for j in 0..m {
                    let idx = i * m + j;
                    let u1 = (i as f64 + uniform(seed, stream, 2 * idx)) / m as f64;
                    let u2 = (j as f64 + uniform(seed, stream, 2 * idx + 1)) / m as f64;
                    let (d, _) = cosine_direction(n, u1, u2);
                    let mut add = |out: Outcome| {
                        if let End::Front { tri, point, .. } = out.end {
                            let root = mesh.hierarchy.elements[tri as usize].vertices;
                            let row = mesh.row_at(tri, barycentric(root, point));
                            *acc.entry(row).or_default() += out.power;
                        }
                    };
                    let out = tracer.trace(s.position, d, Rgb::ONE);
                    // Only a ray that met glazing (every pane loses something: Fresnel)
                    // looks for the mirror image in the first pane it met.
                    let met_glazing = out.glazing_loss != Rgb::ZERO;
                    add(out);
                    if let Some(h) = met_glazing
                        .then(|| tracer.first_hit(s.position, d))
                        .flatten()
                    {
                        if h.glazing {
                            if let Some(out) = tracer.mirror(h.tri, h.point, -d, Rgb::ONE) {
                                add(out);
                            }
                        }
                    }
                }
            }
            let w = 1.0 / (m * m) as f64;
            acc.into_iter()
                .map(|(r, t)| (r, [(t.x * w) as f32, (t.y * w) as f32, (t.z * w) as f32]))
                .collect()
        })
        .collect();
    let entries = per
        .into_iter()
        .enumerate()
        .flat_map(|(k, row)| row.into_iter().map(move |(c, v)| (k as u32, c, v)));
    Sparse::from_sorted(sensors.len(), entries)
}
