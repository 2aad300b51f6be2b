//! The firmware's own fault paths (`pam-fault-paths`, the code the board runs) on a
//! Cortex-M4 in QEMU (mps2-an386, which has an MPU and a CMSDK watchdog), against an
//! emulated board: the output registers, OUT_EN# and the flash's ECC status are words in
//! RAM that a reset does not clear, the CMSDK watchdog stands in for the IWDG.
//!
//! One run is several boots. Each boot checks what the previous one left (the reset
//! happened, the record, the outputs at the safe value and OUT_EN# high), then sets the
//! outputs to a running value and drives the next fault:
//!
//! 1. in-process: the device lock lets a more urgent interrupt (the E-stop) pre-empt it and
//!    holds the others off; a flash ECC error in the configuration pages is survived;
//!    then a stack overflow into the MPU guard → MemManage/HardFault;
//! 2. a panic;
//! 3. an NMI with a double-bit ECC error in the program's flash;
//! 4. an NMI with no ECC error (any other source);
//! 5. an interrupt without a handler;
//! 6. an undefined instruction (UsageFault: the record holds its address);
//! 7. the same with UsageFault disabled (escalated to HardFault);
//! 8. a stack overflow with MemManage disabled (HardFault with the stack pointer in the
//!    guard: the handler runs on its own stack);
//!
//! and the last boot prints `qemu: N passed, M failed` and exits through semihosting.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::ptr::{addr_of, addr_of_mut};
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m::peripheral::scb::Exception;
use cortex_m::peripheral::{NVIC, SCB};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use pam_fault_paths::ceiling::with_ceiling;
use pam_fault_paths::{ConfigPages, FaultBoard, FaultKind, FaultRecord, FlashEcc, RecordSlot};
use pam_firmware_logic::current_loop::nominal_counts;

// ---------------------------------------------------------------------------------------
// The emulated board

/// The output stage of the board (docs/output-stage.md): 24.19 mA at 100 % duty, 8500
/// counts per period. The firmware's `board::OUTPUT_SAFE_COMPARE` is the same constant.
const SAFE_COMPARE: u16 = nominal_counts(4.0, 10.0 * 3.000 / 1.24, 8500);
/// A running value (20 mA) the outputs hold before each fault.
const RUNNING_COMPARE: u16 = 7027;
/// The board's configuration pages (firmware `board::CONFIG_PAGES`).
const CONFIG_PAGES: ConfigPages = ConfigPages {
    bank2_offset: 0x3_F000,
    bytes: 2 * 2048,
    bank_bytes: 256 * 1024,
};
const ECCD: u32 = 1 << 31;
const BK_ECC: u32 = 1 << 21;

/// Everything that must survive a reset: outside every section (memory.x).
#[repr(C)]
struct Persistent {
    magic: u32,
    stage: u32,
    boots: u32,
    passed: u32,
    failed: u32,
    /// The panic's source line, for the record's check.
    panic_line: u32,
    /// Emulated TIM3 CCR1–4.
    compare: [u32; 4],
    /// Emulated OUT_EN# level (1 = high = outputs off).
    out_en_high: u32,
    /// Emulated FLASH_ECCR.
    eccr: u32,
    record: RecordSlot,
}

const PERSISTENT_ADDR: usize = 0x203F_F000;
const MAGIC: u32 = 0x7E57_FA17;

fn state() -> *mut Persistent {
    PERSISTENT_ADDR as *mut Persistent
}

/// Volatile access to one field of the persistent state.
macro_rules! get {
    ($field:ident) => {
        // SAFETY: the reserved RAM at PERSISTENT_ADDR; a single core, plain words
        unsafe { addr_of!((*state()).$field).read_volatile() }
    };
}
macro_rules! set {
    ($field:ident, $value:expr) => {{
        let value = $value;
        // SAFETY: as above
        unsafe { addr_of_mut!((*state()).$field).write_volatile(value) }
    }};
}

/// The CMSDK APB watchdog of mps2-an386 (0x4000_8000): the first timeout raises an NMI,
/// the second resets the machine (RESEN).
const WDOG: usize = 0x4000_8000;
const WDOG_LOAD: usize = WDOG;
const WDOG_CONTROL: usize = WDOG + 0x08;
const WDOG_LOCK: usize = WDOG + 0xC00;

struct QemuBoard;

impl FaultBoard for QemuBoard {
    fn drive_safe() {
        for c in 0..4 {
            // SAFETY: the emulated registers
            unsafe { addr_of_mut!((*state()).compare[c]).write_volatile(u32::from(SAFE_COMPARE)) };
        }
        set!(out_en_high, 1);
    }

    fn record_slot() -> *mut RecordSlot {
        // SAFETY: a field address, no access
        unsafe { addr_of_mut!((*state()).record) }
    }

    fn flash_ecc() -> FlashEcc {
        FlashEcc::from_eccr(get!(eccr))
    }

    fn clear_flash_ecc() {
        set!(eccr, get!(eccr) & !ECCD);
    }

    const CONFIG_PAGES: ConfigPages = CONFIG_PAGES;

    fn report(r: &FaultRecord) {
        hprintln!(
            "fault path: {} pc {:#010x} cfsr {:#010x} hfsr {:#010x} address {:#010x}",
            r.kind.name(),
            r.pc,
            r.cfsr,
            r.hfsr,
            r.address
        );
    }

    fn report_panic(info: &core::panic::PanicInfo) {
        hprintln!("fault path: panic: {}", info);
    }

    fn ensure_reset() {
        // SAFETY: the watchdog's registers; unlock, 0.1 ms of its 25 MHz clock, INTEN | RESEN
        unsafe {
            (WDOG_LOCK as *mut u32).write_volatile(0x1ACC_E551);
            (WDOG_LOAD as *mut u32).write_volatile(2_500);
            (WDOG_CONTROL as *mut u32).write_volatile(0b11);
        }
    }
}

pam_fault_paths::install_fault_handlers!(QemuBoard);

// ---------------------------------------------------------------------------------------
// Checks

fn check(name: &str, ok: bool) {
    if ok {
        set!(passed, get!(passed) + 1);
        hprintln!("ok   fault paths {}", name);
    } else {
        set!(failed, get!(failed) + 1);
        hprintln!("FAIL fault paths {}", name);
    }
}

fn outputs_running() {
    for c in 0..4 {
        // SAFETY: the emulated registers
        unsafe { addr_of_mut!((*state()).compare[c]).write_volatile(u32::from(RUNNING_COMPARE)) };
    }
    set!(out_en_high, 0);
}

fn outputs_safe() -> bool {
    let compare = get!(compare);
    compare.iter().all(|&c| c == u32::from(SAFE_COMPARE)) && get!(out_en_high) == 1
}

fn outputs_untouched() -> bool {
    let compare = get!(compare);
    compare.iter().all(|&c| c == u32::from(RUNNING_COMPARE)) && get!(out_en_high) == 0
}

/// What the previous boot's fault left: the record of `kind` (and `address` when given),
/// the outputs at the safe value with OUT_EN# high.
fn check_after_reset(label: &str, record: Option<FaultRecord>, kinds: &[FaultKind]) {
    hprintln!(
        "     after the {} and the watchdog reset: {:?}",
        label,
        record
    );
    check(
        "a record of the fault survived the reset",
        record.is_some_and(|r| kinds.contains(&r.kind)),
    );
    check(
        "the outputs were left at the safe compare value (4 mA) and OUT_EN# high",
        outputs_safe(),
    );
}

// ---------------------------------------------------------------------------------------
// Interrupts for the lock's test: a RAM vector table with three handlers

/// E-stop-like (more urgent than the lock's ceiling), control-like (at the ceiling) and
/// link-like (below it); byte priorities that survive 3 implemented priority bits.
const IRQ_ESTOP: usize = 0;
const IRQ_CONTROL: usize = 1;
const IRQ_LINK: usize = 2;
const PRIO_ESTOP: u8 = 0x20;
const CEILING: u8 = 0x40;
const PRIO_LINK: u8 = 0x60;

static ESTOP_RAN: AtomicBool = AtomicBool::new(false);
static LINK_RAN: AtomicBool = AtomicBool::new(false);
/// Seen inside the control handler's lock: (E-stop ran, link ran).
static INSIDE: [AtomicBool; 2] = [AtomicBool::new(false), AtomicBool::new(false)];
/// The same with a critical section instead of the lock.
static INSIDE_CS: [AtomicBool; 2] = [AtomicBool::new(false), AtomicBool::new(false)];
static USE_CRITICAL_SECTION: AtomicBool = AtomicBool::new(false);

extern "C" fn estop_handler() {
    ESTOP_RAN.store(true, Ordering::SeqCst);
}

extern "C" fn link_handler() {
    LINK_RAN.store(true, Ordering::SeqCst);
}

fn pend(irq: usize) {
    // SAFETY: NVIC set-pending register, IRQs 0..31
    unsafe { (*NVIC::PTR).ispr[0].write(1 << irq) };
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
}

/// Runs at the ceiling's priority, like the control task: pends the E-stop and the link
/// inside the lock and notes which ran before the lock was released.
extern "C" fn control_handler() {
    let body = || {
        pend(IRQ_ESTOP);
        pend(IRQ_LINK);
        [
            ESTOP_RAN.load(Ordering::SeqCst),
            LINK_RAN.load(Ordering::SeqCst),
        ]
    };
    if USE_CRITICAL_SECTION.load(Ordering::SeqCst) {
        let seen = cortex_m::interrupt::free(|_| body());
        INSIDE_CS[0].store(seen[0], Ordering::SeqCst);
        INSIDE_CS[1].store(seen[1], Ordering::SeqCst);
    } else {
        let seen = with_ceiling(CEILING, body);
        INSIDE[0].store(seen[0], Ordering::SeqCst);
        INSIDE[1].store(seen[1], Ordering::SeqCst);
    }
}

#[repr(C, align(256))]
struct VectorTable([u32; 48]);
static mut VECTORS: VectorTable = VectorTable([0; 48]);

fn install_test_vectors() {
    // SAFETY: the table is copied from the one at address 0 (VTOR's reset value), three
    // entries replaced, then VTOR points at it; nothing else uses it.
    unsafe {
        let table = &mut *addr_of_mut!(VECTORS);
        for (i, slot) in table.0.iter_mut().enumerate() {
            *slot = ((i * 4) as *const u32).read_volatile();
        }
        table.0[16 + IRQ_ESTOP] = estop_handler as *const () as usize as u32;
        table.0[16 + IRQ_CONTROL] = control_handler as *const () as usize as u32;
        table.0[16 + IRQ_LINK] = link_handler as *const () as usize as u32;
        (*SCB::PTR).vtor.write(table.0.as_ptr() as u32);
        let nvic = &*NVIC::PTR;
        nvic.ipr[IRQ_ESTOP].write(PRIO_ESTOP);
        nvic.ipr[IRQ_CONTROL].write(CEILING);
        nvic.ipr[IRQ_LINK].write(PRIO_LINK);
        nvic.iser[0].write((1 << IRQ_ESTOP) | (1 << IRQ_CONTROL) | (1 << IRQ_LINK));
    }
}

fn run_lock(critical_section: bool) -> [bool; 2] {
    ESTOP_RAN.store(false, Ordering::SeqCst);
    LINK_RAN.store(false, Ordering::SeqCst);
    USE_CRITICAL_SECTION.store(critical_section, Ordering::SeqCst);
    pend(IRQ_CONTROL);
    let inside = if critical_section {
        &INSIDE_CS
    } else {
        &INSIDE
    };
    [
        inside[0].load(Ordering::SeqCst),
        inside[1].load(Ordering::SeqCst),
    ]
}

fn lock_checks() {
    install_test_vectors();
    let [estop_inside, link_inside] = run_lock(false);
    check(
        "the device lock: an E-stop interrupt pre-empts a control step holding it",
        estop_inside,
    );
    check(
        "the device lock: a lower-priority interrupt waits for it",
        !link_inside && LINK_RAN.load(Ordering::SeqCst),
    );
    // The check above can fail: a critical section (PRIMASK) holds the E-stop off.
    let [estop_inside_cs, _] = run_lock(true);
    check(
        "a critical section instead would hold the E-stop off (the check discriminates)",
        !estop_inside_cs && ESTOP_RAN.load(Ordering::SeqCst),
    );
    // SAFETY: back to the image's vector table for the faults below
    unsafe { (*SCB::PTR).vtor.write(0) };
}

// ---------------------------------------------------------------------------------------
// The faults

fn pend_nmi() {
    // SAFETY: ICSR.NMIPENDSET
    unsafe { (*SCB::PTR).icsr.write(1 << 31) };
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
}

// An undefined instruction at a known address (the stacked PC of its fault).
core::arch::global_asm!(
    ".pushsection .text.pam_test_udf,\"ax\",%progbits",
    ".global pam_test_udf",
    ".type pam_test_udf,%function",
    ".thumb_func",
    "pam_test_udf:",
    "udf #0",
    "bx lr",
    ".popsection",
);
extern "C" {
    fn pam_test_udf();
}

fn udf_address() -> u32 {
    (pam_test_udf as *const () as u32) & !1
}

#[inline(never)]
#[allow(unconditional_recursion)]
fn recurse(depth: u32) -> u32 {
    let frame = [depth; 32];
    black_box(&frame);
    recurse(black_box(depth + 1)).wrapping_add(frame[7])
}

fn in_guard(record: Option<FaultRecord>) -> bool {
    pam_fault_paths::guard::guard_bounds()
        .is_some_and(|(base, floor)| record.is_some_and(|r| r.address >= base && r.address < floor))
}

fn next_stage(stage: u32) {
    set!(stage, stage);
    outputs_running();
}

/// Takes this boot's record from the persistent slot.
fn take_record() -> Option<FaultRecord> {
    // SAFETY: the record's slot in the persistent RAM
    unsafe { pam_fault_paths::record::take(QemuBoard::record_slot()) }
}

fn finish() -> ! {
    let (passed, failed) = (get!(passed), get!(failed));
    set!(magic, 0);
    hprintln!("qemu: {} passed, {} failed", passed, failed);
    debug::exit(if failed == 0 {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}

/// Boots 1–4: the in-process checks and the stack overflow; its check and the panic; the
/// panic's check and an ECC error in the program; its check and an NMI of no known source.
fn first_faults(stage: u32, record: Option<FaultRecord>, core: &mut cortex_m::Peripherals) {
    match stage {
        0 => {
            lock_checks();

            // a double-bit ECC error in the configuration pages is survived
            outputs_running();
            set!(eccr, ECCD | BK_ECC | 0x3_F010);
            pend_nmi();
            check(
                "NMI: an ECC error in the configuration pages is cleared and counted",
                get!(eccr) & ECCD == 0 && pam_fault_paths::tolerated_ecc_errors() == 1,
            );
            check(
                "NMI: ... and leaves the outputs alone and no record",
                outputs_untouched() && take_record().is_none(),
            );

            let guard = pam_fault_paths::guard::enable_stack_guard(&mut core.MPU, 8 * 1024);
            check("the MPU stack guard is enabled", guard);
            next_stage(1);
            hprintln!("     stack overflow into the MPU guard");
            black_box(recurse(0));
        }
        1 => {
            check_after_reset("stack overflow", record, &[FaultKind::MemManage]);
            check("the record names an address in the guard", in_guard(record));
            next_stage(2);
            set!(panic_line, line!() + 1);
            panic!("a deliberate panic");
        }
        2 => {
            check_after_reset("panic", record, &[FaultKind::Panic]);
            check(
                "the panic's record holds its source line",
                record.is_some_and(|r| r.address == get!(panic_line)),
            );
            next_stage(3);
            hprintln!("     NMI: a double-bit ECC error in the program's flash");
            set!(eccr, ECCD | 0x0_1000);
            pend_nmi();
        }
        3 => {
            check_after_reset(
                "NMI (ECC error outside the configuration pages)",
                record,
                &[FaultKind::Nmi],
            );
            check(
                "the NMI's record holds the ECC address",
                record.is_some_and(|r| r.address == 0x1000),
            );
            next_stage(4);
            hprintln!("     NMI: not a flash ECC error");
            pend_nmi();
        }
        _ => {}
    }
}

/// Boots 5–9: the NMI's check and an unexpected interrupt; a UsageFault; a HardFault; a
/// stack overflow escalated to HardFault; its check and the summary.
fn later_faults(stage: u32, record: Option<FaultRecord>, core: &mut cortex_m::Peripherals) {
    match stage {
        4 => {
            check_after_reset("NMI (no ECC error)", record, &[FaultKind::Nmi]);
            check(
                "the NMI's record says no ECC address",
                record.is_some_and(|r| r.address == u32::MAX),
            );
            next_stage(5);
            hprintln!("     an interrupt without a handler (IRQ 5)");
            // SAFETY: IRQ 5's vector is DefaultHandler (the image's table)
            unsafe { (*NVIC::PTR).iser[0].write(1 << 5) };
            pend(5);
        }
        5 => {
            check_after_reset(
                "unexpected interrupt",
                record,
                &[FaultKind::UnexpectedInterrupt],
            );
            check(
                "the record holds the IRQ number",
                record.is_some_and(|r| r.address == 5),
            );
            next_stage(6);
            hprintln!("     an undefined instruction at {:#010x}", udf_address());
            // SAFETY: faults; the fault path never returns
            unsafe { pam_test_udf() };
        }
        6 => {
            check_after_reset("UsageFault", record, &[FaultKind::UsageFault]);
            check(
                "the record holds the faulting instruction's address (stacked PC) and UNDEFINSTR",
                record.is_some_and(|r| r.pc == udf_address() && r.cfsr & (1 << 16) != 0),
            );
            next_stage(7);
            hprintln!("     the same with UsageFault disabled: escalated to HardFault");
            core.SCB.disable(Exception::UsageFault);
            // SAFETY: as above
            unsafe { pam_test_udf() };
        }
        7 => {
            check_after_reset("HardFault", record, &[FaultKind::HardFault]);
            check(
                "the record holds the stacked PC and HFSR.FORCED",
                record.is_some_and(|r| r.pc == udf_address() && r.hfsr & (1 << 30) != 0),
            );
            let guard = pam_fault_paths::guard::enable_stack_guard(&mut core.MPU, 8 * 1024);
            next_stage(8);
            core.SCB.disable(Exception::MemoryManagement);
            hprintln!("     stack overflow with MemManage disabled");
            if guard {
                black_box(recurse(0));
            }
        }
        8 => {
            check_after_reset(
                "stack overflow (HardFault)",
                record,
                &[FaultKind::HardFault],
            );
            check("the record names an address in the guard", in_guard(record));
            finish();
        }
        _ => {}
    }
}

#[entry]
fn main() -> ! {
    let mut core = cortex_m::Peripherals::take().unwrap();
    if get!(magic) != MAGIC {
        // first boot: the persistent RAM holds whatever QEMU left there
        set!(magic, MAGIC);
        set!(stage, 0);
        set!(boots, 0);
        set!(passed, 0);
        set!(failed, 0);
        set!(eccr, 0);
        let _ = take_record();
        hprintln!("the firmware's fault paths (pam-fault-paths) on Cortex-M4 (QEMU mps2-an386)");
    }
    set!(boots, get!(boots) + 1);
    let record = take_record();
    set!(eccr, 0);
    core.SCB.enable(Exception::MemoryManagement);
    core.SCB.enable(Exception::BusFault);
    core.SCB.enable(Exception::UsageFault);
    if get!(boots) > 12 {
        check("the fault sequence ends", false);
        finish();
    }
    let stage = get!(stage);
    if stage > 0 {
        check(
            "the fault path reset the machine (the next boot ran)",
            get!(boots) == stage + 1,
        );
    }
    match stage {
        0..=3 => first_faults(stage, record, &mut core),
        4..=8 => later_faults(stage, record, &mut core),
        _ => {
            check("a known stage", false);
            finish();
        }
    }
    check("the fault path did not return", false);
    finish()
}
