//! Stages 3–4 of a forward step, streamed: the sources' directions (projections and
//! sensor responses) a block at a time, each block counted and transferred onto the
//! interreflection mesh before the next is read, so that a step holds one block's leaves
//! and every direction's sensor responses, not every direction's leaves. On the generated
//! building an instant's 752 directions held 310 MB of leaves at once.

use super::super::direct::{add_mesh_irradiance, MeshWeights};
use super::super::directions::DirectionData;
use super::super::report::{Report, StageTimes};
use super::notes::count_sources;
use super::Engine;
use crate::hierarchy::{Hierarchy, LeafUnion};
use crate::photometry::Rgb;
use crate::projection::DirectionRecord;
use crate::radiosity::Transport;
use crate::sources::Source;
use crate::transfer;
use rayon::prelude::*;
use std::sync::Arc;

/// What the streamed direct stages leave for the rest of a step.
pub(super) struct DirectPass {
    /// Per source (in order) its direction data: only the sensor responses, unless the
    /// step keeps its refined elements ([`DirectPass::elements`]), which read the leaves.
    pub data: Vec<Arc<DirectionData>>,
    /// The direct irradiance of the operator's mesh rows (RGB W/m²) and, with surface
    /// output, the irradiance transmitted through its glazing; `None` without an operator.
    pub mesh: Option<(Vec<Rgb>, Option<Vec<Rgb>>)>,
    /// The refined elements and their direct light, when the step keeps them.
    pub elements: Option<(Hierarchy, transfer::DirectIrradiance)>,
}

impl Engine<'_> {
    /// Stages 3–4 for `sources`: directions, the counts of `report`, the refined element
    /// count or elements when `detail`, and the mesh's direct irradiance. Blocks of 8 ×
    /// threads sources, summed in source order: the sums do not depend on the block.
    pub(super) fn direct_pass(
        &self,
        sources: &[Source],
        detail: bool,
        times: &mut StageTimes,
        report: &mut Report,
    ) -> DirectPass {
        let block = 8 * rayon::current_num_threads().max(1);
        // The arena of refined elements reads every direction's leaves at once.
        let keep_leaves = detail && !self.opts.count_elements_only;
        let mut union = (detail && !keep_leaves).then(LeafUnion::default);
        let mut mesh = self.operator.as_ref().map(|op| {
            (
                vec![Rgb::ZERO; op.rows()],
                self.surfaces.as_ref().map(|_| vec![Rgb::ZERO; op.rows()]),
            )
        });
        let mut data = Vec::with_capacity(sources.len());
        for srcs in sources.chunks(block) {
            let ds = times.time("directions", || self.dirs.get_all(srcs));
            let records: Vec<&DirectionRecord> = ds.iter().map(|d| &d.record).collect();
            count_sources(srcs, &records, self.scene, &mut report.counts);
            if let Some(u) = union.as_mut() {
                times.time("transfer", || {
                    u.add(records.iter().flat_map(|r| r.leaves.iter().map(|l| l.key)))
                });
            }
            if let (Some(op), Some((e, et))) = (&self.operator, mesh.as_mut()) {
                times.time("transfer_mesh", || {
                    self.add_mesh_direct(op, srcs, &ds, e, et.as_mut())
                });
            }
            data.extend(ds.into_iter().map(|d| {
                if keep_leaves {
                    d
                } else {
                    Arc::new(DirectionData {
                        record: DirectionRecord::default(),
                        sensors: d.sensors.clone(),
                        rays: d.rays,
                    })
                }
            }));
        }
        if let Some(u) = union {
            report.counts.elements_after = u.leaf_count(self.scene.triangles.len());
        }
        let elements = keep_leaves.then(|| {
            times.time("transfer", || {
                let mut h = Hierarchy::new(self.scene);
                let records: Vec<&DirectionRecord> = data.iter().map(|d| &d.record).collect();
                let d = transfer::transfer(&mut h, sources, &records);
                report.counts.elements_after = h.leaf_count();
                (h, d)
            })
        });
        DirectPass {
            data,
            mesh,
            elements,
        }
    }

    /// Adds the direct irradiance of the mesh rows from `srcs` (with their direction data
    /// `ds`) to `e`, and the irradiance transmitted through glazing to `et` when surface
    /// output is asked: the sources' mesh weights (memoised) in parallel, summed in order.
    fn add_mesh_direct(
        &self,
        op: &Transport,
        srcs: &[Source],
        ds: &[Arc<DirectionData>],
        e: &mut [Rgb],
        et: Option<&mut Vec<Rgb>>,
    ) {
        let weights: Vec<MeshWeights> = srcs
            .par_iter()
            .zip(ds)
            .map(|(src, d)| {
                let res = self.dirs.quality().projection.resolution_for(src.is_sun());
                self.mesh_memo.weights(self.scene, op, src, res, &d.record)
            })
            .collect();
        add_mesh_irradiance(e, srcs, &weights);
        if let (Some(m), Some(et)) = (&self.surfaces, et) {
            for (src, w) in srcs.iter().zip(&weights) {
                m.add_transmitted(et, src, w, self.scene);
            }
        }
    }
}
