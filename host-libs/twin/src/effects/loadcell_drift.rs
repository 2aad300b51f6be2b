//! Load-cell offset and drift (an untared or warming bridge), sensor frame.
//!
//! Adds `offset + drift·t` (in newtons, converted to volts through the cell's gain) to each
//! channel. Joint angles, pressures and the true force are unchanged.

use super::{effect_params, Ctx, Effect, EffectId, RawSensors};

#[derive(Clone, Debug, PartialEq)]
pub struct LoadcellDrift {
    pub offset_x_n: f64,
    pub offset_z_n: f64,
    pub drift_x_n_per_s: f64,
    pub drift_z_n_per_s: f64,
}

impl Default for LoadcellDrift {
    fn default() -> Self {
        LoadcellDrift {
            offset_x_n: 1.5,
            offset_z_n: -1.0,
            drift_x_n_per_s: 0.01,
            drift_z_n_per_s: -0.005,
        }
    }
}

impl Effect for LoadcellDrift {
    fn id(&self) -> EffectId {
        EffectId::LoadcellDrift
    }
    fn summary(&self) -> &'static str {
        "Offset plus linear drift of both load-cell channels (sensor frame)."
    }
    effect_params! {
        offset_x_n, "N", "offset of sensor X at t = 0";
        offset_z_n, "N", "offset of sensor Z at t = 0";
        drift_x_n_per_s, "N/s", "drift of sensor X";
        drift_z_n_per_s, "N/s", "drift of sensor Z";
    }
    fn sensor(&mut self, ctx: &Ctx, raw: &mut RawSensors) {
        let g = ctx.params.load_cell.gain_n_per_v;
        raw.loadcell_v[0] += (self.offset_x_n + self.drift_x_n_per_s * ctx.t_s) / g[0];
        raw.loadcell_v[1] += (self.offset_z_n + self.drift_z_n_per_s * ctx.t_s) / g[1];
    }
}
