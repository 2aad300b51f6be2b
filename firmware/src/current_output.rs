//! 4–20 mA output driver: four PWM channels of one timer, each followed by a 2nd-order RC
//! filter and an XTR111 voltage-to-current converter (circuit, part values, ripple and
//! settling in `docs/output-stage.md`).
//!
//! * Per-channel law: duty = `duty_per_ma` × I + `duty_offset` (fractions of the PWM
//!   period), given at construction (the circuit's nominal law from `board`). The rig's
//!   measured per-channel trim is `pam_protocol::OutputCalibration`, set by the host and
//!   applied by `pam-device` before the current reaches this driver: one place for it.
//! * Every request is clamped to 4–20 mA (NaN → 4 mA) before it reaches the timer.
//! * Open-loop detection: each XTR111 pulls its EF pin low when it cannot drive the loop
//!   (broken wire, I/P converter unplugged, no compliance). A flag low for
//!   `OUTPUT_ERROR_DEBOUNCE_PERIODS` consecutive reads is an open loop.
//! * Safe state (vent): 4 mA on every channel. The compare values that give it are
//!   published in atomics, so the panic handler can restore them with plain register
//!   writes ([`drive_safe_from_panic`]). Before the timer is set up (reset, early boot) the
//!   PWM pins float, the filter's pull-down holds the XTR111 input at 0 V and the loop
//!   carries 0 mA: the I/P converters vent as well.
//!
//! The per-period write goes straight to the compare registers (one store per channel, no
//! assertion on the control path); the HAL does the setup.

use core::sync::atomic::{AtomicU16, Ordering};

use embassy_stm32::gpio::{Input, OutputType};
use embassy_stm32::timer::simple_pwm::{PwmPin, SimplePwm};
use embassy_stm32::timer::low_level::CountingMode;

use crate::board;

pub const CHANNELS: usize = 4;
pub const LOOP_MIN_MA: f32 = 4.0;
pub const LOOP_MAX_MA: f32 = 20.0;

/// Compare values giving 4 mA on each channel, for the panic handler. 0 (0 mA, also a
/// vent) until the driver has been set up.
static SAFE_COMPARE: [AtomicU16; CHANNELS] = [const { AtomicU16::new(0) }; CHANNELS];

/// mA → duty law of one channel.
#[derive(Clone, Copy, Debug, PartialEq, defmt::Format)]
pub struct ChannelCalibration {
    /// Duty fraction per mA (nominal: 1 / full-scale current).
    pub duty_per_ma: f32,
    /// Duty fraction at 0 mA (op-amp offset, leakage), nominal 0.
    pub duty_offset: f32,
}

impl ChannelCalibration {
    /// The stage's nominal law (`board::OUTPUT_FULL_SCALE_MA` at 100 % duty).
    pub const fn nominal() -> Self {
        Self {
            duty_per_ma: 1.0 / board::OUTPUT_FULL_SCALE_MA,
            duty_offset: 0.0,
        }
    }

    fn duty(&self, current_ma: f32) -> f32 {
        self.duty_per_ma * current_ma + self.duty_offset
    }

    /// A usable law is finite, increasing, and puts the whole 4–20 mA range inside the
    /// PWM's 0–100 % duty.
    pub fn is_valid(&self) -> bool {
        let lo = self.duty(LOOP_MIN_MA);
        let hi = self.duty(LOOP_MAX_MA);
        self.duty_per_ma.is_finite()
            && self.duty_offset.is_finite()
            && self.duty_per_ma > 0.0
            && lo >= 0.0
            && hi <= 1.0
    }
}

/// What one write put on the loops.
#[derive(Clone, Copy, Debug, PartialEq, defmt::Format)]
pub struct AppliedCurrents {
    /// Requested current after clamping to 4–20 mA, per channel.
    pub current_ma: [f32; CHANNELS],
    /// A request was outside 4–20 mA or not finite.
    pub clamped: bool,
}

pub struct CurrentLoopOutputs {
    // Owns the timer and its pins (configured once, then only the compares change).
    pwm: SimplePwm<'static, board::OutputTimer>,
    error_flags: [Input<'static>; CHANNELS],
    error_periods: [u16; CHANNELS],
    calibration: [ChannelCalibration; CHANNELS],
    /// Compare value of 100 % duty (= timer period in counts).
    full_duty_counts: u32,
}

impl CurrentLoopOutputs {
    /// Starts the timer with every channel at 4 mA, then enables the outputs. A channel
    /// whose law is invalid (see [`ChannelCalibration::is_valid`]) gets the nominal one.
    pub fn new(o: board::CurrentOutputs, calibration: [ChannelCalibration; CHANNELS]) -> Self {
        let pwm = SimplePwm::new(
            o.timer,
            Some(PwmPin::new(o.ch1, OutputType::PushPull)),
            Some(PwmPin::new(o.ch2, OutputType::PushPull)),
            Some(PwmPin::new(o.ch3, OutputType::PushPull)),
            Some(PwmPin::new(o.ch4, OutputType::PushPull)),
            board::OUTPUT_PWM_HZ,
            CountingMode::EdgeAlignedUp,
        );
        let full_duty_counts = pwm.max_duty_cycle();
        let pull = board::OUTPUT_ERROR_FLAG_PULL;
        let mut this = Self {
            error_flags: [
                Input::new(o.error_flag1, pull),
                Input::new(o.error_flag2, pull),
                Input::new(o.error_flag3, pull),
                Input::new(o.error_flag4, pull),
            ],
            error_periods: [0; CHANNELS],
            calibration: calibration.map(|c| {
                if c.is_valid() {
                    c
                } else {
                    ChannelCalibration::nominal()
                }
            }),
            full_duty_counts,
            pwm,
        };
        this.publish_safe_compares();
        this.write_ma([LOOP_MIN_MA; CHANNELS]);
        // The compares are preloaded: force an update so the 4 mA values are live before
        // the pins start driving.
        board::OUTPUT_TIMER_REGS.egr().write(|w| w.set_ug(true));
        use embassy_stm32::timer::Channel::*;
        for c in [Ch1, Ch2, Ch3, Ch4] {
            this.pwm.channel(c).enable();
        }
        this
    }

    fn compare_for(&self, channel: usize, current_ma: f32) -> u16 {
        let duty = self.calibration[channel].duty(current_ma).clamp(0.0, 1.0);
        let counts = duty * self.full_duty_counts as f32 + 0.5;
        // `as` saturates; the period fits in 16 bits (checked by `new`'s timer setup).
        (counts as u32).min(self.full_duty_counts) as u16
    }

    fn publish_safe_compares(&self) {
        for (c, slot) in SAFE_COMPARE.iter().enumerate() {
            slot.store(self.compare_for(c, LOOP_MIN_MA), Ordering::Relaxed);
        }
    }

    /// Writes the four loop currents, clamped to 4–20 mA. Takes effect at the next PWM
    /// period (≤ 50 µs), all channels together.
    pub fn write_ma(&mut self, current_ma: [f32; CHANNELS]) -> AppliedCurrents {
        let mut clamped = false;
        let mut applied = [LOOP_MIN_MA; CHANNELS];
        for c in 0..CHANNELS {
            let request = current_ma[c];
            let ma = if request.is_nan() {
                LOOP_MIN_MA
            } else {
                request.clamp(LOOP_MIN_MA, LOOP_MAX_MA)
            };
            clamped |= ma != request;
            applied[c] = ma;
            let compare = self.compare_for(c, ma);
            board::OUTPUT_TIMER_REGS
                .ccr(c)
                .write(|w| w.set_ccr(compare));
        }
        AppliedCurrents {
            current_ma: applied,
            clamped,
        }
    }

    /// Reads the error flags once (call once per control period) and returns, per
    /// channel, whether the loop has been reported open for the debounce time.
    pub fn poll_open_loop(&mut self) -> [bool; CHANNELS] {
        let mut open = [false; CHANNELS];
        for ((flag, periods), open) in self
            .error_flags
            .iter()
            .zip(self.error_periods.iter_mut())
            .zip(open.iter_mut())
        {
            *periods = if flag.is_low() {
                periods.saturating_add(1)
            } else {
                0
            };
            *open = *periods >= board::OUTPUT_ERROR_DEBOUNCE_PERIODS;
        }
        open
    }
}

/// Puts every channel back to its 4 mA compare value with plain register stores: no lock,
/// no allocation, nothing that another context could be holding. For the panic handler.
pub fn drive_safe_from_panic() {
    for (c, slot) in SAFE_COMPARE.iter().enumerate() {
        let compare = slot.load(Ordering::Relaxed);
        board::OUTPUT_TIMER_REGS
            .ccr(c)
            .write(|w| w.set_ccr(compare));
    }
}
