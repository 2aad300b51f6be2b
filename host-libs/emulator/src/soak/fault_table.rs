//! What follows a fault: each fault kind of the soak, from each mode, with a held hand and a
//! free handle, on the twin whose converters fill and exhaust at their measured, unequal
//! rates ([`ConverterRates::spread`]). The emulator's period (device step inside the
//! emulated board, then the twin) is stepped as fast as the host allows, as in the soak.
//!
//! Per case: the time from the fault's first period to the vent command (the device no
//! longer armed and every loop the board drives at 4 mA), the time until every muscle is
//! below 0.5 bar, and the handle's largest excursion from where it was when the fault began
//! and its largest speed, within [`WATCH_S`] after the fault.
//!
//! `cargo xtask fault-table [--write]` prints the table (`examples/fault_table.rs`) or
//! rewrites its section of hil-tests/README.md.

use pam_protocol::{
    wire, ReplyData, Request, RequestBody, SessionId, NO_SESSION, PROTOCOL_VERSION,
    SCHEMA_FINGERPRINT,
};
use pam_twin::{ConverterRates, EffectSet, HandSpring, HandleCondition};

use super::{injection_at, Kind, KINDS};
use crate::inject::{Injection, StepClock};
use crate::plant::Plant;
use crate::{EmulatorError, HandleMode, SimConfig};

/// Time armed in the mode before the fault (s): the slowest channel fills 0 → 5 bar in
/// 3.6 s; the targets below need at most about half of that.
pub const SETTLE_S: f64 = 3.0;
/// Time watched after the fault (s): the command timeout and its ramp, then the slowest
/// exhaust (2.4 s over 5 bar), with margin.
pub const WATCH_S: f64 = 6.0;
/// Every muscle below this is "vented" (bar).
pub const VENTED_BAR: f64 = 0.5;
/// The held hand: the relaxed hand of `pamctl sim --handle held-relaxed` (N/m, N·s/m), the
/// softest the closed force loop is tested against, so the one that moves most.
const HAND_N_PER_M: f64 = 1000.0;
const HAND_N_S_PER_M: f64 = 50.0;
/// The loop current of the vent (mA).
const VENT_MA: f64 = 4.0;
/// The muscles brought up at the neutral pose before the mode's target, so that the
/// target starts from the pretension and not from the converters' fill.
const PRETENSION: wire::Mode = wire::Mode::Joint {
    alpha_rad: [0.0, 0.0],
    torque_nm: [0.0, 0.0],
    stiffness_nm_per_rad: [50.0, 25.0],
};
const PRETENSION_S: f64 = 2.0;
/// Heartbeat interval of the host (periods), as the soak's.
const HEARTBEAT_PERIODS: u64 = 20;

/// The modes of the table, each with a moderate target near the neutral pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum TableMode {
    Pressures,
    Joint,
    ForceOpenLoop,
    ForceClosedLoop,
    Impedance,
}

pub const TABLE_MODES: [TableMode; 5] = [
    TableMode::Pressures,
    TableMode::Joint,
    TableMode::ForceOpenLoop,
    TableMode::ForceClosedLoop,
    TableMode::Impedance,
];

impl TableMode {
    pub fn name(self) -> &'static str {
        match self {
            TableMode::Pressures => "pressures",
            TableMode::Joint => "joint",
            TableMode::ForceOpenLoop => "force, open loop",
            TableMode::ForceClosedLoop => "force, closed loop",
            TableMode::Impedance => "impedance",
        }
    }

    /// The target held before the fault.
    pub fn target(self) -> wire::Mode {
        match self {
            TableMode::Pressures => wire::Mode::Pressures {
                pressure_bar: [2.5, 2.0, 2.5, 2.0],
            },
            TableMode::Joint => wire::Mode::Joint {
                alpha_rad: [0.1, -0.1],
                torque_nm: [0.0, 0.0],
                stiffness_nm_per_rad: [50.0, 25.0],
            },
            TableMode::ForceOpenLoop => wire::Mode::Force {
                force_n: [5.0, 0.0],
                stiffness_nm_per_rad: [20.0, 20.0],
                feed_forward: true,
            },
            TableMode::ForceClosedLoop => wire::Mode::ForceClosedLoop {
                force_n: [5.0, 0.0],
                stiffness_nm_per_rad: [20.0, 20.0],
                feed_forward: true,
                gain_scale: 1.0,
            },
            TableMode::Impedance => wire::Mode::Impedance {
                // where the handle is: a target away from it is a hand that does not
                // follow, which the loop's released-handle guard faults on
                target_user_m: [0.0, 0.0],
                stiffness_n_per_m: [200.0, 200.0],
                damping_n_s_per_m: [20.0, 20.0],
            },
        }
    }
}

/// What holds the handle throughout, before and after the fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Hand {
    /// A relaxed hand (1000 N/m, 50 N·s/m) holds the handle where it was when the mode was
    /// set, and keeps holding it after the fault.
    Held,
    /// Nothing touches the handle.
    Free,
}

/// One measured case. Times are from the fault's first period (s); `None`: not within
/// [`WATCH_S`].
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub kind: Kind,
    pub mode: TableMode,
    pub hand: Hand,
    /// Why the case could not run as set up (a refused request, a fault before the
    /// injection); the figures are then absent.
    pub setup_problem: Option<String>,
    /// The fault bits latched after the injection (0: none).
    pub faults: u16,
    pub to_vent_s: Option<f64>,
    pub to_vented_s: Option<f64>,
    pub excursion_mm: f64,
    pub speed_mm_s: f64,
    /// The largest force the hand takes (N; 0 for a free handle).
    pub hand_force_n: f64,
}

/// The emulator, a host that heartbeats and what holds the handle.
struct Rig {
    plant: Plant,
    time_us: u64,
    id: u16,
    hand: HandleCondition,
    silent: bool,
    /// The session the device gave the table's host in the handshake.
    session: SessionId,
}

impl Rig {
    fn request(&mut self, body: RequestBody) -> Result<(), String> {
        self.id = self.id.wrapping_add(1).max(1);
        let reply = self.plant.handle_frame(Ok(Request {
            id: self.id,
            body,
            session: self.session,
        }));
        match reply.result {
            Ok(ReplyData::Hello(info)) => {
                self.session = info.session;
                Ok(())
            }
            Ok(_) => Ok(()),
            Err(e) => Err(format!("{body:?} refused: {e:?}")),
        }
    }

    /// One emulator period with the table's own handle condition (the hand stays on the
    /// handle whatever the device's state).
    fn period(&mut self, k: u64) {
        let period_us = self.plant.device.period_us().max(1);
        let plant = &mut self.plant;
        plant.board.before_step(&mut plant.device);
        let raw = plant.raw_sensors();
        let clock = StepClock::start();
        let result = plant.device.step(
            raw,
            pam_device::StepTiming {
                time_us: self.time_us as u32,
                loop_exec_us: 20,
                loop_jitter_us: 0,
            },
        );
        let stall_us = plant.board.stall_us(period_us);
        let driven = plant.board.after_step(
            &mut plant.device,
            self.time_us as u32,
            clock.elapsed_us() + stall_us,
            period_us,
            result.current_ma,
        );
        plant.last_currents_ma = driven.map(f64::from);
        let at_converters = plant.board.converter_currents(plant.last_currents_ma);
        plant.last = plant
            .twin
            .step(period_us as f64 * 1e-6, at_converters, &self.hand);
        plant.t_s += period_us as f64 * 1e-6;
        self.time_us += period_us as u64;
        if !self.silent && k.is_multiple_of(HEARTBEAT_PERIODS) {
            let _ = self.request(RequestBody::Heartbeat);
        }
    }

    fn run_s(&mut self, seconds: f64) {
        for k in 0..periods(seconds) {
            self.period(k);
        }
    }

    fn hold_here(&mut self, hand: Hand) {
        self.hand = match hand {
            Hand::Free => HandleCondition::Free,
            Hand::Held => HandleCondition::Hand(HandSpring {
                target_user_m: self.plant.twin.state().handle_user_m,
                target_velocity_user_m_s: [0.0; 2],
                stiffness_n_per_m: HAND_N_PER_M,
                damping_n_s_per_m: HAND_N_S_PER_M,
            }),
        };
    }
}

fn periods(seconds: f64) -> u64 {
    (seconds * 1e3).round() as u64
}

/// The twin of the table: converters at their measured rates, spread per channel.
pub fn sim_config(seed: u64) -> SimConfig {
    let effects = EffectSet::none()
        .with(Box::new(ConverterRates::spread()))
        .unwrap_or_else(|_| EffectSet::none());
    SimConfig {
        effects,
        handle: HandleMode::Free,
        seed,
        ..SimConfig::default()
    }
}

/// Runs one case in fast-forward: home, arm, the mode's target for [`SETTLE_S`], the fault,
/// [`WATCH_S`] watched.
pub fn run_case(kind: Kind, mode: TableMode, hand: Hand) -> Result<Outcome, EmulatorError> {
    let (reports, _) = std::sync::mpsc::channel();
    let plant = Plant::new(&sim_config(1), reports)?;
    let mut rig = Rig {
        plant,
        time_us: 0,
        id: 0,
        hand: HandleCondition::Free,
        silent: false,
        session: NO_SESSION,
    };
    let mut out = Outcome {
        kind,
        mode,
        hand,
        setup_problem: None,
        faults: 0,
        to_vent_s: None,
        to_vented_s: None,
        excursion_mm: 0.0,
        speed_mm_s: 0.0,
        hand_force_n: 0.0,
    };
    rig.run_s(0.01);
    let setup = [
        RequestBody::Hello {
            protocol_version: PROTOCOL_VERSION,
            schema_fingerprint: SCHEMA_FINGERPRINT,
        },
        RequestBody::Home,
        // the pressures mode is a service mode: the table enables it for every run, so that
        // each mode starts from the same sequence
        RequestBody::SetServiceMode { enabled: true },
        RequestBody::Arm,
        RequestBody::SetMode(PRETENSION),
        RequestBody::SetMode(mode.target()),
    ];
    for body in setup {
        if matches!(body, RequestBody::SetMode(_)) {
            rig.hold_here(hand);
        }
        if let Err(e) = rig.request(body) {
            out.setup_problem = Some(e);
            return Ok(out);
        }
        if body == RequestBody::SetMode(PRETENSION) {
            rig.run_s(PRETENSION_S);
        }
    }
    rig.run_s(SETTLE_S);
    let before = rig.plant.device.controller().faults().0;
    if before != 0 {
        out.setup_problem = Some(format!("not run: {before:#06x} latched before the fault"));
        return Ok(out);
    }
    watch(&mut rig, kind, &mut out);
    Ok(out)
}

/// Injects `kind` and measures what follows.
fn watch(rig: &mut Rig, kind: Kind, out: &mut Outcome) {
    // an overrun two periods longer than the count that latches, as in the hil-test
    let overrun = rig.plant.device.controller().safety().overrun_fault_periods + 2;
    match injection_at(kind, 0, 0, overrun) {
        Some(i) => rig.plant.inject(i, rig.time_us),
        None => rig.silent = true,
    }
    let start = rig.plant.twin.state().handle_user_m;
    for k in 0..periods(WATCH_S) {
        rig.period(k);
        let t_s = (k + 1) as f64 * 1e-3;
        let s = rig.plant.twin.state();
        let d = [s.handle_user_m[0] - start[0], s.handle_user_m[1] - start[1]];
        out.excursion_mm = out.excursion_mm.max(d[0].hypot(d[1]) * 1e3);
        let v = s.handle_velocity_user_m_s;
        out.speed_mm_s = out.speed_mm_s.max(v[0].hypot(v[1]) * 1e3);
        let f = s.force_on_holder_user_n;
        out.hand_force_n = out.hand_force_n.max(f[0].hypot(f[1]));
        if out.to_vented_s.is_none() && s.pressure_bar.iter().all(|&p| p < VENTED_BAR) {
            out.to_vented_s = Some(t_s);
        }
        let c = rig.plant.device.controller();
        let armed = c.state() == pam_control::State::Armed;
        out.faults = c.faults().0;
        let vent = rig.plant.last_currents_ma.iter().all(|&m| m <= VENT_MA);
        if out.to_vent_s.is_none() && !armed && vent {
            out.to_vent_s = Some(t_s);
        }
    }
    if kind == Kind::EStop {
        rig.plant.inject(Injection::EStopRelease, rig.time_us);
    }
}

/// Every fault kind × every mode × held and free.
pub fn run_all(mut progress: impl FnMut(&Outcome)) -> Result<Vec<Outcome>, EmulatorError> {
    let mut all = Vec::new();
    for kind in KINDS {
        for mode in TABLE_MODES {
            for hand in [Hand::Held, Hand::Free] {
                let o = run_case(kind, mode, hand)?;
                progress(&o);
                all.push(o);
            }
        }
    }
    Ok(all)
}

fn ms(v: Option<f64>) -> String {
    v.map_or(format!("> {:.0}", WATCH_S * 1e3), |s| {
        format!("{:.0}", s * 1e3)
    })
}

fn cells(o: Option<&Outcome>) -> String {
    match o {
        None => "| | | | ".into(),
        Some(o) => match &o.setup_problem {
            Some(p) => format!("| {p} | | | "),
            None => format!(
                "| {} | {} | {:.1} | {:.0} ",
                ms(o.to_vent_s),
                ms(o.to_vented_s),
                o.excursion_mm,
                o.speed_mm_s
            ),
        },
    }
}

/// The markdown table: one row per fault × mode, held hand then free.
pub fn markdown(outcomes: &[Outcome]) -> String {
    let mut s = String::new();
    s.push_str("| fault | mode | faults latched (held / free) | held: to vent command (ms) | held: all < 0.5 bar (ms) | held: excursion (mm) | held: speed (mm/s) | free: to vent command (ms) | free: all < 0.5 bar (ms) | free: excursion (mm) | free: speed (mm/s) |\n");
    s.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for kind in KINDS {
        for mode in TABLE_MODES {
            let find = |hand| {
                outcomes
                    .iter()
                    .find(|o| o.kind == kind && o.mode == mode && o.hand == hand)
            };
            let (held, free) = (find(Hand::Held), find(Hand::Free));
            let bits =
                |o: Option<&Outcome>| o.map_or("—".into(), |o| format!("{:#06x}", o.faults));
            s.push_str(&format!(
                "| {} | {} | {} / {} {}{}|\n",
                kind.name(),
                mode.name(),
                bits(held),
                bits(free),
                cells(held),
                cells(free)
            ));
        }
    }
    s
}
