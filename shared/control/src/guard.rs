//! The closed force loop's guard: a large, a persistent or an oscillating error latches
//! `Faults::CONTROL_UNSTABLE` (the supervisor vents). And [`EncoderMotion`], the encoders'
//! plausibility in the modes whose pressures do not follow the handle.

use crate::force_loop::ForceLoopConfig;
use pam_model::Vec2;

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

/// The sign of `v` once beyond ±`band`, `last` within it: a sign with hysteresis, whose
/// changes are the swings an oscillation detector counts.
pub(crate) fn sign_beyond(v: f32, band: f32, last: i8) -> i8 {
    if v > band {
        1
    } else if v < -band {
        -1
    } else {
        last
    }
}

/// Leaky counts of the error's sign flips per axis, across two bands at once: the fast
/// count (band `guard_band_n`, time constant 1 s) and the slow one (band
/// [`SLOW_OSCILLATION_BAND_N`], time constant [`SLOW_OSCILLATION_TAU_S`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct FlipCount {
    /// The last sign beyond each band, per axis: [fast, slow].
    sign: [[i8; 2]; 2],
    flips: [[f32; 2]; 2],
}

impl FlipCount {
    const fn new() -> Self {
        FlipCount {
            sign: [[0; 2]; 2],
            flips: [[0.0; 2]; 2],
        }
    }

    /// One period: decay, count a flip across each band; whether a count passes its limit.
    fn update(&mut self, error_n: Vec2<f32>, cfg: &ForceLoopConfig, dt_s: f32) -> bool {
        let bands = [cfg.guard_band_n, SLOW_OSCILLATION_BAND_N];
        let leaks = [dt_s, dt_s * (1.0 / SLOW_OSCILLATION_TAU_S)];
        let limits = [cfg.guard_flips, SLOW_OSCILLATION_FLIPS];
        let mut over = false;
        for b in 0..2 {
            for a in 0..2 {
                self.flips[b][a] *= 1.0 - leaks[b];
                let last = self.sign[b][a];
                let s = sign_beyond(error_n[a], bands[b], last);
                if s != last && last != 0 {
                    self.flips[b][a] += 1.0;
                }
                self.sign[b][a] = s;
                over |= self.flips[b][a] > limits[b];
            }
        }
        over
    }
}

/// The guard's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Guard {
    large_error_s: f32,
    flips: FlipCount,
    /// The command, low-passed like the converters follow it, N.
    command_n: Vec2<f32>,
    implausible_s: f32,
}

impl Guard {
    pub(crate) const fn new() -> Self {
        Guard {
            large_error_s: 0.0,
            flips: FlipCount::new(),
            command_n: [0.0; 2],
            implausible_s: 0.0,
        }
    }

    /// The load cell against the force the loop commands: a command (low-passed, its larger
    /// axis) beyond [`CELL_PLAUSIBILITY_FLOOR_N`] + [`CELL_PLAUSIBILITY_RATIO`] × the
    /// measured force (its larger axis) for
    /// [`CELL_PLAUSIBILITY_TIME_S`] is a cell that does not see what the muscles do.
    pub(crate) fn cell_implausible(
        &mut self,
        command_n: Vec2<f32>,
        measured_n: Vec2<f32>,
        dt_s: f32,
    ) -> bool {
        let k = (dt_s * (1.0 / CELL_PLAUSIBILITY_FILTER_S)).min(1.0);
        for a in 0..2 {
            self.command_n[a] += k * (command_n[a] - self.command_n[a]);
        }
        // the larger axis of each (no square root on the control path)
        let command = self.command_n[0].abs().max(self.command_n[1].abs());
        let measured = measured_n[0].abs().max(measured_n[1].abs());
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
        let oscillating = self.flips.update(error_n, cfg, dt_s);
        // NaN included: nothing downstream may act on a non-finite error
        if !(err_sq <= cfg.guard_error_max_n * cfg.guard_error_max_n) {
            Some(GuardTrip::ErrorBound)
        } else if self.large_error_s >= cfg.guard_time_s {
            Some(GuardTrip::PersistentError)
        } else if oscillating {
            Some(GuardTrip::Oscillation)
        } else {
            None
        }
    }
}

/// A change of the muscles' torque at the measured angle, N·m, that moves a free arm
/// (≈ 10° at the thesis's lowest joint-1 stiffness, many hundred counts), far above what
/// the joints' friction holds.
pub const UNSEEN_MOTION_TORQUE_NM: f32 = 10.0;
/// A handle that keeps the arm from moving carries the change: the load cell's torque moves
/// by ≈ 0.57 of the model's on the rig (Table 5.2), 1.0 on the model. Less than this
/// fraction of it is a handle that does not hold.
pub const UNSEEN_MOTION_HELD_FRACTION: f32 = 0.25;
/// How long the change must stay unseen, s: the converters follow a step in ≈ 0.4 s
/// (Table 5.2), and a free arm moves as soon as its torque does.
pub const UNSEEN_MOTION_TIME_S: f32 = 1.5;

/// The encoders' plausibility where the pressures do not follow the handle (joint,
/// pressures and open-loop force modes), per joint: the torque the muscles' cables transmit
/// at the measured angle for the commanded pressures (the model's, each force floored at zero)
/// and the torque the load cell says holds the arm (Jᵀ F), both as
/// they were when the angle last changed. A torque that has since changed by more than
/// [`UNSEEN_MOTION_TORQUE_NM`] with the held torque following by less than
/// [`UNSEEN_MOTION_HELD_FRACTION`] of it, for [`UNSEEN_MOTION_TIME_S`], the angle
/// bit-identical all along, is an arm the encoder does not see moving. A held or blocked
/// handle carries the change and is not judged; neither is a joint at a range end, where
/// a hard stop holds what no sensor reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct EncoderMotion {
    started: bool,
    alpha_rad: Vec2<f32>,
    torque_nm: Vec2<f32>,
    held_nm: Vec2<f32>,
    unseen_s: Vec2<f32>,
}

impl EncoderMotion {
    pub(crate) const fn new() -> Self {
        EncoderMotion {
            started: false,
            alpha_rad: [0.0; 2],
            torque_nm: [0.0; 2],
            held_nm: [0.0; 2],
            unseen_s: [0.0; 2],
        }
    }

    pub(crate) fn reset(&mut self) {
        self.started = false;
    }

    /// One armed period with finite sensors: the angle, (τ_model, Jᵀ F), whether each joint
    /// is inside its judged range. True once a joint's motion has gone unseen.
    pub(crate) fn update(
        &mut self,
        alpha_rad: Vec2<f32>,
        (torque_nm, held_nm): (Vec2<f32>, Vec2<f32>),
        in_range: [bool; 2],
        dt_s: f32,
    ) -> bool {
        let mut unseen = false;
        for j in 0..2 {
            if !self.started || alpha_rad[j] != self.alpha_rad[j] || !in_range[j] {
                self.alpha_rad[j] = alpha_rad[j];
                self.torque_nm[j] = torque_nm[j];
                self.held_nm[j] = held_nm[j];
                self.unseen_s[j] = 0.0;
                continue;
            }
            let moved = (torque_nm[j] - self.torque_nm[j]).abs();
            let held = (held_nm[j] - self.held_nm[j]).abs();
            // NaN compares false: an undefined torque never counts
            if moved > UNSEEN_MOTION_TORQUE_NM && held < UNSEEN_MOTION_HELD_FRACTION * moved {
                self.unseen_s[j] += dt_s;
            } else {
                self.unseen_s[j] = 0.0;
            }
            unseen |= self.unseen_s[j] >= UNSEEN_MOTION_TIME_S;
        }
        self.started = true;
        unseen
    }
}
