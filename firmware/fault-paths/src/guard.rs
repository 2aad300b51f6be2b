//! The MPU stack guard and the painted stack's high-water mark.
//!
//! The stack grows down from `_stack_start` (the end of RAM) towards the statics, which end
//! at cortex-m-rt's `_stack_end`. Just above them an MPU region of 1 KiB forbids every
//! access (`pam_firmware_logic::stack_guard`): an overflow faults (MemManage, or HardFault
//! when the exception cannot stack its frame either; HardFault runs with the MPU off,
//! HFNMIENA = 0) instead of silently overwriting the statics. The fault exceptions then run
//! on a stack of their own ([`crate::install_fault_handlers!`]). An MPU region rather than
//! flip-link: flip-link is a separate linker every machine would have to `cargo install`.
//!
//! At boot the unused stack above the guard (up to a margin below the live stack pointer) is
//! filled with a pattern; [`stack_usage`] later finds the lowest word that changed.

use core::ptr::addr_of;

use pam_firmware_logic::stack_guard::StackGuard;

const STACK_PAINT: u32 = 0x5AC5_5AC5;
/// Left unpainted below the stack pointer at the time of painting (the painting
/// function's own frame, an interrupt that arrives meanwhile).
const PAINT_MARGIN_BYTES: usize = 256;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// (end of the statics, start of the stack) from the linker's symbols.
fn linker_bounds() -> (u32, u32) {
    // only the symbols' addresses are taken
    (addr_of!(_stack_end) as u32, addr_of!(_stack_start) as u32)
}

/// The guard's place (whether or not it is enabled: it depends only on the statics' end).
fn place() -> Option<StackGuard> {
    let (end, start) = linker_bounds();
    StackGuard::new(end, start, 0)
}

/// (lowest stack address, lowest address above the guard, top of the stack).
pub fn stack_region() -> (u32, u32, u32) {
    let (end, start) = linker_bounds();
    match place() {
        Some(g) => (end, g.floor, start),
        None => (end, end, start),
    }
}

/// The guard's bounds: [base, floor).
pub fn guard_bounds() -> Option<(u32, u32)> {
    place().map(|g| (g.base, g.floor))
}

/// Makes the guard region no-access (MPU region 0; privileged code keeps the default
/// memory map everywhere else). Call once at boot, before anything deep runs. Returns
/// false if the stack is too small for a guard and `min_stack_bytes` above it (then
/// there is none).
pub fn enable_stack_guard(mpu: &mut cortex_m::peripheral::MPU, min_stack_bytes: u32) -> bool {
    let (end, start) = linker_bounds();
    let Some(g) = StackGuard::new(end, start, min_stack_bytes) else {
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

/// Fills the unused stack above the guard with the pattern. Call once at boot.
#[inline(never)]
pub fn paint_stack() {
    let (_, floor, _) = stack_region();
    let sp = cortex_m::register::msp::read() as usize;
    let top = sp.saturating_sub(PAINT_MARGIN_BYTES) & !3;
    let mut p = floor as usize;
    while p < top {
        // SAFETY: [floor, sp − margin) is RAM below the live stack that nothing uses.
        unsafe { (p as *mut u32).write_volatile(STACK_PAINT) };
        p += 4;
    }
}

/// Stack size and the deepest use seen since boot, bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StackUsage {
    pub size_bytes: u32,
    pub used_max_bytes: u32,
}

impl StackUsage {
    pub fn free_min_bytes(&self) -> u32 {
        self.size_bytes.saturating_sub(self.used_max_bytes)
    }
}

/// The high-water mark: scans up from the guard to the first overwritten word.
pub fn stack_usage() -> StackUsage {
    let (_, floor, top) = stack_region();
    let mut p = floor;
    // SAFETY: reads of RAM inside the stack region, word-aligned.
    while p < top && unsafe { (p as *const u32).read_volatile() } == STACK_PAINT {
        p += 4;
    }
    StackUsage {
        size_bytes: top - floor,
        used_max_bytes: top - p,
    }
}
