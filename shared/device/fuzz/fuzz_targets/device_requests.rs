//! The device service's request handling, fed arbitrary requests (postcard bytes that
//! decode or not, raw frames) interleaved with control periods whose sensors come from the
//! input, starting from a state the input chooses (homed or not, armed, a mode, faulted,
//! telemetry off, a stored record, a 10 ms period). Input format: `src/input.rs`.
//!
//! Invariants, checked after every operation:
//! * nothing panics;
//! * every output current is finite and inside the converter's range (4–20 mA), and it is
//!   exactly `VENT_CURRENT_MA` (4 mA) whenever the device is disarmed, or faulted by
//!   anything but a command timeout (which ramps to it), whatever the configuration and
//!   the output calibration;
//! * a reply carries the request's id; a malformed frame gets `Malformed`;
//! * a refused request leaves state, mode, faults, home and the whole configuration
//!   (robot, calibration, limits, origin) unchanged;
//! * an accepted `SetMode` is the mode in force, an accepted `Arm` arms, an accepted
//!   `Disarm` leaves the device unarmed and idle;
//! * telemetry sequence numbers follow each other without a gap.
#![no_main]

#[allow(dead_code)] // the seed writers are for the corpus test
#[path = "../src/input.rs"]
mod input;

use input::*;
use libfuzzer_sys::fuzz_target;
use pam_config_store::{ConfigStore, RamFlash, StoredConfig};
use pam_control::{Faults, Mode, SafetyConfig, State, MAX_LOOP_CURRENT_MA, VENT_CURRENT_MA};
use pam_device::{Device, DeviceOptions, RawSensors, StepTiming};
use pam_model::RobotParams;
use pam_protocol::{
    wire, ConfigOrigin, DecodeError, ErrorCode, FrameDecoder, ReplyData,
    Request, RequestBody, Version, PROTOCOL_VERSION, SCHEMA_FINGERPRINT,
};

/// The firmware's configuration flash: two 2 KiB pages.
type Flash = RamFlash<4096>;

/// What a refused request must leave as it was.
#[derive(Debug, PartialEq)]
struct Snapshot {
    state: State,
    mode: Mode,
    faults: Faults,
    homed: bool,
    config: StoredConfig,
    origin: ConfigOrigin,
}

struct Rig {
    device: Device,
    store: ConfigStore<Flash>,
    counts: [u32; 2],
    volts: [f32; 2],
    time_us: u32,
    dither: u32,
    last_seq: Option<u32>,
}

impl Rig {
    fn new(slow: bool) -> Self {
        let mut safety = SafetyConfig::default_1khz();
        if slow {
            safety.period_s = 0.010;
        }
        let device = Device::new(
            RobotParams::thesis(),
            safety,
            DeviceOptions {
                firmware_version: Version {
                    major: 0,
                    minor: 0,
                    patch: 0,
                },
                encoder_counter_bits: 16,
                boot_nonce: 0,
            },
        );
        let store = ConfigStore::new(Flash::new(), 0).expect("two pages fit");
        Rig {
            device,
            store,
            counts: [0; 2],
            volts: [0.0; 2],
            time_us: 0,
            dither: 0,
            last_seq: None,
        }
    }

    fn snapshot(&self) -> Snapshot {
        let c = self.device.controller();
        Snapshot {
            state: c.state(),
            mode: c.mode(),
            faults: c.faults(),
            homed: self.device.homed(),
            config: self.device.stored_config(),
            origin: self.device.config_origin(),
        }
    }

    fn step(&mut self) {
        self.time_us = self.time_us.wrapping_add(self.device.period_us());
        let out = self.device.step(
            RawSensors {
                encoder_counts: self.counts,
                loadcell_volts: self.volts,
            },
            StepTiming {
                time_us: self.time_us,
                loop_exec_us: 0,
                loop_jitter_us: 0,
            },
        );
        let c = self.device.controller();
        for i in out.current_ma {
            assert!(
                i.is_finite() && (VENT_CURRENT_MA..=MAX_LOOP_CURRENT_MA).contains(&i),
                "current {i} mA outside {VENT_CURRENT_MA}–{MAX_LOOP_CURRENT_MA} mA"
            );
        }
        // the safe state is a constant: no configuration or calibration moves it
        if c.outputs_vented() {
            assert_eq!(
                out.current_ma,
                [VENT_CURRENT_MA; 4],
                "not at the vent while {:?} with faults {:#06x}",
                c.state(),
                c.faults().0
            );
        }
        if let Some(t) = out.telemetry {
            if let Some(last) = self.last_seq {
                assert_eq!(t.seq, last.wrapping_add(1), "telemetry seq gap");
            }
            self.last_seq = Some(t.seq);
        }
    }

    /// A quiet period: the same pose, the load cell dithering by a few µV as a live ADC does.
    fn quiet_step(&mut self) {
        self.dither = self.dither.wrapping_add(1);
        let d = (self.dither % 5) as f32 * 1e-4;
        let base = self.volts;
        self.volts = [base[0] + d, base[1] - d];
        self.step();
        self.volts = base;
    }

    fn request(&mut self, request: &Request) {
        let before = self.snapshot();
        let reply = self.device.handle_with_store(&mut self.store, request);
        assert_eq!(reply.id, request.id, "reply to another request");
        let after = self.snapshot();
        match reply.result {
            Err(code) => assert_eq!(
                before, after,
                "refused ({code:?}) request {request:?} changed the device"
            ),
            Ok(data) => self.check_accepted(request, &data, &after),
        }
    }

    fn check_accepted(&self, request: &Request, data: &ReplyData, after: &Snapshot) {
        match request.body {
            RequestBody::SetMode(m) => assert_eq!(after.mode, Mode::from(m), "mode not in force"),
            RequestBody::Arm => assert_eq!(after.state, State::Armed, "accepted arm"),
            RequestBody::Disarm => {
                assert_ne!(after.state, State::Armed, "armed after a disarm");
                assert_eq!(after.mode, Mode::Idle, "a mode after a disarm");
            }
            RequestBody::ClearFaults => {
                assert_eq!(after.faults, Faults::NONE, "faults after a clear");
                assert_eq!(after.state, State::Disarmed, "not disarmed after a clear");
            }
            RequestBody::GetStatus => {
                let ReplyData::Status(s) = data else {
                    panic!("status request answered with {data:?}")
                };
                assert_eq!(s.faults, after.faults.0);
                assert_eq!(s.mode, wire::Mode::from(after.mode));
            }
            _ => {}
        }
    }

    fn frame_bytes(&mut self, bytes: &[u8], decoder: &mut FrameDecoder<Request>) {
        for &b in bytes {
            match decoder.push(b) {
                None => {}
                Some(Ok(request)) => self.request(&request),
                Some(Err(e)) => self.malformed(e),
            }
        }
    }

    fn malformed(&mut self, e: DecodeError) {
        let before = self.snapshot();
        let reply = self.device.handle_frame(Err(e));
        assert_eq!(reply.result, Err(ErrorCode::Malformed));
        assert_eq!(
            before,
            self.snapshot(),
            "a malformed frame changed the device"
        );
    }
}

fn setup(rig: &mut Rig, flags: u8, id: &mut u16) {
    let mut send = |rig: &mut Rig, body: RequestBody| {
        *id = id.wrapping_add(1);
        rig.request(&Request {
            id: *id,
            body,
            session: 1,
        });
    };
    rig.quiet_step();
    send(
        rig,
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        },
    );
    if flags & SETUP_PERSIST != 0 {
        send(rig, RequestBody::PersistConfig);
    }
    if flags & SETUP_TELEMETRY_OFF != 0 {
        send(rig, RequestBody::SetTelemetry { divider: 0 });
    }
    if flags & SETUP_HOME != 0 {
        send(rig, RequestBody::Home);
    }
    if flags & SETUP_ARM != 0 {
        send(rig, RequestBody::Arm);
    }
    let mode = match (flags >> SETUP_MODE_SHIFT) & 3 {
        0 => None,
        1 => Some(wire::Mode::Pressures {
            pressure_bar: [2.0, 1.5, 2.5, 1.0],
        }),
        2 => Some(wire::Mode::Joint {
            alpha_rad: [0.1, -0.1],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [20.0; 2],
        }),
        _ => Some(wire::Mode::Force {
            force_n: [5.0, -3.0],
            stiffness_nm_per_rad: [20.0; 2],
            feed_forward: true,
        }),
    };
    if let Some(mode) = mode {
        if matches!(mode, wire::Mode::Pressures { .. }) {
            send(rig, RequestBody::SetServiceMode { enabled: true });
        }
        send(rig, RequestBody::SetMode(mode));
    }
    rig.quiet_step();
    if flags & SETUP_FAULT != 0 {
        rig.device.raise(Faults::SELF_CHECK);
        rig.quiet_step();
    }
}

fuzz_target!(|data: &[u8]| {
    let mut input = Cursor(data);
    let Some(flags) = input.u8() else { return };
    let mut rig = Rig::new(flags & SETUP_SLOW_PERIOD != 0);
    let mut id = 0u16;
    setup(&mut rig, flags, &mut id);
    let mut decoder = FrameDecoder::<Request>::new();
    while let Some(op) = input.u8() {
        match op % 4 {
            OP_REQUEST => {
                let Some(bytes) = input.chunk() else { break };
                match postcard::from_bytes::<Request>(bytes) {
                    Ok(request) => rig.request(&request),
                    // what the frame decoder makes of an intact frame that is no request
                    Err(_) => rig.malformed(DecodeError::Message {
                        leading_u16: postcard::take_from_bytes::<u16>(bytes).ok().map(|(v, _)| v),
                    }),
                }
            }
            OP_STEP => {
                let (Some(d0), Some(d1), Some(volts)) = (input.u8(), input.u8(), input.volts())
                else {
                    break;
                };
                rig.counts[0] = rig.counts[0].wrapping_add(d0 as i8 as u32);
                rig.counts[1] = rig.counts[1].wrapping_add(d1 as i8 as u32);
                rig.volts = volts;
                rig.step();
            }
            OP_STEPS => {
                let Some(n) = input.u8() else { break };
                for _ in 0..=(n % 64) {
                    rig.quiet_step();
                }
            }
            _ => {
                let Some(bytes) = input.chunk() else { break };
                rig.frame_bytes(bytes, &mut decoder);
            }
        }
    }
    // a control period after the last operation: the invariants hold there too
    rig.quiet_step();
});
