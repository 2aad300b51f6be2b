//! Signal laws of the rig: I/P converter current ↔ pressure (eq. 2.2) and load-cell
//! volts → newtons (eq. 2.1).

use crate::params::{IpConverter, LoadCell};
use crate::real::Real;

/// A current command and whether the requested pressure had to be limited to reach it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentCommand<R> {
    pub current_ma: R,
    /// The pressure the converter will regulate to with this current.
    pub pressure_bar: R,
    pub saturated: bool,
}

impl<R: Real> IpConverter<R> {
    /// Pressure regulated for a loop current (eq. 2.2), limited to the converter's output
    /// range (it cannot go below 0.1 bar nor above 5 bar).
    pub fn pressure_bar(&self, current_ma: R) -> R {
        (self.gain_bar_per_ma * current_ma + self.offset_bar)
            .clamp_to(self.output_min_bar, self.output_max_bar)
    }

    /// The loop current for a pressure, inside the 4–20 mA range.
    ///
    /// With the thesis's law, 0 bar needs 4.99 mA and 5 bar would need 20.30 mA: the
    /// highest pressure a 4–20 mA loop can command is 4.90 bar. Requests beyond either end
    /// are saturated and flagged; NaN gives the minimum current.
    pub fn current_for(&self, pressure_bar: R) -> CurrentCommand<R> {
        let raw = (pressure_bar - self.offset_bar) / self.gain_bar_per_ma;
        let current_ma = raw.clamp_to(self.current_min_ma, self.current_max_ma);
        let tol = R::from_f64(1e-6);
        let below_floor = pressure_bar < self.output_min_bar && current_ma > self.current_min_ma;
        CurrentCommand {
            current_ma,
            pressure_bar: self.pressure_bar(current_ma),
            saturated: !((raw - current_ma).abs() <= tol) && !below_floor,
        }
    }
}

impl<R: Real> LoadCell<R> {
    /// Sensor-frame forces (X, Z) in N from the two channel voltages (eq. 2.1).
    #[inline]
    pub fn forces_n(&self, volts: [R; 2]) -> [R; 2] {
        [
            (volts[0] - self.offset_v[0]) * self.gain_n_per_v[0],
            (volts[1] - self.offset_v[1]) * self.gain_n_per_v[1],
        ]
    }

    /// The offsets that make the present reading zero (tare).
    pub fn tare(&mut self, volts_at_rest: [R; 2]) {
        self.offset_v = volts_at_rest;
    }
}
