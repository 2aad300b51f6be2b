//! Encoder angles α ↔ D-H angles θ, forward and inverse kinematics in the world (D-H)
//! and user frames, the Jacobian, and the load-cell frame rotation (§2.2, App. A).

use crate::mat2::{Mat2, Vec2};
use crate::params::RobotParams;
use crate::real::Real;

/// sin/cos of θ1 and θ1 + θ2 at one pose: everything the Jacobian, the forward
/// kinematics and the load-cell rotation need, computed once per control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseTrig<R> {
    pub s1: R,
    pub c1: R,
    pub s12: R,
    pub c12: R,
}

/// Kinematic constants derived from the parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kinematics<R> {
    pub l1_m: R,
    pub l2_m: R,
    /// θ1,init = 90° + α0, θ2,init = −90°, α0 = atan(L2/L1) (eq. 2.3–2.4).
    pub theta_init_rad: [R; 2],
    /// The handle at the neutral pose in the world frame: the user frame's origin.
    pub home_world_m: Vec2<R>,
}

impl<R: Real> Kinematics<R> {
    pub fn new(params: &RobotParams<R>) -> Self {
        let l1 = params.joints[0].segment_length_m;
        let l2 = params.joints[1].segment_length_m;
        let half_pi = R::PI * R::half();
        let alpha0 = l2.atan2(l1);
        let mut k = Kinematics {
            l1_m: l1,
            l2_m: l2,
            theta_init_rad: [half_pi + alpha0, -half_pi],
            home_world_m: [R::ZERO, R::ZERO],
        };
        k.home_world_m = k.forward_world([R::ZERO, R::ZERO]);
        k
    }

    #[inline]
    pub fn theta(&self, alpha_rad: Vec2<R>) -> Vec2<R> {
        [
            self.theta_init_rad[0] + alpha_rad[0],
            self.theta_init_rad[1] + alpha_rad[1],
        ]
    }

    #[inline]
    pub fn alpha(&self, theta_rad: Vec2<R>) -> Vec2<R> {
        [
            theta_rad[0] - self.theta_init_rad[0],
            theta_rad[1] - self.theta_init_rad[1],
        ]
    }

    #[inline]
    pub fn trig(&self, alpha_rad: Vec2<R>) -> PoseTrig<R> {
        let t = self.theta(alpha_rad);
        let (s1, c1) = t[0].sin_cos();
        let (s12, c12) = (t[0] + t[1]).sin_cos();
        PoseTrig { s1, c1, s12, c12 }
    }

    /// Handle position in the world frame (App. A, eq. A.5).
    pub fn forward_world(&self, alpha_rad: Vec2<R>) -> Vec2<R> {
        self.forward_world_at(&self.trig(alpha_rad))
    }

    #[inline]
    pub fn forward_world_at(&self, t: &PoseTrig<R>) -> Vec2<R> {
        [
            self.l1_m * t.c1 + self.l2_m * t.c12,
            self.l1_m * t.s1 + self.l2_m * t.s12,
        ]
    }

    /// Handle position in the user frame: world axes, origin at the neutral handle.
    pub fn forward_user(&self, alpha_rad: Vec2<R>) -> Vec2<R> {
        let w = self.forward_world(alpha_rad);
        [w[0] - self.home_world_m[0], w[1] - self.home_world_m[1]]
    }

    /// Joint angles for a world-frame handle position, with the elbow on the side of the
    /// neutral pose (θ2 < 0). `None` if out of reach.
    pub fn inverse_world(&self, p_m: Vec2<R>) -> Option<Vec2<R>> {
        let (l1, l2) = (self.l1_m, self.l2_m);
        let r2 = p_m[0] * p_m[0] + p_m[1] * p_m[1];
        let c2 = (r2 - l1 * l1 - l2 * l2) / (R::from_f64(2.0) * l1 * l2);
        if !(c2 >= -R::ONE && c2 <= R::ONE) {
            return None;
        }
        let theta2 = -c2.acos();
        let s2 = theta2.sin();
        let theta1 = p_m[1].atan2(p_m[0]) - (l2 * s2).atan2(l1 + l2 * c2);
        // put θ1 in the same turn as θ1,init
        let mut a = self.alpha([theta1, theta2]);
        let two_pi = R::from_f64(2.0) * R::PI;
        while a[0] > R::PI {
            a[0] -= two_pi;
        }
        while a[0] < -R::PI {
            a[0] += two_pi;
        }
        Some(a)
    }

    pub fn inverse_user(&self, p_m: Vec2<R>) -> Option<Vec2<R>> {
        self.inverse_world([p_m[0] + self.home_world_m[0], p_m[1] + self.home_world_m[1]])
    }

    /// ∂(x, y)/∂(α1, α2), identical to ∂/∂θ. The thesis prints the (1,2) entry as
    /// +a2·S12 (eq. 2.5, A.7); differentiating its own eq. A.5 gives −a2·S12, used here.
    pub fn jacobian(&self, alpha_rad: Vec2<R>) -> Mat2<R> {
        self.jacobian_at(&self.trig(alpha_rad))
    }

    #[inline]
    pub fn jacobian_at(&self, t: &PoseTrig<R>) -> Mat2<R> {
        Mat2::new(
            -self.l1_m * t.s1 - self.l2_m * t.s12,
            -self.l2_m * t.s12,
            self.l1_m * t.c1 + self.l2_m * t.c12,
            self.l2_m * t.c12,
        )
    }

    /// Rotates a force from the load-cell frame (end-effector frame, eq. 2.6–2.7: rotation
    /// by θ1 + θ2) to the world frame, which has the user frame's axes.
    pub fn sensor_to_user(&self, alpha_rad: Vec2<R>, force_sensor_n: Vec2<R>) -> Vec2<R> {
        Self::sensor_to_user_at(&self.trig(alpha_rad), force_sensor_n)
    }

    #[inline]
    pub fn sensor_to_user_at(t: &PoseTrig<R>, f: Vec2<R>) -> Vec2<R> {
        [t.c12 * f[0] - t.s12 * f[1], t.s12 * f[0] + t.c12 * f[1]]
    }

    /// The inverse rotation: user frame → load-cell frame.
    pub fn user_to_sensor(&self, alpha_rad: Vec2<R>, force_user_n: Vec2<R>) -> Vec2<R> {
        let t = self.trig(alpha_rad);
        let f = force_user_n;
        [t.c12 * f[0] + t.s12 * f[1], -t.s12 * f[0] + t.c12 * f[1]]
    }

    /// τ = Jᵀ F (eq. A.1): joint torques that make the handle exert `force_user_n`.
    pub fn joint_torques(&self, alpha_rad: Vec2<R>, force_user_n: Vec2<R>) -> Vec2<R> {
        self.jacobian(alpha_rad).transpose().mul_vec(force_user_n)
    }
}
