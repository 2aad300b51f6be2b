//! The scripted host of the soak: one episode is recover (repair, clear, maybe a new count
//! of missed periods, arm), one to three mode segments with random targets, bad targets
//! and line noise, and perhaps one injected fault watched to the safe state.

use pam_control::{State, OVERRUN_FAULT_PERIODS_RANGE};
use pam_protocol::{
    encode_frame, wire, Config, ConfigSection, ErrorCode, ReplyData, Request, RequestBody,
    MAX_FRAME,
};

use super::{injection, limits_with_overrun, Consequence, Host, Kind, KINDS};

/// Home at the neutral pose, where the twin starts.
pub(super) fn start(host: &mut Host) {
    host.run_periods(10);
    if let Err(e) = host.request(RequestBody::Home) {
        host.problem(format!("home refused: {e:?}"));
    }
}

pub(super) fn episode(host: &mut Host) {
    host.report.episodes += 1;
    recover(host);
    if host.plant.device.controller().state() != State::Armed {
        return;
    }
    let segments = 1 + host.below(3);
    let inject_in = (host.below(10) < 6).then(|| host.below(segments));
    for s in 0..segments {
        if !segment(host, inject_in == Some(s)) {
            return; // a fault: the next episode recovers
        }
    }
    let _ = host.request(RequestBody::Disarm);
    host.run_periods(5);
}

/// Back to armed: disarm, repair whatever was injected, clear, perhaps a new overrun count.
fn recover(host: &mut Host) {
    host.silent = false;
    let _ = host.request(RequestBody::Disarm);
    host.plant.board.repair();
    host.run_periods(50);
    if !host.plant.device.controller().faults().is_none() {
        let mut cleared = false;
        for _ in 0..30 {
            match host.request(RequestBody::ClearFaults) {
                Ok(_) => {
                    cleared = true;
                    break;
                }
                Err(ErrorCode::FaultStillPresent) => host.run_periods(100),
                Err(e) => {
                    host.problem(format!("clear refused: {e:?}"));
                    break;
                }
            }
        }
        if !cleared {
            let bits = host.plant.device.controller().faults().0;
            host.problem(format!("faults {bits:#06x} would not clear after repair"));
            return;
        }
        host.report.clears += 1;
        host.run_periods(5);
    }
    if host.below(4) == 0 {
        change_overrun_count(host);
    }
    // the script drives every mode, the pressures mode among them: a service mode, behind
    // the device's interlock, which goes off at every disarm and fault
    if let Err(e) = host.request(RequestBody::SetServiceMode { enabled: true }) {
        if host.plant.device.controller().faults().is_none() {
            host.problem(format!("service interlock refused while disarmed: {e:?}"));
        }
    }
    match host.request(RequestBody::Arm) {
        Ok(_) => host.report.arms += 1,
        // a fault latched again since the clear (a vented arm drifting past its range
        // end): refusing is right; the next episode recovers again
        Err(ErrorCode::WrongState) if !host.plant.device.controller().faults().is_none() => {
            host.report.relatched_before_arm += 1
        }
        Err(e) => host.problem(format!("arm refused after recovery: {e:?}")),
    }
}

/// A new count of missed periods, and one the device must refuse.
fn change_overrun_count(host: &mut Host) {
    let n = 1 + host.below(8) as u32;
    match host.request(limits_with_overrun(n)) {
        Ok(_) => {
            host.overrun_periods = n;
            host.report.overrun_count_changes += 1;
        }
        Err(e) => host.problem(format!("overrun count {n} refused: {e:?}")),
    }
    let bad = if host.below(2) == 0 {
        0
    } else {
        OVERRUN_FAULT_PERIODS_RANGE.end() + 1 + host.below(1000) as u32
    };
    if host.request(limits_with_overrun(bad)) != Err(ErrorCode::OutOfRange) {
        host.problem(format!("overrun count {bad} not refused"));
    }
    match host.request(RequestBody::GetConfig(ConfigSection::Limits)) {
        Ok(ReplyData::Config(Config::Limits(l))) if l.overrun_fault_periods == n => {}
        other => host.problem(format!("limits after a refused count: {other:?}")),
    }
}

/// A random target of a random mode, inside the limits the device checks.
fn random_mode(host: &mut Host) -> (&'static str, wire::Mode) {
    let u = |h: &mut Host, lo, hi| h.uniform(lo, hi);
    match host.below(6) {
        0 => ("idle", wire::Mode::Idle),
        1 => (
            "pressures",
            wire::Mode::Pressures {
                // 1.5–3.5 bar: a pair's imbalance and mean within the mode's ceilings
                pressure_bar: [0; 4].map(|_| u(host, 1.5, 3.5)),
            },
        ),
        2 => (
            "joint",
            wire::Mode::Joint {
                alpha_rad: [u(host, -0.2, 0.2), u(host, -0.2, 0.2)],
                torque_nm: [u(host, -1.0, 1.0), u(host, -1.0, 1.0)],
                stiffness_nm_per_rad: [u(host, 20.0, 80.0), u(host, 10.0, 40.0)],
            },
        ),
        3 => (
            "force",
            wire::Mode::Force {
                force_n: [u(host, -15.0, 15.0), u(host, -15.0, 15.0)],
                stiffness_nm_per_rad: [u(host, 10.0, 40.0), u(host, 10.0, 40.0)],
                feed_forward: host.below(2) == 0,
            },
        ),
        4 => (
            "force closed loop",
            wire::Mode::ForceClosedLoop {
                force_n: [u(host, -10.0, 10.0), u(host, -10.0, 10.0)],
                stiffness_nm_per_rad: [u(host, 10.0, 40.0), u(host, 10.0, 40.0)],
                feed_forward: host.below(2) == 0,
                gain_scale: u(host, 0.3, 1.0),
            },
        ),
        _ => (
            "impedance",
            wire::Mode::Impedance {
                target_user_m: [u(host, -0.03, 0.03), u(host, -0.03, 0.03)],
                stiffness_n_per_m: [u(host, 50.0, 300.0), u(host, 50.0, 300.0)],
                damping_n_s_per_m: [u(host, 5.0, 30.0), u(host, 5.0, 30.0)],
            },
        ),
    }
}

/// One mode segment; false once the device is no longer armed.
fn segment(host: &mut Host, inject: bool) -> bool {
    let (name, mode) = random_mode(host);
    if let Err(e) = host.request(RequestBody::SetMode(mode)) {
        host.problem(format!("{name} target {mode:?} refused: {e:?}"));
    }
    *host.report.modes.entry(name).or_default() += 1;
    let length = 300 + host.below(2_200);
    let inject_at = inject.then(|| host.below(length));
    for k in 0..length {
        if Some(k) == inject_at {
            inject_and_watch(host, name);
            return false;
        }
        match host.below(1_000) {
            0 => bad_target(host),
            1 => noise(host),
            _ => {}
        }
        let t = host.period();
        if t.state != wire::State::Armed {
            *host.report.spontaneous.entry((name, t.faults)).or_default() += 1;
            return false;
        }
    }
    true
}

/// NaN, ∞ or out-of-range targets: refused, the mode unchanged.
fn bad_target(host: &mut Host) {
    let before = host.plant.device.controller().mode();
    let bad = [f32::NAN, f32::INFINITY, -1.0e6, 1.0e6][host.below(4) as usize];
    let mode = match host.below(4) {
        0 => wire::Mode::Pressures {
            pressure_bar: [2.0, bad, 2.0, 2.0],
        },
        1 => wire::Mode::Joint {
            alpha_rad: [0.0, 0.0],
            torque_nm: [0.0, 0.0],
            stiffness_nm_per_rad: [bad, 20.0],
        },
        2 => wire::Mode::Force {
            force_n: [bad, 0.0],
            stiffness_nm_per_rad: [20.0, 20.0],
            feed_forward: true,
        },
        _ => wire::Mode::Impedance {
            target_user_m: [0.0, 0.0],
            stiffness_n_per_m: [100.0, 100.0],
            damping_n_s_per_m: [bad, 10.0],
        },
    };
    match host.request(RequestBody::SetMode(mode)) {
        Err(ErrorCode::OutOfRange) => host.report.bad_targets_refused += 1,
        // a pressures target without the interlock is refused before its values are read
        Err(ErrorCode::ServiceModeOff) if matches!(mode, wire::Mode::Pressures { .. }) => {
            host.report.bad_targets_refused += 1
        }
        other => host.problem(format!("bad target {mode:?} answered {other:?}")),
    }
    if host.plant.device.controller().mode() != before {
        host.problem("a refused target changed the mode".into());
    }
}

/// A request frame with one byte changed (never to the delimiter), or a run of bytes
/// longer than any frame: `Malformed` or nothing, and no change.
fn noise(host: &mut Host) {
    let c = host.plant.device.controller();
    let before = (c.state(), c.mode(), c.faults());
    let mut bytes = Vec::new();
    if host.below(2) == 0 {
        let mut buf = [0u8; MAX_FRAME];
        let request = Request {
            id: 4242,
            body: RequestBody::Disarm,
            session: host.session,
        };
        let n = encode_frame(&request, &mut buf).expect("fits");
        // another value, never the delimiter
        let i = host.below(n as u64 - 1) as usize;
        let mut v = 1 + host.below(254) as u8;
        if v >= buf[i] {
            v += 1;
        }
        buf[i] = v;
        bytes.extend_from_slice(&buf[..n]);
    } else {
        let n = MAX_FRAME + 1 + host.below(400) as usize;
        bytes.extend((0..n).map(|_| 1 + host.below(255) as u8));
        bytes.push(0);
    }
    let replies = host.send_bytes(&bytes);
    host.report.noise_bursts += 1;
    if replies
        .iter()
        .any(|r| r.result != Err(ErrorCode::Malformed))
    {
        host.problem(format!("noise answered {replies:?}"));
    }
    let c = host.plant.device.controller();
    if (c.state(), c.mode(), c.faults()) != before {
        host.problem("noise changed the device".into());
    }
}

/// Injects a random fault and watches the telemetry for the fault and the safe state, and
/// the twin for what the handle does after it.
fn inject_and_watch(host: &mut Host, mode: &'static str) {
    let kind = KINDS[host.below(KINDS.len() as u64) as usize];
    let bound = kind.bound_periods(host.overrun_periods);
    let faults_before = host.plant.device.controller().faults().0;
    match injection(kind, host) {
        Some(i) => host.plant.inject(i, host.time_us),
        None => host.silent = true,
    }
    let floor = host.floor_ma();
    let (mut to_fault, mut to_safe, mut preempted) = (None, None, false);
    let start_m = host.plant.twin.state().handle_user_m;
    let mut after = Consequence {
        kind,
        mode,
        ..Consequence::default()
    };
    for k in 0..kind.watch_periods() {
        let t = host.period();
        after.observe(start_m, host.plant.twin.state());
        let new = t.faults & !faults_before;
        if to_fault.is_none() && new != 0 {
            to_fault = Some(k);
            preempted = new & kind.expected_bits() == 0;
        }
        if to_safe.is_none() && t.state != wire::State::Armed && t.current_ma == [floor; 4] {
            to_safe = Some(k);
        }
        // 200 samples in the safe state, and the muscles vented: the handle has stopped
        let vented = host
            .plant
            .twin
            .state()
            .pressure_bar
            .iter()
            .all(|&p| p < 0.5);
        if to_safe.is_some() && k > to_safe.unwrap_or(0) + 200 && vented {
            break;
        }
    }
    if let (Some(b), Some(s)) = (bound, to_safe) {
        if s > b {
            host.problem(format!(
                "{}: safe state after {s} periods, bound {b}",
                kind.name()
            ));
        }
    }
    if bound.is_some() && to_safe.is_none() {
        host.problem(format!("{}: never reached the safe state", kind.name()));
    }
    after.detected = to_fault.is_some();
    host.report.record(after);
    let f = host.report.injected.entry(kind).or_default();
    f.injected += 1;
    f.detected += to_fault.is_some() as u64;
    f.preempted += preempted as u64;
    if to_safe.is_some() && to_safe >= f.worst_periods_to_safe {
        f.bound_periods = bound; // the bound of the worst case (the overrun count varies)
    }
    f.worst_periods_to_fault = f.worst_periods_to_fault.max(to_fault);
    f.worst_periods_to_safe = f.worst_periods_to_safe.max(to_safe);
}

impl Kind {
    /// The fault bits the kind is expected to raise.
    fn expected_bits(self) -> u16 {
        use pam_control::Faults as F;
        match self {
            Kind::LinkLoss => F::COMMAND_TIMEOUT.0,
            Kind::EncoderMiscount => F::ENCODER_JUMP.0,
            Kind::LoadcellSaturated => F::LOADCELL_SATURATED.0,
            Kind::LoadcellFrozen => F::LOADCELL_STUCK.0,
            Kind::ConverterOpen => F::OUTPUT_OPEN_LOOP.0,
            Kind::LoopOverrun => F::LOOP_OVERRUN.0,
            Kind::EStop => F::ESTOP.0,
            // seen through the arm's motion or balance
            Kind::EncoderStuck | Kind::EncoderUnplugged | Kind::ConverterStuck => {
                F::STATIC_IMBALANCE.0 | F::ANGLE_OUT_OF_RANGE.0 | F::ENCODER_JUMP.0
            }
        }
    }
}
