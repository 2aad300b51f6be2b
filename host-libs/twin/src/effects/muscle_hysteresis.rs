//! Muscle hysteresis (§4.2, §5.1): friction between the braid fibres and the bladder makes
//! the force depend on the direction of motion (McKibben-type "dry friction", §1.3).
//!
//! A Dahl-type friction state z ∈ [−1, 1] per muscle follows the contraction:
//! dz/dε = (1 − z·sign(ε̇)) / width. The force loses `fraction` × (isobaric force) × z: a
//! muscle being stretched (ε̇ < 0) pulls harder than on the way back. Proportional to force
//! because the braid's normal load grows with pressure.

use super::{effect_params, Ctx, Effect, EffectId, MuscleView};

#[derive(Clone, Debug, PartialEq)]
pub struct MuscleHysteresis {
    /// ±4 % of the force (Festo quotes hysteresis ≤ 3–5 % for DMSP; estimate).
    pub fraction: f64,
    /// Contraction change over which the friction reverses fully.
    pub width: f64,
    z: [f64; 4],
}

impl Default for MuscleHysteresis {
    fn default() -> Self {
        MuscleHysteresis {
            fraction: 0.04,
            width: 0.002,
            z: [0.0; 4],
        }
    }
}

impl Effect for MuscleHysteresis {
    fn id(&self) -> EffectId {
        EffectId::MuscleHysteresis
    }
    fn summary(&self) -> &'static str {
        "Direction-dependent muscle force (Dahl friction of the braid), proportional to the force."
    }
    effect_params! {
        fraction, "1", "force fraction lost/gained when fully reversed";
        width, "1", "contraction change for a full reversal";
    }
    fn reset(&mut self, _seed: u64) {
        self.z = [0.0; 4];
    }
    fn muscle_force(&mut self, ctx: &Ctx, m: &MuscleView, force_n: &mut f64) {
        let de = m.epsilon_rate_per_s * ctx.dt_s;
        let z = &mut self.z[m.channel & 3];
        let s = if de > 0.0 { 1.0 } else { -1.0 };
        *z = (*z + de / self.width.max(1e-9) * (1.0 - *z * s)).clamp(-1.0, 1.0);
        *force_n -= self.fraction * force_n.max(0.0) * *z;
    }
}
