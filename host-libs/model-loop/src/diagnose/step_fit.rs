//! Fits of step trials: the second-order response of the converters (§5.3) with the
//! effects' extra parameters, on the training part, scored on the held-out part.

use super::cv::{scores_on, FoldScores};
use super::held_out_scores;
use super::Loop;
use super::ModelFit;
use crate::effects::Experiment;
use crate::effects::ModelEffect;
use crate::response;
use crate::response::Drive;
use crate::response::Response;
use crate::response::StepExtra;
use pam_ident::held_out::HeldOut;
use pam_ident::trial::Prepared;
use pam_numerics::stats::std_dev;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The step trial's base on `d`, and its training residual (sum of squares over `axes`).
/// The converters' second order (Table 5.2) was identified end to end, without a dead time;
/// a rig's converter and tube add one of a few milliseconds and the fill of the muscle,
/// which no second order follows. The base is fitted twice, without a dead time and with
/// the converters' own lag (`Drive::own_lag_s`), and keeps the one its training steps
/// prefer: a rig whose converters lag is then not a missing delay, and every effect is
/// fitted over that lag instead of standing in for it.
pub(super) fn fit_base(
    p: &Prepared,
    d: &Drive,
    init: &Response,
    axes: &[usize],
) -> (f64, Response) {
    let mut delays = vec![0.0];
    if d.own_lag_s > 0.0 {
        delays.push(d.own_lag_s);
    }
    let fitted: Vec<(f64, Response)> = delays
        .par_iter()
        .map(|&delay_s| {
            let start = Response { delay_s, ..*init };
            let r = response::fit(p, d, &start, &[], axes, &p.held_out);
            (training_cost(p, d, &r, axes), r)
        })
        .collect();
    // in the candidates' order: the base without a dead time unless the lag fits better
    fitted
        .into_iter()
        .reduce(|best, c| if c.0 < best.0 { c } else { best })
        .expect("one candidate at least")
}

/// Whether the reference `r` moves over `rows`: an axis whose steps all fall in the
/// held-out part (a short log whose last fifth is held out, its axes stepped one after the
/// other) has no gain the training part could fit, and its held-out error would reward any
/// effect that moves its prediction.
pub(super) fn steps_within(r: &[f64], rows: &[usize]) -> bool {
    let values: Vec<f64> = rows.iter().map(|&i| r[i]).collect();
    std_dev(&values) > 1e-9
}

/// Sum of squares of the training residual of `r` over `axes`.
fn training_cost(p: &Prepared, d: &Drive, r: &Response, axes: &[usize]) -> f64 {
    let alpha = [p.alpha_rad[0].as_slice(), p.alpha_rad[1].as_slice()];
    let end = p.held_out.train_end();
    let mut pred = [vec![0.0; end], vec![0.0; end]];
    response::simulate(r, d, &p.t_s, alpha, end, &mut pred);
    axes.iter()
        .map(|&a| {
            p.held_out
                .train_rows()
                .map(|i| (p.force_n[a][i] - pred[a][i]).powi(2))
                .sum::<f64>()
        })
        .sum()
}

/// The effects of `effects` a step trial fits, and their extra parameters (each once).
fn step_extras_of<'e>(
    effects: &[&'e dyn ModelEffect],
) -> (Vec<&'e dyn ModelEffect>, Vec<StepExtra>) {
    let chosen: Vec<&dyn ModelEffect> = effects
        .iter()
        .copied()
        .filter(|e| e.applies(Experiment::Step) && !e.step_extras().is_empty())
        .collect();
    let mut extras: Vec<StepExtra> = Vec::new();
    for e in &chosen {
        for x in e.step_extras() {
            if !extras.contains(x) {
                extras.push(*x);
            }
        }
    }
    (chosen, extras)
}

impl<'a> Loop<'a> {
    /// Axes with a step in the training part (fitted and scored).
    pub(super) fn stepping_axes(&self) -> Vec<usize> {
        let r = self.p.force_ref_n.as_ref().expect("checked in new");
        let rows: Vec<usize> = self.p.held_out.train_rows().collect();
        (0..2).filter(|&a| steps_within(&r[a], &rows)).collect()
    }

    /// The step trial's base and its training residual over the stepping axes (fitted
    /// once, with the drive).
    pub(super) fn base_step_params(&self) -> (Response, f64) {
        let mut cached = self.base_step.lock().expect("base cache");
        if let Some(b) = *cached {
            return b;
        }
        let init = self
            .step_init
            .unwrap_or(Response::base(0.7, 20.0, [1.0, 1.0]));
        let d = self.drive.as_ref().expect("step trials have a drive");
        let axes = self.stepping_axes();
        let r = response::fit(&self.p, d, &init, &[], &axes, &self.p.held_out);
        let fitted = (r, training_cost(&self.p, d, &r, &axes));
        *cached = Some(fitted);
        fitted
    }

    pub(super) fn fit_step(&self, effects: &[&dyn ModelEffect]) -> ModelFit {
        let p = &self.p;
        let d = self.drive.as_ref().expect("step trials have a drive");
        let (base, base_cost) = self.base_step_params();
        let (chosen, extras) = step_extras_of(effects);
        let axes = self.stepping_axes();
        let fitted = if extras.is_empty() {
            base
        } else {
            response::fit(p, d, &base, &extras, &axes, &p.held_out)
        };
        let alpha = [p.alpha_rad[0].as_slice(), p.alpha_rad[1].as_slice()];
        let mut pred = [vec![0.0; p.len()], vec![0.0; p.len()]];
        response::simulate(&fitted, d, &p.t_s, alpha, p.len(), &mut pred);
        let y = p.force_n.clone();
        let (nrmse, r2) = held_out_scores(p, &y, &pred);
        let mut params = BTreeMap::new();
        let axis_name = ["x", "y"];
        let mut b = BTreeMap::new();
        b.insert("zeta".to_string(), base.zeta);
        b.insert("omega_n_rad_s".to_string(), base.omega_n_rad_s);
        if base.delay_s > 0.0 {
            b.insert("own_lag_s".to_string(), base.delay_s);
        }
        for &a in &axes {
            b.insert(format!("gain_{}", axis_name[a]), base.gain[a]);
            b.insert(format!("offset_n_{}", axis_name[a]), base.offset_n[a]);
        }
        params.insert("base".to_string(), b);
        for e in &chosen {
            let m: BTreeMap<String, f64> = e
                .step_extras()
                .iter()
                .flat_map(|x| fitted.extra_params(*x, d.units, &axes))
                .collect();
            params.insert(e.id().to_string(), m);
        }
        let train_gain = if chosen.is_empty() {
            0.0
        } else {
            // the base's own, from the fit that chose it
            let rb = base_cost;
            let re: f64 = axes
                .iter()
                .map(|&a| {
                    p.held_out
                        .train_rows()
                        .map(|i| (y[a][i] - pred[a][i]).powi(2))
                        .sum::<f64>()
                })
                .sum();
            1.0 - re / rb.max(1e-300)
        };
        let added = response::extra_param_count(&extras, &axes);
        ModelFit {
            experiment: Experiment::Step,
            effect_ids: chosen.iter().map(|e| e.id().to_string()).collect(),
            params,
            added_params: added,
            nrmse,
            r2,
            axes,
            measured: y,
            predicted: pred,
            train_gain,
            held_out: p.held_out.clone(),
            warnings: Vec::new(),
        }
    }
}

/// Folds of the cross-validation over steps: each fold fits four steps of every five, as
/// the held-out design does, and all five together score every step.
pub(super) const STEP_FOLDS: usize = 5;

/// The cross-validation over steps is asked only of logs with fewer held-out steps than
/// this: with more, the held-out blocks carry the fold test themselves, and the folds would
/// multiply a long log's fits (the nine-pose step log's) for little.
const STEP_CV_HELD_OUT_BELOW: usize = 10;

/// A held-out step's first row, Σ residual² and Σ (measured − its mean)² over the axes.
type StepScore = (usize, f64, f64);

/// Σ residual² and Σ (measured − mean)² over `axes` on each range of `held_out`, of
/// `r` simulated over the whole trial.
fn per_step_scores(
    p: &Prepared,
    d: &Drive,
    r: &Response,
    axes: &[usize],
    held_out: &HeldOut,
) -> Vec<StepScore> {
    let alpha = [p.alpha_rad[0].as_slice(), p.alpha_rad[1].as_slice()];
    let end = held_out.ranges().last().map_or(0, |x| x.end);
    let mut pred = [vec![0.0; end], vec![0.0; end]];
    response::simulate(r, d, &p.t_s, alpha, end, &mut pred);
    held_out
        .ranges()
        .iter()
        .map(|range| {
            let (sse, sst) = scores_on(&p.force_n, &pred, axes, range.clone());
            (range.start, sse, sst)
        })
        .collect()
}

/// Per-step scores of every fold, in the steps' time order.
fn in_time_order(mut scored: Vec<StepScore>) -> FoldScores {
    scored.sort_by_key(|s| s.0);
    FoldScores {
        sse: scored.iter().map(|s| s.1).collect(),
        sst: scored.iter().map(|s| s.2).collect(),
    }
}

impl<'a> Loop<'a> {
    /// The cross-validation over steps: the scores of the base and of base + `effects`,
    /// each refitted on every fold's training steps, one entry per held-out step in time
    /// order. `None` when the trial has too few steps for the folds. The held-out design
    /// scores a fifth of the steps; a short log's two or three held-out steps cannot show
    /// a gain alike, where all of its steps, each scored by a fit that never saw it, can.
    pub(super) fn step_cv(&self, effects: &[&dyn ModelEffect]) -> Option<(FoldScores, FoldScores)> {
        if self.step_folds.is_empty() || self.p.held_out.ranges().len() >= STEP_CV_HELD_OUT_BELOW {
            return None;
        }
        let p = &self.p;
        let d = self.drive.as_ref().expect("step trials have a drive");
        let axes = self.stepping_axes();
        let (bases, base_scores) = self.step_cv_base.get_or_init(|| {
            let (base, _) = self.base_step_params();
            let fitted: Vec<(Response, Vec<StepScore>)> = self
                .step_folds
                .par_iter()
                .map(|fold| {
                    let r = response::fit(p, d, &base, &[], &axes, fold);
                    (r, per_step_scores(p, d, &r, &axes, fold))
                })
                .collect();
            let scored = fitted.iter().flat_map(|f| f.1.iter().copied()).collect();
            (
                fitted.into_iter().map(|f| f.0).collect(),
                in_time_order(scored),
            )
        });
        let (_, extras) = step_extras_of(effects);
        let scored: Vec<StepScore> = self
            .step_folds
            .par_iter()
            .zip(bases)
            .flat_map(|(fold, base)| {
                let r = response::fit(p, d, base, &extras, &axes, fold);
                per_step_scores(p, d, &r, &axes, fold)
            })
            .collect();
        Some((base_scores.clone(), in_time_order(scored)))
    }
}
