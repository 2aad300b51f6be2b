//! Closed-loop handle force: a two-degree-of-freedom controller around the
//! open-loop force path (gain plane, τ = Jᵀ F, inverse model).
//!
//! - **Reference**: the target is rate-limited (`force_rate_n_per_s`), then follows a
//!   critically damped reference model of bandwidth `reference_bandwidth_rad_s`.
//! - **Feed-forward**: the reference model's output passed through the inverse of the
//!   converters' identified second order (Table 5.2, `params.ip`): the command that makes
//!   the plant follow the model, computed from the model's own states (no differentiation
//!   of a measured signal).
//! - **Feedback**: PI on the error between the model and the load-cell force (user frame),
//!   added before the gain-plane correction, so with `feed_forward` the identified gain
//!   plane G(α) schedules the loop gain over the pose (the command is divided by G). The
//!   integral is frozen while the previous command was clamped by a capability limit
//!   (torque quadrilateral, pressure range, converter range; not the slew limit, which
//!   catches up by itself) in the direction that would grow it, and is bounded by
//!   `integral_limit_n`.
//! - **What holds the handle** ([`ForceLoop::observe_handle`], force mode): the feedback gains
//!   fall with the handle's measured compliance (a block does not move, a hand does, and the
//!   arm's mass on it resonates on the loop's crossover); the reference slows by the same
//!   factor (a hand's force K·x + B·ẋ overshoots when the handle is moved faster than its
//!   B/K), and the feed-forward gives up the gain plane's correction
//!   ([`ForceLoop::through_plane`]): the plane is a bet on the plant's static gain that only
//!   a fast feedback can take back, and against a hand the feedback is slow, so the bet
//!   would go into the patient's hand. The direct loop (impedance mode) keeps the design's
//!   gains until the handle rings at a relaxed hand's 3.3–7 Hz, then takes the square of
//!   this factor ([`ForceLoop::held_scale`]): an operator moving the handle is no compliance.
//! - **The plant's gain** ([`crate::plant_gain`], force mode, at a block): measured at steady
//!   levels and within a step, the command divided by it as the gain plane divides; and the
//!   integral waits while the force closes the error by itself in a step not (yet) known to
//!   follow the nominal plant g·H (slow, flow-limited converters: the commands are arriving).
//! - **Guard**: an error beyond `guard_error_max_n`, or beyond `guard_error_n` for
//!   `guard_time_s`, or sustained oscillation
//!   of the error (sign flips beyond ±`guard_band_n`, a leaky count over about one second
//!   above `guard_flips`; and, for the arm's slow swings down to 0.5 Hz, flips beyond
//!   ±[`SLOW_OSCILLATION_BAND_N`] counted over [`SLOW_OSCILLATION_TAU_S`] above
//!   [`SLOW_OSCILLATION_FLIPS`]: [`crate::guard`]), latches `Faults::CONTROL_UNSTABLE` and the supervisor
//!   vents.
//!
//! The design, its margins and the measured tables are in docs/closed-loop.md. f32, no heap.

pub use crate::force_loop_config::ForceLoopConfig;
use crate::guard::Guard;
pub use crate::guard::{
    GuardTrip, SLOW_OSCILLATION_BAND_N, SLOW_OSCILLATION_FLIPS, SLOW_OSCILLATION_TAU_S,
};
use crate::plant_gain::PlantGain;
use pam_model::kinematics::PoseTrig;
use pam_model::params::{GainPlane, IpConverter};
use pam_model::{Real, RobotModel, Vec2};

/// Least force change over which [`ForceLoop::observe_handle`] divides the handle's travel, N
/// (the load cell's noise is 0.15 N).
pub const COMPLIANCE_FORCE_MIN_N: f32 = 2.0;

/// The compliance the feedback gains and the reference are set for until
/// [`ForceLoop::observe_handle`] has seen a block, m/N: the twin's firm grip's (5000 N/m, the
/// stiffest hand the loop is designed for; a softer hand gets its own, gentler gains once it
/// has moved past the dead band). The arming ramp moves nothing, so the loop starts without
/// knowing what holds the handle, and a hand's gains are the safe guess (a block only gets a
/// slower first step; docs/closed-loop.md, "Arming"). A relaxed hand's (1 mm/N) slows the
/// first step at a block to 0.27–0.32 s for no less overshoot into a hand.
pub const UNDECIDED_COMPLIANCE_M_PER_N: f32 = 2e-4;

/// Force change since the loop started, with the handle still within the dead band, that
/// tells a block from a hand, N: a firm grip (5000 N/m) gives way 0.6 mm under it, two
/// encoder counts at the handle, where a block does not move. At 2 N the twin's firm grip,
/// whose damping holds it back early in a step, is taken for a block at some poses and gets
/// up to 1.09 N beyond a 9.1 N step.
pub const BLOCK_FORCE_N: f32 = 3.0;

/// Largest multiplier of the designed feedback gains a mode may request: the design's gain
/// margin (2–3, docs/closed-loop.md), so no accepted scale is far past the edge of
/// stability; the guard catches a loop driven to it.
pub const MAX_GAIN_SCALE: f32 = 3.0;

/// The loop's state: reference, reference model, integral, guard.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLoop {
    fresh: bool,
    reference_n: Vec2<f32>,
    model_n: Vec2<f32>,
    model_rate_n_s: Vec2<f32>,
    integral_n: Vec2<f32>,
    error_n: Vec2<f32>,
    last_measured_n: Vec2<f32>,
    measured_rate_n_s: Vec2<f32>,
    guard: Guard,
    handle_seen: bool,
    block_seen: bool,
    handle0_m: Vec2<f32>,
    force0_n: Vec2<f32>,
    compliance_m_per_n: f32,
    plant_gain: PlantGain,
}

impl Default for ForceLoop {
    fn default() -> Self {
        Self::new()
    }
}

/// A command `command_n` whose feed-forward share is `ff`, through the gain plane as
/// [`ForceLoop::through_plane`] sends it: `keep` of the feed-forward (1 −
/// [`ForceLoop::plane_weight`]) passes it by, the rest is divided by G(α). Linear in both.
fn plane_map(
    keep: f32,
    command_n: Vec2<f32>,
    ff: Vec2<f32>,
    plane: &GainPlane<f32>,
    alpha_rad: Vec2<f32>,
) -> (Vec2<f32>, bool) {
    let rest = [command_n[0] - keep * ff[0], command_n[1] - keep * ff[1]];
    let (c, limited) = plane.correct(rest, alpha_rad);
    ([c[0] + keep * ff[0], c[1] + keep * ff[1]], limited)
}

/// One step's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceLoopOutput {
    /// The force command before the gain plane, user frame, N.
    pub command_n: Vec2<f32>,
    /// The feed-forward's share of `command_n`, N.
    pub feed_forward_n: Vec2<f32>,
    /// The reference model's force (what the load cell should read now), N.
    pub model_n: Vec2<f32>,
    pub trip: Option<GuardTrip>,
}

impl ForceLoop {
    pub const fn new() -> Self {
        ForceLoop {
            fresh: true,
            reference_n: [0.0; 2],
            model_n: [0.0; 2],
            model_rate_n_s: [0.0; 2],
            integral_n: [0.0; 2],
            error_n: [0.0; 2],
            last_measured_n: [0.0; 2],
            measured_rate_n_s: [0.0; 2],
            guard: Guard::new(),
            handle_seen: false,
            block_seen: false,
            handle0_m: [0.0; 2],
            force0_n: [0.0; 2],
            compliance_m_per_n: 0.0,
            plant_gain: PlantGain::new(),
        }
    }

    /// Forget everything: the next step starts from the measured force (bumpless entry).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    pub fn integral_n(&self) -> Vec2<f32> {
        self.integral_n
    }

    /// The plant's static gain the loop measured at steady levels and divides its command by
    /// (1 until measured; `crate::plant_gain`).
    pub fn plant_gain(&self) -> f32 {
        self.plant_gain.gain()
    }

    /// The plant-gain estimator's state (diagnostics).
    pub fn plant_gain_state(&self) -> &PlantGain {
        &self.plant_gain
    }

    /// Forget the measured plant gain (the plant changed: the gain plane was switched).
    pub fn forget_plant_gain(&mut self) {
        self.plant_gain = PlantGain::new();
    }

    /// The compliance of what holds the handle, as [`ForceLoop::observe_handle`] last saw it,
    /// m/N (0 until it is called: a blocked handle).
    pub fn compliance_m_per_n(&self) -> f32 {
        self.compliance_m_per_n
    }

    /// What holds the handle, once per period before [`ForceLoop::step`] (force mode; any
    /// frame origin, `handle_m` is only differenced). The handle's travel beyond
    /// `handle_deadband_m` per newton of force change since the loop started, held at its
    /// peak and forgotten over about a second. A blocked handle (§5.2) does not move and the
    /// gains are the design's; a hand gives way, and the arm's mass on it makes a resonance
    /// at 20–60 rad/s, on the loop's crossover, where the converters' lag leaves no phase to
    /// damp it with: there the feedback gains fall toward `compliant_gain_scale`
    /// (docs/closed-loop.md, "A held handle"). The gains and the reference start as against a
    /// hand ([`ForceLoop::gains_compliance_m_per_n`]) and take the block's once the
    /// force has changed by [`BLOCK_FORCE_N`] with the handle within the dead band: the
    /// mistake this risks is a slower step at a block, not a block's gains against a hand.
    pub fn observe_handle(
        &mut self,
        cfg: &ForceLoopConfig,
        handle_m: Vec2<f32>,
        measured_n: Vec2<f32>,
        dt_s: f32,
    ) {
        if !self.handle_seen {
            self.handle0_m = handle_m;
            self.force0_n = measured_n;
            self.handle_seen = true;
        }
        let dx = [
            handle_m[0] - self.handle0_m[0],
            handle_m[1] - self.handle0_m[1],
        ];
        let df = [
            measured_n[0] - self.force0_n[0],
            measured_n[1] - self.force0_n[1],
        ];
        let travel_m = ((dx[0] * dx[0] + dx[1] * dx[1]).sqrt() - cfg.handle_deadband_m).max(0.0);
        let force_n = (df[0] * df[0] + df[1] * df[1])
            .sqrt()
            .max(COMPLIANCE_FORCE_MIN_N);
        let c = travel_m / force_n;
        let decayed = self.compliance_m_per_n * (1.0 - dt_s).max(0.0);
        // NaN: keeps the decayed value (the guard trips on a non-finite force anyway)
        self.compliance_m_per_n = if c > decayed { c } else { decayed };
        let still = travel_m <= 0.0;
        if still && df[0] * df[0] + df[1] * df[1] >= BLOCK_FORCE_N * BLOCK_FORCE_N {
            self.block_seen = true;
        }
    }

    /// The compliance the feedback gains and the reference are set for, m/N: the one seen,
    /// and at least [`UNDECIDED_COMPLIANCE_M_PER_N`] from the first
    /// [`ForceLoop::observe_handle`] until a block is seen.
    pub fn gains_compliance_m_per_n(&self) -> f32 {
        match self.handle_seen && !self.block_seen {
            true => self.compliance_m_per_n.max(UNDECIDED_COMPLIANCE_M_PER_N),
            false => self.compliance_m_per_n,
        }
    }

    /// The feedback gains' factor for the compliance seen.
    fn compliance_scale(&self, cfg: &ForceLoopConfig) -> f32 {
        let s = cfg.compliant_gain_scale;
        s + (1.0 - s) / (1.0 + self.gains_compliance_m_per_n() / cfg.compliance_ref_m_per_n)
    }

    /// The feedback gains' factor for a loop that rang against what holds the handle: the
    /// square of the factor the force mode sets its gains by for the compliance seen
    /// ([`ForceLoop::observe_handle`]; 0.09–0.2 against a hand, 1 at a block).
    /// The impedance mode takes it, on its feedback and on the arm's inertia it feeds forward,
    /// once the handle has rung (`crate::impedance::Ringing`): a relaxed hand puts the arm's
    /// mass on it at 4–5 Hz, on the converters' own resonance, where the lagging feedback
    /// and feed-forward take more damping than the hand has (docs/impedance.md).
    pub fn held_scale(&self, cfg: &ForceLoopConfig) -> f32 {
        let c = self.compliance_scale(cfg);
        c * c
    }

    /// How much of the gain plane's correction the feed-forward gets, 0–1: all of it at a
    /// block, (1 + c / `compliance_ref_m_per_n`)⁻² against a compliance c (0.04 at the twin's
    /// firm grip, 0.002 at a relaxed hand). The plane (eq. 5.2) was identified at a blocked
    /// handle and multiplies the feed-forward by up to 1/0.57; where the plant lacks that
    /// deficit (the default twin) the feed-forward over-delivers by 75 %, which the design's
    /// feedback takes back within the step (§5.2 tables) but the gentle feedback against a
    /// hand does not: without the plane the feed-forward can only fall short of the force.
    pub fn plane_weight(&self, cfg: &ForceLoopConfig) -> f32 {
        let w = 1.0 / (1.0 + self.compliance_m_per_n / cfg.compliance_ref_m_per_n);
        w * w
    }

    /// The loop's command through the gain plane `plane` at the pose `alpha_rad` (the
    /// feed-forward with [`ForceLoop::plane_weight`] of the plane's correction, the feedback
    /// with all of it), N, and whether the plane's gain was limited.
    pub fn through_plane(
        &self,
        cfg: &ForceLoopConfig,
        out: &ForceLoopOutput,
        plane: &GainPlane<f32>,
        alpha_rad: Vec2<f32>,
    ) -> (Vec2<f32>, bool) {
        let keep = 1.0 - self.plane_weight(cfg);
        plane_map(keep, out.command_n, out.feed_forward_n, plane, alpha_rad)
    }

    /// How much of `target_n` the muscles can give at the pose, 0–1
    /// ([`RobotModel::reachable_force_scale`] on the steady command the target needs: the
    /// loop's steady command, (target + integral) / measured plant gain, and with
    /// `feed_forward` through the gain plane as [`ForceLoop::through_plane`] sends it; the
    /// integral carries what the model misses at the present level, so this is the local
    /// extrapolation from where the plant is). The caller scales the target by it.
    pub fn reachable_scale(
        &self,
        cfg: &ForceLoopConfig,
        model: &RobotModel<f32>,
        alpha_rad: Vec2<f32>,
        trig: &PoseTrig<f32>,
        target_n: Vec2<f32>,
        feed_forward: bool,
    ) -> f32 {
        let g = self.plant_gain.gain();
        let i = self.integral_n;
        let (mut t, mut o) = ([target_n[0] / g, target_n[1] / g], [i[0] / g, i[1] / g]);
        if feed_forward {
            // the target is the steady feed-forward, the integral is feedback
            let plane = &model.params.gain_plane;
            let keep = 1.0 - self.plane_weight(cfg);
            t = plane_map(keep, t, t, plane, alpha_rad).0;
            o = plane_map(keep, o, [0.0; 2], plane, alpha_rad).0;
        }
        let (f, m) = (cfg.taut_force_fraction, cfg.reach_margin);
        model.reachable_force_scale(alpha_rad, trig, t, o, f, m)
    }

    /// One period. `saturated`: the previous command was clamped by a capability limit on
    /// its way to the converters (torque, pressure or current range; anti-windup).
    /// `gain_scale` multiplies kp, ki and kd (1 = the design).
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        cfg: &ForceLoopConfig,
        ip: &IpConverter<f32>,
        target_n: Vec2<f32>,
        measured_n: Vec2<f32>,
        gain_scale: f32,
        saturated: bool,
        dt_s: f32,
    ) -> ForceLoopOutput {
        let gains = [gain_scale, 1.0];
        self.run(cfg, ip, target_n, measured_n, gains, saturated, dt_s, true)
    }

    /// [`ForceLoop::step`] without the reference model: the target is followed as it comes,
    /// only rate-limited (impedance mode, where the target is itself a function of the
    /// measured motion and any lag would change the rendered impedance). The designed gains
    /// × `gain_scale` (no compliance factor of its own: [`ForceLoop::held_scale`] is the
    /// caller's), the integral's also × `integral_scale`.
    #[allow(clippy::too_many_arguments)]
    pub fn step_direct(
        &mut self,
        cfg: &ForceLoopConfig,
        ip: &IpConverter<f32>,
        target_n: Vec2<f32>,
        measured_n: Vec2<f32>,
        [gain_scale, integral_scale]: [f32; 2],
        saturated: bool,
        dt_s: f32,
    ) -> ForceLoopOutput {
        let gains = [gain_scale, integral_scale];
        self.run(cfg, ip, target_n, measured_n, gains, saturated, dt_s, false)
    }

    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        cfg: &ForceLoopConfig,
        ip: &IpConverter<f32>,
        target_n: Vec2<f32>,
        measured_n: Vec2<f32>,
        [gain_scale, integral_scale]: [f32; 2],
        saturated: bool,
        dt_s: f32,
        shaped: bool,
    ) -> ForceLoopOutput {
        if self.fresh {
            // start where the plant is: no jump in the command at entry
            self.reference_n = measured_n;
            self.model_n = measured_n;
            self.last_measured_n = measured_n;
            self.fresh = false;
        }
        // a hand: gentler gains, and a reference that moves the handle slowly enough that
        // the hand's damping force (B·ẋ) does not add to the force asked for
        let c = self.compliance_scale(cfg);
        let wm = cfg.reference_bandwidth_rad_s * c;
        let wn = ip.natural_freq_rad_s;
        let zeta = ip.damping_ratio;
        // direct: the target follows the handle, its rate is not a step's to slow
        let (max_df, g) = if shaped {
            (cfg.force_rate_n_per_s * c * dt_s, gain_scale * c)
        } else {
            (cfg.force_rate_n_per_s * dt_s, gain_scale)
        };
        let (kp, ki, kd) = (cfg.kp * g, cfg.ki_per_s * g * integral_scale, cfg.kd_s * g);
        let wf_dt = cfg.derivative_filter_rad_s * dt_s;
        let alpha = wf_dt / (1.0 + wf_dt);
        let mut command_n = [0.0; 2];
        let mut feed_forward_n = [0.0; 2];
        let mut err_sq = 0.0;
        // the integral waits while the force closes the error by itself faster than half the
        // rate the integral alone would close it, ki/(1 + kp) (plant g = 1): the commands sent
        // are still arriving (slow, flow-limited converters); not once this step's force is
        // known to follow the nominal plant g·H, where the closing is the loop's own doing;
        // at a block (a hand yields by itself, and its gentle loop needs the integral) and in
        // force mode (the impedance mode's target moves with the handle)
        if (0..2).any(|a| (target_n[a] - self.reference_n[a]).abs() >= 1e-3) {
            self.plant_gain.begin_step();
        }
        let closing_per_s =
            if !shaped || self.compliance_m_per_n != 0.0 || !self.plant_gain.undecided_step() {
                f32::INFINITY
            } else {
                0.5 * ki / (1.0 + kp)
            };
        for a in 0..2 {
            let r =
                self.reference_n[a] + (target_n[a] - self.reference_n[a]).clamp_to(-max_df, max_df);
            self.reference_n[a] = r;
            let acc = if shaped {
                // critically damped model, semi-implicit Euler
                let acc = wm * wm * (r - self.model_n[a]) - 2.0 * wm * self.model_rate_n_s[a];
                self.model_rate_n_s[a] += acc * dt_s;
                // no faster toward r than wm·|r − m|: a critically damped model started
                // within that bound does not overshoot r, also after wm fell mid-step
                let bound = wm * (r - self.model_n[a]);
                let v = self.model_rate_n_s[a];
                if v * bound > 0.0 && v.abs() > bound.abs() {
                    self.model_rate_n_s[a] = bound;
                }
                self.model_n[a] += self.model_rate_n_s[a] * dt_s;
                acc
            } else {
                // direct: the rate-limited target itself
                self.model_rate_n_s[a] = 0.0;
                self.model_n[a] = r;
                0.0
            };
            // H⁻¹ of the converters' second order applied to the model: x + 2ζ/ωn ẋ + ẍ/ωn²
            let ff = self.model_n[a] + 2.0 * zeta / wn * self.model_rate_n_s[a] + acc / (wn * wn);
            let e = self.model_n[a] - measured_n[a];
            let raw_rate = (measured_n[a] - self.last_measured_n[a]) / dt_s;
            self.last_measured_n[a] = measured_n[a];
            self.measured_rate_n_s[a] += alpha * (raw_rate - self.measured_rate_n_s[a]);
            let e_rate = self.model_rate_n_s[a] - self.measured_rate_n_s[a];
            self.error_n[a] = e;
            err_sq += e * e;
            // anti-windup: while clamped, or while the error closes by itself, the integral
            // may only shrink
            let grows = e * self.integral_n[a] > 0.0 || self.integral_n[a] == 0.0;
            let closing = self.measured_rate_n_s[a] * e.signum() > closing_per_s * e.abs();
            if !((saturated || closing) && grows) {
                self.integral_n[a] = (self.integral_n[a] + ki * e * dt_s)
                    .clamp_to(-cfg.integral_limit_n, cfg.integral_limit_n);
            }
            feed_forward_n[a] = ff;
            command_n[a] = ff + kp * e + kd * e_rate;
        }
        // the plant's static gain, measured at steady levels at a block (a hand's force is
        // not the muscles' alone); the integral keeps the command where it was
        let settled = shaped
            && !saturated
            && self.compliance_m_per_n == 0.0
            && (target_n[0] - self.reference_n[0]).abs() < 1e-3
            && (target_n[1] - self.reference_n[1]).abs() < 1e-3;
        let (m, i) = (self.model_n, self.integral_n);
        let blocked = shaped && !saturated && self.compliance_m_per_n == 0.0;
        // (force mode only: the impedance mode never measures it, its gain stays 1)
        let new_integral = match shaped {
            false => None,
            true => match self.plant_gain.track(measured_n, [m, i], blocked, dt_s) {
                None => self
                    .plant_gain
                    .observe(m, self.reference_n, i, self.error_n, settled, dt_s)
                    .map(|k| PlantGain::bumpless_integral(m, i, k)),
                v => v,
            },
        };
        if let Some(v) = new_integral {
            for a in 0..2 {
                self.integral_n[a] = v[a].clamp_to(-cfg.integral_limit_n, cfg.integral_limit_n);
            }
        }
        // divided by the measured gain, as the gain plane divides: the design's loop gain
        let g = self.plant_gain.gain();
        for a in 0..2 {
            feed_forward_n[a] /= g;
            command_n[a] = (command_n[a] + self.integral_n[a]) / g;
        }
        if shaped {
            self.plant_gain.drive(command_n, wn, zeta, dt_s);
        }
        let mut trip = self.guard.update(cfg, self.error_n, err_sq, dt_s);
        // the reference model's loop (force mode) is the one a dead cell winds up; in
        // impedance mode the force follows the handle's motion, checked by its own guards
        if shaped && trip.is_none() && self.guard.cell_implausible(command_n, measured_n, dt_s) {
            trip = Some(GuardTrip::ImplausibleLoadCell);
        }
        ForceLoopOutput {
            command_n,
            feed_forward_n,
            model_n: self.model_n,
            trip,
        }
    }
}
