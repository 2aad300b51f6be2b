//! Consistent Overhead Byte Stuffing: removes every 0x00 from a frame so that 0x00 can
//! delimit frames on a byte stream. Overhead: one byte per 254 bytes, plus one.

/// Bytes needed to COBS-encode `len` bytes (without the delimiter).
pub const fn max_encoded_len(len: usize) -> usize {
    len + len / 254 + 1
}

/// Encodes `src` into `dst`; returns the length written, or `None` if `dst` is too small.
pub fn encode(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    if dst.len() < max_encoded_len(src.len()) {
        return None;
    }
    let mut code_pos = 0;
    let mut out = 1;
    let mut code: u8 = 1;
    for &b in src {
        if b == 0 {
            dst[code_pos] = code;
            code_pos = out;
            out += 1;
            code = 1;
        } else {
            dst[out] = b;
            out += 1;
            code += 1;
            if code == 0xFF {
                dst[code_pos] = code;
                code_pos = out;
                out += 1;
                code = 1;
            }
        }
    }
    dst[code_pos] = code;
    Some(out)
}

/// Decodes a COBS block (without its delimiter) in place; returns the decoded length,
/// or `None` if the block is not valid COBS (a zero byte or a code running past the end).
pub fn decode_in_place(buf: &mut [u8]) -> Option<usize> {
    let mut read = 0;
    let mut write = 0;
    while read < buf.len() {
        let code = buf[read];
        if code == 0 {
            return None;
        }
        read += 1;
        let run = code as usize - 1;
        if read + run > buf.len() {
            return None;
        }
        for k in 0..run {
            let b = buf[read + k];
            if b == 0 {
                return None;
            }
            buf[write + k] = b;
        }
        write += run;
        read += run;
        // a code below 0xFF stands for a zero, except at the very end of the block
        if code != 0xFF && read < buf.len() {
            buf[write] = 0;
            write += 1;
        }
    }
    Some(write)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(data: &[u8]) {
        let mut enc = [0u8; 1200];
        let n = encode(data, &mut enc).unwrap();
        assert!(n <= max_encoded_len(data.len()));
        assert!(!enc[..n].contains(&0), "encoded block contains a zero");
        let d = decode_in_place(&mut enc[..n]).unwrap();
        assert_eq!(&enc[..d], data);
    }

    #[test]
    fn known_vectors() {
        let mut enc = [0u8; 16];
        let n = encode(&[0x11, 0x22, 0x00, 0x33], &mut enc).unwrap();
        assert_eq!(&enc[..n], &[0x03, 0x11, 0x22, 0x02, 0x33]);
        let n = encode(&[0x00], &mut enc).unwrap();
        assert_eq!(&enc[..n], &[0x01, 0x01]);
        let n = encode(&[], &mut enc).unwrap();
        assert_eq!(&enc[..n], &[0x01]);
    }

    #[test]
    fn round_trips_including_long_runs() {
        round_trip(&[]);
        round_trip(&[0, 0, 0]);
        let long: [u8; 600] = core::array::from_fn(|i| (i % 255) as u8 + 1);
        round_trip(&long);
        let mixed: [u8; 700] = core::array::from_fn(|i| (i * 7 % 13) as u8);
        round_trip(&mixed);
        let exact: [u8; 254] = [7; 254];
        round_trip(&exact);
    }

    #[test]
    fn invalid_blocks_are_refused() {
        assert_eq!(decode_in_place(&mut [0x05, 0x11]), None);
        assert_eq!(decode_in_place(&mut [0x02, 0x00]), None);
    }
}
