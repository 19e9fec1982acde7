//! Values-only sums of daylight coefficients over a batch of steps (the light paths of
//! `annual --leed`, [`crate::sequence::annual`]): the steps' cuts arranged node by node,
//! so each node's rows are read once for every step of the batch that uses it.

use super::{g, Coefficients};
use crate::sequence::day_cuts;
use crate::sequence::estimate::SensorValue;
use crate::sources::{Source, SourceKey};

/// One step's use of a node: the step's index in its batch, the grey radiance of the
/// node's four children (W·sr⁻¹·m⁻²) and its normal irradiance (W/m²).
type NodeUse = (u32, [f32; 4], f32);

/// The cuts of a batch of steps, arranged for [`Coefficients::evaluate_values_batch`]:
/// per sky or ground node (in key order), the steps that use it with the grey radiance of
/// its four children and its normal irradiance; per step, its sun.
pub(in crate::sequence) struct CutBatch {
    pub(super) nodes: Vec<(SourceKey, Vec<NodeUse>)>,
    /// Per step, the sun source (`None`: no sun).
    pub suns: Vec<Option<Source>>,
}

impl CutBatch {
    /// Arranges the cuts `cuts` (one per step, each a step's sources).
    pub fn new(cuts: &[&[Source]]) -> CutBatch {
        let mut uses: Vec<(SourceKey, u32, [f32; 4], f32)> = Vec::new();
        let mut suns = Vec::with_capacity(cuts.len());
        for (j, cut) in cuts.iter().enumerate() {
            let mut sun = None;
            for src in cut.iter() {
                if src.is_sun() {
                    sun = Some(*src);
                } else {
                    let l = src.child_radiance.map(g);
                    // L̂·ω as every sum reads it ([`day_cuts::canonical`]).
                    let e = g(day_cuts::node_irradiance(src));
                    uses.push((src.key, j as u32, l, e));
                }
            }
            suns.push(sun);
        }
        // Stable: a node's uses stay in step order.
        uses.sort_by_key(|u| u.0);
        let mut nodes: Vec<(SourceKey, Vec<NodeUse>)> = Vec::new();
        for (key, j, l, e) in uses {
            match nodes.last_mut() {
                Some((k, v)) if *k == key => v.push((j, l, e)),
                _ => nodes.push((key, vec![(j, l, e)])),
            }
        }
        CutBatch { nodes, suns }
    }
}

impl super::NodeData {
    /// What [`Coefficients::evaluate_values_batch`] reads of a node of `k` sensors and `parts`
    /// parts: the four children's direct rows, and the mean of the parts' interreflected
    /// rows.
    pub(super) fn values_only(self, parts: usize, k: usize) -> super::NodeData {
        let direct = if self.direct.is_empty() {
            Vec::new()
        } else {
            self.direct[..4 * k].to_vec()
        }
        .into();
        let mut mean = vec![0f32; k];
        for q in 0..parts {
            for (m, v) in mean.iter_mut().zip(&self.indirect[q * k..(q + 1) * k]) {
                *m += *v;
            }
        }
        let inv = 1.0 / parts as f32;
        mean.iter_mut().for_each(|m| *m *= inv);
        super::NodeData {
            direct,
            indirect: std::sync::Arc::new(mean.into()),
            direction_err: Vec::new(),
        }
    }
}

impl Coefficients {
    /// Sensor values of the steps of `batch` from coefficients prepared with
    /// `values_only`: the sums of [`Self::evaluate`] less those of the error estimate
    /// (`lux_err` is 0, not stated), node by node: each node's rows are read once for
    /// every step of the batch that uses it, not once per step (per-step sums read the
    /// year's coefficients from memory thousands of times). `sun_fine[j]`
    /// is step j's direct sun per sensor (lux). Each step's sums run over its nodes in key
    /// order, so a step's values do not depend on which steps share its batch.
    pub(in crate::sequence) fn evaluate_values_batch(
        &self,
        batch: &CutBatch,
        sun_fine: &[Vec<f64>],
    ) -> Vec<Vec<SensorValue>> {
        let k = self.sensors;
        let n = batch.suns.len();
        let mut sky = vec![0f32; n * k];
        let mut ind = vec![0f32; n * k];
        for (key, uses) in &batch.nodes {
            let nd = self.nodes.get(key).unwrap_or_else(|| {
                panic!("daylight coefficients: {key:?} was not prepared (Engine::prepare must see every step)")
            });
            let d = &nd.direct[..4 * k];
            let (d0, d1, d2, d3) = (&d[..k], &d[k..2 * k], &d[2 * k..3 * k], &d[3 * k..]);
            let m = &nd.indirect[..k];
            for &(j, l, e) in uses {
                let j = j as usize;
                let sky = &mut sky[j * k..(j + 1) * k];
                let ind = &mut ind[j * k..(j + 1) * k];
                for s in 0..k {
                    sky[s] += l[0] * d0[s] + l[1] * d1[s] + l[2] * d2[s] + l[3] * d3[s];
                    ind[s] += e * m[s];
                }
            }
        }
        (0..n)
            .map(|j| {
                let ind = &mut ind[j * k..(j + 1) * k];
                if let Some(sun) = &batch.suns[j] {
                    self.add_sun(sun, ind, None);
                }
                (0..k)
                    .map(|s| {
                        let (sun, sky, ind) =
                            (sun_fine[j][s], sky[j * k + s] as f64, ind[s] as f64);
                        SensorValue {
                            lux: sun + sky + ind,
                            lux_err: 0.0,
                            lux_sun: sun,
                            lux_sky: sky,
                            lux_indirect: ind,
                        }
                    })
                    .collect()
            })
            .collect()
    }
}
