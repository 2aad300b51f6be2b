//! The input format of the `device_requests` fuzz target, shared by the target and by the
//! test that writes its seed corpus (`shared/device/src/fuzz_seeds.rs`), so that the two
//! cannot drift apart.
//!
//! An input is one set-up byte, then operations until the bytes run out:
//!
//! | byte | operation | what follows |
//! |---|---|---|
//! | `OP_REQUEST` | a request as postcard bytes (decoded as `Request`, or handled as a malformed frame if it does not decode) | length `n` (two bytes, little-endian, mod [`CHUNK_MAX`]), `n` bytes |
//! | `OP_STEP` | one control period with sensors from the input | 2 encoder deltas (i8), a volts selector (see [`Cursor::volts`]) |
//! | `OP_STEPS` | several periods with the last sensors (plus an ADC dither) | count (one byte, mod 64, + 1) |
//! | `OP_FRAME` | raw bytes through the frame decoder | length `n` (as for a request), `n` bytes |
//!
//! Any other op byte is taken modulo 4.

/// Set-up flags (the first byte).
pub const SETUP_HOME: u8 = 1 << 0;
pub const SETUP_ARM: u8 = 1 << 1;
/// Two bits: 0 idle, 1 pressures, 2 joint, 3 force.
pub const SETUP_MODE_SHIFT: u8 = 2;
pub const SETUP_FAULT: u8 = 1 << 4;
pub const SETUP_TELEMETRY_OFF: u8 = 1 << 5;
pub const SETUP_PERSIST: u8 = 1 << 6;
/// A 10 ms period instead of 1 ms.
pub const SETUP_SLOW_PERIOD: u8 = 1 << 7;

pub const OP_REQUEST: u8 = 0;
pub const OP_STEP: u8 = 1;
pub const OP_STEPS: u8 = 2;
pub const OP_FRAME: u8 = 3;
/// Longest request or frame one operation carries, past the longest frame (a whole
/// `SetConfig(Robot)` fits).
pub const CHUNK_MAX: usize = 512;

/// Reads the input front to back; every read past the end gives `None`.
pub struct Cursor<'a>(pub &'a [u8]);

impl<'a> Cursor<'a> {
    pub fn u8(&mut self) -> Option<u8> {
        let (&b, rest) = self.0.split_first()?;
        self.0 = rest;
        Some(b)
    }

    pub fn bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        if self.0.len() < n {
            return None;
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Some(head)
    }

    /// A length-prefixed chunk (two bytes little-endian, mod [`CHUNK_MAX`]).
    pub fn chunk(&mut self) -> Option<&'a [u8]> {
        let n = u16::from_le_bytes([self.u8()?, self.u8()?]) as usize % CHUNK_MAX;
        self.bytes(n)
    }

    /// Load-cell volts: selector bit 7 set, the next 8 bytes are two raw f32 (NaN, ∞,
    /// anything); otherwise channel 1 is (selector − 64) × 50 mV and channel 2 the next
    /// byte as i8 × 50 mV.
    pub fn volts(&mut self) -> Option<[f32; 2]> {
        let sel = self.u8()?;
        if sel & 0x80 != 0 {
            let b = self.bytes(8)?;
            Some([
                f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                f32::from_le_bytes([b[4], b[5], b[6], b[7]]),
            ])
        } else {
            let other = self.u8()?;
            Some([(sel as f32 - 64.0) * 0.05, (other as i8) as f32 * 0.05])
        }
    }
}

/// Appends a request operation (for seeds).
pub fn push_request(input: &mut Vec<u8>, postcard_bytes: &[u8]) {
    push_chunk(input, OP_REQUEST, postcard_bytes);
}

/// Appends bytes for the frame decoder (for seeds).
pub fn push_frame_bytes(input: &mut Vec<u8>, bytes: &[u8]) {
    push_chunk(input, OP_FRAME, bytes);
}

fn push_chunk(input: &mut Vec<u8>, op: u8, bytes: &[u8]) {
    assert!(bytes.len() < CHUNK_MAX, "too long for one operation");
    input.push(op);
    input.extend((bytes.len() as u16).to_le_bytes());
    input.extend_from_slice(bytes);
}

/// Appends `n` (1–64) quiet periods (for seeds).
pub fn push_steps(input: &mut Vec<u8>, n: u8) {
    input.push(OP_STEPS);
    input.push(n.saturating_sub(1));
}

/// Appends one period that moves the encoders and sets the load-cell volts in 50 mV steps
/// (channel 1 within −64..=63) (for seeds).
pub fn push_step(input: &mut Vec<u8>, encoder_delta: [i8; 2], volts_50mv: [i8; 2]) {
    assert!(
        (-64..=63).contains(&volts_50mv[0]),
        "channel 1 outside the selector's range"
    );
    input.push(OP_STEP);
    input.extend(encoder_delta.map(|d| d as u8));
    input.push((volts_50mv[0] as i16 + 64) as u8);
    input.push(volts_50mv[1] as u8);
}
