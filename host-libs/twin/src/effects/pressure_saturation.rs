//! Pressure saturation below the converter's nominal 5 bar: a supply or converter that
//! cannot deliver the top of its range (the thesis's 4–20 mA loop already tops at 4.90 bar,
//! `IpConverter::current_for`; a drooping supply lowers that further).
//!
//! Commands above `knee_bar` are compressed smoothly toward `max_bar` (tanh), so forces
//! that need high pressures fall short while low-pressure work is unchanged.

use super::{effect_params, Ctx, Effect, EffectId};

#[derive(Clone, Debug, PartialEq)]
pub struct PressureSaturation {
    pub max_bar: f64,
    pub knee_bar: f64,
}

impl Default for PressureSaturation {
    fn default() -> Self {
        PressureSaturation {
            max_bar: 4.0,
            knee_bar: 3.2,
        }
    }
}

impl Effect for PressureSaturation {
    fn id(&self) -> EffectId {
        EffectId::PressureSaturation
    }
    fn summary(&self) -> &'static str {
        "Soft saturation of the delivered pressure above a knee toward a maximum below 5 bar."
    }
    effect_params! {
        max_bar, "bar", "highest pressure delivered";
        knee_bar, "bar", "commands below this are unchanged";
    }
    fn pressure_command(&mut self, _ctx: &Ctx, p_set: &mut [f64; 4]) {
        let span = (self.max_bar - self.knee_bar).max(1e-6);
        for p in p_set.iter_mut() {
            if *p > self.knee_bar {
                *p = self.knee_bar + span * ((*p - self.knee_bar) / span).tanh();
            }
        }
    }
}
