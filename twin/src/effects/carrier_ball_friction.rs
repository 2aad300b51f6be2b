//! Dry friction of the handle's carrier ball on the table (§6.2: "the friction is still
//! quite noticeable").
//!
//! The ball sits under the handle, beyond the load cell, so the friction force acts on the
//! handle and the load cell measures it with the user's force. Coulomb friction opposing the
//! handle velocity, smoothed over `smoothing_m_s` so it is a continuous force the integrator
//! can follow; a viscous part for the ball's rolling resistance.

use super::{effect_params, smooth_sign, Ctx, Effect};
use pam_model::Vec2;

#[derive(Clone, Debug, PartialEq)]
pub struct CarrierBallFriction {
    /// The thesis gives no value; 2 N is a few percent of the trial forces (estimate).
    pub coulomb_n: f64,
    pub viscous_n_s_per_m: f64,
    pub smoothing_m_s: f64,
}

impl Default for CarrierBallFriction {
    fn default() -> Self {
        CarrierBallFriction { coulomb_n: 2.0, viscous_n_s_per_m: 0.0, smoothing_m_s: 0.005 }
    }
}

impl Effect for CarrierBallFriction {
    fn id(&self) -> &'static str {
        "carrier_ball_friction"
    }
    fn summary(&self) -> &'static str {
        "Dry (Coulomb, smoothed) plus viscous friction of the carrier ball on the table, acting on the handle against its velocity; seen by the load cell."
    }
    effect_params! {
        coulomb_n, "N", "Coulomb friction force";
        viscous_n_s_per_m, "N·s/m", "viscous rolling resistance";
        smoothing_m_s, "m/s", "speed over which the Coulomb force reaches its value";
    }
    fn handle_force(&mut self, ctx: &Ctx, force: &mut Vec2<f64>) {
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
