//! Execution time and wake-up jitter of a periodic loop from a free-running 32-bit cycle
//! counter (the Cortex-M DWT CYCCNT, which wraps every 25 s at 170 MHz).
//!
//! * Execution time: from the wake-up to the end of the cycle's work.
//! * Jitter: |actual − nominal| of the interval between two consecutive wake-ups.
//! * Overrun: an execution time longer than the period.
//! * Missed period: an overrun, or a wake-up a whole period (or more) late. A run of
//!   `overrun_fault_periods` consecutive missed periods (default
//!   [`DEFAULT_OVERRUN_FAULT_PERIODS`]) is a loop overrun fault: the firmware latches
//!   `Faults::LOOP_OVERRUN`, which vents.

/// Consecutive missed periods that make a loop overrun fault until the device's safety
/// configuration says otherwise (`pam_control::SafetyConfig::overrun_fault_periods`, whose
/// default is the same 3: checked by pam-emulator's tests).
pub const DEFAULT_OVERRUN_FAULT_PERIODS: u32 = 3;

/// Summary since start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoopTiming {
    /// Cycles of the loop run so far.
    pub cycles: u32,
    pub period_cycles: u32,
    pub exec_last_cycles: u32,
    pub exec_max_cycles: u32,
    pub jitter_last_cycles: u32,
    pub jitter_max_cycles: u32,
    pub overruns: u32,
    /// Missed periods (overrun or late wake-up) in a row up to and including the last cycle.
    pub consecutive_missed: u32,
    /// `consecutive_missed` is at or beyond the configured limit: the condition, present
    /// while the run lasts (the controller latches the fault; it clears once this is false).
    pub overrun_fault: bool,
}

/// Clock cycles → ns at `clock_hz`, saturating at u32::MAX.
pub fn cycles_to_ns(cycles: u32, clock_hz: u32) -> u32 {
    if clock_hz == 0 {
        return u32::MAX;
    }
    let ns = u64::from(cycles) * 1_000_000_000 / u64::from(clock_hz);
    ns.min(u64::from(u32::MAX)) as u32
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CycleStats {
    timing: LoopTiming,
    last_start: Option<u32>,
    start: u32,
    /// This cycle's wake-up came a whole period late.
    late_wakeup: bool,
    overrun_fault_periods: u32,
}

impl CycleStats {
    pub const fn new(period_cycles: u32) -> Self {
        Self {
            timing: LoopTiming {
                cycles: 0,
                period_cycles,
                exec_last_cycles: 0,
                exec_max_cycles: 0,
                jitter_last_cycles: 0,
                jitter_max_cycles: 0,
                overruns: 0,
                consecutive_missed: 0,
                overrun_fault: false,
            },
            last_start: None,
            start: 0,
            late_wakeup: false,
            overrun_fault_periods: DEFAULT_OVERRUN_FAULT_PERIODS,
        }
    }

    /// Consecutive missed periods that make a loop overrun fault (at least 1: the check
    /// cannot be switched off).
    pub const fn with_overrun_fault_periods(mut self, periods: u32) -> Self {
        self.set_overrun_fault_periods(periods);
        self
    }

    /// A new count of consecutive missed periods that make the fault (at least 1), from the
    /// next [`CycleStats::end`] on; the run counted so far is kept.
    pub const fn set_overrun_fault_periods(&mut self, periods: u32) {
        self.overrun_fault_periods = if periods == 0 { 1 } else { periods };
    }

    /// A new period: the next wake-up has no reference, jitter restarts from there.
    pub fn set_period(&mut self, period_cycles: u32) {
        self.timing.period_cycles = period_cycles;
        self.last_start = None;
    }

    /// The counter at the wake-up; returns this wake-up's jitter (0 without a reference).
    pub fn start(&mut self, now: u32) -> u32 {
        let mut jitter = 0;
        self.late_wakeup = false;
        if let Some(last) = self.last_start {
            let interval = now.wrapping_sub(last);
            self.late_wakeup = interval >= self.timing.period_cycles.saturating_mul(2);
            jitter = interval.abs_diff(self.timing.period_cycles);
            self.timing.jitter_last_cycles = jitter;
            self.timing.jitter_max_cycles = self.timing.jitter_max_cycles.max(jitter);
        }
        self.last_start = Some(now);
        self.start = now;
        jitter
    }

    /// The counter at the end of the cycle's work; returns the updated summary.
    pub fn end(&mut self, now: u32) -> LoopTiming {
        let exec = now.wrapping_sub(self.start);
        let t = &mut self.timing;
        t.cycles = t.cycles.wrapping_add(1);
        t.exec_last_cycles = exec;
        t.exec_max_cycles = t.exec_max_cycles.max(exec);
        let overrun = exec > t.period_cycles;
        if overrun {
            t.overruns = t.overruns.saturating_add(1);
        }
        if overrun || self.late_wakeup {
            t.consecutive_missed = t.consecutive_missed.saturating_add(1);
        } else {
            t.consecutive_missed = 0;
        }
        t.overrun_fault = t.consecutive_missed >= self.overrun_fault_periods;
        *t
    }

    pub fn timing(&self) -> LoopTiming {
        self.timing
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PERIOD: u32 = 170_000; // 1 ms at 170 MHz

    #[test]
    fn execution_time_and_jitter_of_regular_cycles() {
        let mut s = CycleStats::new(PERIOD);
        assert_eq!(s.start(1_000), 0);
        let t = s.end(1_000 + 5_000);
        assert_eq!(
            (t.cycles, t.exec_last_cycles, t.exec_max_cycles),
            (1, 5_000, 5_000)
        );
        // next wake-up 300 cycles late, then one 200 cycles early
        assert_eq!(s.start(1_000 + PERIOD + 300), 300);
        s.end(1_000 + PERIOD + 300 + 4_000);
        assert_eq!(s.start(1_000 + 2 * PERIOD + 100), 200);
        let t = s.end(1_000 + 2 * PERIOD + 100 + 4_500);
        assert_eq!(t.jitter_last_cycles, 200);
        assert_eq!(t.jitter_max_cycles, 300);
        assert_eq!(t.exec_last_cycles, 4_500);
        assert_eq!(t.exec_max_cycles, 5_000);
        assert_eq!(t.overruns, 0);
        assert_eq!(t.cycles, 3);
    }

    #[test]
    fn the_counter_wrapping_changes_nothing() {
        let mut s = CycleStats::new(PERIOD);
        let before_wrap = u32::MAX - 50_000;
        s.start(before_wrap);
        let t = s.end(before_wrap.wrapping_add(60_000));
        assert_eq!(t.exec_last_cycles, 60_000);
        assert_eq!(s.start(before_wrap.wrapping_add(PERIOD + 7)), 7);
    }

    #[test]
    fn an_execution_longer_than_the_period_is_an_overrun() {
        let mut s = CycleStats::new(PERIOD);
        s.start(0);
        assert_eq!(s.end(PERIOD).overruns, 0);
        s.start(PERIOD);
        assert_eq!(s.end(2 * PERIOD + 1).overruns, 1);
    }

    #[test]
    fn three_consecutive_overruns_are_a_fault_two_are_not() {
        let mut s = CycleStats::new(PERIOD);
        let mut now = 0;
        // two overruns, a good cycle, two more: never three in a row
        for exec in [PERIOD + 1, PERIOD + 1, 1_000, PERIOD + 1, PERIOD + 1] {
            s.start(now);
            let t = s.end(now + exec);
            assert!(!t.overrun_fault, "exec {exec}");
            now += PERIOD.max(exec);
        }
        assert_eq!(s.timing().consecutive_missed, 2);
        s.start(now);
        let t = s.end(now + PERIOD + 1);
        assert_eq!(t.consecutive_missed, 3);
        assert!(t.overrun_fault);
        // a good cycle ends the condition (the controller keeps the fault latched)
        now += PERIOD + 1;
        s.start(now);
        let t = s.end(now + 1_000);
        assert_eq!(t.consecutive_missed, 0);
        assert!(!t.overrun_fault);
    }

    #[test]
    fn late_wakeups_are_missed_periods_and_the_limit_is_configurable() {
        let mut s = CycleStats::new(PERIOD).with_overrun_fault_periods(2);
        s.start(0);
        assert!(!s.end(1_000).overrun_fault);
        // a wake-up 2 periods after the previous one: one period missed (short execution)
        s.start(2 * PERIOD);
        let t = s.end(2 * PERIOD + 1_000);
        assert_eq!((t.consecutive_missed, t.overrun_fault), (1, false));
        // one period minus a cycle late is still on time
        s.start(4 * PERIOD - 1);
        let t = s.end(4 * PERIOD);
        assert_eq!((t.consecutive_missed, t.overrun_fault), (0, false));
        s.start(6 * PERIOD);
        s.end(6 * PERIOD + 10);
        s.start(8 * PERIOD);
        let t = s.end(8 * PERIOD + 10);
        assert_eq!((t.consecutive_missed, t.overrun_fault), (2, true));
        // a limit of 0 cannot switch the check off: it is 1
        let mut s = CycleStats::new(PERIOD).with_overrun_fault_periods(0);
        s.start(0);
        assert!(s.end(PERIOD + 1).overrun_fault);
    }

    #[test]
    fn the_limit_changes_at_run_time_and_keeps_the_run_counted() {
        let mut s = CycleStats::new(PERIOD);
        s.set_overrun_fault_periods(5);
        let mut now = 0;
        let mut miss = |s: &mut CycleStats| {
            s.start(now);
            let t = s.end(now + PERIOD + 1);
            now += PERIOD + 1;
            t
        };
        for _ in 0..4 {
            assert!(!miss(&mut s).overrun_fault, "5 allowed");
        }
        assert!(miss(&mut s).overrun_fault, "the fifth");
        // lowered mid-run: the next miss is past it at once
        s.set_overrun_fault_periods(2);
        assert!(miss(&mut s).overrun_fault);
        s.set_overrun_fault_periods(100);
        let t = miss(&mut s);
        assert_eq!((t.consecutive_missed, t.overrun_fault), (7, false));
    }

    #[test]
    fn a_period_change_restarts_the_jitter_reference() {
        let mut s = CycleStats::new(PERIOD);
        s.start(0);
        s.end(10);
        s.set_period(10 * PERIOD);
        // the first wake-up after the change is 1 ms later, not 10 ms: no false jitter
        assert_eq!(s.start(PERIOD), 0);
        s.end(PERIOD + 10);
        assert_eq!(s.start(PERIOD + 10 * PERIOD), 0);
        assert_eq!(s.timing().jitter_max_cycles, 0);
    }

    #[test]
    fn cycles_convert_to_nanoseconds() {
        assert_eq!(cycles_to_ns(170, 170_000_000), 1_000);
        assert_eq!(cycles_to_ns(PERIOD, 170_000_000), 1_000_000);
        assert_eq!(cycles_to_ns(u32::MAX, 1), u32::MAX);
        assert_eq!(cycles_to_ns(5, 0), u32::MAX);
    }
}
