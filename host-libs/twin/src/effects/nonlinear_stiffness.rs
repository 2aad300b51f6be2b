//! Stiffening beyond the polynomial muscle law (§4.3: the fitted slope over a trial differs
//! from the linearised stiffness at the equilibrium).
//!
//! Each cable force gains a cubic term in the muscle's stretch from its pretensioned length:
//! ΔF = −cubic_n · (Δε / 0.01)³ with Δε = ε − ε0 (ε0 of the neutral pose). A stretched
//! muscle (Δε < 0) pulls harder, a shortened one less; for a joint pair this is a restoring
//! torque growing with the cube of the excursion, invisible to a linearisation at the centre.

use super::{effect_params, Ctx, Effect, EffectId, MuscleView};

#[derive(Clone, Debug, PartialEq)]
pub struct NonlinearStiffness {
    /// Force change at 1 % contraction change: 15 N ≈ 0.6 % of the isobaric 2400 N per unit ε
    /// slope (estimate; makes the secant over ±4 cm ~20–40 % stiffer than the tangent).
    pub cubic_n: f64,
}

impl Default for NonlinearStiffness {
    fn default() -> Self {
        NonlinearStiffness { cubic_n: 15.0 }
    }
}

impl Effect for NonlinearStiffness {
    fn id(&self) -> EffectId {
        EffectId::NonlinearStiffness
    }
    fn summary(&self) -> &'static str {
        "Cubic stiffening of each cable force with its stretch from the neutral pretension: a restoring torque ∝ excursion³ the linear KBM cannot represent."
    }
    effect_params! {
        cubic_n, "N", "cable force change at a 1 % change of contraction";
    }
    fn muscle_force(&mut self, ctx: &Ctx, m: &MuscleView, force_n: &mut f64) {
        let eps0 = ctx.params.joints[m.joint].epsilon0();
        let x = (m.epsilon - eps0) / 0.01;
        *force_n -= self.cubic_n * x * x * x;
    }
}
