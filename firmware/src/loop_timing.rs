//! Per-cycle execution time and wake-up jitter of the control loop, from the DWT cycle
//! counter (one count per core clock, 5.9 ns at 170 MHz), kept for telemetry. The
//! statistics are `pam_firmware_logic::cycle_stats` (host-tested); this module feeds them
//! the counter and shares the summary.
//!
//! * Execution time: from the loop's wake-up to the last output written.
//! * Jitter: |actual − nominal| of the interval between two consecutive wake-ups. The
//!   ticker keeps the *average* period exact; this measures how late each wake-up is
//!   relative to the previous one (interrupt latency, critical sections of other code).
//! * Overrun: an execution time longer than the period. The safety configuration's
//!   `overrun_fault_periods` (default 3, `pamctl config set limits.overrun_fault_periods=N`)
//!   missed periods in a row (overruns or wake-ups a whole period late) set
//!   `LoopTiming::overrun_fault`; the control task then latches `Faults::LOOP_OVERRUN`.
//!
//! The control task publishes the summary each cycle (a critical section of a few dozen
//! cycles); any task reads it with [`snapshot`].

use core::cell::Cell;

use cortex_m::peripheral::{DCB, DWT};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
pub use pam_firmware_logic::cycle_stats::LoopTiming;
use pam_firmware_logic::cycle_stats::{cycles_to_ns, CycleStats};

use crate::board;

static SHARED: Mutex<CriticalSectionRawMutex, Cell<LoopTiming>> =
    Mutex::new(Cell::new(LoopTiming {
        cycles: 0,
        period_cycles: 0,
        exec_last_cycles: 0,
        exec_max_cycles: 0,
        jitter_last_cycles: 0,
        jitter_max_cycles: 0,
        overruns: 0,
        consecutive_missed: 0,
        overrun_fault: false,
    }));

/// The latest published timing.
pub fn snapshot() -> LoopTiming {
    SHARED.lock(|c| c.get())
}

/// Core-clock cycles → ns.
pub fn ns(cycles: u32) -> u32 {
    cycles_to_ns(cycles, board::SYSCLK_HZ)
}

/// Measures one control cycle after another (owned by the control task).
pub struct CycleMeter {
    stats: CycleStats,
}

impl CycleMeter {
    /// Enables the cycle counter (needs the core peripherals once, at boot).
    pub fn new(dcb: &mut DCB, dwt: &mut DWT, period_cycles: u32) -> Self {
        dcb.enable_trace();
        dwt.enable_cycle_counter();
        Self {
            stats: CycleStats::new(period_cycles)
                .with_overrun_fault_periods(board::LOOP_OVERRUN_FAULT_PERIODS_AT_BOOT),
        }
    }

    /// The device's count of consecutive missed periods that latch the fault (its safety
    /// configuration, validated there: 1–100).
    pub fn set_overrun_fault_periods(&mut self, periods: u32) {
        self.stats.set_overrun_fault_periods(periods);
    }

    /// A new period length (the host changed the loop rate).
    pub fn set_period(&mut self, period_cycles: u32) {
        self.stats.set_period(period_cycles);
    }

    /// Call first thing after the wake-up; returns this wake-up's jitter in cycles.
    pub fn cycle_start(&mut self) -> u32 {
        self.stats.start(DWT::cycle_count())
    }

    /// Call after the outputs are written; publishes and returns the summary.
    pub fn cycle_end(&mut self) -> LoopTiming {
        let timing = self.stats.end(DWT::cycle_count());
        SHARED.lock(|c| c.set(timing));
        timing
    }
}
