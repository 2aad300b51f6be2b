//! What the generator takes from the robot model: kinematics, the open-loop inverse model
//! that turns (torque, stiffness) into the logged currents, Table 4.1's points and §5.2's
//! nine step poses, and the thesis's identified dynamics.

use pam_model::thesis::TABLE_4_1;
use pam_model::RobotModel;

/// 2×2 matrix, row major.
pub type M2 = [[f64; 2]; 2];

pub fn mul(m: &M2, v: [f64; 2]) -> [f64; 2] {
    [
        m[0][0] * v[0] + m[0][1] * v[1],
        m[1][0] * v[0] + m[1][1] * v[1],
    ]
}

/// Symmetric positive definite (both leading minors > 0).
pub fn is_pd(m: &M2) -> bool {
    m[0][0] > 0.0 && m[0][0] * m[1][1] - m[0][1] * m[1][0] > 0.0
}

/// Cartesian K at point 1, minimum stiffness, temporal fit (§4.3): N/m.
pub const K_THESIS: M2 = [[253.7, 107.1], [107.1, 364.0]];
/// Cartesian B (§4.3) with B_yy raised from the printed 0.9 to 13 N·s/m: the printed matrix
/// is not positive definite, and §4.3–4.4 give 13–27 N·s/m on the diagonal.
pub const B_THESIS: M2 = [[26.6, 9.4], [9.4, 13.0]];
/// Cartesian M (§4.3) with the printed, unphysical M_yy = −0.027 kg replaced by 0.9 kg
/// (M_xx of the same fit is 0.93 kg).
pub const M_THESIS: M2 = [[0.93, -0.053], [-0.053, 0.9]];

/// Encoder resolution: the device's default calibration (a 2 000-line encoder read on all
/// four edges, `pam_protocol::EncoderCalibration::default`).
pub const ENCODER_COUNTS_PER_REV: f64 = 8000.0;

/// Rounds an angle to the encoder's counts.
pub fn quantise(alpha_rad: f64) -> f64 {
    let q = 2.0 * std::f64::consts::PI / ENCODER_COUNTS_PER_REV;
    (alpha_rad / q).round() * q
}

/// Table 4.1's point `site` (1–5), radians.
pub fn point_alpha_rad(site: usize) -> [f64; 2] {
    let (a1, a2, _) = TABLE_4_1[(site - 1).min(4)];
    [a1.to_radians(), a2.to_radians()]
}

pub use pam_model::thesis::STEP_POSES_DEG;

pub fn step_pose_rad(site: usize) -> [f64; 2] {
    let p = STEP_POSES_DEG[(site - 1).min(8)];
    [p[0].to_radians(), p[1].to_radians()]
}

/// Channel currents (mA) for per-joint muscle pressures, through the joint channel map and
/// the I/P law (eq. 2.2).
pub fn currents_ma(model: &RobotModel<f64>, joint_pressure_bar: [[f64; 2]; 2]) -> [f64; 4] {
    let ch = model.channel_pressures_bar(joint_pressure_bar);
    ch.map(|p| model.params.ip.current_for(p).current_ma)
}

/// Channel pressures (bar) the converters regulate to for logged currents.
pub fn pressures_bar(model: &RobotModel<f64>, currents_ma: [f64; 4]) -> [f64; 4] {
    currents_ma.map(|i| model.params.ip.pressure_bar(i))
}

/// The open-loop force command of fig. 4.1 (no gain-plane feed-forward): the joint
/// pressures for a force at the handle at the given joint stiffness, and whether the
/// inverse model had to clamp the request.
pub fn force_pressures(
    model: &RobotModel<f64>,
    alpha_rad: [f64; 2],
    force_n: [f64; 2],
    stiffness_nm_per_rad: [f64; 2],
) -> ([[f64; 2]; 2], bool) {
    let cmd = model.force_command(alpha_rad, force_n, stiffness_nm_per_rad, false);
    let limited = cmd.joints.iter().any(|j| j.limited.0 != 0);
    (
        [cmd.joints[0].pressure_bar, cmd.joints[1].pressure_bar],
        limited,
    )
}

/// Handle force (user frame) of the model's muscles at channel pressures, blocked at α.
pub fn model_force_n(
    model: &RobotModel<f64>,
    alpha_rad: [f64; 2],
    channel_bar: [f64; 4],
) -> [f64; 2] {
    let jp = model.joint_pressures_bar(channel_bar);
    let d = model.direct(alpha_rad, jp);
    let tau = [d[0].0, d[1].0];
    // τ = Jᵀ F  →  F = J⁻ᵀ τ
    let j = model.kinematics.jacobian(alpha_rad);
    let jt = j.transpose();
    match jt.inverse() {
        Some(inv) => inv.mul_vec(tau),
        None => [0.0, 0.0],
    }
}

/// J⁻ᵀ τ: the handle force that carries joint torques `tau_nm` (user frame).
pub fn torque_to_force(model: &RobotModel<f64>, alpha_rad: [f64; 2], tau_nm: [f64; 2]) -> [f64; 2] {
    match model.kinematics.jacobian(alpha_rad).transpose().inverse() {
        Some(inv) => inv.mul_vec(tau_nm),
        None => [0.0, 0.0],
    }
}
