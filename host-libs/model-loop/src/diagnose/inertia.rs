//! The inertia the dynamic base model lets the hand feel besides eq. 4.29's constant
//! Cartesian mass: a constant inertia at each joint, and the arm's own rigid-body dynamics.
//! Each is a set of columns with coefficients ≥ 0, taken only when the training part pays
//! for it (see `base::pays`).

use crate::effects::DynCtx;
use pam_model::cartesian::{coriolis_torques, joint_inertia};
use pam_numerics::lsq::Column;

/// How the dynamic base model writes the inertia the hand feels: a symmetric Cartesian
/// mass, constant over the trial (eq. 4.29 as printed, 3 parameters, always), and, when the
/// training part asks for them, after the stiffness's columns in this order:
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MassForm {
    /// a constant inertia at each joint ([`joint_inertia_columns`]): 2 parameters;
    pub joint: bool,
    /// the arm's rigid-body dynamics ([`rigid_body_column`]): 1 parameter.
    pub arm: bool,
}

impl MassForm {
    /// Number of columns beyond the Cartesian mass.
    pub fn columns(self) -> usize {
        2 * usize::from(self.joint) + usize::from(self.arm)
    }
}

/// A joint's rate and acceleration at row `i`: the smoothed angles' central differences,
/// on the derivatives' band.
fn rates(ctx: &DynCtx, j: usize, i: usize) -> (f64, f64) {
    let p = ctx.p;
    let (a, n, h) = (&p.alpha_smooth_rad[j], p.len(), p.dt_s);
    if n < 3 {
        return (0.0, 0.0);
    }
    let k = i.clamp(1, n - 2);
    (
        (a[k + 1] - a[k - 1]) / (2.0 * h),
        (a[k + 1] - 2.0 * a[k] + a[k - 1]) / (h * h),
    )
}

/// A constant inertia at each joint, −f = J⁻ᵀ diag(I₁, I₂) α̈, I ≥ 0 (kg·m²): what turns
/// with a joint whatever the pose (its pulley, cable and shaft, and the part of the arm's
/// inertia about it that the elbow does not change). The muscles and pulleys act at the
/// joints, so through the Jacobian this inertia changes with the pose across the
/// operator's few centimetres, which a Cartesian mass constant over the trial cannot
/// follow: a residual even in the motion that `pose_dependence` or
/// `stiffness_nonlinearity` would otherwise take. On pam-physgen's dynamic controls the
/// fit puts about 0.6 kg·m² at joint 1 and keeps about 0.7 kg in the Cartesian mass:
/// together about the 1.1 kg·m² the model's segments give joint 1 with the elbow square
/// (eq. 4.15). The noise-free trace of one such control had `pose_dependence` remove 61 %
/// of the error without these columns, and 12 % with them.
pub(super) fn joint_inertia_columns(ctx: &DynCtx) -> Vec<Column> {
    vec![
        // the columns are in −f, and `torque_column` writes −J⁻ᵀτ
        ctx.torque_column("joint_inertia_kg_m2_joint1", |i| [-rates(ctx, 0, i).1, 0.0]),
        ctx.torque_column("joint_inertia_kg_m2_joint2", |i| [0.0, -rates(ctx, 1, i).1]),
    ]
}

/// The arm's own rigid-body dynamics, M(θ) θ̈ + C(θ, θ̇) θ̇ (eq. 4.14–4.17 with the
/// segments' masses, and their Coriolis and centrifugal torques), as a handle force through
/// J⁻ᵀ at each sample, one scale: −f = s·J⁻ᵀ(M θ̈ + C θ̇). A Cartesian mass constant over the
/// trial is the arm's inertia at one pose only: across the operator's few centimetres the
/// elbow's angle changes it by several per cent, and the motion's centrifugal forces add
/// to it, a residual quadratic in the motion that a pose dependence would otherwise take
/// (two of pam-physgen's controls: with the arm's inertia halved neither raised one,
/// doubled both were named a pose dependence).
pub(super) fn rigid_body_column(ctx: &DynCtx) -> Column {
    let a = &ctx.p.alpha_smooth_rad;
    let params = &ctx.model.params;
    ctx.torque_column("rigid_body_scale", |i| {
        let (w1, a1) = rates(ctx, 0, i);
        let (w2, a2) = rates(ctx, 1, i);
        let theta2 = ctx.model.kinematics.theta([a[0][i], a[1][i]])[1];
        let m = joint_inertia(params, theta2).mul_vec([a1, a2]);
        let c = coriolis_torques(params, theta2, [w1, w2]);
        // the columns are in −f, and `torque_column` writes −J⁻ᵀτ
        [-(m[0] + c[0]), -(m[1] + c[1])]
    })
}
