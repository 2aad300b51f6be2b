//! Checks of every request and error path of the device service, run by `cargo test` on
//! the host and on the Cortex-M4F under QEMU (`qemu-tests/`).

use crate::*;
use pam_model::kinematics::Kinematics;

pub use pam_model::checks::{Check, CheckResult, Failure};

use pam_model::checks::{holds_that as holds, near_f32 as near};

const OPTIONS: DeviceOptions = DeviceOptions {
    firmware_version: Version {
        major: 0,
        minor: 1,
        patch: 0,
    },
    encoder_counter_bits: 16,
};

fn device() -> Device {
    Device::new(RobotParams::thesis(), SafetyConfig::default_1khz(), OPTIONS)
}

/// Encoders at `counts`, load cell near zero with the dither a live ADC has.
fn raw(counts: [u32; 2], k: u32) -> RawSensors {
    let d = if k.is_multiple_of(2) { 0.001 } else { -0.001 };
    RawSensors {
        encoder_counts: counts,
        loadcell_volts: [0.02 + d, -0.01],
    }
}

const HOME: [u32; 2] = [1000, 2000];

fn request(d: &mut Device, body: RequestBody) -> Result<ReplyData, ErrorCode> {
    let reply = d.handle(&Request { id: 77, body });
    if reply.id != 77 {
        return Err(ErrorCode::Malformed);
    }
    reply.result
}

fn done(d: &mut Device, body: RequestBody) -> CheckResult {
    holds("request done", request(d, body) == Ok(ReplyData::Done))
}

fn refused(d: &mut Device, body: RequestBody, code: ErrorCode) -> CheckResult {
    holds(
        "request refused with its code",
        request(d, body) == Err(code),
    )
}

fn steps(d: &mut Device, n: u32, start: u32) -> StepResult {
    let mut out = d.step(raw(HOME, start), StepTiming::default());
    for k in 1..n {
        out = d.step(raw(HOME, start + k), StepTiming::default());
    }
    out
}

/// Like [`steps`], with the host's heartbeat every 10 periods.
fn steps_alive(d: &mut Device, n: u32, start: u32) -> StepResult {
    let mut out = d.step(raw(HOME, start), StepTiming::default());
    for k in 1..n {
        if k % 10 == 0 {
            d.handle(&Request {
                id: 1,
                body: RequestBody::Heartbeat,
            });
        }
        out = d.step(raw(HOME, start + k), StepTiming::default());
    }
    out
}

/// Stepped once, homed, armed.
fn armed_device() -> Result<Device, Failure> {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    Ok(d)
}

fn status(d: &mut Device) -> Result<Status, Failure> {
    match request(d, RequestBody::GetStatus) {
        Ok(ReplyData::Status(s)) => Ok(s),
        _ => Err(Failure {
            what: "GetStatus answers a status",
            got: 0.0,
            expected: 1.0,
            tolerance: 0.0,
            index: 0,
        }),
    }
}

fn config(d: &mut Device, s: ConfigSection) -> Result<Config, Failure> {
    match request(d, RequestBody::GetConfig(s)) {
        Ok(ReplyData::Config(c)) => Ok(c),
        _ => Err(Failure {
            what: "GetConfig answers a config",
            got: 0.0,
            expected: 1.0,
            tolerance: 0.0,
            index: 0,
        }),
    }
}

pub fn boots_disarmed_unhomed_and_vented() -> CheckResult {
    let mut d = device();
    let out = steps(&mut d, 1, 0);
    holds("vent currents", out.current_ma.iter().all(|&i| i == 4.0))?;
    let t = out.telemetry.ok_or(Failure {
        what: "telemetry at boot",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })?;
    holds("seq starts at 0", t.seq == 0)?;
    holds(
        "disarmed",
        t.state == State::Disarmed && t.mode == ModeKind::Idle,
    )?;
    let s = status(&mut d)?;
    holds(
        "not homed",
        !s.homed && s.period_us == 1000 && s.telemetry_divider == 1,
    )
}

pub fn hello_answers_versions_and_refuses_another_protocol() -> CheckResult {
    let mut d = device();
    match request(
        &mut d,
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
        },
    ) {
        Ok(ReplyData::Hello(info)) => {
            holds(
                "protocol version",
                info.protocol_version == PROTOCOL_VERSION,
            )?;
            holds(
                "firmware version",
                info.firmware_version == OPTIONS.firmware_version,
            )?;
            holds("period", info.period_us == 1000)?;
            holds(
                "params hash",
                info.params_hash == pam_protocol::params_hash(&RobotParams::thesis()),
            )?;
        }
        _ => holds("hello answered", false)?,
    }
    refused(
        &mut d,
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION + 1,
        },
        ErrorCode::UnsupportedVersion,
    )
}

pub fn arm_needs_homing_and_disarm_vents() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    refused(&mut d, RequestBody::Arm, ErrorCode::NotHomed)?;
    holds("still disarmed", d.controller().state() == State::Disarmed)?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    refused(&mut d, RequestBody::Arm, ErrorCode::WrongState)?;
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Pressures {
                pressure_bar: [2.0; 4],
            }
            .into(),
        ),
    )?;
    let out = steps_alive(&mut d, 50, 1);
    holds("pressurised", out.current_ma.iter().all(|&i| i > 9.0))?;
    done(&mut d, RequestBody::Disarm)?;
    let out = steps(&mut d, 1, 60);
    holds("vented at once", out.current_ma.iter().all(|&i| i == 4.0))
}

pub fn home_zeroes_the_angle_and_is_refused_while_armed() -> CheckResult {
    let mut d = device();
    let t = steps(&mut d, 1, 0)
        .telemetry
        .unwrap_or_else(unreachable_telemetry);
    holds("boot position is the origin", t.alpha_rad == [0.0, 0.0])?;
    // move slowly (10 counts per ms = 7.9 rad/s, below the encoder-jump speed)
    let mut t = None;
    for k in 1..=8 {
        t = d
            .step(
                raw([HOME[0] + 10 * k, HOME[1] - 5 * k], k),
                StepTiming::default(),
            )
            .telemetry;
    }
    let moved = [HOME[0] + 80, HOME[1] - 40];
    let a = t.map(|t| t.alpha_rad).unwrap_or([9.0; 2]);
    let per_count = 2.0 * core::f32::consts::PI / 8000.0;
    near(
        "alpha1 before homing",
        a[0],
        (moved[0] - HOME[0]) as f32 * per_count,
        1e-6,
    )?;
    done(&mut d, RequestBody::Home)?;
    let t = d.step(raw(moved, 9), StepTiming::default()).telemetry;
    holds(
        "homed position reads zero",
        t.map(|t| t.alpha_rad) == Some([0.0, 0.0]),
    )?;
    holds(
        "homing is no encoder jump",
        d.controller().faults().is_none(),
    )?;
    done(&mut d, RequestBody::Arm)?;
    refused(&mut d, RequestBody::Home, ErrorCode::WrongState)
}

fn unreachable_telemetry() -> Telemetry {
    Telemetry {
        seq: u32::MAX,
        time_us: 0,
        alpha_rad: [f32::NAN; 2],
        force_user_n: [f32::NAN; 2],
        force_ref_n: None,
        current_ma: [f32::NAN; 4],
        pressure_cmd_bar: [f32::NAN; 4],
        mode: ModeKind::Idle,
        state: State::Faulted.into(),
        faults: u16::MAX,
        limited: 0,
        loop_exec_us: 0,
        loop_jitter_us: 0,
    }
}

pub fn encoder_counts_survive_counter_wrap_both_ways() -> CheckResult {
    for bits in [16u8, 32] {
        let mut e = frontend::Encoders::new(bits, [EncoderCalibration::default(); 2]);
        let top = if bits == 16 { 0xFFFF } else { u32::MAX };
        let mut raw_counts = [top - 25, 30u32];
        e.update(raw_counts);
        // 60 periods of +7 counts on joint 1 (wraps forward), −3 on joint 2 (wraps back)
        for _ in 0..60 {
            raw_counts = [
                raw_counts[0].wrapping_add(7) & top,
                raw_counts[1].wrapping_sub(3) & top,
            ];
            e.update(raw_counts);
        }
        holds("no count lost on wrap", e.position_counts() == [420, -180])?;
    }
    Ok(())
}

pub fn encoder_calibration_sets_scale_and_sign() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    let mut cal = d.calibration();
    cal.encoder = [
        EncoderCalibration {
            counts_per_rev: 4000,
            sign: -1,
        },
        EncoderCalibration {
            counts_per_rev: 10_000,
            sign: 1,
        },
    ];
    done(&mut d, RequestBody::SetConfig(Config::Calibration(cal)))?;
    let t = d
        .step(
            raw([HOME[0] + 100, HOME[1] + 100], 1),
            StepTiming::default(),
        )
        .telemetry;
    let a = t.map(|t| t.alpha_rad).unwrap_or([9.0; 2]);
    let tau = 2.0 * core::f32::consts::PI;
    near(
        "joint 1: −100 counts of 4000",
        a[0],
        -100.0 * tau / 4000.0,
        1e-6,
    )?;
    near(
        "joint 2: 100 counts of 10000",
        a[1],
        100.0 * tau / 10_000.0,
        1e-6,
    )
}

pub fn loadcell_volts_become_user_frame_newtons_and_tare_zeroes_them() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    done(&mut d, RequestBody::Home)?;
    let volts = [0.9, -0.6];
    let r = RawSensors {
        encoder_counts: HOME,
        loadcell_volts: volts,
    };
    let t = d.step(r, StepTiming::default()).telemetry;
    let f = t.map(|t| t.force_user_n).unwrap_or([f32::NAN; 2]);
    let model = d.controller().model();
    let sensor = [0.9 / 0.09, -0.6 / 0.06];
    let expected = Kinematics::sensor_to_user_at(&model.kinematics.trig([0.0, 0.0]), sensor);
    near("fx", f[0], expected[0], 1e-3)?;
    near("fy", f[1], expected[1], 1e-3)?;
    done(&mut d, RequestBody::Tare)?;
    let t = d.step(r, StepTiming::default()).telemetry;
    let f = t.map(|t| t.force_user_n).unwrap_or([f32::NAN; 2]);
    holds("tared force is zero", f == [0.0, 0.0])?;
    match config(&mut d, ConfigSection::Calibration)? {
        Config::Calibration(c) => {
            holds("tare is in the calibration", c.load_cell.offset_v == volts)?
        }
        _ => holds("calibration section", false)?,
    }
    done(&mut d, RequestBody::Arm)?;
    refused(&mut d, RequestBody::Tare, ErrorCode::WrongState)
}

pub fn tare_before_any_sample_is_refused() -> CheckResult {
    let mut d = device();
    refused(&mut d, RequestBody::Tare, ErrorCode::WrongState)?;
    refused(&mut d, RequestBody::ClearFaults, ErrorCode::WrongState)
}

pub fn out_of_range_mode_is_refused_and_nothing_changes() -> CheckResult {
    let mut d = armed_device()?;
    let good = Mode::Pressures {
        pressure_bar: [1.0, 2.0, 3.0, 2.5],
    };
    done(&mut d, RequestBody::SetMode(good.into()))?;
    for bad in [
        Mode::Pressures {
            pressure_bar: [1.0, 2.0, 5.5, 2.5],
        },
        Mode::Pressures {
            pressure_bar: [f32::NAN, 2.0, 3.0, 2.5],
        },
        Mode::Joint {
            alpha_rad: [1.0, 0.0],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [60.0, 27.0],
        },
        Mode::Force {
            force_n: [1000.0, 0.0],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
        },
    ] {
        refused(
            &mut d,
            RequestBody::SetMode(bad.into()),
            ErrorCode::OutOfRange,
        )?;
    }
    holds("mode unchanged", d.controller().mode() == good)?;
    holds("still armed", d.controller().state() == State::Armed)
}

pub fn each_mode_reaches_the_outputs() -> CheckResult {
    let mut d = armed_device()?;
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Pressures {
                pressure_bar: [1.0, 2.0, 3.0, 2.5],
            }
            .into(),
        ),
    )?;
    let out = steps_alive(&mut d, 200, 1);
    let t = out.telemetry.unwrap_or_else(unreachable_telemetry);
    near("channel 3 pressure", t.pressure_cmd_bar[2], 3.0, 1e-5)?;
    holds(
        "pressures mode",
        t.mode == ModeKind::Pressures && t.force_ref_n.is_none(),
    )?;
    let ip = &d.controller().model().params.ip;
    near(
        "channel 3 current",
        out.current_ma[2],
        (3.0 - ip.offset_bar) / ip.gain_bar_per_ma,
        1e-3,
    )?;

    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Joint {
                alpha_rad: [0.0, 0.0],
                torque_nm: [0.0, 0.0],
                stiffness_nm_per_rad: [60.0, 27.0],
            }
            .into(),
        ),
    )?;
    let t = steps_alive(&mut d, 200, 300)
        .telemetry
        .unwrap_or_else(unreachable_telemetry);
    holds(
        "joint mode",
        t.mode == ModeKind::Joint && t.state == State::Armed,
    )?;
    let p = t.pressure_cmd_bar;
    // zero torque at the neutral pose: both muscles of a pair at the same pressure
    near("joint 1 pair balanced", p[0], p[1], 1e-3)?;
    near("joint 2 pair balanced", p[2], p[3], 1e-3)?;

    let force = [9.1, -4.0];
    done(
        &mut d,
        RequestBody::SetMode(
            Mode::Force {
                force_n: force,
                stiffness_nm_per_rad: [60.0, 27.0],
                feed_forward: true,
            }
            .into(),
        ),
    )?;
    let t = steps_alive(&mut d, 200, 600)
        .telemetry
        .unwrap_or_else(unreachable_telemetry);
    holds(
        "force mode with feed-forward",
        t.mode == ModeKind::ForceFeedForward,
    )?;
    holds("force reference reported", t.force_ref_n == Some(force))?;
    holds("no fault", t.faults == 0 && t.state == State::Armed)
}

pub fn get_config_returns_every_section() -> CheckResult {
    let mut d = device();
    holds(
        "robot",
        config(&mut d, ConfigSection::Robot)? == Config::Robot(RobotParams::thesis().into()),
    )?;
    holds(
        "limits",
        config(&mut d, ConfigSection::Limits)?
            == Config::Limits(SafetyConfig::default_1khz().into()),
    )?;
    holds(
        "calibration",
        config(&mut d, ConfigSection::Calibration)? == Config::Calibration(d.calibration()),
    )
}

pub fn invalid_robot_parameters_are_refused_and_nothing_changes() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let before = config(&mut d, ConfigSection::Robot)?;
    let thesis = RobotParams::<f32>::thesis();
    let mut over_pressure = thesis;
    over_pressure.pressure.max_bar = 6.0;
    let mut nan = thesis;
    nan.muscle.passive_n[2] = f32::NAN;
    let mut bad_map = thesis;
    bad_map.joints[1].channel_of_muscle = [0, 1];
    let mut bad_cell = thesis;
    bad_cell.load_cell.gain_n_per_v[0] = 0.0;
    for p in [over_pressure, nan, bad_map, bad_cell] {
        refused(
            &mut d,
            RequestBody::SetConfig(Config::Robot(p.into())),
            ErrorCode::OutOfRange,
        )?;
    }
    holds("unchanged", config(&mut d, ConfigSection::Robot)? == before)?;
    let mut good = thesis;
    good.joints[0].pulley_radius_m = 0.072;
    done(&mut d, RequestBody::SetConfig(Config::Robot(good.into())))?;
    holds(
        "applied",
        d.controller().model().params.joints[0].pulley_radius_m == 0.072,
    )?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Robot(thesis.into())),
        ErrorCode::WrongState,
    )
}

pub fn invalid_calibration_is_refused_and_output_calibration_applies() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let good = d.calibration();
    let mut bad_sign = good;
    bad_sign.encoder[0].sign = 0;
    let mut bad_cpr = good;
    bad_cpr.encoder[1].counts_per_rev = 0;
    let mut bad_gain = good;
    bad_gain.output[2].gain = 3.0;
    let mut bad_offset = good;
    bad_offset.output[0].offset_ma = f32::INFINITY;
    for c in [bad_sign, bad_cpr, bad_gain, bad_offset] {
        refused(
            &mut d,
            RequestBody::SetConfig(Config::Calibration(c)),
            ErrorCode::OutOfRange,
        )?;
    }
    holds("unchanged", d.calibration() == good)?;
    let mut trimmed = good;
    trimmed.output[1] = OutputCalibration {
        gain: 1.0,
        offset_ma: 0.25,
    };
    trimmed.output[2] = OutputCalibration {
        gain: 0.9,
        offset_ma: 0.0,
    };
    done(&mut d, RequestBody::SetConfig(Config::Calibration(trimmed)))?;
    let out = steps(&mut d, 1, 1);
    near("offset trim", out.current_ma[1], 4.25, 1e-6)?;
    // 0.9 × 4 mA = 3.6 mA is below the loop range: clamped to 4 mA
    near("clamped to the loop range", out.current_ma[2], 4.0, 1e-6)?;
    let t = out.telemetry.unwrap_or_else(unreachable_telemetry);
    holds("telemetry reports the loop current", t.current_ma[1] == 4.0)
}

pub fn limits_are_validated_and_the_period_is_fixed_while_armed() -> CheckResult {
    let mut d = device();
    steps(&mut d, 1, 0);
    let mut slow = SafetyConfig::default_1khz();
    slow.period_s = 0.020;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(slow.into())),
        ErrorCode::OutOfRange,
    )?;
    let mut no_timeout = SafetyConfig::default_1khz();
    no_timeout.command_timeout_s = f32::NAN;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(no_timeout.into())),
        ErrorCode::OutOfRange,
    )?;
    holds("period unchanged", d.period_us() == 1000)?;
    let mut two_ms = SafetyConfig::default_1khz();
    two_ms.period_s = 0.002;
    done(
        &mut d,
        RequestBody::SetConfig(Config::Limits(two_ms.into())),
    )?;
    holds("period 2 ms", d.period_us() == 2000)?;
    done(&mut d, RequestBody::Home)?;
    done(&mut d, RequestBody::Arm)?;
    refused(
        &mut d,
        RequestBody::SetConfig(Config::Limits(SafetyConfig::default_1khz().into())),
        ErrorCode::WrongState,
    )?;
    let mut slower_slew = two_ms;
    slower_slew.slew_bar_per_s = 20.0;
    done(
        &mut d,
        RequestBody::SetConfig(Config::Limits(slower_slew.into())),
    )
}

pub fn telemetry_divider_and_sequence() -> CheckResult {
    let mut d = device();
    done(&mut d, RequestBody::SetTelemetry { divider: 3 })?;
    let mut sent = 0u32;
    for k in 0..30 {
        if let Some(t) = d.step(raw(HOME, k), StepTiming::default()).telemetry {
            holds("seq counts frames", t.seq == sent)?;
            holds("on the divider", k % 3 == 0)?;
            sent += 1;
        }
    }
    holds("one frame in three", sent == 10)?;
    done(&mut d, RequestBody::SetTelemetry { divider: 0 })?;
    holds("off", steps(&mut d, 10, 40).telemetry.is_none())?;
    let timing = StepTiming {
        time_us: 123_456,
        loop_exec_us: 17,
        loop_jitter_us: 3,
    };
    done(&mut d, RequestBody::SetTelemetry { divider: 1 })?;
    let t = d.step(raw(HOME, 0), timing).telemetry;
    holds(
        "timing carried",
        t.map(|t| (t.seq, t.time_us, t.loop_exec_us, t.loop_jitter_us))
            == Some((10, 123_456, 17, 3)),
    )
}

pub fn any_request_is_a_heartbeat_and_silence_times_out() -> CheckResult {
    let mut d = armed_device()?;
    for k in 0..1000 {
        if k % 50 == 49 {
            request(&mut d, RequestBody::GetStatus).map_err(|_| Failure {
                what: "status",
                got: 0.0,
                expected: 1.0,
                tolerance: 0.0,
                index: k,
            })?;
        }
        d.step(raw(HOME, k), StepTiming::default());
    }
    holds(
        "alive while the host talks",
        d.controller().state() == State::Armed,
    )?;
    let mut events = 0;
    let mut first_at = 0;
    for k in 0..300 {
        if let Some(e) = d.step(raw(HOME, k), StepTiming::default()).fault_event {
            events += 1;
            first_at = k;
            holds(
                "timeout code",
                e.code == 0 && e.bits == Faults::COMMAND_TIMEOUT.0,
            )?;
        }
    }
    holds("one fault event", events == 1)?;
    near("timeout after 100 ms", first_at as f32, 100.0, 1.0)?;
    holds("faulted", d.controller().state() == State::Faulted)
}

pub fn faults_clear_only_when_gone() -> CheckResult {
    let mut d = armed_device()?;
    d.raise(Faults::WATCHDOG_RESET);
    let out = steps(&mut d, 1, 1);
    holds(
        "fault event",
        out.fault_event.map(|e| e.code) == Some(7) && out.current_ma.iter().all(|&i| i == 4.0),
    )?;
    refused(&mut d, RequestBody::Arm, ErrorCode::WrongState)?;
    done(&mut d, RequestBody::ClearFaults)?;
    holds(
        "cleared, disarmed",
        status(&mut d)?.faults == 0 && d.controller().state() == State::Disarmed,
    )?;
    // a saturated load cell that stays saturated cannot be cleared
    let sat = RawSensors {
        encoder_counts: HOME,
        loadcell_volts: [20.0, 0.0],
    };
    let ev = d.step(sat, StepTiming::default()).fault_event;
    holds("saturation event", ev.map(|e| e.code) == Some(4))?;
    refused(
        &mut d,
        RequestBody::ClearFaults,
        ErrorCode::FaultStillPresent,
    )?;
    steps(&mut d, 1, 2);
    done(&mut d, RequestBody::ClearFaults)
}

pub fn corrupted_frames_get_a_malformed_reply() -> CheckResult {
    let mut d = device();
    let r = d.handle_frame(Err(DecodeError::Crc));
    holds(
        "unknown id",
        r.id == UNKNOWN_REQUEST_ID && r.result == Err(ErrorCode::Malformed),
    )?;
    let r = d.handle_frame(Err(DecodeError::Message {
        leading_u16: Some(42),
    }));
    holds(
        "id echoed",
        r.id == 42 && r.result == Err(ErrorCode::Malformed),
    )?;
    let r = d.handle_frame(Ok(Request {
        id: 5,
        body: RequestBody::Heartbeat,
    }));
    holds(
        "good frame handled",
        r.id == 5 && r.result == Ok(ReplyData::Done),
    )
}

pub fn requests_survive_the_wire() -> CheckResult {
    // the same request through encode → byte stream → decoder → device → reply frame
    let mut d = device();
    let mut buf = [0u8; pam_protocol::MAX_FRAME];
    let req = Request {
        id: 9,
        body: RequestBody::GetConfig(ConfigSection::Robot),
    };
    let n = pam_protocol::encode_frame(&req, &mut buf).map_err(|_| Failure {
        what: "encode",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })?;
    let mut dec = pam_protocol::FrameDecoder::<Request>::new();
    let mut reply = None;
    for &b in &buf[..n] {
        if let Some(frame) = dec.push(b) {
            reply = Some(d.handle_frame(frame));
        }
    }
    let reply = reply.ok_or(Failure {
        what: "frame decoded",
        got: 0.0,
        expected: 1.0,
        tolerance: 0.0,
        index: 0,
    })?;
    let n = pam_protocol::encode_frame(&DeviceMessage::Reply(reply), &mut buf).unwrap_or(0);
    let mut dec = pam_protocol::FrameDecoder::<DeviceMessage>::new();
    let mut got = None;
    for &b in &buf[..n] {
        if let Some(Ok(m)) = dec.push(b) {
            got = Some(m);
        }
    }
    holds(
        "robot parameters came back",
        got == Some(DeviceMessage::Reply(Reply {
            id: 9,
            result: Ok(ReplyData::Config(Config::Robot(
                RobotParams::thesis().into(),
            ))),
        })),
    )
}

use pam_protocol::DeviceMessage;

pam_model::register_checks!(
    boots_disarmed_unhomed_and_vented,
    hello_answers_versions_and_refuses_another_protocol,
    arm_needs_homing_and_disarm_vents,
    home_zeroes_the_angle_and_is_refused_while_armed,
    encoder_counts_survive_counter_wrap_both_ways,
    encoder_calibration_sets_scale_and_sign,
    loadcell_volts_become_user_frame_newtons_and_tare_zeroes_them,
    tare_before_any_sample_is_refused,
    out_of_range_mode_is_refused_and_nothing_changes,
    each_mode_reaches_the_outputs,
    get_config_returns_every_section,
    invalid_robot_parameters_are_refused_and_nothing_changes,
    invalid_calibration_is_refused_and_output_calibration_applies,
    limits_are_validated_and_the_period_is_fixed_while_armed,
    telemetry_divider_and_sequence,
    any_request_is_a_heartbeat_and_silence_times_out,
    faults_clear_only_when_gone,
    corrupted_frames_get_a_malformed_reply,
    requests_survive_the_wire,
);
