//! Plausibility of the calibration requests (`Tare`, `Home`) and of a load-cell gain.
//!
//! Both calibrations run disarmed, with the muscles vented, so the device knows what the
//! sensors must read when the calibration is right:
//! - vented muscles push nothing through the handle, so with the handle free the load cell
//!   reads ≈ 0 N in its present calibration (drift between tares is a few newtons); a
//!   larger reading is a hand on the handle, and taring it would command that force back;
//! - the encoders count continuously from boot, so once homed the zero can only move by
//!   what a re-home corrects (the arm placed back at the neutral pose by hand); a re-home
//!   far from the previous zero is a wrong pose, or counts lost. A vented arm has no
//!   pressure equilibrium to compare the pose with (the vented twin drifts to its range
//!   ends), so a home cannot be judged when it is asked: the controller judges it at the
//!   first rest with the muscles tensioned, against the model's equilibrium for the
//!   commanded pressures (`pam_control::home_check`), and the device forgets a home it
//!   refuses.

use pam_model::params::LoadCell;

/// Largest force (N, per sensor axis, in the calibration in use) a tare may zero.
pub const TARE_MAX_FORCE_N: f32 = 5.0;

/// Largest move of the zero (rad, per joint) a re-home may make once homed.
pub const REHOME_MAX_SHIFT_RAD: f32 = 0.1;

/// The reading at tare is near zero force: a free handle, not a hand leaning on it.
pub fn tare_plausible(cell: &LoadCell<f32>, volts: [f32; 2]) -> bool {
    cell.forces_n(volts)
        .iter()
        .all(|f| f.abs() <= TARE_MAX_FORCE_N)
}

/// The present angles (in the zero in use) are close enough to it for a re-home.
pub fn rehome_plausible(alpha_rad: [f32; 2]) -> bool {
    alpha_rad.iter().all(|a| a.abs() <= REHOME_MAX_SHIFT_RAD)
}

/// The load cell's gains are positive and finite: a force on the handle reads with its
/// sign, never the reverse (which would turn the force loop into positive feedback).
pub fn load_cell_gain_plausible(cell: &LoadCell<f32>) -> bool {
    cell.gain_n_per_v.iter().all(|g| g.is_finite() && *g > 0.0)
}
