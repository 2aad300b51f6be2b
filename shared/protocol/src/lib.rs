//! The link between the firmware (or the emulator) and the host: one crate, used by both
//! ends, so the wire format has exactly one definition.
//!
//! - [`messages`]: requests (host → device), replies, telemetry and fault events
//!   (device → host), [`PROTOCOL_VERSION`], [`SCHEMA_FINGERPRINT`].
//! - [`wire`]: the protocol's own forms of the domain values it carries (mode, state,
//!   limits, robot parameters), with `From` conversions to and from pam-model's and
//!   pam-control's types, and the compile-time schema fingerprint.
//! - [`frame`]: `COBS(postcard(message) ‖ CRC-16/CCITT-FALSE) ‖ 0x00` framing and the
//!   streaming [`FrameDecoder`], which resynchronises at the next 0x00 after any garbage.
//!
//! `no_std`, no heap: every buffer is a fixed array of at most [`MAX_FRAME`] bytes.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

pub mod frame;
pub mod messages;
pub mod wire;

pub use frame::{
    decode_block, encode_frame, DecodeError, EncodeError, FrameDecoder, MAX_FRAME, MAX_PAYLOAD,
};
pub use messages::*;

/// USB identity of the firmware's CDC-ACM interface, so `pamctl ports` can point at the
/// robot: the pid.codes test VID/PID, to be replaced by an allocated pair before the device
/// leaves the lab.
pub const USB_VID: u16 = 0x1209;
pub const USB_PID: u16 = 0x0001;

/// Largest telemetry frame on the wire, delimiter included (all varints at their longest,
/// force reference present). Typical frames are a few bytes shorter. Checked by the
/// `telemetry_frame_size` test.
pub const TELEMETRY_FRAME_MAX: usize = 84;

/// A 32-bit fingerprint (FNV-1a over the postcard encoding of its wire form) of a
/// parameter set, so the host can tell whether the device runs the parameters it expects.
pub fn params_hash(params: &pam_model::RobotParams<f32>) -> u32 {
    let mut buf = [0u8; MAX_PAYLOAD];
    let bytes: &[u8] = match postcard::to_slice(&wire::RobotParams::from(*params), &mut buf) {
        Ok(b) => b,
        Err(_) => &[],
    };
    wire::schema::fnv_bytes(wire::schema::FNV_OFFSET, bytes)
}

#[cfg(test)]
mod fuzz_seeds;
#[cfg(test)]
mod golden;
#[cfg(test)]
mod tests;
