//! The twin, the device it is wired to, and what holds the handle.

use crate::config::emulator_version;
use crate::inject::{Board, Injection, Scheduled};
use crate::{EmulatorError, HandleMode, SimConfig};
use pam_control::{Mode, SafetyConfig, State};
use pam_device::{Device, DeviceOptions, RawSensors, StepResult, StepTiming};
use pam_model::{RobotModel, RobotParams, Vec2};
use pam_protocol::{Calibration, Config, EncoderCalibration, Request, RequestBody};
use pam_twin::experiments::OperatorPath;
use pam_twin::{HandSpring, HandleCondition, Measurement, Twin, TwinConfig};

/// The relaxed hand of `--handle held-relaxed`: stiffness, N/m, and damping, N·s/m.
const RELAXED_HAND_N_PER_M: f64 = 1000.0;
const RELAXED_HAND_N_S_PER_M: f64 = 50.0;
use std::sync::mpsc::Sender;

/// Width of the emulated encoder timers (the board's TIM3/TIM4 are 16-bit).
const ENCODER_COUNTER_BITS: u8 = 16;
/// Arbitrary power-on value of the encoder counters: homing must not depend on it.
const ENCODER_POWER_ON_COUNTS: i64 = 0x7A31;
/// Operator: how long the hand holds the target still before moving.
const OPERATOR_HOLD_S: f64 = 3.0;
/// Operator path length; after it the hand holds the target still.
const OPERATOR_PATH_S: f64 = 600.0;

/// The twin and what holds its handle.
pub(crate) struct Plant {
    pub(crate) device: Device,
    pub(crate) twin: Twin,
    pub(crate) last: Measurement,
    pub(crate) handle_mode: HandleMode,
    pub(crate) model: RobotModel<f64>,
    /// Operator path around (0, 0); the centre is added. Built only for the operator.
    pub(crate) path: Option<OperatorPath>,
    /// Condition chosen at the last arm/mode change, and when that was (plant time).
    pub(crate) hold_point: Vec2<f64>,
    pub(crate) since_s: f64,
    pub(crate) last_mode: (State, Mode),
    pub(crate) t_s: f64,
    /// The emulated board: injected failures, E-stop, loop timing.
    pub(crate) board: Board,
    /// Scheduled injections not applied yet, latest first.
    pub(crate) schedule: Vec<Scheduled>,
    pub(crate) reports: Sender<String>,
    /// Loop currents driven in the last period.
    pub(crate) last_currents_ma: [f64; 4],
    /// The configuration flash (persist, restore, erase; read at start).
    pub(crate) store: pam_config_store::ConfigStore<crate::flash::SimFlash>,
    /// Wiring mistakes of the rig, applied in order between the twin and the device.
    pub(crate) miswiring: Vec<crate::Miswire>,
    /// The lagging converters' currents, mA (`Miswire::SlowConverter`).
    lagged_ma: [f64; 4],
    /// A blocked handle stays blocked in the pressures mode that follows a force mode, to
    /// the disarm (the person holds the block for the whole blocked step).
    blocked_this_arming: bool,
}

impl Plant {
    pub(crate) fn new(config: &SimConfig, reports: Sender<String>) -> Result<Plant, EmulatorError> {
        let mut twin_cfg = if config.identified_rig {
            TwinConfig::identified_rig()
        } else {
            TwinConfig::thesis()
        };
        twin_cfg.effects = config.effects.clone();
        twin_cfg.seed = config.seed;
        for m in &config.miswiring {
            for (alpha, rest) in twin_cfg.initial_alpha_rad.iter_mut().zip(m.rest_pose_rad()) {
                *alpha += rest;
            }
        }
        let counts_per_rev = twin_cfg.sensors.encoder_counts_per_rev;
        let mut twin = Twin::new(twin_cfg);
        let mut safety = SafetyConfig::default_1khz();
        safety.command_timeout_s = config.command_timeout_s;
        safety
            .validate()
            .map_err(|_| EmulatorError::CommandTimeout {
                seconds: config.command_timeout_s,
            })?;
        let mut device = Device::new(
            RobotParams::thesis(),
            safety,
            DeviceOptions {
                firmware_version: emulator_version(),
                encoder_counter_bits: ENCODER_COUNTER_BITS,
                boot_nonce: boot_nonce(),
            },
        );
        // the rig's calibration: the twin's encoder resolution
        let mut cal: Calibration = device.calibration();
        for (enc, counts) in cal.encoder.iter_mut().zip(counts_per_rev) {
            *enc = EncoderCalibration {
                counts_per_rev: counts.max(1),
                sign: 1,
                zero_rad: 0.0,
            };
        }
        let reply = device.handle(&Request {
            id: 0,
            body: RequestBody::SetConfig(Config::Calibration(cal)),
            session: pam_protocol::NO_SESSION,
        });
        reply.result.map_err(EmulatorError::Calibration)?;
        // like the firmware's boot: the record in flash, if there is a good one
        let mut store = crate::flash::store(config.config_flash.clone())?;
        device.boot_config(store.load());
        let last = twin.step(1e-6, [4.0; 4], &HandleCondition::Free);
        let model = *twin.model();
        let path = (config.handle == HandleMode::Operator)
            .then(|| OperatorPath::new([0.0; 2], 0.04, (0.1, 2.0), OPERATOR_PATH_S, config.seed));
        let hold_point = twin.state().handle_user_m;
        let last_mode = (device.controller().state(), device.controller().mode());
        let mut schedule = config.injections.clone();
        schedule.sort_by(|a, b| b.at_s.total_cmp(&a.at_s));
        let board = Board::new(device.period_us());
        Ok(Plant {
            device,
            twin,
            last,
            handle_mode: config.handle,
            model,
            path,
            hold_point,
            since_s: 0.0,
            last_mode,
            t_s: 0.0,
            board,
            schedule,
            reports,
            last_currents_ma: [4.0; 4],
            store,
            miswiring: config.miswiring.clone(),
            lagged_ma: [4.0; 4],
            blocked_this_arming: false,
        })
    }

    /// A request frame, the storage requests with the emulated flash.
    pub(crate) fn handle_frame(
        &mut self,
        frame: Result<Request, pam_protocol::DecodeError>,
    ) -> pam_protocol::Reply {
        match &frame {
            Ok(request) => self.device.handle_with_store(&mut self.store, request),
            Err(_) => self.device.handle_frame(frame),
        }
    }

    /// One control period of `period_us` (the device's period when the period began) at
    /// device time `device_time_us`: the injections due, the device's step inside the
    /// emulated board, the plant over the same period. `stall` is handed
    /// an injected overrun's extra µs (the real-time loop sleeps them; a fast-forward run
    /// only counts them: the board's clock sees them either way).
    pub(crate) fn period(
        &mut self,
        period_us: u32,
        device_time_us: u64,
        last_exec_us: u16,
        jitter_us: u16,
        stall: impl FnOnce(u32),
    ) -> StepResult {
        while self
            .schedule
            .last()
            .is_some_and(|s| s.at_s <= self.t_s + 1e-9)
        {
            if let Some(s) = self.schedule.pop() {
                self.inject(s.injection, device_time_us);
            }
        }
        self.board.before_step(&mut self.device);
        let raw = self.raw_sensors();
        let step_clock = crate::inject::StepClock::start();
        let result = self.device.step(
            raw,
            StepTiming {
                time_us: device_time_us as u32,
                loop_exec_us: last_exec_us,
                loop_jitter_us: jitter_us,
            },
        );
        let step_us = step_clock.elapsed_us();
        let stall_us = self.board.stall_us(period_us);
        if stall_us > 0 {
            stall(stall_us);
        }
        let driven_ma = self.board.after_step(
            &mut self.device,
            device_time_us as u32,
            step_us + stall_us,
            period_us,
            result.current_ma,
        );
        let handle = self.handle_condition();
        let period_s = period_us as f64 * 1e-6;
        self.last_currents_ma = driven_ma.map(|c| c as f64);
        let mut at_converters = self.board.converter_currents(self.last_currents_ma);
        for m in &self.miswiring {
            at_converters = m.at_converters(at_converters);
            if let Some((c, tau_s)) = m.converter_lag() {
                let a = 1.0 - (-period_s / tau_s).exp();
                self.lagged_ma[c] += a * (at_converters[c] - self.lagged_ma[c]);
                at_converters[c] = self.lagged_ma[c];
            }
        }
        self.last = self.twin.step(period_s, at_converters, &handle);
        self.t_s += period_s;
        result
    }

    /// Applies `injection` from the coming period on and reports it.
    pub(crate) fn inject(&mut self, injection: Injection, device_time_us: u64) {
        if injection == Injection::HandleRelease {
            self.handle_mode = HandleMode::Free;
        }
        self.board
            .inject(injection, &self.last, self.last_currents_ma);
        let _ = self.reports.send(format!(
            "injected {injection:?} at time_us={}",
            device_time_us as u32
        ));
    }

    pub(crate) fn raw_sensors(&self) -> RawSensors {
        let mut seen = self.board.sensors(self.last);
        let lc = self.twin.config().params.load_cell;
        for m in &self.miswiring {
            seen.encoder_counts = m.encoder_counts(seen.encoder_counts);
            seen.loadcell_v = m.loadcell_v(seen.loadcell_v, lc.offset_v, lc.gain_n_per_v);
        }
        let counts = seen
            .encoder_counts
            .map(|c| (c + ENCODER_POWER_ON_COUNTS) as u32);
        RawSensors {
            encoder_counts: counts,
            loadcell_volts: seen.loadcell_v.map(|v| v as f32),
        }
    }

    /// What holds the handle during the coming period.
    pub(crate) fn handle_condition(&mut self) -> HandleCondition {
        let state = self.device.controller().state();
        let mode = self.device.controller().mode();
        if (state, mode) != self.last_mode {
            self.last_mode = (state, mode);
            self.since_s = self.t_s;
            self.hold_point = match mode {
                Mode::Joint { alpha_rad, .. } => self
                    .model
                    .kinematics
                    .forward_user([alpha_rad[0] as f64, alpha_rad[1] as f64]),
                Mode::Impedance { target_user_m, .. } => {
                    [target_user_m[0] as f64, target_user_m[1] as f64]
                }
                _ => self.twin.state().handle_user_m,
            };
        }
        let armed = state == State::Armed;
        let force = matches!(mode, Mode::Force { .. } | Mode::ForceClosedLoop { .. });
        let pressures = matches!(mode, Mode::Pressures { .. });
        self.blocked_this_arming = armed && (force || (pressures && self.blocked_this_arming));
        // the operator moves the handle about the joint or the impedance target
        let joint = matches!(mode, Mode::Joint { .. } | Mode::Impedance { .. });
        match self.handle_mode {
            HandleMode::Free => HandleCondition::Free,
            HandleMode::Blocked if armed && (force || self.blocked_this_arming) => {
                HandleCondition::Blocked
            }
            HandleMode::Blocked => HandleCondition::Free,
            HandleMode::Held if armed => HandleCondition::held_at(self.hold_point),
            HandleMode::Held => HandleCondition::Free,
            HandleMode::HeldRelaxed if armed => HandleCondition::Hand(HandSpring {
                target_user_m: self.hold_point,
                target_velocity_user_m_s: [0.0; 2],
                stiffness_n_per_m: RELAXED_HAND_N_PER_M,
                damping_n_s_per_m: RELAXED_HAND_N_S_PER_M,
            }),
            HandleMode::HeldRelaxed => HandleCondition::Free,
            HandleMode::Operator if armed && force => HandleCondition::Blocked,
            HandleMode::Operator if armed && joint => {
                let t = self.t_s - self.since_s - OPERATOR_HOLD_S;
                match &self.path {
                    Some(path) if t > 0.0 => {
                        let (p, v) = path.at(t);
                        let c = self.hold_point;
                        HandleCondition::moved([c[0] + p[0], c[1] + p[1]], v)
                    }
                    _ => HandleCondition::held_at(self.hold_point),
                }
            }
            HandleMode::Operator => HandleCondition::Free,
        }
    }
}

/// A number for the device's session tokens that differs at every start of the emulator, as
/// the board's random number generator draws one at every boot: std's hasher keys come
/// from the operating system's randomness.
fn boot_nonce() -> u32 {
    use std::hash::BuildHasher;
    let state = std::collections::hash_map::RandomState::new();
    state.hash_one(std::time::SystemTime::now()) as u32
}

#[cfg(test)]
mod tests {
    use super::Plant;
    use crate::{Miswire, SimConfig};

    #[test]
    fn an_arm_off_its_zero_rests_there_until_armed() {
        let config = SimConfig {
            miswiring: vec![Miswire::parse("encoder_zero:joint=1,deg=3").unwrap()],
            ..SimConfig::default()
        };
        let (tx, _rx) = std::sync::mpsc::channel();
        let mut plant = Plant::new(&config, tx).unwrap();
        let period_us = plant.device.period_us();
        for k in 0..2000u64 {
            plant.period(period_us, k * u64::from(period_us), 0, 0, |_| {});
        }
        // vented for 2 s: where the procedure homes it, still 3° off the neutral pose
        let alpha = plant.twin.state().alpha_rad;
        assert!((alpha[0].to_degrees() - 3.0).abs() < 0.5, "{alpha:?}");
        assert!(alpha[1].abs() < 0.01, "{alpha:?}");
    }
}
