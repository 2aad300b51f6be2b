//! Frames on the byte stream: `COBS(postcard(message) ‖ CRC-16 big-endian) ‖ 0x00`.

use crate::cobs;
use crate::crc::crc16;
use core::marker::PhantomData;
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Largest serialized message (the robot-parameters configuration reply is the biggest).
pub const MAX_PAYLOAD: usize = 320;
const CRC_LEN: usize = 2;
/// Largest frame on the wire, delimiter included.
pub const MAX_FRAME: usize = cobs::max_encoded_len(MAX_PAYLOAD + CRC_LEN) + 1;
pub const DELIMITER: u8 = 0x00;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The message does not fit in [`MAX_PAYLOAD`] or the output buffer.
    TooLarge,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// More than [`MAX_FRAME`] bytes before a delimiter; the bytes up to it were dropped.
    Overflow,
    /// Not valid COBS.
    Cobs,
    /// Shorter than a CRC.
    TooShort,
    /// CRC mismatch: the frame was corrupted.
    Crc,
    /// Intact frame whose content is not a message of the expected type. `leading_u16` is
    /// its first field read as a varint u16 (a request's id), if that much decodes.
    Message { leading_u16: Option<u16> },
}

/// Writes the frame of `msg` into `out`; returns its length (delimiter included).
pub fn encode_frame<T: Serialize>(msg: &T, out: &mut [u8]) -> Result<usize, EncodeError> {
    let mut payload = [0u8; MAX_PAYLOAD + CRC_LEN];
    let n = postcard::to_slice(msg, &mut payload[..MAX_PAYLOAD])
        .map_err(|_| EncodeError::TooLarge)?
        .len();
    let crc = crc16(&payload[..n]);
    payload[n..n + CRC_LEN].copy_from_slice(&crc.to_be_bytes());
    let m = cobs::encode(&payload[..n + CRC_LEN], out).ok_or(EncodeError::TooLarge)?;
    if m >= out.len() {
        return Err(EncodeError::TooLarge);
    }
    out[m] = DELIMITER;
    Ok(m + 1)
}

/// Checks and decodes the body of one frame (the bytes between two delimiters, still
/// COBS-encoded). Works in place on `block`.
pub fn decode_block<T: DeserializeOwned>(block: &mut [u8]) -> Result<T, DecodeError> {
    let n = cobs::decode_in_place(block).ok_or(DecodeError::Cobs)?;
    if n < CRC_LEN {
        return Err(DecodeError::TooShort);
    }
    let (payload, crc) = block[..n].split_at(n - CRC_LEN);
    if crc16(payload).to_be_bytes() != [crc[0], crc[1]] {
        return Err(DecodeError::Crc);
    }
    postcard::from_bytes(payload).map_err(|_| DecodeError::Message {
        leading_u16: postcard::take_from_bytes::<u16>(payload)
            .ok()
            .map(|(v, _)| v),
    })
}

/// Streaming accumulator: feed it every received byte. It never panics, never allocates,
/// and after any garbage it is back in step at the next delimiter.
pub struct FrameDecoder<T> {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflowed: bool,
    _msg: PhantomData<fn() -> T>,
}

impl<T: DeserializeOwned> Default for FrameDecoder<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: DeserializeOwned> FrameDecoder<T> {
    pub const fn new() -> Self {
        FrameDecoder {
            buf: [0; MAX_FRAME],
            len: 0,
            overflowed: false,
            _msg: PhantomData,
        }
    }

    /// `None` while a frame is incomplete (and for empty frames, which senders may use to
    /// flush a half-received frame at the other end); at a delimiter, the decoded message
    /// or why the frame was rejected.
    pub fn push(&mut self, byte: u8) -> Option<Result<T, DecodeError>> {
        if byte != DELIMITER {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflowed, false) {
            return Some(Err(DecodeError::Overflow));
        }
        if len == 0 {
            return None;
        }
        Some(decode_block(&mut self.buf[..len]))
    }

    /// Drops a partly received frame (e.g. after a reconnect).
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }
}
