//! Checks of every request and error path of the device service, run by `cargo test` on
//! the host and on the Cortex-M4F under QEMU (`qemu-tests/`).

use crate::*;
use pam_model::kinematics::Kinematics;

pub use pam_model::checks::{Check, CheckResult, Failure};

use pam_model::checks::{holds_that as holds, near_f32 as near};

/// The options of the device every check (and the QEMU bench and the host's property test)
/// starts from: firmware 0.1.0, 16-bit encoder counters, boot nonce 0.
pub const OPTIONS: DeviceOptions = DeviceOptions {
    firmware_version: Version {
        major: 0,
        minor: 1,
        patch: 0,
    },
    encoder_counter_bits: 16,
    boot_nonce: 0,
};

/// A device after the host's handshake: the host's session is [`SESSION`].
pub(crate) fn device() -> Device {
    let mut d = Device::new(RobotParams::thesis(), SafetyConfig::default_1khz(), OPTIONS);
    let hello = d.handle(&Request {
        id: 1,
        body: RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        },
        session: NO_SESSION,
    });
    debug_assert!(matches!(hello.result, Ok(ReplyData::Hello(i)) if i.session == SESSION));
    d
}

/// The session of the host in [`device`].
pub(crate) const SESSION: SessionId = 1;

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
    let reply = d.handle(&Request {
        id: 77,
        body,
        session: SESSION,
    });
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
                session: SESSION,
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

mod config;
mod lifecycle;
mod link;
mod modes;
mod sensors;
mod session;

pub use config::*;
pub use lifecycle::*;
pub use link::*;
pub use modes::*;
pub use sensors::*;
pub use session::*;

pam_model::register_checks!(
    boots_disarmed_unhomed_and_vented,
    hello_answers_versions_and_refuses_another_protocol,
    arm_needs_homing_and_disarm_vents,
    a_board_unsafe_in_reset_never_arms,
    home_zeroes_the_angle_and_is_refused_while_armed,
    encoder_counts_survive_counter_wrap_both_ways,
    encoder_calibration_sets_scale_and_sign,
    loadcell_volts_become_user_frame_newtons_and_tare_zeroes_them,
    tare_before_any_sample_is_refused,
    tare_under_load_is_refused,
    negative_load_cell_gain_is_refused,
    rehome_far_from_the_zero_is_refused,
    a_first_home_far_from_the_pressures_equilibrium_is_refused,
    out_of_range_mode_is_refused_and_nothing_changes,
    each_mode_reaches_the_outputs,
    get_config_returns_every_section,
    invalid_robot_parameters_are_refused_and_nothing_changes,
    invalid_calibration_is_refused_and_output_calibration_applies,
    the_channel_map_routes_the_outputs_and_must_be_a_permutation,
    limits_are_validated_and_the_period_is_fixed_while_armed,
    no_configuration_moves_the_safe_state_or_loosens_a_limit,
    telemetry_divider_and_sequence,
    arm_and_set_mode_need_a_session_of_this_schema,
    a_session_does_not_survive_a_reboot,
    only_the_commander_feeds_the_command_timeout,
    setting_the_mode_takes_the_command,
    pressures_mode_needs_the_service_interlock,
    faults_clear_only_when_gone,
    corrupted_frames_get_a_malformed_reply,
    requests_survive_the_wire,
);
