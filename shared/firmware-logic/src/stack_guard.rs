//! Where the MPU's stack guard goes (ARMv7-M PMSA): a no-access region at the bottom of the
//! stack, just above the statics (cortex-m-rt's `_stack_end`), so that a stack overflow
//! faults instead of silently overwriting the statics. A region's size is a power of two of
//! at least 32 bytes and its base a multiple of its size (ARMv7-M ARM, B3.5.8).

/// Guard size: larger than any single stack frame of the firmware (the largest, the
/// configuration store's record buffer, is ≈ 560 bytes), so an overflow cannot step over it.
pub const GUARD_BYTES: u32 = 1024;

/// The guard region and the lowest stack address usable above it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StackGuard {
    pub base: u32,
    pub size_bytes: u32,
    /// The first byte above the guard: the stack's real bottom (painting starts here).
    pub floor: u32,
}

impl StackGuard {
    /// The guard for the stack from `stack_end` (low, the end of the statics) up to
    /// `stack_start` (high, the initial stack pointer); `None` if it leaves less than
    /// `min_stack_bytes` of stack.
    pub fn new(stack_end: u32, stack_start: u32, min_stack_bytes: u32) -> Option<StackGuard> {
        let base = stack_end.checked_add(GUARD_BYTES - 1)? & !(GUARD_BYTES - 1);
        let floor = base.checked_add(GUARD_BYTES)?;
        (stack_start >= floor && stack_start - floor >= min_stack_bytes).then_some(StackGuard {
            base,
            size_bytes: GUARD_BYTES,
            floor,
        })
    }

    /// MPU_RASR.SIZE: the region is 2^(SIZE+1) bytes.
    pub fn rasr_size_field(&self) -> u32 {
        self.size_bytes.trailing_zeros() - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_guard_is_aligned_above_the_statics_and_below_the_stack() {
        // statics end at an odd address (7 704 B of them)
        let end = 0x2000_0000 + 7_704;
        let g = StackGuard::new(end, 0x2002_0000, 8 * 1024).unwrap();
        assert_eq!(g.base % g.size_bytes, 0);
        assert!(g.base >= end && g.base - end < GUARD_BYTES);
        assert_eq!(g.floor, g.base + GUARD_BYTES);
        assert_eq!(1u32 << (g.rasr_size_field() + 1), GUARD_BYTES);
        // already aligned: no gap
        let g = StackGuard::new(0x2000_2000, 0x2002_0000, 0).unwrap();
        assert_eq!(g.base, 0x2000_2000);
    }

    #[test]
    fn no_guard_when_it_would_eat_the_stack() {
        assert_eq!(StackGuard::new(0x2001_FC00, 0x2002_0000, 8 * 1024), None);
        assert_eq!(StackGuard::new(u32::MAX - 10, u32::MAX, 0), None);
    }
}
