//! A 50 Hz tone on the load-cell channels (mains pickup on the bridge wiring).
//!
//! Deliberately NOT a model-catalog effect: nothing in the robot's physics produces it, so
//! model tools should flag data containing it as unexplained. Sampled at the thesis's 50 ms
//! it aliases to DC (50 Hz × 0.05 s = 2.5 cycles: alternating sign), at 1 ms it is a clean tone.

use super::{effect_params, Ctx, Effect, EffectId, RawSensors};

#[derive(Clone, Debug, PartialEq)]
pub struct MainsHum {
    pub amplitude_n: f64,
    pub frequency_hz: f64,
    phase_rad: f64,
}

impl Default for MainsHum {
    fn default() -> Self {
        MainsHum {
            amplitude_n: 0.8,
            frequency_hz: 50.0,
            phase_rad: 0.0,
        }
    }
}

impl Effect for MainsHum {
    fn id(&self) -> EffectId {
        EffectId::MainsHum
    }
    fn summary(&self) -> &'static str {
        "Mains pickup: a sinusoidal tone added to both load-cell channels. Not a physical effect of the robot."
    }
    effect_params! {
        amplitude_n, "N", "tone amplitude on each channel";
        frequency_hz, "Hz", "tone frequency";
    }
    fn reset(&mut self, seed: u64) {
        self.phase_rad = crate::rng::Rng::new(seed).uniform() * std::f64::consts::TAU;
    }
    fn sensor(&mut self, ctx: &Ctx, raw: &mut RawSensors) {
        let s = (std::f64::consts::TAU * self.frequency_hz * ctx.t_s + self.phase_rad).sin();
        let g = ctx.params.load_cell.gain_n_per_v;
        raw.loadcell_v[0] += self.amplitude_n * s / g[0];
        raw.loadcell_v[1] += self.amplitude_n * s / g[1];
    }
}
