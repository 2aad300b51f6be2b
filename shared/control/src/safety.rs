//! The limits the firmware enforces whatever the host says, and why a command is refused.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

/// The load-cell amplifier's full-scale output, V (±10 V, what the NI 9215 accepted). A
/// channel at or beyond it is saturated: X ±111 N, Z ±167 N with the thesis's gains
/// (0.09 V/N, 0.06 V/N). The volts are recovered from the force with the present
/// calibration, so the limit holds whatever the gain, offset or tare.
pub const LOADCELL_AMPLIFIER_FULL_SCALE_V: f32 = 10.0;

/// Consecutive missed control periods that latch `Faults::LOOP_OVERRUN` by default: one or two can be a debugger or a long USB critical section; three in a row is a
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
    /// Ramp rate to the vent after a command timeout; at least
    /// [`ceiling::TIMEOUT_RAMP_MIN_BAR_PER_S`], so the ramp ends within
    /// [`ceiling::TIMEOUT_RAMP_MAX_S`].
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

/// The ceilings of [`SafetyConfig`]: compile-time bounds that no configuration can pass.
/// A configuration may only be tighter (and, while armed, only tighten further:
/// [`SafetyConfig::may_apply_while_armed`]). Each is at or beyond the default, so the
/// defaults are valid, and each keeps its protection on (a zero or an infinity is refused).
pub mod ceiling {
    /// Control period range, s (1–10 ms: the loop and its timing checks are designed for it).
    pub const PERIOD_MIN_S: f32 = 0.001;
    pub const PERIOD_MAX_S: f32 = 0.010;
    /// Longest silence of the commanding host before the link-loss ramp starts, s.
    pub const COMMAND_TIMEOUT_MAX_S: f32 = 1.0;
    /// Fastest pressure change a mode may command, bar/s (the converters' own full-scale
    /// fill takes 1.6–2.4 s: faster commands only strain them).
    pub const SLEW_MAX_BAR_PER_S: f32 = 100.0;
    /// Longest link-loss ramp from the absolute pressure limit to the vent, s.
    pub const TIMEOUT_RAMP_MAX_S: f32 = 1.0;
    /// Slowest link-loss ramp: from the absolute pressure limit (5 bar) to the vent within
    /// [`TIMEOUT_RAMP_MAX_S`].
    pub const TIMEOUT_RAMP_MIN_BAR_PER_S: f32 = 5.0 / TIMEOUT_RAMP_MAX_S;
    /// Fastest believable joint speed between two samples (beyond: an encoder jump), rad/s.
    pub const JOINT_SPEED_MAX_RAD_S: f32 = 20.0;
    /// Widest margin beyond the joint range before the angle is a fault, rad (≈ 5.7°).
    pub const ANGLE_MARGIN_MAX_RAD: f32 = 0.1;
    /// Largest sensor-frame force before saturation is declared, N (the amplifier's full
    /// scale of the thesis's X channel is ±111 N, Z ±167 N; the cell is rated 200 N).
    pub const LOADCELL_LIMIT_MAX_N: f32 = 200.0;
    /// Most identical load-cell samples before a stuck cell is declared.
    pub const LOADCELL_STUCK_SAMPLES_MAX: u32 = 1000;
    /// Fewest: two identical samples are not yet a frozen cell.
    pub const LOADCELL_STUCK_SAMPLES_MIN: u32 = 2;
    /// Largest |torque| of a joint request, N·m.
    pub const REQUEST_TORQUE_MAX_NM: f32 = 200.0;
    /// Largest joint stiffness of a request, N·m/rad.
    pub const REQUEST_STIFFNESS_MAX_NM_PER_RAD: f32 = 500.0;
    /// Largest handle force of a request, N.
    pub const REQUEST_FORCE_MAX_N: f32 = 100.0;
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

    /// Refuses configurations that would disable or loosen a protection beyond its
    /// [`ceiling`]. NaN fails every comparison below, so it is refused too.
    pub fn validate(&self) -> Result<(), Reject> {
        use ceiling::*;
        let within = |v: f32, hi: f32| v > 0.0 && v <= hi;
        let ok = (PERIOD_MIN_S..=PERIOD_MAX_S).contains(&self.period_s)
            && within(self.command_timeout_s, COMMAND_TIMEOUT_MAX_S)
            && within(self.slew_bar_per_s, SLEW_MAX_BAR_PER_S)
            && self.timeout_ramp_bar_per_s >= TIMEOUT_RAMP_MIN_BAR_PER_S
            && self.timeout_ramp_bar_per_s.is_finite()
            && within(self.max_joint_speed_rad_s, JOINT_SPEED_MAX_RAD_S)
            && (0.0..=ANGLE_MARGIN_MAX_RAD).contains(&self.angle_margin_rad)
            && within(self.loadcell_limit_n, LOADCELL_LIMIT_MAX_N)
            && (LOADCELL_STUCK_SAMPLES_MIN..=LOADCELL_STUCK_SAMPLES_MAX)
                .contains(&self.loadcell_stuck_samples)
            && within(self.max_request_torque_nm, REQUEST_TORQUE_MAX_NM)
            && within(
                self.max_request_stiffness_nm_per_rad,
                REQUEST_STIFFNESS_MAX_NM_PER_RAD,
            )
            && within(self.max_request_force_n, REQUEST_FORCE_MAX_N)
            && OVERRUN_FAULT_PERIODS_RANGE.contains(&self.overrun_fault_periods);
        if ok {
            Ok(())
        } else {
            Err(Reject::OutOfRange)
        }
    }

    /// Whether `new` may replace `self` while the robot is armed: the same period, and
    /// every limit as tight or tighter (a protection may be tightened under a patient,
    /// never loosened). `new` must also pass [`SafetyConfig::validate`].
    pub fn may_apply_while_armed(&self, new: &SafetyConfig) -> bool {
        new.period_s == self.period_s
            && new.command_timeout_s <= self.command_timeout_s
            && new.slew_bar_per_s <= self.slew_bar_per_s
            && new.timeout_ramp_bar_per_s >= self.timeout_ramp_bar_per_s
            && new.max_joint_speed_rad_s <= self.max_joint_speed_rad_s
            && new.angle_margin_rad <= self.angle_margin_rad
            && new.loadcell_limit_n <= self.loadcell_limit_n
            && new.loadcell_stuck_samples <= self.loadcell_stuck_samples
            && new.max_request_torque_nm <= self.max_request_torque_nm
            && new.max_request_stiffness_nm_per_rad <= self.max_request_stiffness_nm_per_rad
            && new.max_request_force_n <= self.max_request_force_n
            && new.overrun_fault_periods <= self.overrun_fault_periods
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
