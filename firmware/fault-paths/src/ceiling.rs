//! A priority-ceiling lock (BASEPRI): it masks the interrupts at and below a ceiling
//! priority and leaves the more urgent ones running. The device's lock uses it, so that the
//! emergency stop's interrupt (above the ceiling) pre-empts a control step or a host request
//! in progress instead of waiting for a critical section to end.
//!
//! Priorities are the NVIC's byte values: lower is more urgent. A caller that already runs
//! above the ceiling (a more urgent interrupt, NMI, HardFault) cannot be kept out by
//! BASEPRI; it gets a full critical section instead, which still excludes everyone else.

use core::sync::atomic::{compiler_fence, Ordering};

use cortex_m::peripheral::scb::{Exception, VectActive};
use cortex_m::peripheral::{NVIC, SCB};
use cortex_m::register::{basepri, basepri_max};

/// The priority byte of the running exception, `None` in thread mode. NMI and HardFault
/// (fixed negative priorities, more urgent than any byte) are reported as 0, the most
/// urgent byte, which is above every ceiling the lock accepts (≥ 1).
fn running_priority() -> Option<u8> {
    match SCB::vect_active() {
        VectActive::ThreadMode => None,
        VectActive::Exception(e) => match e {
            Exception::NonMaskableInt | Exception::HardFault => Some(0),
            other => {
                // SAFETY: a read of the SCB's SHPR bytes at their fixed address
                let scb = unsafe { &*SCB::PTR };
                let index = match other.irqn() {
                    // SHPR1..3 hold exceptions 4..15 (irqn −12..−1)
                    n if n < 0 => (n + 12) as usize,
                    _ => return Some(0),
                };
                Some(scb.shpr[index].read())
            }
        },
        VectActive::Interrupt { irqn } => {
            // SAFETY: a read of one NVIC priority byte at its fixed address
            let nvic = unsafe { &*NVIC::PTR };
            Some(nvic.ipr[usize::from(irqn)].read())
        }
    }
}

/// Runs `f` with every interrupt whose priority byte is `ceiling` or larger (as urgent or
/// less) masked. A ceiling of 0 (BASEPRI = 0 masks nothing) gives a critical section.
pub fn with_ceiling<R>(ceiling: u8, f: impl FnOnce() -> R) -> R {
    match running_priority() {
        _ if ceiling == 0 => cortex_m::interrupt::free(|_| f()),
        // more urgent than the ceiling: contexts more urgent still could pre-empt it, and
        // BASEPRI at the ceiling would not keep them out
        Some(p) if p < ceiling => cortex_m::interrupt::free(|_| f()),
        _ => {
            let before = basepri::read();
            basepri_max::write(ceiling);
            compiler_fence(Ordering::SeqCst);
            let r = f();
            compiler_fence(Ordering::SeqCst);
            // SAFETY: restores the mask this context had on entry
            unsafe { basepri::write(before) };
            r
        }
    }
}
