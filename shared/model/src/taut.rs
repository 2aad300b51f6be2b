//! The inverse model with cables that cannot push (the closed loops).
//!
//! The capability quadrilateral (Table 3.2) is the image of the pressure box under the force
//! law, which is affine in pressure (eq. 3.1) and takes negative values at low pressure. Its
//! lower stiffness edge runs from K_min (both cables at the anti-slack force) to the τ_max /
//! τ_min corners, where one muscle is at the lowest pressure: along it the unloaded muscle's
//! force falls through zero at most poses. The inverse model then asks that muscle to
//! *push*. A cable cannot: on the rig (and in the twin) its force stays at zero, so only the
//! other muscle's share of a torque change reaches the handle. In the §5.2 force-step test,
//! whose stiffness is the least attainable at ±27.3 N, this happens on the steps to ±27.3 N
//! (and at some poses already at ±18.2 N): the plant's gain falls to about 0.45 and the torque
//! leaks into the other axis (measured: docs/closed-loop.md).
//!
//! [`JointConsts::inverse_taut`] keeps both forces at or above a floor: the muscle the
//! inverse model would unload below it is held at the floor and the other carries the whole
//! torque, τ = R (F2 − F1) (eq. 3.2). The torque is the one requested; the stiffness is then
//! higher than requested (flagged [`Limited::STIFFNESS`]), as it must be: the requested one is
//! not attainable with taut cables. If the loaded muscle would leave the pressure range it is
//! put at the top of the range and the other gives up its margin, down to zero force, before
//! the torque is cut; a torque beyond that is flagged [`Limited::PRESSURE`] (the closed loop's
//! anti-windup reads it). The open-loop force mode keeps the thesis's inverse model unchanged.

use crate::joint::{InverseSolution, JointConsts, Limited};
use crate::kinematics::PoseTrig;
use crate::mat2::Vec2;
use crate::params::MuscleCoeffs;
use crate::real::Real;
use crate::robot::{ForceCommand, RobotModel};

impl<R: Real> JointConsts<R> {
    /// [`JointConsts::inverse`] with no muscle force below `min_force_n` (see the module
    /// documentation). A solution whose forces are both at or above the floor is returned
    /// unchanged; so is an invalid-input or singular one (the safe pretension).
    // not inlined: inlined, it changed how the rest of the control step was compiled and cost
    // the open-loop and impedance steps about 200 instructions each (QEMU, measured)
    #[inline(never)]
    pub fn inverse_taut(
        &self,
        muscle: &MuscleCoeffs<R>,
        alpha_rad: R,
        torque_nm: R,
        stiffness_nm_per_rad: R,
        min_force_n: R,
    ) -> InverseSolution<R> {
        if !self.alpha_in_range(alpha_rad) {
            // the inverse's own answer to invalid input (the safe pretension)
            return self.inverse(muscle, alpha_rad, torque_nm, stiffness_nm_per_rad);
        }
        let pose = self.pose(muscle, alpha_rad);
        let cap = pose.capability(self);
        let sol = self.solve_within(&pose, &cap, torque_nm, stiffness_nm_per_rad);
        if sol.limited.contains(Limited::INVALID_INPUT) || sol.limited.contains(Limited::SINGULAR) {
            return sol;
        }
        let f = pose.forces_n(sol.pressure_bar);
        if f[0] >= min_force_n && f[1] >= min_force_n {
            return sol;
        }
        // F2 − F1 of the (clamped) solution: the torque it was meant to give
        let diff_n = sol.torque_nm / self.pulley_radius_m;
        // s: the muscle held at the floor, l: the one that carries the torque
        let (s, l, sign) = if f[0] < f[1] {
            (0, 1, R::ONE)
        } else {
            (1, 0, -R::ONE)
        };
        let (lo, hi) = (self.pressure_min_bar, self.pressure_max_bar);
        let mut limited = sol.limited.with(Limited::STIFFNESS);
        let mut p = [R::ZERO; 2];
        p[s] = pose.muscles[s].pressure_for_force_bar(min_force_n);
        p[l] = pose.muscles[l].pressure_for_force_bar(min_force_n + sign * diff_n);
        if p[l] > hi {
            // the torque limit with taut cables: the loaded muscle at the top of the range,
            // the other gives up its margin down to zero force before the torque is cut
            p[l] = hi;
            let f_l = pose.muscles[l].force_n(hi);
            let f_s = (f_l - sign * diff_n).max(R::ZERO).min(min_force_n);
            p[s] = pose.muscles[s].pressure_for_force_bar(f_s);
            if f_l - sign * diff_n < R::ZERO {
                limited = limited.with(Limited::PRESSURE);
            }
        }
        let pc = [p[0].clamp_to(lo, hi), p[1].clamp_to(lo, hi)];
        let tol = R::from_f64(1e-3);
        // NaN included: a non-finite pressure is flagged (and clamped above)
        if !((pc[0] - p[0]).abs() <= tol && (pc[1] - p[1]).abs() <= tol) {
            limited = limited.with(Limited::PRESSURE);
        }
        InverseSolution {
            pressure_bar: pc,
            torque_nm: pose.torque_nm(pc),
            stiffness_nm_per_rad: pose.stiffness_nm_per_rad(pc),
            limited,
        }
    }

    /// The torque range with taut cables at this pose, N·m: the loaded muscle at the top of
    /// the pressure range, the other at `min_force_n` (or more, where the bottom of the range
    /// already gives more), τ = R (F2 − F1). The torque [`JointConsts::inverse_taut`] gives
    /// without cutting it, less the floor's margin. `None` for a pose out of range.
    pub fn taut_torque_range_nm(
        &self,
        muscle: &MuscleCoeffs<R>,
        alpha_rad: R,
        min_force_n: R,
    ) -> Option<(R, R)> {
        if !self.alpha_in_range(alpha_rad) {
            return None;
        }
        let pose = self.pose(muscle, alpha_rad);
        let (lo, hi) = (self.pressure_min_bar, self.pressure_max_bar);
        let unloaded = |m: usize| pose.muscles[m].force_n(lo).max(min_force_n);
        let r = self.pulley_radius_m;
        Some((
            r * (unloaded(1) - pose.muscles[0].force_n(hi)),
            r * (pose.muscles[1].force_n(hi) - unloaded(0)),
        ))
    }
}

impl<R: Real> RobotModel<R> {
    /// How much of a force command the muscles can give at this pose with taut cables: the
    /// largest s in [0, 1] for which τ = Jᵀ (s·`force_cmd_n` + `offset_cmd_n`) stays within
    /// `margin` × each joint's [`JointConsts::taut_torque_range_nm`]. The closed loop scales
    /// its target by it (the direction kept) so that its reference, feed-forward and integral
    /// ask only for what can arrive: a target beyond the capability otherwise saturates one
    /// joint, the other still follows, and the force turns away from the direction asked for
    /// (measured: +6.4 N on Y for −27.3 N on X at the rig's pose 4, docs/closed-loop.md).
    /// 1 where it cannot say: a joint's pose out of range, a command that is not finite, or an
    /// offset alone already beyond the range (the inverse model's limits and the loop's
    /// anti-windup and guard handle those).
    pub fn reachable_force_scale(
        &self,
        alpha_rad: Vec2<R>,
        trig: &PoseTrig<R>,
        force_cmd_n: Vec2<R>,
        offset_cmd_n: Vec2<R>,
        min_force_fraction: R,
        margin: R,
    ) -> R {
        let range = |j: usize| {
            let c = &self.joints[j];
            let floor = min_force_fraction * c.anti_slack_force_n;
            c.taut_torque_range_nm(&self.params.muscle, alpha_rad[j], floor)
        };
        self.scale_within(trig, force_cmd_n, offset_cmd_n, margin, range)
    }

    /// [`RobotModel::reachable_force_scale`] for the thesis's inverse model at the least
    /// stiffness (the impedance mode's): each joint's range is the capability
    /// quadrilateral's torque range at the pose (Table 3.2), which the inverse model would
    /// otherwise clamp each joint to on its own, turning the force.
    pub fn reachable_force_scale_least_stiffness(
        &self,
        alpha_rad: Vec2<R>,
        trig: &PoseTrig<R>,
        force_cmd_n: Vec2<R>,
        offset_cmd_n: Vec2<R>,
        margin: R,
    ) -> R {
        let range = |j: usize| {
            let in_range = self.joints[j].alpha_in_range(alpha_rad[j]);
            in_range.then(|| self.capability(j, alpha_rad[j]).torque_limits_nm())
        };
        self.scale_within(trig, force_cmd_n, offset_cmd_n, margin, range)
    }

    /// The largest s in [0, 1] with Jᵀ (s·`force_cmd_n` + `offset_cmd_n`) within `margin` ×
    /// `range(j)` on both joints (1 where it cannot say; see the callers).
    fn scale_within(
        &self,
        trig: &PoseTrig<R>,
        force_cmd_n: Vec2<R>,
        offset_cmd_n: Vec2<R>,
        margin: R,
        range: impl Fn(usize) -> Option<(R, R)>,
    ) -> R {
        let jt = self.kinematics.jacobian_at(trig).transpose();
        let (slope, offset) = (jt.mul_vec(force_cmd_n), jt.mul_vec(offset_cmd_n));
        let mut s = R::ONE;
        for j in 0..2 {
            let Some((lo, hi)) = range(j) else {
                continue;
            };
            let (lo, hi, a, b) = (margin * lo, margin * hi, slope[j], offset[j]);
            // NaN: every comparison is false and s stays as it is
            if !(b >= lo && b <= hi) {
                continue;
            }
            if a > R::ZERO && a + b > hi {
                s = s.min((hi - b) / a);
            } else if a < R::ZERO && a + b < lo {
                s = s.min((lo - b) / a);
            }
        }
        s
    }

    /// [`RobotModel::force_command_at`] with taut cables: each joint's muscles keep at least
    /// `min_force_fraction` × the joint's anti-slack force ([`JointConsts::inverse_taut`]).
    pub fn force_command_taut_at(
        &self,
        alpha_rad: Vec2<R>,
        trig: &PoseTrig<R>,
        force_ref_n: Vec2<R>,
        stiffness_nm_per_rad: Vec2<R>,
        feed_forward: bool,
        min_force_fraction: R,
    ) -> ForceCommand<R> {
        let (force_cmd_n, gain_limited, joint_torque_nm) =
            self.joint_torque_for(alpha_rad, trig, force_ref_n, feed_forward);
        let m = &self.params.muscle;
        let one = |j: usize| {
            let c = &self.joints[j];
            c.inverse_taut(
                m,
                alpha_rad[j],
                joint_torque_nm[j],
                stiffness_nm_per_rad[j],
                min_force_fraction * c.anti_slack_force_n,
            )
        };
        ForceCommand {
            force_cmd_n,
            gain_limited,
            joint_torque_nm,
            joints: [one(0), one(1)],
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::joint::Limited;
    use crate::robot::RobotModel;
    use crate::thesis::STEP_POSES_DEG;

    /// The §5.2 step test's worst step: 27.3 N along X at pose 7, at the test's stiffness.
    /// The thesis's inverse model asks a muscle for a negative force there; the taut one
    /// keeps it at the floor, gives the same torque, and is stiffer.
    #[test]
    fn no_muscle_is_asked_to_push_and_the_torque_is_kept() {
        let model = RobotModel::<f64>::thesis();
        let a = STEP_POSES_DEG[7];
        let alpha = [a[0].to_radians(), a[1].to_radians()];
        let k = crate::protocols::step_test_stiffness(&model, alpha);
        let trig = model.kinematics.trig(alpha);
        let f = [27.3, 0.0];
        let plain = model.force_command_at(alpha, &trig, f, k, false);
        let taut = model.force_command_taut_at(alpha, &trig, f, k, false, 0.1);
        let mut some_pushed = false;
        for j in 0..2 {
            let pose = model.pose(j, alpha[j]);
            let floor = 0.1 * model.joints[j].anti_slack_force_n;
            let fp = pose.forces_n(plain.joints[j].pressure_bar);
            let ft = pose.forces_n(taut.joints[j].pressure_bar);
            some_pushed |= fp[0] < 0.0 || fp[1] < 0.0;
            assert!(
                ft[0] >= floor - 1e-6 && ft[1] >= floor - 1e-6,
                "joint {j}: {ft:?}"
            );
            assert!(
                (taut.joints[j].torque_nm - plain.joints[j].torque_nm).abs() < 1e-6,
                "joint {j}: torque {} vs {}",
                taut.joints[j].torque_nm,
                plain.joints[j].torque_nm
            );
            assert!(taut.joints[j].stiffness_nm_per_rad >= plain.joints[j].stiffness_nm_per_rad);
            if fp[0] < floor || fp[1] < floor {
                assert!(taut.joints[j].limited.contains(Limited::STIFFNESS));
            } else {
                assert_eq!(taut.joints[j], plain.joints[j]);
            }
        }
        assert!(
            some_pushed,
            "the thesis's inverse model no longer asks a cable to push"
        );
    }

    /// Beyond what taut cables can give: the loaded muscle at the top of the range, the other
    /// at zero force (not at the floor), the torque cut and flagged.
    #[test]
    fn at_the_torque_limit_the_margin_goes_before_the_torque() {
        let model = RobotModel::<f64>::thesis();
        let m = &model.params.muscle;
        let c = &model.joints[0];
        let pose = model.pose(0, 0.0);
        let hi = c.pressure_max_bar;
        let f_hi = pose.muscles[1].force_n(hi);
        let floor = 0.1 * c.anti_slack_force_n;
        // a torque the loaded muscle can just give with the other at half the floor
        let t = c.pulley_radius_m * (f_hi - 0.5 * floor);
        let s = c.inverse_taut(m, 0.0, t, 0.0, floor);
        let f = pose.forces_n(s.pressure_bar);
        assert!((s.pressure_bar[1] - hi).abs() < 1e-9, "{s:?}");
        assert!((f[0] - 0.5 * floor).abs() < 1e-6, "{f:?}");
        assert!((s.torque_nm - t).abs() < 1e-6, "{s:?}");
        assert!(!s.limited.contains(Limited::PRESSURE), "{s:?}");
        // more than that: the other muscle at zero force, the torque cut, flagged
        let s = c.inverse_taut(m, 0.0, 2.0 * t, 0.0, floor);
        let f = pose.forces_n(s.pressure_bar);
        assert!(f[0].abs() < 1e-6 && s.torque_nm < 2.0 * t, "{s:?} {f:?}");
        assert!(s.limited.contains(Limited::PRESSURE), "{s:?}");
    }

    #[test]
    fn invalid_pose_gives_the_safe_pretension() {
        let model = RobotModel::<f64>::thesis();
        let m = &model.params.muscle;
        let c = &model.joints[0];
        let s = c.inverse_taut(m, f64::NAN, 1.0, 10.0, 10.0);
        assert!(s.limited.contains(Limited::INVALID_INPUT));
        assert_eq!(s, c.inverse(m, f64::NAN, 1.0, 10.0));
    }

    /// The §5.2 step test's 27.3 N along X at pose 7 with the rig's 0.57 (a command of
    /// 27.3 / 0.57 N): beyond the taut-cable torque range. The scale brings it inside, the
    /// scaled command needs no cut of the torque, and a force within reach is left alone.
    #[test]
    fn a_command_beyond_the_capability_is_scaled_inside_it() {
        let model = RobotModel::<f64>::thesis();
        let a = STEP_POSES_DEG[7];
        let alpha = [a[0].to_radians(), a[1].to_radians()];
        let trig = model.kinematics.trig(alpha);
        let k = crate::protocols::step_test_stiffness(&model, alpha);
        let cmd = [27.3 / 0.57, 0.0];
        let s = model.reachable_force_scale(alpha, &trig, cmd, [0.0; 2], 0.1, 1.0);
        assert!(s > 0.3 && s < 0.95, "{s}");
        let limits = Limited::TORQUE.with(Limited::PRESSURE);
        let cut = |f: [f64; 2]| {
            let c = model.force_command_taut_at(alpha, &trig, f, k, false, 0.1);
            c.joints.iter().any(|j| j.limited.0 & limits.0 != 0)
        };
        assert!(
            cut(cmd),
            "the unscaled command is within reach: the test shows nothing"
        );
        assert!(!cut([s * cmd[0], s * cmd[1]]), "{s}");
        // a margin scales the range; an offset shifts it
        let s95 = model.reachable_force_scale(alpha, &trig, cmd, [0.0; 2], 0.1, 0.95);
        assert!((s95 - 0.95 * s).abs() < 1e-9, "{s95} {s}");
        let shifted = model.reachable_force_scale(alpha, &trig, cmd, [2.0, 0.0], 0.1, 1.0);
        assert!(shifted < s, "{shifted} {s}");
        // within reach, not finite, or an offset alone beyond: 1
        assert_eq!(
            model.reachable_force_scale(alpha, &trig, [5.0, -3.0], [0.0; 2], 0.1, 1.0),
            1.0
        );
        assert_eq!(
            model.reachable_force_scale(alpha, &trig, [f64::NAN, 0.0], [0.0; 2], 0.1, 1.0),
            1.0
        );
        assert_eq!(
            model.reachable_force_scale(alpha, &trig, cmd, [1e4, 0.0], 0.1, 1.0),
            1.0
        );
    }
}
