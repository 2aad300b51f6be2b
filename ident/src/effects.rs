//! The model-side effect catalog. Each effect is one small unit: an id (the same snake_case
//! ids as the digital twin's effects), what it adds to the base model — extra regressors
//! for the mass-spring-damper fit of dynamic trials (optionally over a grid of shape
//! parameters, e.g. a delay or a hysteresis width), and/or extra parameters of the
//! second-order response of step trials — and the name of the residual signature that
//! points to it.
//!
//! Sign convention of the dynamic regressors: they are contributions to −f (the hand's
//! force on the robot, see [`crate::msd::target`]), chosen so that a fitted parameter has
//! the sign and unit of the physical parameter it stands for.
//!
//! To add an effect, implement [`ModelEffect`] and list it in [`catalog`] (or pass your own
//! list to [`crate::diagnose::diagnose_with`]); see `docs/model-loop.md`.

use crate::lsq::Column;
use crate::response::StepExtra;
use crate::trial::Prepared;
use pam_model::RobotModel;

#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Experiment {
    Dynamic,
    Step,
}

impl std::str::FromStr for Experiment {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "dynamic" => Ok(Experiment::Dynamic),
            "step" => Ok(Experiment::Step),
            _ => Err(format!("unknown experiment `{s}` (dynamic | step)")),
        }
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

/// One setting of an effect's nonlinear (shape) parameters, e.g. a delay.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shape(pub Vec<(&'static str, f64)>);

impl Shape {
    pub fn get(&self, name: &str) -> f64 {
        self.0
            .iter()
            .find(|(n, _)| *n == name)
            .map(|p| p.1)
            .unwrap_or(0.0)
    }
}

/// What an effect adds to the dynamic (mass-spring-damper) regression.
#[derive(Clone, Debug, Default)]
pub struct DynTerm {
    pub columns: Vec<Column>,
    /// The base regressors are taken this much earlier (force lagging motion), seconds.
    pub base_delay_s: f64,
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
        let mut v: Vec<(String, f64)> = fitted.to_vec();
        v.extend(shape.0.iter().map(|(n, x)| (n.to_string(), *x)));
        v
    }
    /// Extra parameters of the second-order step response, for step trials.
    fn step_extras(&self) -> &'static [StepExtra] {
        &[]
    }
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
fn reference_shapes() -> Vec<Shape> {
    vec![
        Shape(vec![("from_neutral_pose", 1.0)]),
        Shape(vec![("from_neutral_pose", 0.0)]),
    ]
}

fn from_neutral(s: &Shape) -> bool {
    s.get("from_neutral_pose") != 0.0
}

/// Dry friction of the carrier ball: a force of constant size against the handle velocity,
/// smoothed over a speed (grid), like Coulomb friction.
pub struct CarrierBallFriction;
impl ModelEffect for CarrierBallFriction {
    fn id(&self) -> &'static str {
        "carrier_ball_friction"
    }
    fn summary(&self) -> &'static str {
        "Coulomb friction of the carrier ball against the handle velocity (§6.2)"
    }
    fn signature(&self) -> &'static str {
        "residual jumps with the sign of the velocity"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.001, 0.003, 0.01, 0.03, 0.1]
            .iter()
            .map(|&w| Shape(vec![("smoothing_m_s", w)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let w = shape.get("smoothing_m_s");
        let v = &ctx.p.v_m_s;
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for i in 0..ctx.p.len() {
            let s = v[0][i].hypot(v[1][i]);
            // v̂ · s/√(s² + w²): the direction of motion, faded in over w
            let k = 1.0 / (s * s + w * w).sqrt();
            x.push(v[0][i] * k);
            y.push(v[1][i] * k);
        }
        DynTerm {
            columns: vec![Column::both("coulomb_n", x, y)],
            positive: vec![0],
            ..Default::default()
        }
    }
}

/// Quadratic drag c·|v|·v at the handle.
pub struct VelocitySquared;
impl ModelEffect for VelocitySquared {
    fn id(&self) -> &'static str {
        "velocity_squared"
    }
    fn summary(&self) -> &'static str {
        "force growing with the square of the handle speed, c·|v|·v (§4.6)"
    }
    fn signature(&self) -> &'static str {
        "residual grows with the square of the speed, with the velocity's sign"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn dynamic_term(&self, ctx: &DynCtx, _s: &Shape) -> DynTerm {
        let v = &ctx.p.v_m_s;
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for i in 0..ctx.p.len() {
            let s = v[0][i].hypot(v[1][i]);
            x.push(s * v[0][i]);
            y.push(s * v[1][i]);
        }
        DynTerm {
            columns: vec![Column::both("coeff_n_s2_per_m2", x, y)],
            positive: vec![0],
            ..Default::default()
        }
    }
}

/// Cubic stiffening of the cable forces with the muscle contraction (per joint).
pub struct NonlinearStiffness;
impl NonlinearStiffness {
    /// Joint torque per unit cable force coefficient c of ΔF = −c·(Δε/0.01)³ per muscle:
    /// Δε = ∓(R/l0)α for the two muscles, τ = R(F2 − F1) → Δτ = −2cR((R/l0)α/0.01)³.
    fn torque_per_n(model: &RobotModel<f64>, j: usize, alpha: f64) -> f64 {
        let jp = &model.params.joints[j];
        let r = jp.pulley_radius_m;
        let u = r / jp.muscle_rest_length_m * alpha / 0.01;
        -2.0 * r * u * u * u
    }
}
impl ModelEffect for NonlinearStiffness {
    fn id(&self) -> &'static str {
        "nonlinear_stiffness"
    }
    fn summary(&self) -> &'static str {
        "restoring joint torque growing with the cube of the excursion (cubic term of the cable force in the contraction, §4.3)"
    }
    fn signature(&self) -> &'static str {
        "residual grows with the cube of the displacement"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    /// The stretch is counted from the neutral pose's pretension (a trial away from it
    /// then also shows the effect as a shift of the equilibrium) or from the start of the
    /// trial (only the change of stiffness shows): chosen on the data.
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        reference_shapes()
    }
    fn dynamic_term(&self, ctx: &DynCtx, s: &Shape) -> DynTerm {
        let p = ctx.p;
        let mut cols = Vec::new();
        for j in 0..2 {
            let a = &p.alpha_smooth_rad[j];
            let t0 = if from_neutral(s) {
                0.0
            } else {
                at_start(p, |i| Self::torque_per_n(ctx.model, j, a[i]))
            };
            let name = ["cubic_n_joint1", "cubic_n_joint2"][j];
            cols.push(ctx.torque_column(name, |i| {
                let mut t = [0.0; 2];
                t[j] = Self::torque_per_n(ctx.model, j, a[i]) - t0;
                t
            }));
        }
        DynTerm {
            columns: cols,
            carries_constant: from_neutral(s),
            ..Default::default()
        }
    }
    fn report_params(
        &self,
        _ctx: &DynCtx,
        fitted: &[(String, f64)],
        s: &Shape,
    ) -> Vec<(String, f64)> {
        let mut v = fitted.to_vec();
        v.extend(s.0.iter().map(|(n, x)| (n.to_string(), *x)));
        // one cubic coefficient for both joints (the twin's parameter), from the two fits
        // weighted towards the joint that moved most is approximated by their mean
        let c = fitted.iter().map(|p| p.1).sum::<f64>() / fitted.len().max(1) as f64;
        v.push(("cubic_n".into(), c));
        v
    }
}

/// Dahl-type hysteresis of each muscle pair: a direction state z ∈ [−1, 1] that turns
/// over a contraction change `width` (grid); the torque loss is proportional to z.
pub struct MuscleHysteresis;
impl ModelEffect for MuscleHysteresis {
    fn id(&self) -> &'static str {
        "muscle_hysteresis"
    }
    fn summary(&self) -> &'static str {
        "direction-dependent muscle force (Dahl friction of the braid), a torque that reverses over a small excursion (§4.2, §5.1)"
    }
    fn signature(&self) -> &'static str {
        "residual follows the direction of the last motion and turns over a small displacement (loops against displacement)"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Hysteresis]
    }
    fn shapes(&self, _ctx: &DynCtx) -> Vec<Shape> {
        [0.0005, 0.001, 0.002, 0.004, 0.008]
            .iter()
            .map(|&w| Shape(vec![("width", w)]))
            .collect()
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let width = shape.get("width");
        let mut cols = Vec::new();
        for j in 0..2 {
            let jp = &ctx.model.params.joints[j];
            let eps_per_rad = jp.pulley_radius_m / jp.muscle_rest_length_m;
            let a = &p.alpha_smooth_rad[j];
            // z of muscle 2 (ε2 = ε0 + (R/l0)α); muscle 1's is its opposite
            let mut z = vec![0.0; p.len()];
            let mut zi = 0.0f64;
            for i in 1..p.len() {
                let de = eps_per_rad * (a[i] - a[i - 1]);
                let s = if de > 0.0 { 1.0 } else { -1.0 };
                zi = (zi + de / width * (1.0 - zi * s)).clamp(-1.0, 1.0);
                z[i] = zi;
            }
            // ΔF_i = −fraction·F_i·z_i, z1 = −z2 → Δτ = R(ΔF2 − ΔF1) = −R·fraction·(F1 + F2)·z2
            let name = ["torque_nm_joint1", "torque_nm_joint2"][j];
            cols.push(ctx.torque_column(name, |i| {
                let mut t = [0.0; 2];
                t[j] = -z[i];
                t
            }));
        }
        DynTerm {
            columns: cols,
            positive: vec![0, 1],
            ..Default::default()
        }
    }
    fn report_params(
        &self,
        ctx: &DynCtx,
        fitted: &[(String, f64)],
        shape: &Shape,
    ) -> Vec<(String, f64)> {
        let mut v = fitted.to_vec();
        v.push(("width".into(), shape.get("width")));
        // fraction = amplitude / (R (F1 + F2)) with the muscle forces of the model at the
        // commanded pressures (from the logged currents), when the log has them
        if let Some(cur) = &ctx.p.current_ma {
            let model = ctx.model;
            let mut fr = Vec::new();
            for j in 0..2 {
                let i0 = 0;
                let ch: [f64; 4] = [cur[0][i0], cur[1][i0], cur[2][i0], cur[3][i0]]
                    .map(|c| model.params.ip.pressure_bar(c));
                let jp = model.joint_pressures_bar(ch);
                let pose = model.pose(j, ctx.p.alpha0_rad[j]);
                let f = pose.forces_n(jp[j]);
                let r = model.params.joints[j].pulley_radius_m;
                let sum = f[0].max(0.0) + f[1].max(0.0);
                if sum > 1.0 {
                    fr.push(fitted[j].1 / (r * sum));
                }
            }
            if !fr.is_empty() {
                v.push(("fraction".into(), fr.iter().sum::<f64>() / fr.len() as f64));
            }
        }
        v
    }
}

/// Pose dependence of the stiffness: the restoring force gains terms quadratic in the
/// displacement (a stiffness that changes linearly across the workspace).
pub struct PoseDependence;
impl ModelEffect for PoseDependence {
    fn id(&self) -> &'static str {
        "pose_dependence"
    }
    fn summary(&self) -> &'static str {
        "stiffness/gain varying over the workspace (§4.6, §5.3: gain plane eq. 5.2)"
    }
    fn signature(&self) -> &'static str {
        "residual depends on where the handle is (even in the displacement) / step gain varies with the pose"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    /// Two forms, chosen on the data like any shape: the gain plane acting on the muscle
    /// pressures (needs the currents; 2 parameters), or a restoring force quadratic in the
    /// displacement (6 parameters; any simulator or rig).
    /// With the gain plane, its angles count from the neutral pose (eq. 5.2: a trial away
    /// from it also shows a shift of the equilibrium) or from the start of the trial.
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let mut v = Vec::new();
        if joint_pressures(ctx.p, ctx.model).is_some() {
            for r in reference_shapes() {
                v.push(Shape([vec![("quadratic_form", 0.0)], r.0].concat()));
            }
        }
        v.push(Shape(vec![("quadratic_form", 1.0)]));
        v
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        // with the pressures known (currents in the log): the pressure part of each joint's
        // torque scaled by a plane in (α1, α2) — the gain plane of eq. 5.2 acting on the
        // muscles; the parameters are the plane's slopes
        let pressures = if shape.get("quadratic_form") == 0.0 {
            joint_pressures(ctx.p, ctx.model)
        } else {
            None
        };
        if let Some(pr) = pressures {
            let p = ctx.p;
            let a = &p.alpha_smooth_rad;
            let origin = if from_neutral(shape) {
                [0.0; 2]
            } else {
                p.alpha0_rad
            };
            let mut cols = Vec::new();
            for (k, name) in [(0, "gain_per_rad_1"), (1, "gain_per_rad_2")] {
                let v: Vec<[f64; 2]> = (0..p.len())
                    .map(|i| {
                        let mut t = [0.0; 2];
                        for j in 0..2 {
                            t[j] = model_torque(ctx.model, j, a[j][i], pr[i][j]).0
                                * (a[k][i] - origin[k]);
                        }
                        t
                    })
                    .collect();
                // the extra muscle torque is balanced by the hand: −f gains −J⁻ᵀΔτ
                let c = ctx.torque_column(name, |i| v[i]);
                cols.push(c);
            }
            return DynTerm {
                columns: cols,
                carries_constant: from_neutral(shape),
                ..Default::default()
            };
        }
        // without: a stiffness that changes linearly across the workspace, i.e. restoring
        // forces quadratic in the displacement
        let d = &ctx.p.dx_m;
        let sq = |f: &dyn Fn(usize) -> f64| (0..ctx.p.len()).map(f).collect::<Vec<f64>>();
        let xx = sq(&|i| d[0][i] * d[0][i]);
        let xy = sq(&|i| d[0][i] * d[1][i]);
        let yy = sq(&|i| d[1][i] * d[1][i]);
        DynTerm {
            columns: vec![
                Column::on("qx_xx_n_per_m2", 0, xx.clone()),
                Column::on("qx_xy_n_per_m2", 0, xy.clone()),
                Column::on("qx_yy_n_per_m2", 0, yy.clone()),
                Column::on("qy_xx_n_per_m2", 1, xx),
                Column::on("qy_xy_n_per_m2", 1, xy),
                Column::on("qy_yy_n_per_m2", 1, yy),
            ],
            ..Default::default()
        }
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::PoseGain]
    }
}

/// Joint-1 cable: backlash in the pulley groove (play, grid) and slip that creeps while the
/// joint torque exceeds what the groove holds (hold torque, grid).
pub struct CableSlip;
impl ModelEffect for CableSlip {
    fn id(&self) -> &'static str {
        "cable_slip"
    }
    fn summary(&self) -> &'static str {
        "joint-1 cable backlash and slip in the pulley groove under high torque (§2.3, §6.2)"
    }
    fn signature(&self) -> &'static str {
        "the equilibrium of joint 1 creeps after high-torque phases; a dead band in joint 1's restoring torque"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Dynamic
    }
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        let tmax = ctx.joint_torque_nm[0]
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let mut v = Vec::new();
        for b in [0.0, 0.002, 0.004, 0.008, 0.016] {
            for frac in [0.3, 0.5, 0.7, 0.85] {
                v.push(Shape(vec![
                    ("backlash_rad", b),
                    ("hold_torque_nm", frac * tmax),
                ]));
            }
        }
        v
    }
    fn dynamic_term(&self, ctx: &DynCtx, shape: &Shape) -> DynTerm {
        let p = ctx.p;
        let n = p.len();
        let a = &p.alpha_smooth_rad[0];
        let half = 0.5 * shape.get("backlash_rad");
        let hold = shape.get("hold_torque_nm");
        // play operator minus the angle: what the muscles do not see
        let mut play = vec![0.0; n];
        let mut t = a[0];
        for i in 0..n {
            if a[i] > t + half {
                t = a[i] - half;
            } else if a[i] < t - half {
                t = a[i] + half;
            }
            play[i] = t - a[i];
        }
        // accumulated torque excess: the slip angle up to a rate constant
        let mut slip = vec![0.0; n];
        let mut s = 0.0;
        for i in 1..n {
            let tq = ctx.joint_torque_nm[0][i - 1];
            let excess = tq.abs() - hold;
            if excess > 0.0 {
                s += tq.signum() * excess * (p.t_s[i] - p.t_s[i - 1]);
            }
            slip[i] = s;
        }
        let mut cols = vec![ctx.torque_column("slip_nm_per_nm_s", |i| [slip[i], 0.0])];
        if half > 0.0 {
            cols.push(ctx.torque_column("backlash_torque_nm_per_rad", |i| [play[i], 0.0]));
        }
        DynTerm {
            columns: cols,
            ..Default::default()
        }
    }
}

/// Pure delay: the force follows the motion late (dynamic trials) / the reference late
/// (step trials).
pub struct TransportDelay;
impl ModelEffect for TransportDelay {
    fn id(&self) -> &'static str {
        "transport_delay"
    }
    fn summary(&self) -> &'static str {
        "pure delay between command/motion and force (tubes, converter pilot stage; Table 5.1)"
    }
    fn signature(&self) -> &'static str {
        "lagged cross-correlation of the residual with the inputs peaks at a non-zero lag"
    }
    fn applies(&self, e: Experiment) -> bool {
        // In a dynamic trial the pressures are constant (joint mode is open loop), so a delay
        // of the pressure command cannot show; a lag of the force behind the motion is what
        // the base model's pneumatic term describes. The delay is identified from steps.
        e == Experiment::Step
    }
    fn shapes(&self, ctx: &DynCtx) -> Vec<Shape> {
        // 5 ms steps (or one sample when that is finer), up to 150 ms; delays that are
        // not whole samples are interpolated
        let step = ctx.p.dt_s.min(0.005);
        let count = (0.15 / step).round() as usize;
        (1..=count)
            .map(|k| Shape(vec![("delay_s", k as f64 * step)]))
            .collect()
    }
    fn dynamic_term(&self, _ctx: &DynCtx, shape: &Shape) -> DynTerm {
        DynTerm {
            columns: vec![],
            base_delay_s: shape.get("delay_s"),
            ..Default::default()
        }
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Delay]
    }
}

/// Load-cell offset and linear drift, in the sensor frame (it turns with θ1 + θ2).
pub struct LoadcellDrift;
impl ModelEffect for LoadcellDrift {
    fn id(&self) -> &'static str {
        "loadcell_drift"
    }
    fn summary(&self) -> &'static str {
        "offset and linear drift of the load-cell channels (sensor frame)"
    }
    fn signature(&self) -> &'static str {
        "residual has an offset and drifts with time"
    }
    fn applies(&self, _e: Experiment) -> bool {
        true
    }
    fn dynamic_term(&self, ctx: &DynCtx, _s: &Shape) -> DynTerm {
        let p = ctx.p;
        let k = &ctx.model.kinematics;
        let mut cols = Vec::new();
        for (axis, name_o, name_d) in [
            (0, "offset_x_n", "drift_x_n_per_s"),
            (1, "offset_z_n", "drift_z_n_per_s"),
        ] {
            let mut e = [0.0; 2];
            e[axis] = 1.0;
            let (mut ox, mut oy, mut dx, mut dy) = (vec![], vec![], vec![], vec![]);
            for i in 0..p.len() {
                // the offset adds to the measured f; the column is its share of −f
                let u = k.sensor_to_user([p.alpha_rad[0][i], p.alpha_rad[1][i]], e);
                let t = p.t_s[i] - p.t_s[0];
                ox.push(-u[0]);
                oy.push(-u[1]);
                dx.push(-u[0] * t);
                dy.push(-u[1] * t);
            }
            cols.push(Column::both(name_o, ox, oy));
            cols.push(Column::both(name_d, dx, dy));
        }
        DynTerm {
            columns: cols,
            carries_constant: true,
            ..Default::default()
        }
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Drift]
    }
}

/// Flow-limited converters: the force slews at a limited rate, different up and down.
pub struct AsymmetricIpRates;
impl ModelEffect for AsymmetricIpRates {
    fn id(&self) -> &'static str {
        "asymmetric_ip_rates"
    }
    fn summary(&self) -> &'static str {
        "flow-limited I/P converters: the force rises and falls at limited, different rates (Table 5.1)"
    }
    fn signature(&self) -> &'static str {
        "large steps are slower than small ones, and rising differs from falling (ramp-shaped residual after large steps)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::SlewRate]
    }
}

/// The delivered pressure saturates: large force commands fall short.
pub struct PressureSaturation;
impl ModelEffect for PressureSaturation {
    fn id(&self) -> &'static str {
        "pressure_saturation"
    }
    fn summary(&self) -> &'static str {
        "the delivered pressure saturates, so large force commands fall short"
    }
    fn signature(&self) -> &'static str {
        "the step gain drops for large commands (residual grows with |reference|)"
    }
    fn applies(&self, e: Experiment) -> bool {
        e == Experiment::Step
    }
    fn step_extras(&self) -> &'static [StepExtra] {
        &[StepExtra::Saturation]
    }
}

/// The model-side catalog, in the twin's order.
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
    ]
}

pub fn ids() -> Vec<&'static str> {
    catalog().iter().map(|e| e.id()).collect()
}

/// Looks up ids (comma-separated lists allowed) in a catalog.
pub fn lookup<'a>(
    catalog: &[&'a dyn ModelEffect],
    ids: &[String],
) -> Result<Vec<&'a dyn ModelEffect>, String> {
    let mut out: Vec<&dyn ModelEffect> = Vec::new();
    for id in ids
        .iter()
        .flat_map(|s| s.split(','))
        .map(str::trim)
        .filter(|s| !s.is_empty())
    {
        let e = catalog.iter().find(|e| e.id() == id).ok_or_else(|| {
            format!(
                "unknown effect `{id}` (known: {})",
                catalog
                    .iter()
                    .map(|e| e.id())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?;
        if !out.iter().any(|o| o.id() == id) {
            out.push(*e);
        }
    }
    Ok(out)
}
