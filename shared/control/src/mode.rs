//! What the robot is asked to do, the arm/fault state, and one period's inputs and outputs.

use pam_model::{Limited, Vec2};
#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::faults::Faults;

/// What the robot is asked to do while armed.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub enum Mode {
    /// Safe outputs (vent).
    Idle,
    /// Four channel pressures, bar.
    Pressures { pressure_bar: [f32; 4] },
    /// Per joint: equilibrium angle, torque and stiffness → inverse model.
    Joint {
        alpha_rad: Vec2<f32>,
        torque_nm: Vec2<f32>,
        stiffness_nm_per_rad: Vec2<f32>,
    },
    /// Handle force in the user frame → τ = Jᵀ F → inverse model at the measured pose.
    Force {
        force_n: Vec2<f32>,
        stiffness_nm_per_rad: Vec2<f32>,
        feed_forward: bool,
    },
    /// [`Mode::Force`] with the load cell in the loop (`force_loop`): the same path, its
    /// command corrected by feedback. `gain_scale` multiplies the designed feedback gains
    /// (1 = the design; 0 < scale ≤ [`MAX_GAIN_SCALE`]).
    ForceClosedLoop {
        force_n: Vec2<f32>,
        stiffness_nm_per_rad: Vec2<f32>,
        feed_forward: bool,
        gain_scale: f32,
    },
    /// A Cartesian spring-damper-mass about `target_user_m` (user frame, diagonal K, B and
    /// M), rendered by the closed force loop (`impedance`); the muscles at their least
    /// stiffness. `mass_kg` is the virtual mass added to what the operator feels (0: none).
    Impedance {
        target_user_m: Vec2<f32>,
        stiffness_n_per_m: Vec2<f32>,
        damping_n_s_per_m: Vec2<f32>,
        mass_kg: Vec2<f32>,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
pub enum State {
    Disarmed,
    Armed,
    Faulted,
}

/// One period's sensor readings, already in physical units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensors {
    pub alpha_rad: Vec2<f32>,
    /// Load cell in its own frame (X, Z), N.
    pub force_sensor_n: Vec2<f32>,
}

/// What one step decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepOutput {
    pub pressure_bar: [f32; 4],
    pub current_ma: [f32; 4],
    /// Force at the handle in the user frame, N.
    pub force_user_n: Vec2<f32>,
    pub state: State,
    pub faults: Faults,
    /// What the model clamped this step (joint 1 | joint 2).
    pub limited: Limited,
    /// The slew limit or a converter's range changed the command this step.
    pub output_limited: bool,
}

/// Bit of [`StepOutput::limited_byte`] set when the slew limit or a converter's range changed
/// the command (above the model's `Limited` bits).
pub const LIMITED_OUTPUT: u8 = 0x80;

impl StepOutput {
    /// What was limited, as telemetry and the logs carry it: the model's `Limited` bits of
    /// both joints, with [`LIMITED_OUTPUT`] for the output path.
    pub fn limited_byte(&self) -> u8 {
        let out = if self.output_limited {
            LIMITED_OUTPUT
        } else {
            0
        };
        (self.limited.0 & !LIMITED_OUTPUT) | out
    }
}
