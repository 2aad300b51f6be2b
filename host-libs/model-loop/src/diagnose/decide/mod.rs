//! The verdict: every effect against the base, fold by fold; the accepted ones added while
//! they pay; the families the data cannot tell apart.

mod combine;
mod refusals;

use super::cv::{held_out_blocks, FoldScores, STEP_BLOCKS};
use super::diagnosis::{BaseReport, Diagnosis, EffectReport, StepReport};
use super::recording::loop_without_spikes;
use super::recording::sampling_warning;
use super::selection::fold_test;
use super::selection::paired_test;
use super::selection::t_critical;
use super::sizes::{effect_size, effective_samples, effective_samples_of};
use super::tried::{best_shape_per_family, family_key, Tried};
use super::verdict::{lag_warning, verdict_of};
use super::AxisPair;
use super::Loop;
use super::ModelFit;
use super::Settings;
use super::StepTest;
use super::Warning;
use crate::effects::Experiment;
use crate::effects::ModelEffect;
use crate::effects::{self, Family};
use pam_ident::trial::Trial;
use pam_model::RobotModel;

/// Diagnoses a trial against the standard catalog.
pub fn diagnose(
    trial: &Trial,
    model: &RobotModel<f64>,
    experiment: Experiment,
    settings: Settings,
) -> Result<(Diagnosis, Vec<ModelFit>), pam_ident::IdentError> {
    diagnose_with(
        trial,
        model,
        experiment,
        settings,
        &crate::effects::catalog(),
    )
}

/// Diagnoses a trial against a given catalog. Returns the diagnosis and the fits of the
/// step-by-step sequence (base first) for reports.
pub fn diagnose_with(
    trial: &Trial,
    model: &RobotModel<f64>,
    experiment: Experiment,
    settings: Settings,
    catalog: &[&dyn ModelEffect],
) -> Result<(Diagnosis, Vec<ModelFit>), pam_ident::IdentError> {
    diagnose_observed(trial, model, experiment, settings, catalog, &|_| {})
}

/// The families a log cannot tell apart, and why.
#[derive(Default)]
struct Ambiguity {
    families: Vec<Family>,
    separating_experiment: Option<String>,
    evidence: Option<String>,
}

/// Where a diagnosis is, for a progress display (effects are fitted on several threads, so
/// `EffectDone` comes in any order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// The trial is prepared and the base fitted; this many effects follow.
    BaseFitted { effects: usize },
    /// One effect has been fitted and cross-validated on its own.
    EffectDone { effect: &'static str },
    /// The accepted effects are being combined (greedy sequence).
    Combining,
}

/// [`diagnose_with`], telling `progress` where it is.
pub fn diagnose_observed(
    trial: &Trial,
    model: &RobotModel<f64>,
    experiment: Experiment,
    settings: Settings,
    catalog: &[&dyn ModelEffect],
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<(Diagnosis, Vec<ModelFit>), pam_ident::IdentError> {
    let (lp, base, spikes) = loop_without_spikes(trial, model, experiment, settings)?;
    let dynamic = experiment == Experiment::Dynamic;
    let applicable: Vec<&dyn ModelEffect> = catalog
        .iter()
        .copied()
        .filter(|e| e.applies(experiment))
        .filter(|e| dynamic || !e.step_extras().is_empty())
        .collect();
    let judge = Judge::new(&lp, &base, settings, &applicable);
    progress(Progress::BaseFitted {
        effects: applicable.len(),
    });
    // every effect alone against the base, on both cores
    let alone: Vec<(ModelFit, FoldScores)> = {
        use rayon::prelude::*;
        applicable
            .par_iter()
            .map(|e| {
                let f = lp.fit(&[*e]);
                let folds = judge.folds_of(&[*e], &f);
                progress(Progress::EffectDone { effect: e.id() });
                (f, folds)
            })
            .collect()
    };
    progress(Progress::Combining);
    let tried: Vec<Tried> = applicable
        .into_iter()
        .zip(alone)
        .map(|(e, (f, folds))| judge.tried(e, f, folds))
        .collect();
    let reports = best_shape_per_family(tried);
    let ambiguity = judge.ambiguity(&reports);
    let (fits, current, current_fit, refinements) = judge.combine(&reports);
    let structure = super::unexplained::structure(&lp, &current_fit, &settings);
    let unexplained = structure.found;
    let verdict = verdict_of(
        reports.iter().map(|t| &t.report),
        !current.is_empty(),
        &current_fit,
        judge.e_base,
        &unexplained,
    );
    let steps = fits
        .iter()
        .map(|f| StepReport {
            effects: f.effect_ids.clone(),
            nrmse: AxisPair::of(f.nrmse),
        })
        .collect();
    let base_params = base.params.get("base").cloned().unwrap_or_default();
    let mut warnings = base.warnings.clone();
    if let Some(t) = &lp.tare {
        warnings.push(Warning::TareInSensorFrame {
            sensor_n: t.sensor_n,
            turning_rms_n: t.turning_rms_n,
            gain: t.gain,
        });
    }
    if let Some(s) = &spikes {
        warnings.push(s.warning());
    }
    warnings.extend(sampling_warning(&lp));
    // the best shape of each family the log has too few steps to decide on
    let undecided: Vec<Warning> = reports.iter().filter_map(|t| t.undecided.clone()).collect();
    let too_few_steps = undecided
        .iter()
        .filter_map(Warning::steps_to_decide)
        .collect();
    let within_spread = undecided
        .iter()
        .filter_map(Warning::within_spread)
        .collect();
    warnings.extend(undecided);
    warnings.extend(structure.set_aside);
    if dynamic {
        let delay = reports
            .iter()
            .map(|r| &r.report)
            .find(|r| r.family == Some(Family::Delay));
        if let Some(w) = lag_warning(delay) {
            warnings.push(w);
        }
    }
    Ok((
        Diagnosis {
            experiment,
            samples: lp.p.len(),
            sample_period_s: lp.p.dt_s,
            held_out: lp.p.held_out.describe(),
            spikes,
            base: BaseReport {
                nrmse: AxisPair::of(base.nrmse),
                r2: AxisPair::of(base.r2),
                params: base_params,
            },
            verdict,
            effects: reports.into_iter().map(|r| r.report).collect(),
            ambiguous: ambiguity.families,
            separating_experiment: ambiguity.separating_experiment,
            ambiguity_evidence: ambiguity.evidence,
            unexplained,
            steps,
            refinements,
            too_few_steps,
            within_spread,
            warnings,
        },
        fits,
    ))
}

/// What every effect of one diagnosis is judged against: the base, its folds, and the
/// levels of the tests.
struct Judge<'l, 'a> {
    lp: &'l Loop<'a>,
    base: &'l ModelFit,
    settings: Settings,
    dynamic: bool,
    /// The base's held-out relative error.
    e_base: f64,
    /// Independent samples the training residual is worth.
    n_eff: f64,
    /// Independent samples the held-out residual is worth.
    n_eff_test: f64,
    base_folds: FoldScores,
    /// The critical t of the fold test and the level of each family's test.
    t_crit: f64,
    level: f64,
    /// The encoders' rounding in the force (frozen at every rest), drawn when first asked.
    floor: std::sync::OnceLock<Option<super::resolution::EncoderFloor>>,
    /// The share of the step base's held-out error the converters' spread removes, drawn
    /// when first asked.
    spread: std::sync::OnceLock<f64>,
}

impl<'l, 'a> Judge<'l, 'a> {
    fn new(
        lp: &'l Loop<'a>,
        base: &'l ModelFit,
        settings: Settings,
        applicable: &[&dyn ModelEffect],
    ) -> Self {
        let dynamic = lp.experiment == Experiment::Dynamic;
        let held_out: Vec<Vec<f64>> = base
            .axes
            .iter()
            .map(|&a| {
                let r = base.residual(a);
                base.held_out.rows().map(|i| r[i]).collect()
            })
            .collect();
        let mut judge = Judge {
            lp,
            base,
            settings,
            dynamic,
            e_base: base.relative_mse(),
            n_eff: effective_samples(lp, base),
            n_eff_test: effective_samples_of(&held_out),
            base_folds: FoldScores::default(),
            t_crit: 0.0,
            level: 0.0,
            floor: std::sync::OnceLock::new(),
            spread: std::sync::OnceLock::new(),
        };
        judge.base_folds = judge.folds_of(&[], base);
        // the level is split over the candidates the data is asked about: one per family
        let mut families: Vec<String> = applicable.iter().map(|e| family_key(*e)).collect();
        families.sort();
        families.dedup();
        let folds_count = judge.base_folds.sse.len();
        // the level of each family's test (split in half between the t-test and the
        // signed-rank test); with `bonferroni`, the level is split over the families as well
        let split = if settings.bonferroni {
            families.len().max(1)
        } else {
            1
        };
        judge.level = settings.alpha / split as f64;
        judge.t_crit = t_critical(folds_count, settings.alpha / 2.0, split);
        judge
    }

    /// The fold scores of a fit: cross-validated in a dynamic trial, held-out blocks in a
    /// step trial.
    fn folds_of(&self, effects: &[&dyn ModelEffect], f: &ModelFit) -> FoldScores {
        if self.dynamic {
            match effects.split_last() {
                Some((last, fixed)) => self.lp.cv_effect(fixed, *last),
                None => self.lp.cv_dynamic(&[], None),
            }
        } else {
            held_out_blocks(f, STEP_BLOCKS)
        }
    }

    /// One effect alone against the base: its scores, its evidence, and whether it is
    /// accepted.
    fn tried<'e>(&self, e: &'e dyn ModelEffect, f: ModelFit, folds: FoldScores) -> Tried<'e> {
        let (dynamic, settings, t_crit, level) =
            (self.dynamic, &self.settings, self.t_crit, self.level);
        let (n_eff, n_eff_test) = (self.n_eff, self.n_eff_test);
        let test = fold_test(&self.base_folds, &folds, dynamic);
        let held_out_improvement = 1.0 - f.relative_mse() / self.e_base.max(1e-300);
        let improvement = if dynamic {
            test.improvement
        } else {
            held_out_improvement
        };
        let score = improvement - settings.penalty_per_param * f.added_params as f64;
        // the training gain must pass the Bayesian information criterion counted on the
        // effective number of independent residual samples (the residual is
        // autocorrelated: n alone would flatter it)
        let bic =
            n_eff * (1.0 - f.train_gain).max(1e-300).ln() + f.added_params as f64 * n_eff.ln();
        let size = effect_size(self.base, &f);
        let accepted = if dynamic {
            // the cross-validated gain must exceed the fold-to-fold spread at the split
            // level and pay for the parameters it adds; it is material when it changes the
            // prediction by a share of the signal (in a noisy log a real effect removes
            // only a small share of the error)
            test.significant(t_crit, level)
                && score > 0.0
                && f.train_gain > 0.0
                && bic < 0.0
                && size >= settings.min_effect_size
        } else {
            // steps: the training part holds few, strongly autocorrelated step responses
            // and the held-out steps carry the evidence; a step effect often acts on a few
            // steps only (the largest, those of one sign), so the blocks' gains are not
            // alike and the held-out gain decides, by its size or by the BIC on the
            // held-out effective samples
            let held_bic = n_eff_test * (1.0 - improvement).max(1e-300).ln()
                + f.added_params as f64 * n_eff_test.ln();
            (score > settings.min_improvement
                || (improvement > settings.min_significant_improvement && held_bic < 0.0))
                && test.fold_mean > 0.0
                && size >= settings.min_effect_size
        };
        // a delay within the rig's own lag is not told from it
        let lag = if accepted {
            self.within_lag(e, &f)
        } else {
            None
        };
        let accepted = accepted && lag.is_none();
        // a slow change within the encoders' rounding is not told from it
        let rounding = if accepted {
            self.within_rounding(e, &f)
        } else {
            None
        };
        let accepted = accepted && rounding.is_none();
        // nor one within the load cell's coloured noise
        let colour = if accepted {
            self.within_colour(e, &f)
        } else {
            None
        };
        let accepted = accepted && colour.is_none();
        // nor a step family the converters' spread explains as well
        let spread = if accepted {
            self.within_spread(e, &f, improvement)
        } else {
            None
        };
        let accepted = accepted && spread.is_none();
        // steps: a gain the held-out blocks do not show alike, and that is not decisive by
        // its size, is what a rig's step-to-step differences give as often as an effect
        // (pam-physgen's controls; pam-synth's weakest effects look the same): too few
        // steps to decide, said as such. The blocks' test counts only when every block
        // holds a held-out step of its own (three held-out steps cut in six blocks are
        // three pieces of evidence, not six), and a gain decisive by its size must stay so
        // without the block that gains most (one step the base misses badly can carry the
        // whole held-out gain)
        let blocks_own_steps = self.lp.p.held_out.ranges().len() >= STEP_BLOCKS;
        let held_decisive = dynamic
            || (blocks_own_steps && test.significant(t_crit, level))
            || (improvement >= settings.step_decisive_improvement
                && test.improvement_without_best >= settings.step_decisive_improvement);
        // what the held-out steps leave open, all of the log's steps decide, each scored
        // by a fit of the folds that never saw it. The steps of one fold share that fit and
        // every two folds share most of their training steps, so the gains are not
        // independent: the t-test takes `fold_test`'s correction for cross-validated folds
        // (about twice the variance of independent gains). The signed-rank test, its null
        // widened by the same factor, does not decide here: over the steps a family must
        // pass on its mean gain
        let cv = if accepted && !held_decisive {
            self.lp.step_cv(&[e]).map(|(b, w)| fold_test(&b, &w, true))
        } else {
            None
        };
        // (and its gain over every step material by the held-out score's own rule)
        let cv_t_crit = cv.as_ref().map(|t| t_critical(t.folds, level / 2.0, 1));
        let decisive = held_decisive
            || cv.as_ref().zip(cv_t_crit).is_some_and(|(t, crit)| {
                t.improvement - settings.penalty_per_param * f.added_params as f64
                    > settings.min_improvement
                    && t.t >= crit
            });
        let too_few_steps = accepted && !decisive;
        // the warning names a family: an effect outside the catalog's families is refused
        // with its evidence alone
        let undecided = too_few_steps
            .then(|| {
                // the test that left it open: all the steps where they were asked and
                // fell short, else the held-out blocks where those did
                let by = match (&cv, cv_t_crit) {
                    (Some(c), Some(crit)) if c.t < crit || test.t >= t_crit => {
                        (StepTest::AllSteps, c.t, crit)
                    }
                    _ => (StepTest::HeldOutBlocks, test.t, t_crit),
                };
                self.too_few_steps(e, improvement, by)
            })
            .flatten()
            .or_else(|| {
                let share = spread?;
                Some(Warning::WithinConverterSpread {
                    family: e.family()?,
                    improvement,
                    spread_improvement: share.spread,
                    beyond_spread: share.beyond,
                })
            });
        let accepted = accepted && decisive;
        let mut evidence = format!(
            "{}: refitting with it removes {:.1} % of the base model's training residual and {:.1} % of the {} error (fold gains {:.1} ± {:.1} %, t = {:.1} against {:.1}), changing the prediction by {:.2} % of the signal ({} parameter{})",
            e.signature(),
            100.0 * f.train_gain,
            100.0 * improvement,
            if dynamic { "cross-validated" } else { "held-out" },
            100.0 * test.fold_mean,
            100.0 * test.fold_sd,
            test.t,
            if dynamic { t_crit } else { 0.0 },
            100.0 * size,
            f.added_params,
            if f.added_params == 1 { "" } else { "s" },
        );
        if let (Some(t), Some(crit)) = (&cv, cv_t_crit) {
            evidence.push_str(&format!(
                "; cross-validated over its {} steps (each scored by a fit that never saw it): removes {:.1} %, t = {:.1} against {crit:.1}",
                t.folds,
                100.0 * t.improvement,
                t.t
            ));
        }
        if too_few_steps {
            evidence.push_str(&self.too_few_steps_note(
                improvement,
                &test,
                blocks_own_steps,
                undecided.is_some(),
            ));
        }
        if let Some(note) = lag {
            evidence.push_str(&note);
        }
        if let Some(s) = spread {
            evidence.push_str(&format!(
                "; a share of each axis's force in the other (the converters' spread) removes {:.1} %, and with the spread in the base the effect removes {:.1} % of what is left: the log cannot tell it from that spread",
                100.0 * s.spread,
                100.0 * s.beyond.max(0.0)
            ));
        }
        if let Some((change, bound, exponent)) = colour {
            evidence.push_str(&format!(
                "; a slow change of {change:.3} N RMS lies within what the load cell's coloured noise puts in a record's level (its spectrum falls as f^−{exponent:.2} above the slow band; extended below it, a straight line of up to {bound:.3} N RMS at the test's level): the log cannot tell it from that noise"
            ));
        }
        if let Some((change, bound)) = rounding {
            evidence.push_str(&format!(
                "; a slow change of {change:.3} N RMS lies within what the encoders' rounding can put in the force's level (up to {bound:.3} N RMS in {draws} draws of it: it is frozen while a count is held): the log cannot tell it from their rounding",
                draws = super::resolution::DRAWS
            ));
        }
        Tried {
            report: EffectReport {
                id: e
                    .family()
                    .map(|x| x.catalog_id().name())
                    .unwrap_or(e.id())
                    .to_string(),
                family: e.family(),
                shape: e.shape_name().to_string(),
                effect: e.id().to_string(),
                nrmse: AxisPair::of(f.nrmse),
                params: f.params.get(e.id()).cloned().unwrap_or_default(),
                evidence,
                signature: e.signature().to_string(),
                signature_strength: f.train_gain,
                improvement,
                held_out_improvement,
                added_params: f.added_params,
                score,
                effect_size: size,
                folds: test,
                t_critical: if dynamic { t_crit } else { 0.0 },
                accepted,
                other_shapes: Vec::new(),
            },
            effect: e,
            folds,
            fit: accepted.then_some(f),
            alternatives: Vec::new(),
            undecided,
        }
    }

    /// Accepted families the log cannot tell from the first: their fold-by-fold difference
    /// is within the spread, or they remove within `min_family_gain` of the base model's
    /// error of each other (`improvement`: cross-validated, or held out in a step trial).
    /// A gap that small is what a shape outside the catalog of either family could close
    /// (the same margin that keeps a second family out of the final model), so it does not
    /// say which family the log holds: at one stiffness level a joint's friction and the
    /// muscles' hysteresis give the same torque, and whichever catalog shape fits a rig's
    /// form a little better comes first. Returns the families, the experiment that would
    /// separate the first two, and why, in words.
    fn ambiguity(&self, reports: &[Tried]) -> Ambiguity {
        let mut out = Ambiguity::default();
        let Some(top) = reports.first().filter(|t| t.report.accepted) else {
            return out;
        };
        let margin = self.settings.min_family_gain;
        let mut why = Vec::new();
        for other in reports[1..].iter().filter(|t| t.report.accepted) {
            let (Some(fa), Some(fb)) = (top.report.family, other.report.family) else {
                continue;
            };
            let d = paired_test(&self.base_folds, &top.folds, &other.folds, self.dynamic);
            let gap = top.report.improvement - other.report.improvement;
            let within_spread = d.t < self.settings.ambiguity_t;
            if !within_spread && gap >= margin {
                continue;
            }
            if out.families.is_empty() {
                out.families.push(fa);
                out.separating_experiment =
                    Some(effects::separating_experiment(fa, fb).to_string());
            }
            out.families.push(fb);
            let reason = if within_spread {
                format!(
                    "their fold-by-fold difference is within the spread, t = {:.1} against {:.1}",
                    d.t, self.settings.ambiguity_t
                )
            } else {
                format!(
                    "less than the {:.0} % a shape outside the catalog can account for",
                    100.0 * margin
                )
            };
            why.push(format!(
                "{} removes {:.1} % of the base model's error and {} {:.1} %: {:.1} % apart, {reason}",
                fa.name(),
                100.0 * top.report.improvement,
                fb.name(),
                100.0 * other.report.improvement,
                100.0 * gap.max(0.0),
            ));
        }
        if !why.is_empty() {
            out.evidence = Some(why.join("; "));
        }
        out
    }
}
