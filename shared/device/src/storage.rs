//! The configuration in flash, as the device sees it: what is stored
//! ([`Device::stored_config`]), what a boot does with what the store found
//! ([`Device::boot_config`]), and the three storage requests (`PersistConfig`,
//! `RestoreConfig`, `EraseConfig`).
//!
//! A request is carried out in three steps so that the firmware can keep the flash work
//! (a 2 KiB page erase takes up to ≈ 22 ms) out of the device's critical section, which the
//! control loop needs every period: [`Device::begin_storage`] (checks, snapshot; under the
//! lock), [`run_storage`] (the flash only, no device), [`Device::finish_storage`] (applies a
//! restored record, the reply; under the lock). [`Device::handle_with_store`] chains them
//! for a caller that owns both (the emulator, tests).
//!
//! Policy: a boot that finds no record uses the thesis defaults without a fault (an erased
//! or new board is a normal state, `Status::config` says so); one that finds a damaged,
//! foreign or refused record, or cannot read the flash, uses the defaults and latches
//! `SELF_CHECK`: someone must look before the robot moves with the wrong calibration.

use embedded_storage::nor_flash::NorFlash;
use pam_config_store::{ConfigStore, Loaded, StoreError, StoredConfig};
use pam_control::{Faults, SafetyConfig, State};
use pam_model::RobotParams;
use pam_protocol::{
    Config, ConfigOrigin, CpuFault, ErrorCode, Reply, ReplyData, Request, RequestBody, StackUsage,
};

use crate::Device;

/// What the board reports about itself (the emulator reports nothing).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BoardHealth {
    /// `pam_protocol::BOARD_CHECK_*` bits failing now; non-zero keeps `SELF_CHECK` raised.
    pub board_checks: u8,
    pub vdda_v: Option<f32>,
    pub stack: Option<StackUsage>,
    pub last_cpu_fault: Option<CpuFault>,
}

/// The flash work of one storage request (one at a time, never collected).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StorageJob {
    Persist(StoredConfig),
    Restore,
    Erase,
}

/// What the flash work gave.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StorageDone {
    Persisted,
    Restored(Loaded),
    Erased,
}

/// The flash part of a storage request. No device involved: the firmware runs it outside
/// the device's lock.
pub fn run_storage<F: NorFlash>(
    store: &mut ConfigStore<F>,
    job: StorageJob,
) -> Result<StorageDone, StoreError> {
    Ok(match job {
        StorageJob::Persist(config) => {
            store.save(&config)?;
            StorageDone::Persisted
        }
        StorageJob::Restore => StorageDone::Restored(store.load()?),
        StorageJob::Erase => {
            store.erase()?;
            StorageDone::Erased
        }
    })
}

impl Device {
    /// The configuration in use, as it is stored.
    pub fn stored_config(&self) -> StoredConfig {
        StoredConfig {
            robot: self.controller.model().params.into(),
            calibration: self.calibration(),
            limits: (*self.controller.safety()).into(),
        }
    }

    /// Applies a stored configuration whole or not at all (disarmed only).
    pub fn apply_stored(&mut self, stored: &StoredConfig) -> Result<(), ErrorCode> {
        if self.controller.state() == State::Armed {
            return Err(ErrorCode::WrongState);
        }
        let before = self.stored_config();
        let result = self.apply_sections(stored);
        if result.is_err() {
            // the configuration in use was accepted before: it is accepted again
            let _ = self.apply_sections(&before);
        }
        result
    }

    fn apply_sections(&mut self, c: &StoredConfig) -> Result<(), ErrorCode> {
        self.set_config(&Config::Robot(c.robot), false)?;
        self.set_config(&Config::Calibration(c.calibration), false)?;
        self.set_config(&Config::Limits(c.limits), false)
    }

    /// What a boot does with what the store found (see the module doc for the policy).
    pub fn boot_config(&mut self, loaded: Result<Loaded, StoreError>) {
        let origin = match loaded {
            Ok(Loaded::Record(stored)) => match self.apply_stored(&stored) {
                Ok(()) => ConfigOrigin::Flash,
                Err(_) => ConfigOrigin::DefaultsRefused,
            },
            Ok(Loaded::Missing) => ConfigOrigin::DefaultsNoRecord,
            Ok(Loaded::Corrupt) => ConfigOrigin::DefaultsCorrupt,
            Ok(Loaded::OtherVersion) => ConfigOrigin::DefaultsOtherVersion,
            Err(_) => ConfigOrigin::DefaultsNoStorage,
        };
        if origin != ConfigOrigin::Flash {
            self.use_defaults();
        }
        if !matches!(origin, ConfigOrigin::Flash | ConfigOrigin::DefaultsNoRecord) {
            self.raise(Faults::SELF_CHECK);
        }
        self.config_origin = origin;
        self.config_unsaved = false;
    }

    /// The thesis defaults, keeping the period and command timeout the device was built
    /// with (the firmware's, or the emulator's longer timeout).
    fn use_defaults(&mut self) {
        let mut limits = SafetyConfig::default_1khz();
        limits.period_s = self.controller.safety().period_s;
        limits.command_timeout_s = self.controller.safety().command_timeout_s;
        let defaults = StoredConfig {
            robot: RobotParams::<f32>::thesis().into(),
            calibration: pam_protocol::Calibration {
                encoder: self.encoders.calibration(),
                load_cell: RobotParams::<f32>::thesis().load_cell.into(),
                output: Default::default(),
                output_of_channel: pam_protocol::IDENTITY_CHANNEL_MAP,
            },
            limits: limits.into(),
        };
        let _ = self.apply_sections(&defaults);
    }

    /// The board's self-report, shown in `Status` (checks keep `SELF_CHECK` raised).
    pub fn set_board_health(&mut self, health: BoardHealth) {
        self.board = health;
    }

    /// Where the configuration in use came from (boot or the last restore/persist).
    pub fn config_origin(&self) -> ConfigOrigin {
        self.config_origin
    }

    pub fn board_health(&self) -> BoardHealth {
        self.board
    }

    /// First step of a storage request: `None` if `request` is not one; otherwise the
    /// flash work to do, or the reply if it is refused. Counts as a heartbeat.
    pub fn begin_storage(&mut self, request: &Request) -> Option<Result<StorageJob, Reply>> {
        let job = match request.body {
            RequestBody::PersistConfig => StorageJob::Persist(self.stored_config()),
            RequestBody::RestoreConfig => StorageJob::Restore,
            RequestBody::EraseConfig => StorageJob::Erase,
            _ => return None,
        };
        self.controller.heartbeat();
        if self.controller.state() == State::Armed {
            return Some(Err(Reply {
                id: request.id,
                result: Err(ErrorCode::WrongState),
            }));
        }
        Some(Ok(job))
    }

    /// Last step: applies a restored record and builds the reply.
    pub fn finish_storage(
        &mut self,
        id: pam_protocol::RequestId,
        done: Result<StorageDone, StoreError>,
    ) -> Reply {
        let result = match done {
            Err(_) => Err(ErrorCode::StorageFailed),
            Ok(StorageDone::Persisted) => {
                self.config_origin = ConfigOrigin::Flash;
                self.config_unsaved = false;
                Ok(ReplyData::Done)
            }
            Ok(StorageDone::Erased) => {
                self.config_unsaved = true;
                Ok(ReplyData::Done)
            }
            Ok(StorageDone::Restored(Loaded::Record(stored))) => {
                self.apply_stored(&stored).map(|()| {
                    self.config_origin = ConfigOrigin::Flash;
                    self.config_unsaved = false;
                    ReplyData::Done
                })
            }
            Ok(StorageDone::Restored(_)) => Err(ErrorCode::NoStoredConfig),
        };
        Reply { id, result }
    }

    /// A request handled with the store at hand (emulator, tests): storage requests go
    /// through the three steps, every other request to [`Device::handle`].
    pub fn handle_with_store<F: NorFlash>(
        &mut self,
        store: &mut ConfigStore<F>,
        request: &Request,
    ) -> Reply {
        match self.begin_storage(request) {
            None => self.handle(request),
            Some(Err(refused)) => refused,
            Some(Ok(job)) => {
                let done = run_storage(store, job);
                self.finish_storage(request.id, done)
            }
        }
    }
}

#[cfg(test)]
#[path = "storage_tests.rs"]
mod tests;
