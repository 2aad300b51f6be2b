//! Dry friction of the handle's carrier ball on the table (§6.2: "the friction is still
//! quite noticeable").
//!
//! "The whole system rests on a carrier ball" (§2.1): the ball carries the end of the forearm,
//! sensor and handle. Where it attaches decides whether the load cell sees it: on the arm side
//! (default, `beyond_load_cell = 0`) the hand has to push through it and the load cell
//! measures that; on the handle side (`beyond_load_cell = 1`) only the hand feels it.
//! Coulomb friction opposing the
//! handle velocity, smoothed over `smoothing_m_s` so it is a continuous force the integrator
//! can follow; a viscous part for the ball's rolling resistance.

use super::{effect_params, smooth_sign, Ctx, Effect, EffectId, HandleForces};

#[derive(Clone, Debug, PartialEq)]
pub struct CarrierBallFriction {
    /// The thesis gives no value; 2 N is a few percent of the trial forces (estimate).
    pub coulomb_n: f64,
    pub viscous_n_s_per_m: f64,
    pub smoothing_m_s: f64,
    /// 0: the ball is on the arm side of the load cell; 1: on the handle side.
    pub beyond_load_cell: f64,
}

impl Default for CarrierBallFriction {
    fn default() -> Self {
        CarrierBallFriction {
            coulomb_n: 2.0,
            viscous_n_s_per_m: 0.0,
            smoothing_m_s: 0.005,
            beyond_load_cell: 0.0,
        }
    }
}

impl Effect for CarrierBallFriction {
    fn id(&self) -> EffectId {
        EffectId::CarrierBallFriction
    }
    fn summary(&self) -> &'static str {
        "Dry (Coulomb, smoothed) plus viscous friction of the carrier ball on the table, acting at the handle against its velocity; on the arm side of the load cell by default, so the load cell sees the hand push through it."
    }
    effect_params! {
        coulomb_n, "N", "Coulomb friction force";
        viscous_n_s_per_m, "N·s/m", "viscous rolling resistance";
        smoothing_m_s, "m/s", "speed over which the Coulomb force reaches its value";
        beyond_load_cell, "0/1", "1 if the ball is on the handle side of the load cell";
    }
    fn handle_force(&mut self, ctx: &Ctx, forces: &mut HandleForces) {
        let force = if self.beyond_load_cell >= 0.5 {
            &mut forces.handle_side_user_n
        } else {
            &mut forces.arm_side_user_n
        };
        let v = ctx.handle_velocity_user_m_s;
        let speed = (v[0] * v[0] + v[1] * v[1]).sqrt();
        if speed == 0.0 {
            return;
        }
        let coulomb = self.coulomb_n * smooth_sign(speed, self.smoothing_m_s.max(1e-6));
        for i in 0..2 {
            force[i] -= coulomb * v[i] / speed + self.viscous_n_s_per_m * v[i];
        }
    }
}
