//! The step's first stage: the sensors and the timing judged, new faults latched.

use pam_model::kinematics::{Kinematics, PoseTrig};
use pam_model::{RobotModel, Vec2};

use crate::faults::Faults;
use crate::guard::EncoderMotion;
use crate::home_check::HomeVerdict;
use crate::mode::{Mode, Sensors, State};
use crate::plausibility::{torques_at_nm, STOP_BAND_RAD};
use crate::safety::LOADCELL_AMPLIFIER_FULL_SCALE_V;
use crate::supervisor::Controller;

/// What the later stages need of the measured pose, computed once per step.
pub(crate) struct Pose {
    pub alpha_rad: Vec2<f32>,
    /// sin/cos of the pose, shared by the load-cell rotation and τ = Jᵀ F.
    pub trig: PoseTrig<f32>,
    /// Force at the handle in the user frame, N (zero when a sensor is not finite).
    pub force_user_n: Vec2<f32>,
}

impl Controller {
    /// The faults a sample shows by itself (and, with `track_history`, against the last
    /// one): non-finite values, an angle beyond the range, an encoder jump, a saturated
    /// load cell.
    pub(crate) fn sensor_faults(&self, s: &Sensors, track_history: bool) -> Faults {
        let mut f = Faults::NONE;
        let finite = s
            .alpha_rad
            .iter()
            .chain(s.force_sensor_n.iter())
            .all(|x| x.is_finite());
        if !finite {
            return f.with(Faults::NON_FINITE);
        }
        for j in 0..2 {
            let jp = &self.model.params.joints[j];
            let m = self.safety.angle_margin_rad;
            if s.alpha_rad[j] < jp.alpha_min_rad - m || s.alpha_rad[j] > jp.alpha_max_rad + m {
                f = f.with(Faults::ANGLE_OUT_OF_RANGE);
            }
        }
        if track_history {
            if let Some(last) = self.last_alpha_rad {
                let max_step = self.safety.max_joint_speed_rad_s * self.safety.period_s;
                if (0..2).any(|j| (s.alpha_rad[j] - last[j]).abs() > max_step) {
                    f = f.with(Faults::ENCODER_JUMP);
                }
            }
        }
        let cell = &self.model.params.load_cell;
        // volts at the amplifier output: F / gain + offset (the inverse of eq. 2.1); a
        // zero or non-finite gain gives NaN/∞ and is left to the force limit below
        let at_full_scale = (0..2).any(|ch| {
            let volts = s.force_sensor_n[ch] / cell.gain_n_per_v[ch] + cell.offset_v[ch];
            volts.abs() >= LOADCELL_AMPLIFIER_FULL_SCALE_V
        });
        if at_full_scale
            || s.force_sensor_n
                .iter()
                .any(|x| x.abs() > self.safety.loadcell_limit_n)
        {
            f = f.with(Faults::LOADCELL_SATURATED);
        }
        f
    }

    /// Judges one period's sensors and timing: the sample's own faults, a frozen load
    /// cell, the static balance, motion the encoders do not see, the last home against the
    /// pressures' equilibrium, the joint speed (every mode), the command timeout. New
    /// faults latch and fault the controller. Returns the measured pose, computed once for
    /// every stage.
    #[inline(always)]
    pub(crate) fn supervise(&mut self, sensors: &Sensors) -> Pose {
        let mut faults = self.sensor_faults(sensors, true);
        // stuck load cell: bit-identical samples while armed (a live ADC always dithers)
        if sensors.force_sensor_n == self.last_force_raw {
            self.same_force_count = self.same_force_count.saturating_add(1);
        } else {
            self.same_force_count = 0;
        }
        self.last_force_raw = sensors.force_sensor_n;
        let armed = self.state == State::Armed;
        if armed && self.same_force_count >= self.safety.loadcell_stuck_samples {
            faults = faults.with(Faults::LOADCELL_STUCK);
        }
        let finite = !faults.contains(Faults::NON_FINITE);
        if finite {
            self.last_alpha_rad = Some(sensors.alpha_rad);
        }
        let pose = self.pose(sensors, finite);
        // the muscles' torque at the measured pose for the commanded pressures and the torque
        // the handle holds: computed at most once a period, for whichever check needs it
        let model = &self.model;
        let pressure_bar = self.pressure_bar;
        let mut cached = None;
        let mut torques = || {
            *cached.get_or_insert_with(|| {
                torques_at_nm(
                    model,
                    pose.alpha_rad,
                    &pose.trig,
                    pose.force_user_n,
                    pressure_bar,
                )
            })
        };
        let period_s = self.safety.period_s;
        // static balance against the pressures the converters have been commanded
        if armed && finite {
            if self
                .balance
                .update_at(model, period_s, pose.alpha_rad, pressure_bar, &mut torques)
            {
                faults = faults.with(Faults::STATIC_IMBALANCE);
            }
        } else {
            self.balance.reset();
        }
        let watched = matches!(
            self.mode,
            Mode::Joint { .. } | Mode::Pressures { .. } | Mode::Force { .. }
        );
        if !(armed && finite && watched) {
            self.unseen_motion.reset();
        } else if unseen_motion_judged(&mut self.unseen_motion, model, &pose, torques(), period_s) {
            faults = faults.with(Faults::STATIC_IMBALANCE);
        }
        // the first rest with the muscles tensioned judges the last home
        let tensioned = self.mode != Mode::Idle && self.arm_ramp.done();
        if !(armed && finite && tensioned && self.home.pending()) {
            self.home.restart();
        } else if self
            .home
            .update(model, period_s, pose.alpha_rad, pressure_bar, torques())
            == HomeVerdict::Refused
        {
            faults = faults.with(Faults::STATIC_IMBALANCE);
        }
        // the arm moving faster than any mode may move it; a jump is the encoder's fault,
        // not a motion. The closed loops watch the handle's speed themselves (a tighter
        // bound: 0.5 m/s is ≈ 0.7 rad/s at joint 1's lever), so there the joint speed
        // history restarts instead.
        let own_guard = matches!(
            self.mode,
            Mode::ForceClosedLoop { .. } | Mode::Impedance { .. }
        ) && self.arm_ramp.done();
        if !armed || own_guard {
            self.speed.reset();
        } else if faults.is_none() && self.speed.update(sensors.alpha_rad, self.safety.period_s) {
            faults = faults.with(Faults::CONTROL_UNSTABLE);
        }
        self.periods_since_command = self.periods_since_command.saturating_add(1);
        let timeout_periods = (self.safety.command_timeout_s / self.safety.period_s + 0.5) as u32;
        if armed && self.periods_since_command > timeout_periods {
            faults = faults.with(Faults::COMMAND_TIMEOUT);
        }
        if !faults.is_none() {
            self.faults = self.faults.with(faults);
            self.state = State::Faulted;
        }
        pose
    }

    /// The measured pose's trigonometry and the handle force in the user frame.
    #[inline(always)]
    pub(crate) fn pose(&self, sensors: &Sensors, finite: bool) -> Pose {
        let alpha_rad = sensors.alpha_rad;
        let trig = self
            .model
            .kinematics
            .trig(if finite { alpha_rad } else { [0.0; 2] });
        let force_user_n = if finite {
            Kinematics::sensor_to_user_at(&trig, sensors.force_sensor_n)
        } else {
            [0.0; 2]
        };
        Pose {
            alpha_rad,
            trig,
            force_user_n,
        }
    }
}

/// The encoders in the modes whose pressures are the command (joint, pressures, open-loop
/// force): a torque change the arm should follow, not seen by the encoder nor carried by the
/// handle ([`crate::guard::EncoderMotion`]); `torques` is (τ of the cables, Jᵀ F): where
/// the model has a muscle push (a large force step toward one side), the rig's cable is
/// slack, and a blocked handle carries none of that push.
#[inline(always)]
fn unseen_motion_judged(
    motion: &mut EncoderMotion,
    model: &RobotModel<f32>,
    pose: &Pose,
    torques: (Vec2<f32>, Vec2<f32>),
    period_s: f32,
) -> bool {
    let j = &model.params.joints;
    let in_range = [0, 1].map(|k| {
        pose.alpha_rad[k] >= j[k].alpha_min_rad + STOP_BAND_RAD
            && pose.alpha_rad[k] <= j[k].alpha_max_rad - STOP_BAND_RAD
    });
    motion.update(pose.alpha_rad, torques, in_range, period_s)
}
