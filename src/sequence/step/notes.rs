//! What a step's report says ([`super::Engine::step`]): the source and element counts, the
//! sun's snapping, the work the scene lets it skip, and the largest stated errors.

use super::super::estimate::SensorValue;
use super::super::report::{Counts, Report};
use super::Engine;
use crate::hierarchy::Hierarchy;
use crate::projection::DirectionRecord;
use crate::scene::Scene;
use crate::sources::{Source, SourceKey};

impl Engine<'_> {
    /// The report's source counts, sun snapping and what the scene lets the step skip.
    pub(super) fn note_sources(&self, s: &super::super::sky::SkySources, report: &mut Report) {
        let scene = self.scene;
        report.counts = Counts {
            negligible_sources: s.negligible,
            elements_before: scene.triangles.len(),
            back_faces: scene.triangles.len() - scene.input_triangles,
            sensors: scene.sensors.len(),
            degenerate_triangles_dropped: scene.dropped_degenerate,
            junction_triangles_cut: scene.junctions.cut,
            junction_triangles_added: scene.junctions.added,
            operators_reused: usize::from(self.operator.is_some() && self.operator_from_cache),
            ..Counts::default()
        };
        if let Some(e) = s.sun_snapping_deg {
            report.sun.used = true;
            report.sun.snapping_error_deg = e;
            report.sun.max_shadow_shift_m = scene_diagonal(scene) * e.to_radians();
        }
        self.note_skipped(&s.sources, report);
    }

    fn note_skipped(&self, sources: &[Source], report: &mut Report) {
        if sources.is_empty() {
            report
                .skipped
                .push("all projections: the sky emits nothing at this instant".into());
        }
        if !self.scene.has_glazing() {
            report
                .skipped
                .push("glazing transmission: the scene has no glazing".into());
        }
        if self.scene.triangles.is_empty() {
            report
                .skipped
                .push("projections: the scene has no geometry".into());
        }
        if self.scene.faces == crate::scene::Faces::Front {
            report.skipped.push(
                "back faces: the scene file says faces = \"front\" (back faces are black)".into(),
            );
        }
    }
}

/// The report's largest stated error, absolute and relative, over `values`.
pub(super) fn note_errors(values: &[SensorValue], report: &mut Report) {
    report.max_lux_err = values.iter().map(|v| v.lux_err).fold(0.0, f64::max);
    report.max_relative_err = values
        .iter()
        .filter_map(|v| v.relative_error(1.0))
        .fold(0.0, f64::max);
}

fn scene_diagonal(scene: &Scene) -> f64 {
    if scene.triangles.is_empty() {
        return 0.0;
    }
    let (lo, hi) = scene.bounds();
    (hi - lo).length()
}

/// Source kinds, LDI sizes and fragments, and the leaves the sun alone refines.
pub(super) fn count_sources(
    sources: &[Source],
    records: &[&DirectionRecord],
    scene: &Scene,
    c: &mut Counts,
) {
    for (s, r) in sources.iter().zip(records) {
        match s.key {
            SourceKey::Sky(_) => c.sky_sources += 1,
            SourceKey::Ground(_) => c.ground_sources += 1,
            SourceKey::Sun(_) | SourceKey::SunGrid(_) => c.sun_sources += 1,
        }
        let px = r.stats.width as u64 * r.stats.height as u64;
        c.ldi_pixels += px;
        c.ldi_fragments += r.stats.fragments;
        c.splits += r.stats.elements_split;
        if px > c.ldi_max_size.0 as u64 * c.ldi_max_size.1 as u64 {
            c.ldi_max_size = (r.stats.width, r.stats.height);
        }
        if s.is_sun() {
            let mut h = Hierarchy::new(scene);
            for l in &r.leaves {
                h.insert(l.key);
            }
            c.elements_after_sun = h.leaf_count();
        }
    }
}
