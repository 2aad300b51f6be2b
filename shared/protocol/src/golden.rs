//! Golden bytes: one fixed instance of every message variant and its exact postcard
//! encoding, written out. Any change of the wire layout (a field added, removed, reordered
//! or retyped in `messages.rs` or `wire/`) fails here, and so does the fingerprint golden.
//!
//! Updating after a deliberate change of the wire format:
//! 1. bump `PROTOCOL_VERSION` (once per change that reaches main);
//! 2. run `cargo test -p pam-protocol golden -- --nocapture`: each failure prints the new
//!    encoding; check it byte by byte (field order, varints, little-endian f32) and paste it;
//! 3. paste the new `SCHEMA_FINGERPRINT` printed by `the_schema_fingerprint_is_pinned`.
//!    The two goldens move together: a wire change that leaves either unchanged is a bug.
//!
//! Reading the bytes: integers are varints (7 bits a byte, low first: 300 = `ac 02`; `i8`
//! and `u8` are one raw byte), f32 is 4 bytes little-endian (1.0 = `00 00 80 3f`), bool one
//! byte, an enum's variant its index as a varint, `Option` a `00`/`01` tag, `Result` `00`
//! for `Ok`, `01` for `Err`; structs and arrays are their fields in order, no lengths.
//! The instances use 1.0, 2.0, 3.0… in field order, so the order can be read off the bytes.

use super::*;
use crate::wire;

/// Lowercase hex, a space between bytes.
fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn encode<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_PAYLOAD];
    postcard::to_slice(msg, &mut buf).expect("fits").to_vec()
}

/// f32 values 1.0, 2.0, … in order.
struct Counter(f32);
impl Counter {
    fn next(&mut self) -> f32 {
        self.0 += 1.0;
        self.0
    }
    fn arr<const N: usize>(&mut self) -> [f32; N] {
        core::array::from_fn(|_| self.next())
    }
}

fn robot_params() -> wire::RobotParams {
    let mut c = Counter(0.0);
    let mut joint = |ch: [u8; 2]| wire::JointParams {
        segment_length_m: c.next(),
        pulley_radius_m: c.next(),
        alpha_min_rad: c.next(),
        alpha_max_rad: c.next(),
        initial_shortening_m: c.next(),
        muscle_rest_length_m: c.next(),
        pretension_pressure_bar: c.next(),
        channel_of_muscle: ch,
        segment: wire::SegmentMass {
            mass_kg: c.next(),
            com_distance_m: c.next(),
            inertia_com_kg_m2: c.next(),
        },
    };
    let joints = [joint([1, 0]), joint([2, 3])];
    let mut c = Counter(20.0);
    wire::RobotParams {
        joints,
        muscle: wire::MuscleCoeffs {
            pressure_n_per_pa: c.arr(),
            passive_n: c.arr(),
        },
        pressure: wire::PressureLimits {
            min_bar: c.next(),
            max_bar: c.next(),
        },
        ip: wire::IpConverter {
            gain_bar_per_ma: c.next(),
            offset_bar: c.next(),
            current_min_ma: c.next(),
            current_max_ma: c.next(),
            output_min_bar: c.next(),
            output_max_bar: c.next(),
            natural_freq_rad_s: c.next(),
            damping_ratio: c.next(),
        },
        load_cell: load_cell(),
        gain_plane: wire::GainPlane {
            coeffs: [c.arr(), c.arr()],
            min_gain: c.next(),
        },
    }
}

fn load_cell() -> wire::LoadCell {
    wire::LoadCell {
        gain_n_per_v: [1.0, 2.0],
        offset_v: [3.0, 4.0],
        rated_force_n: 5.0,
    }
}

fn safety() -> wire::SafetyConfig {
    wire::SafetyConfig {
        period_s: 1.0,
        command_timeout_s: 2.0,
        slew_bar_per_s: 3.0,
        timeout_ramp_bar_per_s: 4.0,
        max_joint_speed_rad_s: 5.0,
        angle_margin_rad: 6.0,
        loadcell_limit_n: 7.0,
        loadcell_stuck_samples: 300,
        max_request_torque_nm: 9.0,
        max_request_stiffness_nm_per_rad: 10.0,
        max_request_force_n: 11.0,
        overrun_fault_periods: 12,
    }
}

fn calibration() -> Calibration {
    Calibration {
        encoder: [
            EncoderCalibration {
                counts_per_rev: 8000,
                sign: 1,
                zero_rad: 0.5,
            },
            EncoderCalibration {
                counts_per_rev: 300,
                sign: -1,
                zero_rad: -0.25,
            },
        ],
        load_cell: load_cell(),
        output: [
            OutputCalibration {
                gain: 1.0,
                offset_ma: 2.0,
            },
            OutputCalibration {
                gain: 3.0,
                offset_ma: 4.0,
            },
            OutputCalibration {
                gain: 5.0,
                offset_ma: 6.0,
            },
            OutputCalibration {
                gain: 7.0,
                offset_ma: 8.0,
            },
        ],
        output_of_channel: [1, 0, 3, 2],
    }
}

fn modes() -> [wire::Mode; 6] {
    [
        wire::Mode::Idle,
        wire::Mode::Pressures {
            pressure_bar: [1.0, 2.0, 3.0, 4.0],
        },
        wire::Mode::Joint {
            alpha_rad: [1.0, 2.0],
            torque_nm: [3.0, 4.0],
            stiffness_nm_per_rad: [5.0, 6.0],
        },
        wire::Mode::Force {
            force_n: [1.0, 2.0],
            stiffness_nm_per_rad: [3.0, 4.0],
            feed_forward: true,
        },
        wire::Mode::ForceClosedLoop {
            force_n: [1.0, 2.0],
            stiffness_nm_per_rad: [3.0, 4.0],
            feed_forward: true,
            gain_scale: 5.0,
        },
        wire::Mode::Impedance {
            target_user_m: [1.0, 2.0],
            stiffness_n_per_m: [3.0, 4.0],
            damping_n_s_per_m: [5.0, 6.0],
        },
    ]
}

fn telemetry(force_ref_n: Option<[f32; 2]>) -> Telemetry {
    Telemetry {
        seq: 300,
        time_us: 1_000_000,
        alpha_rad: [1.0, 2.0],
        force_user_n: [3.0, 4.0],
        force_ref_n,
        current_ma: [7.0, 8.0, 9.0, 10.0],
        pressure_cmd_bar: [11.0, 12.0, 13.0, 14.0],
        mode: ModeKind::ForceFeedForward,
        state: wire::State::Armed,
        faults: 0x0102,
        limited: 0x81,
        loop_exec_us: 12,
        loop_jitter_us: 200,
    }
}

/// Every request body's variant name: adding a variant fails to compile here, a
/// reminder to add its golden below.
fn request_variant(b: &RequestBody) -> &'static str {
    match b {
        RequestBody::Hello { .. } => "Hello",
        RequestBody::Heartbeat => "Heartbeat",
        RequestBody::Arm => "Arm",
        RequestBody::Disarm => "Disarm",
        RequestBody::Home => "Home",
        RequestBody::Tare => "Tare",
        RequestBody::ClearFaults => "ClearFaults",
        RequestBody::GetStatus => "GetStatus",
        RequestBody::SetMode(_) => "SetMode",
        RequestBody::GetConfig(_) => "GetConfig",
        RequestBody::SetConfig(_) => "SetConfig",
        RequestBody::SetTelemetry { .. } => "SetTelemetry",
        RequestBody::PersistConfig => "PersistConfig",
        RequestBody::RestoreConfig => "RestoreConfig",
        RequestBody::EraseConfig => "EraseConfig",
        RequestBody::SetServiceMode { .. } => "SetServiceMode",
        RequestBody::TakeCommand => "TakeCommand",
    }
}

/// The same for device messages (replies by their data, errors by their code).
fn device_variant(m: &DeviceMessage) -> String {
    match m {
        DeviceMessage::Reply(r) => match &r.result {
            Ok(ReplyData::Done) => "Reply::Done".into(),
            Ok(ReplyData::Hello(_)) => "Reply::Hello".into(),
            Ok(ReplyData::Status(_)) => "Reply::Status".into(),
            Ok(ReplyData::Config(_)) => "Reply::Config".into(),
            Err(code) => format!("Reply::Err::{code:?}"),
        },
        DeviceMessage::Telemetry(_) => "Telemetry".into(),
        DeviceMessage::FaultEvent(_) => "FaultEvent".into(),
    }
}

/// (instance, golden hex). Requests carry id 300 (`ac 02`).
fn golden_requests() -> Vec<(Request, &'static str)> {
    let [idle, pressures, joint, force, force_closed_loop, impedance] = modes();
    let r = |body| Request {
        id: 300,
        body,
        session: 5,
    };
    vec![
        (
            r(RequestBody::Hello {
                protocol_version: 2,
                schema_fingerprint: 0x1234_5678,
            }),
            "ac 02 00 02 f8 ac d1 91 01 05",
        ),
        (r(RequestBody::Heartbeat), "ac 02 01 05"),
        (r(RequestBody::Arm), "ac 02 02 05"),
        (r(RequestBody::Disarm), "ac 02 03 05"),
        (r(RequestBody::Home), "ac 02 04 05"),
        (r(RequestBody::Tare), "ac 02 05 05"),
        (r(RequestBody::ClearFaults), "ac 02 06 05"),
        (r(RequestBody::GetStatus), "ac 02 07 05"),
        (r(RequestBody::SetMode(idle)), "ac 02 08 00 05"),
        (
            r(RequestBody::SetMode(pressures)),
            "ac 02 08 01 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 05",
        ),
        (
            r(RequestBody::SetMode(joint)),
            "ac 02 08 02 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 a0 40 \
            00 00 c0 40 05",
        ),
        (
            r(RequestBody::SetMode(force)),
            "ac 02 08 03 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 01 05",
        ),
        (
            r(RequestBody::SetMode(force_closed_loop)),
            "ac 02 08 04 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 01 00 00 a0 40 05",
        ),
        (
            r(RequestBody::SetMode(impedance)),
            "ac 02 08 05 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 a0 40 \
            00 00 c0 40 05",
        ),
        (
            r(RequestBody::GetConfig(ConfigSection::Robot)),
            "ac 02 09 00 05",
        ),
        (
            r(RequestBody::GetConfig(ConfigSection::Calibration)),
            "ac 02 09 01 05",
        ),
        (
            r(RequestBody::GetConfig(ConfigSection::Limits)),
            "ac 02 09 02 05",
        ),
        (
            r(RequestBody::SetConfig(Config::Robot(robot_params()))),
            "ac 02 0a 00 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 a0 40 \
            00 00 c0 40 00 00 e0 40 01 00 00 00 00 41 00 00 10 41 00 00 20 41 00 00 \
            30 41 00 00 40 41 00 00 50 41 00 00 60 41 00 00 70 41 00 00 80 41 00 00 \
            88 41 02 03 00 00 90 41 00 00 98 41 00 00 a0 41 00 00 a8 41 00 00 b0 41 \
            00 00 b8 41 00 00 c0 41 00 00 c8 41 00 00 d0 41 00 00 d8 41 00 00 e0 41 \
            00 00 e8 41 00 00 f0 41 00 00 f8 41 00 00 00 42 00 00 04 42 00 00 08 42 \
            00 00 0c 42 00 00 10 42 00 00 14 42 00 00 18 42 00 00 1c 42 00 00 20 42 \
            00 00 24 42 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 a0 40 \
            00 00 28 42 00 00 2c 42 00 00 30 42 00 00 34 42 00 00 38 42 00 00 3c 42 \
            00 00 40 42 05",
        ),
        (
            r(RequestBody::SetConfig(Config::Calibration(calibration()))),
            "ac 02 0a 01 c0 3e 01 00 00 00 3f ac 02 ff 00 00 80 be 00 00 80 3f 00 00 \
            00 40 00 00 40 40 00 00 80 40 00 00 a0 40 00 00 80 3f 00 00 00 40 00 00 \
            40 40 00 00 80 40 00 00 a0 40 00 00 c0 40 00 00 e0 40 00 00 00 41 01 00 \
            03 02 05",
        ),
        (
            r(RequestBody::SetConfig(Config::Limits(safety()))),
            "ac 02 0a 02 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 a0 40 \
            00 00 c0 40 00 00 e0 40 ac 02 00 00 10 41 00 00 20 41 00 00 30 41 0c 05",
        ),
        (
            r(RequestBody::SetTelemetry { divider: 300 }),
            "ac 02 0b ac 02 05",
        ),
        (r(RequestBody::PersistConfig), "ac 02 0c 05"),
        (r(RequestBody::RestoreConfig), "ac 02 0d 05"),
        (r(RequestBody::EraseConfig), "ac 02 0e 05"),
        (
            r(RequestBody::SetServiceMode { enabled: true }),
            "ac 02 0f 01 05",
        ),
        (r(RequestBody::TakeCommand), "ac 02 10 05"),
    ]
}

/// (instance, golden hex). Replies carry id 300 (`ac 02`).
fn golden_device_messages() -> Vec<(DeviceMessage, &'static str)> {
    let reply = |result| DeviceMessage::Reply(Reply { id: 300, result });
    let [_, _, _, force, _, _] = modes();
    let mut v = vec![
        // 00 Reply, ac 02 id 300, 00 Ok, 00 Done
        (reply(Ok(ReplyData::Done)), "00 ac 02 00 00"),
        // … 01 Hello: 02 protocol_version, 84 86 88 08 schema_fingerprint 0x01020304,
        // 01 02 ac 02 firmware 1.2.300, e8 07 period_us 1000, ef fd b6 f5 0d params_hash
        (
            reply(Ok(ReplyData::Hello(DeviceInfo {
                protocol_version: 2,
                schema_fingerprint: 0x0102_0304,
                firmware_version: Version {
                    major: 1,
                    minor: 2,
                    patch: 300,
                },
                period_us: 1000,
                params_hash: 0xdead_beef,
                session: 300,
            }))),
            "00 ac 02 00 01 02 84 86 88 08 01 02 ac 02 e8 07 ef fd b6 f5 0d ac 02",
        ),
        // … 02 Status: 02 Faulted, 03 Force {4 × f32, 01 feed_forward}, 80 03 faults
        // 0x180, 01 homed, e8 07 period_us, 0a divider, 03 DefaultsOtherVersion, 01 unsaved,
        // 02 board checks, 01 Some vdda 3.0, 01 Some stack (ac 02 used 300, e8 07 size
        // 1000), 01 Some CPU fault (02 BusFault, ac 02 pc 300, 01 address), 01 service mode
        (
            reply(Ok(ReplyData::Status(Status {
                state: wire::State::Faulted,
                mode: force,
                faults: 0x0180,
                homed: true,
                period_us: 1000,
                telemetry_divider: 10,
                config: ConfigOrigin::DefaultsOtherVersion,
                config_unsaved: true,
                board_checks: BOARD_CHECK_ADC_DUAL,
                vdda_v: Some(3.0),
                stack: Some(StackUsage {
                    used_max_bytes: 300,
                    size_bytes: 1000,
                }),
                last_cpu_fault: Some(CpuFault {
                    kind: CpuFaultKind::BusFault,
                    pc: 300,
                    address: 1,
                }),
                service_mode: true,
            }))),
            "00 ac 02 00 02 02 03 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 01 \
            80 03 01 e8 07 0a 03 01 02 01 00 00 40 40 01 ac 02 e8 07 01 02 ac 02 01 01",
        ),
        // … 03 Config, 00 Robot: joint 1 (7 × f32, 01 00 channels, 3 × f32 segment),
        // joint 2 (… 02 03 …), muscle, pressure, ip, load cell (1.0 … 5.0), gain plane
        (
            reply(Ok(ReplyData::Config(Config::Robot(robot_params())))),
            "00 ac 02 00 03 00 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 \
            a0 40 00 00 c0 40 00 00 e0 40 01 00 00 00 00 41 00 00 10 41 00 00 20 41 \
            00 00 30 41 00 00 40 41 00 00 50 41 00 00 60 41 00 00 70 41 00 00 80 41 \
            00 00 88 41 02 03 00 00 90 41 00 00 98 41 00 00 a0 41 00 00 a8 41 00 00 \
            b0 41 00 00 b8 41 00 00 c0 41 00 00 c8 41 00 00 d0 41 00 00 d8 41 00 00 \
            e0 41 00 00 e8 41 00 00 f0 41 00 00 f8 41 00 00 00 42 00 00 04 42 00 00 \
            08 42 00 00 0c 42 00 00 10 42 00 00 14 42 00 00 18 42 00 00 1c 42 00 00 \
            20 42 00 00 24 42 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 \
            a0 40 00 00 28 42 00 00 2c 42 00 00 30 42 00 00 34 42 00 00 38 42 00 00 \
            3c 42 00 00 40 42",
        ),
        (
            reply(Ok(ReplyData::Config(Config::Calibration(calibration())))),
            "00 ac 02 00 03 01 c0 3e 01 00 00 00 3f ac 02 ff 00 00 80 be 00 00 80 3f \
            00 00 00 40 00 00 40 40 00 00 80 40 00 00 a0 40 00 00 80 3f 00 00 00 40 \
            00 00 40 40 00 00 80 40 00 00 a0 40 00 00 c0 40 00 00 e0 40 00 00 00 41 \
            01 00 03 02",
        ),
        (
            reply(Ok(ReplyData::Config(Config::Limits(safety())))),
            "00 ac 02 00 03 02 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 \
            a0 40 00 00 c0 40 00 00 e0 40 ac 02 00 00 10 41 00 00 20 41 00 00 30 41 0c",
        ),
        // 01 Telemetry: ac 02 seq 300, c0 84 3d time_us 10⁶, α and force (4 × f32), 00 no
        // force reference, currents and pressures (8 × f32), 04 ForceFeedForward, 01 Armed,
        // 82 02 faults 0x102, 81 limited (a raw byte), 0c exec 12 µs, c8 01 jitter 200 µs
        (
            DeviceMessage::Telemetry(telemetry(None)),
            "01 ac 02 c0 84 3d 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 00 00 \
            00 e0 40 00 00 00 41 00 00 10 41 00 00 20 41 00 00 30 41 00 00 40 41 00 \
            00 50 41 00 00 60 41 04 01 82 02 81 0c c8 01",
        ),
        (
            DeviceMessage::Telemetry(telemetry(Some([5.0, 6.0]))),
            "01 ac 02 c0 84 3d 00 00 80 3f 00 00 00 40 00 00 40 40 00 00 80 40 01 00 \
            00 a0 40 00 00 c0 40 00 00 e0 40 00 00 00 41 00 00 10 41 00 00 20 41 00 \
            00 30 41 00 00 40 41 00 00 50 41 00 00 60 41 04 01 82 02 81 0c c8 01",
        ),
        (
            DeviceMessage::FaultEvent(FaultEvent {
                code: 7,
                bits: 0x0180,
            }),
            "02 07 80 03",
        ),
    ];
    let errors = [
        (ErrorCode::Malformed, "00 ac 02 01 00"),
        (ErrorCode::UnsupportedVersion, "00 ac 02 01 01"),
        (ErrorCode::OutOfRange, "00 ac 02 01 02"),
        (ErrorCode::WrongState, "00 ac 02 01 03"),
        (ErrorCode::FaultStillPresent, "00 ac 02 01 04"),
        (ErrorCode::NotHomed, "00 ac 02 01 05"),
        (ErrorCode::StorageFailed, "00 ac 02 01 06"),
        (ErrorCode::NoStoredConfig, "00 ac 02 01 07"),
        (ErrorCode::Implausible, "00 ac 02 01 08"),
        (ErrorCode::NoSession, "00 ac 02 01 09"),
        (ErrorCode::NotCommander, "00 ac 02 01 0a"),
        (ErrorCode::SchemaMismatch, "00 ac 02 01 0b"),
        (ErrorCode::ServiceModeOff, "00 ac 02 01 0c"),
    ];
    v.extend(errors.map(|(code, hex)| (reply(Err(code)), hex)));
    v
}

fn check<T>(cases: &[(T, &'static str)], name: impl Fn(&T) -> String) -> Vec<String>
where
    T: serde::Serialize + serde::de::DeserializeOwned + core::fmt::Debug + PartialEq,
{
    let mut failures = Vec::new();
    for (msg, golden) in cases {
        let got = hex(&encode(msg));
        let want: String = golden.split_whitespace().collect::<Vec<_>>().join(" ");
        if got != want {
            failures.push(format!("{}: encodes as\n    \"{got}\"", name(msg)));
            continue;
        }
        // and the golden bytes decode to the instance
        let bytes: Vec<u8> = want
            .split(' ')
            .filter(|s| !s.is_empty())
            .map(|b| u8::from_str_radix(b, 16).unwrap())
            .collect();
        let back: T = postcard::from_bytes(&bytes).expect("golden bytes decode");
        assert_eq!(&back, msg, "{}", name(msg));
    }
    failures
}

#[test]
fn every_request_has_golden_bytes() {
    let cases = golden_requests();
    let failures = check(&cases, |r| request_variant(&r.body).into());
    assert!(
        failures.is_empty(),
        "wire layout changed:\n{}",
        failures.join("\n")
    );
}

#[test]
fn every_device_message_has_golden_bytes() {
    let cases = golden_device_messages();
    let failures = check(&cases, device_variant);
    assert!(
        failures.is_empty(),
        "wire layout changed:\n{}",
        failures.join("\n")
    );
}

#[test]
fn the_goldens_cover_every_variant() {
    let reqs: std::collections::BTreeSet<_> = golden_requests()
        .iter()
        .map(|(r, _)| request_variant(&r.body))
        .collect();
    assert_eq!(reqs.len(), 17, "{reqs:?}");
    let modes: std::collections::HashSet<_> = golden_requests()
        .iter()
        .filter_map(|(r, _)| match r.body {
            RequestBody::SetMode(m) => Some(core::mem::discriminant(&m)),
            _ => None,
        })
        .collect();
    assert_eq!(modes.len(), 6);
    let msgs: std::collections::BTreeSet<_> = golden_device_messages()
        .iter()
        .map(|(m, _)| device_variant(m))
        .collect();
    // Done, Hello, Status, Config, thirteen error codes, telemetry, fault event
    assert_eq!(msgs.len(), 19, "{msgs:?}");
}

#[test]
fn the_schema_fingerprint_is_pinned() {
    // Moves with PROTOCOL_VERSION and with any wire type (see the module doc): update it in
    // the same commit as the golden bytes above.
    println!("SCHEMA_FINGERPRINT = {SCHEMA_FINGERPRINT:#010x}");
    assert_eq!(
        SCHEMA_FINGERPRINT, 0x7047_d529,
        "{SCHEMA_FINGERPRINT:#010x}"
    );
}

#[test]
fn the_fingerprint_depends_on_the_version_and_both_directions() {
    use crate::wire::schema::{fnv_u32, Schema, FNV_OFFSET};
    let of =
        |version: u32, req: u32, dev: u32| fnv_u32(fnv_u32(fnv_u32(FNV_OFFSET, version), req), dev);
    let (req, dev) = (Request::SCHEMA_HASH, DeviceMessage::SCHEMA_HASH);
    assert_eq!(SCHEMA_FINGERPRINT, of(PROTOCOL_VERSION as u32, req, dev));
    assert_ne!(
        SCHEMA_FINGERPRINT,
        of(PROTOCOL_VERSION as u32 + 1, req, dev)
    );
    assert_ne!(
        SCHEMA_FINGERPRINT,
        of(PROTOCOL_VERSION as u32, req ^ 1, dev)
    );
    assert_ne!(
        SCHEMA_FINGERPRINT,
        of(PROTOCOL_VERSION as u32, req, dev ^ 1)
    );
    // a payload type's change reaches the messages that carry it
    assert_ne!(
        wire::RobotParams::SCHEMA_HASH,
        wire::JointParams::SCHEMA_HASH
    );
}

#[test]
fn domain_values_survive_their_wire_forms() {
    use pam_control::{Mode, SafetyConfig, State};
    use pam_model::RobotParams;
    let p = RobotParams::<f32>::thesis();
    assert_eq!(RobotParams::from(wire::RobotParams::from(p)), p);
    assert_eq!(
        pam_model::params::LoadCell::from(wire::LoadCell::from(p.load_cell)),
        p.load_cell
    );
    let s = SafetyConfig::default_1khz();
    assert_eq!(SafetyConfig::from(wire::SafetyConfig::from(s)), s);
    for st in [State::Disarmed, State::Armed, State::Faulted] {
        assert_eq!(State::from(wire::State::from(st)), st);
        assert_eq!(wire::State::from(st), st);
    }
    for m in modes() {
        assert_eq!(wire::Mode::from(Mode::from(m)), m);
    }
    // the wire form of the thesis parameters is what params_hash hashes
    assert_eq!(params_hash(&p), {
        let bytes = encode(&wire::RobotParams::from(p));
        crate::wire::schema::fnv_bytes(crate::wire::schema::FNV_OFFSET, &bytes)
    });
}
