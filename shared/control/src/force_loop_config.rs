//! The closed force loop's gains and limits ([`ForceLoopConfig`]), the design's defaults and
//! their validity.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// Gains and limits of the closed force loop. Defaults: [`ForceLoopConfig::designed`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct ForceLoopConfig {
    /// Bandwidth of the critically damped reference model, rad/s.
    pub reference_bandwidth_rad_s: f32,
    /// Proportional gain, N of command per N of error.
    pub kp: f32,
    /// Integral gain, 1/s.
    pub ki_per_s: f32,
    /// Derivative gain on the error rate, s (damps the converters' resonance).
    pub kd_s: f32,
    /// Bandwidth of the first-order filter of the measured force's rate, rad/s.
    pub derivative_filter_rad_s: f32,
    /// Largest rate of the force reference, N/s.
    pub force_rate_n_per_s: f32,
    /// Bound of the integral term, N.
    pub integral_limit_n: f32,
    /// Error (norm over both axes) that, held for `guard_time_s`, is a fault, N.
    pub guard_error_n: f32,
    pub guard_time_s: f32,
    /// Error (norm) that is a fault at once: a growing oscillation reaches it within a
    /// period or two of its swing, before the flip count does, N.
    pub guard_error_max_n: f32,
    /// Hysteresis band of the oscillation detector, N.
    pub guard_band_n: f32,
    /// Leaky count of error sign flips (time constant 1 s) that is a fault.
    pub guard_flips: f32,
    /// Handle speed that is a fault in the closed-loop modes, m/s: a force loop that
    /// cannot find its force (the patient let go of the handle, the block gave way) drives
    /// the arm away; this stops it within a few centimetres.
    pub guard_speed_m_s: f32,
    /// Least muscle force the closed loop's inverse model may ask for, as a fraction of the
    /// joint's anti-slack force (`pam_model::taut`): a cable cannot push, and a muscle asked
    /// for less than nothing leaves the loop with half its gain.
    pub taut_force_fraction: f32,
    /// Share of the taut-cable torque range a target may ask for in steady state, 0–1: a
    /// target beyond it is scaled down, its direction kept
    /// ([`pam_model::RobotModel::reachable_force_scale`]); the rest is the feedback's room
    /// for what the model misses.
    pub reach_margin: f32,
    /// Compliance of what holds the handle (handle travel per newton) at which the loop's
    /// gains are halfway to [`ForceLoopConfig::compliant_gain_scale`], m/N: 20 000 N/m puts
    /// the arm's resonance on it (≈ 1.4 kg) at 120 rad/s, three times the loop's crossover; a
    /// hand (1000–5000 N/m) puts it at 20–60 rad/s, on the crossover.
    pub compliance_ref_m_per_n: f32,
    /// The feedback gains' factor (kp, ki, kd) against a very compliant handle: 0.3 keeps the
    /// loop stable against the twin's hands up to the top of the plant-gain range the loop is
    /// designed for (g = 1.75, the gain plane on a plant without the 0.57).
    pub compliant_gain_scale: f32,
    /// Handle travel since the loop started that is not yet compliance, m: about one encoder
    /// count at the handle (10 000 counts per revolution, 0.45 m), so that a block's count
    /// flicker is not mistaken for a hand.
    pub handle_deadband_m: f32,
}

impl ForceLoopConfig {
    /// The design of docs/closed-loop.md for the thesis's converters (ωn 23 rad/s, ζ 0.42).
    pub const fn designed() -> Self {
        ForceLoopConfig {
            reference_bandwidth_rad_s: 40.0,
            kp: 1.0,
            ki_per_s: 20.0,
            kd_s: 0.06,
            derivative_filter_rad_s: 60.0,
            force_rate_n_per_s: 300.0,
            integral_limit_n: 40.0,
            guard_error_n: 12.0,
            guard_time_s: 0.5,
            guard_error_max_n: 25.0,
            guard_band_n: 2.0,
            guard_flips: 6.0,
            guard_speed_m_s: 0.5,
            taut_force_fraction: 0.1,
            reach_margin: 0.95,
            compliance_ref_m_per_n: 5e-5,
            compliant_gain_scale: 0.3,
            handle_deadband_m: 3e-4,
        }
    }

    pub fn is_valid(&self) -> bool {
        let pos = [
            self.reference_bandwidth_rad_s,
            self.derivative_filter_rad_s,
            self.force_rate_n_per_s,
            self.integral_limit_n,
            self.guard_error_n,
            self.guard_time_s,
            self.guard_error_max_n,
            self.guard_band_n,
            self.guard_flips,
            self.guard_speed_m_s,
        ];
        pos.iter().all(|v| v.is_finite() && *v > 0.0)
            && self.kp.is_finite()
            && self.kp >= 0.0
            && self.ki_per_s.is_finite()
            && self.ki_per_s >= 0.0
            && self.kd_s.is_finite()
            && self.kd_s >= 0.0
            && self.taut_force_fraction >= 0.0
            && self.taut_force_fraction < 1.0
            && self.reach_margin > 0.0
            && self.reach_margin <= 1.0
            && self.compliance_ref_m_per_n.is_finite()
            && self.compliance_ref_m_per_n > 0.0
            && self.compliant_gain_scale.is_finite()
            && self.compliant_gain_scale > 0.0
            && self.compliant_gain_scale <= 1.0
            && self.handle_deadband_m.is_finite()
            && self.handle_deadband_m >= 0.0
    }
}

impl Default for ForceLoopConfig {
    fn default() -> Self {
        Self::designed()
    }
}
