//! The limits the firmware enforces whatever the host says, and why a command is refused.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// The load-cell amplifier's full-scale output, V (±10 V, what the NI 9215 accepted). A
/// channel at or beyond it is saturated: X ±111 N, Z ±167 N with the thesis's gains
/// (0.09 V/N, 0.06 V/N). The volts are recovered from the force with the present
/// calibration, so the limit holds whatever the gain, offset or tare.
pub const LOADCELL_AMPLIFIER_FULL_SCALE_V: f32 = 10.0;

/// Consecutive missed control periods that latch `Faults::LOOP_OVERRUN` by default (issue
/// 12): one or two can be a debugger or a long USB critical section; three in a row is a
/// loop that no longer keeps its rate.
pub const DEFAULT_OVERRUN_FAULT_PERIODS: u32 = 3;

/// The range [`SafetyConfig::overrun_fault_periods`] must be in: at least one (the check
/// cannot be switched off), at most 100 (0.1 s at 1 kHz, 1 s at 100 Hz, of a loop running
/// missed periods back to back before it vents).
pub const OVERRUN_FAULT_PERIODS_RANGE: core::ops::RangeInclusive<u32> = 1..=100;

/// Limits the firmware enforces whatever the host says.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub struct SafetyConfig {
    pub period_s: f32,
    pub command_timeout_s: f32,
    /// Per-channel slew limit of the commanded pressure.
    pub slew_bar_per_s: f32,
    /// Ramp rate to the safe state after a command timeout.
    pub timeout_ramp_bar_per_s: f32,
    /// Largest believable joint speed; a bigger step between two samples is an encoder fault.
    pub max_joint_speed_rad_s: f32,
    /// Margin beyond the joint range before an angle is a fault (the joint has hard stops).
    pub angle_margin_rad: f32,
    /// A sensor-frame force beyond this is saturation.
    pub loadcell_limit_n: f32,
    /// This many identical consecutive load-cell samples while armed is a stuck sensor.
    pub loadcell_stuck_samples: u32,
    /// Largest |torque| a joint request may carry before it is refused outright.
    pub max_request_torque_nm: f32,
    pub max_request_stiffness_nm_per_rad: f32,
    pub max_request_force_n: f32,
    /// This many consecutive missed periods (an overrun, or a wake-up a whole period late)
    /// is a latched `LOOP_OVERRUN` fault; within [`OVERRUN_FAULT_PERIODS_RANGE`]. A
    /// configuration file without it gets the default.
    #[cfg_attr(feature = "serde", serde(default = "default_overrun_fault_periods"))]
    pub overrun_fault_periods: u32,
}

#[cfg(feature = "serde")]
fn default_overrun_fault_periods() -> u32 {
    DEFAULT_OVERRUN_FAULT_PERIODS
}

impl SafetyConfig {
    pub const fn default_1khz() -> Self {
        SafetyConfig {
            period_s: 0.001,
            command_timeout_s: 0.100,
            slew_bar_per_s: 50.0,
            timeout_ramp_bar_per_s: 5.0,
            max_joint_speed_rad_s: 20.0,
            angle_margin_rad: 0.05,
            loadcell_limit_n: 190.0,
            loadcell_stuck_samples: 500,
            max_request_torque_nm: 200.0,
            max_request_stiffness_nm_per_rad: 500.0,
            max_request_force_n: 100.0,
            overrun_fault_periods: DEFAULT_OVERRUN_FAULT_PERIODS,
        }
    }

    /// Refuses configurations that would disable a protection.
    pub fn validate(&self) -> Result<(), Reject> {
        let positive = [
            self.command_timeout_s,
            self.slew_bar_per_s,
            self.timeout_ramp_bar_per_s,
            self.max_joint_speed_rad_s,
            self.loadcell_limit_n,
            self.max_request_torque_nm,
            self.max_request_stiffness_nm_per_rad,
            self.max_request_force_n,
        ];
        if !(self.period_s >= 0.001 && self.period_s <= 0.010) {
            return Err(Reject::OutOfRange);
        }
        if positive.iter().any(|v| !(v.is_finite() && *v > 0.0))
            || !(self.angle_margin_rad >= 0.0)
            || self.loadcell_stuck_samples < 2
            || !OVERRUN_FAULT_PERIODS_RANGE.contains(&self.overrun_fault_periods)
        {
            return Err(Reject::OutOfRange);
        }
        if self.command_timeout_s > 1.0 {
            return Err(Reject::OutOfRange);
        }
        Ok(())
    }
}

/// Why a command was refused. A refused command changes nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// A value is NaN/∞ or outside the absolute limits.
    OutOfRange,
    /// Not allowed in the present state (e.g. arm while faulted).
    WrongState,
    /// Clear refused: a fault condition is still present.
    FaultStillPresent,
}
