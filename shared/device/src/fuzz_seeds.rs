//! The seed corpus of the `device_requests` fuzz target (`fuzz/corpus/device_requests/`),
//! generated here in the target's own input format (`fuzz/src/input.rs`, included below)
//! from the current requests: sessions that home, arm, set every mode, run periods, fault,
//! clear, change and store the configuration.
//!
//! The test fails when the files differ from what is generated today (after a wire or input
//! format change); `PAM_WRITE_FUZZ_SEEDS=1 cargo test -p pam-device fuzz_seeds` rewrites them.

#[allow(dead_code)] // the target's reader half
#[path = "../fuzz/src/input.rs"]
mod input;

use input::*;
use pam_control::SafetyConfig;
use pam_model::RobotParams;
use pam_protocol::{
    encode_frame, wire, Calibration, Config, ConfigSection, EncoderCalibration, OutputCalibration,
    Request, RequestBody, MAX_FRAME, PROTOCOL_VERSION, SCHEMA_FINGERPRINT,
};
use std::path::PathBuf;

struct Seed {
    input: Vec<u8>,
    id: u16,
}

impl Seed {
    fn new(setup: u8) -> Self {
        Seed {
            input: vec![setup],
            id: 100,
        }
    }

    fn send(mut self, body: RequestBody) -> Self {
        self.id += 1;
        let mut buf = [0u8; MAX_FRAME];
        let bytes = postcard::to_slice(
            &Request {
                id: self.id,
                body,
                session: 1,
            },
            &mut buf,
        )
        .expect("a request fits");
        push_request(&mut self.input, bytes);
        self
    }

    /// The request as a frame through the decoder, with line noise before it.
    fn frame(mut self, body: RequestBody) -> Self {
        self.id += 1;
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_frame(
            &Request {
                id: self.id,
                body,
                session: 1,
            },
            &mut buf,
        )
        .expect("fits");
        let mut bytes = vec![0x55, 0xAA, 0x00];
        bytes.extend_from_slice(&buf[..n]);
        push_frame_bytes(&mut self.input, &bytes);
        self
    }

    fn steps(mut self, n: u8) -> Self {
        push_steps(&mut self.input, n);
        self
    }

    fn step(mut self, encoder_delta: [i8; 2], volts_50mv: [i8; 2]) -> Self {
        push_step(&mut self.input, encoder_delta, volts_50mv);
        self
    }

    /// One period with raw load-cell volts (NaN, ∞, …).
    fn raw_volts(mut self, volts: [f32; 2]) -> Self {
        self.input.extend([OP_STEP, 0, 0, 0x80]);
        for v in volts {
            self.input.extend(v.to_le_bytes());
        }
        self
    }
}

fn modes() -> [wire::Mode; 6] {
    [
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
    ]
}

fn seeds() -> Vec<Vec<u8>> {
    let params = RobotParams::<f32>::thesis();
    let mut limits: wire::SafetyConfig = SafetyConfig::default_1khz().into();
    limits.slew_bar_per_s = 2.0;
    let calibration = Calibration {
        encoder: [EncoderCalibration::default(); 2],
        load_cell: params.load_cell.into(),
        output: [OutputCalibration {
            gain: 1.01,
            offset_ma: -0.05,
        }; 4],
        output_of_channel: pam_protocol::IDENTITY_CHANNEL_MAP,
    };
    let pressures = SETUP_HOME | SETUP_ARM | (1 << SETUP_MODE_SHIFT);
    let joint = SETUP_HOME | SETUP_ARM | (2 << SETUP_MODE_SHIFT);
    let force = SETUP_HOME | SETUP_ARM | (3 << SETUP_MODE_SHIFT);
    let mut every_mode = Seed::new(SETUP_HOME).send(RequestBody::Arm);
    for m in modes() {
        every_mode = every_mode.send(RequestBody::SetMode(m)).steps(20);
    }
    vec![
        Seed::new(0)
            .send(RequestBody::Hello {
                protocol_version: PROTOCOL_VERSION,
                schema_fingerprint: SCHEMA_FINGERPRINT,
            })
            .send(RequestBody::GetStatus)
            .send(RequestBody::Arm)
            .send(RequestBody::Home)
            .send(RequestBody::Arm)
            .steps(10)
            .send(RequestBody::Disarm),
        Seed::new(pressures)
            .steps(64)
            .send(RequestBody::GetStatus)
            .step([1, 0], [1, 1])
            .steps(64)
            .send(RequestBody::Disarm)
            .steps(5),
        Seed::new(joint)
            .step([2, -1], [0, 0])
            .step([3, -2], [1, -1])
            .send(RequestBody::SetMode(modes()[3]))
            .steps(30)
            .send(RequestBody::Heartbeat)
            .steps(64)
            .steps(64),
        every_mode.send(RequestBody::Disarm),
        Seed::new(SETUP_PERSIST)
            .send(RequestBody::SetConfig(Config::Limits(limits)))
            .send(RequestBody::PersistConfig)
            .send(RequestBody::SetTelemetry { divider: 5 })
            .send(RequestBody::EraseConfig)
            .send(RequestBody::RestoreConfig)
            .send(RequestBody::GetConfig(ConfigSection::Limits)),
        Seed::new(SETUP_FAULT | force)
            .steps(3)
            .send(RequestBody::ClearFaults)
            .send(RequestBody::Arm)
            .steps(5)
            .step([100, 0], [0, 0])
            .send(RequestBody::ClearFaults),
        Seed::new(SETUP_HOME)
            .send(RequestBody::Tare)
            .send(RequestBody::SetConfig(Config::Calibration(calibration)))
            .send(RequestBody::SetConfig(Config::Robot(params.into())))
            .send(RequestBody::GetConfig(ConfigSection::Robot))
            .send(RequestBody::Arm)
            .send(RequestBody::SetMode(modes()[1]))
            .steps(40),
        Seed::new(SETUP_SLOW_PERIOD | SETUP_TELEMETRY_OFF | pressures)
            .frame(RequestBody::GetStatus)
            .raw_volts([f32::NAN, 0.0])
            .frame(RequestBody::ClearFaults)
            .raw_volts([0.0, f32::INFINITY])
            .steps(10),
    ]
    .into_iter()
    .map(|s| s.input)
    .collect()
}

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus/device_requests")
}

/// The `seed*` files; units the fuzzer adds (named by their hash, ignored by git) are not
/// the test's business.
fn seed_files_on_disk() -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(corpus_dir())
        .expect("the corpus directory")
        .map(|e| e.expect("a directory entry").path())
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.to_string();
            name.starts_with("seed")
                .then(|| (name, std::fs::read(&p).expect("a seed file")))
        })
        .collect();
    files.sort();
    files
}

#[test]
fn the_fuzz_seed_corpus_is_the_current_input_format() {
    let mut expected: Vec<(String, Vec<u8>)> = seeds()
        .into_iter()
        .enumerate()
        .map(|(i, s)| (format!("seed{i}"), s))
        .collect();
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
        "fuzz/corpus/device_requests is not the generated seed corpus: \
         PAM_WRITE_FUZZ_SEEDS=1 cargo test -p pam-device fuzz_seeds"
    );
}

/// Every request a seed carries decodes, and every operation is read whole: the seeds mean
/// what they say to the target.
#[test]
fn every_seed_reads_as_whole_operations_of_valid_requests() {
    for (i, seed) in seeds().iter().enumerate() {
        let mut c = Cursor(&seed[1..]);
        while let Some(op) = c.u8() {
            match op {
                OP_REQUEST => {
                    let bytes = c.chunk().expect("a whole request");
                    postcard::from_bytes::<Request>(bytes)
                        .unwrap_or_else(|e| panic!("seed{i}: {e}"));
                }
                OP_STEP => {
                    c.bytes(2).expect("encoder deltas");
                    c.volts().expect("volts");
                }
                OP_STEPS => {
                    c.u8().expect("a count");
                }
                OP_FRAME => {
                    c.chunk().expect("frame bytes");
                }
                other => panic!("seed{i}: op {other}"),
            }
        }
    }
}
