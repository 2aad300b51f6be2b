//! The seed corpus of the `frame_decoder` fuzz target (`fuzz/corpus/frame_decoder/`),
//! generated here from the current messages so that it follows the protocol version: one
//! frame of every request variant with plausible values (`seed0`, `seed1`, …), a few device
//! messages, and `session`, the frames of a whole session in one stream.
//!
//! The test fails when the files differ from what the protocol encodes today (after a wire
//! change); `PAM_WRITE_FUZZ_SEEDS=1 cargo test -p pam-protocol fuzz_seeds` rewrites them.

use super::*;
use std::path::PathBuf;

use super::tests::{device_info, frame_of as frame};

fn request(id: u16, body: RequestBody) -> Request {
    Request {
        id,
        body,
        session: 1,
    }
}

fn requests() -> Vec<Request> {
    let params = pam_model::RobotParams::<f32>::thesis();
    let safety = pam_control::SafetyConfig::default_1khz();
    let modes = [
        wire::Mode::Idle,
        wire::Mode::Pressures {
            pressure_bar: [2.0, 1.5, 2.5, 1.0],
        },
        wire::Mode::Joint {
            alpha_rad: [0.17, 0.11],
            torque_nm: [0.0, 0.5],
            stiffness_nm_per_rad: [20.0, 10.0],
        },
        wire::Mode::Force {
            force_n: [10.0, 0.0],
            stiffness_nm_per_rad: [20.0, 20.0],
            feed_forward: true,
        },
        wire::Mode::ForceClosedLoop {
            force_n: [5.0, -5.0],
            stiffness_nm_per_rad: [20.0, 20.0],
            feed_forward: true,
            gain_scale: 1.0,
        },
        wire::Mode::Impedance {
            target_user_m: [0.02, 0.01],
            stiffness_n_per_m: [200.0, 200.0],
            damping_n_s_per_m: [20.0, 20.0],
        },
    ];
    let mut bodies = vec![
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        },
        RequestBody::Heartbeat,
        RequestBody::Home,
        RequestBody::Tare,
        RequestBody::Arm,
    ];
    bodies.extend(modes.map(RequestBody::SetMode));
    bodies.extend([
        RequestBody::GetStatus,
        RequestBody::Disarm,
        RequestBody::ClearFaults,
        RequestBody::GetConfig(ConfigSection::Robot),
        RequestBody::GetConfig(ConfigSection::Calibration),
        RequestBody::GetConfig(ConfigSection::Limits),
        RequestBody::SetConfig(Config::Robot(params.into())),
        RequestBody::SetConfig(Config::Calibration(Calibration {
            encoder: [EncoderCalibration::default(); 2],
            load_cell: params.load_cell.into(),
            output: [OutputCalibration::default(); 4],
            output_of_channel: [1, 0, 2, 3],
        })),
        RequestBody::SetConfig(Config::Limits(safety.into())),
        RequestBody::SetTelemetry { divider: 10 },
        RequestBody::PersistConfig,
        RequestBody::RestoreConfig,
        RequestBody::EraseConfig,
        RequestBody::SetServiceMode { enabled: true },
        RequestBody::TakeCommand,
    ]);
    (1..).zip(bodies).map(|(id, b)| request(id, b)).collect()
}

fn device_messages() -> Vec<DeviceMessage> {
    let telemetry = Telemetry {
        seq: 41,
        time_us: 41_000,
        alpha_rad: [0.17, 0.11],
        force_user_n: [9.5, 0.2],
        force_ref_n: Some([10.0, 0.0]),
        current_ma: [9.0, 7.5, 11.0, 6.0],
        pressure_cmd_bar: [2.0, 1.5, 2.5, 1.0],
        mode: ModeKind::Force,
        state: wire::State::Armed,
        faults: 0,
        limited: 0,
        loop_exec_us: 80,
        loop_jitter_us: 3,
    };
    vec![
        DeviceMessage::Reply(Reply {
            id: 1,
            result: Ok(ReplyData::Hello(device_info())),
        }),
        DeviceMessage::Reply(Reply {
            id: 5,
            result: Err(ErrorCode::NotHomed),
        }),
        DeviceMessage::Telemetry(telemetry),
        DeviceMessage::FaultEvent(FaultEvent {
            code: 0,
            bits: 0x0001,
        }),
    ]
}

/// File name → bytes, as the corpus must hold them.
fn seeds() -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut session = Vec::new();
    for r in requests() {
        let f = frame(&r);
        session.extend_from_slice(&f);
        out.push((format!("seed{}", out.len()), f));
    }
    for m in device_messages() {
        let f = frame(&m);
        session.extend_from_slice(&f);
        out.push((format!("seed{}", out.len()), f));
    }
    out.push(("session".to_string(), session));
    out
}

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/frame_decoder")
}

/// The seed files (`seed*`, `session`) in the corpus directory; units the fuzzer adds
/// (named by their hash, ignored by git) are not the test's business.
fn seed_files_on_disk() -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(corpus_dir())
        .expect("the corpus directory")
        .map(|e| e.expect("a directory entry").path())
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.to_string();
            (name.starts_with("seed") || name == "session")
                .then(|| (name, std::fs::read(&p).expect("a seed file")))
        })
        .collect();
    files.sort();
    files
}

#[test]
fn every_seed_decodes_as_the_message_it_was_made_from() {
    for (r, (name, bytes)) in requests().iter().zip(seeds()) {
        let mut dec = FrameDecoder::<Request>::new();
        let got: Vec<_> = bytes.iter().filter_map(|&b| dec.push(b)).collect();
        assert_eq!(got, vec![Ok(*r)], "{name}");
    }
}

#[test]
fn the_fuzz_seed_corpus_is_the_current_protocol() {
    let mut expected = seeds();
    if std::env::var_os("PAM_WRITE_FUZZ_SEEDS").is_some() {
        for (name, _) in seed_files_on_disk() {
            std::fs::remove_file(corpus_dir().join(name)).expect("remove an old seed");
        }
        for (name, bytes) in &expected {
            std::fs::write(corpus_dir().join(name), bytes).expect("write a seed");
        }
    }
    expected.sort();
    assert!(
        seed_files_on_disk() == expected,
        "fuzz/corpus/frame_decoder is not protocol {PROTOCOL_VERSION}'s seed corpus: \
         PAM_WRITE_FUZZ_SEEDS=1 cargo test -p pam-protocol fuzz_seeds"
    );
}
