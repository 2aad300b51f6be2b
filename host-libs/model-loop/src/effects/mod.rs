//! The model-side effect catalog. Each effect is one small unit: an id (the same snake_case
//! ids as the digital twin's effects), what it adds to the base model — extra regressors
//! for the mass-spring-damper fit of dynamic trials (optionally over a grid of shape
//! parameters, e.g. a delay or a hysteresis width), and/or extra parameters of the
//! second-order response of step trials — and the name of the residual signature that
//! points to it.
//!
//! Sign convention of the dynamic regressors: they are contributions to −f (the hand's
//! force on the robot, see [`pam_ident::msd::target`]), chosen so that a fitted parameter has
//! the sign and unit of the physical parameter it stands for.
//!
//! To add an effect, implement [`ModelEffect`] and list it in [`catalog`] (or pass your own
//! list to [`crate::diagnose::diagnose_with`]); see `docs/model-loop.md`.

use crate::response::StepExtra;
use pam_ident::trial::Prepared;
use pam_model::RobotModel;
use pam_numerics::lsq::Column;

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Experiment {
    Dynamic,
    Step,
}

impl std::str::FromStr for Experiment {
    type Err = pam_ident::IdentError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "dynamic" => Ok(Experiment::Dynamic),
            "step" => Ok(Experiment::Step),
            _ => Err(pam_ident::IdentError::UnknownExperiment(s.to_string())),
        }
    }
}

impl std::fmt::Display for Experiment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Experiment {
    pub fn name(self) -> &'static str {
        match self {
            Experiment::Dynamic => "dynamic",
            Experiment::Step => "step",
        }
    }
}

pub use pam_effect_id::Family;

/// The experiment that tells families `a` and `b` apart when a log cannot.
pub fn separating_experiment(a: Family, b: Family) -> &'static str {
    use Family::*;
    let pair = if a <= b { (a, b) } else { (b, a) };
    match pair {
        (StiffnessNonlinearity, PoseDependence) => {
            "repeat the dynamic trial at the neutral pose with larger excursions on both sides of the equilibrium: a cubic is odd in the displacement, a pose-dependent stiffness even"
        }
        (Friction, Drag) => {
            "move the handle at two clearly different speeds: friction keeps its size, drag grows with the speed squared"
        }
        (Friction, Hysteresis) => {
            "repeat the same trial at Table 4.1's other stiffness level and diagnose both logs together (`pamctl model diagnose A.csv B.csv`): the muscles' hysteresis grows with their pressure, friction keeps its size; slow reversals (well below 1 Hz) show the loop's shape best"
        }
        (Hysteresis, Backlash) | (Friction, Backlash) => {
            "move with small reversals (a few mm) and with large ones: friction acts at every reversal alike, hysteresis turns over a small excursion, backlash shows as a dead band in position"
        }
        (Hysteresis, Drift) | (Drift, Saturation) | (Hysteresis, Saturation) => {
            "steps of both signs and two sizes, approached from above and from below: hysteresis follows the direction of the last step, saturation the size, drift the time"
        }
        (Delay, RateLimits) => {
            "steps of two clearly different sizes: a dead time is the same for both, a rate limit makes the large step slower"
        }
        (Delay, _) | (_, Delay) => {
            "sample faster (≤ 5 ms) and include quick reversals or small fast steps: a pure delay shifts every frequency by the same time"
        }
        (Drift, _) | (_, Drift) => {
            "a longer trial with rests at the start and the end: drift grows with time, the other effect does not"
        }
        _ => "repeat the trial at a second pose and with larger excursions (or steps of both signs and two sizes)",
    }
}

/// What the effects of a dynamic trial may use, computed once per trial.
pub struct DynCtx<'a> {
    pub p: &'a Prepared,
    pub model: &'a RobotModel<f64>,
    /// J⁻ᵀ at each sample: joint torque → handle force.
    pub jinv_t: Vec<[[f64; 2]; 2]>,
    /// Joint torques the measured force corresponds to, τ = Jᵀ f.
    pub joint_torque_nm: [Vec<f64>; 2],
}

impl<'a> DynCtx<'a> {
    pub fn new(p: &'a Prepared, model: &'a RobotModel<f64>) -> Self {
        let n = p.len();
        let mut jinv_t = Vec::with_capacity(n);
        let mut tq = [Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let j = model
                .kinematics
                .jacobian([p.alpha_rad[0][i], p.alpha_rad[1][i]]);
            let jt = j.transpose();
            let inv = jt.inverse().map(|m| m.0).unwrap_or([[0.0; 2]; 2]);
            jinv_t.push(inv);
            let t = jt.mul_vec([p.force_n[0][i], p.force_n[1][i]]);
            tq[0].push(t[0]);
            tq[1].push(t[1]);
        }
        DynCtx {
            p,
            model,
            jinv_t,
            joint_torque_nm: tq,
        }
    }

    /// The column in −f of a joint-torque disturbance Δτ(t) (per unit parameter): a torque
    /// added to the muscles' is balanced by the hand, −f = −J⁻ᵀ Δτ.
    pub fn torque_column(&self, name: &str, torque: impl Fn(usize) -> [f64; 2]) -> Column {
        let n = self.p.len();
        let (mut x, mut y) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for i in 0..n {
            let t = torque(i);
            let m = &self.jinv_t[i];
            x.push(-(m[0][0] * t[0] + m[0][1] * t[1]));
            y.push(-(m[1][0] * t[0] + m[1][1] * t[1]));
        }
        Column::both(name, x, y)
    }
}

/// A nonlinear (shape) parameter of an effect: the catalog's, or a custom effect's own.
/// Typed, so a misspelt name is a compile error rather than a silent zero.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShapeParam {
    QuadraticForm,
    Width,
    BreakawayRad,
    SmoothingMS,
    StribeckMS,
    PreslidingM,
    SmoothingRadS,
    PreslidingRad,
    DelayS,
    CornerHz,
    TimeConstantS,
    JointSpace,
    BacklashRad,
    HoldTorqueNm,
    FromNeutralPose,
    /// A parameter of an effect outside the catalog (its name as reported).
    Custom(&'static str),
}

impl ShapeParam {
    /// The name in reports and `--json` (with its unit as a suffix).
    pub fn name(self) -> &'static str {
        match self {
            ShapeParam::QuadraticForm => "quadratic_form",
            ShapeParam::Width => "width",
            ShapeParam::BreakawayRad => "breakaway_rad",
            ShapeParam::SmoothingMS => "smoothing_m_s",
            ShapeParam::StribeckMS => "stribeck_m_s",
            ShapeParam::PreslidingM => "presliding_m",
            ShapeParam::SmoothingRadS => "smoothing_rad_s",
            ShapeParam::PreslidingRad => "presliding_rad",
            ShapeParam::DelayS => "delay_s",
            ShapeParam::CornerHz => "corner_hz",
            ShapeParam::TimeConstantS => "time_constant_s",
            ShapeParam::JointSpace => "joint_space",
            ShapeParam::BacklashRad => "backlash_rad",
            ShapeParam::HoldTorqueNm => "hold_torque_nm",
            ShapeParam::FromNeutralPose => "from_neutral_pose",
            ShapeParam::Custom(n) => n,
        }
    }
}

/// One setting of an effect's nonlinear (shape) parameters, e.g. a delay.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shape(pub Vec<(ShapeParam, f64)>);

impl Shape {
    /// The parameter's value, if this shape sets it.
    pub fn get(&self, p: ShapeParam) -> Option<f64> {
        self.0.iter().find(|(n, _)| *n == p).map(|x| x.1)
    }
    /// A two-way choice of form (e.g. joint space or Cartesian): set and non-zero.
    pub fn flag(&self, p: ShapeParam) -> bool {
        self.get(p).is_some_and(|v| v != 0.0)
    }
    /// The parameters as (name, value) for reports.
    pub fn named(&self) -> impl Iterator<Item = (String, f64)> + '_ {
        self.0.iter().map(|(n, x)| (n.name().to_string(), *x))
    }
}

/// What an effect adds to the dynamic (mass-spring-damper) regression.
#[derive(Clone, Debug, Default)]
pub struct DynTerm {
    pub columns: Vec<Column>,
    /// The force is sampled this much later than the motion (a sensor-sync delay), seconds:
    /// the fit's target is shifted by it in whole samples.
    pub base_delay_s: f64,
    /// The force is measured through a low-pass of this corner (Hz; 0: none), as a load
    /// cell's amplifier filters it: every column of the fit passes through the same filter.
    pub force_lowpass_hz: f64,
    /// Indices (into `columns`) of parameters that are physically ≥ 0 (dissipation, a
    /// friction force): a sign-flipped fit of one effect must not pass for another.
    pub positive: Vec<usize>,
    /// The term has a constant part of its own (an offset, or the equilibrium shift of an
    /// effect counted from the neutral pose): the base variant with a fitted preload is then
    /// not used with it, as the two cannot be told apart.
    pub carries_constant: bool,
}

/// A model-side effect.
pub trait ModelEffect: Sync {
    /// Stable snake_case id, shared with the digital twin.
    fn id(&self) -> &'static str;
    /// One line: what it models.
    fn summary(&self) -> &'static str;
    /// The residual signature that points to this effect (named in the evidence).
    fn signature(&self) -> &'static str;
    /// Whether it can be seen in this kind of experiment.
    fn applies(&self, experiment: Experiment) -> bool;
    /// Grid of shape-parameter settings tried for dynamic trials (one empty shape when the
    /// effect is linear in its parameters).
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        vec![Shape::default()]
    }
    /// Shapes between the grid's neighbours of `best`, the grid's best on the training
    /// part, tried after the grid (none by default).
    fn finer_shapes(&self, _ctx: &DynCtx, _best: &Shape) -> Vec<Shape> {
        Vec::new()
    }
    /// Extra regressors (and base transform) for a dynamic trial.
    fn dynamic_term(&self, _ctx: &DynCtx, _shape: &Shape) -> DynTerm {
        DynTerm::default()
    }
    /// Parameters to report, from the fitted linear coefficients (named as the columns) and
    /// the shape. Default: both, as they are.
    fn report_params(
        &self,
        _ctx: &DynCtx,
        fitted: &[(String, f64)],
        shape: &Shape,
    ) -> Vec<(String, f64)> {
        fitted_and_shape(fitted, shape)
    }
    /// Extra parameters of the second-order step response, for step trials.
    fn step_extras(&self) -> &'static [StepExtra] {
        &[]
    }
    /// The physical family this effect is a shape of (`None` for an effect outside the
    /// families, e.g. a user's own).
    fn family(&self) -> Option<Family> {
        None
    }
    /// The shape's name within its family (e.g. `coulomb`, `elastic_loop`).
    fn shape_name(&self) -> &'static str {
        self.id()
    }
}

/// The fitted coefficients as they are, then the shape's parameters: what
/// [`ModelEffect::report_params`] reports unless an effect adds its own.
pub fn fitted_and_shape(fitted: &[(String, f64)], shape: &Shape) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = fitted.to_vec();
    v.extend(shape.named());
    v
}

/// Joint pressures [[P1, P2], [P1, P2]] (bar) at each sample, from the logged I/P currents
/// through the converter law (eq. 2.2); `None` when the log has no currents.
pub fn joint_pressures(p: &Prepared, model: &RobotModel<f64>) -> Option<Vec<[[f64; 2]; 2]>> {
    let cur = p.current_ma.as_ref()?;
    Some(
        (0..p.len())
            .map(|i| {
                let ch = [cur[0][i], cur[1][i], cur[2][i], cur[3][i]]
                    .map(|c| model.params.ip.pressure_bar(c));
                model.joint_pressures_bar(ch)
            })
            .collect(),
    )
}

/// Joint torque of the model's muscles (eq. 3.2) at angle α and pressures, split into the
/// pressure part R(A2 P2 − A1 P1) and the total.
pub fn model_torque(
    model: &RobotModel<f64>,
    j: usize,
    alpha: f64,
    pressure_bar: [f64; 2],
) -> (f64, f64) {
    let pose = model.pose(j, alpha);
    let r = model.params.joints[j].pulley_radius_m;
    let total = pose.torque_nm(pressure_bar);
    let passive = pose.torque_nm([0.0, 0.0]);
    let _ = r;
    (total - passive, total)
}

/// The model's muscle force law as the base model's stiffness: per joint, the torque of
/// the model's muscles (eq. 3.1 through the joint pair, eq. 3.2–3.5) at the logged angle and
/// the pressures from the logged currents — minus its value at the start of the trial when
/// `from_start`, else as it is (the model's own equilibrium) — as a handle force through
/// J⁻ᵀ. Away from the neutral pose this force law is
/// visibly curved over the operator's motion, which no constant K follows. One gain per
/// joint (≈ 1 when the model's force law is right). `None` without currents in the log.
pub fn force_law_columns(ctx: &DynCtx, from_start: bool) -> Option<Vec<Column>> {
    let p = ctx.p;
    let pr = joint_pressures(p, ctx.model)?;
    let mut cols = Vec::new();
    for j in 0..2 {
        let a = &p.alpha_smooth_rad[j];
        let tau: Vec<f64> = (0..p.len())
            .map(|i| model_torque(ctx.model, j, a[i], pr[i][j]).1)
            .collect();
        let tau0 = if from_start {
            at_start(p, |i| tau[i])
        } else {
            0.0
        };
        let name = ["force_law_gain_joint1", "force_law_gain_joint2"][j];
        // the muscles' restoring torque is balanced by the hand: −f gains −J⁻ᵀ Δτ, and
        // Δτ < 0 for α > α0; the regressor is that column itself, so the gain is +1 when
        // the model's force law is right
        cols.push(ctx.torque_column(name, |i| {
            let mut t = [0.0; 2];
            t[j] = tau[i] - tau0;
            t
        }));
    }
    Some(cols)
}

/// Value of a per-sample quantity at the equilibrium (mean over the first 0.1 s), so a
/// position-dependent regressor is zero where the trial starts, like x − x0.
pub(crate) fn at_start(p: &Prepared, f: impl Fn(usize) -> f64) -> f64 {
    let k = ((0.1 / p.dt_s).round() as usize).clamp(1, p.len());
    (0..k).map(&f).sum::<f64>() / k as f64
}

/// The two references of a pose-dependent effect: the neutral pose (α = 0, where the
/// model's muscles are pretensioned) or the start of the trial.
pub(crate) fn reference_shapes() -> Vec<Shape> {
    vec![
        Shape(vec![(ShapeParam::FromNeutralPose, 1.0)]),
        Shape(vec![(ShapeParam::FromNeutralPose, 0.0)]),
    ]
}

pub(crate) fn from_neutral(s: &Shape) -> bool {
    s.flag(ShapeParam::FromNeutralPose)
}

mod friction;
mod hysteresis;
mod pose;
mod sensor_filter;
mod slip;
mod step_effects;
mod stiffness;
pub use friction::{
    CarrierBallFriction, JointFriction, PreslidingFriction, StribeckFriction, VelocitySquared,
};
pub(crate) use hysteresis::SLIP_BREAKAWAYS_RAD;
pub use hysteresis::{ElasticLoop, MaxwellSlip, MuscleHysteresis, PressureHysteresis};
pub use pose::PoseDependence;
pub use sensor_filter::{group_delay_s, LoadCellFilter, LowpassMemo};
pub use slip::{CableSlip, JointPlay};
pub use step_effects::{
    AsymmetricIpRates, CommandSlew, ForceSaturation, ForceSlew, LoadcellDrift, MusclePressureCap,
    PressureSaturation, SettlingDrift, TransportDelay, MAX_DYNAMIC_DELAY_S,
};
pub use stiffness::{CubicAboutEquilibrium, NonlinearStiffness};

/// The model-side catalog: the twin's effects in its order, then the families' other
/// shapes.
pub fn catalog() -> Vec<&'static dyn ModelEffect> {
    vec![
        &CarrierBallFriction,
        &VelocitySquared,
        &NonlinearStiffness,
        &MuscleHysteresis,
        &AsymmetricIpRates,
        &PressureSaturation,
        &PoseDependence,
        &CableSlip,
        &TransportDelay,
        &LoadcellDrift,
        &StribeckFriction,
        &PreslidingFriction,
        &JointPlay,
        &SettlingDrift,
        &CommandSlew,
        &ForceSlew,
        &ElasticLoop,
        &MaxwellSlip,
        // after the muscles' Maxwell-slip: a joint's Maxwell-slip friction is the same
        // signal, and where the two fit alike the family whose own shape it is comes first
        // (the diagnosis says the log cannot tell them apart either way)
        &JointFriction,
        &CubicAboutEquilibrium,
        &ForceSaturation,
        &MusclePressureCap,
        &PressureHysteresis,
        &LoadCellFilter,
    ]
}

pub fn ids() -> Vec<&'static str> {
    catalog().iter().map(|e| e.id()).collect()
}

/// Looks up ids (comma-separated lists allowed) in a catalog.
pub fn lookup<'a>(
    catalog: &[&'a dyn ModelEffect],
    ids: &[String],
) -> Result<Vec<&'a dyn ModelEffect>, pam_ident::IdentError> {
    let mut out: Vec<&dyn ModelEffect> = Vec::new();
    for id in ids
        .iter()
        .flat_map(|s| s.split(','))
        .map(str::trim)
        .filter(|s| !s.is_empty())
    {
        // an effect's own id, or a family (its name or catalog id: the family's first shape)
        let e = catalog
            .iter()
            .find(|e| e.id() == id)
            .or_else(|| {
                let family: Option<Family> = id.parse().ok().or_else(|| {
                    Family::ALL
                        .into_iter()
                        .find(|f| f.catalog_id().name() == id)
                });
                catalog
                    .iter()
                    .find(|e| family.is_some() && e.family() == family)
            })
            .ok_or_else(|| pam_ident::IdentError::UnknownEffect {
                name: id.to_string(),
                known: catalog
                    .iter()
                    .map(|e| e.id())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        if !out.iter().any(|o| o.id() == id) {
            out.push(*e);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod shape_tests {
    use super::*;

    #[test]
    fn a_shape_reports_only_what_it_sets_under_unique_names() {
        let s = Shape(vec![
            (ShapeParam::DelayS, 0.04),
            (ShapeParam::JointSpace, 1.0),
        ]);
        assert_eq!(s.get(ShapeParam::DelayS), Some(0.04));
        assert_eq!(s.get(ShapeParam::Width), None);
        assert!(s.flag(ShapeParam::JointSpace));
        assert!(!s.flag(ShapeParam::FromNeutralPose));
        let named: Vec<(String, f64)> = s.named().collect();
        assert_eq!(named[0], ("delay_s".to_string(), 0.04));
        // every catalog shape's parameters have distinct report names
        let mut names = Vec::new();
        for p in [
            ShapeParam::QuadraticForm,
            ShapeParam::Width,
            ShapeParam::BreakawayRad,
            ShapeParam::SmoothingMS,
            ShapeParam::StribeckMS,
            ShapeParam::PreslidingM,
            ShapeParam::DelayS,
            ShapeParam::CornerHz,
            ShapeParam::TimeConstantS,
            ShapeParam::JointSpace,
            ShapeParam::BacklashRad,
            ShapeParam::HoldTorqueNm,
            ShapeParam::FromNeutralPose,
        ] {
            assert!(!names.contains(&p.name()), "{} twice", p.name());
            names.push(p.name());
        }
    }
}
