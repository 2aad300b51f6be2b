//! The control logic of the firmware, free of any peripheral: modes, the arm/disarm/fault
//! state machine and the safety supervisor. The firmware feeds it sensor readings once per
//! period and writes what it returns to the four current outputs; the emulator runs the
//! same code against the digital twin.
//!
//! # Safe state: vent
//!
//! On a fault, a disarm or at boot the four I/P converters get [`VENT_CURRENT_MA`], the
//! converters' floor (4 mA), a compile-time constant: no configuration and no output
//! calibration changes it. Every muscle vents to the converter's floor (0.1 bar) and the arm goes limp.
//! The alternative, holding the 2.3 bar pretension, keeps the cables seated but leaves a
//! spring of 60–120 N·m/rad pulling the patient's arm toward the neutral pose, driven by a
//! controller that has just declared itself untrustworthy. A limp planar arm on a table
//! cannot hurt the patient (no gravity load in the plane); slack cables are an equipment
//! problem, handled by re-tensioning when the operator re-arms. Venting is also what the
//! hardware does by itself when the board resets or loses power (current below 4 mA), so
//! software and hardware fail the same way.
//!
//! Faults cut to the safe state at once; a command timeout (the host went quiet) ramps
//! down to the vent at the configured rate, never slower than
//! [`safety::ceiling::TIMEOUT_RAMP_MIN_BAR_PER_S`] (so within
//! [`safety::ceiling::TIMEOUT_RAMP_MAX_S`] from any pressure), since nothing is known to be
//! wrong with the plant.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![allow(clippy::needless_range_loop)]

pub mod faults;
pub mod force_loop;
mod force_loop_config;
pub mod guard;
pub mod home_check;
pub mod impedance;
pub mod mode;
pub mod motion;
mod output;
pub mod plant_gain;
pub mod plausibility;
pub mod safety;
mod supervise;
pub mod supervisor;
mod targets;

/// The safe state's loop current, mA: the converters' floor, where every muscle vents. The
/// output whenever the controller is not armed or is faulted (a finished link-loss ramp
/// included), never passed through the output calibration and never configurable.
pub const VENT_CURRENT_MA: f32 = 4.0;
/// The largest loop current any output may carry, mA (the 4–20 mA range's top).
pub const MAX_LOOP_CURRENT_MA: f32 = 20.0;

#[cfg(any(test, feature = "checks"))]
pub mod checks;
#[cfg(any(test, feature = "checks"))]
pub mod force_loop_checks;
#[cfg(any(test, feature = "checks"))]
pub mod motion_checks;
#[cfg(any(test, feature = "checks"))]
pub mod safety_checks;

pub use force_loop::{ForceLoop, ForceLoopConfig, GuardTrip, MAX_GAIN_SCALE};
pub use impedance::{
    arm_inertia_force_n, impedance_force_n, Impedance, VirtualImpedance,
    MAX_IMPEDANCE_DAMPING_N_S_PER_M, MAX_IMPEDANCE_MASS_KG, MAX_IMPEDANCE_STIFFNESS_N_PER_M,
    MAX_IMPEDANCE_TARGET_M,
};
pub use supervisor::*;
