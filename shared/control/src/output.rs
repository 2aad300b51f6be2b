//! The step's last stage: the limits every command passes on its way to the converters
//! (pressure range, slew, the link-loss ramp's floor and rate), and the fixed safe current.

use pam_model::{Limited, Real, Vec2};

use crate::faults::Faults;
use crate::mode::{State, StepOutput};
use crate::safety::ceiling::TIMEOUT_RAMP_MIN_BAR_PER_S;
use crate::supervisor::Controller;
use crate::targets::{Command, CommandKind};
use crate::VENT_CURRENT_MA;

impl Controller {
    /// Limits `command` channel by channel and returns the step's outputs. Not armed or
    /// faulted, every channel ends at [`VENT_CURRENT_MA`] (the link-loss ramp ends there).
    #[inline(always)]
    pub(crate) fn limit(&mut self, command: Command, force_user_n: Vec2<f32>) -> StepOutput {
        let ip = &self.model.params.ip;
        let vent = ip.output_min_bar;
        let dt = self.safety.period_s;
        let cut = command.kind == CommandKind::Vent;
        let ramp = command.kind == CommandKind::TimeoutRamp;
        let (floor, slew) = if ramp {
            // down to the vent itself, not to the modes' least pressure, at a rate that
            // ends the ramp within its ceiling whatever the configuration
            let rate = self
                .safety
                .timeout_ramp_bar_per_s
                .max(TIMEOUT_RAMP_MIN_BAR_PER_S);
            (vent, rate)
        } else {
            (
                self.model.params.pressure.min_bar,
                self.safety.slew_bar_per_s,
            )
        };
        let limited = command.limited;
        let mut output_limited = false;
        // the capability limits only (pressure range, converter range), not the slew limit:
        // a slew-limited command catches up by itself, a clamped one never does
        let mut range_limited = false;
        let max_step = slew * dt;
        let mut out = [vent; 4];
        let mut current = [VENT_CURRENT_MA; 4];
        for c in 0..4 {
            let mut p = command.target_bar[c];
            if !p.is_finite() {
                // the model never returns NaN, but the output path does not rely on that
                self.faults = self.faults.with(Faults::OUTPUT_NON_FINITE);
                self.state = State::Faulted;
                p = vent;
            }
            let p_in = p;
            p = p.clamp_to(floor, self.model.params.pressure.max_bar);
            range_limited |= (p - p_in).abs() > 1e-6;
            if !cut {
                let prev = self.pressure_bar[c];
                p = p.clamp_to(prev - max_step, prev + max_step);
            }
            let cmd = ip.current_for(p);
            output_limited |= (p - p_in).abs() > 1e-6 || cmd.saturated;
            range_limited |= cmd.saturated;
            // At the converter's floor (idle, a finished timeout ramp, a 0.1 bar command) the
            // output is the safe state itself, 4 mA: the same 0.1 bar at the converter as the
            // 5.3 mA its law gives, and the current an open or unpowered loop would also give.
            let at_floor = p <= vent;
            out[c] = if cut { vent } else { p };
            current[c] = if cut || at_floor {
                VENT_CURRENT_MA
            } else {
                cmd.current_ma
            };
        }
        // a fault latched by this very step's output check vents too
        if self.state != State::Armed && !ramp {
            out = [vent; 4];
            current = [VENT_CURRENT_MA; 4];
        }
        self.pressure_bar = out;
        self.last_saturated = range_limited
            || limited.contains(Limited::TORQUE)
            || limited.contains(Limited::PRESSURE);
        StepOutput {
            pressure_bar: out,
            current_ma: current,
            force_user_n,
            state: self.state,
            faults: self.faults,
            limited,
            output_limited,
        }
    }
}
