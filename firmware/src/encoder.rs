//! Quadrature encoder driver: a timer in encoder mode (×4 decoding) whose 16-bit count is
//! extended in software to a signed 64-bit count, so no count is lost when the hardware
//! counter wraps. The output is raw counts; counts → rad, the homing offset and the sign
//! belong to `pam-device`. The extension itself is `pam_firmware_logic::counter` (host-tested).
//!
//! Wrap safety: between two reads the hardware count may move by at most ±32767 counts
//! (half the 16-bit range) for the difference to be unambiguous. Read every control period
//! (≤ 10 ms), that allows 3.2 M counts/s, i.e. 400 rev/s at 8000 counts/rev: far beyond
//! what a joint with hard stops at ±32.5° can do.

use embassy_stm32::timer::qei::{Config, Qei, QeiMode};
use embassy_stm32::timer::{Ch1, Ch2, GeneralInstance4Channel, TimerPin};
use embassy_stm32::Peri;

use pam_firmware_logic::counter::WrapExtender;

use crate::board;

pub struct QuadratureEncoder<'d, T: GeneralInstance4Channel> {
    qei: Qei<'d, T>,
    extender: WrapExtender,
}

impl<'d, T: GeneralInstance4Channel> QuadratureEncoder<'d, T> {
    /// Puts the timer in encoder mode 3 (counts on both edges of both inputs).
    pub fn new(
        timer: Peri<'d, T>,
        ch_a: Peri<'d, impl TimerPin<T, Ch1>>,
        ch_b: Peri<'d, impl TimerPin<T, Ch2>>,
    ) -> Self {
        let config = Config {
            ch1_pull: board::ENCODER_PULL,
            ch2_pull: board::ENCODER_PULL,
            mode: QeiMode::Mode3,
            auto_reload: u16::MAX,
        };
        let qei = Qei::new::<Ch1, Ch2>(timer, ch_a, ch_b, config);
        let first = qei.count();
        Self {
            qei,
            extender: WrapExtender::new(first),
        }
    }

    /// Samples the hardware counter and returns the extended count since start-up. Must
    /// be called at least once per ±32767 counts of motion (every control period).
    pub fn read_counts(&mut self) -> i64 {
        self.extender.update(self.qei.count())
    }
}
