//! Fits of step trials: the second-order response of the converters (§5.3) with the
//! effects' extra parameters, on the training part, scored on the held-out part.

use super::held_out_scores;
use super::Loop;
use super::ModelFit;
use crate::effects::Experiment;
use crate::effects::ModelEffect;
use crate::response;
use crate::response::Drive;
use crate::response::Response;
use crate::response::StepExtra;
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
