//! The device's configuration in flash: robot parameters, calibration (load-cell tare and
//! scale, encoder resolution and direction, output-stage trim) and safety limits, kept as
//! one record over any [`NorFlash`] (embedded-storage): the STM32's flash on the board,
//! [`RamFlash`] in tests and in the emulator.
//!
//! **Layout.** Two slots of one erase unit each (two 2 KiB pages on the STM32G474RE,
//! `firmware/src/board.rs`). A save erases the slot that does *not* hold the newest good
//! record and writes the new record there with a sequence number one higher; a load takes
//! the good record with the highest sequence number. A power loss during a save therefore
//! leaves the previous record intact (the half-written one fails its CRC).
//!
//! **Record.** `magic` (4 bytes) · `format` u16 · payload length u16 · `seq` u32 ·
//! [`LAYOUT_HASH`] u32 · payload ([`StoredConfig`], postcard) · CRC-32 (ISO-HDLC) of all
//! that, little-endian, padded with 0xFF to the flash's write size.
//!
//! **Versions.** [`LAYOUT_HASH`] is computed at compile time from the wire types' schema
//! hashes (`pam_protocol::wire::Schema`): any change of a stored field's name, type or
//! order changes it, so a record written by another firmware is recognised as such
//! ([`Loaded::OtherVersion`]) instead of being decoded into wrong values.
//!
//! What the caller does with a [`Loaded`] that is not a record (the thesis defaults and a
//! status/fault bit) is `pam-device`'s business; nothing here panics.
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

mod ram;

#[cfg(any(test, feature = "checks"))]
pub mod checks;

pub use ram::{PowerCut, RamFlash, RamFlashError};

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use pam_protocol::wire::schema::{fnv_str, fnv_u32, member, Schema, FNV_OFFSET};
use pam_protocol::{wire, Calibration};
use serde::{Deserialize, Serialize};

/// Everything that is kept across a reset. The encoders' home is not: the counters are
/// incremental and start anywhere at power-up, so a stored home offset would give a
/// believable, wrong angle (`pamctl home` after every boot).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredConfig {
    pub robot: wire::RobotParams,
    pub calibration: Calibration,
    pub limits: wire::SafetyConfig,
}

/// Bump when the record's framing (not its payload types) changes.
pub const FORMAT_VERSION: u16 = 1;

/// The payload's shape: [`StoredConfig`]'s fields and their wire types' schema hashes.
pub const LAYOUT_HASH: u32 = member(
    member(
        member(
            fnv_str(fnv_u32(FNV_OFFSET, FORMAT_VERSION as u32), "StoredConfig"),
            "robot",
            wire::RobotParams::SCHEMA_HASH,
        ),
        "calibration",
        Calibration::SCHEMA_HASH,
    ),
    "limits",
    wire::SafetyConfig::SCHEMA_HASH,
);

const MAGIC: [u8; 4] = *b"PAMC";
const HEADER_BYTES: usize = 16;
const CRC_BYTES: usize = 4;
/// Room for the payload; the thesis configuration takes about 330 bytes.
pub const PAYLOAD_MAX: usize = 480;
/// The largest record written, before padding.
pub const RECORD_MAX: usize = HEADER_BYTES + PAYLOAD_MAX + CRC_BYTES;
/// Padding up to a write size of at most this many bytes is supported.
const WRITE_SIZE_MAX: usize = 32;
const BUF: usize = RECORD_MAX + WRITE_SIZE_MAX;

const CRC32: crc::Crc<u32, crc::NoTable> =
    crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// What a load found. (A record is large next to the other variants; it is returned once
/// per boot, never stored in a collection.)
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Loaded {
    /// A good record of this firmware's layout.
    Record(StoredConfig),
    /// Both slots erased: nothing was ever saved, or it was erased.
    Missing,
    /// Something is there, but no slot holds a record whose CRC checks.
    Corrupt,
    /// A record whose CRC checks, written with another format or payload layout.
    OtherVersion,
}

/// Why the store could not do what was asked. A load never fails on bad contents (that is
/// [`Loaded`]); only the flash itself or the set-up can fail.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum StoreError {
    #[error("flash error: {0:?}")]
    Flash(NorFlashErrorKind),
    #[error("the store's two slots do not fit the flash at offset {base:#x} (erase size {erase_size} B, capacity {capacity} B)")]
    Region {
        base: u32,
        erase_size: usize,
        capacity: usize,
    },
    #[error("the configuration does not fit a record ({PAYLOAD_MAX} B of payload)")]
    TooLarge,
}

fn flash_err<E: NorFlashError>(e: E) -> StoreError {
    StoreError::Flash(e.kind())
}

/// What one slot holds.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    Erased,
    Corrupt,
    OtherVersion { seq: u32 },
    Good { seq: u32, config: StoredConfig },
}

/// `a` is newer than `b` (sequence numbers wrap).
fn newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// The record store: two slots of `F::ERASE_SIZE` bytes from flash offset `base`.
pub struct ConfigStore<F> {
    flash: F,
    base: u32,
}

impl<F: NorFlash> ConfigStore<F> {
    /// Checks that two erase units from `base` fit the flash and hold a record.
    pub fn new(flash: F, base: u32) -> Result<Self, StoreError> {
        let region = StoreError::Region {
            base,
            erase_size: F::ERASE_SIZE,
            capacity: flash.capacity(),
        };
        let fits = (base as usize)
            .checked_add(2 * F::ERASE_SIZE)
            .is_some_and(|end| end <= flash.capacity());
        if !fits
            || !(base as usize).is_multiple_of(F::ERASE_SIZE)
            || F::ERASE_SIZE < BUF
            || F::WRITE_SIZE > WRITE_SIZE_MAX
            || F::READ_SIZE > 1
        {
            return Err(region);
        }
        Ok(ConfigStore { flash, base })
    }

    pub fn flash(&self) -> &F {
        &self.flash
    }

    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    fn slot_offset(&self, slot: usize) -> u32 {
        self.base + (slot * F::ERASE_SIZE) as u32
    }

    fn read_slot(&mut self, slot: usize) -> Result<Slot, StoreError> {
        let mut buf = [0u8; RECORD_MAX];
        self.flash
            .read(self.slot_offset(slot), &mut buf)
            .map_err(flash_err)?;
        if buf.iter().all(|&b| b == 0xFF) {
            return Ok(Slot::Erased);
        }
        if buf[..4] != MAGIC {
            return Ok(Slot::Corrupt);
        }
        let format = u16::from_le_bytes([buf[4], buf[5]]);
        let len = u16::from_le_bytes([buf[6], buf[7]]) as usize;
        let seq = u32::from_le_bytes([buf[8], buf[9], buf[10], buf[11]]);
        let layout = u32::from_le_bytes([buf[12], buf[13], buf[14], buf[15]]);
        if len > PAYLOAD_MAX {
            return Ok(Slot::Corrupt);
        }
        let end = HEADER_BYTES + len;
        let stored_crc = u32::from_le_bytes([buf[end], buf[end + 1], buf[end + 2], buf[end + 3]]);
        if CRC32.checksum(&buf[..end]) != stored_crc {
            return Ok(Slot::Corrupt);
        }
        if format != FORMAT_VERSION || layout != LAYOUT_HASH {
            return Ok(Slot::OtherVersion { seq });
        }
        Ok(
            match postcard::from_bytes::<StoredConfig>(&buf[HEADER_BYTES..end]) {
                Ok(config) => Slot::Good { seq, config },
                // the CRC held, so this firmware wrote it with the same layout: cannot happen
                // short of a hash collision; treat it as damage
                Err(_) => Slot::Corrupt,
            },
        )
    }

    fn slots(&mut self) -> Result<[Slot; 2], StoreError> {
        Ok([self.read_slot(0)?, self.read_slot(1)?])
    }

    /// The newest good record, or why there is none.
    pub fn load(&mut self) -> Result<Loaded, StoreError> {
        let slots = self.slots()?;
        let good = newest_good(&slots);
        if let Some((_, _, config)) = good {
            return Ok(Loaded::Record(config));
        }
        Ok(
            if slots.iter().any(|s| matches!(s, Slot::OtherVersion { .. })) {
                Loaded::OtherVersion
            } else if slots.iter().all(|s| *s == Slot::Erased) {
                Loaded::Missing
            } else {
                Loaded::Corrupt
            },
        )
    }

    /// Writes `config` as the newest record, into the slot that does not hold the newest
    /// good one (which stays intact until the new one is complete).
    pub fn save(&mut self, config: &StoredConfig) -> Result<(), StoreError> {
        let mut buf = [0xFFu8; BUF];
        let len = postcard::to_slice(config, &mut buf[HEADER_BYTES..HEADER_BYTES + PAYLOAD_MAX])
            .map_err(|_| StoreError::TooLarge)?
            .len();
        let slots = self.slots()?;
        // the newest sequence number of anything readable, so that a record of another
        // version that is kept never looks newer than the one written now
        let last_seq = slots.iter().fold(None, |acc: Option<u32>, s| {
            let seq = match s {
                Slot::Good { seq, .. } | Slot::OtherVersion { seq } => *seq,
                _ => return acc,
            };
            Some(match acc {
                Some(a) if newer(a, seq) => a,
                _ => seq,
            })
        });
        let target = match newest_good(&slots) {
            Some((slot, _, _)) => 1 - slot,
            None => 0,
        };
        let seq = last_seq.map_or(1, |s| s.wrapping_add(1));
        buf[..4].copy_from_slice(&MAGIC);
        buf[4..6].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        buf[6..8].copy_from_slice(&(len as u16).to_le_bytes());
        buf[8..12].copy_from_slice(&seq.to_le_bytes());
        buf[12..16].copy_from_slice(&LAYOUT_HASH.to_le_bytes());
        let end = HEADER_BYTES + len;
        let crc = CRC32.checksum(&buf[..end]);
        buf[end..end + CRC_BYTES].copy_from_slice(&crc.to_le_bytes());
        let total = (end + CRC_BYTES).div_ceil(F::WRITE_SIZE) * F::WRITE_SIZE;

        let offset = self.slot_offset(target);
        self.flash
            .erase(offset, offset + F::ERASE_SIZE as u32)
            .map_err(flash_err)?;
        self.flash.write(offset, &buf[..total]).map_err(flash_err)
    }

    /// Erases both slots: the next load finds [`Loaded::Missing`].
    pub fn erase(&mut self) -> Result<(), StoreError> {
        let from = self.base;
        self.flash
            .erase(from, from + 2 * F::ERASE_SIZE as u32)
            .map_err(flash_err)
    }
}

fn newest_good(slots: &[Slot; 2]) -> Option<(usize, u32, StoredConfig)> {
    let mut best: Option<(usize, u32, StoredConfig)> = None;
    for (i, s) in slots.iter().enumerate() {
        if let Slot::Good { seq, config } = *s {
            if best.is_none_or(|(_, b, _)| newer(seq, b)) {
                best = Some((i, seq, config));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests;
