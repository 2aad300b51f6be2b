//! Raw sensor readings → the physical units `pam_control::Sensors` wants.
//!
//! TEMPORARY: this belongs to the shared `pam-device` crate (homing offset, sign, counts per
//! revolution, load-cell calibration and tare, all tested on the host). Delete this module
//! when that crate lands on main; the drivers' outputs (raw counts, volts) stay as they are.

use core::f32::consts::TAU;

use pam_model::params::LoadCell;

use crate::board;

pub struct SensorConversion {
    /// Encoder count at the neutral pose (α = 0), per joint.
    zero_counts: [i64; 2],
    /// +1 or −1: direction of the encoder relative to α (a wiring/mounting fact).
    sign: [f32; 2],
    rad_per_count: f32,
}

impl SensorConversion {
    /// Counts are zero at power-up, and the rig is powered up at the neutral pose, so the
    /// neutral pose is count 0 until a homing command says otherwise.
    pub const fn at_power_up() -> Self {
        Self {
            zero_counts: [0; 2],
            sign: [1.0; 2],
            rad_per_count: TAU / board::ENCODER_COUNTS_PER_REV as f32,
        }
    }

    /// Makes the present counts the neutral pose.
    #[allow(dead_code)] // the homing command arrives with the protocol
    pub fn home(&mut self, counts: [i64; 2]) {
        self.zero_counts = counts;
    }

    pub fn alpha_rad(&self, counts: [i64; 2]) -> [f32; 2] {
        [0, 1].map(|j| {
            // The difference is small (the joints move < 1 rev): exact in f32.
            let steps = counts[j].wrapping_sub(self.zero_counts[j]) as f32;
            self.sign[j] * steps * self.rad_per_count
        })
    }

    /// Sensor-frame forces (eq. 2.1) with the model's per-channel calibration.
    pub fn force_sensor_n(load_cell: &LoadCell<f32>, volts: [f32; 2]) -> [f32; 2] {
        load_cell.forces_n(volts)
    }
}
