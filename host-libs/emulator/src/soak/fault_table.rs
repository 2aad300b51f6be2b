//! The fault-consequence table: every fault the soak injects, from every control mode, with
//! a relaxed hand on the handle and with the handle free, fast-forwarded on the twin with
//! the converters' flow limits (`pam_twin::ConverterRates::spread`: exhaust 1.6–2.4 s per
//! channel, filling 1.5 times slower).
//!
//! One cell: home, arm, set the mode with the hand on the handle (held: a relaxed hand,
//! 1000 N/m and 50 N·s/m, at the joint or impedance target, else where the handle is, as
//! the emulator's `--handle held-relaxed`; it holds on after the fault as a patient's hand
//! does), let the arm settle, inject the fault, watch. Measured from the fault's
//! first period: the first period the device commands the vent (disarmed or faulted, the
//! 4 mA floor on every loop), the first time all four muscles are below 0.5 bar, the
//! handle's largest distance from where it was at the fault and its largest speed, and the
//! largest force between hand and handle.

use std::fmt::Write as _;

use pam_control::{SafetyConfig, State};
use pam_device::{StepResult, StepTiming};
use pam_protocol::{wire, Request, RequestBody};
use pam_twin::faults::PlantFault;
use pam_twin::{ConverterRates, EffectSet, HandSpring, HandleCondition};

use super::{Kind, KINDS};
use crate::inject::Injection;
use crate::plant::Plant;
use crate::{EmulatorError, HandleMode, SimConfig};

/// The relaxed hand: stiffness (N/m) and damping (N·s/m), a patient who does not
/// co-contract.
const HAND_N_PER_M: f64 = 1000.0;
const HAND_N_S_PER_M: f64 = 50.0;
/// The "muscles vented" level.
pub const VENTED_BAR: f64 = 0.5;

/// What holds the handle from the grab on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hand {
    Held,
    Free,
}

impl Hand {
    pub fn name(self) -> &'static str {
        match self {
            Hand::Held => "held",
            Hand::Free => "free",
        }
    }
}

/// The modes of the table, by name, with the target each runs.
pub const MODES: [&str; 5] = [
    "pressures",
    "joint",
    "force open loop",
    "force closed loop",
    "impedance",
];

fn mode(name: &str) -> wire::Mode {
    match name {
        "pressures" => wire::Mode::Pressures {
            pressure_bar: [2.0; 4],
        },
        "joint" => wire::Mode::Joint {
            alpha_rad: [0.1, -0.1],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [50.0, 25.0],
        },
        "force open loop" => wire::Mode::Force {
            force_n: [5.0, 0.0],
            stiffness_nm_per_rad: [20.0, 20.0],
            feed_forward: true,
        },
        "force closed loop" => wire::Mode::ForceClosedLoop {
            force_n: [5.0, 0.0],
            stiffness_nm_per_rad: [20.0, 20.0],
            feed_forward: true,
            gain_scale: 0.5,
        },
        _ => wire::Mode::Impedance {
            target_user_m: [0.02, 0.0],
            stiffness_n_per_m: [200.0, 200.0],
            damping_n_s_per_m: [20.0, 20.0],
        },
    }
}

/// Timing of one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableConfig {
    /// From the mode set to the fault: `settle_s + hold_s`.
    pub settle_s: f64,
    pub hold_s: f64,
    /// Watched after the fault.
    pub watch_s: f64,
    pub seed: u64,
}

impl Default for TableConfig {
    fn default() -> Self {
        TableConfig {
            settle_s: 2.0,
            hold_s: 0.5,
            watch_s: 5.0,
            seed: 1,
        }
    }
}

/// What followed one fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Consequence {
    /// Fault bits latched by the end of the watch.
    pub faults: u16,
    pub to_vent_command_s: Option<f64>,
    pub to_vented_s: Option<f64>,
    pub excursion_mm: f64,
    pub speed_mm_s: f64,
    /// The handle's speed in the fault's first period (the mode's own motion), mm/s.
    pub speed_at_fault_mm_s: f64,
    /// Largest force between hand and handle (0 when free), N.
    pub hand_force_n: f64,
}

/// One cell: its consequence, or why it could not be measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub kind: Kind,
    pub mode: &'static str,
    pub hand: Hand,
    pub outcome: Result<Consequence, String>,
}

/// The emulated device, the twin with the converters' flow limits, and the host's clock.
struct Rig {
    plant: Plant,
    time_us: u64,
    id: u16,
    since_request: u32,
    link_lost: bool,
}

impl Rig {
    fn new(seed: u64) -> Result<Rig, EmulatorError> {
        let effects = EffectSet::none()
            .with(Box::new(ConverterRates::spread()))
            .map_err(|e| EmulatorError::Injection {
                text: "converter_rates".into(),
                reason: e.to_string(),
            })?;
        let sim = SimConfig {
            effects,
            handle: HandleMode::Free,
            seed,
            ..SimConfig::default()
        };
        let (reports, _) = std::sync::mpsc::channel();
        Ok(Rig {
            plant: Plant::new(&sim, reports)?,
            time_us: 0,
            id: 0,
            since_request: 0,
            link_lost: false,
        })
    }

    fn request(&mut self, body: RequestBody) -> Result<(), pam_protocol::ErrorCode> {
        self.id = self.id.wrapping_add(1).max(1);
        self.since_request = 0;
        let reply = self.plant.handle_frame(Ok(Request { id: self.id, body }));
        reply.result.map(|_| ())
    }

    /// One control period with `hand` on the handle; heartbeats every 20 periods unless
    /// the link is lost.
    fn period(&mut self, hand: &HandleCondition) -> StepResult {
        let p = &mut self.plant;
        let period_us = p.device.period_us().max(1);
        p.board.before_step(&mut p.device);
        let raw = p.raw_sensors();
        let result = p.device.step(
            raw,
            StepTiming {
                time_us: self.time_us as u32,
                loop_exec_us: 20,
                loop_jitter_us: 0,
            },
        );
        let stall_us = p.board.stall_us(period_us);
        let driven = p.board.after_step(
            &mut p.device,
            self.time_us as u32,
            20 + stall_us,
            period_us,
            result.current_ma,
        );
        p.last_currents_ma = driven.map(f64::from);
        let at_converters = p.board.converter_currents(p.last_currents_ma);
        let period_s = period_us as f64 * 1e-6;
        p.last = p.twin.step(period_s, at_converters, hand);
        p.t_s += period_s;
        self.time_us += period_us as u64;
        self.since_request += 1;
        if !self.link_lost && self.since_request >= 20 {
            let _ = self.request(RequestBody::Heartbeat);
        }
        result
    }

    fn periods(&self, s: f64) -> u64 {
        (s / (self.plant.device.period_us().max(1) as f64 * 1e-6)).round() as u64
    }
}

/// The injection of `kind` in the table: joint 1, channel 1 (the fastest exhaust of the
/// spread; the stuck one holds its pressure anyway), +400 counts, one missed period more
/// than the fault count. Link loss is the host's silence.
fn injection(kind: Kind) -> Option<Injection> {
    Some(match kind {
        Kind::LinkLoss => return None,
        Kind::EncoderStuck => Injection::Plant(PlantFault::EncoderStuck { joint: 0 }),
        Kind::EncoderUnplugged => Injection::Plant(PlantFault::EncoderUnplugged { joint: 0 }),
        Kind::EncoderMiscount => Injection::Plant(PlantFault::EncoderJump {
            joint: 0,
            counts: 400,
        }),
        Kind::LoadcellSaturated => Injection::Plant(PlantFault::LoadcellSaturated { channel: 0 }),
        Kind::LoadcellFrozen => Injection::Plant(PlantFault::LoadcellFrozen),
        Kind::ConverterOpen => Injection::Plant(PlantFault::ConverterOpen { channel: 0 }),
        Kind::ConverterStuck => Injection::Plant(PlantFault::ConverterStuck { channel: 0 }),
        Kind::LoopOverrun => Injection::Overrun {
            periods: SafetyConfig::default_1khz().overrun_fault_periods + 1,
        },
        Kind::EStop => Injection::EStop,
    })
}

/// Runs one cell.
pub fn cell(
    kind: Kind,
    mode_name: &'static str,
    hand: Hand,
    cfg: &TableConfig,
) -> Result<Cell, EmulatorError> {
    let mut rig = Rig::new(cfg.seed)?;
    let done = |outcome| Cell {
        kind,
        mode: mode_name,
        hand,
        outcome,
    };
    for _ in 0..10 {
        rig.period(&HandleCondition::Free);
    }
    for body in [RequestBody::Home, RequestBody::Arm] {
        if let Err(e) = rig.request(body) {
            return Ok(done(Err(format!("{body:?} refused: {e:?}"))));
        }
    }
    if let Err(e) = rig.request(RequestBody::SetMode(mode(mode_name))) {
        return Ok(done(Err(format!("mode refused: {e:?}"))));
    }
    let grab = match hand {
        Hand::Free => HandleCondition::Free,
        Hand::Held => HandleCondition::Hand(HandSpring {
            target_user_m: hold_point(&rig, mode_name),
            target_velocity_user_m_s: [0.0; 2],
            stiffness_n_per_m: HAND_N_PER_M,
            damping_n_s_per_m: HAND_N_S_PER_M,
        }),
    };
    for _ in 0..rig.periods(cfg.settle_s + cfg.hold_s) {
        rig.period(&grab);
    }
    let c = rig.plant.device.controller();
    if c.state() != State::Armed {
        return Ok(done(Err(format!(
            "the mode faults by itself ({}) {}",
            fault_names(c.faults().0),
            match hand {
                Hand::Free => "with the handle free",
                Hand::Held => "against a relaxed hand",
            }
        ))));
    }
    match injection(kind) {
        Some(i) => rig.plant.inject(i, rig.time_us),
        None => rig.link_lost = true,
    }
    Ok(done(Ok(watch(&mut rig, &grab, cfg.watch_s))))
}

/// Where the hand holds the handle: at the joint or impedance target, else where it is
/// (the emulator's `--handle held-relaxed`).
fn hold_point(rig: &Rig, mode_name: &str) -> [f64; 2] {
    match mode(mode_name) {
        wire::Mode::Joint { alpha_rad, .. } => rig
            .plant
            .model
            .kinematics
            .forward_user([alpha_rad[0] as f64, alpha_rad[1] as f64]),
        wire::Mode::Impedance { target_user_m, .. } => {
            [target_user_m[0] as f64, target_user_m[1] as f64]
        }
        _ => rig.plant.twin.state().handle_user_m,
    }
}

/// Watches `watch_s` after the fault.
fn watch(rig: &mut Rig, hand: &HandleCondition, watch_s: f64) -> Consequence {
    let period_s = rig.plant.device.period_us().max(1) as f64 * 1e-6;
    let start = rig.plant.twin.state().handle_user_m;
    let v0 = rig.plant.twin.state().handle_velocity_user_m_s;
    let mut out = Consequence {
        faults: 0,
        to_vent_command_s: None,
        to_vented_s: None,
        excursion_mm: 0.0,
        speed_mm_s: 0.0,
        speed_at_fault_mm_s: v0[0].hypot(v0[1]) * 1e3,
        hand_force_n: 0.0,
    };
    for k in 0..rig.periods(watch_s) {
        let r = rig.period(hand);
        let t_s = k as f64 * period_s;
        let c = rig.plant.device.controller();
        if out.to_vent_command_s.is_none()
            && c.state() != State::Armed
            && r.current_ma.iter().all(|&ma| ma <= 4.0)
        {
            out.to_vent_command_s = Some(t_s);
        }
        let s = rig.plant.twin.state();
        if out.to_vented_s.is_none() && s.pressure_bar.iter().all(|&p| p < VENTED_BAR) {
            out.to_vented_s = Some(t_s + period_s);
        }
        let d = [s.handle_user_m[0] - start[0], s.handle_user_m[1] - start[1]];
        out.excursion_mm = out.excursion_mm.max(d[0].hypot(d[1]) * 1e3);
        let v = s.handle_velocity_user_m_s;
        out.speed_mm_s = out.speed_mm_s.max(v[0].hypot(v[1]) * 1e3);
        if matches!(hand, HandleCondition::Hand(_)) {
            let f = s.force_on_holder_user_n;
            out.hand_force_n = out.hand_force_n.max(f[0].hypot(f[1]));
        }
        out.faults = c.faults().0;
    }
    out
}

/// Every fault × every mode × held and free.
pub fn run(cfg: &TableConfig, mut progress: impl FnMut(&Cell)) -> Result<Vec<Cell>, EmulatorError> {
    let mut cells = Vec::new();
    for kind in KINDS {
        for mode_name in MODES {
            for hand in [Hand::Held, Hand::Free] {
                let c = cell(kind, mode_name, hand, cfg)?;
                progress(&c);
                cells.push(c);
            }
        }
    }
    Ok(cells)
}

/// The names of the bits of the control-loop faults the table can show.
fn fault_names(bits: u16) -> String {
    use pam_control::Faults as F;
    let names = [
        (F::COMMAND_TIMEOUT, "COMMAND_TIMEOUT"),
        (F::ANGLE_OUT_OF_RANGE, "ANGLE_OUT_OF_RANGE"),
        (F::ENCODER_JUMP, "ENCODER_JUMP"),
        (F::LOADCELL_SATURATED, "LOADCELL_SATURATED"),
        (F::LOADCELL_STUCK, "LOADCELL_STUCK"),
        (F::OUTPUT_OPEN_LOOP, "OUTPUT_OPEN_LOOP"),
        (F::LOOP_OVERRUN, "LOOP_OVERRUN"),
        (F::ESTOP, "ESTOP"),
        (F::STATIC_IMBALANCE, "STATIC_IMBALANCE"),
        (F::CONTROL_UNSTABLE, "CONTROL_UNSTABLE"),
    ];
    let set: Vec<&str> = names
        .iter()
        .filter(|(f, _)| bits & f.0 != 0)
        .map(|(_, n)| *n)
        .collect();
    if set.is_empty() {
        format!("{bits:#06x}")
    } else {
        set.join(" + ")
    }
}

fn secs(v: Option<f64>, watch_s: f64) -> String {
    v.map_or(format!("> {watch_s:.0} s"), |s| {
        format!("{:.0} ms", s * 1e3)
    })
}

/// The table in markdown, one row per fault × mode, held and free side by side.
pub fn markdown(cells: &[Cell], cfg: &TableConfig) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| fault | mode | hand | vent command | all < {VENTED_BAR} bar | excursion mm | speed mm/s (at the fault) | hand force N | faults latched |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|---|");
    for c in cells {
        let row = match &c.outcome {
            Ok(q) => format!(
                "{} | {} | {:.1} | {:.0} ({:.0}) | {} | {}",
                secs(q.to_vent_command_s, cfg.watch_s),
                secs(q.to_vented_s, cfg.watch_s),
                q.excursion_mm,
                q.speed_mm_s,
                q.speed_at_fault_mm_s,
                match c.hand {
                    Hand::Held => format!("{:.1}", q.hand_force_n),
                    Hand::Free => "—".into(),
                },
                if q.faults == 0 {
                    "none".into()
                } else {
                    fault_names(q.faults)
                }
            ),
            Err(why) => format!("not measured: {why} | — | — | — | — | —"),
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {row} |",
            c.kind.name(),
            c.mode,
            c.hand.name()
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estop_in_joint_mode_vents_at_once_and_the_handle_stays_within_the_workspace() {
        let cfg = TableConfig {
            settle_s: 1.0,
            hold_s: 0.2,
            watch_s: 3.5,
            seed: 1,
        };
        let c = cell(Kind::EStop, "joint", Hand::Held, &cfg).unwrap();
        let q = c
            .outcome
            .expect("the joint mode runs against a relaxed hand");
        // the E-stop vents in its first period; the slowest converter exhausts 5 bar in
        // 2.4 s, so the joint mode's pressures are below 0.5 bar within the watch but not
        // faster than the fastest converter's rate allows
        assert_eq!(q.to_vent_command_s, Some(0.0));
        let vented = q.to_vented_s.expect("vented within the watch");
        assert!(vented > 0.1 && vented < 3.0, "{vented}");
        assert!(
            q.excursion_mm.is_finite() && q.excursion_mm < 300.0,
            "{q:?}"
        );
        assert!(q.speed_mm_s.is_finite() && q.hand_force_n > 0.0, "{q:?}");
        assert_ne!(q.faults & pam_control::Faults::ESTOP.0, 0);
    }
}
