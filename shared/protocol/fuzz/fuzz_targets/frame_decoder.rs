//! Any byte stream through the frame decoders (both directions) and into the device
//! service: nothing may panic, anything accepted must re-encode to the same message, and
//! the device must stay inside its output range whatever it was told.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pam_control::SafetyConfig;
use pam_device::{Device, DeviceOptions, RawSensors, StepTiming};
use pam_model::RobotParams;
use pam_protocol::{encode_frame, DeviceMessage, FrameDecoder, Request, Version, MAX_FRAME};

fn same_encoding<T: serde_like::Ser>(a: &T, b: &T) -> bool {
    a.bytes() == b.bytes()
}

/// Postcard bytes, for a comparison where NaN equals NaN.
mod serde_like {
    pub trait Ser {
        fn bytes(&self) -> ([u8; pam_protocol::MAX_PAYLOAD], usize);
    }
    impl<T: serde::Serialize> Ser for T {
        fn bytes(&self) -> ([u8; pam_protocol::MAX_PAYLOAD], usize) {
            let mut b = [0u8; pam_protocol::MAX_PAYLOAD];
            let n = postcard::to_slice(self, &mut b)
                .map(|s| s.len())
                .unwrap_or(usize::MAX);
            (b, n)
        }
    }
}

fn round_trips<T>(msg: &T) -> bool
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let mut buf = [0u8; MAX_FRAME];
    let n = match encode_frame(msg, &mut buf) {
        Ok(n) => n,
        Err(_) => return false,
    };
    let mut dec = FrameDecoder::<T>::new();
    let mut got = None;
    for &b in &buf[..n] {
        if let Some(r) = dec.push(b) {
            got = Some(r);
        }
    }
    matches!(got, Some(Ok(ref m)) if same_encoding(m, msg))
}

/// The message survives postcard alone (serialize, deserialize, same bytes). For what the
/// device produces after every frame and period: framing it too (COBS, CRC, a decoder fed
/// byte by byte) was two thirds of each input's cost, and the framing is what the fuzzed
/// decoders and [`round_trips`] on every decoded message already exercise.
fn payload_round_trips<T>(msg: &T) -> bool
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    let (bytes, n) = serde_like::Ser::bytes(msg);
    n <= bytes.len()
        && matches!(postcard::from_bytes::<T>(&bytes[..n]), Ok(ref m) if same_encoding(m, msg))
}

fuzz_target!(|data: &[u8]| {
    let mut requests = FrameDecoder::<Request>::new();
    let mut device_msgs = FrameDecoder::<DeviceMessage>::new();
    let mut device = Device::new(
        RobotParams::thesis(),
        SafetyConfig::default_1khz(),
        DeviceOptions {
            firmware_version: Version {
                major: 0,
                minor: 0,
                patch: 0,
            },
            encoder_counter_bits: 16,
        },
    );
    let mut k = 0u32;
    for &b in data {
        if let Some(frame) = requests.push(b) {
            if let Ok(r) = &frame {
                assert!(
                    round_trips(r),
                    "accepted request does not round-trip: {r:?}"
                );
            }
            let reply = device.handle_frame(frame);
            assert!(payload_round_trips(&DeviceMessage::Reply(reply)));
            // a control period after every request, with sensors taken from the stream
            k = k.wrapping_add(1);
            let out = device.step(
                RawSensors {
                    encoder_counts: [b as u32 * 3, k & 0xFF],
                    loadcell_volts: [b as f32 * 0.01, -0.02],
                },
                StepTiming {
                    time_us: k,
                    loop_exec_us: 0,
                    loop_jitter_us: 0,
                },
            );
            let ip = &device.controller().model().params.ip;
            for c in out.current_ma {
                assert!(
                    c >= ip.current_min_ma && c <= ip.current_max_ma,
                    "current {c} out of range"
                );
            }
            if let Some(t) = out.telemetry {
                assert!(payload_round_trips(&DeviceMessage::Telemetry(t)));
            }
        }
        if let Some(Ok(m)) = device_msgs.push(b) {
            assert!(
                round_trips(&m),
                "accepted device message does not round-trip: {m:?}"
            );
        }
    }
});
