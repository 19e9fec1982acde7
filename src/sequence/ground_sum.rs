//! The uniform ground glow as one source of daylight coefficients: every ground node of a
//! cut has the same radiance (ρ·E_h/π, one value per step), so a step's ground terms are
//! that radiance times the sum of the nodes' rows, which is the same for every step that
//! cuts the ground alike. Summed once, the ground costs a step one node's arithmetic
//! instead of hundreds (316 nodes at `default`). Radiance's 2-phase likewise keeps the
//! ground as one patch of its sky matrix.

use super::{Coefficients, NodeData, DIRECT_ROWS};
use crate::sources::{Source, SourceKey};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The rows of a cut's ground nodes, summed (each `sensors` f32).
#[derive(Debug)]
pub(super) struct GroundSum {
    /// Σ over nodes of the direct response (lux per W·sr⁻¹·m⁻² of the ground's radiance).
    pub direct: Vec<f32>,
    /// Σ over nodes and children of the visibility uncertainties (same unit).
    pub uncertainty: Vec<f32>,
    /// parts + 1 rows: Σ over nodes of solid angle (sr) × interreflected lux per W/m².
    pub indirect: Vec<f32>,
    /// Σ over nodes of solid angle × the stated error of interreflected rows taken from
    /// ancestors (lux per W/m²; empty when no node takes them).
    pub direction_err: Vec<f32>,
}

/// Ground sums already made, by the cut's ground nodes in order: fine (all rows) and
/// coarse (the direct row only).
#[derive(Default)]
pub(super) struct GroundMemo {
    fine: Mutex<HashMap<Vec<SourceKey>, Arc<GroundSum>, ahash::RandomState>>,
    coarse: Mutex<HashMap<Vec<SourceKey>, Arc<Vec<f32>>, ahash::RandomState>>,
}

/// The ground's grey radiance (W·sr⁻¹·m⁻²) when every one of `ground` has it, on the node
/// and on each child: `None` otherwise (a ground that is not uniform is summed node by
/// node).
pub(super) fn uniform_radiance(ground: &[&Source]) -> Option<f32> {
    let first = ground.first()?;
    let l = first.radiance;
    ground
        .iter()
        .all(|s| s.radiance == l && s.child_radiance.iter().all(|c| *c == l))
        .then(|| super::g(l))
}

/// Splits a cut into its ground nodes and the rest (sky nodes and the sun), each in order.
pub(super) fn split_ground(cut: &[Source]) -> (Vec<&Source>, Vec<&Source>) {
    cut.iter()
        .partition(|s| matches!(s.key, SourceKey::Ground(_)))
}

fn keys(ground: &[&Source]) -> Vec<SourceKey> {
    ground.iter().map(|s| s.key).collect()
}

/// Σ of rows, accumulated in f64 so that the sum of hundreds of nodes adds no rounding
/// of its own beyond the final f32.
fn sum_rows<'a>(k: usize, rows: impl Iterator<Item = (f64, &'a [f32])>) -> Vec<f32> {
    let mut acc = vec![0f64; k];
    for (w, row) in rows {
        for (a, x) in acc.iter_mut().zip(row) {
            *a += w * *x as f64;
        }
    }
    acc.into_iter().map(|a| a as f32).collect()
}

/// Direct row `r` of a node of `k` sensors.
fn row(nd: &NodeData, r: usize, k: usize) -> &[f32] {
    &nd.direct[r * k..(r + 1) * k]
}

impl Coefficients {
    /// The summed rows of the fine cut's ground nodes `ground` (made once per distinct
    /// ground cut).
    pub(super) fn ground_sum(&self, ground: &[&Source]) -> Arc<GroundSum> {
        let key = keys(ground);
        if let Some(s) = self.ground.fine.lock().expect("ground lock").get(&key) {
            return s.clone();
        }
        let (k, p) = (self.sensors, self.parts);
        let nodes: Vec<(&NodeData, f64)> = ground
            .iter()
            .map(|s| (self.node(s), s.solid_angle))
            .collect();
        let direct = sum_rows(k, nodes.iter().map(|(nd, _)| (1.0, row(nd, 4, k))));
        let uncertainty = sum_rows(
            k,
            nodes
                .iter()
                .flat_map(|(nd, _)| (5..DIRECT_ROWS).map(move |r| (1.0, row(nd, r, k)))),
        );
        let indirect = (0..=p)
            .flat_map(|r| {
                sum_rows(
                    k,
                    nodes
                        .iter()
                        .map(|(nd, w)| (*w, &nd.indirect[r * k..(r + 1) * k])),
                )
            })
            .collect();
        let direction_err = if nodes.iter().all(|(nd, _)| nd.direction_err.is_empty()) {
            Vec::new()
        } else {
            let errs = nodes.iter().filter(|(nd, _)| !nd.direction_err.is_empty());
            sum_rows(k, errs.map(|(nd, w)| (*w, nd.direction_err.as_slice())))
        };
        let s = Arc::new(GroundSum {
            direct,
            uncertainty,
            indirect,
            direction_err,
        });
        self.ground
            .fine
            .lock()
            .expect("ground lock")
            .entry(key)
            .or_insert(s)
            .clone()
    }

    /// The summed direct rows of the coarse cut's ground nodes `ground`, from the coarse
    /// level's rows `rows_of` (4 children each).
    pub(super) fn coarse_ground_sum(
        &self,
        ground: &[&Source],
        rows_of: impl Fn(&Source) -> Arc<Vec<f32>>,
    ) -> Arc<Vec<f32>> {
        let key = keys(ground);
        if let Some(s) = self.ground.coarse.lock().expect("ground lock").get(&key) {
            return s.clone();
        }
        let k = self.sensors;
        let rows: Vec<Arc<Vec<f32>>> = ground.iter().map(|s| rows_of(s)).collect();
        let s = Arc::new(sum_rows(
            k,
            rows.iter()
                .flat_map(|d| (0..4).map(move |c| (1.0, &d[c * k..(c + 1) * k]))),
        ));
        self.ground
            .coarse
            .lock()
            .expect("ground lock")
            .entry(key)
            .or_insert(s)
            .clone()
    }
}
