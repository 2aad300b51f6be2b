//! The whole robot: both joints, kinematics and the signal laws, with every derived
//! constant computed once. This is what the firmware's control step calls.

use crate::cartesian::{joint_inertia, joint_to_cartesian};
use crate::joint::{Capability, InverseSolution, JointConsts, JointPose, Limited};
use crate::kinematics::{Kinematics, PoseTrig};
use crate::mat2::{Mat2, Vec2};
use crate::params::RobotParams;
use crate::real::Real;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotModel<R> {
    pub params: RobotParams<R>,
    pub joints: [JointConsts<R>; 2],
    pub kinematics: Kinematics<R>,
}

/// One joint's capability at a pose together with the inverse-model answer there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointEvaluation<R> {
    pub capability: Capability<R>,
    pub solution: InverseSolution<R>,
}

/// A Cartesian force request turned into joint requests and pressures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceCommand<R> {
    /// The force actually commanded after the gain-plane correction (if enabled).
    pub force_cmd_n: Vec2<R>,
    pub gain_limited: bool,
    pub joint_torque_nm: Vec2<R>,
    pub joints: [InverseSolution<R>; 2],
}

impl<R: Real> RobotModel<R> {
    pub fn new(params: RobotParams<R>) -> Self {
        let joints = [
            JointConsts::new(&params.joints[0], &params.muscle, &params.pressure),
            JointConsts::new(&params.joints[1], &params.muscle, &params.pressure),
        ];
        let kinematics = Kinematics::new(&params);
        RobotModel {
            params,
            joints,
            kinematics,
        }
    }

    pub fn thesis() -> Self {
        Self::new(RobotParams::thesis())
    }

    #[inline]
    pub fn pose(&self, joint: usize, alpha_rad: R) -> JointPose<R> {
        self.joints[joint].pose(&self.params.muscle, alpha_rad)
    }

    pub fn capability(&self, joint: usize, alpha_rad: R) -> Capability<R> {
        self.pose(joint, alpha_rad).capability(&self.joints[joint])
    }

    /// Direct model for both joints: `pressure_bar[j] = [P1, P2]` → `(τ, K)` per joint.
    pub fn direct(&self, alpha_rad: Vec2<R>, pressure_bar: [[R; 2]; 2]) -> [(R, R); 2] {
        let mut out = [(R::ZERO, R::ZERO); 2];
        for j in 0..2 {
            let pose = self.pose(j, alpha_rad[j]);
            out[j] = (
                pose.torque_nm(pressure_bar[j]),
                pose.stiffness_nm_per_rad(pressure_bar[j]),
            );
        }
        out
    }

    /// Inverse model for both joints, with limits.
    pub fn inverse(
        &self,
        alpha_rad: Vec2<R>,
        torque_nm: Vec2<R>,
        stiffness_nm_per_rad: Vec2<R>,
    ) -> [InverseSolution<R>; 2] {
        let m = &self.params.muscle;
        [
            self.joints[0].inverse(m, alpha_rad[0], torque_nm[0], stiffness_nm_per_rad[0]),
            self.joints[1].inverse(m, alpha_rad[1], torque_nm[1], stiffness_nm_per_rad[1]),
        ]
    }

    /// One full model evaluation for both joints: muscles at the pose, capability
    /// quadrilateral, inverse model with clamping, direct model of the result.
    pub fn evaluate(
        &self,
        alpha_rad: Vec2<R>,
        torque_nm: Vec2<R>,
        stiffness_nm_per_rad: Vec2<R>,
    ) -> [JointEvaluation<R>; 2] {
        let one = |j: usize| {
            let consts = &self.joints[j];
            let a = alpha_rad[j];
            if !consts.alpha_in_range(a) {
                // capability at the nearest valid angle, answer the safe pretension
                let a_valid = if a.is_finite() {
                    a.clamp_to(consts.alpha_min_rad, consts.alpha_max_rad)
                } else {
                    R::ZERO
                };
                return JointEvaluation {
                    capability: self.capability(j, a_valid),
                    solution: consts.inverse(
                        &self.params.muscle,
                        a,
                        torque_nm[j],
                        stiffness_nm_per_rad[j],
                    ),
                };
            }
            let pose = self.pose(j, a);
            let capability = pose.capability(consts);
            let solution =
                consts.solve_within(&pose, &capability, torque_nm[j], stiffness_nm_per_rad[j]);
            JointEvaluation {
                capability,
                solution,
            }
        };
        [one(0), one(1)]
    }

    /// Cartesian force mode: F (user frame, the force the handle exerts) → optional gain
    /// plane correction → τ = Jᵀ F → inverse model at the requested joint stiffness.
    pub fn force_command(
        &self,
        alpha_rad: Vec2<R>,
        force_ref_n: Vec2<R>,
        stiffness_nm_per_rad: Vec2<R>,
        feed_forward: bool,
    ) -> ForceCommand<R> {
        self.force_command_at(
            alpha_rad,
            &self.kinematics.trig(alpha_rad),
            force_ref_n,
            stiffness_nm_per_rad,
            feed_forward,
        )
    }

    /// The same with the pose's trig already computed (the control step shares it with the
    /// load-cell rotation).
    pub fn force_command_at(
        &self,
        alpha_rad: Vec2<R>,
        trig: &PoseTrig<R>,
        force_ref_n: Vec2<R>,
        stiffness_nm_per_rad: Vec2<R>,
        feed_forward: bool,
    ) -> ForceCommand<R> {
        let (force_cmd_n, gain_limited, joint_torque_nm) =
            self.joint_torque_for(alpha_rad, trig, force_ref_n, feed_forward);
        let joints = self.inverse(alpha_rad, joint_torque_nm, stiffness_nm_per_rad);
        ForceCommand {
            force_cmd_n,
            gain_limited,
            joint_torque_nm,
            joints,
        }
    }

    /// The force mode's first half: the optional gain-plane correction of the requested
    /// force, and the joint torques τ = Jᵀ F of the corrected force (with whether the plane
    /// was limited).
    pub(crate) fn joint_torque_for(
        &self,
        alpha_rad: Vec2<R>,
        trig: &PoseTrig<R>,
        force_ref_n: Vec2<R>,
        feed_forward: bool,
    ) -> (Vec2<R>, bool, Vec2<R>) {
        let (force_cmd_n, gain_limited) = if feed_forward {
            self.params.gain_plane.correct(force_ref_n, alpha_rad)
        } else {
            (force_ref_n, false)
        };
        let joint_torque_nm = self
            .kinematics
            .jacobian_at(trig)
            .transpose()
            .mul_vec(force_cmd_n);
        (force_cmd_n, gain_limited, joint_torque_nm)
    }

    /// The four channel pressures (I/P outputs 0..=3) from per-joint `[P1, P2]`, through
    /// each joint's channel map (this is where joint 1's permuted numbering is applied).
    pub fn channel_pressures_bar(&self, joint_pressure_bar: [[R; 2]; 2]) -> [R; 4] {
        let mut out = [R::ZERO; 4];
        for j in 0..2 {
            let map = self.params.joints[j].channel_of_muscle;
            out[(map[0] & 3) as usize] = joint_pressure_bar[j][0];
            out[(map[1] & 3) as usize] = joint_pressure_bar[j][1];
        }
        out
    }

    /// Per-joint `[P1, P2]` from the four channel pressures (inverse of the map above).
    pub fn joint_pressures_bar(&self, channel_pressure_bar: [R; 4]) -> [[R; 2]; 2] {
        let mut out = [[R::ZERO; 2]; 2];
        for j in 0..2 {
            let map = self.params.joints[j].channel_of_muscle;
            out[j] = [
                channel_pressure_bar[(map[0] & 3) as usize],
                channel_pressure_bar[(map[1] & 3) as usize],
            ];
        }
        out
    }

    /// Cartesian stiffness at the handle for diagonal joint stiffness (eq. 4.13, 4.23).
    pub fn cartesian_stiffness(
        &self,
        alpha_rad: Vec2<R>,
        stiffness_nm_per_rad: Vec2<R>,
    ) -> Option<Mat2<R>> {
        let j = self.kinematics.jacobian(alpha_rad);
        joint_to_cartesian(
            &j,
            &Mat2::diag(stiffness_nm_per_rad[0], stiffness_nm_per_rad[1]),
        )
    }

    /// Cartesian mass at the handle (eq. 4.11).
    pub fn cartesian_mass(&self, alpha_rad: Vec2<R>) -> Option<Mat2<R>> {
        let j = self.kinematics.jacobian(alpha_rad);
        let theta = self.kinematics.theta(alpha_rad);
        joint_to_cartesian(&j, &joint_inertia(&self.params, theta[1]))
    }

    /// Whether any joint's answer was changed to make it attainable.
    pub fn any_limited(solutions: &[InverseSolution<R>; 2]) -> Limited {
        solutions[0].limited.with(solutions[1].limited)
    }
}
