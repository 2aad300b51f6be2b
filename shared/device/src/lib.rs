//! The device service of the PAM robot: everything between the peripherals and the link
//! that does not depend on the hardware. The firmware and the emulator both run it, so
//! they share this logic literally.
//!
//! The firmware's whole job, per control period:
//!
//! ```text
//! let out = device.step(RawSensors { encoder_counts, loadcell_volts }, timing);
//! write out.current_ma to the four 4–20 mA stages;
//! queue out.telemetry / out.fault_event (if any) to the link.
//! ```
//!
//! and, per request frame received (bytes through a `pam_protocol::FrameDecoder<Request>`):
//!
//! ```text
//! let reply = device.handle_frame(decoded);   // or device.handle(&request)
//! send DeviceMessage::Reply(reply)
//! ```
//!
//! `Device` has one owner. On the firmware, the simplest safe wiring is to let the control
//! task own it: the link task decodes frames and queues the `Result<Request, DecodeError>`s
//! (a heapless channel), the control task handles at most a few per period before `step`
//! and queues the replies back. Costs on the Cortex-M4F (QEMU, `cargo xtask qemu-bench`):
//! `step` ≈ 2 100 instructions, the slowest requests ≈ 1 900 (`Hello`) and ≈ 3 800
//! (`SetConfig(Robot)`).
//!
//! `no_std`, no heap, no panic path. f32 throughout.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Per-channel loops index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

pub mod calibration;
pub mod channel_map;
pub mod frontend;
pub mod storage;
mod validate;

#[cfg(any(test, feature = "checks"))]
pub mod checks;
#[cfg(test)]
mod fuzz_seeds;

use frontend::Encoders;
use pam_control::{
    Controller, Faults, Mode, Reject, SafetyConfig, Sensors, State, MAX_LOOP_CURRENT_MA,
    VENT_CURRENT_MA,
};
use pam_model::{Real, RobotModel, RobotParams};
use pam_protocol::{
    Calibration, Config, ConfigOrigin, ConfigSection, DecodeError, DeviceInfo, EncoderCalibration,
    ErrorCode, FaultEvent, ModeKind, OutputCalibration, Reply, ReplyData, Request, RequestBody,
    SessionId, Status, Telemetry, Version, NO_SESSION, PROTOCOL_VERSION, SCHEMA_FINGERPRINT,
    UNKNOWN_REQUEST_ID,
};
pub use storage::{run_storage, BoardHealth, StorageDone, StorageJob};

/// One period's raw readings, as the peripherals give them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawSensors {
    /// Free-running encoder counter values (16- or 32-bit timers, see [`DeviceOptions`]).
    pub encoder_counts: [u32; 2],
    /// Load-cell channel voltages, sampled at the same instant.
    pub loadcell_volts: [f32; 2],
}

/// Timing of the period, measured by the firmware (DWT cycle counter) or the emulator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepTiming {
    pub time_us: u32,
    /// Execution time of the previous step.
    pub loop_exec_us: u16,
    /// |actual − nominal| start of this period.
    pub loop_jitter_us: u16,
}

/// What one period produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepResult {
    /// Setpoints for the four output stages (loop current after the output calibration).
    pub current_ma: [f32; 4],
    /// The sample to send, when the telemetry divider says so.
    pub telemetry: Option<Telemetry>,
    /// New faults latched this period.
    pub fault_event: Option<FaultEvent>,
}

/// Facts about the hardware the device runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceOptions {
    pub firmware_version: Version,
    /// Width of the encoder counters (16 or 32).
    pub encoder_counter_bits: u8,
    /// A number drawn at every boot (the MCU's random number generator; the emulator's
    /// operating system): the session tokens are the boot's handshakes masked by it, so a
    /// token a host kept from before a reset is refused after it, however many handshakes
    /// follow. 0 leaves the tokens 1, 2, 3… (tests).
    pub boot_nonce: u32,
}

/// Pressures above this are never allowed, whatever parameters the host sends (the
/// converters' range is 0–5 bar).
pub const ABSOLUTE_MAX_PRESSURE_BAR: f32 = 5.0;

pub struct Device {
    controller: Controller,
    encoders: Encoders,
    output_calibration: [OutputCalibration; 4],
    /// The output stage of each I/P channel (a permutation, validated at configuration).
    output_of_channel: [u8; 4],
    options: DeviceOptions,
    telemetry_divider: u16,
    periods_to_telemetry: u16,
    seq: u32,
    last_raw: Option<RawSensors>,
    last_sensors: Option<Sensors>,
    last_faults: Faults,
    /// Where the configuration came from (boot or restore), and whether it changed since.
    config_origin: ConfigOrigin,
    config_unsaved: bool,
    board: BoardHealth,
    /// Handshakes since boot (`Hello` replies): the tokens of 1..=`sessions_issued`, masked
    /// by the boot's nonce, are sessions.
    sessions_issued: u32,
    /// The session whose control requests feed the command timeout ([`NO_SESSION`]: none).
    commander: SessionId,
    /// The pressures mode's service interlock.
    service_mode: bool,
}

impl Device {
    /// Boots disarmed, not homed, vented, telemetry at every period. Parameters the model
    /// refuses, or pressure limits beyond [`ABSOLUTE_MAX_PRESSURE_BAR`], fall back to the
    /// thesis values (the device must boot whatever is stored).
    pub fn new(params: RobotParams<f32>, safety: SafetyConfig, options: DeviceOptions) -> Self {
        let params = if validate::robot_params(&params).is_ok()
            && calibration::load_cell_gain_plausible(&params.load_cell)
        {
            params
        } else {
            RobotParams::thesis()
        };
        let safety = if safety.validate().is_ok() {
            safety
        } else {
            SafetyConfig::default_1khz()
        };
        Device {
            controller: Controller::new(RobotModel::new(params), safety),
            encoders: Encoders::new(
                options.encoder_counter_bits,
                [EncoderCalibration::default(); 2],
            ),
            output_calibration: [OutputCalibration::default(); 4],
            output_of_channel: pam_protocol::IDENTITY_CHANNEL_MAP,
            options,
            telemetry_divider: 1,
            periods_to_telemetry: 1,
            seq: 0,
            last_raw: None,
            last_sensors: None,
            last_faults: Faults::NONE,
            config_origin: ConfigOrigin::DefaultsNoStorage,
            config_unsaved: false,
            board: BoardHealth::default(),
            sessions_issued: 0,
            commander: NO_SESSION,
            service_mode: false,
        }
    }

    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// The control period the firmware must run at (it may change with `SetConfig(Limits)`).
    pub fn period_us(&self) -> u32 {
        (self.controller.safety().period_s * 1.0e6 + 0.5) as u32
    }

    pub fn homed(&self) -> bool {
        self.encoders.homed()
    }

    /// The firmware reports a hardware fault (watchdog reset, open current loop).
    pub fn raise(&mut self, fault: Faults) {
        self.controller.raise(fault);
    }

    pub fn calibration(&self) -> Calibration {
        Calibration {
            encoder: self.encoders.calibration(),
            load_cell: self.controller.model().params.load_cell.into(),
            output: self.output_calibration,
            output_of_channel: self.output_of_channel,
        }
    }

    /// One control period: sensors in, outputs out. Never panics.
    pub fn step(&mut self, raw: RawSensors, timing: StepTiming) -> StepResult {
        let sensors = Sensors {
            alpha_rad: self.encoders.update(raw.encoder_counts),
            force_sensor_n: self
                .controller
                .model()
                .params
                .load_cell
                .forces_n(raw.loadcell_volts),
        };
        self.last_raw = Some(raw);
        self.last_sensors = Some(sensors);
        if self.board.board_checks != 0 {
            self.controller.raise(Faults::SELF_CHECK);
        }
        let out = self.controller.step(&sensors);
        if out.state == State::Faulted {
            self.service_mode = false;
        }
        // the arm rested far from the pressures' equilibrium: the home is wrong
        if self.controller.home_check().refused() {
            self.encoders.forget_home();
        }

        // the safe state is the fixed vent current, untrimmed; a trimmed command stays
        // within the loop range (clamp_to cannot panic and maps NaN to the low end)
        let vent = self.controller.outputs_vented();
        // each channel's current leaves through the output stage wired to its converter
        let current_ma = channel_map::route(
            self.output_of_channel,
            out.current_ma,
            &self.output_calibration,
            |cal, i| {
                if vent || i <= VENT_CURRENT_MA {
                    VENT_CURRENT_MA
                } else {
                    (cal.gain * i + cal.offset_ma).clamp_to(VENT_CURRENT_MA, MAX_LOOP_CURRENT_MA)
                }
            },
            VENT_CURRENT_MA,
        );

        let new_faults = out.faults.0 & !self.last_faults.0;
        self.last_faults = out.faults;
        let fault_event = (new_faults != 0).then(|| FaultEvent {
            code: new_faults.trailing_zeros() as u8,
            bits: out.faults.0,
        });

        let telemetry = if self.telemetry_divider == 0 {
            None
        } else {
            self.periods_to_telemetry = self.periods_to_telemetry.saturating_sub(1);
            if self.periods_to_telemetry == 0 {
                self.periods_to_telemetry = self.telemetry_divider;
                let mode = self.controller.mode();
                let t = Telemetry {
                    seq: self.seq,
                    time_us: timing.time_us,
                    alpha_rad: sensors.alpha_rad,
                    force_user_n: out.force_user_n,
                    force_ref_n: match mode {
                        Mode::Force { force_n, .. } | Mode::ForceClosedLoop { force_n, .. } => {
                            Some(force_n)
                        }
                        _ => None,
                    },
                    current_ma: out.current_ma,
                    pressure_cmd_bar: out.pressure_bar,
                    mode: ModeKind::of(&mode),
                    state: out.state.into(),
                    faults: out.faults.0,
                    limited: out.limited_byte(),
                    loop_exec_us: timing.loop_exec_us,
                    loop_jitter_us: timing.loop_jitter_us,
                };
                self.seq = self.seq.wrapping_add(1);
                Some(t)
            } else {
                None
            }
        };
        StepResult {
            current_ma,
            telemetry,
            fault_event,
        }
    }

    /// The reply to whatever came out of the frame decoder: a request is handled, a
    /// corrupted frame gets `Malformed` (with its id if that much was readable).
    pub fn handle_frame(&mut self, frame: Result<Request, DecodeError>) -> Reply {
        match frame {
            Ok(request) => self.handle(&request),
            Err(e) => Reply {
                id: match e {
                    DecodeError::Message {
                        leading_u16: Some(id),
                    } => id,
                    _ => UNKNOWN_REQUEST_ID,
                },
                result: Err(ErrorCode::Malformed),
            },
        }
    }

    /// Carries out one request; a refused one changes nothing. Only the commander's control
    /// requests (`Arm`, `SetMode`, `Heartbeat`) keep the command timeout fed: whoever else
    /// talks to the device (status, telemetry, another host) cannot keep an arm alive
    /// whose commander has gone.
    pub fn handle(&mut self, request: &Request) -> Reply {
        let result = self.execute(&request.body, request.session);
        Reply {
            id: request.id,
            result,
        }
    }

    /// The session of the commander (the last to arm or set the mode), [`NO_SESSION`] if
    /// none.
    pub fn commander(&self) -> SessionId {
        self.commander
    }

    pub fn service_mode(&self) -> bool {
        self.service_mode
    }

    fn session_valid(&self, session: SessionId) -> bool {
        let count = session ^ self.options.boot_nonce;
        session != NO_SESSION && count != 0 && count <= self.sessions_issued
    }

    /// The next handshake's token: its count masked by the boot's nonce, never
    /// [`NO_SESSION`] (the one count the mask would turn into it is skipped).
    fn issue_session(&mut self) -> SessionId {
        self.sessions_issued = self.sessions_issued.saturating_add(1);
        if self.sessions_issued ^ self.options.boot_nonce == NO_SESSION {
            self.sessions_issued = self.sessions_issued.saturating_add(1);
        }
        self.sessions_issued ^ self.options.boot_nonce
    }

    /// A control request of `session`: it becomes the commander and feeds the timeout.
    fn take_command(&mut self, session: SessionId) -> Result<(), ErrorCode> {
        if !self.session_valid(session) {
            return Err(ErrorCode::NoSession);
        }
        self.commander = session;
        Ok(())
    }

    fn execute(&mut self, body: &RequestBody, session: SessionId) -> Result<ReplyData, ErrorCode> {
        const DONE: Result<ReplyData, ErrorCode> = Ok(ReplyData::Done);
        let armed = self.controller.state() == State::Armed;
        match *body {
            RequestBody::Hello {
                protocol_version,
                schema_fingerprint,
            } => {
                if protocol_version != PROTOCOL_VERSION {
                    return Err(ErrorCode::UnsupportedVersion);
                }
                if schema_fingerprint != SCHEMA_FINGERPRINT {
                    return Err(ErrorCode::SchemaMismatch);
                }
                // a new session never takes the command: it is only allowed to ask for it
                let session = self.issue_session();
                Ok(ReplyData::Hello(DeviceInfo {
                    protocol_version: PROTOCOL_VERSION,
                    schema_fingerprint: SCHEMA_FINGERPRINT,
                    firmware_version: self.options.firmware_version,
                    period_us: self.period_us(),
                    params_hash: pam_protocol::params_hash(&self.controller.model().params),
                    session,
                }))
            }
            RequestBody::Heartbeat => {
                if armed && (session == NO_SESSION || session != self.commander) {
                    return Err(ErrorCode::NotCommander);
                }
                self.controller.heartbeat();
                DONE
            }
            RequestBody::Arm => {
                if !self.session_valid(session) {
                    return Err(ErrorCode::NoSession);
                }
                if !self.encoders.homed() {
                    return Err(ErrorCode::NotHomed);
                }
                self.controller.arm().map_err(error_code)?;
                self.take_command(session)?;
                DONE
            }
            RequestBody::Disarm => {
                self.controller.disarm();
                self.commander = NO_SESSION;
                self.service_mode = false;
                DONE
            }
            RequestBody::TakeCommand => {
                if !armed {
                    return Err(ErrorCode::WrongState);
                }
                self.take_command(session)?;
                self.controller.heartbeat();
                DONE
            }
            RequestBody::SetServiceMode { enabled } => {
                if !self.session_valid(session) {
                    return Err(ErrorCode::NoSession);
                }
                let in_pressures = matches!(self.controller.mode(), Mode::Pressures { .. });
                if enabled {
                    let idle = self.controller.mode() == Mode::Idle;
                    if armed && !idle && !in_pressures {
                        return Err(ErrorCode::WrongState);
                    }
                } else if in_pressures {
                    self.controller.set_mode(Mode::Idle).map_err(error_code)?;
                }
                self.service_mode = enabled;
                DONE
            }
            RequestBody::Home => {
                if armed {
                    return Err(ErrorCode::WrongState);
                }
                if self.encoders.homed()
                    && !calibration::rehome_plausible(self.encoders.alpha_rad())
                {
                    return Err(ErrorCode::Implausible);
                }
                self.controller.reset_angle_history().map_err(error_code)?;
                self.controller.judge_home().map_err(error_code)?;
                self.encoders.home();
                DONE
            }
            RequestBody::Tare => {
                let Some(raw) = self.last_raw.filter(|_| !armed) else {
                    return Err(ErrorCode::WrongState);
                };
                if !raw.loadcell_volts.iter().all(|v| v.is_finite()) {
                    return Err(ErrorCode::OutOfRange);
                }
                let mut cell = self.controller.model().params.load_cell;
                if !calibration::tare_plausible(&cell, raw.loadcell_volts) {
                    return Err(ErrorCode::Implausible);
                }
                cell.tare(raw.loadcell_volts);
                self.controller.set_load_cell(cell);
                self.config_unsaved = true;
                DONE
            }
            RequestBody::ClearFaults => {
                // a failing board check (an output stage unsafe in reset, a bad supply) is a
                // condition that persists: cleared, it would leave a period to arm in
                if self.board.board_checks != 0 {
                    return Err(ErrorCode::FaultStillPresent);
                }
                let sensors = self.last_sensors.ok_or(ErrorCode::WrongState)?;
                self.controller.clear_faults(&sensors).map_err(error_code)?;
                self.last_faults = Faults::NONE;
                DONE
            }
            RequestBody::GetStatus => Ok(ReplyData::Status(Status {
                state: self.controller.state().into(),
                mode: self.controller.mode().into(),
                faults: self.controller.faults().0,
                homed: self.encoders.homed(),
                period_us: self.period_us(),
                telemetry_divider: self.telemetry_divider,
                config: self.config_origin,
                config_unsaved: self.config_unsaved,
                board_checks: self.board.board_checks,
                vdda_v: self.board.vdda_v,
                stack: self.board.stack,
                last_cpu_fault: self.board.last_cpu_fault,
                service_mode: self.service_mode,
            })),
            RequestBody::SetMode(mode) => {
                if !self.session_valid(session) {
                    return Err(ErrorCode::NoSession);
                }
                let mode: Mode = mode.into();
                if matches!(mode, Mode::Pressures { .. }) && !self.service_mode {
                    return Err(ErrorCode::ServiceModeOff);
                }
                self.controller.set_mode(mode).map_err(error_code)?;
                self.take_command(session)?;
                DONE
            }
            RequestBody::GetConfig(section) => Ok(ReplyData::Config(match section {
                ConfigSection::Robot => Config::Robot(self.controller.model().params.into()),
                ConfigSection::Calibration => Config::Calibration(self.calibration()),
                ConfigSection::Limits => Config::Limits((*self.controller.safety()).into()),
            })),
            RequestBody::SetConfig(config) => {
                // while armed, the limits are the commander's (a change does not feed the timeout)
                if armed && session != self.commander {
                    return Err(ErrorCode::NotCommander);
                }
                self.set_config(&config, armed)?;
                self.config_unsaved = true;
                DONE
            }
            RequestBody::SetTelemetry { divider } => {
                self.telemetry_divider = divider;
                self.periods_to_telemetry = divider.min(1);
                DONE
            }
            // the caller has no store ([`Device::handle_with_store`] has one)
            RequestBody::PersistConfig | RequestBody::RestoreConfig | RequestBody::EraseConfig => {
                Err(ErrorCode::StorageFailed)
            }
        }
    }

    fn set_config(&mut self, config: &Config, armed: bool) -> Result<(), ErrorCode> {
        match config {
            Config::Robot(params) => {
                if armed {
                    return Err(ErrorCode::WrongState);
                }
                let params = RobotParams::<f32>::from(*params);
                validate::robot_params(&params)?;
                if !calibration::load_cell_gain_plausible(&params.load_cell) {
                    return Err(ErrorCode::Implausible);
                }
                self.controller
                    .set_model(RobotModel::new(params))
                    .map_err(error_code)?;
                // a new geometry may move the angle limits: start the jump check afresh
                self.controller.reset_angle_history().map_err(error_code)
            }
            Config::Calibration(cal) => {
                if armed {
                    return Err(ErrorCode::WrongState);
                }
                validate::calibration(cal)?;
                if !calibration::load_cell_gain_plausible(&cal.load_cell.into()) {
                    return Err(ErrorCode::Implausible);
                }
                self.encoders.set_calibration(cal.encoder);
                self.controller.set_load_cell(cal.load_cell.into());
                self.output_calibration = cal.output;
                self.output_of_channel = cal.output_of_channel;
                self.controller.reset_angle_history().map_err(error_code)
            }
            Config::Limits(safety) => {
                let safety = SafetyConfig::from(*safety);
                if armed && safety.period_s != self.controller.safety().period_s {
                    return Err(ErrorCode::WrongState);
                }
                self.controller.set_safety(safety).map_err(error_code)
            }
        }
    }
}

fn error_code(r: Reject) -> ErrorCode {
    match r {
        Reject::OutOfRange => ErrorCode::OutOfRange,
        Reject::WrongState => ErrorCode::WrongState,
        Reject::FaultStillPresent => ErrorCode::FaultStillPresent,
    }
}
