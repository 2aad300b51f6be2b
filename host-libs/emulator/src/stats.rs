//! Timing of the real-time loop.

use std::sync::atomic::{AtomicU64, Ordering};

/// Timing of the real-time loop, shared with whoever wants to report it.
#[derive(Default, Debug)]
pub struct LoopStats {
    pub periods: AtomicU64,
    /// Periods that started one period or more after their deadline (caught up).
    pub late: AtomicU64,
    /// Times the loop gave up catching up (more than 1 s behind).
    pub resyncs: AtomicU64,
    pub max_jitter_us: AtomicU64,
    pub max_exec_us: AtomicU64,
    pub exec_us_total: AtomicU64,
    /// Frames dropped because a connection did not take them in time.
    pub frames_dropped: AtomicU64,
    pub bytes_sent: AtomicU64,
}

impl LoopStats {
    pub fn summary(&self) -> String {
        let n = self.periods.load(Ordering::Relaxed);
        format!(
            "{} periods, {} late (caught up), {} resyncs, jitter max {} µs, step {:.1} µs mean / {} µs max, \
             {} frames dropped at the link, {} bytes sent",
            n,
            self.late.load(Ordering::Relaxed),
            self.resyncs.load(Ordering::Relaxed),
            self.max_jitter_us.load(Ordering::Relaxed),
            self.exec_us_total.load(Ordering::Relaxed) as f64 / n.max(1) as f64,
            self.max_exec_us.load(Ordering::Relaxed),
            self.frames_dropped.load(Ordering::Relaxed),
            self.bytes_sent.load(Ordering::Relaxed),
        )
    }
}
