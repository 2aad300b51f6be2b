//! Sensor front end: raw timer counts and ADC volts → angles and sensor-frame forces.

use pam_protocol::EncoderCalibration;

/// Quadrature encoders read from free-running hardware counters of `counter_bits` bits.
/// Each sample's change is taken modulo the counter width, so a wrap between two samples
/// loses no count as long as the joint moves less than half the counter range per period
/// (32 768 counts per period for a 16-bit timer: 4 turns at 8 000 counts/rev).
#[derive(Clone, Copy, Debug)]
pub struct Encoders {
    counter_mask: u32,
    last_raw: [u32; 2],
    started: bool,
    /// Accumulated counts since boot (wrapping i32: ±268 000 turns at 8 000 counts/rev).
    position_counts: [i32; 2],
    home_counts: [i32; 2],
    homed: bool,
    /// sign · 2π / counts_per_rev, precomputed.
    rad_per_count: [f32; 2],
    calibration: [EncoderCalibration; 2],
}

impl Encoders {
    /// `counter_bits` in 1..=32 (16 or 32 on STM32 timers).
    pub fn new(counter_bits: u8, calibration: [EncoderCalibration; 2]) -> Self {
        let bits = counter_bits.clamp(1, 32);
        let mut e = Encoders {
            counter_mask: if bits == 32 {
                u32::MAX
            } else {
                (1u32 << bits) - 1
            },
            last_raw: [0; 2],
            started: false,
            position_counts: [0; 2],
            home_counts: [0; 2],
            homed: false,
            rad_per_count: [0.0; 2],
            calibration,
        };
        e.set_calibration(calibration);
        e
    }

    pub fn calibration(&self) -> [EncoderCalibration; 2] {
        self.calibration
    }

    /// Caller validates (counts_per_rev > 0, sign ±1).
    pub fn set_calibration(&mut self, calibration: [EncoderCalibration; 2]) {
        self.calibration = calibration;
        for j in 0..2 {
            let c = calibration[j];
            self.rad_per_count[j] =
                c.sign as f32 * (2.0 * core::f32::consts::PI) / c.counts_per_rev.max(1) as f32;
        }
    }

    /// Takes one sample; returns α (rad) of both joints.
    #[inline]
    pub fn update(&mut self, raw: [u32; 2]) -> [f32; 2] {
        let half = self.counter_mask / 2;
        for j in 0..2 {
            let r = raw[j] & self.counter_mask;
            if self.started {
                let delta = r.wrapping_sub(self.last_raw[j]) & self.counter_mask;
                let signed = if delta > half {
                    // backwards: delta − 2^bits, as an i32
                    (delta as i32)
                        .wrapping_sub(self.counter_mask as i32)
                        .wrapping_sub(1)
                } else {
                    delta as i32
                };
                self.position_counts[j] = self.position_counts[j].wrapping_add(signed);
            }
            self.last_raw[j] = r;
        }
        self.started = true;
        self.alpha_rad()
    }

    pub fn alpha_rad(&self) -> [f32; 2] {
        [0, 1].map(|j| {
            self.position_counts[j].wrapping_sub(self.home_counts[j]) as f32 * self.rad_per_count[j]
                - self.calibration[j].zero_rad
        })
    }

    /// The present position becomes the homing pose: α = −`zero_rad` (0 with the arm at the
    /// neutral pose and the zero commissioned).
    pub fn home(&mut self) {
        self.home_counts = self.position_counts;
        self.homed = true;
    }

    pub fn homed(&self) -> bool {
        self.homed
    }

    /// The zero is known to be wrong: the angles keep it, arming needs a new home.
    pub fn forget_home(&mut self) {
        self.homed = false;
    }

    /// Accumulated counts since boot (for tests and diagnostics).
    pub fn position_counts(&self) -> [i32; 2] {
        self.position_counts
    }
}
