//! Motion limits that hold in every mode: the tensioning ramp that brings the muscles up
//! without moving the arm, the joint speed the arm may reach, the soft
//! joint limits a joint target is kept within, the shaping of a joint target in
//! firmware, and the co-contraction and imbalance a pressures command may ask for.
//!
//! The arm carries a patient's arm on a table: what hurts is a fast or unexpected
//! motion, so a step of the joint target is never handed to the muscles as a step. A
//! joint target moves from where the arm is at a bounded speed and acceleration (a
//! trapezoidal profile), so the lightly damped arm (≈ 2 Hz, the muscles' own stiffness
//! against the segments' inertia) follows without swinging past it.
//!
//! Soft limits clamp the joint target [`SOFT_LIMIT_RAD`] inside each hard stop (the
//! joint's range): the equilibrium the muscles are asked for never sits on a stop. The
//! measured angle beyond the range by more than the configured margin stays a fault
//! (`ANGLE_OUT_OF_RANGE`: an encoder that lies).
//!
//! The joint speed is supervised in every mode while armed: a low-passed speed above
//! [`MOTION_SPEED_MAX_RAD_S`] latches `CONTROL_UNSTABLE` and the supervisor vents.

use pam_model::{Real, RobotModel, Vec2};

/// How long the muscles take from the vent to a mode's command before the mode takes over,
/// s ([`ArmRamp`]). The converters fill the more contracted muscle (the larger volume) a
/// little later than its partner, and the joint's equilibrium moves with that lag while
/// the pressures rise: over 1 s the handle moves at most a few millimetres on the twins
/// (host-libs/twin/tests/arming.rs), over 0.3 s up to 17 mm.
pub const ARM_RAMP_S: f32 = 1.0;

/// A joint target is kept this far inside each end of the joint's range, rad (≈ 3°).
pub const SOFT_LIMIT_RAD: f32 = 0.05;
/// Fastest speed of a shaped joint target, rad/s (≈ 8.6°/s: a 10° move in about 1.7 s,
/// twice the period of the arm's slowest swing, so the move leaves almost no swing behind).
pub const JOINT_TARGET_RATE_MAX_RAD_S: f32 = 0.15;
/// Largest acceleration of a shaped joint target, rad/s².
pub const JOINT_TARGET_ACCEL_MAX_RAD_S2: f32 = 0.3;
/// Fastest change of a joint mode's torque request, N·m/s.
pub const JOINT_TORQUE_RATE_MAX_NM_PER_S: f32 = 20.0;
/// Fastest joint speed the arm may reach in any mode, rad/s (low-passed over
/// [`SPEED_FILTER_S`]); beyond it the supervisor vents.
pub const MOTION_SPEED_MAX_RAD_S: f32 = 4.0;
/// Time constant of the speed supervision's low-pass, s: longer than the encoder's count
/// quantisation (one count per period is 0.4–0.8 rad/s at 1 kHz), shorter than a swing.
pub const SPEED_FILTER_S: f32 = 0.02;
/// Largest pressure difference between the two muscles of a joint a pressures command may
/// ask for, bar.
pub const PRESSURES_IMBALANCE_MAX_BAR: f32 = 2.0;
/// Largest mean pressure of the two muscles of a joint (co-contraction) a pressures
/// command may ask for, bar.
pub const PRESSURES_COCONTRACTION_MAX_BAR: f32 = 3.5;

/// Whether a pressures command keeps every joint's pair within the imbalance and
/// co-contraction ceilings; `pairs` gives each joint's two channels.
pub fn pressures_within_limits(pressure_bar: &[f32; 4], pairs: [[u8; 2]; 2]) -> bool {
    pairs.iter().all(|pair| {
        let a = pressure_bar[(pair[0] & 3) as usize];
        let b = pressure_bar[(pair[1] & 3) as usize];
        (a - b).abs() <= PRESSURES_IMBALANCE_MAX_BAR
            && 0.5 * (a + b) <= PRESSURES_COCONTRACTION_MAX_BAR
    })
}

/// The tensioning ramp that precedes every mode (from arming, or from idle). Per joint,
/// at the measured angle: both muscles rise from the vent to the pressure where their
/// cable turns taut at the same instant (the first half of [`ARM_RAMP_S`]: a slack cable
/// pulls nothing), then each muscle's pressure moves in proportion from there to the
/// mode's own target (the second half). The model's force is linear in pressure at a
/// given angle and zero at the taut pressure, so every cable force, and the joint's
/// torque, is the same fraction of the mode's: a mode that holds the arm where it is asks
/// for no torque at any instant of the ramp, and the ramp ends on the mode's command
/// itself, with no jump for the slew limit to spread unevenly over the muscles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmRamp {
    elapsed_s: f32,
}

impl Default for ArmRamp {
    fn default() -> Self {
        Self::new()
    }
}

impl ArmRamp {
    pub const fn new() -> Self {
        ArmRamp { elapsed_s: 0.0 }
    }

    /// Start again (armed, or idle: vented).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Whether the ramp is over.
    pub fn done(&self) -> bool {
        self.elapsed_s >= ARM_RAMP_S
    }

    /// One period of the ramp toward the mode's channel pressures `target_bar`: the
    /// channel pressures, bar.
    pub fn step(
        &mut self,
        model: &RobotModel<f32>,
        measured_rad: Vec2<f32>,
        target_bar: [f32; 4],
        dt: f32,
    ) -> [f32; 4] {
        let p = &model.params;
        self.elapsed_s += dt;
        let s = (self.elapsed_s * (2.0 / ARM_RAMP_S)).min(2.0);
        let (lo, hi) = (p.ip.output_min_bar, p.pressure.max_bar);
        let target = model.joint_pressures_bar(target_bar);
        let joint = |j: usize| {
            let jp = &p.joints[j];
            let a = measured_rad[j].clamp_to(jp.alpha_min_rad, jp.alpha_max_rad);
            let pose = model.pose(j, a);
            let taut = |m: usize| pose.muscles[m].pressure_for_force_bar(0.0).clamp_to(lo, hi);
            if s < 1.0 {
                let w = smoothstep(s);
                [0, 1].map(|m| lo + w * (taut(m) - lo))
            } else {
                let w = smoothstep(s - 1.0);
                [0, 1].map(|m| taut(m) + w * (target[j][m] - taut(m)))
            }
        };
        model.channel_pressures_bar([joint(0), joint(1)])
    }
}

/// 3u² − 2u³: from 0 to 1 with no rate at either end, so the converters' lag, which
/// differs between two muscles of unequal volume, neither sets in nor ends as a step.
fn smoothstep(u: f32) -> f32 {
    u * u * (3.0 - 2.0 * u)
}

/// The joint mode's shaped reference: angle and rate per joint, and the torque request.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointShaper {
    started: bool,
    alpha_rad: Vec2<f32>,
    rate_rad_s: Vec2<f32>,
    torque_nm: Vec2<f32>,
}

impl Default for JointShaper {
    fn default() -> Self {
        Self::new()
    }
}

impl JointShaper {
    pub const fn new() -> Self {
        JointShaper {
            started: false,
            alpha_rad: [0.0; 2],
            rate_rad_s: [0.0; 2],
            torque_nm: [0.0; 2],
        }
    }

    /// Forget the reference: the next step starts at rest at the measured angle.
    pub fn reset(&mut self) {
        self.started = false;
    }

    /// The reference one period closer to `target_rad` / `torque_nm`; `range_rad` are the
    /// soft limits per joint (the target is clamped into them). Returns the reference
    /// angle, torque, and whether the soft limits clamped the target.
    pub fn step(
        &mut self,
        target_rad: Vec2<f32>,
        torque_nm: Vec2<f32>,
        measured_rad: Vec2<f32>,
        range_rad: [(f32, f32); 2],
        dt: f32,
    ) -> (Vec2<f32>, Vec2<f32>, bool) {
        let mut clamped = false;
        for j in 0..2 {
            let (lo, hi) = range_rad[j];
            if !self.started {
                self.alpha_rad[j] = measured_rad[j].clamp_to(lo, hi);
                self.rate_rad_s[j] = 0.0;
                self.torque_nm[j] = 0.0;
            }
            let target = target_rad[j].clamp_to(lo, hi);
            clamped |= target != target_rad[j];
            self.alpha_rad[j] = self.alpha_rad[j].clamp_to(lo, hi);
            self.advance(j, target, dt);
            let step = JOINT_TORQUE_RATE_MAX_NM_PER_S * dt;
            let t = self.torque_nm[j];
            self.torque_nm[j] = torque_nm[j].clamp_to(t - step, t + step);
        }
        self.started = true;
        (self.alpha_rad, self.torque_nm, clamped)
    }

    /// Trapezoidal profile: the rate that still stops at the target under the
    /// acceleration limit, itself reached at that limit.
    fn advance(&mut self, j: usize, target: f32, dt: f32) {
        let e = target - self.alpha_rad[j];
        let brake = <f32 as Real>::sqrt(2.0 * JOINT_TARGET_ACCEL_MAX_RAD_S2 * e.abs());
        let speed = brake.min(JOINT_TARGET_RATE_MAX_RAD_S);
        let wanted = if e < 0.0 { -speed } else { speed };
        let dv = JOINT_TARGET_ACCEL_MAX_RAD_S2 * dt;
        let v = self.rate_rad_s[j];
        let v = wanted.clamp_to(v - dv, v + dv);
        let next = self.alpha_rad[j] + v * dt;
        // the last step lands on the target instead of passing it
        if (target - next) * e <= 0.0 {
            self.alpha_rad[j] = target;
            self.rate_rad_s[j] = 0.0;
        } else {
            self.alpha_rad[j] = next;
            self.rate_rad_s[j] = v;
        }
    }
}

/// The low-passed joint speed, for the supervision in every mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpeedMonitor {
    last_rad: Option<Vec2<f32>>,
    speed_rad_s: Vec2<f32>,
}

impl Default for SpeedMonitor {
    fn default() -> Self {
        Self::new()
    }
}

impl SpeedMonitor {
    pub const fn new() -> Self {
        SpeedMonitor {
            last_rad: None,
            speed_rad_s: [0.0; 2],
        }
    }

    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// The low-passed speed, rad/s.
    pub fn speed_rad_s(&self) -> Vec2<f32> {
        self.speed_rad_s
    }

    /// One sample (finite angles); returns whether a joint moves faster than
    /// [`MOTION_SPEED_MAX_RAD_S`].
    pub fn update(&mut self, alpha_rad: Vec2<f32>, dt: f32) -> bool {
        let k = (dt * (1.0 / SPEED_FILTER_S)).min(1.0);
        let inv_dt = 1.0 / dt;
        let mut fast = false;
        if let Some(last) = self.last_rad {
            for j in 0..2 {
                let v = (alpha_rad[j] - last[j]) * inv_dt;
                self.speed_rad_s[j] += k * (v - self.speed_rad_s[j]);
                fast |= !(self.speed_rad_s[j].abs() <= MOTION_SPEED_MAX_RAD_S);
            }
        }
        self.last_rad = Some(alpha_rad);
        fast
    }
}
