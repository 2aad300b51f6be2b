//! A force ∝ |v|·v at the handle (§4.6 names "velocity-squared terms" as missing).
//!
//! The Coriolis and centrifugal torques of the two segments are *not* this effect: they are
//! part of the twin's base rigid-body dynamics (eq. 4.14–4.17, `pam_model::cartesian`), and at
//! hand speeds (≤ 0.3 m/s, ≤ 0.5 rad/s) they are below 0.1 N at the handle. This effect
//! stands for whatever quadratic drag the rig has beyond that (air drag on the arm, the
//! carrier ball's rolling losses growing with speed, the operator's grip), so the model
//! tools can test a quadratic term.

use super::{effect_params, Ctx, Effect, EffectId, HandleForces};

#[derive(Clone, Debug, PartialEq)]
pub struct VelocitySquared {
    /// 40 N·s²/m² gives 1.6 N at 0.2 m/s (estimate, chosen to be visible in a trial).
    pub coeff_n_s2_per_m2: f64,
}

impl Default for VelocitySquared {
    fn default() -> Self {
        VelocitySquared {
            coeff_n_s2_per_m2: 40.0,
        }
    }
}

impl Effect for VelocitySquared {
    fn id(&self) -> EffectId {
        EffectId::VelocitySquared
    }
    fn summary(&self) -> &'static str {
        "Quadratic drag −c·|v|·v on the handle (Coriolis/centrifugal terms are already in the base dynamics and negligible at hand speeds)."
    }
    effect_params! {
        coeff_n_s2_per_m2, "N·s²/m²", "drag coefficient c";
    }
    fn handle_force(&mut self, ctx: &Ctx, forces: &mut HandleForces) {
        // acts on the arm: the hand pushes through it and the load cell sees that
        let force = &mut forces.arm_side_user_n;
        let v = ctx.handle_velocity_user_m_s;
        let speed = (v[0] * v[0] + v[1] * v[1]).sqrt();
        for i in 0..2 {
            force[i] -= self.coeff_n_s2_per_m2 * speed * v[i];
        }
    }
}
