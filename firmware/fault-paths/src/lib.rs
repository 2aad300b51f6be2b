//! The firmware's fault paths, written once and run in two places: on the STM32G474 with
//! the real output timer and `OUT_EN#`, and on a Cortex-M4 in QEMU (mps2-an386) with an
//! emulated register block, where the tests drive a stack overflow, a panic and NMIs
//! through them (`qemu-tests/src/bin/fault_paths.rs`).
//!
//! What differs between the two is the [`FaultBoard`] trait: how the outputs reach the safe
//! state, where the record lives, what the flash's ECC status says, how a reset is made
//! sure of and where the log goes. Everything else, from the exception entry to the halt, is
//! this crate, installed into a binary by [`install_fault_handlers!`].
//!
//! * Every fault path (HardFault, MemManage, BusFault, UsageFault, an interrupt without a
//!   handler, an NMI that is not a configuration-page ECC error, a panic) first calls
//!   [`FaultBoard::drive_safe`]: constant compare values, fixed at compile time, into the
//!   output registers and the output stage disabled. Nothing is read from RAM that a stack
//!   overflow or a stray write could have changed.
//! * Then interrupts are masked, a record is written to no-init RAM (the first fault of a
//!   run keeps its record: a fault inside a fault path only re-drives the outputs), the
//!   record is logged, and the core waits for the watchdog's reset, re-driving the safe
//!   outputs. [`FaultBoard::ensure_reset`] starts the watchdog if it was not running yet.
//! * The CPU fault exceptions run on a stack of their own: a stack overflow leaves the
//!   stack pointer inside the MPU guard, where the handler could not push a word.
//! * The next boot takes the record ([`record::take`]) and reports it.
#![no_std]

pub mod ceiling;
pub mod entry;
pub mod guard;
pub mod record;

pub use entry::{fault_entry, nmi_entry, panic_entry, tolerated_ecc_errors};
pub use pam_firmware_logic::nmi::{ConfigPages, FlashEcc, NmiCause};
pub use record::{FaultKind, FaultRecord, RecordSlot};

/// What the fault paths need from the board. Every function is called from a fault
/// context: interrupts masked or about to be, the stack possibly just overflowed, any lock
/// possibly held by the interrupted code. None may take a lock, allocate or wait.
pub trait FaultBoard {
    /// Puts every output in the safe state with plain register stores: the compare values
    /// of the safe current (compile-time constants) and the output stage's enable off.
    /// Called repeatedly; must be idempotent.
    fn drive_safe();
    /// The record's slot: RAM that neither the start-up code nor a reset clears.
    fn record_slot() -> *mut RecordSlot;
    /// The flash's ECC status register at an NMI.
    fn flash_ecc() -> FlashEcc;
    /// Clears the flash's double-error flag (after a tolerated ECC error).
    fn clear_flash_ecc();
    /// Where the configuration record lives in flash.
    const CONFIG_PAGES: ConfigPages;
    /// Logs a record (the first fault of a run only). May do nothing.
    fn report(record: &FaultRecord);
    /// Logs a panic's message (before its record). May do nothing.
    fn report_panic(info: &core::panic::PanicInfo);
    /// Makes sure a reset follows: starts the watchdog if it is not running.
    fn ensure_reset();
}

/// Installs the fault paths into a binary: the exception vectors of HardFault, MemManage,
/// BusFault, UsageFault, NMI and DefaultHandler, the fault stack, and the panic handler, all
/// going to this crate's code with `$board` as the [`FaultBoard`]. Invoke once, at the top
/// level of the binary crate (which must depend on `cortex-m-rt`).
#[macro_export]
macro_rules! install_fault_handlers {
    ($board:ty) => {
        /// The stack the CPU fault exceptions run on (8-byte aligned, AAPCS).
        #[no_mangle]
        static mut __PAM_FAULT_STACK: $crate::entry::FaultStack = $crate::entry::FaultStack::new();

        // The exception vectors (cortex-m-rt's link.x only PROVIDEs them): each loads the
        // stack pointer at the exception and the exception number, switches to the fault
        // stack and branches to the handler, which never returns.
        ::core::arch::global_asm!(
            ".pushsection .text.__pam_fault_trampoline,\"ax\",%progbits",
            ".global HardFault",
            ".global MemoryManagement",
            ".global BusFault",
            ".global UsageFault",
            ".global DefaultHandler",
            ".type HardFault,%function",
            ".type MemoryManagement,%function",
            ".type BusFault,%function",
            ".type UsageFault,%function",
            ".type DefaultHandler,%function",
            ".thumb_func",
            "HardFault:",
            ".thumb_func",
            "MemoryManagement:",
            ".thumb_func",
            "BusFault:",
            ".thumb_func",
            "UsageFault:",
            ".thumb_func",
            "DefaultHandler:",
            "mrs r0, msp",
            "mrs r1, ipsr",
            "ldr r2, ={stack}",
            "add.w r2, r2, #{size}",
            "mov sp, r2",
            "b {entry}",
            ".popsection",
            stack = sym __PAM_FAULT_STACK,
            size = const $crate::entry::FAULT_STACK_BYTES,
            entry = sym __pam_fault_entry,
        );

        #[no_mangle]
        unsafe extern "C" fn __pam_fault_entry(sp: u32, ipsr: u32) -> ! {
            $crate::fault_entry::<$board>(sp, ipsr)
        }

        #[no_mangle]
        unsafe extern "C" fn NonMaskableInt() {
            $crate::nmi_entry::<$board>()
        }

        #[panic_handler]
        fn __pam_panic(info: &::core::panic::PanicInfo) -> ! {
            $crate::panic_entry::<$board>(info)
        }
    };
}
