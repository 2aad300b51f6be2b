//! The soak test: hours of emulated operation, fast-forwarded. The emulator's own period
//! ([`Plant::period`], the same one `pamctl sim` runs in real time) is stepped as fast as the
//! host allows, and a scripted host drives it through the link's framing (requests encoded,
//! decoded by the device's `FrameDecoder`, replies and telemetry encoded and decoded back):
//! random targets in every mode, the faults of the fault-injection table at random times
//! (hil-tests/README.md), bad targets and line noise, then repair, clear and re-arm.
//!
//! Checked throughout, each violation reported in [`SoakReport::problems`]:
//! * every telemetry frame arrives and `seq` has no gap;
//! * every reply answers its request; a refused target leaves the mode as it was; noise
//!   gets `Malformed` and changes nothing;
//! * every sample that is disarmed, or faulted by anything but a lone command timeout
//!   (which ramps), has 4 mA on every loop, and so has every current the board drives;
//! * each injected fault that the supervisor is built to detect latches, and reaches the
//!   safe state, within its documented number of periods ([`Kind::bound_periods`]);
//! * after every episode the device clears and re-arms.
//!
//! Measured, not checked: for each injected fault, the mode it struck in, whether a fault
//! latched, and the handle's largest excursion, speed and force on what holds it while the
//! fault is watched (to the end of the vent); [`SoakReport::coverage`] per fault kind and
//! mode, [`SoakReport::undetected`] for every fault nothing answered. The twin's converters
//! fill and exhaust at their measured rates ([`fault_table::sim_config`]).
//!
//! `cargo xtask soak [--hours H] [--seed S]` runs it (`examples/soak.rs`); a few emulated
//! minutes run as a test (`tests/soak.rs`).

use std::time::Instant;

use pam_control::{Faults, SafetyConfig};
use pam_firmware_logic::current_loop::OUTPUT_ERROR_DEBOUNCE_PERIODS;
use pam_protocol::{
    encode_frame, wire, Config, DeviceMessage, ErrorCode, FrameDecoder, ReplyData, Request,
    RequestBody, SessionId, Telemetry, MAX_FRAME, NO_SESSION, PROTOCOL_VERSION, SCHEMA_FINGERPRINT,
};
use pam_twin::faults::PlantFault;
use pam_twin::rng::Rng;

use crate::inject::Injection;
use crate::plant::Plant;
use crate::{EmulatorError, HandleMode, SimConfig};

pub mod fault_table;
mod report;
mod script;
pub use report::{Consequence, KindFigures, SoakReport};

/// What a soak run does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SoakConfig {
    pub emulated_s: f64,
    pub seed: u64,
}

/// One kind of fault the soak injects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    LinkLoss,
    EncoderStuck,
    EncoderUnplugged,
    EncoderMiscount,
    LoadcellSaturated,
    LoadcellFrozen,
    ConverterOpen,
    ConverterStuck,
    LoopOverrun,
    EStop,
}

pub const KINDS: [Kind; 10] = [
    Kind::LinkLoss,
    Kind::EncoderStuck,
    Kind::EncoderUnplugged,
    Kind::EncoderMiscount,
    Kind::LoadcellSaturated,
    Kind::LoadcellFrozen,
    Kind::ConverterOpen,
    Kind::ConverterStuck,
    Kind::LoopOverrun,
    Kind::EStop,
];

/// The device's safety configuration during the soak (the emulator's default command
/// timeout, 0.1 s, like the firmware's).
fn safety() -> SafetyConfig {
    SafetyConfig::default_1khz()
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::LinkLoss => "link loss",
            Kind::EncoderStuck => "stuck encoder",
            Kind::EncoderUnplugged => "unplugged encoder",
            Kind::EncoderMiscount => "encoder miscount",
            Kind::LoadcellSaturated => "saturated load cell",
            Kind::LoadcellFrozen => "frozen load cell",
            Kind::ConverterOpen => "converter loop open",
            Kind::ConverterStuck => "converter stuck",
            Kind::LoopOverrun => "loop overrun",
            Kind::EStop => "E-stop",
        }
    }

    /// The periods from the fault's first period to the first sample in the safe state
    /// that hil-tests/README.md documents for it, or `None` where the supervisor is not
    /// built to see it every time ("What these scenarios do not catch" there: a stuck
    /// encoder or converter shows only once the arm moves or unbalances enough).
    /// `overrun_periods` is the configured count of missed periods.
    pub fn bound_periods(self, overrun_periods: u32) -> Option<u64> {
        let s = safety();
        let period_s = s.period_s as f64;
        Some(match self {
            // the timeout, then the ramp from at most 5 bar to the vent
            Kind::LinkLoss => {
                (s.command_timeout_s as f64 / period_s).round() as u64
                    + (5.0 / s.timeout_ramp_bar_per_s as f64 / period_s).ceil() as u64
                    + 2
            }
            Kind::EncoderMiscount | Kind::LoadcellSaturated | Kind::EStop => 0,
            Kind::LoadcellFrozen => s.loadcell_stuck_samples as u64,
            Kind::ConverterOpen => OUTPUT_ERROR_DEBOUNCE_PERIODS as u64 - 1,
            Kind::LoopOverrun => overrun_periods as u64,
            Kind::EncoderStuck | Kind::EncoderUnplugged | Kind::ConverterStuck => return None,
        })
    }

    /// How long the soak watches after injecting it.
    fn watch_periods(self) -> u64 {
        match self {
            // the balance check's 3 s still window, and some
            Kind::EncoderStuck | Kind::EncoderUnplugged | Kind::ConverterStuck => 4_500,
            // the timeout and its ramp, then the slowest exhaust (2.4 s), so that the
            // handle's motion after the vent command is watched to its end
            Kind::LinkLoss => 4_000,
            _ => 3_000,
        }
    }
}

/// The host's end of the in-process link, and the checks on what comes back.
struct Host {
    plant: Plant,
    rng: Rng,
    id: u16,
    /// The session the device gave this host in the handshake.
    session: SessionId,
    time_us: u64,
    device_decoder: FrameDecoder<Request>,
    host_decoder: FrameDecoder<DeviceMessage>,
    next_seq: Option<u32>,
    last: Option<Telemetry>,
    /// Heartbeats stop (link loss).
    silent: bool,
    periods_since_request: u64,
    overrun_periods: u32,
    report: SoakReport,
}

impl Host {
    fn problem(&mut self, what: String) {
        if self.report.problems.len() < 100 {
            self.report
                .problems
                .push(format!("t = {:.3} s: {what}", self.time_us as f64 * 1e-6));
        }
    }

    /// Bytes down the link; the replies that come back.
    fn send_bytes(&mut self, bytes: &[u8]) -> Vec<pam_protocol::Reply> {
        let mut replies = Vec::new();
        for &b in bytes {
            if let Some(frame) = self.device_decoder.push(b) {
                let reply = self.plant.handle_frame(frame);
                let mut buf = [0u8; MAX_FRAME];
                let n = encode_frame(&DeviceMessage::Reply(reply), &mut buf).unwrap_or(0);
                for &c in &buf[..n] {
                    match self.host_decoder.push(c) {
                        Some(Ok(DeviceMessage::Reply(r))) => replies.push(r),
                        Some(other) => self.problem(format!("a reply decoded as {other:?}")),
                        None => {}
                    }
                }
            }
        }
        self.report.requests += 1;
        self.periods_since_request = 0;
        replies
    }

    fn request(&mut self, body: RequestBody) -> Result<ReplyData, ErrorCode> {
        self.id = self.id.wrapping_add(1).max(1);
        let request = Request {
            id: self.id,
            body,
            session: self.session,
        };
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_frame(&request, &mut buf).expect("requests fit a frame");
        let replies = self.send_bytes(&buf[..n]);
        match replies.as_slice() {
            [r] if r.id == request.id => r.result,
            other => {
                self.problem(format!("{body:?} answered by {other:?}"));
                Err(ErrorCode::Malformed)
            }
        }
    }

    /// One control period, its telemetry through the link, the checks on it.
    fn period(&mut self) -> Telemetry {
        let period_us = self.plant.device.period_us().max(1);
        let result = self.plant.period(period_us, self.time_us, 20, 0, |_| {});
        self.time_us += period_us as u64;
        self.report.periods += 1;
        self.periods_since_request += 1;
        if !self.silent && self.periods_since_request >= 20 {
            let _ = self.request(RequestBody::Heartbeat);
        }
        let mut got = None;
        let mut buf = [0u8; MAX_FRAME];
        let messages = result
            .fault_event
            .map(DeviceMessage::FaultEvent)
            .into_iter()
            .chain(result.telemetry.map(DeviceMessage::Telemetry));
        for m in messages {
            let n = encode_frame(&m, &mut buf).unwrap_or(0);
            for &c in &buf[..n] {
                match self.host_decoder.push(c) {
                    Some(Ok(DeviceMessage::Telemetry(t))) => got = Some(t),
                    Some(Ok(DeviceMessage::FaultEvent(_))) => self.report.fault_events += 1,
                    Some(other) => self.problem(format!("the stream decoded as {other:?}")),
                    None => {}
                }
            }
        }
        let Some(t) = got else {
            self.report.lost_frames += 1;
            self.problem("a period without telemetry".into());
            return self.last.unwrap_or_else(|| panic!("no telemetry at all"));
        };
        if let Some(expected) = self.next_seq {
            if t.seq != expected {
                self.report.lost_frames += t.seq.wrapping_sub(expected) as u64;
                self.problem(format!("telemetry seq {} after {}", t.seq, expected - 1));
            }
        }
        self.next_seq = Some(t.seq.wrapping_add(1));
        self.report.telemetry_frames += 1;
        self.check_safe(&t);
        self.last = Some(t);
        t
    }

    /// The safe loop current (4 mA).
    fn floor_ma(&self) -> f32 {
        self.plant
            .device
            .controller()
            .model()
            .params
            .ip
            .current_min_ma
    }

    /// Disarmed, or faulted by anything but a lone timeout: 4 mA everywhere.
    fn check_safe(&mut self, t: &Telemetry) {
        let floor = self.floor_ma();
        let must_vent = match t.state {
            wire::State::Disarmed => true,
            wire::State::Faulted => t.faults != Faults::COMMAND_TIMEOUT.0,
            wire::State::Armed => false,
        };
        if must_vent && t.current_ma != [floor; 4] {
            self.problem(format!(
                "{:?} with faults {:#06x} but currents {:?}",
                t.state, t.faults, t.current_ma
            ));
        }
        let driven = self.plant.last_currents_ma;
        if must_vent && driven.iter().any(|&c| c != floor as f64) {
            self.problem(format!("{:?}: the board drives {driven:?}", t.state));
        }
    }

    fn run_periods(&mut self, n: u64) {
        for _ in 0..n {
            self.period();
        }
    }

    fn uniform(&mut self, lo: f64, hi: f64) -> f32 {
        (lo + (hi - lo) * self.rng.uniform()) as f32
    }

    fn below(&mut self, n: u64) -> u64 {
        self.rng.next_u64() % n
    }
}

/// Runs the soak; `progress` is called about every emulated minute with the report so far.
pub fn run(
    config: SoakConfig,
    mut progress: impl FnMut(&SoakReport),
) -> Result<SoakReport, EmulatorError> {
    let sim = SimConfig {
        // the set-up of the thesis's trials and of the fault-injection table: the handle
        // blocked in the force modes, free otherwise (a hand held at a random joint target
        // would pull the load cell into saturation at every new target)
        handle: HandleMode::Blocked,
        // the converters fill and exhaust at their measured rates, each its own: the
        // consequences of a fault are the arm's motion while the muscles vent
        effects: fault_table::sim_config(config.seed).effects,
        seed: config.seed,
        command_timeout_s: safety().command_timeout_s,
        ..SimConfig::default()
    };
    let (reports, _) = std::sync::mpsc::channel();
    let plant = Plant::new(&sim, reports)?;
    let mut host = Host {
        plant,
        rng: Rng::derive(config.seed, "soak"),
        id: 0,
        session: NO_SESSION,
        time_us: 0,
        device_decoder: FrameDecoder::new(),
        host_decoder: FrameDecoder::new(),
        next_seq: None,
        last: None,
        silent: false,
        periods_since_request: 0,
        overrun_periods: safety().overrun_fault_periods,
        report: SoakReport::default(),
    };
    let wall = Instant::now();
    let end_us = (config.emulated_s * 1e6) as u64;
    let mut next_progress_us = 60_000_000;
    if let Ok(ReplyData::Hello(info)) = host.request(RequestBody::Hello {
        protocol_version: PROTOCOL_VERSION,
        schema_fingerprint: SCHEMA_FINGERPRINT,
    }) {
        host.session = info.session;
    }
    script::start(&mut host);
    while host.time_us < end_us {
        script::episode(&mut host);
        if host.time_us >= next_progress_us {
            next_progress_us += 60_000_000;
            host.report.emulated_s = host.time_us as f64 * 1e-6;
            host.report.wall_s = wall.elapsed().as_secs_f64();
            progress(&host.report);
        }
    }
    host.report.emulated_s = host.time_us as f64 * 1e-6;
    host.report.wall_s = wall.elapsed().as_secs_f64();
    Ok(host.report)
}

/// The injection that makes `kind` happen (link loss is the host's own doing), on a random
/// joint and channel.
fn injection(kind: Kind, host: &mut Host) -> Option<Injection> {
    let joint = host.below(2) as usize;
    let channel = host.below(4) as usize;
    let sign = host.below(2);
    let overrun = host.overrun_periods + host.below(3) as u32;
    injection_at(kind, joint, channel + 4 * sign as usize, overrun)
}

/// The injection that makes `kind` happen on `joint` and `channel` (mod 4; a load cell on
/// channel mod 2; an encoder miscount of +400 counts for channel < 4, −400 otherwise), with
/// an overrun of `overrun_periods` stalled periods.
fn injection_at(
    kind: Kind,
    joint: usize,
    channel: usize,
    overrun_periods: u32,
) -> Option<Injection> {
    Some(match kind {
        Kind::LinkLoss => return None,
        Kind::EncoderStuck => Injection::Plant(PlantFault::EncoderStuck { joint }),
        Kind::EncoderUnplugged => Injection::Plant(PlantFault::EncoderUnplugged { joint }),
        Kind::EncoderMiscount => Injection::Plant(PlantFault::EncoderJump {
            joint,
            counts: if channel < 4 { 400 } else { -400 },
        }),
        Kind::LoadcellSaturated => Injection::Plant(PlantFault::LoadcellSaturated {
            channel: channel % 2,
        }),
        Kind::LoadcellFrozen => Injection::Plant(PlantFault::LoadcellFrozen),
        Kind::ConverterOpen => Injection::Plant(PlantFault::ConverterOpen {
            channel: channel % 4,
        }),
        Kind::ConverterStuck => Injection::Plant(PlantFault::ConverterStuck {
            channel: channel % 4,
        }),
        Kind::LoopOverrun => Injection::Overrun {
            periods: overrun_periods,
        },
        Kind::EStop => Injection::EStop,
    })
}

/// `Config::Limits` with a new count of missed periods.
fn limits_with_overrun(periods: u32) -> RequestBody {
    let mut s = safety();
    s.overrun_fault_periods = periods;
    RequestBody::SetConfig(Config::Limits(s.into()))
}
