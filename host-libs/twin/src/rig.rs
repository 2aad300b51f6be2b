//! What the assembled rig has that the thesis's model does not, calibrated from the thesis's
//! own identification.
//!
//! The thesis identified the Cartesian stiffness at point 1 three times (§4.3–4.4): a static
//! trial and dynamic trials at the low and the high stiffness. All three exceed its model
//! (Fig. 4.3), statically too, so the missing stiffness is not a dynamic effect (air
//! compressibility is in the twin and adds little: see README, "Stiffness"). Mapped into joint
//! space (K_J = Jᵀ K_C J) the excess is nearly the same at both stiffness levels and mostly on
//! the diagonal: a passive elastic element in parallel with each muscle pair (the sleeves'
//! and end fittings' bending, the cable wrap), roughly independent of pressure.
//!
//! The identified rig ([`TwinConfig::identified_rig`](crate::TwinConfig::identified_rig))
//! therefore has a parallel joint stiffness with its rest at the neutral pose, the mean excess
//! of two of the three identified matrices (static low, dynamic high). The third (dynamic low,
//! the one issue 3 compares against) is held out: reproducing it is a check of the whole chain,
//! not an input to it.
//!
//! It is not the default. A spring with its rest at the neutral pose preloads the handle
//! everywhere else (at point 2 of Table 4.1, ≈ 20 N), so away from neutral the rig's force no
//! longer vanishes where the thesis's model puts the equilibrium; a linear model fitted with
//! "the equilibrium from the start of the trial" (§4.3) reads that as an offset. The default
//! twin is the thesis's model, consistent at every pose, so that a log without a hidden effect
//! is a clean control case anywhere.

use pam_model::mat2::Mat2;
use pam_model::{RobotModel, RobotParams};

use crate::experiments::{trial_stiffness, StiffnessLevel};

/// Thesis §4.3, static trial, point 1, K_low: pure-spring fit (eq. 4.28), N/m, user frame.
pub const KC_STATIC_LOW_POINT1_N_PER_M: [[f64; 2]; 2] = [[145.9, 73.5], [73.5, 387.0]];
/// Thesis §4.3, dynamic trial, point 1, K_high: temporal MSD fit, N/m.
pub const KC_DYNAMIC_HIGH_POINT1_N_PER_M: [[f64; 2]; 2] = [[304.1, 166.7], [166.7, 491.5]];
/// Thesis §4.3, dynamic trial, point 1, K_low: temporal MSD fit, N/m. Held out of the
/// calibration.
pub const KC_DYNAMIC_LOW_POINT1_N_PER_M: [[f64; 2]; 2] = [[253.7, 107.1], [107.1, 364.0]];

/// The parallel joint stiffness (N·m/rad) that explains the identified matrices at point 1:
/// the mean over the static-low and dynamic-high trials of diag(Jᵀ K_C J) − K_model.
pub fn parallel_stiffness_from_thesis(params: &RobotParams<f64>) -> [f64; 2] {
    let model = RobotModel::new(*params);
    let alpha = [0.0; 2];
    let jacobian = model.kinematics.jacobian(alpha);
    let mut excess = [0.0; 2];
    let trials = [
        (KC_STATIC_LOW_POINT1_N_PER_M, StiffnessLevel::Low),
        (KC_DYNAMIC_HIGH_POINT1_N_PER_M, StiffnessLevel::High),
    ];
    for (k_c, level) in trials {
        let k_joint = Mat2(k_c).congruence(&jacobian);
        let k_model = trial_stiffness(&model, alpha, level);
        for j in 0..2 {
            excess[j] += (k_joint.0[j][j] - k_model[j]) / trials.len() as f64;
        }
    }
    excess
}
