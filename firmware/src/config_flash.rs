//! The configuration record in flash (`pam-config-store` over embassy-stm32's blocking
//! flash driver): bank 2's last two pages, 0x0807_F000–0x0807_FFFF (memory.x's CONFIG).
//!
//! The store is owned by the link task (thread mode). Storage requests go through
//! `pam_device`'s three steps so that the device's critical section is held only for the
//! checks and for applying a restored record, never for the flash work: a page erase
//! (≈ 22 ms at most) runs while the control loop keeps preempting it. The program lives
//! in bank 1 (memory.x), so that erase does not stall its instruction fetches either.
//! Storage requests are refused while armed (`pam_device`).

use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::pac;
use embassy_stm32::peripherals::FLASH;
use embassy_stm32::Peri;
use embedded_storage::nor_flash::{NorFlash, NorFlashErrorKind};
use pam_config_store::{ConfigStore, StoreError};
use pam_device::run_storage;
use pam_protocol::{Reply, Request};

use crate::control::with_device;

pub type Store = ConfigStore<Flash<'static, Blocking>>;

/// Offset of the first slot from the start of flash (0x0807_F000).
pub const CONFIG_FLASH_OFFSET: u32 = 0x0007_F000;

// two 2 KiB pages from the offset are the last two of the 512 KiB (dual-bank page size)
const _: () = assert!(<Flash<'static, Blocking> as NorFlash>::ERASE_SIZE == 2048);
const _: () = assert!(CONFIG_FLASH_OFFSET as usize + 2 * 2048 == 512 * 1024);

/// The store, if the flash is in the dual-bank layout the firmware was built for (the HAL
/// would panic otherwise; here it is a boot with the defaults and `SELF_CHECK`).
pub fn open(flash: Peri<'static, FLASH>) -> Result<Store, StoreError> {
    if !pac::FLASH.optr().read().dbank() {
        defmt::warn!("config: the flash is single-bank (option bit DBANK = 0): no store");
        return Err(StoreError::Flash(NorFlashErrorKind::Other));
    }
    ConfigStore::new(Flash::new_blocking(flash), CONFIG_FLASH_OFFSET)
}

/// The reply to a storage request (`None` if `request` is not one, or no device is
/// installed, which cannot happen once the link runs).
pub fn handle(store: Option<&mut Store>, request: &Request) -> Option<Reply> {
    let job = match with_device(|d| d.begin_storage(request))?? {
        Ok(job) => job,
        Err(refused) => return Some(refused),
    };
    let done = match store {
        Some(store) => run_storage(store, job),
        None => Err(StoreError::Flash(NorFlashErrorKind::Other)),
    };
    if done.is_err() {
        defmt::warn!("config: the flash failed");
    }
    with_device(|d| d.finish_storage(request.id, done))
}
