//! Modes, state machine and supervisor. f32 throughout (the target's type).

use pam_model::params::LoadCell;
use pam_model::{RobotModel, Vec2};

pub use crate::faults::Faults;
pub use crate::mode::{Mode, Sensors, State, StepOutput};
pub use crate::safety::{
    ceiling, Reject, SafetyConfig, DEFAULT_OVERRUN_FAULT_PERIODS, LOADCELL_AMPLIFIER_FULL_SCALE_V,
    OVERRUN_FAULT_PERIODS_RANGE,
};

use crate::force_loop::{ForceLoop, ForceLoopConfig, MAX_GAIN_SCALE};
use crate::guard::EncoderMotion;
use crate::home_check::HomeCheck;
use crate::impedance::{
    Impedance, MAX_IMPEDANCE_DAMPING_N_S_PER_M, MAX_IMPEDANCE_MASS_KG,
    MAX_IMPEDANCE_STIFFNESS_N_PER_M, MAX_IMPEDANCE_TARGET_M,
};
use crate::motion::{pressures_within_limits, ArmRamp, JointShaper, SpeedMonitor};
use crate::plausibility::{BalanceMonitor, EncoderWatch};

/// The control step's state. One period is three stages, each in its own module:
/// `supervise` (sensor and timing faults, latched), `targets` (the mode's command) and
/// `output` (the limits every command passes on its way to the converters).
pub struct Controller {
    pub(crate) model: RobotModel<f32>,
    pub(crate) safety: SafetyConfig,
    pub(crate) state: State,
    pub(crate) mode: Mode,
    pub(crate) faults: Faults,
    /// Control periods since the last accepted command (an integer: no drift).
    pub(crate) periods_since_command: u32,
    /// Last output, for the slew limit.
    pub(crate) pressure_bar: [f32; 4],
    pub(crate) last_alpha_rad: Option<Vec2<f32>>,
    pub(crate) last_force_raw: Vec2<f32>,
    pub(crate) same_force_count: u32,
    pub(crate) balance: BalanceMonitor,
    pub(crate) force_loop_cfg: ForceLoopConfig,
    pub(crate) force_loop: ForceLoop,
    pub(crate) impedance: Impedance,
    /// The joint mode's shaped reference.
    pub(crate) shaper: JointShaper,
    /// The tensioning ramp before a mode's target applies.
    pub(crate) arm_ramp: ArmRamp,
    /// The joint speed supervision of every mode.
    pub(crate) speed: SpeedMonitor,
    /// The encoders' plausibility in impedance mode.
    pub(crate) encoders: EncoderWatch,
    /// The encoders' plausibility in joint, pressures and open-loop force modes.
    pub(crate) unseen_motion: EncoderMotion,
    /// The last home, judged at the first rest with the muscles tensioned.
    pub(crate) home: HomeCheck,
    /// The last command was clamped on its way out (the force loop's anti-windup).
    pub(crate) last_saturated: bool,
}

impl Controller {
    pub fn new(model: RobotModel<f32>, safety: SafetyConfig) -> Self {
        let vent = model.params.ip.output_min_bar;
        Controller {
            model,
            safety,
            state: State::Disarmed,
            mode: Mode::Idle,
            faults: Faults::NONE,
            periods_since_command: 0,
            pressure_bar: [vent; 4],
            last_alpha_rad: None,
            last_force_raw: [f32::NAN; 2],
            same_force_count: 0,
            balance: BalanceMonitor::new(),
            force_loop_cfg: ForceLoopConfig::designed(),
            force_loop: ForceLoop::new(),
            impedance: Impedance::new(),
            shaper: JointShaper::new(),
            arm_ramp: ArmRamp::new(),
            speed: SpeedMonitor::new(),
            encoders: EncoderWatch::new(),
            unseen_motion: EncoderMotion::new(),
            home: HomeCheck::new(),
            last_saturated: false,
        }
    }

    pub fn state(&self) -> State {
        self.state
    }
    pub fn mode(&self) -> Mode {
        self.mode
    }
    pub fn faults(&self) -> Faults {
        self.faults
    }
    /// Whether the outputs are the safe state, exactly [`crate::VENT_CURRENT_MA`] on every
    /// channel: disarmed, or faulted by anything but a lone command timeout (whose ramp
    /// ends there within [`crate::safety::ceiling::TIMEOUT_RAMP_MAX_S`]).
    pub fn outputs_vented(&self) -> bool {
        match self.state {
            State::Disarmed => true,
            State::Faulted => self.faults != Faults::COMMAND_TIMEOUT,
            State::Armed => false,
        }
    }
    pub fn safety(&self) -> &SafetyConfig {
        &self.safety
    }
    pub fn model(&self) -> &RobotModel<f32> {
        &self.model
    }
    pub fn force_loop_config(&self) -> &ForceLoopConfig {
        &self.force_loop_cfg
    }
    pub fn force_loop(&self) -> &ForceLoop {
        &self.force_loop
    }
    /// The handle's motion as the closed-loop modes track it (and whether it has rung).
    pub fn handle_motion(&self) -> &Impedance {
        &self.impedance
    }

    /// Replaces the closed force loop's gains and guard. Refused while armed.
    pub fn set_force_loop_config(&mut self, cfg: ForceLoopConfig) -> Result<(), Reject> {
        if !cfg.is_valid() {
            return Err(Reject::OutOfRange);
        }
        if self.state == State::Armed {
            return Err(Reject::WrongState);
        }
        self.force_loop_cfg = cfg;
        Ok(())
    }

    /// An accepted command (arming, a mode, a keep-alive, a disarm or a clear) resets the
    /// command timeout; a configuration change does not.
    fn accepted(&mut self) {
        self.periods_since_command = 0;
    }

    /// A keep-alive with no other effect.
    pub fn heartbeat(&mut self) {
        self.accepted();
    }

    pub fn arm(&mut self) -> Result<(), Reject> {
        match self.state {
            State::Disarmed if self.faults.is_none() => {
                self.state = State::Armed;
                self.force_loop.reset();
                self.encoders.reset();
                self.impedance.reset();
                self.shaper.reset();
                self.speed.reset();
                self.arm_ramp.reset();
                self.accepted();
                Ok(())
            }
            _ => Err(Reject::WrongState),
        }
    }

    pub fn disarm(&mut self) {
        if self.state == State::Armed {
            self.state = State::Disarmed;
        }
        self.mode = Mode::Idle;
        self.accepted();
    }

    /// Clears latched faults; refused while a condition persists. Leaves the robot disarmed.
    pub fn clear_faults(&mut self, sensors: &Sensors) -> Result<(), Reject> {
        let present = self.sensor_faults(sensors, false);
        if !present.is_none() {
            return Err(Reject::FaultStillPresent);
        }
        self.faults = Faults::NONE;
        self.state = State::Disarmed;
        self.mode = Mode::Idle;
        self.last_alpha_rad = None;
        self.same_force_count = 0;
        self.balance.reset();
        self.accepted();
        Ok(())
    }

    /// Sets the mode after checking every value against the absolute limits. Values
    /// inside them but beyond what the robot can do at the pose are clamped each step and
    /// flagged in [`StepOutput::limited`].
    pub fn set_mode(&mut self, mode: Mode) -> Result<(), Reject> {
        let s = &self.safety;
        let p = &self.model.params;
        let finite_in = |v: f32, lo: f32, hi: f32| v.is_finite() && v >= lo && v <= hi;
        let ok = match &mode {
            Mode::Idle => true,
            Mode::Pressures { pressure_bar } => {
                pressure_bar
                    .iter()
                    .all(|&x| finite_in(x, p.pressure.min_bar, p.pressure.max_bar))
                    && pressures_within_limits(
                        pressure_bar,
                        [p.joints[0].channel_of_muscle, p.joints[1].channel_of_muscle],
                    )
            }
            Mode::Joint {
                alpha_rad,
                torque_nm,
                stiffness_nm_per_rad,
            } => (0..2).all(|j| {
                finite_in(
                    alpha_rad[j],
                    p.joints[j].alpha_min_rad,
                    p.joints[j].alpha_max_rad,
                ) && finite_in(
                    torque_nm[j],
                    -s.max_request_torque_nm,
                    s.max_request_torque_nm,
                ) && finite_in(
                    stiffness_nm_per_rad[j],
                    0.0,
                    s.max_request_stiffness_nm_per_rad,
                )
            }),
            Mode::Force {
                force_n,
                stiffness_nm_per_rad,
                ..
            } => (0..2).all(|j| {
                finite_in(force_n[j], -s.max_request_force_n, s.max_request_force_n)
                    && finite_in(
                        stiffness_nm_per_rad[j],
                        0.0,
                        s.max_request_stiffness_nm_per_rad,
                    )
            }),
            Mode::ForceClosedLoop {
                force_n,
                stiffness_nm_per_rad,
                gain_scale,
                ..
            } => {
                gain_scale.is_finite()
                    && *gain_scale > 0.0
                    && *gain_scale <= MAX_GAIN_SCALE
                    && (0..2).all(|j| {
                        finite_in(force_n[j], -s.max_request_force_n, s.max_request_force_n)
                            && finite_in(
                                stiffness_nm_per_rad[j],
                                0.0,
                                s.max_request_stiffness_nm_per_rad,
                            )
                    })
            }
            Mode::Impedance {
                target_user_m,
                stiffness_n_per_m,
                damping_n_s_per_m,
                mass_kg,
            } => (0..2).all(|a| {
                finite_in(
                    target_user_m[a],
                    -MAX_IMPEDANCE_TARGET_M,
                    MAX_IMPEDANCE_TARGET_M,
                ) && finite_in(stiffness_n_per_m[a], 0.0, MAX_IMPEDANCE_STIFFNESS_N_PER_M)
                    && finite_in(damping_n_s_per_m[a], 0.0, MAX_IMPEDANCE_DAMPING_N_S_PER_M)
                    && finite_in(mass_kg[a], 0.0, MAX_IMPEDANCE_MASS_KG)
            }),
        };
        if !ok {
            return Err(Reject::OutOfRange);
        }
        // a new target keeps the loop's state (bumpless); entering the mode starts afresh
        if !matches!(
            (self.mode, mode),
            (Mode::ForceClosedLoop { .. }, Mode::ForceClosedLoop { .. })
                | (Mode::Impedance { .. }, Mode::Impedance { .. })
        ) {
            self.force_loop.reset();
            self.impedance.reset();
            self.encoders.reset();
        }
        // a new joint target continues from the shaped reference; entering starts at the arm
        if !matches!((self.mode, mode), (Mode::Joint { .. }, Mode::Joint { .. })) {
            self.shaper.reset();
        }
        // the gain plane is part of the plant the loop measured: switched, measure again
        if let (
            Mode::ForceClosedLoop {
                feed_forward: was, ..
            },
            Mode::ForceClosedLoop { feed_forward, .. },
        ) = (self.mode, mode)
        {
            if was != feed_forward {
                self.force_loop.forget_plant_gain();
            }
        }
        self.mode = mode;
        self.accepted();
        Ok(())
    }

    /// Replaces the safety configuration: refused if it would pass a ceiling, and while
    /// armed unless it only tightens ([`SafetyConfig::may_apply_while_armed`]).
    pub fn set_safety(&mut self, safety: SafetyConfig) -> Result<(), Reject> {
        safety.validate()?;
        if self.state == State::Armed && !self.safety.may_apply_while_armed(&safety) {
            return Err(Reject::WrongState);
        }
        // a configuration is not a command: it does not keep an arm alive
        self.safety = safety;
        Ok(())
    }

    /// Replaces the robot model (new parameters). Refused while armed; latched faults stay.
    pub fn set_model(&mut self, model: RobotModel<f32>) -> Result<(), Reject> {
        if self.state == State::Armed {
            return Err(Reject::WrongState);
        }
        self.model = model;
        Ok(())
    }

    /// Replaces the load-cell calibration (tare, gain/offset). It derives no constant, so
    /// it is allowed in any state.
    pub fn set_load_cell(&mut self, load_cell: LoadCell<f32>) {
        self.model.params.load_cell = load_cell;
    }

    /// Forgets the previous angle sample, so that a deliberate change of the angle origin
    /// (homing) is not taken for an encoder jump. Refused while armed.
    pub fn reset_angle_history(&mut self) -> Result<(), Reject> {
        if self.state == State::Armed {
            return Err(Reject::WrongState);
        }
        self.last_alpha_rad = None;
        Ok(())
    }

    /// A new home (the caller's: the encoders' zero): judged at the first rest with the
    /// muscles tensioned ([`crate::home_check`]). Refused while armed.
    pub fn judge_home(&mut self) -> Result<(), Reject> {
        if self.state == State::Armed {
            return Err(Reject::WrongState);
        }
        self.home.expect();
        Ok(())
    }

    /// The last home's judgement: waiting for a rest, refused (the arm rested far from the
    /// model's equilibrium; `STATIC_IMBALANCE` latched), or neither (confirmed, or none).
    pub fn home_check(&self) -> &HomeCheck {
        &self.home
    }

    /// The firmware reports a hardware fault (watchdog reset, open current loop).
    pub fn raise(&mut self, fault: Faults) {
        self.faults = self.faults.with(fault);
        self.state = State::Faulted;
    }

    /// One control period: supervise the sensors, compute the command of the mode, enforce
    /// the limits, and return the outputs to write. Never panics; every path ends in finite
    /// outputs inside the converters' range.
    pub fn step(&mut self, sensors: &Sensors) -> StepOutput {
        let pose = self.supervise(sensors);
        let command = self.mode_target(&pose);
        self.limit(command, pose.force_user_n)
    }
}
