//! The fault paths themselves: the CPU fault exceptions' handler (on the fault stack), the
//! NMI handler and the panic handler. [`crate::install_fault_handlers!`] wires them.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cortex_m::peripheral::SCB;
use pam_firmware_logic::nmi::{classify, NmiCause};

use crate::record::{self, FaultKind, FaultRecord};
use crate::FaultBoard;

/// The fault stack's size: the handler, the record and the log's formatting.
pub const FAULT_STACK_BYTES: usize = 2048;

/// The stack the CPU fault exceptions switch to.
#[repr(C, align(8))]
pub struct FaultStack([u8; FAULT_STACK_BYTES]);

impl FaultStack {
    #[allow(clippy::new_without_default)]
    pub const fn new() -> Self {
        Self([0; FAULT_STACK_BYTES])
    }
}

/// Set by the first fault path of a run: a later one (an NMI or a fault inside a handler)
/// keeps the first record and only re-drives the outputs.
static FAULTING: AtomicBool = AtomicBool::new(false);

/// Double-bit ECC errors in the configuration pages survived since boot.
static TOLERATED_ECC_ERRORS: AtomicU32 = AtomicU32::new(0);

pub fn tolerated_ecc_errors() -> u32 {
    TOLERATED_ECC_ERRORS.load(Ordering::Relaxed)
}

// CFSR bits (ARMv7-M ARM B3.2.15)
const MSTKERR: u32 = 1 << 4;
const MMARVALID: u32 = 1 << 7;
const BSTKERR: u32 = 1 << 12;
const BFARVALID: u32 = 1 << 15;

fn fault_status() -> (u32, u32, u32, u32) {
    // SAFETY: reads of the SCB's fault status registers at their fixed address
    unsafe {
        let scb = &*SCB::PTR;
        (
            scb.cfsr.read(),
            scb.hfsr.read(),
            scb.mmfar.read(),
            scb.bfar.read(),
        )
    }
}

/// Writes the record if this is the run's first fault path; true if it was.
fn claim<B: FaultBoard>(record: &FaultRecord) -> bool {
    if FAULTING.swap(true, Ordering::AcqRel) {
        return false;
    }
    // SAFETY: the board's slot; interrupts are masked and only the first path writes
    unsafe { record::write(B::record_slot(), record) };
    true
}

/// Waits for the reset, re-driving the safe outputs: nothing else may touch them now.
fn wait_for_reset<B: FaultBoard>() -> ! {
    B::ensure_reset();
    loop {
        B::drive_safe();
        core::hint::spin_loop();
    }
}

/// Outputs safe, interrupts masked, the record (the first of the run) and its log, then the
/// wait for the reset.
fn halt<B: FaultBoard>(record: FaultRecord) -> ! {
    B::drive_safe();
    cortex_m::interrupt::disable();
    if claim::<B>(&record) {
        B::report(&record);
    }
    wait_for_reset::<B>()
}

/// The CPU fault exceptions (and interrupts without a handler), entered on the fault stack
/// with the stack pointer at the exception (`sp`) and the exception number (`ipsr`).
pub fn fault_entry<B: FaultBoard>(sp: u32, ipsr: u32) -> ! {
    B::drive_safe();
    let exception = ipsr & 0x1FF;
    let (cfsr, hfsr, mmfar, bfar) = fault_status();
    let kind = match exception {
        3 => FaultKind::HardFault,
        4 => FaultKind::MemManage,
        5 => FaultKind::BusFault,
        6 => FaultKind::UsageFault,
        _ => FaultKind::UnexpectedInterrupt,
    };
    let address = match kind {
        // the IRQ number (negative for a system exception without a handler)
        FaultKind::UnexpectedInterrupt => exception.wrapping_sub(16),
        _ if cfsr & MMARVALID != 0 => mmfar,
        _ if cfsr & BFARVALID != 0 => bfar,
        _ => 0,
    };
    let pc = if kind == FaultKind::UnexpectedInterrupt {
        0
    } else {
        stacked_pc(sp, kind, cfsr)
    };
    halt::<B>(FaultRecord {
        kind,
        pc,
        cfsr,
        hfsr,
        address,
    })
}

/// The PC in the exception frame at `sp`, when there is a frame and reading it cannot
/// fault: not after a failed stacking, only inside the stack, and inside the MPU guard only
/// from HardFault (which runs with the MPU off).
fn stacked_pc(sp: u32, kind: FaultKind, cfsr: u32) -> u32 {
    if cfsr & (MSTKERR | BSTKERR) != 0 || sp & 3 != 0 {
        return 0;
    }
    let (bottom, floor, top) = crate::guard::stack_region();
    let lowest = if kind == FaultKind::HardFault {
        bottom
    } else {
        floor
    };
    if sp < lowest || sp.saturating_add(32) > top {
        return 0;
    }
    // SAFETY: an aligned word inside the stack (above the guard, or with the MPU off)
    unsafe { ((sp + 24) as *const u32).read_volatile() }
}

/// The NMI: a double-bit ECC error in the configuration pages is cleared and counted (the
/// record there then fails its CRC); anything else is a fault.
pub fn nmi_entry<B: FaultBoard>() {
    match classify(B::flash_ecc(), B::CONFIG_PAGES) {
        NmiCause::ConfigEcc { .. } => {
            B::clear_flash_ecc();
            TOLERATED_ECC_ERRORS.fetch_add(1, Ordering::Relaxed);
        }
        NmiCause::OtherEcc { address } => halt::<B>(nmi_record(address)),
        NmiCause::Other => halt::<B>(nmi_record(u32::MAX)),
    }
}

fn nmi_record(address: u32) -> FaultRecord {
    let (cfsr, hfsr, _, _) = fault_status();
    FaultRecord {
        kind: FaultKind::Nmi,
        pc: 0,
        cfsr,
        hfsr,
        address,
    }
}

/// A panic: the same halt, with the panic's source line in the record. The record is
/// written before the message is formatted: a panic inside the formatting finds the run
/// already claimed and only waits.
pub fn panic_entry<B: FaultBoard>(info: &core::panic::PanicInfo) -> ! {
    B::drive_safe();
    cortex_m::interrupt::disable();
    let (cfsr, hfsr, _, _) = fault_status();
    let record = FaultRecord {
        kind: FaultKind::Panic,
        pc: 0,
        cfsr,
        hfsr,
        address: info.location().map_or(0, |l| l.line()),
    };
    if claim::<B>(&record) {
        B::report_panic(info);
        B::report(&record);
    }
    wait_for_reset::<B>()
}
