//! A flash in RAM with the STM32G4's rules (2 KiB erase pages, 8-byte programming of erased
//! double-words only) and an optional power cut after a number of byte operations, so that
//! a save interrupted at any point can be tested. The emulator keeps one in a file.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// Why a [`RamFlash`] operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RamFlashError {
    #[error("outside the flash or not aligned")]
    OutOfBounds,
    #[error("programming a double-word that is not erased")]
    NotErased,
    #[error("the power was cut")]
    PowerCut,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            RamFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            RamFlashError::NotErased | RamFlashError::PowerCut => NorFlashErrorKind::Other,
        }
    }
}

/// When the power goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PowerCut {
    Never,
    /// After this many more bytes programmed or erased (an erase works byte by byte here,
    /// so a cut leaves a page partly erased).
    AfterBytes(usize),
    /// The power is off: every write and erase fails until [`RamFlash::restore_power`].
    Off,
}

pub struct RamFlash<const N: usize> {
    bytes: [u8; N],
    cut: PowerCut,
}

impl<const N: usize> RamFlash<N> {
    pub const PAGE_BYTES: usize = 2048;

    /// An erased flash.
    pub fn new() -> Self {
        RamFlash {
            bytes: [0xFF; N],
            cut: PowerCut::Never,
        }
    }

    /// A flash holding `bytes` (e.g. read back from a file); missing bytes read as erased.
    pub fn from_bytes(bytes: &[u8]) -> Self {
        let mut f = Self::new();
        let n = bytes.len().min(N);
        f.bytes[..n].copy_from_slice(&bytes[..n]);
        f
    }

    pub fn as_bytes(&self) -> &[u8; N] {
        &self.bytes
    }

    /// Direct access, for tests that damage the contents.
    pub fn as_bytes_mut(&mut self) -> &mut [u8; N] {
        &mut self.bytes
    }

    pub fn cut_power(&mut self, cut: PowerCut) {
        self.cut = cut;
    }

    pub fn restore_power(&mut self) {
        self.cut = PowerCut::Never;
    }

    /// Spends one byte operation of the power budget.
    fn spend(&mut self) -> Result<(), RamFlashError> {
        match self.cut {
            PowerCut::Never => Ok(()),
            PowerCut::Off | PowerCut::AfterBytes(0) => {
                self.cut = PowerCut::Off;
                Err(RamFlashError::PowerCut)
            }
            PowerCut::AfterBytes(n) => {
                self.cut = PowerCut::AfterBytes(n - 1);
                Ok(())
            }
        }
    }

    fn range(&self, offset: u32, len: usize, align: usize) -> Result<usize, RamFlashError> {
        let start = offset as usize;
        let aligned = start.is_multiple_of(align) && len.is_multiple_of(align);
        if !aligned || start.checked_add(len).is_none_or(|end| end > N) {
            return Err(RamFlashError::OutOfBounds);
        }
        Ok(start)
    }
}

impl<const N: usize> Default for RamFlash<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ErrorType for RamFlash<N> {
    type Error = RamFlashError;
}

impl<const N: usize> ReadNorFlash for RamFlash<N> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        let start = self.range(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.bytes[start..start + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        N
    }
}

impl<const N: usize> NorFlash for RamFlash<N> {
    const WRITE_SIZE: usize = 8;
    const ERASE_SIZE: usize = Self::PAGE_BYTES;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let len = (to as usize).saturating_sub(from as usize);
        let start = self.range(from, len, Self::ERASE_SIZE)?;
        for i in start..start + len {
            self.spend()?;
            self.bytes[i] = 0xFF;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let start = self.range(offset, bytes.len(), Self::WRITE_SIZE)?;
        for (k, chunk) in bytes.chunks(Self::WRITE_SIZE).enumerate() {
            let at = start + k * Self::WRITE_SIZE;
            if self.bytes[at..at + Self::WRITE_SIZE]
                .iter()
                .any(|&b| b != 0xFF)
            {
                return Err(RamFlashError::NotErased);
            }
            for (i, &b) in chunk.iter().enumerate() {
                self.spend()?;
                self.bytes[at + i] = b;
            }
        }
        Ok(())
    }
}
