//! Pure delay between the current command and the converter (tubes, converter pilot stage;
//! Table 5.1 bounds the tube part below 0.05 s and calls it negligible).
//!
//! The pressure command is delayed by `delay_s` (held at the first command until then).

use std::collections::VecDeque;

use super::{effect_params, Ctx, Effect, EffectId};

#[derive(Clone, Debug, PartialEq)]
pub struct TransportDelay {
    pub delay_s: f64,
    history: VecDeque<(f64, [f64; 4])>,
}

impl Default for TransportDelay {
    fn default() -> Self {
        TransportDelay {
            delay_s: 0.04,
            history: VecDeque::new(),
        }
    }
}

impl Effect for TransportDelay {
    fn id(&self) -> EffectId {
        EffectId::TransportDelay
    }
    fn summary(&self) -> &'static str {
        "Pure transport delay of the pressure command (Table 5.1: < 0.05 s)."
    }
    effect_params! {
        delay_s, "s", "delay of the pressure command";
    }
    fn reset(&mut self, _seed: u64) {
        self.history.clear();
    }
    fn pressure_command(&mut self, ctx: &Ctx, p_set: &mut [f64; 4]) {
        self.history.push_back((ctx.t_s, *p_set));
        let due = ctx.t_s - self.delay_s;
        // keep the newest sample that is at least `delay_s` old at the front
        while self.history.len() > 1 && self.history[1].0 <= due + 1e-12 {
            self.history.pop_front();
        }
        *p_set = self.history[0].1;
    }
}
