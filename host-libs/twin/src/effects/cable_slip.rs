//! Cable slip and backlash at the joint-1 pulley (§2.3, §6.2: the cable slips in the groove
//! under large pressure changes or near the range limits).
//!
//! The muscles of joint 1 see the angle α1 − slip, through a backlash of `backlash_rad`
//! (the cable's play in the groove). The slip offset grows while the torque the cable has
//! to carry exceeds what the groove's friction holds, at `slip_rate_rad_per_nm_s` per N·m of
//! excess. Torques on the segment then come from muscles that are no longer where the model
//! thinks: the equilibrium creeps, and the creep stays.

use super::{effect_params, Ctx, Effect, EffectId};
use pam_model::Vec2;

#[derive(Clone, Debug, PartialEq)]
pub struct CableSlip {
    pub backlash_rad: f64,
    /// Torque the groove holds without slipping (estimate: a bit below joint 1's ±31.5 N·m).
    pub hold_torque_nm: f64,
    pub slip_rate_rad_per_nm_s: f64,
    slip_rad: f64,
    /// Angle transmitted through the backlash (the play's position).
    transmitted_rad: Option<f64>,
}

impl Default for CableSlip {
    fn default() -> Self {
        CableSlip {
            backlash_rad: 0.004,
            hold_torque_nm: 15.0,
            slip_rate_rad_per_nm_s: 0.002,
            slip_rad: 0.0,
            transmitted_rad: None,
        }
    }
}

impl CableSlip {
    pub fn slip_rad(&self) -> f64 {
        self.slip_rad
    }
}

impl Effect for CableSlip {
    fn id(&self) -> EffectId {
        EffectId::CableSlip
    }
    fn summary(&self) -> &'static str {
        "Joint-1 cable: backlash in the pulley groove and slip when the carried torque exceeds the groove's hold."
    }
    effect_params! {
        backlash_rad, "rad", "total play of the cable in the groove";
        hold_torque_nm, "N·m", "torque carried without slipping";
        slip_rate_rad_per_nm_s, "rad/(N·m·s)", "slip speed per N·m beyond the hold";
    }
    fn reset(&mut self, _seed: u64) {
        self.slip_rad = 0.0;
        self.transmitted_rad = None;
    }
    fn transmission(&mut self, ctx: &Ctx, alpha: &mut Vec2<f64>) {
        let excess = ctx.last_joint_torque_nm[0].abs() - self.hold_torque_nm;
        if excess > 0.0 {
            // the cable gives way in the direction the torque pulls the segment
            self.slip_rad += ctx.last_joint_torque_nm[0].signum()
                * excess
                * self.slip_rate_rad_per_nm_s
                * ctx.dt_s;
        }
        let a = alpha[0];
        let half = 0.5 * self.backlash_rad;
        let mut t = self.transmitted_rad.unwrap_or(a);
        if a > t + half {
            t = a - half;
        } else if a < t - half {
            t = a + half;
        }
        self.transmitted_rad = Some(t);
        alpha[0] = t - self.slip_rad;
    }
}
