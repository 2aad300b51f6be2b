//! Frames on the byte stream: `COBS(postcard(message) ‖ CRC-16 big-endian) ‖ 0x00`.
//!
//! COBS is the `cobs` crate (the one postcard itself uses), the CRC the `crc` crate's
//! CRC-16/CCITT-FALSE (`CRC_16_IBM_3740`: poly 0x1021, init 0xFFFF, no reflection, no
//! final xor; detects every error burst up to 16 bits and any 1–3 bit errors in frames of
//! our size), with its 256-entry table as before.

use core::marker::PhantomData;
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Largest serialized message (the robot-parameters configuration reply is the biggest).
pub const MAX_PAYLOAD: usize = 320;
const CRC_LEN: usize = 2;
/// Largest frame on the wire, delimiter included.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_PAYLOAD + CRC_LEN) + 1;
pub const DELIMITER: u8 = 0x00;

const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// The frame's checksum over the postcard bytes.
pub fn crc16(data: &[u8]) -> u16 {
    CRC16.checksum(data)
}

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
    let m = cobs::try_encode(&payload[..n + CRC_LEN], out).map_err(|_| EncodeError::TooLarge)?;
    if m >= out.len() {
        return Err(EncodeError::TooLarge);
    }
    out[m] = DELIMITER;
    Ok(m + 1)
}

/// Checks and decodes the body of one frame (the bytes between two delimiters, still
/// COBS-encoded). Works in place on `block`.
pub fn decode_block<T: DeserializeOwned>(block: &mut [u8]) -> Result<T, DecodeError> {
    let n = cobs::decode_in_place(block).map_err(|_| DecodeError::Cobs)?;
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

#[cfg(test)]
mod tests {
    use super::crc16;

    #[test]
    fn crc_check_value_of_the_standard() {
        // the catalogue's check value for "123456789"
        assert_eq!(crc16(b"123456789"), 0x29B1);
        assert_eq!(crc16(b""), 0xFFFF);
    }

    // the wire format is standard COBS; these pin it against a change of the crate
    fn round_trip(data: &[u8]) {
        let mut enc = [0u8; 1200];
        let n = cobs::try_encode(data, &mut enc).unwrap();
        assert!(n <= cobs::max_encoding_length(data.len()));
        assert!(!enc[..n].contains(&0), "encoded block contains a zero");
        let d = cobs::decode_in_place(&mut enc[..n]).unwrap();
        assert_eq!(&enc[..d], data);
    }

    #[test]
    fn cobs_known_vectors() {
        let mut enc = [0u8; 16];
        let n = cobs::try_encode(&[0x11, 0x22, 0x00, 0x33], &mut enc).unwrap();
        assert_eq!(&enc[..n], &[0x03, 0x11, 0x22, 0x02, 0x33]);
        let n = cobs::try_encode(&[0x00], &mut enc).unwrap();
        assert_eq!(&enc[..n], &[0x01, 0x01]);
    }

    #[test]
    fn cobs_round_trips_including_long_runs() {
        round_trip(&[0, 0, 0]);
        let long: [u8; 600] = core::array::from_fn(|i| (i % 255) as u8 + 1);
        round_trip(&long);
        let mixed: [u8; 700] = core::array::from_fn(|i| (i * 7 % 13) as u8);
        round_trip(&mixed);
        let exact: [u8; 254] = [7; 254];
        round_trip(&exact);
    }

    #[test]
    fn invalid_cobs_blocks_are_refused() {
        assert!(cobs::decode_in_place(&mut [0x05, 0x11]).is_err());
        assert!(cobs::decode_in_place(&mut [0x02, 0x00]).is_err());
    }
}
