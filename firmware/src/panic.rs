//! The panic handler and the CPU fault handlers (HardFault, MemManage, BusFault,
//! UsageFault, unexpected interrupts): outputs to the safe state first, then the log (and,
//! for a CPU fault, a record for the next boot), then a halt that the watchdog turns into a
//! reset. Also the stack's high-water mark (painted stack), at the end of the file.
//!
//! Order matters: the outputs are written before anything that could fail or block. The
//! writes are plain stores to the timer's compare registers of values kept in atomics
//! (`current_output::drive_safe_from_panic`): no lock another context could hold, no
//! allocation, no formatting. Then interrupts are masked (no task runs again, the loop
//! stops feeding the watchdog) and the message goes out over defmt/RTT. The core then
//! waits: a debugger can read the log; the IWDG, if it was started, resets the MCU after
//! `board::WATCHDOG_TIMEOUT_US` and the next boot reports WATCHDOG_RESET. A panic before
//! the watchdog is started halts with the outputs vented.

use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use crate::current_output;

static PANICKING: AtomicBool = AtomicBool::new(false);

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    current_output::drive_safe_from_panic();
    cortex_m::interrupt::disable();
    // A panic inside the logging below must not log again (it could recurse forever).
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!("panic: {}", defmt::Display2Format(info));
    }
    loop {
        // Keep re-asserting the safe outputs: nothing else may touch them now.
        current_output::drive_safe_from_panic();
        core::hint::spin_loop();
    }
}

// ---------------------------------------------------------------------------------------
// CPU fault exceptions
//
// HardFault, MemManage, BusFault, UsageFault and any interrupt without a handler end like
// a panic: outputs to the safe state first (the same plain compare stores), interrupts
// masked, then a record in no-init RAM, then a halt that the IWDG turns into a reset. The
// next boot finds the record ([`FaultRecord::take`]), logs it and latches
// `Faults::CPU_FAULT`, which `pamctl status`/`fault` show. MemManage, BusFault and
// UsageFault are enabled separately at boot ([`enable_fault_exceptions`]) so that each
// reports its own kind; otherwise they escalate to HardFault, which is handled the same.
// ---------------------------------------------------------------------------------------

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use cortex_m::peripheral::scb::Exception;
use cortex_m::peripheral::SCB;
use cortex_m_rt::{exception, ExceptionFrame};

/// Which exception ended the last run. Numbered like the fault codes: stable, logged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
#[repr(u32)]
pub enum CpuFaultKind {
    HardFault = 1,
    MemManage = 2,
    BusFault = 3,
    UsageFault = 4,
    /// An interrupt or exception without a handler (DefaultHandler).
    UnexpectedInterrupt = 5,
}

impl CpuFaultKind {
    fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            1 => Self::HardFault,
            2 => Self::MemManage,
            3 => Self::BusFault,
            4 => Self::UsageFault,
            5 => Self::UnexpectedInterrupt,
            _ => return None,
        })
    }
}

/// What a fault handler leaves for the next boot. Lives in `.uninit` (cortex-m-rt's NOLOAD
/// section): neither zeroed nor initialised at boot, so it survives the watchdog reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct FaultRecord {
    pub kind: CpuFaultKind,
    /// Stacked PC for a HardFault; 0 where the handler has no exception frame.
    pub pc: u32,
    /// SCB CFSR (MemManage | BusFault | UsageFault status) at the fault.
    pub cfsr: u32,
    /// SCB HFSR at the fault.
    pub hfsr: u32,
    /// MMFAR or BFAR when valid, else 0; the IRQ number for an unexpected interrupt.
    pub address: u32,
}

const RECORD_MAGIC: u32 = 0xFA17_C0DE;

#[repr(C)]
struct RawRecord {
    magic: u32,
    kind: u32,
    pc: u32,
    cfsr: u32,
    hfsr: u32,
    address: u32,
    /// magic ^ kind ^ pc ^ cfsr ^ hfsr ^ address, rotated: random RAM after power-up is
    /// not taken for a record.
    check: u32,
}

impl RawRecord {
    fn check(&self) -> u32 {
        (self.magic ^ self.kind ^ self.pc ^ self.cfsr ^ self.hfsr ^ self.address).rotate_left(7)
    }
}

#[link_section = ".uninit.FAULT_RECORD"]
static mut FAULT_RECORD: MaybeUninit<RawRecord> = MaybeUninit::uninit();

impl FaultRecord {
    /// The record left by a fault handler before the last reset, if any; clears it, so
    /// that the next boot reports only its own. Called once at boot.
    pub fn take() -> Option<Self> {
        // SAFETY: called once from `main` before any interrupt that could fault; a plain
        // read of words (any bit pattern is a valid u32), then a volatile clear.
        unsafe {
            let raw = addr_of!(FAULT_RECORD).cast::<RawRecord>().read_volatile();
            addr_of_mut!(FAULT_RECORD)
                .cast::<RawRecord>()
                .write_volatile(RawRecord {
                    magic: 0,
                    kind: 0,
                    pc: 0,
                    cfsr: 0,
                    hfsr: 0,
                    address: 0,
                    check: 0,
                });
            if raw.magic != RECORD_MAGIC || raw.check != raw.check() {
                return None;
            }
            Some(FaultRecord {
                kind: CpuFaultKind::from_u32(raw.kind)?,
                pc: raw.pc,
                cfsr: raw.cfsr,
                hfsr: raw.hfsr,
                address: raw.address,
            })
        }
    }
}

/// Enables the separate MemManage, BusFault and UsageFault handlers (SCB SHCSR); call
/// once at boot. Their priority stays 0, above every interrupt.
pub fn enable_fault_exceptions(scb: &mut SCB) {
    scb.enable(Exception::MemoryManagement);
    scb.enable(Exception::BusFault);
    scb.enable(Exception::UsageFault);
}

/// Outputs safe, interrupts masked, record written, log; then the same halt as a panic.
fn fault_halt(kind: CpuFaultKind, pc: u32) -> ! {
    current_output::drive_safe_from_panic();
    cortex_m::interrupt::disable();
    // SAFETY: the SCB registers are read-only here; `ptr()` is the fixed address.
    let (cfsr, hfsr, mmfar, bfar) = unsafe {
        let scb = &*SCB::PTR;
        (
            scb.cfsr.read(),
            scb.hfsr.read(),
            scb.mmfar.read(),
            scb.bfar.read(),
        )
    };
    let address = match kind {
        CpuFaultKind::UnexpectedInterrupt => pc,
        // CFSR.MMARVALID (bit 7), CFSR.BFARVALID (bit 15)
        _ if cfsr & (1 << 7) != 0 => mmfar,
        _ if cfsr & (1 << 15) != 0 => bfar,
        _ => 0,
    };
    let pc = if kind == CpuFaultKind::UnexpectedInterrupt {
        0
    } else {
        pc
    };
    let mut raw = RawRecord {
        magic: RECORD_MAGIC,
        kind: kind as u32,
        pc,
        cfsr,
        hfsr,
        address,
        check: 0,
    };
    raw.check = raw.check();
    // SAFETY: interrupts are masked and nothing else writes the record.
    unsafe {
        addr_of_mut!(FAULT_RECORD)
            .cast::<RawRecord>()
            .write_volatile(raw)
    };
    if !PANICKING.swap(true, Ordering::Relaxed) {
        defmt::error!(
            "CPU fault {}: pc {=u32:#010x}, cfsr {=u32:#010x}, hfsr {=u32:#010x}, address {=u32:#010x}",
            kind,
            pc,
            cfsr,
            hfsr,
            address
        );
    }
    loop {
        current_output::drive_safe_from_panic();
        core::hint::spin_loop();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    fault_halt(CpuFaultKind::HardFault, frame.pc())
}

#[exception]
fn MemoryManagement() {
    fault_halt(CpuFaultKind::MemManage, 0)
}

#[exception]
fn BusFault() {
    fault_halt(CpuFaultKind::BusFault, 0)
}

#[exception]
fn UsageFault() {
    fault_halt(CpuFaultKind::UsageFault, 0)
}

/// The wire form of a record, for `status`.
impl From<FaultRecord> for pam_protocol::CpuFault {
    fn from(r: FaultRecord) -> Self {
        use pam_protocol::CpuFaultKind as K;
        pam_protocol::CpuFault {
            kind: match r.kind {
                CpuFaultKind::HardFault => K::HardFault,
                CpuFaultKind::MemManage => K::MemManage,
                CpuFaultKind::BusFault => K::BusFault,
                CpuFaultKind::UsageFault => K::UsageFault,
                CpuFaultKind::UnexpectedInterrupt => K::UnexpectedInterrupt,
            },
            pc: r.pc,
            address: r.address,
        }
    }
}

/// Flash double-bit ECC errors seen (and survived) since boot.
pub static FLASH_ECC_ERRORS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// The G4 raises an NMI for a flash double-bit ECC error (RM0440 §3.3.4, FLASH_ECCR.ECCD).
/// The one flash area that is ever programmed is the configuration record's; a power loss
/// while it is written can leave such a double-word, and reading it at boot must give a
/// record that fails its CRC (defaults + SELF_CHECK), not a fault, a watchdog reset and
/// the same again at every boot. Any other NMI ends like a CPU fault.
// SAFETY (cortex-m-rt's requirement for an NMI handler): it shares nothing with the code
// it interrupts but the FLASH_ECCR flag it clears and an atomic counter.
#[exception]
unsafe fn NonMaskableInt() {
    let flash = embassy_stm32::pac::FLASH;
    if flash.eccr().read().eccd() {
        // write 1 to clear
        flash.eccr().modify(|w| w.set_eccd(true));
        FLASH_ECC_ERRORS.fetch_add(1, Ordering::Relaxed);
        return;
    }
    fault_halt(CpuFaultKind::UnexpectedInterrupt, u32::MAX)
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    // the IRQ number travels in the record's address field
    fault_halt(CpuFaultKind::UnexpectedInterrupt, irqn as i32 as u32)
}

// ---------------------------------------------------------------------------------------
// Stack guard and high-water mark
//
// The stack grows down from `_stack_start` (the end of RAM) towards the statics, which end
// at cortex-m-rt's `_stack_end`. Just above them an MPU region of 1 KiB forbids every
// access ([`enable_stack_guard`], `pam_firmware_logic::stack_guard`): an overflow faults
// (MemManage, escalated to HardFault when the handler cannot push either; HardFault runs
// with the MPU off, HFNMIENA = 0, so its handler vents and records) instead of silently
// overwriting the statics, the telemetry channel and the task pools. Why not flip-link
// (which moves the stack below the statics so that an overflow leaves RAM): it is a
// separate linker binary that `./test.sh` and every developer would have to
// `cargo install`; the MPU needs nothing outside the firmware.
//
// At boot the unused stack above the guard (up to a margin below the live stack pointer) is
// filled with a pattern; [`stack_usage`] later finds the lowest word that changed. A run
// whose free stack falls below `board::STACK_MIN_FREE_BYTES` latches `Faults::STACK_LOW`.
// ---------------------------------------------------------------------------------------

use pam_firmware_logic::stack_guard::StackGuard;

const STACK_PAINT: u32 = 0x5AC5_5AC5;
/// Left unpainted below the stack pointer at the time of painting (the painting
/// function's own frame, an interrupt that arrives meanwhile).
const PAINT_MARGIN_BYTES: usize = 256;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

fn guard() -> Option<StackGuard> {
    // linker symbols: only their addresses are taken
    let (end, start) = (
        addr_of!(_stack_end) as u32,
        addr_of!(_stack_start) as u32,
    );
    StackGuard::new(end, start, crate::board::STACK_MIN_FREE_BYTES)
}

/// The usable stack: (lowest address, above the guard if there is one; top).
fn stack_bounds() -> (usize, usize) {
    let top = addr_of!(_stack_start) as usize;
    match guard() {
        Some(g) => (g.floor as usize, top),
        None => (addr_of!(_stack_end) as usize, top),
    }
}

/// Makes the guard region no-access (MPU region 0; privileged code keeps the default
/// memory map everywhere else). Call once at boot, before anything deep runs. Returns
/// false if the stack is too small for a guard (then there is none).
pub fn enable_stack_guard(mpu: &mut cortex_m::peripheral::MPU) -> bool {
    let Some(g) = guard() else {
        return false;
    };
    // RASR: XN (28), AP = 000 no access (26:24), normal memory S C (18, 17), SIZE, ENABLE
    let rasr = (1 << 28) | (1 << 18) | (1 << 17) | (g.rasr_size_field() << 1) | 1;
    // SAFETY: the region covers only the guard, which nothing uses (the statics end below
    // it, the painted stack starts above it); PRIVDEFENA keeps the default map elsewhere.
    unsafe {
        mpu.rnr.write(0);
        mpu.rbar.write(g.base);
        mpu.rasr.write(rasr);
        // ENABLE | PRIVDEFENA; HFNMIENA = 0: HardFault and NMI run without the MPU
        mpu.ctrl.write(0b101);
    }
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
    true
}

/// Fills the unused stack with the pattern. Call once at boot.
#[inline(never)]
pub fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let top = sp.saturating_sub(PAINT_MARGIN_BYTES) & !3;
    let mut p = bottom;
    while p < top {
        // SAFETY: [bottom, sp − margin) is RAM below the live stack that nothing uses.
        unsafe { (p as *mut u32).write_volatile(STACK_PAINT) };
        p += 4;
    }
}

impl From<StackUsage> for pam_protocol::StackUsage {
    fn from(s: StackUsage) -> Self {
        pam_protocol::StackUsage {
            used_max_bytes: s.used_max_bytes,
            size_bytes: s.size_bytes,
        }
    }
}

/// Stack size and the deepest use seen since boot, bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub struct StackUsage {
    pub size_bytes: u32,
    pub used_max_bytes: u32,
}

impl StackUsage {
    pub fn free_min_bytes(&self) -> u32 {
        self.size_bytes.saturating_sub(self.used_max_bytes)
    }
}

/// The high-water mark: scans up from the bottom to the first overwritten word.
pub fn stack_usage() -> StackUsage {
    let (bottom, top) = stack_bounds();
    let mut p = bottom;
    // SAFETY: reads of RAM inside the stack region, word-aligned.
    while p < top && unsafe { (p as *const u32).read_volatile() } == STACK_PAINT {
        p += 4;
    }
    StackUsage {
        size_bytes: (top - bottom) as u32,
        used_max_bytes: (top - p) as u32,
    }
}
