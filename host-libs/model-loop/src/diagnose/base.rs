//! The dynamic base model: eq. 4.29's mass and damping, the arm's own rigid-body dynamics
//! when the data asks for them, the stiffness in one of several forms (Cartesian, joint
//! space, the muscles' force law), a force offset per axis and the muscles' pneumatic
//! compliance; and the derivative filter's cutoff that suits the data.

use super::sizes::effective_samples_of;
use crate::effects::DynCtx;
use pam_ident::msd;
use pam_ident::msd::MSD_POSITIVE;
use pam_ident::step;
use pam_ident::step::StepParams;
use pam_ident::trial::FilterSettings;
use pam_ident::trial::Prepared;
use pam_ident::trial::Trial;
use pam_model::cartesian::{coriolis_torques, joint_inertia};
use pam_model::RobotModel;
use pam_numerics::lsq;
use pam_numerics::lsq::Column;
use rayon::prelude::*;

pub(super) struct BaseVariant {
    /// The base columns; with `offset`, the last two are a constant force per axis.
    pub(super) cols: Vec<Column>,
    pub(super) offset: bool,
    /// With `offset`: the load cell's tare in its frame, two columns before the offsets
    /// (see [`super::tare`]).
    pub(super) tare: bool,
    pub(super) pneumatic: (f64, f64),
    pub(super) stiffness: Stiffness,
    pub(super) mass: MassForm,
    /// Normal equations of `cols` on the training rows: shared by every fit with this
    /// variant.
    pub(super) normal: lsq::Normal,
}

impl BaseVariant {
    /// Parameters kept ≥ 0: the stiffness form's, the arm's scale, and the pneumatic term's
    /// diagonals.
    pub(super) fn positive(&self) -> Vec<usize> {
        self.stiffness
            .positive_with(self.mass, self.pneumatic.0 > 0.0)
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
) -> Result<Prepared, pam_ident::IdentError> {
    // the three preparations (kinematics once) and their fits on both cores, chosen in
    // order below
    let filters = [1.0, 0.6, 0.4].map(|f| FilterSettings {
        cutoff_hz: filter.cutoff_hz * f,
        ..filter
    });
    let prepared: Vec<(f64, Prepared)> = trial
        .prepare_each(model, &filters)?
        .into_par_iter()
        .map(|p| {
            let p = p.every(analysis_stride(p.dt_s));
            let y = msd::target(&p);
            let mut cols = msd::msd_columns(&p);
            cols.extend(offset_columns(p.len()));
            let ne = lsq::normal_equations(&cols, &[&y[0], &y[1]], 0..p.split());
            let th = lsq::solve(&ne, &MSD_POSITIVE);
            let yty: f64 = (0..2)
                .map(|a| y[a][..p.split()].iter().map(|v| v * v).sum::<f64>())
                .sum();
            (lsq::rss(&ne, yty, &th), p)
        })
        .collect();
    let mut best: Option<(f64, Prepared)> = None;
    for (rss, p) in prepared {
        // a lower cutoff must gain more than rounding
        if best.as_ref().is_none_or(|b| rss < 0.995 * b.0) {
            best = Some((rss, p));
        }
    }
    Ok(best.expect("three cutoffs").1)
}

/// The columns every base variant starts from, made once so that the variants share them
/// (the fits' products with them are then computed once, see [`lsq::GramMemo`]): eq.
/// 4.29's mass, damping and Cartesian stiffness, the arm's rigid body, and the offsets;
/// and the Jacobians every variant's joint-space columns go through.
pub(super) struct SharedColumns<'a> {
    pub(super) msd: Vec<Column>,
    /// The arm's rigid-body dynamics ([`rigid_body_column`]) when the training part takes
    /// it.
    pub(super) arm: Option<Column>,
    pub(super) offsets: [Column; 2],
    pub(super) ctx: DynCtx<'a>,
}

impl<'a> SharedColumns<'a> {
    pub(super) fn of(p: &'a Prepared, model: &'a RobotModel<f64>) -> Self {
        let mut shared = SharedColumns {
            msd: msd::msd_columns(p),
            arm: None,
            offsets: offset_columns(p.len()),
            ctx: DynCtx::new(p, model),
        };
        let arm = rigid_body_column(&shared.ctx);
        if arm_pays(p, &shared, &arm) {
            shared.arm = Some(arm);
        }
        shared
    }

    pub(super) fn mass(&self) -> MassForm {
        if self.arm.is_some() {
            MassForm::CartesianAndArm
        } else {
            MassForm::Cartesian
        }
    }
}

/// Whether the arm's rigid-body column pays for itself, like the pneumatic term: half a per
/// cent of the training residual and the BIC on the plain residual's effective samples. A
/// rig whose inertia sits at the handle, or a simulator with a constant Cartesian mass, does
/// without it and its cost. Judged with the joint-space stiffness: the Cartesian one leaves
/// the kinematics' curvature in the residual, which hides what the arm adds.
fn arm_pays(p: &Prepared, without: &SharedColumns, arm: &Column) -> bool {
    let Some(mut plain) = base_columns(p, &without.ctx, Stiffness::Joint, 0.0, 0.0, without) else {
        return false;
    };
    let mut with_arm = plain.clone();
    with_arm.push(arm.clone());
    for cols in [&mut plain, &mut with_arm] {
        cols.extend(without.offsets.iter().cloned());
    }
    let y = msd::target(p);
    let target = [y[0].as_slice(), y[1].as_slice()];
    let yty = sum_of_squares(&y, p.split());
    let fit = |cols: &[Column], mass: MassForm| {
        let ne = lsq::normal_equations(cols, &target, 0..p.split());
        let th = lsq::solve(&ne, &Stiffness::Joint.positive_with(mass, false));
        (lsq::rss(&ne, yty, &th), th)
    };
    let (rss_plain, th) = fit(&plain, MassForm::Cartesian);
    let (rss_arm, _) = fit(&with_arm, MassForm::CartesianAndArm);
    let ratio = rss_arm / rss_plain.max(1e-300);
    let n_eff = training_effective_samples(p, &plain, &th, &y);
    ratio < 0.995 && n_eff * ratio.ln() + n_eff.ln() < 0.0
}

/// The effective number of independent samples of a fit's training residual (`y` the
/// target): the sample count a term's BIC is charged on.
fn training_effective_samples(
    p: &Prepared,
    cols: &[Column],
    theta: &[f64],
    y: &[Vec<f64>; 2],
) -> f64 {
    let pred = lsq::predict(cols, theta, p.split());
    let residuals: Vec<Vec<f64>> = (0..2)
        .map(|a| (0..p.split()).map(|i| y[a][i] - pred[a][i]).collect())
        .collect();
    effective_samples_of(&residuals)
}

/// Each joint's angle from where the trial starts (the smoothed angles).
fn joint_angle_changes(p: &Prepared) -> [Vec<f64>; 2] {
    [0, 1].map(|j| {
        p.alpha_smooth_rad[j]
            .iter()
            .map(|a| a - p.alpha0_rad[j])
            .collect()
    })
}

/// How the dynamic base model writes the inertia the hand feels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MassForm {
    /// A symmetric Cartesian mass, constant over the trial (eq. 4.29 as printed): 3
    /// parameters.
    Cartesian,
    /// The same and the arm's own rigid-body dynamics in joint space, one scale
    /// ([`rigid_body_column`], after the stiffness's columns): 4 parameters.
    CartesianAndArm,
}

/// The arm's own rigid-body dynamics, M(θ) θ̈ + C(θ, θ̇) θ̇ (eq. 4.14–4.17 with the
/// segments' masses, and their Coriolis and centrifugal torques), as a handle force through
/// J⁻ᵀ at each sample, one scale: −f = s·J⁻ᵀ(M θ̈ + C θ̇). A Cartesian mass constant over the
/// trial is the arm's inertia at one pose only: across the operator's few centimetres the
/// elbow's angle changes it by several per cent, and the motion's centrifugal forces add
/// to it, a residual quadratic in the motion that a pose dependence would otherwise take
/// (two of pam-physgen's controls: with the arm's inertia halved neither raised one,
/// doubled both were named a pose dependence). The joint rates are the smoothed angles'
/// central differences, on the derivatives' band.
fn rigid_body_column(ctx: &DynCtx) -> Column {
    let p = ctx.p;
    let n = p.len();
    let a = &p.alpha_smooth_rad;
    let h = p.dt_s;
    let rates = |j: usize, i: usize| -> (f64, f64) {
        if n < 3 {
            return (0.0, 0.0);
        }
        let k = i.clamp(1, n - 2);
        (
            (a[j][k + 1] - a[j][k - 1]) / (2.0 * h),
            (a[j][k + 1] - 2.0 * a[j][k] + a[j][k - 1]) / (h * h),
        )
    };
    let params = &ctx.model.params;
    ctx.torque_column("rigid_body_scale", |i| {
        let (w1, a1) = rates(0, i);
        let (w2, a2) = rates(1, i);
        let theta2 = ctx.model.kinematics.theta([a[0][i], a[1][i]])[1];
        let m = joint_inertia(params, theta2).mul_vec([a1, a2]);
        let c = coriolis_torques(params, theta2, [w1, w2]);
        // the columns are in −f, and `torque_column` writes −J⁻ᵀτ
        [-(m[0] + c[0]), -(m[1] + c[1])]
    })
}

/// A constant force per axis (the parameter is the offset of the measured f; the columns
/// are in −f).
pub(super) fn offset_columns(n: usize) -> [Column; 2] {
    [
        Column::on("offset_n_x", 0, vec![-1.0; n]),
        Column::on("offset_n_y", 1, vec![-1.0; n]),
    ]
}

/// The stride that puts a trial on the model loop's 5 ms analysis grid
/// ([`super::analysis_trial`]): after the derivative filter (8 Hz) a dynamic trial carries
/// nothing a 200 Hz grid loses. On the grid the stride is 1: every fit uses every row.
pub(super) fn analysis_stride(dt_s: f64) -> usize {
    // (a log's mean period is rarely exact: 0.005 / 0.001000000001 must still be 5)
    ((0.005 / dt_s + 1e-6).floor() as usize).max(1)
}

/// Σ y² of both axes over the first `rows` samples.
pub(super) fn sum_of_squares(y: &[Vec<f64>; 2], rows: usize) -> f64 {
    y.iter()
        .map(|axis| axis[..rows].iter().map(|v| v * v).sum::<f64>())
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

    /// Number of base columns without the pneumatic term (M, B, the stiffness and, with
    /// that mass form, the arm).
    pub fn plain_len(self, mass: MassForm) -> usize {
        self.block_len() + usize::from(mass == MassForm::CartesianAndArm)
    }

    /// Number of columns of M, B and the stiffness.
    fn block_len(self) -> usize {
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

    /// [`Self::positive`], the rigid body's scale with that mass form, and, with the
    /// pneumatic term, its diagonals: a stretched
    /// muscle's volume shrinks and its pressure rises until the converter bleeds it back,
    /// so the gas stiffens the arm at the motion's faster frequencies and never softens it.
    /// A force that lags the motion (a load cell's filter, the sensors read at different
    /// instants) softens it there; kept physical, the term leaves that lag to the delay
    /// family.
    pub fn positive_with(self, mass: MassForm, pneumatic: bool) -> Vec<usize> {
        let mut v = self.positive().to_vec();
        if mass == MassForm::CartesianAndArm {
            v.push(self.block_len());
        }
        if pneumatic {
            let at = self.plain_len(mass);
            v.extend([at, at + 2]);
        }
        v
    }

    /// Whether the base carries a constant force per axis: the trial's equilibrium is known
    /// only to an encoder count and the load cell's tare only to its drift, so a constant
    /// force is part of the base, not a missing effect (the preload form has its own).
    pub(super) fn takes_offset(self) -> bool {
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
pub(super) fn base_columns(
    p: &Prepared,
    ctx: &DynCtx,
    stiffness: Stiffness,
    omega_n: f64,
    zeta: f64,
    shared: &SharedColumns,
) -> Option<Vec<Column>> {
    let mut cols = shared.msd.clone();
    match stiffness {
        Stiffness::Cartesian => {}
        Stiffness::Joint => {
            cols.truncate(6);
            cols.extend(joint_stiffness_columns(ctx, &joint_angle_changes(p), "kj"));
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
    if let Some(arm) = &shared.arm {
        cols.push(arm.clone());
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
pub(super) fn choose_pneumatic(
    p: &Prepared,
    model: &RobotModel<f64>,
    stiffness: Stiffness,
    shared: &SharedColumns,
) -> Option<(Vec<Column>, (f64, f64))> {
    let y = msd::target(p);
    let rows = 0..p.split();
    let yty = sum_of_squares(&y, p.split());
    let wn0 = model.params.ip.natural_freq_rad_s;
    let ctx = &shared.ctx;
    let z0 = model.params.ip.damping_ratio;
    let with_offset = |cols: &[Column]| {
        let mut c = cols.to_vec();
        if stiffness.takes_offset() {
            c.extend(shared.offsets.iter().cloned());
        }
        c
    };
    // without the pneumatic term
    let plain = base_columns(p, ctx, stiffness, 0.0, 0.0, shared)?;
    let plain_off = with_offset(&plain);
    let target = [y[0].as_slice(), y[1].as_slice()];
    let ne_plain = lsq::normal_equations(&plain_off, &target, rows.clone());
    let th_plain = lsq::solve(&ne_plain, &stiffness.positive_with(shared.mass(), false));
    let rss_plain = lsq::rss(&ne_plain, yty, &th_plain);
    // the pneumatic columns go after the plain ones (and before the offsets, as in
    // `base_columns`); only their products are new, the plain block is reused
    let plain_ne = ne_plain.prefix(plain.len());
    let mut best: Option<(f64, Vec<Column>, (f64, f64))> = None;
    // the grid's fits share the plain and offset columns: their products once
    let mut memo = lsq::GramMemo::default();
    for (wf, z) in [0.6, 1.0, 1.6]
        .iter()
        .flat_map(|&wf| [z0, 0.7, 1.0].into_iter().map(move |z| (wf, z)))
    {
        let mut cols = plain.clone();
        cols.extend(pneumatic_columns(
            p,
            ctx,
            stiffness.joint_space(),
            wn0 * wf,
            z,
        ));
        let ne = lsq::normal_equations_extended(
            &plain_ne,
            &with_offset(&cols),
            &target,
            rows.clone(),
            &mut memo,
        );
        let th = lsq::solve(&ne, &stiffness.positive_with(shared.mass(), true));
        let r = lsq::rss(&ne, yty, &th);
        if best.as_ref().is_none_or(|b| r < b.0) {
            best = Some((r, cols, (wn0 * wf, z)));
        }
    }
    let (rss_pn, cols, wz) = best.expect("grid is not empty");
    // the term must pay for itself like an effect: a relative gain of 1 % and the BIC on
    // the effective number of samples of the plain residual (4 parameters with the grid)
    let n_eff = training_effective_samples(p, &plain_off, &th_plain, &y);
    let ratio = rss_pn / rss_plain.max(1e-300);
    Some(
        if ratio < 0.99 && n_eff * ratio.ln() + 4.0 * n_eff.ln() < 0.0 {
            (cols, wz)
        } else {
            (plain, (0.0, 0.0))
        },
    )
}
