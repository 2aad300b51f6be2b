//! Modes, state machine and supervisor. f32 throughout (the target's type).

use pam_model::kinematics::Kinematics;
use pam_model::params::LoadCell;
use pam_model::{Limited, Real, RobotModel, Vec2};

pub use crate::faults::Faults;
pub use crate::mode::{Mode, Sensors, State, StepOutput};
pub use crate::safety::{
    Reject, SafetyConfig, DEFAULT_OVERRUN_FAULT_PERIODS, LOADCELL_AMPLIFIER_FULL_SCALE_V,
    OVERRUN_FAULT_PERIODS_RANGE,
};

use crate::force_loop::{ForceLoop, ForceLoopConfig, MAX_GAIN_SCALE};
use crate::impedance::{
    arm_inertia_force_n, impedance_force_n, reachable_impedance_force_n, Impedance,
    VirtualImpedance, IMPEDANCE_INTEGRAL_SCALE, MAX_IMPEDANCE_DAMPING_N_S_PER_M,
    MAX_IMPEDANCE_MASS_KG, MAX_IMPEDANCE_STIFFNESS_N_PER_M, MAX_IMPEDANCE_TARGET_M,
};
use crate::plausibility::BalanceMonitor;

pub struct Controller {
    model: RobotModel<f32>,
    safety: SafetyConfig,
    state: State,
    mode: Mode,
    faults: Faults,
    /// Control periods since the last accepted command (an integer: no drift).
    periods_since_command: u32,
    /// Last output, for the slew limit.
    pressure_bar: [f32; 4],
    last_alpha_rad: Option<Vec2<f32>>,
    last_force_raw: Vec2<f32>,
    same_force_count: u32,
    balance: BalanceMonitor,
    force_loop_cfg: ForceLoopConfig,
    force_loop: ForceLoop,
    impedance: Impedance,
    /// The last command was clamped on its way out (the force loop's anti-windup).
    last_saturated: bool,
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

    /// Replaces the closed force loop's gains and guard. Refused while armed.
    pub fn set_force_loop_config(&mut self, cfg: ForceLoopConfig) -> Result<(), Reject> {
        if !cfg.is_valid() {
            return Err(Reject::OutOfRange);
        }
        if self.state == State::Armed {
            return Err(Reject::WrongState);
        }
        self.force_loop_cfg = cfg;
        self.accepted();
        Ok(())
    }

    /// Any accepted command resets the command timeout.
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
                self.impedance.reset();
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
            Mode::Pressures { pressure_bar } => pressure_bar
                .iter()
                .all(|&x| finite_in(x, p.pressure.min_bar, p.pressure.max_bar)),
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

    /// Replaces the safety configuration (refused if it would disable a protection).
    pub fn set_safety(&mut self, safety: SafetyConfig) -> Result<(), Reject> {
        safety.validate()?;
        self.safety = safety;
        self.accepted();
        Ok(())
    }

    /// Replaces the robot model (new parameters). Refused while armed; latched faults stay.
    pub fn set_model(&mut self, model: RobotModel<f32>) -> Result<(), Reject> {
        if self.state == State::Armed {
            return Err(Reject::WrongState);
        }
        self.model = model;
        self.accepted();
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

    /// The firmware reports a hardware fault (watchdog reset, open current loop).
    pub fn raise(&mut self, fault: Faults) {
        self.faults = self.faults.with(fault);
        self.state = State::Faulted;
    }

    fn sensor_faults(&self, s: &Sensors, track_history: bool) -> Faults {
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

    /// One control period: supervise the sensors, compute the command of the mode, enforce
    /// the limits, and return the outputs to write. Never panics; every path ends in finite
    /// outputs inside the converters' range.
    pub fn step(&mut self, sensors: &Sensors) -> StepOutput {
        let dt = self.safety.period_s;
        let mut faults = self.sensor_faults(sensors, true);
        // stuck load cell: bit-identical samples while armed (a live ADC always dithers)
        if sensors.force_sensor_n == self.last_force_raw {
            self.same_force_count = self.same_force_count.saturating_add(1);
        } else {
            self.same_force_count = 0;
        }
        self.last_force_raw = sensors.force_sensor_n;
        if self.state == State::Armed && self.same_force_count >= self.safety.loadcell_stuck_samples
        {
            faults = faults.with(Faults::LOADCELL_STUCK);
        }
        if !faults.contains(Faults::NON_FINITE) {
            self.last_alpha_rad = Some(sensors.alpha_rad);
        }
        // static balance against the pressures the converters have been commanded
        if self.state == State::Armed && !faults.contains(Faults::NON_FINITE) {
            let period_s = self.safety.period_s;
            if self
                .balance
                .update(&self.model, period_s, sensors, self.pressure_bar)
            {
                faults = faults.with(Faults::STATIC_IMBALANCE);
            }
        } else {
            self.balance.reset();
        }
        self.periods_since_command = self.periods_since_command.saturating_add(1);
        let timeout_periods = (self.safety.command_timeout_s / dt + 0.5) as u32;
        let timed_out = self.state == State::Armed && self.periods_since_command > timeout_periods;
        if timed_out {
            faults = faults.with(Faults::COMMAND_TIMEOUT);
        }
        if !faults.is_none() {
            self.faults = self.faults.with(faults);
            self.state = State::Faulted;
        }

        let ip = &self.model.params.ip;
        let vent = ip.output_min_bar;
        let alpha = sensors.alpha_rad;
        // sin/cos of the pose once per step, shared by the load-cell rotation and τ = Jᵀ F
        let trig = self
            .model
            .kinematics
            .trig(if faults.contains(Faults::NON_FINITE) {
                [0.0; 2]
            } else {
                alpha
            });
        let force_user_n = if faults.contains(Faults::NON_FINITE) {
            [0.0; 2]
        } else {
            Kinematics::sensor_to_user_at(&trig, sensors.force_sensor_n)
        };

        let mut limited = Limited::NONE;
        let (target, slew, cut) = match self.state {
            State::Armed => {
                let target = match self.mode {
                    Mode::Idle => [vent; 4],
                    Mode::Pressures { pressure_bar } => pressure_bar,
                    Mode::Joint {
                        alpha_rad,
                        torque_nm,
                        stiffness_nm_per_rad,
                    } => {
                        let sol = self
                            .model
                            .inverse(alpha_rad, torque_nm, stiffness_nm_per_rad);
                        limited = sol[0].limited.with(sol[1].limited);
                        self.model
                            .channel_pressures_bar([sol[0].pressure_bar, sol[1].pressure_bar])
                    }
                    Mode::Force {
                        force_n,
                        stiffness_nm_per_rad,
                        feed_forward,
                    } => {
                        let cmd = self.model.force_command_at(
                            alpha,
                            &trig,
                            force_n,
                            stiffness_nm_per_rad,
                            feed_forward,
                        );
                        limited = cmd.joints[0].limited.with(cmd.joints[1].limited);
                        self.model.channel_pressures_bar([
                            cmd.joints[0].pressure_bar,
                            cmd.joints[1].pressure_bar,
                        ])
                    }
                    Mode::ForceClosedLoop {
                        force_n,
                        stiffness_nm_per_rad,
                        feed_forward,
                        gain_scale,
                    } => {
                        // the handle is blocked or held: a loop that moves it lost its force
                        let w = self.model.kinematics.forward_world_at(&trig);
                        let too_fast =
                            handle_too_fast(&mut self.impedance, &self.force_loop_cfg, w, dt);
                        // a hand gives way where a block does not: gentler gains
                        self.force_loop
                            .observe_handle(&self.force_loop_cfg, w, force_user_n, dt);
                        // a target beyond the muscles is scaled to what they can give
                        let reach = self.force_loop.reachable_scale(
                            &self.force_loop_cfg,
                            &self.model,
                            alpha,
                            &trig,
                            force_n,
                            feed_forward,
                        );
                        let target_n = [reach * force_n[0], reach * force_n[1]];
                        let fl = self.force_loop.step(
                            &self.force_loop_cfg,
                            ip,
                            target_n,
                            force_user_n,
                            gain_scale,
                            self.last_saturated,
                            dt,
                        );
                        // the patient let go while the loop pushes: the reference model asks for
                        // a force the load cell no longer reads, and the handle runs
                        let released = self.impedance.released(fl.model_n, force_user_n, dt);
                        if fl.trip.is_some() || too_fast || released {
                            self.faults = self.faults.with(Faults::CONTROL_UNSTABLE);
                            self.state = State::Faulted;
                        }
                        // the gain plane: all of it on the feedback, on the feed-forward only
                        // at a block (a bet the gentle loop against a hand cannot take back)
                        let command_n = if feed_forward {
                            let plane = &self.model.params.gain_plane;
                            let cfg = &self.force_loop_cfg;
                            self.force_loop.through_plane(cfg, &fl, plane, alpha).0
                        } else {
                            fl.command_n
                        };
                        // no cable asked to push: the loop's gain stays the model's
                        let cmd = self.model.force_command_taut_at(
                            alpha,
                            &trig,
                            command_n,
                            stiffness_nm_per_rad,
                            false,
                            self.force_loop_cfg.taut_force_fraction,
                        );
                        limited = cmd.joints[0].limited.with(cmd.joints[1].limited);
                        if reach < 1.0 {
                            limited = limited.with(Limited::TARGET);
                        }
                        self.model.channel_pressures_bar([
                            cmd.joints[0].pressure_bar,
                            cmd.joints[1].pressure_bar,
                        ])
                    }
                    Mode::Impedance {
                        target_user_m,
                        stiffness_n_per_m,
                        damping_n_s_per_m,
                        mass_kg,
                    } => {
                        let w = self.model.kinematics.forward_world_at(&trig);
                        let home = self.model.kinematics.home_world_m;
                        let x_m = [w[0] - home[0], w[1] - home[1]];
                        let too_fast =
                            handle_too_fast(&mut self.impedance, &self.force_loop_cfg, x_m, dt);
                        let imp = VirtualImpedance {
                            stiffness_n_per_m,
                            damping_n_s_per_m,
                            mass_kg,
                        };
                        let f_ref = impedance_force_n(target_user_m, &imp, &self.impedance, x_m);
                        // the muscles also move the arm's own mass, behind the load cell
                        let inertia = arm_inertia_force_n(
                            &self.model,
                            &trig,
                            self.impedance.acceleration_m_s2(),
                        );
                        // a spring force beyond the muscles is scaled, its direction kept
                        let (f_ref, reach) = reachable_impedance_force_n(
                            &self.model,
                            &self.force_loop_cfg,
                            (alpha, &trig),
                            (f_ref, self.safety.max_request_force_n),
                            [self.force_loop.integral_n(), inertia],
                        );
                        let released = self.impedance.released(f_ref, force_user_n, dt);
                        let fl = self.force_loop.step_direct(
                            &self.force_loop_cfg,
                            ip,
                            f_ref,
                            force_user_n,
                            IMPEDANCE_INTEGRAL_SCALE,
                            self.last_saturated,
                            dt,
                        );
                        if fl.trip.is_some() || too_fast || released {
                            self.faults = self.faults.with(Faults::CONTROL_UNSTABLE);
                            self.state = State::Faulted;
                        }
                        let command_n =
                            [fl.command_n[0] + inertia[0], fl.command_n[1] + inertia[1]];
                        // stiffness 0: the inverse model gives the least the muscles can
                        let cmd = self
                            .model
                            .force_command_at(alpha, &trig, command_n, [0.0; 2], false);
                        limited = cmd.joints[0].limited.with(cmd.joints[1].limited);
                        if reach < 1.0 {
                            limited = limited.with(Limited::TARGET);
                        }
                        self.model.channel_pressures_bar([
                            cmd.joints[0].pressure_bar,
                            cmd.joints[1].pressure_bar,
                        ])
                    }
                };
                (target, self.safety.slew_bar_per_s, false)
            }
            // A timeout alone ramps down; any other fault (or a disarm) vents at once.
            State::Faulted if self.faults == Faults::COMMAND_TIMEOUT => {
                ([vent; 4], self.safety.timeout_ramp_bar_per_s, false)
            }
            State::Faulted | State::Disarmed => ([vent; 4], 0.0, true),
        };
        // the force loop's guard faults inside the armed branch: vent this very period
        let (target, slew, cut) = if self.faults.contains(Faults::CONTROL_UNSTABLE) {
            ([vent; 4], 0.0, true)
        } else {
            (target, slew, cut)
        };

        let mut output_limited = false;
        // the capability limits only (pressure range, converter range), not the slew limit:
        // a slew-limited command catches up by itself, a clamped one never does
        let mut range_limited = false;
        let max_step = slew * dt;
        let mut out = [vent; 4];
        let mut current = [ip.current_min_ma; 4];
        for c in 0..4 {
            let mut p = target[c];
            if !p.is_finite() {
                // the model never returns NaN, but the output path does not rely on that
                self.faults = self.faults.with(Faults::OUTPUT_NON_FINITE);
                self.state = State::Faulted;
                p = vent;
            }
            let p_in = p;
            p = p.clamp_to(
                self.model.params.pressure.min_bar,
                self.model.params.pressure.max_bar,
            );
            range_limited |= (p - p_in).abs() > 1e-6;
            if !cut {
                let prev = self.pressure_bar[c];
                p = p.clamp_to(prev - max_step, prev + max_step);
            }
            let cmd = ip.current_for(p);
            output_limited |= (p - p_in).abs() > 1e-6 || cmd.saturated;
            range_limited |= cmd.saturated;
            // At the converter's floor (idle, a finished timeout ramp, a 0.1 bar command) the
            // output is the safe state itself, 4 mA: the same 0.1 bar at the converter as the
            // 5.3 mA its law gives, and the current an open or unpowered loop would also give.
            let at_floor = p <= vent;
            out[c] = if cut { vent } else { p };
            current[c] = if cut || at_floor {
                ip.current_min_ma
            } else {
                cmd.current_ma
            };
        }
        self.pressure_bar = out;
        self.last_saturated = range_limited
            || limited.contains(Limited::TORQUE)
            || limited.contains(Limited::PRESSURE);
        StepOutput {
            pressure_bar: out,
            current_ma: current,
            force_user_n,
            state: self.state,
            faults: self.faults,
            limited,
            output_limited,
        }
    }
}

/// Tracks the handle's velocity (any frame origin: `x_m` is only differenced) and says
/// whether it exceeds the closed loop's speed guard.
fn handle_too_fast(motion: &mut Impedance, cfg: &ForceLoopConfig, x_m: Vec2<f32>, dt: f32) -> bool {
    let v = motion.track(x_m, dt);
    v[0] * v[0] + v[1] * v[1] > cfg.guard_speed_m_s * cfg.guard_speed_m_s
}
