//! The board's side of the fault paths (`pam_fault_paths`): the panic handler, the CPU
//! fault handlers (HardFault, MemManage, BusFault, UsageFault, an interrupt without a
//! handler) and the NMI handler are that crate's, installed here with [`Stm32FaultBoard`].
//! The same code runs in QEMU against an emulated board (`qemu-tests`).
//!
//! Every one of them, first: the vent current's compare value, a constant, into the four
//! channels of TIM3, and OUT_EN# high (the buffers off: 0 mA on the revised board, and on
//! the first one, whose /OE is tied low, the 4 mA compares). Then interrupts masked, a
//! record in `.uninit` RAM (the first fault of a run), the log over defmt, and a wait that
//! re-asserts the outputs until the IWDG resets the MCU; the wait starts the IWDG if it was
//! not running yet (a fault during boot), so a reset always follows: within
//! `board::WATCHDOG_TIMEOUT_US` once the loop runs, within the IWDG's reset-default
//! 512 ms before. The next boot logs the record and latches `Faults::CPU_FAULT`.
//!
//! The NMI handler survives exactly one NMI: a flash double-bit ECC error whose address is
//! in the configuration record's pages (a power loss while it was written; the record then
//! fails its CRC). Any other ECC error, and any other NMI, is a fault like the others.
//! The G4's IWDG has no early-warning interrupt; the window watchdog is not used.

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;

use cortex_m::peripheral::scb::Exception;
use cortex_m::peripheral::SCB;
use embassy_stm32::pac;
use pam_fault_paths::{ConfigPages, FaultBoard, FaultKind, FaultRecord, FlashEcc, RecordSlot};

use crate::board;
use crate::current_output;

pub use pam_fault_paths::guard::{enable_stack_guard, paint_stack, stack_usage, StackUsage};

pub struct Stm32FaultBoard;

#[link_section = ".uninit.FAULT_RECORD"]
static mut FAULT_RECORD: MaybeUninit<RecordSlot> = MaybeUninit::uninit();

impl FaultBoard for Stm32FaultBoard {
    fn drive_safe() {
        current_output::drive_safe_compares();
        current_output::disable_output_stage();
    }

    fn record_slot() -> *mut RecordSlot {
        addr_of_mut!(FAULT_RECORD).cast()
    }

    fn flash_ecc() -> FlashEcc {
        FlashEcc::from_eccr(pac::FLASH.eccr().read().0)
    }

    fn clear_flash_ecc() {
        // ECCD: write 1 to clear
        pac::FLASH.eccr().modify(|w| w.set_eccd(true));
    }

    const CONFIG_PAGES: ConfigPages = board::CONFIG_PAGES;

    fn report(r: &FaultRecord) {
        defmt::error!(
            "fault {=str} ({=u32}): pc {=u32:#010x}, cfsr {=u32:#010x}, hfsr {=u32:#010x}, address {=u32:#010x}",
            r.kind.name(),
            r.kind as u32,
            r.pc,
            r.cfsr,
            r.hfsr,
            r.address
        );
    }

    fn report_panic(info: &core::panic::PanicInfo) {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    }

    fn ensure_reset() {
        // starts the IWDG if it is not running (no effect on a running one)
        pac::IWDG
            .kr()
            .write(|w| w.set_key(pac::iwdg::vals::Key::START));
    }
}

pam_fault_paths::install_fault_handlers!(Stm32FaultBoard);

/// The record left by a fault path before the last reset, if any (cleared: the next boot
/// reports only its own). Called once at boot.
pub fn take_fault_record() -> Option<FaultRecord> {
    // SAFETY: the record's own `.uninit` slot, read before any fault path can run again
    unsafe { pam_fault_paths::record::take(Stm32FaultBoard::record_slot()) }
}

/// Enables the separate MemManage, BusFault and UsageFault handlers (SCB SHCSR); call
/// once at boot. Their priority stays 0, above every interrupt.
pub fn enable_fault_exceptions(scb: &mut SCB) {
    scb.enable(Exception::MemoryManagement);
    scb.enable(Exception::BusFault);
    scb.enable(Exception::UsageFault);
}

/// Flash double-bit ECC errors in the configuration pages seen (and survived) since boot.
pub fn tolerated_ecc_errors() -> u32 {
    pam_fault_paths::tolerated_ecc_errors()
}

/// The wire form of a record, for `status`. The protocol names the CPU exceptions; an NMI
/// is reported as the interrupt it is (number −14), a panic has no wire kind (the boot log
/// names it, and `CPU_FAULT` is latched for it all the same).
pub fn wire_record(r: FaultRecord) -> Option<pam_protocol::CpuFault> {
    use pam_protocol::CpuFaultKind as K;
    let (kind, address) = match r.kind {
        FaultKind::HardFault => (K::HardFault, r.address),
        FaultKind::MemManage => (K::MemManage, r.address),
        FaultKind::BusFault => (K::BusFault, r.address),
        FaultKind::UsageFault => (K::UsageFault, r.address),
        FaultKind::UnexpectedInterrupt => (K::UnexpectedInterrupt, r.address),
        FaultKind::Nmi => (K::UnexpectedInterrupt, -14i32 as u32),
        FaultKind::Panic => return None,
    };
    Some(pam_protocol::CpuFault {
        kind,
        pc: r.pc,
        address,
    })
}

/// The wire form of the stack's high-water mark.
pub fn wire_stack(s: StackUsage) -> pam_protocol::StackUsage {
    pam_protocol::StackUsage {
        used_max_bytes: s.used_max_bytes,
        size_bytes: s.size_bytes,
    }
}
