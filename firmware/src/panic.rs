//! The panic handler: outputs to the safe state first, then the log, then a halt that the
//! watchdog turns into a reset.
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
