//! 4–20 mA output driver: four PWM channels of one timer, each followed by a 2nd-order RC
//! filter and an XTR111 voltage-to-current converter (circuit, part values, ripple and
//! settling in `docs/output-stage.md`).
//!
//! * Per-channel law: duty = `duty_per_ma` × I + `duty_offset` (fractions of the PWM
//!   period), given at construction (the circuit's nominal law from `board`). The rig's
//!   measured per-channel trim is `pam_protocol::OutputCalibration`, set by the host and
//!   applied by `pam-device` before the current reaches this driver: one place for it.
//! * Every request is clamped to 4–20 mA (NaN → 4 mA) before it reaches the timer, and no
//!   compare value beyond `board::OUTPUT_CEILING_COMPARE` (20.5 mA, NAMUR NE43) is ever
//!   written, whatever the law.
//! * Open-loop detection: each XTR111 pulls its EF pin low when it cannot drive the loop
//!   (broken wire, I/P converter unplugged, no compliance). A flag low for
//!   `OUTPUT_ERROR_DEBOUNCE_PERIODS` consecutive reads is an open loop.
//! * Safe state (vent): 4 mA on every channel. Its compare value is a constant computed by
//!   the compiler (`board::OUTPUT_SAFE_COMPARE`), which the fault paths and the E-stop write
//!   with plain register stores ([`drive_safe_compares`]): nothing is read from RAM. The
//!   timer's period is set to `board::OUTPUT_PERIOD_COUNTS`, so the constant is right by
//!   construction. Before the timer is set up (reset, early boot) the PWM pins float, the
//!   filter's pull-down holds the XTR111 input at 0 V and the loop carries 0 mA: the I/P
//!   converters vent as well.
//!
//! The law, the clamp and the debounce are `pam_firmware_logic` (host-tested). The
//! per-period write goes straight to the compare registers (one store per channel, no
//! assertion on the control path); the HAL does the setup.

use embassy_stm32::gpio::{Input, OutputType};
use embassy_stm32::timer::low_level::CountingMode;
use embassy_stm32::timer::simple_pwm::{PwmPin, SimplePwm};
use pam_firmware_logic::current_loop::clamp_loop_ma;
pub use pam_firmware_logic::current_loop::{ChannelLaw, LOOP_MIN_MA};
use pam_firmware_logic::debounce::Debounce;

use crate::board;

pub const CHANNELS: usize = 4;

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
    open_loop: [Debounce; CHANNELS],
    law: [ChannelLaw; CHANNELS],
}

impl CurrentLoopOutputs {
    /// Starts the timer with every channel at 4 mA, then enables the outputs. A channel
    /// whose law is invalid (see [`ChannelLaw::is_valid`]) gets the nominal one.
    pub fn new(o: board::CurrentOutputs, law: [ChannelLaw; CHANNELS]) -> Self {
        let pwm = SimplePwm::new(
            o.timer,
            Some(PwmPin::new(o.ch1, OutputType::PushPull)),
            Some(PwmPin::new(o.ch2, OutputType::PushPull)),
            Some(PwmPin::new(o.ch3, OutputType::PushPull)),
            Some(PwmPin::new(o.ch4, OutputType::PushPull)),
            board::OUTPUT_PWM_HZ,
            CountingMode::EdgeAlignedUp,
        );
        // The period the compare constants assume (the HAL's choice for 20 kHz at 170 MHz,
        // written again so that it cannot differ).
        let regs = board::OUTPUT_TIMER_REGS;
        regs.psc().write_value(0);
        regs.arr()
            .write(|w| w.set_arr(board::OUTPUT_PERIOD_COUNTS - 1));
        let pull = board::OUTPUT_ERROR_FLAG_PULL;
        let mut this = Self {
            error_flags: [
                Input::new(o.error_flag1, pull),
                Input::new(o.error_flag2, pull),
                Input::new(o.error_flag3, pull),
                Input::new(o.error_flag4, pull),
            ],
            open_loop: [Debounce::new(board::OUTPUT_ERROR_DEBOUNCE_PERIODS); CHANNELS],
            law: law.map(|l| {
                if l.is_valid() {
                    l
                } else {
                    board::output_nominal_law()
                }
            }),
            pwm,
        };
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

    /// Writes the four loop currents, clamped to 4–20 mA. Takes effect at the next PWM
    /// period (≤ 50 µs), all channels together.
    pub fn write_ma(&mut self, current_ma: [f32; CHANNELS]) -> AppliedCurrents {
        let mut clamped = false;
        let mut applied = [LOOP_MIN_MA; CHANNELS];
        for (c, (&request, law)) in current_ma.iter().zip(self.law.iter()).enumerate() {
            let (ma, changed) = clamp_loop_ma(request);
            clamped |= changed;
            applied[c] = ma;
            let compare = law
                .compare(ma, board::OUTPUT_PERIOD_COUNTS)
                .min(board::OUTPUT_CEILING_COMPARE);
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
        for ((flag, debounce), open) in self
            .error_flags
            .iter()
            .zip(self.open_loop.iter_mut())
            .zip(open.iter_mut())
        {
            *open = debounce.update(flag.is_low());
        }
        open
    }
}

/// Puts every channel at the vent current's compare value, a constant: plain register
/// stores, no lock, no RAM read, nothing another context could be holding. For the E-stop's
/// interrupt and the fault paths.
pub fn drive_safe_compares() {
    for c in 0..CHANNELS {
        board::OUTPUT_TIMER_REGS
            .ccr(c)
            .write(|w| w.set_ccr(board::OUTPUT_SAFE_COMPARE));
    }
}

/// OUT_EN# high: the output buffers off, the loops at 0 mA on the revised board. For the
/// fault paths, which end in a reset (after which the board's pull-up holds it high).
pub fn disable_output_stage() {
    board::OUTPUT_ENABLE_PORT
        .bsrr()
        .write(|w| w.set_bs(board::OUTPUT_ENABLE_PIN, true));
}
