//! The effects tried one at a time against the base, grouped by family.

use super::cv::FoldScores;
use super::diagnosis::{EffectReport, ShapeScore};
use super::ModelFit;
use super::Warning;
use crate::effects::ModelEffect;

/// One catalog effect tried alone against the base.
pub(super) struct Tried<'e> {
    pub(super) report: EffectReport,
    pub(super) effect: &'e dyn ModelEffect,
    pub(super) folds: FoldScores,
    /// The effect's fit alone, kept when it is accepted: the final model's first step is
    /// this same fit, not fitted again (a step trial's fits are most of a diagnosis's time).
    pub(super) fit: Option<ModelFit>,
    /// The family's other shapes (filled by [`best_shape_per_family`]).
    pub(super) alternatives: Vec<&'e dyn ModelEffect>,
    /// A step family that would be accepted but for the fold test (the log has too few
    /// steps to decide on it) or for the converters' spread: the warning that says so.
    pub(super) undecided: Option<Warning>,
}

/// One entry per family: its best shape (an accepted one before any other), the others
/// listed under it.
pub(super) fn best_shape_per_family(mut tried: Vec<Tried>) -> Vec<Tried> {
    let rank = |t: &Tried| (t.report.accepted, t.report.score);
    tried.sort_by(|a, b| {
        let (ra, rb) = (rank(a), rank(b));
        rb.0.cmp(&ra.0).then(rb.1.total_cmp(&ra.1))
    });
    let mut reports: Vec<Tried> = Vec::new();
    for t in tried {
        let key = family_key(t.effect);
        if let Some(head) = reports.iter_mut().find(|r| family_key(r.effect) == key) {
            head.alternatives.push(t.effect);
            head.report.other_shapes.push(ShapeScore {
                shape: t.report.shape.clone(),
                effect: t.report.effect.clone(),
                improvement: t.report.improvement,
                accepted: t.report.accepted,
            });
        } else {
            reports.push(t);
        }
    }

    reports
}

/// The family an effect is judged in (an effect outside the families is its own).
pub(super) fn family_key(e: &dyn ModelEffect) -> String {
    e.family()
        .map(|f| f.name().to_string())
        .unwrap_or_else(|| e.id().to_string())
}
