//! Joint-space ↔ Cartesian mass, damping and stiffness (eq. 4.11–4.13, 4.21) and the
//! joint inertia matrix of the two segments (eq. 4.14–4.17).

use crate::mat2::{Mat2, Vec2};
use crate::params::RobotParams;
use crate::real::Real;

/// X_C = J⁻ᵀ · X_j · J⁻¹ (eq. 4.11–4.13). `None` at a singular pose.
pub fn joint_to_cartesian<R: Real>(jacobian: &Mat2<R>, joint_matrix: &Mat2<R>) -> Option<Mat2<R>> {
    let inv = jacobian.inverse()?;
    Some(joint_matrix.congruence(&inv))
}

/// X_j = Jᵀ · X_C · J, the inverse map.
pub fn cartesian_to_joint<R: Real>(jacobian: &Mat2<R>, cartesian_matrix: &Mat2<R>) -> Mat2<R> {
    cartesian_matrix.congruence(jacobian)
}

/// Joint inertia matrix I(θ) of the two-link arm, each segment a rigid body with its centre
/// of mass on the link line.
///
/// The thesis's eq. 4.15 and 4.17 lost their operators in print; this is the standard
/// form they come from (Newton–Euler for a planar two-link arm): with c = cos θ2,
/// I11 = I1 + m1·r1² + I2 + m2(l1² + r2² + 2 l1 r2 c), I12 = I2 + m2(r2² + l1 r2 c),
/// I22 = I2 + m2·r2² (r_i the centre-of-mass distance, I_i about the centre of mass).
pub fn joint_inertia<R: Real>(params: &RobotParams<R>, theta2_rad: R) -> Mat2<R> {
    joint_inertia_cos(params, theta2_rad.cos())
}

/// [`joint_inertia`] from cos θ2 (when the pose's sines and cosines are already known).
pub fn joint_inertia_cos<R: Real>(params: &RobotParams<R>, cos_theta2: R) -> Mat2<R> {
    let s1 = &params.joints[0].segment;
    let s2 = &params.joints[1].segment;
    let l1 = params.joints[0].segment_length_m;
    let (m1, r1, i1) = (s1.mass_kg, s1.com_distance_m, s1.inertia_com_kg_m2);
    let (m2, r2, i2) = (s2.mass_kg, s2.com_distance_m, s2.inertia_com_kg_m2);
    let c = cos_theta2;
    let two = R::from_f64(2.0);
    let i22 = i2 + m2 * r2 * r2;
    let i12 = i22 + m2 * l1 * r2 * c;
    let i11 = i1 + m1 * r1 * r1 + i22 + m2 * (l1 * l1 + two * l1 * r2 * c);
    Mat2::symmetric(i11, i12, i22)
}

/// Coriolis and centrifugal torques C(θ, θ̇) of the same arm (the velocity-squared terms
/// the thesis names as unmodelled, §4.6).
pub fn coriolis_torques<R: Real>(
    params: &RobotParams<R>,
    theta2_rad: R,
    theta_dot_rad_s: Vec2<R>,
) -> Vec2<R> {
    let s2 = &params.joints[1].segment;
    let l1 = params.joints[0].segment_length_m;
    let h = s2.mass_kg * l1 * s2.com_distance_m * theta2_rad.sin();
    let (w1, w2) = (theta_dot_rad_s[0], theta_dot_rad_s[1]);
    let two = R::from_f64(2.0);
    [-h * (two * w1 * w2 + w2 * w2), h * w1 * w1]
}
