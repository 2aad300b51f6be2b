//! The model loop: fit the base model (plus chosen effects), score it on the held-out 20 %,
//! test every catalog effect against the residual and by refitting, rank them by the
//! held-out error they remove (with a penalty per added parameter), and name the residual
//! structure no effect explains.

mod compare;
mod cv;
mod decide;
mod selection;
mod unexplained;
pub use compare::*;
pub use cv::{FoldScores, FOLDS};
pub use decide::*;
pub use selection::{fold_test, paired_test, t_critical, FoldTest};
pub use unexplained::*;

use crate::effects::{DynCtx, DynTerm, Experiment, Family, ModelEffect, Shape};
use crate::lsq::{self, Column};
use crate::msd::{self, MSD_POSITIVE};
use crate::response::{self, Drive, Response, StepExtra};
use crate::spectrum::{amplitude_spectrum, narrow_peaks};
use crate::step::{self, StepParams};
use crate::trial::{rms, std_dev, FilterSettings, Prepared, Trial};
use pam_model::RobotModel;
use serde::Serialize;
use std::collections::BTreeMap;

/// Knobs of the loop, with defaults chosen for generality (see docs/model-loop.md).
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub filter: FilterSettings,
    /// An effect must remove at least this share of the held-out error (relative MSE)...
    pub min_improvement: f64,
    /// ...after subtracting this much per parameter it adds.
    pub penalty_per_param: f64,
    /// An effect must change the held-out prediction by at least this share of the
    /// measured signal's spread: a statistically clear but physically negligible correction
    /// (a few hundredths of a newton of model bias) is not a missing effect.
    pub min_effect_size: f64,
    /// Below `min_improvement`, an effect still counts when it removes at least this share
    /// and its held-out gain passes the BIC on the held-out part's effective samples.
    pub min_significant_improvement: f64,
    /// Step detection threshold |ΔF| (§5.3).
    pub step_threshold_n: f64,
    /// Spectral peaks: power ≥ this × the local median...
    pub peak_prominence: f64,
    /// ...carrying at least this share of the residual variance.
    pub peak_min_share: f64,
    /// Slow wander of the residual: share of its variance in 20 time-bin means.
    pub structure_min_share: f64,
    /// Level of the fold test that accepts a family (half for the t-test, half for the
    /// sign test). Calibrated on the controls of two generators (docs/model-loop.md).
    pub alpha: f64,
    /// Split `alpha` over the families tested (Bonferroni) as well.
    pub bonferroni: bool,
    /// Two families whose fold-by-fold difference has |t| below this are reported as
    /// ambiguous.
    pub ambiguity_t: f64,
    /// Dynamic trials: try the derivative filter at 1, 0.6 and 0.4 × its cutoff and keep
    /// the one whose plain base fits the training part best (see
    /// [`prepare_with_best_cutoff`]).
    pub adapt_cutoff: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            filter: FilterSettings::default(),
            min_improvement: 0.01,
            penalty_per_param: 0.001,
            min_effect_size: 0.005,
            min_significant_improvement: 0.002,
            step_threshold_n: 3.0,
            peak_prominence: 40.0,
            peak_min_share: 0.03,
            structure_min_share: 0.2,
            alpha: 0.05,
            bonferroni: false,
            ambiguity_t: 2.0,
            adapt_cutoff: true,
        }
    }
}

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
    /// First held-out sample.
    pub split: usize,
    pub warnings: Vec<String>,
}

impl ModelFit {
    /// The relative held-out MSE, pooled over the informative axes: Σ residual² / Σ
    /// (measured − mean)². Pooled rather than averaged so that an axis that hardly moves in
    /// the held-out part (tiny variance) neither dominates nor vanishes.
    pub fn relative_mse(&self) -> f64 {
        let (mut num, mut den) = (0.0, 0.0);
        for &a in &self.axes {
            let m = &self.measured[a][self.split..];
            let p = &self.predicted[a][self.split..];
            let mean = m.iter().sum::<f64>() / m.len().max(1) as f64;
            num += m.iter().zip(p).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
            den += m.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
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
    base_step: std::sync::Mutex<Option<Response>>,
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
    /// Σ y² over the training rows (dynamic trials).
    yty_train: f64,
    /// Training RSS of the base alone, with the variant it prefers (cached).
    base_rss: std::sync::OnceLock<f64>,
}

/// (columns, effect ranges, positive parameters, base columns shifted by a delay) of a
/// dynamic fit.
/// The last element is the number of base columns used (the base's force offsets are left
/// out when an effect carries a constant of its own).
type DynColumns = (Vec<Column>, Vec<(usize, usize)>, Vec<usize>, bool, usize);

/// (criterion, variant, columns, effect ranges, θ, training RSS) of one base variant's fit.
type VariantFit = (f64, usize, Vec<Column>, Vec<(usize, usize)>, Vec<f64>, f64);

struct BaseVariant {
    /// The base columns; with `offset`, the last two are a constant force per axis.
    cols: Vec<Column>,
    offset: bool,
    pneumatic: (f64, f64),
    stiffness: Stiffness,
    /// Normal equations of `cols` on the training rows, every row and every
    /// [`shape_stride`]-th: shared by every fit with this variant.
    normal: lsq::Normal,
    normal_strided: lsq::Normal,
}

impl BaseVariant {
    /// Parameters kept ≥ 0: the stiffness form's. (The pneumatic term's sign is left
    /// free: on the twin the converters' regulation makes the force lag the motion, a
    /// negative effective damping that only a negative term describes. A pure delay is then
    /// partly absorbed by it too; the delay family must beat it fold by fold.)
    fn positive(&self) -> Vec<usize> {
        self.stiffness.positive().to_vec()
    }
}

/// Prepares a dynamic trial with the derivative filter's cutoff that suits its data: the
/// velocities and accelerations come from differentiated encoder angles, and a coarse
/// encoder (8000 counts a turn) sampled every 10 ms puts quantisation noise between the
/// operator's motion (≲ 3 Hz) and 8 Hz that the mass and damping terms turn into a
/// deterministic misfit, which effects then "explain". The cutoff is one of 1, 0.6 and
/// 0.4 × the setting, the one with the smallest training residual of the plain
/// mass-spring-damper (the force itself is not filtered, so the residuals compare; a
/// cutoff below the motion's band raises it).
pub fn prepare_with_best_cutoff(
    trial: &Trial,
    model: &RobotModel<f64>,
    filter: FilterSettings,
) -> Result<Prepared, String> {
    let mut best: Option<(f64, Prepared)> = None;
    for f in [1.0, 0.6, 0.4] {
        let settings = FilterSettings {
            cutoff_hz: filter.cutoff_hz * f,
            ..filter
        };
        let p = trial.prepare(model, settings)?;
        let y = msd::target(&p);
        let mut cols = msd::msd_columns(&p);
        cols.extend(offset_columns(p.len()));
        let ne = lsq::normal_equations(&cols, &[&y[0], &y[1]], 0..p.split);
        let th = lsq::solve(&ne, &MSD_POSITIVE);
        let yty: f64 = (0..2)
            .map(|a| y[a][..p.split].iter().map(|v| v * v).sum::<f64>())
            .sum();
        let rss = lsq::rss(&ne, yty, &th);
        // a lower cutoff must gain more than rounding
        if best.as_ref().is_none_or(|b| rss < 0.995 * b.0) {
            best = Some((rss, p));
        }
    }
    Ok(best.expect("three cutoffs").1)
}

/// A constant force per axis (the parameter is the offset of the measured f; the columns
/// are in −f).
fn offset_columns(n: usize) -> [Column; 2] {
    [
        Column::on("offset_n_x", 0, vec![-1.0; n]),
        Column::on("offset_n_y", 1, vec![-1.0; n]),
    ]
}

/// Row stride of the cheap fits that choose shape parameters (5 ms).
fn shape_stride(dt_s: f64) -> usize {
    ((0.005 / dt_s).floor() as usize).max(1)
}

/// Σ y² of both axes over the first `rows` samples, every `stride`-th one.
fn strided_sum_of_squares(y: &[Vec<f64>; 2], rows: usize, stride: usize) -> f64 {
    y.iter()
        .map(|axis| {
            axis[..rows]
                .iter()
                .step_by(stride)
                .map(|v| v * v)
                .sum::<f64>()
        })
        .sum()
}

/// How the dynamic base model's restoring force is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stiffness {
    /// A symmetric K on the handle displacement (eq. 4.29 as printed), 3 parameters.
    Cartesian,
    /// A symmetric joint-space K on the angle changes, through J⁻ᵀ, 3 parameters.
    Joint,
    /// The model's muscle force law (eq. 3.1 through the joint pair) at the logged angles
    /// and the pressures of the logged currents, minus its value at the start of the trial,
    /// one gain per joint: 2 parameters. Needs the currents.
    ForceLaw,
    /// The same without subtracting the start: the model's own equilibrium (zero torque)
    /// instead of where the trial starts, which the hand need not hold force-free. Right
    /// when the model's torque is right in absolute terms (a constant on the load cell is
    /// then not taken for a preload); the BIC tells.
    ForceLawAbsolute,
    /// `ForceLaw` and the muscles' torque where the trial starts, one constant torque per
    /// joint (a preload, or the equilibrium shift of an effect that counts from the neutral
    /// pose): 4 parameters.
    ForceLawWithPreload,
}

impl Stiffness {
    pub const ALL: [Stiffness; 5] = [
        Stiffness::Cartesian,
        Stiffness::Joint,
        Stiffness::ForceLaw,
        Stiffness::ForceLawAbsolute,
        Stiffness::ForceLawWithPreload,
    ];

    /// Number of base columns without the pneumatic term (M, B and the stiffness).
    pub fn plain_len(self) -> usize {
        match self {
            Stiffness::ForceLaw | Stiffness::ForceLawAbsolute => 8,
            Stiffness::ForceLawWithPreload => 10,
            _ => 9,
        }
    }

    /// Base parameters kept ≥ 0: the mass and damping diagonals and the stiffness
    /// diagonals (or force-law gains). A negative mass is how a least-squares fit absorbs a
    /// force that lags the motion (f(t − τ) ≈ f − τ ḟ turns B into a negative mass): kept
    /// physical, the base leaves a delay for the delay family to show.
    pub fn positive(self) -> [usize; 6] {
        match self {
            Stiffness::ForceLaw | Stiffness::ForceLawAbsolute | Stiffness::ForceLawWithPreload => {
                [0, 2, 3, 5, 6, 7]
            }
            _ => {
                let [b1, b2, k1, k2] = MSD_POSITIVE;
                [0, 2, b1, b2, k1, k2]
            }
        }
    }

    /// Whether the base carries a constant force per axis: the trial's equilibrium is known
    /// only to an encoder count and the load cell's tare only to its drift, so a constant
    /// force is part of the base, not a missing effect (the preload form has its own).
    fn takes_offset(self) -> bool {
        self != Stiffness::ForceLawWithPreload
    }

    /// Whether the pneumatic term is written in joint space.
    fn joint_space(self) -> bool {
        self != Stiffness::Cartesian
    }

    pub fn name(self) -> &'static str {
        match self {
            Stiffness::Cartesian => "cartesian",
            Stiffness::Joint => "joint",
            Stiffness::ForceLaw => "force_law",
            Stiffness::ForceLawAbsolute => "force_law_absolute",
            Stiffness::ForceLawWithPreload => "force_law_with_preload",
        }
    }
}

fn held_out_scores(p: &Prepared, y: &[Vec<f64>; 2], pred: &[Vec<f64>; 2]) -> ([f64; 2], [f64; 2]) {
    let (test, _) = msd::scores(p, y, pred);
    ([test[0].nrmse, test[1].nrmse], [test[0].r2, test[1].r2])
}

impl<'a> Loop<'a> {
    pub fn new(
        trial: &Trial,
        model: &'a RobotModel<f64>,
        experiment: Experiment,
        settings: Settings,
    ) -> Result<Self, String> {
        let mut p = if experiment == Experiment::Dynamic && settings.adapt_cutoff {
            prepare_with_best_cutoff(trial, model, settings.filter)?
        } else {
            trial.prepare(model, settings.filter)?
        };
        if experiment == Experiment::Step && p.force_ref_n.is_none() {
            return Err(
                "a step experiment needs the force reference columns fx_ref_n, fy_ref_n".into(),
            );
        }
        // step trials: graphical starting values from the reference's steps, and the
        // converters' set-points as the model's input (see `response::Drive`)
        let mut step_init = None;
        let mut drive = None;
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
            let d = Drive::new(&p, model).expect("checked above");
            // the other views of a step trial (residual spectra, error over the command)
            // use the force the set-points command
            p.force_ref_n = Some([d.commanded(0), d.commanded(1)]);
            drive = Some(d);
        }
        // the base model's variants: stiffness in Cartesian or joint space, with or without
        // the pneumatic term; every fit (base alone or with effects) uses the variant that
        // its training part prefers by the information criterion
        let (base_variants, n_eff) = if experiment == Experiment::Dynamic {
            let mut v = Vec::new();
            for stiffness in Stiffness::ALL {
                let Some((cols, pneumatic)) = choose_pneumatic(&p, model, stiffness) else {
                    continue;
                };
                let mut plain = cols.clone();
                plain.truncate(stiffness.plain_len());
                let mut forms = vec![(plain, (0.0, 0.0))];
                if pneumatic.0 > 0.0 {
                    forms.push((cols, pneumatic));
                }
                let offset = stiffness.takes_offset();
                for (cols, _) in &mut forms {
                    if offset {
                        cols.extend(offset_columns(p.len()));
                    }
                }
                let y = msd::target(&p);
                for (cols, pneumatic) in forms {
                    let target = [y[0].as_slice(), y[1].as_slice()];
                    let normal = lsq::normal_equations(&cols, &target, 0..p.split);
                    let normal_strided = lsq::normal_equations_strided(
                        &cols,
                        &target,
                        0..p.split,
                        shape_stride(p.dt_s),
                    );
                    v.push(BaseVariant {
                        cols,
                        offset,
                        pneumatic,
                        stiffness,
                        normal,
                        normal_strided,
                    });
                }
            }
            let y = msd::target(&p);
            let pred = msd::fit_columns(&p, &v[0].cols, &v[0].positive(), &y).1;
            let res: Vec<Vec<f64>> = (0..2)
                .map(|a| (0..p.split).map(|i| y[a][i] - pred[a][i]).collect())
                .collect();
            (v, effective_samples_of(&res))
        } else {
            (Vec::new(), 0.0)
        };
        let yty_train = if experiment == Experiment::Dynamic {
            let y = msd::target(&p);
            (0..2)
                .map(|a| y[a][..p.split].iter().map(|v| v * v).sum::<f64>())
                .sum()
        } else {
            0.0
        };
        Ok(Loop {
            step_init,
            drive,
            n_eff,
            yty_train,
            base_rss: Default::default(),
            base_variants,
            p,
            model,
            experiment,
            settings,
            shapes: Default::default(),
            cv: Default::default(),
            base_step: Default::default(),
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

    // ---------------------------------------------------------------- dynamic trials

    fn dyn_columns(
        &self,
        ctx: &DynCtx,
        variant: usize,
        effects: &[(&dyn ModelEffect, Shape)],
    ) -> Option<DynColumns> {
        let terms: Vec<DynTerm> = effects
            .iter()
            .map(|(e, s)| e.dynamic_term(ctx, s))
            .collect();
        self.assemble(variant, &terms)
    }

    /// The columns of a fit with variant `variant` and the effects' terms (computed once and
    /// shared by every variant: their columns are shared, not copied).
    fn assemble(&self, variant: usize, terms: &[DynTerm]) -> Option<DynColumns> {
        let bv = &self.base_variants[variant];
        let preload = bv.stiffness == Stiffness::ForceLawWithPreload;
        // an effect's own constant (an offset, an equilibrium shift) replaces the base's
        let nb = bv.cols.len()
            - if bv.offset && terms.iter().any(|t| t.carries_constant) {
                2
            } else {
                0
            };
        let base_cols = &bv.cols[..nb];
        let mut positive: Vec<usize> = self.base_variants[variant].positive();
        let mut delay = 0.0f64;
        let mut extra = Vec::new();
        let mut ranges = Vec::new();
        for term in terms {
            let term = term.clone();
            if preload && term.carries_constant {
                return None;
            }
            delay = delay.max(term.base_delay_s);
            let start = nb + extra.len();
            positive.extend(term.positive.iter().map(|i| start + i));
            extra.extend(term.columns);
            ranges.push((start, nb + extra.len()));
        }
        let mut cols = base_cols.to_vec();
        if delay > 0.0 {
            let d = delay / self.p.dt_s;
            let (whole, frac) = (d.floor() as usize, d - d.floor());
            for c in &mut cols {
                for v in c.axis.iter_mut().flatten() {
                    let shifted: Vec<f64> = (0..v.len())
                        .map(|i| {
                            let a = v[i.saturating_sub(whole)];
                            let b = v[i.saturating_sub(whole + 1)];
                            a * (1.0 - frac) + b * frac
                        })
                        .collect();
                    *v = std::sync::Arc::new(shifted);
                }
            }
        }
        cols.extend(extra);
        Some((cols, ranges, positive, delay > 0.0, nb))
    }

    /// Information criterion of a fit of `ncols` columns with variant `v`: the pneumatic
    /// variants count one more parameter for their chosen dynamics.
    fn criterion(&self, rss: f64, ncols: usize, v: usize) -> f64 {
        let k = ncols + usize::from(self.base_variants[v].pneumatic.0 > 0.0);
        let n = self.n_eff.max(10.0);
        n * rss.max(1e-300).ln() + k as f64 * n.ln()
    }

    fn choose_shape(&self, ctx: &DynCtx, e: &dyn ModelEffect, y: &[Vec<f64>; 2]) -> Shape {
        self.ranked_shapes(ctx, e, y)
            .into_iter()
            .next()
            .unwrap_or_default()
    }

    /// The effect's shapes, best first by the information criterion of a fit on every
    /// `shape_stride`-th training row (each with the base variant it fits best).
    fn ranked_shapes(&self, ctx: &DynCtx, e: &dyn ModelEffect, y: &[Vec<f64>; 2]) -> Vec<Shape> {
        if let Some(s) = self.shapes.lock().expect("shape cache").get(e.id()) {
            return s.clone();
        }
        let shapes = e.shapes(ctx);
        let ranked = if shapes.len() <= 1 {
            if shapes.is_empty() {
                vec![Shape::default()]
            } else {
                shapes
            }
        } else {
            let stride = shape_stride(self.p.dt_s);
            let rows = 0..self.p.split;
            let yty = strided_sum_of_squares(y, self.p.split, stride);
            let mut scored: Vec<(f64, Shape)> = Vec::new();
            for s in shapes {
                let term = [e.dynamic_term(ctx, &s)];
                let mut best = f64::INFINITY;
                for v in 0..self.base_variants.len() {
                    let Some((cols, _, positive, shifted, nb)) = self.assemble(v, &term) else {
                        continue;
                    };
                    let target = [y[0].as_slice(), y[1].as_slice()];
                    let ne = if shifted {
                        lsq::normal_equations_strided(&cols, &target, rows.clone(), stride)
                    } else {
                        let known = &self.base_variants[v].normal_strided.prefix(nb);
                        lsq::normal_equations_extended(known, &cols, &target, rows.clone(), stride)
                    };
                    let th = lsq::solve(&ne, &positive);
                    let r = self.criterion(lsq::rss(&ne, yty, &th) * stride as f64, cols.len(), v);
                    best = best.min(r);
                }
                scored.push((best, s));
            }
            scored.sort_by(|a, b| a.0.total_cmp(&b.0));
            scored.into_iter().map(|x| x.1).collect()
        };
        self.shapes
            .lock()
            .expect("shape cache")
            .insert(e.id(), ranked.clone());
        ranked
    }

    /// Normal equations of a fit with variant `v` on the training rows (the base part from
    /// the variant's cache unless the effects shifted the base columns).
    fn training_normal(
        &self,
        v: usize,
        cols: &[Column],
        shifted: bool,
        base_len: usize,
        y: &[Vec<f64>; 2],
    ) -> lsq::Normal {
        let target = [y[0].as_slice(), y[1].as_slice()];
        if shifted {
            lsq::normal_equations(cols, &target, 0..self.p.split)
        } else {
            let known = &self.base_variants[v].normal.prefix(base_len);
            lsq::normal_equations_extended(known, cols, &target, 0..self.p.split, 1)
        }
    }

    /// Training RSS of the base alone with the variant it prefers.
    fn base_alone_rss(&self) -> f64 {
        *self.base_rss.get_or_init(|| {
            (0..self.base_variants.len())
                .map(|v| {
                    let bv = &self.base_variants[v];
                    let th = lsq::solve(&bv.normal, &bv.positive());
                    let r = lsq::rss(&bv.normal, self.yty_train, &th);
                    (self.criterion(r, bv.cols.len(), v), r)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map(|x| x.1)
                .unwrap_or(f64::INFINITY)
        })
    }

    fn fit_dynamic(&self, effects: &[&dyn ModelEffect]) -> ModelFit {
        let p = &self.p;
        let ctx = DynCtx::new(p, self.model);
        let y = msd::target(p);
        let chosen: Vec<(&dyn ModelEffect, Shape)> = effects
            .iter()
            .filter(|e| e.applies(Experiment::Dynamic))
            .map(|e| (*e, self.choose_shape(&ctx, *e, &y)))
            .collect();
        // every base variant; keep the one the training part prefers
        let mut best: Option<VariantFit> = None;
        for v in 0..self.base_variants.len() {
            let Some((cols, ranges, positive, shifted, nb)) = self.dyn_columns(&ctx, v, &chosen)
            else {
                continue;
            };
            let ne = self.training_normal(v, &cols, shifted, nb, &y);
            let theta = lsq::solve(&ne, &positive);
            let r = lsq::rss(&ne, self.yty_train, &theta);
            let c = self.criterion(r, cols.len(), v);
            if best.as_ref().is_none_or(|b| c < b.0) {
                best = Some((c, v, cols, ranges, theta, r));
            }
        }
        let (_, variant, cols, ranges, theta, fit_rss) = best.expect("variants");
        let pred = lsq::predict(&cols, &theta, p.len());
        let bv = &self.base_variants[variant];
        let (nrmse, r2) = held_out_scores(p, &y, &pred);
        let mut params = BTreeMap::new();
        // the base's columns end where the first effect's begin
        let nb = ranges.first().map(|r| r.0).unwrap_or(cols.len());
        let mut base: BTreeMap<String, f64> = cols[..nb]
            .iter()
            .zip(&theta)
            .map(|(c, t)| (c.name.clone(), *t))
            .collect();
        base.insert("derivative_cutoff_hz".into(), p.cutoff_hz);
        base.insert("pneumatic_omega_n_rad_s".into(), bv.pneumatic.0);
        base.insert("pneumatic_zeta".into(), bv.pneumatic.1);
        base.insert(
            "joint_space_stiffness".into(),
            if bv.stiffness == Stiffness::Joint {
                1.0
            } else {
                0.0
            },
        );
        let force_law = matches!(
            bv.stiffness,
            Stiffness::ForceLaw | Stiffness::ForceLawAbsolute | Stiffness::ForceLawWithPreload
        );
        base.insert(
            "force_law_stiffness".into(),
            if force_law { 1.0 } else { 0.0 },
        );
        if force_law {
            base.insert(
                "force_law_from_start".into(),
                if bv.stiffness == Stiffness::ForceLawAbsolute {
                    0.0
                } else {
                    1.0
                },
            );
        }
        params.insert("base".to_string(), base);
        let mut added = 0;
        for ((e, s), (a, b)) in chosen.iter().zip(&ranges) {
            let fitted: Vec<(String, f64)> = cols[*a..*b]
                .iter()
                .zip(&theta[*a..*b])
                .map(|(c, t)| (c.name.clone(), *t))
                .collect();
            added += (b - a) + s.0.len();
            params.insert(
                e.id().to_string(),
                e.report_params(&ctx, &fitted, s).into_iter().collect(),
            );
        }
        let warnings = msd::mass_warnings(
            &msd::sym(&theta[0..3]),
            self.model.cartesian_mass(p.alpha0_rad),
        );
        let train_gain = if chosen.is_empty() {
            0.0
        } else {
            // against the base alone, with the variant the base alone prefers
            1.0 - fit_rss / self.base_alone_rss().max(1e-300)
        };
        ModelFit {
            experiment: Experiment::Dynamic,
            effect_ids: chosen.iter().map(|(e, _)| e.id().to_string()).collect(),
            params,
            added_params: added,
            nrmse,
            r2,
            axes: vec![0, 1],
            measured: y,
            predicted: pred,
            train_gain,
            split: p.split,
            warnings,
        }
    }

    // ---------------------------------------------------------------- step trials

    /// Axes scored in a step trial: those whose reference steps in the held-out part (the
    /// NRMSE of an axis that only holds still measures noise), else those that step at all.
    #[allow(dead_code)]
    fn step_axes(&self) -> Vec<usize> {
        let r = self.p.force_ref_n.as_ref().expect("checked in new");
        let s = self.p.split;
        let held: Vec<usize> = (0..2).filter(|&a| std_dev(&r[a][s..]) > 1e-9).collect();
        if !held.is_empty() {
            return held;
        }
        (0..2).filter(|&a| std_dev(&r[a]) > 1e-9).collect()
    }

    /// Axes with any step (fitted).
    fn stepping_axes(&self) -> Vec<usize> {
        let r = self.p.force_ref_n.as_ref().expect("checked in new");
        (0..2).filter(|&a| std_dev(&r[a]) > 1e-9).collect()
    }

    fn base_step_params(&self) -> Response {
        let mut cached = self.base_step.lock().expect("base cache");
        if let Some(b) = *cached {
            return b;
        }
        let init = self
            .step_init
            .unwrap_or(Response::base(0.7, 20.0, [1.0, 1.0]));
        let d = self.drive.as_ref().expect("step trials have a drive");
        let fitted = response::fit(&self.p, d, &init, &[], &self.stepping_axes(), self.p.split);
        *cached = Some(fitted);
        fitted
    }

    fn fit_step(&self, effects: &[&dyn ModelEffect]) -> ModelFit {
        let p = &self.p;
        let d = self.drive.as_ref().expect("step trials have a drive");
        let base = self.base_step_params();
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
            response::fit(p, d, &base, &extras, &axes, p.split)
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
        let train = |pr: &[Vec<f64>; 2], a: usize| {
            (0..p.split)
                .map(|i| (y[a][i] - pr[a][i]).powi(2))
                .sum::<f64>()
        };
        let train_gain = if chosen.is_empty() {
            0.0
        } else {
            let mut bp = [vec![0.0; p.len()], vec![0.0; p.len()]];
            response::simulate(&base, d, &p.t_s, alpha, p.len(), &mut bp);
            let rb: f64 = axes.iter().map(|&a| train(&bp, a)).sum();
            let re: f64 = axes.iter().map(|&a| train(&pred, a)).sum();
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
            split: p.split,
            warnings: Vec::new(),
        }
    }
}

pub(crate) fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let (ma, mb) = (
        a.iter().sum::<f64>() / a.len() as f64,
        b.iter().sum::<f64>() / b.len() as f64,
    );
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
}

/// The pneumatic compliance of the muscles: when the handle moves, each muscle's volume
/// changes and its pressure with it, until the I/P converter — a second-order regulator
/// (Table 5.2) — restores it. The pressure (so the force) deviation is the displacement
/// through the regulator's high-pass, Δx − LP₂(Δx) with LP₂ = ωn²/(s² + 2ζωn s + ωn²),
/// times a symmetric matrix: three more regressors of the base model. On a rig (or a
/// simulator) without this, their coefficients simply come out near zero.
pub fn pneumatic_columns(
    p: &Prepared,
    ctx: &DynCtx,
    joint_space: bool,
    omega_n: f64,
    zeta: f64,
) -> Vec<Column> {
    let sp = StepParams::base(1.0, zeta, omega_n);
    let n = p.len();
    let mut h = [vec![0.0; n], vec![0.0; n]];
    for j in 0..2 {
        let d: Vec<f64> = if joint_space {
            p.alpha_smooth_rad[j]
                .iter()
                .map(|a| a - p.alpha0_rad[j])
                .collect()
        } else {
            p.dx_m[j].clone()
        };
        let mut lp = vec![0.0; n];
        step::simulate(&sp, &p.t_s, &d, d[0], &mut lp);
        for i in 0..n {
            h[j][i] = d[i] - lp[i];
        }
    }
    if joint_space {
        return joint_stiffness_columns(ctx, &h, "kp");
    }
    vec![
        Column::on("kp_xx", 0, h[0].clone()),
        Column::both("kp_xy", h[1].clone(), h[0].clone()),
        Column::on("kp_yy", 1, h[1].clone()),
    ]
}

/// A symmetric joint-space stiffness acting on joint-angle signals `d` (per joint), as
/// handle forces: −f = J⁻ᵀ K_j d. Working in joint space keeps the curvature of the
/// kinematics (J changes with the pose) out of the residual.
pub fn joint_stiffness_columns(ctx: &DynCtx, d: &[Vec<f64>; 2], prefix: &str) -> Vec<Column> {
    vec![
        ctx.torque_column(&format!("{prefix}_11"), |i| [-d[0][i], 0.0]),
        ctx.torque_column(&format!("{prefix}_12"), |i| [-d[1][i], -d[0][i]]),
        ctx.torque_column(&format!("{prefix}_22"), |i| [0.0, -d[1][i]]),
    ]
}

/// The loop's base model for dynamic trials: eq. 4.29's M and B in Cartesian coordinates,
/// the stiffness in Cartesian coordinates (eq. 4.29 as printed), in joint space (the
/// muscles act on the joints: the kinematics' curvature is then the model's, not an error)
/// or as the model's muscle force law with a gain per joint, from the trial's start or
/// absolute (its curvature away from the neutral pose is then the model's too) — whichever the training part prefers — and the
/// pneumatic compliance. `None` when the variant needs what the log lacks (currents).
pub fn base_columns(
    p: &Prepared,
    ctx: &DynCtx,
    stiffness: Stiffness,
    omega_n: f64,
    zeta: f64,
) -> Option<Vec<Column>> {
    let mut cols = msd::msd_columns(p);
    match stiffness {
        Stiffness::Cartesian => {}
        Stiffness::Joint => {
            let da = [0, 1].map(|j| {
                p.alpha_smooth_rad[j]
                    .iter()
                    .map(|a| a - p.alpha0_rad[j])
                    .collect::<Vec<f64>>()
            });
            cols.truncate(6);
            cols.extend(joint_stiffness_columns(ctx, &da, "kj"));
        }
        Stiffness::ForceLaw | Stiffness::ForceLawAbsolute | Stiffness::ForceLawWithPreload => {
            let from_start = stiffness != Stiffness::ForceLawAbsolute;
            let law = crate::effects::force_law_columns(ctx, from_start)?;
            cols.truncate(6);
            cols.extend(law);
            if stiffness == Stiffness::ForceLawWithPreload {
                // the muscles' torque where the trial starts, as a constant joint torque
                cols.push(ctx.torque_column("start_torque_nm_joint1", |_| [1.0, 0.0]));
                cols.push(ctx.torque_column("start_torque_nm_joint2", |_| [0.0, 1.0]));
            }
        }
    }
    if omega_n > 0.0 {
        cols.extend(pneumatic_columns(
            p,
            ctx,
            stiffness.joint_space(),
            omega_n,
            zeta,
        ));
    }
    Some(cols)
}

/// The base columns with the regulator dynamics that fit the training part best, from a
/// small grid around the robot's I/P converter (Table 5.2).
fn choose_pneumatic(
    p: &Prepared,
    model: &RobotModel<f64>,
    stiffness: Stiffness,
) -> Option<(Vec<Column>, (f64, f64))> {
    let y = msd::target(p);
    let stride = shape_stride(p.dt_s);
    let rows = 0..p.split;
    let yty = strided_sum_of_squares(&y, p.split, stride);
    let wn0 = model.params.ip.natural_freq_rad_s;
    let ctx = DynCtx::new(p, model);
    let z0 = model.params.ip.damping_ratio;
    let with_offset = |cols: &[Column]| {
        let mut c = cols.to_vec();
        if stiffness.takes_offset() {
            c.extend(offset_columns(p.len()));
        }
        c
    };
    let fit = |cols: &[Column]| {
        let cols = &with_offset(cols);
        let ne = lsq::normal_equations_strided(cols, &[&y[0], &y[1]], rows.clone(), stride);
        let th = lsq::solve(&ne, &stiffness.positive());
        (lsq::rss(&ne, yty, &th), th)
    };
    // without the pneumatic term
    let plain = base_columns(p, &ctx, stiffness, 0.0, 0.0)?;
    let (rss_plain, th_plain) = fit(&plain);
    let mut best: Option<(f64, Vec<Column>, (f64, f64))> = None;
    for (wf, z) in [0.6, 1.0, 1.6]
        .iter()
        .flat_map(|&wf| [z0, 0.7, 1.0].into_iter().map(move |z| (wf, z)))
    {
        let cols = base_columns(p, &ctx, stiffness, wn0 * wf, z)?;
        let (r, _) = fit(&cols);
        if best.as_ref().is_none_or(|b| r < b.0) {
            best = Some((r, cols, (wn0 * wf, z)));
        }
    }
    let (rss_pn, cols, wz) = best.expect("grid is not empty");
    // the term must pay for itself like an effect: a relative gain of 1 % and the BIC on
    // the effective number of samples of the plain residual (4 parameters with the grid)
    let pred = lsq::predict(&with_offset(&plain), &th_plain, p.len());
    let residuals: Vec<Vec<f64>> = (0..2)
        .map(|a| (0..p.split).map(|i| y[a][i] - pred[a][i]).collect())
        .collect();
    let n_eff = effective_samples_of(&residuals);
    let ratio = rss_pn / rss_plain.max(1e-300);
    Some(
        if ratio < 0.99 && n_eff * ratio.ln() + 4.0 * n_eff.ln() < 0.0 {
            (cols, wz)
        } else {
            (plain, (0.0, 0.0))
        },
    )
}

// -------------------------------------------------------------------- diagnosis
