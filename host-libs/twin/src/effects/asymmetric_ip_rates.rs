//! Asymmetric, flow-limited inflation and deflation through the I/P converters (Table 5.1:
//! full inflation 2.412 s, full deflation 1.608 s with the converter; §5.1 names its internal
//! structure and its 1.2 mm exhaust as the limits).
//!
//! The converter's flow saturates: the muscle pressure can rise at most span/inflation_s and
//! fall at most span/deflation_s. Small steps (Table 5.2) stay below the limits.

use super::{effect_params, Ctx, Effect, EffectId};

#[derive(Clone, Debug, PartialEq)]
pub struct AsymmetricIpRates {
    pub inflation_s: f64,
    pub deflation_s: f64,
    /// Pressure span of the Table 5.1 measurement (0 ↔ 5 bar).
    pub span_bar: f64,
}

impl Default for AsymmetricIpRates {
    fn default() -> Self {
        AsymmetricIpRates {
            inflation_s: 2.412,
            deflation_s: 1.608,
            span_bar: 5.0,
        }
    }
}

impl Effect for AsymmetricIpRates {
    fn id(&self) -> EffectId {
        EffectId::AsymmetricIpRates
    }
    fn summary(&self) -> &'static str {
        "Flow saturation of the I/P converters, slower to inflate than to deflate (Table 5.1)."
    }
    effect_params! {
        inflation_s, "s", "time to inflate over the span";
        deflation_s, "s", "time to deflate over the span";
        span_bar, "bar", "pressure span of those times";
    }
    fn regulator_flow(&mut self, _ctx: &Ctx, flow: &mut [f64; 4]) {
        let up = self.span_bar / self.inflation_s.max(1e-6);
        let down = self.span_bar / self.deflation_s.max(1e-6);
        for q in flow.iter_mut() {
            *q = q.clamp(-down, up);
        }
    }
}
