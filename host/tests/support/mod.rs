//! Test-only mock of the device end of the link: pam-device (the firmware's logic) served
//! over TCP at 1 kHz against a trivial fake plant (the arm stays at its home pose; the
//! load cell reads a small dithering offset). Not the emulator: no dynamics at all.
#![allow(dead_code)]

use pam_control::SafetyConfig;
use pam_device::{Device, DeviceOptions, RawSensors, StepTiming};
use pam_model::RobotParams;
use pam_protocol::{
    encode_frame, DeviceMessage, ErrorCode, FrameDecoder, Reply, ReplyData, Request, RequestBody,
    Version, MAX_FRAME, SCHEMA_FINGERPRINT,
};
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

#[derive(Clone, Copy, Default)]
pub struct Options {
    /// Answer every Hello as a device of another protocol version would.
    pub other_protocol: bool,
    /// Answer every Hello as a device of the same protocol version but other wire types
    /// (another build) would: the real reply with its schema fingerprint changed.
    pub other_fingerprint: bool,
    /// Corrupt one telemetry frame in this many (one flipped byte).
    pub corrupt_every: Option<u64>,
}

/// The fingerprint the `other_fingerprint` device reports: never ours.
pub const OTHER_FINGERPRINT: u32 = SCHEMA_FINGERPRINT ^ 0x5A5A_0001;

pub struct TestDevice {
    pub address: String,
    stop: Arc<AtomicBool>,
    pub corrupted_sent: Arc<AtomicU64>,
    handle: Option<JoinHandle<()>>,
}

impl TestDevice {
    pub fn start(options: Options) -> TestDevice {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        listener.set_nonblocking(true).unwrap();
        let address = format!("tcp://{}", listener.local_addr().unwrap());
        let stop = Arc::new(AtomicBool::new(false));
        let corrupted_sent = Arc::new(AtomicU64::new(0));
        let handle = {
            let stop = stop.clone();
            let corrupted = corrupted_sent.clone();
            std::thread::spawn(move || serve(listener, options, &stop, &corrupted))
        };
        TestDevice {
            address,
            stop,
            corrupted_sent,
            handle: Some(handle),
        }
    }
}

impl Drop for TestDevice {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

fn send(stream: &mut TcpStream, msg: &DeviceMessage, corrupt: bool) -> bool {
    let mut buf = [0u8; MAX_FRAME];
    let Ok(n) = encode_frame(msg, &mut buf) else {
        return false;
    };
    if corrupt {
        buf[n / 2] ^= 0x10;
        if buf[n / 2] == 0 {
            buf[n / 2] = 0x55;
        }
    }
    let mut sent = 0;
    while sent < n {
        match stream.write(&buf[sent..n]) {
            Ok(0) => return false,
            Ok(k) => sent += k,
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_micros(100))
            }
            Err(_) => return false,
        }
    }
    true
}

fn serve(listener: TcpListener, options: Options, stop: &AtomicBool, corrupted: &AtomicU64) {
    let mut safety = SafetyConfig::default_1khz();
    // the longest timeout the device allows, so that separate pamctl processes can follow
    // each other (each one's requests count as heartbeats)
    safety.command_timeout_s = 1.0;
    let mut device = Device::new(
        RobotParams::thesis(),
        safety,
        DeviceOptions {
            firmware_version: Version {
                major: 0,
                minor: 9,
                patch: 1,
            },
            encoder_counter_bits: 16,
            boot_nonce: 0,
        },
    );
    let mut client: Option<TcpStream> = None;
    let mut decoder = FrameDecoder::<Request>::new();
    let mut k: u64 = 0;
    let mut telemetry_sent: u64 = 0;
    let start = Instant::now();
    let mut next = start;
    while !stop.load(Ordering::SeqCst) {
        let period = Duration::from_micros(device.period_us() as u64);
        next += period;
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else if now - next > Duration::from_millis(50) {
            next = now; // too far behind (machine busy): do not burst
        }
        if let Ok((s, _)) = listener.accept() {
            s.set_nonblocking(true).unwrap();
            s.set_nodelay(true).ok();
            client = Some(s); // a new connection replaces the old one, as on USB
            decoder.reset();
        }
        if let Some(s) = client.as_mut() {
            let mut buf = [0u8; 1024];
            let mut alive = true;
            loop {
                match s.read(&mut buf) {
                    Ok(0) => {
                        alive = false;
                        break;
                    }
                    Ok(n) => {
                        for &b in &buf[..n] {
                            if let Some(frame) = decoder.push(b) {
                                let reply = match frame {
                                    Ok(Request {
                                        id,
                                        body: RequestBody::Hello { .. },
                                        ..
                                    }) if options.other_protocol => Reply {
                                        id,
                                        result: Err(ErrorCode::UnsupportedVersion),
                                    },
                                    f => {
                                        let mut reply = device.handle_frame(f);
                                        if let Ok(ReplyData::Hello(info)) = &mut reply.result {
                                            if options.other_fingerprint {
                                                info.schema_fingerprint = OTHER_FINGERPRINT;
                                            }
                                        }
                                        reply
                                    }
                                };
                                alive &= send(s, &DeviceMessage::Reply(reply), false);
                            }
                        }
                    }
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                    Err(_) => {
                        alive = false;
                        break;
                    }
                }
            }
            if !alive {
                client = None;
            }
        }
        k += 1;
        let dither = if k.is_multiple_of(2) { 0.0004 } else { -0.0004 };
        let out = device.step(
            RawSensors {
                encoder_counts: [0, 0],
                loadcell_volts: [0.01 + dither, -0.02 - dither],
            },
            StepTiming {
                time_us: (k * device.period_us() as u64) as u32,
                loop_exec_us: 12,
                loop_jitter_us: (now.elapsed().as_micros() % 7) as u16,
            },
        );
        if let Some(s) = client.as_mut() {
            let mut ok = true;
            if let Some(t) = out.telemetry {
                telemetry_sent += 1;
                let corrupt = options
                    .corrupt_every
                    .is_some_and(|n| telemetry_sent.is_multiple_of(n));
                if corrupt {
                    corrupted.fetch_add(1, Ordering::SeqCst);
                }
                ok &= send(s, &DeviceMessage::Telemetry(t), corrupt);
            }
            if let Some(e) = out.fault_event {
                ok &= send(s, &DeviceMessage::FaultEvent(e), false);
            }
            if !ok {
                client = None;
            }
        }
    }
}
