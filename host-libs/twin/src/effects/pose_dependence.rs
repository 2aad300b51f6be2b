//! Pose dependence of the pressure-to-force gain (§5.3, Fig. 5.4–5.7: the step gain varies
//! over the workspace, which the thesis corrects with a gain plane, eq. 5.2).
//!
//! The pressure that acts in each muscle's force law is scaled by
//! 1 + gain_per_rad_1·α1 + gain_per_rad_2·α2 (e.g. the muscle's attachment geometry and
//! cable wrap changing with the pose). Steady-state pressures, as a gauge would read them,
//! are unchanged: only the force they make.

use super::{effect_params, Ctx, Effect, EffectId};

#[derive(Clone, Debug, PartialEq)]
pub struct PoseDependence {
    /// ±0.26 rad (15°) then changes the gain by ±8 % / ±5 % (estimate; the thesis shows the
    /// planes only as figures).
    pub gain_per_rad_1: f64,
    pub gain_per_rad_2: f64,
}

impl Default for PoseDependence {
    fn default() -> Self {
        PoseDependence {
            gain_per_rad_1: 0.3,
            gain_per_rad_2: -0.2,
        }
    }
}

impl Effect for PoseDependence {
    fn id(&self) -> EffectId {
        EffectId::PoseDependence
    }
    fn summary(&self) -> &'static str {
        "Pose-dependent gain from muscle pressure to force: the effective pressure is scaled by a plane in (α1, α2)."
    }
    effect_params! {
        gain_per_rad_1, "1/rad", "gain slope along α1";
        gain_per_rad_2, "1/rad", "gain slope along α2";
    }
    fn muscle_pressure(&mut self, ctx: &Ctx, p: &mut [f64; 4]) {
        let g =
            (1.0 + self.gain_per_rad_1 * ctx.alpha_rad[0] + self.gain_per_rad_2 * ctx.alpha_rad[1])
                .max(0.0);
        for x in p.iter_mut() {
            *x *= g;
        }
    }
}
