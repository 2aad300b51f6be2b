//! The closed force loop's guard: a large, a persistent or an oscillating error latches
//! `Faults::CONTROL_UNSTABLE` (the supervisor vents).

use crate::force_loop::ForceLoopConfig;
use pam_model::{Real, Vec2};

/// Why the guard tripped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuardTrip {
    /// The error stayed large (growing error, or a force the plant cannot deliver).
    PersistentError,
    /// The error oscillates.
    Oscillation,
    /// The error passed `guard_error_max_n`.
    ErrorBound,
    /// The loop asks the muscles for far more force than the load cell reads, for longer
    /// than the converters take to follow: a dead cell (that may still dither) or a handle
    /// the muscles no longer reach.
    ImplausibleLoadCell,
}

/// The cell plausibility's floor, N: a command below it is never judged (the model's own
/// error at small forces, §5.2: up to 11 N at the handle).
pub const CELL_PLAUSIBILITY_FLOOR_N: f32 = 10.0;
/// The largest believable ratio of the command to the measured force: the rig's muscles
/// give 0.57 of the model's force (Table 5.2), so a healthy loop asks for ≈ 1.75× what it
/// reads at most.
pub const CELL_PLAUSIBILITY_RATIO: f32 = 2.5;
/// How long the command must stay implausible, s (the converters settle in ≈ 0.4 s).
pub const CELL_PLAUSIBILITY_TIME_S: f32 = 1.0;
/// Time constant of the command's low-pass, s (the converters' lag).
pub const CELL_PLAUSIBILITY_FILTER_S: f32 = 0.2;

/// The slow oscillation detector's band, N: an error swinging across ±8 N, well above the
/// load cell's noise and a settled step's ripple, is a limit cycle.
pub const SLOW_OSCILLATION_BAND_N: f32 = 8.0;
/// Its leaky count's time constant, s: long enough that a swing at 0.5 Hz (one flip a
/// second, the arm's slowest mode) accumulates.
pub const SLOW_OSCILLATION_TAU_S: f32 = 4.0;
/// Its count that trips: one flip a second settles at ≈ 4.5 just after each flip and
/// trips after ≈ 5 s; ±20 N at 1 Hz trips in ≈ 2 s.
pub const SLOW_OSCILLATION_FLIPS: f32 = 3.0;

/// A leaky count of the error's sign flips across ±`band`, per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FlipCount {
    sign: [i8; 2],
    flips: [f32; 2],
}

impl FlipCount {
    const fn new() -> Self {
        FlipCount {
            sign: [0; 2],
            flips: [0.0; 2],
        }
    }

    /// One period: decay by `leak`, count a flip across ±`band`; whether an axis passes
    /// `limit`.
    fn update(&mut self, error_n: Vec2<f32>, band: f32, leak: f32, limit: f32) -> bool {
        for a in 0..2 {
            self.flips[a] *= 1.0 - leak;
            let e = error_n[a];
            let s = if e > band {
                1
            } else if e < -band {
                -1
            } else {
                self.sign[a]
            };
            if s != self.sign[a] && self.sign[a] != 0 {
                self.flips[a] += 1.0;
            }
            self.sign[a] = s;
        }
        self.flips[0] > limit || self.flips[1] > limit
    }
}

/// The guard's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Guard {
    large_error_s: f32,
    /// Flips across `guard_band_n`, time constant 1 s.
    fast: FlipCount,
    /// Flips across [`SLOW_OSCILLATION_BAND_N`], time constant [`SLOW_OSCILLATION_TAU_S`].
    slow: FlipCount,
    /// The command, low-passed like the converters follow it, N.
    command_n: Vec2<f32>,
    implausible_s: f32,
}

impl Guard {
    pub(crate) const fn new() -> Self {
        Guard {
            large_error_s: 0.0,
            fast: FlipCount::new(),
            slow: FlipCount::new(),
            command_n: [0.0; 2],
            implausible_s: 0.0,
        }
    }

    /// The load cell against the force the loop commands: a command (low-passed) beyond
    /// [`CELL_PLAUSIBILITY_FLOOR_N`] + [`CELL_PLAUSIBILITY_RATIO`] × the measured force for
    /// [`CELL_PLAUSIBILITY_TIME_S`] is a cell that does not see what the muscles do.
    pub(crate) fn cell_implausible(
        &mut self,
        command_n: Vec2<f32>,
        measured_n: Vec2<f32>,
        dt_s: f32,
    ) -> bool {
        let k = (dt_s / CELL_PLAUSIBILITY_FILTER_S).min(1.0);
        for a in 0..2 {
            self.command_n[a] += k * (command_n[a] - self.command_n[a]);
        }
        let c = self.command_n;
        let m = measured_n;
        let command = <f32 as Real>::sqrt(c[0] * c[0] + c[1] * c[1]);
        let measured = <f32 as Real>::sqrt(m[0] * m[0] + m[1] * m[1]);
        if command > CELL_PLAUSIBILITY_FLOOR_N + CELL_PLAUSIBILITY_RATIO * measured {
            self.implausible_s += dt_s;
        } else {
            self.implausible_s = 0.0;
        }
        self.implausible_s >= CELL_PLAUSIBILITY_TIME_S
    }

    /// One period of the loop's error (`err_sq` its squared norm).
    pub(crate) fn update(
        &mut self,
        cfg: &ForceLoopConfig,
        error_n: Vec2<f32>,
        err_sq: f32,
        dt_s: f32,
    ) -> Option<GuardTrip> {
        if err_sq > cfg.guard_error_n * cfg.guard_error_n || !err_sq.is_finite() {
            self.large_error_s += dt_s;
        } else {
            self.large_error_s = 0.0;
        }
        let fast = self
            .fast
            .update(error_n, cfg.guard_band_n, dt_s, cfg.guard_flips);
        let slow = self.slow.update(
            error_n,
            SLOW_OSCILLATION_BAND_N,
            dt_s / SLOW_OSCILLATION_TAU_S,
            SLOW_OSCILLATION_FLIPS,
        );
        // NaN included: nothing downstream may act on a non-finite error
        if !(err_sq <= cfg.guard_error_max_n * cfg.guard_error_max_n) {
            Some(GuardTrip::ErrorBound)
        } else if self.large_error_s >= cfg.guard_time_s {
            Some(GuardTrip::PersistentError)
        } else if fast || slow {
            Some(GuardTrip::Oscillation)
        } else {
            None
        }
    }
}
