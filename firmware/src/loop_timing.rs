//! Per-cycle execution time and wake-up jitter of the control loop, from the DWT cycle
//! counter (one count per core clock, 5.9 ns at 170 MHz), kept for telemetry.
//!
//! * Execution time: from the loop's wake-up to the last output written.
//! * Jitter: |actual − nominal| of the interval between two consecutive wake-ups. The
//!   ticker keeps the *average* period exact; this measures how late each wake-up is
//!   relative to the previous one (interrupt latency, critical sections of other code).
//! * Overrun: an execution time longer than the period.
//!
//! The control task writes the summary with [`publish`] (a critical section of a few
//! dozen cycles); any task reads it with [`snapshot`].

use core::cell::Cell;

use cortex_m::peripheral::DWT;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;

use crate::board;

/// Timing of the control loop since the last reset of the maxima.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, defmt::Format)]
pub struct LoopTiming {
    /// Control cycles run since boot.
    pub cycles: u32,
    pub period_cycles: u32,
    pub exec_last_cycles: u32,
    pub exec_max_cycles: u32,
    pub jitter_last_cycles: u32,
    pub jitter_max_cycles: u32,
    pub overruns: u32,
}

impl LoopTiming {
    pub const fn cycles_to_ns(cycles: u32) -> u32 {
        ((cycles as u64 * 1_000_000_000) / board::SYSCLK_HZ as u64) as u32
    }
}

static SHARED: Mutex<CriticalSectionRawMutex, Cell<LoopTiming>> = Mutex::new(Cell::new(LoopTiming {
    cycles: 0,
    period_cycles: 0,
    exec_last_cycles: 0,
    exec_max_cycles: 0,
    jitter_last_cycles: 0,
    jitter_max_cycles: 0,
    overruns: 0,
}));

/// The latest published timing.
pub fn snapshot() -> LoopTiming {
    SHARED.lock(|c| c.get())
}

/// Measures one control cycle after another (owned by the control task).
pub struct CycleMeter {
    timing: LoopTiming,
    last_start: Option<u32>,
    start: u32,
}

impl CycleMeter {
    /// Enables the cycle counter (needs the core peripherals once, at boot).
    pub fn new(dcb: &mut cortex_m::peripheral::DCB, dwt: &mut DWT, period_cycles: u32) -> Self {
        dcb.enable_trace();
        dwt.enable_cycle_counter();
        Self {
            timing: LoopTiming {
                period_cycles,
                ..LoopTiming::default()
            },
            last_start: None,
            start: 0,
        }
    }

    /// A new period length (the host changed the loop rate): jitter restarts from here.
    pub fn set_period(&mut self, period_cycles: u32) {
        self.timing.period_cycles = period_cycles;
        self.last_start = None;
    }

    /// Call first thing after the wake-up; returns this wake-up's jitter (0 for the first
    /// period after a start or a period change).
    pub fn cycle_start(&mut self) -> u32 {
        let now = DWT::cycle_count();
        let mut jitter = 0;
        if let Some(last) = self.last_start {
            let interval = now.wrapping_sub(last);
            jitter = interval.abs_diff(self.timing.period_cycles);
            self.timing.jitter_last_cycles = jitter;
            self.timing.jitter_max_cycles = self.timing.jitter_max_cycles.max(jitter);
        }
        self.last_start = Some(now);
        self.start = now;
        jitter
    }

    /// Call after the outputs are written; publishes the summary.
    pub fn cycle_end(&mut self) -> LoopTiming {
        let exec = DWT::cycle_count().wrapping_sub(self.start);
        let t = &mut self.timing;
        t.cycles = t.cycles.wrapping_add(1);
        t.exec_last_cycles = exec;
        t.exec_max_cycles = t.exec_max_cycles.max(exec);
        if exec > t.period_cycles {
            t.overruns = t.overruns.saturating_add(1);
        }
        let timing = *t;
        SHARED.lock(|c| c.set(timing));
        timing
    }
}
