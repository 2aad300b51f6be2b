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

use pam_control::Faults;
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
/// The pretension lasts at least this long (s)…
const PRETENSION_S: f64 = 2.0;
/// …and until the home is judged at its first rest
/// (`pam_control::home_check`), at most this long (s): a free handle swings for a while
/// after the muscles come up.
const PRETENSION_MAX_S: f64 = 30.0;
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

    /// The target held before the fault, for what holds the handle; `here_user_m`: the
    /// handle's position as the host reads it from the telemetry when it sets the mode.
    ///
    /// The closed loops hold a force on a hand. A free handle cannot hold any force but
    /// 0 N: a 5 N target pushes it away, and the loop's released-handle guard rightly faults
    /// that before any fault is injected. So with a free handle the closed force loop runs
    /// at 0 N, steadily until the fault, and the impedance's rest point is where the handle
    /// is (its loop still swings a free handle until its own guard latches, which the
    /// table's note reports). The other modes do not read the load cell's force against a
    /// target and keep one target for both.
    pub fn target(self, hand: Hand, here_user_m: [f32; 2]) -> wire::Mode {
        match (self, hand) {
            (TableMode::Pressures, _) => wire::Mode::Pressures {
                pressure_bar: [2.5, 2.0, 2.5, 2.0],
            },
            (TableMode::Joint, _) => wire::Mode::Joint {
                alpha_rad: [0.1, -0.1],
                torque_nm: [0.0, 0.0],
                stiffness_nm_per_rad: [50.0, 25.0],
            },
            (TableMode::ForceOpenLoop, _) => wire::Mode::Force {
                force_n: [5.0, 0.0],
                stiffness_nm_per_rad: [20.0, 20.0],
                feed_forward: true,
            },
            (TableMode::ForceClosedLoop, hand) => wire::Mode::ForceClosedLoop {
                force_n: match hand {
                    Hand::Held => [5.0, 0.0],
                    Hand::Free => [0.0, 0.0],
                },
                stiffness_nm_per_rad: [20.0, 20.0],
                feed_forward: true,
                gain_scale: 1.0,
            },
            (TableMode::Impedance, hand) => wire::Mode::Impedance {
                // a rest point away from a free handle is a hand that does not follow,
                // which the released-handle guard faults on
                target_user_m: match hand {
                    Hand::Held => [0.0, 0.0],
                    Hand::Free => here_user_m,
                },
                stiffness_n_per_m: [200.0, 200.0],
                damping_n_s_per_m: [20.0, 20.0],
            },
        }
    }

    /// [`TableMode::target`] in words, for the table's text.
    pub fn target_text(self, hand: Hand) -> &'static str {
        match (self, hand) {
            (TableMode::Pressures, _) => "2.5 / 2.0 / 2.5 / 2.0 bar",
            (TableMode::Joint, _) => "(0.1, −0.1) rad at 50 / 25 N·m/rad",
            (TableMode::ForceOpenLoop, _) => "5 N along x at 20 N·m/rad, feed-forward",
            (TableMode::ForceClosedLoop, Hand::Held) => {
                "5 N along x at 20 N·m/rad, feed-forward, gain scale 1"
            }
            (TableMode::ForceClosedLoop, Hand::Free) => {
                "0 N at 20 N·m/rad, feed-forward, gain scale 1"
            }
            (TableMode::Impedance, Hand::Held) => {
                "rest point at the neutral pose, 200 N/m, 20 N·s/m"
            }
            (TableMode::Impedance, Hand::Free) => {
                "rest point where the handle is when the mode is set, 200 N/m, 20 N·s/m"
            }
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

impl Hand {
    pub fn name(self) -> &'static str {
        match self {
            Hand::Held => "held hand",
            Hand::Free => "free handle",
        }
    }
}

/// One measured case. Times are from the fault's first period (s); `None`: not within
/// [`WATCH_S`].
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    pub kind: Kind,
    pub mode: TableMode,
    pub hand: Hand,
    /// Why the case could not run as set up (a refused request, a home not judged, a
    /// fault latched by the setup or by the mode itself before the injection); the figures
    /// are then absent.
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
    /// The joint angles of the last telemetry sample: the pose as the host reads it.
    telemetry_alpha_rad: Option<[f32; 2]>,
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
        if let Some(t) = &result.telemetry {
            self.telemetry_alpha_rad = Some(t.alpha_rad);
        }
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

    /// Runs the setup's `step` for at least `min_s` and until `done`, at most `max_s`: a
    /// fault latched meanwhile ends the setup, with what latched, when and how fast the
    /// handle then moved.
    fn settle(
        &mut self,
        step: &str,
        (min_s, max_s): (f64, f64),
        done: fn(&Rig) -> bool,
    ) -> Result<(), String> {
        let (min, max) = (periods(min_s), periods(max_s));
        let mut k = 0;
        while k < min || !done(self) {
            if k >= max {
                return Err(format!("{step} not over within {max_s:.0} s"));
            }
            self.period(k);
            k += 1;
            let faults = self.plant.device.controller().faults().0;
            if faults != 0 {
                let v = self.plant.twin.state().handle_velocity_user_m_s;
                return Err(format!(
                    "{} latched {:.2} s into {step}, the handle at {:.2} m/s",
                    fault_names(faults),
                    k as f64 * 1e-3,
                    v[0].hypot(v[1])
                ));
            }
        }
        Ok(())
    }

    /// The handle's position as the host computes it from the last telemetry sample.
    fn here_user_m(&self) -> Result<[f32; 2], String> {
        let alpha = self
            .telemetry_alpha_rad
            .ok_or_else(|| "no telemetry to read the pose from".to_string())?;
        Ok(self
            .plant
            .device
            .controller()
            .model()
            .kinematics
            .forward_user(alpha))
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

/// The latched fault bits by their names in `pam_control::Faults`, and the code.
fn fault_names(bits: u16) -> String {
    const NAMES: [(Faults, &str); 16] = [
        (Faults::COMMAND_TIMEOUT, "COMMAND_TIMEOUT"),
        (Faults::NON_FINITE, "NON_FINITE"),
        (Faults::ANGLE_OUT_OF_RANGE, "ANGLE_OUT_OF_RANGE"),
        (Faults::ENCODER_JUMP, "ENCODER_JUMP"),
        (Faults::LOADCELL_SATURATED, "LOADCELL_SATURATED"),
        (Faults::LOADCELL_STUCK, "LOADCELL_STUCK"),
        (Faults::OUTPUT_NON_FINITE, "OUTPUT_NON_FINITE"),
        (Faults::WATCHDOG_RESET, "WATCHDOG_RESET"),
        (Faults::OUTPUT_OPEN_LOOP, "OUTPUT_OPEN_LOOP"),
        (Faults::CPU_FAULT, "CPU_FAULT"),
        (Faults::LOOP_OVERRUN, "LOOP_OVERRUN"),
        (Faults::STACK_LOW, "STACK_LOW"),
        (Faults::ESTOP, "ESTOP"),
        (Faults::STATIC_IMBALANCE, "STATIC_IMBALANCE"),
        (Faults::CONTROL_UNSTABLE, "CONTROL_UNSTABLE"),
        (Faults::SELF_CHECK, "SELF_CHECK"),
    ];
    let names: Vec<&str> = NAMES
        .iter()
        .filter(|(f, _)| Faults(bits).contains(*f))
        .map(|(_, n)| *n)
        .collect();
    format!("{} ({bits:#06x})", names.join(" + "))
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
    run_case_watched(kind, mode, hand, WATCH_S)
}

/// [`run_case`] with the fault watched for `watch_s`.
pub fn run_case_watched(
    kind: Kind,
    mode: TableMode,
    hand: Hand,
    watch_s: f64,
) -> Result<Outcome, EmulatorError> {
    let (reports, _) = std::sync::mpsc::channel();
    let plant = Plant::new(&sim_config(1), reports)?;
    let mut rig = Rig {
        plant,
        time_us: 0,
        id: 0,
        hand: HandleCondition::Free,
        silent: false,
        session: NO_SESSION,
        telemetry_alpha_rad: None,
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
    match set_up(&mut rig, mode, hand) {
        Ok(()) => watch(&mut rig, kind, watch_s, &mut out),
        Err(e) => out.setup_problem = Some(e),
    }
    Ok(out)
}

/// What a user does: the handshake, the home at the neutral pose with the arm vented, the
/// service interlock for the pressures mode only, arm, bring the muscles up at the neutral
/// pose, then the mode's target for [`SETTLE_S`]. The home is judged at the first
/// tensioned rest (`pam_control::home_check`): it must be judged, and right, before the
/// fault, so that no fault of the setup is taken for the injected one.
fn set_up(rig: &mut Rig, mode: TableMode, hand: Hand) -> Result<(), String> {
    rig.run_s(0.01);
    rig.request(RequestBody::Hello {
        protocol_version: PROTOCOL_VERSION,
        schema_fingerprint: SCHEMA_FINGERPRINT,
    })?;
    rig.request(RequestBody::Home)?;
    if mode == TableMode::Pressures {
        rig.request(RequestBody::SetServiceMode { enabled: true })?;
    }
    rig.request(RequestBody::Arm)?;
    rig.hold_here(hand);
    rig.request(RequestBody::SetMode(PRETENSION))?;
    let home_judged = |r: &Rig| !r.plant.device.controller().home_check().pending();
    rig.settle(
        "the pretension (until the home is judged)",
        (PRETENSION_S, PRETENSION_MAX_S),
        home_judged,
    )?;
    rig.hold_here(hand);
    let target = mode.target(hand, rig.here_user_m()?);
    rig.request(RequestBody::SetMode(target))?;
    rig.settle("the mode", (SETTLE_S, SETTLE_S), |_| true)
}

/// Injects `kind` and measures what follows.
fn watch(rig: &mut Rig, kind: Kind, watch_s: f64, out: &mut Outcome) {
    // an overrun two periods longer than the count that latches, as in the hil-test
    let overrun = rig.plant.device.controller().safety().overrun_fault_periods + 2;
    match injection_at(kind, 0, 0, overrun) {
        Some(i) => rig.plant.inject(i, rig.time_us),
        None => rig.silent = true,
    }
    let start = rig.plant.twin.state().handle_user_m;
    for k in 0..periods(watch_s) {
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

/// The four figures of one case; a case that did not run reads "not run" with the number
/// of the note that says why (`notes` collects the reasons, one per mode, holder and
/// reason: the setup comes before the fault and is the same for every fault kind).
fn cells(o: Option<&Outcome>, notes: &mut Vec<String>) -> String {
    match o {
        None => "| | | | ".into(),
        Some(o) => match &o.setup_problem {
            Some(p) => {
                let note = format!("{}, {}: {p}.", o.mode.name(), o.hand.name());
                let n = match notes.iter().position(|n| *n == note) {
                    Some(i) => i + 1,
                    None => {
                        notes.push(note);
                        notes.len()
                    }
                };
                format!("| not run ({n}) | | | ")
            }
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

/// The targets of each mode, held and free, as a markdown table.
pub fn targets_markdown() -> String {
    let mut s = String::from("| mode | target with a held hand | target with a free handle |\n");
    s.push_str("|---|---|---|\n");
    for mode in TABLE_MODES {
        s.push_str(&format!(
            "| {} | {} | {} |\n",
            mode.name(),
            mode.target_text(Hand::Held),
            mode.target_text(Hand::Free)
        ));
    }
    s
}

/// The markdown table: one row per fault × mode, held hand then free; below it, why each
/// case that did not run did not (none when all ran).
pub fn markdown(outcomes: &[Outcome]) -> String {
    let mut s = String::new();
    let mut notes = Vec::new();
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
            let bits = |o: Option<&Outcome>| match o {
                Some(o) if o.setup_problem.is_none() => format!("{:#06x}", o.faults),
                _ => "—".into(),
            };
            let held_cells = cells(held, &mut notes);
            let free_cells = cells(free, &mut notes);
            s.push_str(&format!(
                "| {} | {} | {} / {} {held_cells}{free_cells}|\n",
                kind.name(),
                mode.name(),
                bits(held),
                bits(free),
            ));
        }
    }
    if !notes.is_empty() {
        s.push_str(
            "\nNot run (the setup comes before the fault: the same for every fault kind):\n\n",
        );
        for (i, n) in notes.iter().enumerate() {
            s.push_str(&format!("{}. {n}\n", i + 1));
        }
    }
    s
}
