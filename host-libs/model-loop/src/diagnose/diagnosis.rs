//! What a diagnosis says: the verdict, the base, every effect tried, the steps of the
//! sequence. This is the JSON of `pamctl model diagnose --json`.

use super::recording::SpikeReport;
use super::selection::FoldTest;
use super::unexplained::UnexplainedReport;
use super::AxisPair;
use super::Warning;
use crate::effects::{Experiment, Family};
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Clone, Debug, Serialize)]
pub struct BaseReport {
    pub nrmse: AxisPair,
    pub r2: AxisPair,
    pub params: BTreeMap<String, f64>,
}

/// What the loop concludes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// At least one effect is accepted; `effects[0]` is the first.
    Effect,
    /// The base model explains the log: nothing is missing that the data can show.
    None,
    /// The residual has structure no effect explains (a tone, a wander): no effect is
    /// accepted, or the structure carries more of the residual than the accepted effects
    /// (still listed, `accepted`) removed of the base's error.
    Unexplained,
}

impl Verdict {
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Effect => "effect",
            Verdict::None => "none",
            Verdict::Unexplained => "unexplained",
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Another shape of the same family, tried on the same log.
#[derive(Clone, Debug, Serialize)]
pub struct ShapeScore {
    pub shape: String,
    /// The catalog effect that carries this shape (for `fit --with`).
    pub effect: String,
    pub improvement: f64,
    pub accepted: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct EffectReport {
    /// The family's catalog id, shared with the digital twin (for an effect outside the
    /// families, its own id).
    pub id: String,
    /// The physical family (what the user learns), and the shape that fits best.
    pub family: Option<Family>,
    pub shape: String,
    /// The catalog effect that carries the shape (for `fit --with`).
    pub effect: String,
    /// Held-out NRMSE with this effect added to the base model.
    pub nrmse: AxisPair,
    pub params: BTreeMap<String, f64>,
    pub evidence: String,
    /// The residual signature that points to this effect.
    pub signature: String,
    /// Share of the base model's training residual the effect removes when refitted.
    pub signature_strength: f64,
    /// Share of the relative MSE removed: cross-validated over [`FOLDS`] contiguous folds
    /// (dynamic trials), or on the held-out part (step trials).
    pub improvement: f64,
    /// Share of the held-out relative MSE removed (the rows of [`Diagnosis::held_out`]), fitted
    /// on the others.
    pub held_out_improvement: f64,
    pub added_params: usize,
    /// improvement − penalty × added_params.
    pub score: f64,
    /// How much the effect changes the held-out prediction, RMS over the scored axes as a
    /// share of the measured signal's spread over the whole trial (largest axis).
    pub effect_size: f64,
    /// The gain fold by fold, and the critical t it had to reach.
    pub folds: FoldTest,
    pub t_critical: f64,
    pub accepted: bool,
    /// The family's other shapes, best first.
    pub other_shapes: Vec<ShapeScore>,
}

/// A family the significance tests accepted after the first but that the final model leaves
/// out: what it removes beyond the families already in the model is too little to tell it
/// from a better shape of them (a shape outside the catalog) or from nothing.
#[derive(Clone, Debug, Serialize)]
pub struct Refinement {
    /// The family's catalog id, its family and the shape that fitted.
    pub id: String,
    pub family: Option<Family>,
    pub shape: String,
    /// Share of the base model's held-out error it removes on top of the final model.
    pub removes: f64,
    /// The other shape of a family already in the model that removes most on top of it
    /// (catalog effect id), and the share it removes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined_by: Option<String>,
    pub refined_removes: f64,
    pub evidence: String,
}

#[derive(Clone, Debug, Serialize)]
pub struct StepReport {
    pub effects: Vec<String>,
    pub nrmse: AxisPair,
}

/// A step family the log has too few steps to decide on: the steps it has and about how
/// many would decide (the experiment a diagnosis names for it: the same trial, longer).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct StepsToDecide {
    pub family: Family,
    pub steps: usize,
    /// `None`: its gain is not positive across the steps on average, so no count of them
    /// is in sight.
    pub steps_needed: Option<usize>,
}

/// A step family the converters' spread (a share of each axis's force in the other)
/// explains as well: a saturation that removes no more than the spread does, another
/// family that removes nothing material beyond it. One log at one co-contraction cannot
/// tell it from that spread; the same trial at another co-contraction can
/// ([`crate::spread_pair::saturation_or_spread`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct WithinSpread {
    pub family: Family,
    /// The share of the base's held-out error the family removes.
    pub improvement: f64,
    /// The share the converters' spread removes.
    pub spread_improvement: f64,
    /// The share of the error the spread leaves that the family removes on top of it.
    pub beyond_spread: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Diagnosis {
    pub experiment: Experiment,
    pub samples: usize,
    pub sample_period_s: f64,
    /// Which rows the fits were scored on ([`HeldOut::describe`]).
    pub held_out: String,
    /// Isolated spikes of the force bridged before the fits (none: absent).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spikes: Option<SpikeReport>,
    pub base: BaseReport,
    pub verdict: Verdict,
    /// One entry per family (its best shape): the accepted ones first, best first.
    pub effects: Vec<EffectReport>,
    /// Families the log cannot tell apart (the first is `effects[0]`'s): their fold-by-fold
    /// difference is within the spread, or the shares of the error they remove
    /// (`improvement`) are closer than `Settings::min_family_gain`. Empty when the first is
    /// clearly best.
    pub ambiguous: Vec<Family>,
    /// The experiment that would separate the ambiguous families.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub separating_experiment: Option<String>,
    /// Why the log cannot tell them apart, with the figures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ambiguity_evidence: Option<String>,
    pub unexplained: Vec<UnexplainedReport>,
    /// The error falling as the accepted effects are added one by one: the last step is the
    /// final model.
    pub steps: Vec<StepReport>,
    /// Accepted families the final model leaves out, as too small beyond it to be told from
    /// a refinement of what it holds.
    pub refinements: Vec<Refinement>,
    /// Step families the log has too few steps to decide on (each with a warning that
    /// says so in words).
    pub too_few_steps: Vec<StepsToDecide>,
    /// Step families the log cannot tell from the converters' spread (each with a warning
    /// that says so in words).
    pub within_spread: Vec<WithinSpread>,
    pub warnings: Vec<Warning>,
}

impl Diagnosis {
    /// The families of the final model (the last step's effects), in the order they
    /// entered, each once.
    pub fn final_families(&self) -> Vec<Family> {
        let Some(last) = self.steps.last() else {
            return Vec::new();
        };
        let mut out: Vec<Family> = Vec::new();
        for id in &last.effects {
            let family = self
                .effects
                .iter()
                .find(|e| e.effect == *id || e.other_shapes.iter().any(|s| s.effect == *id))
                .and_then(|e| e.family);
            if let Some(f) = family.filter(|f| !out.contains(f)) {
                out.push(f);
            }
        }
        out
    }
}
