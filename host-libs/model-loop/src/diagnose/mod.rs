//! The model loop: fit the base model (plus chosen effects), score it on the held-out rows
//! (the last 20 %, or every fifth step of a step trial: [`HeldOut`]),
//! test every catalog effect against the residual and by refitting, rank them by the
//! held-out error they remove (with a penalty per added parameter), and name the residual
//! structure no effect explains.

mod base;
mod colour;
mod compare;
mod cv;
mod decide;
mod diagnosis;
mod dynamic;
mod recording;
mod resolution;
mod selection;
mod settings;
mod sizes;
mod step_fit;
mod tare;
mod tried;
mod unexplained;
mod verdict;
mod warning;
use base::{analysis_stride, choose_pneumatic, BaseVariant, SharedColumns};
pub use base::{joint_stiffness_columns, pneumatic_columns, prepare_with_best_cutoff, Stiffness};
pub use compare::{compare, nrmse_pair, Bin, Comparison, Window};
pub use cv::{FoldScores, FOLDS};
pub use decide::{diagnose, diagnose_observed, diagnose_with, Progress};
pub use diagnosis::{
    BaseReport, Diagnosis, EffectReport, Refinement, ShapeScore, StepReport, StepsToDecide,
    Verdict, WithinSpread,
};
pub use recording::{loop_without_spikes, sampling_warning, SpikeReport};
pub use resolution::{encoder_floor, encoder_step_rad, EncoderFloor};
pub use selection::{fold_test, paired_test, t_critical, FoldTest};
pub use settings::Settings;
use sizes::effective_samples_of;
pub use tare::SensorTare;
pub use unexplained::unexplained_structure;
pub use warning::{StepTest, Warning};

use crate::effects::{Experiment, ModelEffect, Shape};
use crate::response::{Drive, Response};
use pam_ident::held_out::HeldOut;
use pam_ident::msd::{self};
use pam_ident::step::{self, StepParams};
use pam_ident::trial::{Prepared, Trial};
use pam_model::RobotModel;
use pam_numerics::lsq::{self, Column};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct AxisPair {
    pub fx: f64,
    pub fy: f64,
}

impl AxisPair {
    fn of(v: [f64; 2]) -> Self {
        AxisPair { fx: v[0], fy: v[1] }
    }
    fn get(&self, axis: usize) -> f64 {
        if axis == 0 {
            self.fx
        } else {
            self.fy
        }
    }
}

/// A fitted model (base + a set of effects) and its held-out scores.
#[derive(Clone, Debug)]
pub struct ModelFit {
    pub experiment: Experiment,
    pub effect_ids: Vec<String>,
    /// Parameters by effect id ("base" for the base model).
    pub params: BTreeMap<String, BTreeMap<String, f64>>,
    pub added_params: usize,
    pub nrmse: [f64; 2],
    pub r2: [f64; 2],
    /// Axes that carry information (a step axis whose reference never changes does not).
    pub axes: Vec<usize>,
    /// What the model predicts for the measured signal (−f for dynamic, f for step).
    pub measured: [Vec<f64>; 2],
    pub predicted: [Vec<f64>; 2],
    /// Fraction of the training residual sum of squares of the base model this fit removes.
    pub train_gain: f64,
    /// The rows scored and not fitted (the trial's [`Prepared::held_out`]).
    pub held_out: HeldOut,
    pub warnings: Vec<Warning>,
}

impl ModelFit {
    /// The relative held-out MSE, pooled over the informative axes: Σ residual² / Σ
    /// (measured − mean)². Pooled rather than averaged so that an axis that hardly moves in
    /// the held-out part (tiny variance) neither dominates nor vanishes.
    pub fn relative_mse(&self) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        let held = self.held_out.len().max(1) as f64;
        for &a in &self.axes {
            let (m, p) = (&self.measured[a], &self.predicted[a]);
            let mean = self.held_out.rows().map(|i| m[i]).sum::<f64>() / held;
            num += self
                .held_out
                .rows()
                .map(|i| (m[i] - p[i]).powi(2))
                .sum::<f64>();
            den += self
                .held_out
                .rows()
                .map(|i| (m[i] - mean).powi(2))
                .sum::<f64>();
        }
        if den > 0.0 {
            num / den
        } else {
            f64::NAN
        }
    }
    pub fn residual(&self, axis: usize) -> Vec<f64> {
        self.measured[axis]
            .iter()
            .zip(&self.predicted[axis])
            .map(|(m, p)| m - p)
            .collect()
    }
}

/// A trial ready for the loop.
pub struct Loop<'a> {
    pub p: Prepared,
    pub model: &'a RobotModel<f64>,
    pub experiment: Experiment,
    pub settings: Settings,
    /// Shapes per effect id, best first by the training part's criterion (cached).
    shapes: std::sync::Mutex<BTreeMap<&'static str, Vec<Shape>>>,
    /// Blocks and base normals of the cross-validation (dynamic trials).
    cv: std::sync::OnceLock<cv::CvCache>,
    base_step: std::sync::Mutex<Option<(Response, f64)>>,
    /// Step trials: the folds of the cross-validation over steps that decides an effect
    /// the held-out steps alone cannot (see [`Loop::step_cv`]).
    step_folds: Vec<HeldOut>,
    /// The base's scores over those folds, each held-out step apart (computed when first
    /// asked).
    step_cv_base: std::sync::OnceLock<(Vec<Response>, cv::FoldScores)>,
    /// What drives a step trial's model (the converters' set-points, or the reference).
    drive: Option<Drive>,
    /// The variants of the dynamic base model (Cartesian, joint-space or force-law
    /// stiffness, see [`base_columns`]), each without and with the pneumatic regulator
    /// dynamics (ωn rad/s, ζ) that fit it best. Every fit uses the variant that its training
    /// part prefers by the information criterion.
    base_variants: Vec<BaseVariant>,
    step_init: Option<Response>,
    /// Effective number of independent training residual samples of the plain base.
    n_eff: f64,
    /// The base variants alone, ranked (cached, see [`Loop::shortlist`]).
    base_ranking: std::sync::OnceLock<BaseRanking>,
    /// The dynamic fit's target per shift in samples (cached, see [`Loop::target`]).
    targets: std::sync::Mutex<BTreeMap<usize, std::sync::Arc<Target>>>,
    /// The columns a sensor filter's shape filtered (see [`Loop::assemble`]); after its
    /// shapes are ranked, the best shape's corner only.
    lowpassed: std::sync::Mutex<crate::effects::LowpassMemo>,
    /// Lower bounds of the dynamic fits' mass diagonals (kg), see
    /// [`Loop::solve_dynamic`].
    mass_floor_kg: [f64; 2],
    /// The load cell's tare in its own frame, in the dynamic base when the data asks for it
    /// (see [`tare`]).
    pub tare: Option<SensorTare>,
}

/// The base variants alone, best first by the criterion on the training rows.
pub(super) struct BaseRanking {
    /// The variants effects are fitted with, best first.
    pub shortlist: Vec<usize>,
    /// Training RSS of the best variant.
    pub best_rss: f64,
}

/// How many of the base variants (best first for the base alone) effects are fitted with.
const SHORTLIST: usize = 6;

/// A dynamic fit's target (−f), possibly shifted for a delay.
pub(super) struct Target {
    /// (shared: fits keep the right-hand sides they share in a [`lsq::GramMemo`])
    pub y: [std::sync::Arc<Vec<f64>>; 2],
    /// Σ y² over the training rows.
    pub yty_train: f64,
}

/// (columns, effect ranges, positive parameters, the target's shift in samples for a
/// delay, see [`Loop::target`]) of a dynamic fit.
/// The last element is the number of base columns used (the base's force offsets are left
/// out when an effect carries a constant of its own).
type DynColumns = (Vec<Column>, Vec<(usize, usize)>, Vec<usize>, usize, usize);

/// (criterion, variant, columns, effect ranges, θ, training RSS, target shift) of one base
/// variant's fit.
type VariantFit = (
    f64,
    usize,
    Vec<Column>,
    Vec<(usize, usize)>,
    Vec<f64>,
    f64,
    usize,
);

fn held_out_scores(p: &Prepared, y: &[Vec<f64>; 2], pred: &[Vec<f64>; 2]) -> ([f64; 2], [f64; 2]) {
    let (test, _) = msd::scores(p, y, pred);
    ([test[0].nrmse, test[1].nrmse], [test[0].r2, test[1].r2])
}

/// Shortest trial the loop judges: ten contiguous folds of at least
/// [`MIN_SAMPLES_PER_FOLD`] samples and [`MIN_DURATION_S`] in all. Shorter, the fold-to-fold
/// spread is meaningless (a fold of one or two samples has none) and a verdict would be
/// noise dressed as evidence.
pub const MIN_DURATION_S: f64 = 10.0;
/// See [`MIN_DURATION_S`].
pub const MIN_SAMPLES_PER_FOLD: usize = 20;

fn check_long_enough(trial: &Trial) -> Result<(), pam_ident::IdentError> {
    let n = trial.len();
    let duration_s = if n > 1 {
        trial.t_s[n - 1] - trial.t_s[0]
    } else {
        0.0
    };
    let needed = cv::FOLDS * MIN_SAMPLES_PER_FOLD;
    if n < needed || !(duration_s >= MIN_DURATION_S) {
        return Err(pam_ident::IdentError::TooShortToJudge {
            samples: n,
            duration_s,
            needed_samples: needed,
            needed_s: MIN_DURATION_S,
        });
    }
    Ok(())
}

/// A step trial's drive, its base with that base's training residual, and the force the
/// drive commands on each axis.
type ChosenDrive = (Drive, (Response, f64), [Vec<f64>; 2]);

/// The step trial's drive the data prefers, with its fitted base and the force it commands. The converters'
/// set-points (from the currents) are the physical view and the default; the reference
/// drives two force channels instead when that base leaves clearly less training residual
/// (< 90 %): then the model's force law, not a missing effect, is what misfits — e.g. a
/// rig whose muscles deliver the requested force more linearly than eq. 3.1 says — and an
/// effect fitted on the set-points would be compensating for it.
fn choose_drive(
    p: &Prepared,
    model: &RobotModel<f64>,
    init: Response,
    own_lag_s: f64,
) -> Option<ChosenDrive> {
    // every candidate fitted on both cores, then chosen in order
    let fitted: Vec<(f64, Drive, Response, [Vec<f64>; 2])> = Drive::candidates(p, model)
        .into_par_iter()
        .map(|mut d| {
            d.own_lag_s = own_lag_s;
            // the axes the drive commands to move in the training part (as
            // `Loop::stepping_axes` will see them)
            let commanded = [d.commanded(0), d.commanded(1)];
            let rows: Vec<usize> = p.held_out.train_rows().collect();
            let axes: Vec<usize> = (0..2)
                .filter(|&a| step_fit::steps_within(&commanded[a], &rows))
                .collect();
            let (cost, fitted) = step_fit::fit_base(p, &d, &init, &axes);
            (cost, d, fitted, commanded)
        })
        .collect();
    let mut best: Option<(f64, Drive, Response, [Vec<f64>; 2])> = None;
    for (k, candidate) in fitted.into_iter().enumerate() {
        let better = match &best {
            None => true,
            // the first candidate is the physical view: another must beat it clearly
            Some((c, ..)) => k > 0 && candidate.0 < 0.9 * c,
        };
        if better {
            best = Some(candidate);
        }
    }
    best.map(|(cost, d, r, commanded)| (d, (r, cost), commanded))
}

/// The trial as the model loop analyses it ([`Loop::p`]): prepared (for a dynamic trial
/// with the derivative filter's best cutoff) and on the analysis grid. A report of a
/// diagnosis draws the fits over these samples.
pub fn analysis_trial(
    trial: &Trial,
    model: &RobotModel<f64>,
    experiment: Experiment,
    settings: Settings,
) -> Result<Prepared, pam_ident::IdentError> {
    check_long_enough(trial)?;
    let p = prepared_at_log_rate(trial, model, experiment, settings)?;
    Ok(on_analysis_grid(p, experiment, &settings))
}

fn prepared_at_log_rate(
    trial: &Trial,
    model: &RobotModel<f64>,
    experiment: Experiment,
    settings: Settings,
) -> Result<Prepared, pam_ident::IdentError> {
    match experiment {
        Experiment::Dynamic if settings.adapt_cutoff => {
            prepare_with_best_cutoff(trial, model, settings.filter)
        }
        Experiment::Dynamic => trial.prepare(model, settings.filter),
        Experiment::Step => trial.prepare_as_sampled(model, settings.filter),
    }
}

/// Multirate: a trial is filtered (and its steps found) at the log's rate and analysed on a
/// 5 ms grid. A dynamic trial's signals are low-passed far below it and every statistic of
/// the verdict was already computed there; a step trial's model is simulated on every
/// sample of the grid, with the commands averaged over each period.
/// A step trial's held-out rows are chosen on the grid: every fifth step of its reference
/// when it has enough ([`HeldOut::every_fifth_step`]).
fn on_analysis_grid(p: Prepared, experiment: Experiment, settings: &Settings) -> Prepared {
    let stride = analysis_stride(p.dt_s);
    // (stride 1: already on the grid, a slow log or the best cutoff's preparation)
    let mut p = match experiment {
        _ if stride <= 1 => p,
        Experiment::Dynamic => p.every(stride),
        Experiment::Step => p.every_with_mean_commands(stride),
    };
    if let (Experiment::Step, Some(r)) = (experiment, &p.force_ref_n) {
        let (steps, levels) = steps_and_levels(r, settings);
        if let Some(h) = HeldOut::every_fifth_step(&steps, &levels, p.len()) {
            p.held_out = h;
        }
    }
    p
}

/// The reference's steps and each one's level, halfway through it (past a ramp's samples).
fn steps_and_levels(
    r: &[Vec<f64>; 2],
    settings: &Settings,
) -> (Vec<pam_ident::step_detection::ReferenceStep>, Vec<[f64; 2]>) {
    let steps = pam_ident::step_detection::reference_steps(r, settings.step_threshold_n);
    let levels = steps
        .iter()
        .map(|s| [r[0][(s.start + s.end) / 2], r[1][(s.start + s.end) / 2]])
        .collect();
    (steps, levels)
}

impl<'a> Loop<'a> {
    pub fn new(
        trial: &Trial,
        model: &'a RobotModel<f64>,
        experiment: Experiment,
        settings: Settings,
    ) -> Result<Self, pam_ident::IdentError> {
        check_long_enough(trial)?;
        let mut p = prepared_at_log_rate(trial, model, experiment, settings)?;
        if experiment == Experiment::Dynamic {
            p = on_analysis_grid(p, experiment, &settings);
        }
        if experiment == Experiment::Step && p.force_ref_n.is_none() {
            return Err(pam_ident::IdentError::NoForceReference);
        }
        // step trials: graphical starting values from the reference's steps, and the
        // converters' set-points as the model's input (see `response::Drive`)
        let mut step_init = None;
        let mut drive = None;
        let base_step = std::sync::Mutex::new(None);
        let mut step_folds = Vec::new();
        if experiment == Experiment::Step {
            let steps = step::analyse_steps(&p, settings.step_threshold_n);
            let init = [0, 1].map(|a| step::initial_params(&steps, a));
            // one ζ, ωn for the four converters: the graphical estimates of the axes that step
            let moving: Vec<&StepParams> = (0..2)
                .filter(|&a| steps.iter().any(|s| s.axis == a))
                .map(|a| &init[a])
                .collect();
            let avg = |f: &dyn Fn(&StepParams) -> f64, d: f64| {
                if moving.is_empty() {
                    d
                } else {
                    moving.iter().map(|q| f(q)).sum::<f64>() / moving.len() as f64
                }
            };
            step_init = Some(Response::base(
                avg(&|q| q.zeta, 0.7),
                avg(&|q| q.omega_n_rad_s, 20.0),
                [init[0].gain, init[1].gain],
            ));
            // the steps are found at the log's rate, the model fitted on the analysis grid
            p = on_analysis_grid(p, experiment, &settings);
            if let Some(r) = &p.force_ref_n {
                let (steps, levels) = steps_and_levels(r, &settings);
                step_folds = HeldOut::step_folds(&steps, &levels, p.len(), step_fit::STEP_FOLDS);
            }
            let (d, base, commanded) = choose_drive(
                &p,
                model,
                step_init.expect("set above"),
                settings.converter_lag_s,
            )
            .ok_or(pam_ident::IdentError::NoForceReference)?;
            *base_step.lock().expect("base cache") = Some(base);
            // the other views of a step trial (residual spectra, error over the command)
            // use the force the set-points command
            p.force_ref_n = Some(commanded);
            drive = Some(d);
        }
        // the base model's variants: stiffness in Cartesian or joint space, with or without
        // the pneumatic term; every fit (base alone or with effects) uses the variant that
        // its training part prefers by the information criterion
        let (mut base_variants, n_eff) = if experiment == Experiment::Dynamic {
            // the stiffness forms on both cores, kept in their order
            let shared = SharedColumns::of(&p, model);
            let v: Vec<BaseVariant> = Stiffness::ALL
                .par_iter()
                .map(|&stiffness| {
                    let Some((cols, pneumatic)) = choose_pneumatic(&p, model, stiffness, &shared)
                    else {
                        return Vec::new();
                    };
                    let mut plain = cols.clone();
                    plain.truncate(stiffness.plain_len(shared.mass()));
                    let mut forms = vec![(plain, (0.0, 0.0))];
                    if pneumatic.0 > 0.0 {
                        forms.push((cols, pneumatic));
                    }
                    let offset = stiffness.takes_offset();
                    for (cols, _) in &mut forms {
                        if offset {
                            cols.extend(shared.offsets.iter().cloned());
                        }
                    }
                    let y = msd::target(&p);
                    forms
                        .into_iter()
                        .map(|(cols, pneumatic)| {
                            let target = [y[0].as_slice(), y[1].as_slice()];
                            let normal = lsq::normal_equations(&cols, &target, 0..p.split());
                            BaseVariant {
                                cols,
                                offset,
                                tare: false,
                                pneumatic,
                                stiffness,
                                mass: shared.mass(),
                                normal,
                            }
                        })
                        .collect::<Vec<_>>()
                })
                .flatten()
                .collect();
            let y = msd::target(&p);
            let pred = msd::fit_columns(&p, &v[0].cols, &v[0].positive(), &y).1;
            let res: Vec<Vec<f64>> = (0..2)
                .map(|a| (0..p.split()).map(|i| y[a][i] - pred[a][i]).collect())
                .collect();
            (v, effective_samples_of(&res))
        } else {
            (Vec::new(), 0.0)
        };
        let tare = tare::add_tare(&p, model, &mut base_variants, n_eff);
        Ok(Loop {
            step_init,
            drive,
            n_eff,
            base_ranking: Default::default(),
            targets: Default::default(),
            lowpassed: Default::default(),
            mass_floor_kg: if experiment == Experiment::Dynamic {
                model
                    .cartesian_mass(p.alpha0_rad)
                    .map(|m| [m.0[0][0], m.0[1][1]].map(|v| v.max(0.0) * settings.mass_floor_share))
                    .unwrap_or([0.0; 2])
            } else {
                [0.0; 2]
            },
            base_variants,
            tare,
            p,
            model,
            experiment,
            settings,
            shapes: Default::default(),
            cv: Default::default(),
            base_step,
            step_folds,
            step_cv_base: Default::default(),
        })
    }

    /// Fits base + `effects`. Shapes of effects not yet chosen are chosen here (each on its
    /// own with the base, on the training rows).
    pub fn fit(&self, effects: &[&dyn ModelEffect]) -> ModelFit {
        match self.experiment {
            Experiment::Dynamic => self.fit_dynamic(effects),
            Experiment::Step => self.fit_step(effects),
        }
    }
}

// -------------------------------------------------------------------- diagnosis

#[cfg(test)]
mod length_tests {
    use super::*;

    fn still_trial(samples: usize, dt_s: f64) -> Trial {
        let t_s: Vec<f64> = (0..samples).map(|i| i as f64 * dt_s).collect();
        let wiggle: Vec<f64> = t_s.iter().map(|t| 0.01 * (3.0 * t).sin()).collect();
        Trial {
            force_n: [wiggle.clone(), wiggle.clone()],
            alpha_rad: [wiggle.clone(), wiggle],
            t_s,
            force_ref_n: None,
            current_ma: None,
        }
    }

    #[test]
    fn a_trial_too_short_for_the_folds_is_refused_not_judged() {
        let model = RobotModel::<f64>::thesis();
        for (n, dt) in [(30, 0.001), (150, 0.1), (5000, 0.001)] {
            let r = Loop::new(
                &still_trial(n, dt),
                &model,
                Experiment::Dynamic,
                Settings::default(),
            );
            assert!(
                matches!(r, Err(pam_ident::IdentError::TooShortToJudge { .. })),
                "{n} samples every {dt} s"
            );
        }
        // long enough: judged (whatever the verdict)
        let r = Loop::new(
            &still_trial(2000, 0.01),
            &model,
            Experiment::Dynamic,
            Settings::default(),
        );
        assert!(r.is_ok());
    }
}
