//! The emulator's configuration flash: the firmware's two 2 KiB pages as a [`RamFlash`],
//! kept in a file when `pamctl sim --config-flash FILE` names one (so that a persisted
//! configuration is there after the emulator restarts), else in memory only (every run
//! starts with an erased flash). The file is the pages' raw bytes: damaging it is how the
//! tests make a corrupt record.

use crate::EmulatorError;
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use pam_config_store::{ConfigStore, RamFlash, RamFlashError, StoreError};
use std::path::PathBuf;

/// Two pages, like `firmware/src/config_flash.rs`.
pub const FLASH_BYTES: usize = 2 * 2048;

pub struct SimFlash {
    ram: RamFlash<FLASH_BYTES>,
    file: Option<PathBuf>,
}

impl SimFlash {
    /// The file's contents (a missing file is an erased flash; a short one is erased
    /// beyond its end), or an erased flash in memory.
    pub fn open(file: Option<PathBuf>) -> Result<SimFlash, EmulatorError> {
        let ram = match &file {
            Some(path) if path.exists() => {
                let bytes = std::fs::read(path).map_err(|source| EmulatorError::ConfigFlash {
                    path: path.display().to_string(),
                    source,
                })?;
                RamFlash::from_bytes(&bytes)
            }
            _ => RamFlash::new(),
        };
        Ok(SimFlash { ram, file })
    }

    /// Writes the pages back to the file; a file that cannot be written is a flash error.
    fn sync(&self) -> Result<(), RamFlashError> {
        match &self.file {
            Some(path) => std::fs::write(path, self.ram.as_bytes().as_slice()).map_err(|e| {
                eprintln!("sim: cannot write {}: {e}", path.display());
                RamFlashError::PowerCut
            }),
            None => Ok(()),
        }
    }
}

impl ErrorType for SimFlash {
    type Error = RamFlashError;
}

impl ReadNorFlash for SimFlash {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.ram.read(offset, bytes)
    }
    fn capacity(&self) -> usize {
        FLASH_BYTES
    }
}

impl NorFlash for SimFlash {
    const WRITE_SIZE: usize = RamFlash::<FLASH_BYTES>::WRITE_SIZE;
    const ERASE_SIZE: usize = RamFlash::<FLASH_BYTES>::ERASE_SIZE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        let r = self.ram.erase(from, to);
        self.sync()?;
        r
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        let r = self.ram.write(offset, bytes);
        self.sync()?;
        r
    }
}

pub fn store(file: Option<PathBuf>) -> Result<ConfigStore<SimFlash>, EmulatorError> {
    ConfigStore::new(SimFlash::open(file)?, 0)
        .map_err(|e: StoreError| EmulatorError::ConfigStore(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use pam_config_store::Loaded;

    #[test]
    fn a_record_saved_through_a_file_is_there_for_the_next_emulator() {
        let path = std::env::temp_dir().join(format!("pam-sim-flash-{}.bin", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let mut s = store(Some(path.clone())).unwrap();
        assert_eq!(s.load(), Ok(Loaded::Missing));
        let d = pam_device::Device::new(
            pam_model::RobotParams::thesis(),
            pam_control::SafetyConfig::default_1khz(),
            pam_device::DeviceOptions {
                firmware_version: pam_protocol::Version {
                    major: 0,
                    minor: 0,
                    patch: 0,
                },
                encoder_counter_bits: 16,
                boot_nonce: 0,
            },
        );
        s.save(&d.stored_config()).unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), FLASH_BYTES as u64);
        let mut again = store(Some(path.clone())).unwrap();
        assert_eq!(again.load(), Ok(Loaded::Record(d.stored_config())));
        // in memory only: nothing carries over
        assert_eq!(store(None).unwrap().load(), Ok(Loaded::Missing));
        let _ = std::fs::remove_file(&path);
    }
}
