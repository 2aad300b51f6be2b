//! Measuring a fault scenario from telemetry: when the fault bit appears, when the outputs
//! reach the safe state (faulted, every loop at 4 mA), in control periods from the moment
//! of the fault, and whether the telemetry before it arrived without a gap.

use pam_control::{Faults, State};
use pam_link::Client;
use pam_protocol::{ReplyData, RequestBody, Telemetry};
use std::time::{Duration, Instant};

/// The safe loop current.
pub const SAFE_MA: f32 = 4.0;

/// What one scenario measured.
#[derive(Clone, Debug)]
pub struct Measured {
    /// Fault bits of the first faulted sample.
    pub faults: u16,
    /// Periods from the fault's start to the first sample carrying the expected bit.
    pub raised_periods: i64,
    /// Periods from the fault's start to the first faulted sample at 4 mA on every loop.
    pub safe_periods: i64,
    /// Telemetry samples received from the start of the measurement to the fault.
    pub samples_before: usize,
    /// `seq` steps other than +1 among them.
    pub gaps_before: usize,
    /// Every sample after the safe state (for `tail`) was still faulted at 4 mA.
    pub stayed_safe: bool,
}

impl Measured {
    /// One row of the fault-injection table.
    pub fn row(&self, scenario: &str) -> String {
        format!(
            "| {scenario} | {} (0x{:04x}) | {} | {} | {} samples, {} gaps |",
            pam_link::fault_names(self.faults),
            self.faults,
            self.raised_periods,
            self.safe_periods,
            self.samples_before,
            self.gaps_before
        )
    }
}

fn is_safe(t: &Telemetry) -> bool {
    t.state == State::Faulted && t.current_ma.iter().all(|&i| i <= SAFE_MA + 1e-3)
}

/// The device's period, µs.
pub fn period_us(c: &Client) -> u32 {
    match c.request(RequestBody::GetStatus).expect("status") {
        ReplyData::Status(s) => s.period_us,
        other => panic!("status: unexpected {other:?}"),
    }
}

/// Streams telemetry (heartbeats every 20 ms while `beat` says so), collects `lead`
/// samples, calls `start` with the last sample (it makes the fault happen and returns the
/// device time of its first period, µs), then waits up to `limit` for `expect` and the safe state, and watches
/// `tail` more samples. Panics if the fault or the safe state does not come.
pub fn measure(
    c: &Client,
    lead: usize,
    start: impl FnOnce(&Telemetry) -> u32,
    beat_after_start: bool,
    expect: Faults,
    limit: Duration,
    tail: usize,
) -> Measured {
    let period = period_us(c) as i64;
    c.start_telemetry();
    let mut samples: Vec<Telemetry> = Vec::new();
    let mut last_beat = Instant::now();
    let mut beat = true;
    let mut start = Some(start);
    let mut t0_us = 0u32;
    let mut deadline = Instant::now() + Duration::from_secs(5);
    let mut raised: Option<usize> = None;
    let mut safe: Option<usize> = None;
    while Instant::now() < deadline {
        if beat && last_beat.elapsed() > Duration::from_millis(20) {
            c.heartbeat().expect("heartbeat");
            last_beat = Instant::now();
        }
        let Some(t) = c
            .next_telemetry(Duration::from_millis(10))
            .expect("telemetry")
        else {
            continue;
        };
        samples.push(t);
        let i = samples.len() - 1;
        if let Some(s) = start.take_if(|_| samples.len() >= lead) {
            t0_us = s(&samples[i]);
            beat = beat_after_start;
            deadline = Instant::now() + limit;
            continue;
        }
        if start.is_some() {
            continue;
        }
        if raised.is_none() && t.faults & expect.0 != 0 {
            raised = Some(i);
        }
        if raised.is_some() && safe.is_none() && is_safe(&t) {
            safe = Some(i);
        }
        if safe.is_some_and(|s| i >= s + tail) {
            break;
        }
    }
    let at = |i: usize| (samples[i].time_us.wrapping_sub(t0_us) as i32) as i64 / period;
    let raised = raised.unwrap_or_else(|| {
        let last = samples.last();
        panic!("{expect:?} not raised within {limit:?} (last sample: {last:?})")
    });
    let safe = safe.unwrap_or_else(|| panic!("no safe state within {limit:?}"));
    let gaps = samples[..=raised]
        .windows(2)
        .filter(|w| w[1].seq != w[0].seq.wrapping_add(1))
        .count();
    Measured {
        faults: samples[raised].faults,
        raised_periods: at(raised),
        safe_periods: at(safe),
        samples_before: raised + 1,
        gaps_before: gaps,
        stayed_safe: samples[safe..].iter().all(is_safe),
    }
}
