//! Arming with a free handle and into a hand: the muscles come up from the vent to their
//! pretension without moving the handle, at the neutral pose, at §5.2's poses and next to the
//! soft limits, in the modes that hold the arm still and arm through the tensioning ramp
//! (joint, open-loop force, closed-loop force, impedance). Figures with `--nocapture`.

use pam_control::motion::{ARM_RAMP_S, SOFT_LIMIT_RAD};
use pam_control::{Controller, Mode, SafetyConfig, Sensors, State};
use pam_model::RobotModel;
use pam_twin::experiments::STEP_POSES_DEG;
use pam_twin::{HandSpring, HandleCondition, Twin, TwinConfig};

/// How far and how fast the handle went while the muscles came up.
#[derive(Debug)]
struct Arming {
    /// Largest distance of the handle from where it was when armed, m.
    excursion_m: f64,
    /// Largest handle speed, m/s.
    speed_m_s: f64,
}

/// What holds the handle while the arm is armed.
#[derive(Clone, Copy, Debug)]
enum Holder {
    Free,
    /// A hand where the vented arm left the handle: stiffness N/m, damping N·s/m.
    Hand(f64, f64),
}

/// A mode that holds the arm where it is: from the joint angles and the handle's position
/// (user frame), when armed.
type HoldMode = fn([f32; 2], [f32; 2]) -> Mode;

/// The twin vented at `alpha_rad`, the handle held by `holder`; armed into `mode`, through
/// the tensioning ramp and 1.5 s after it.
fn arm_at(rig: bool, alpha_rad: [f64; 2], mode: HoldMode, holder: Holder) -> Arming {
    arm_for(rig, alpha_rad, mode, holder, ARMING_RUN_PERIODS)
}

/// [`arm_at`] over `periods` after arming.
fn arm_for(
    rig: bool,
    alpha_rad: [f64; 2],
    mode: HoldMode,
    holder: Holder,
    periods: usize,
) -> Arming {
    let mut cfg = if rig {
        TwinConfig::identified_rig()
    } else {
        TwinConfig::thesis()
    };
    cfg.initial_alpha_rad = alpha_rad;
    let params = cfg.params;
    let mut twin = Twin::new(cfg);
    let mut ctl = Controller::new(RobotModel::new(params.cast()), SafetyConfig::default_1khz());
    let x0 = twin.state().handle_user_m;
    let handle = match holder {
        Holder::Free => HandleCondition::Free,
        Holder::Hand(k, b) => HandleCondition::Hand(HandSpring {
            target_user_m: x0,
            target_velocity_user_m_s: [0.0; 2],
            stiffness_n_per_m: k,
            damping_n_s_per_m: b,
        }),
    };
    let mut m = twin.step(1e-9, [4.0; 4], &handle);
    ctl.arm().unwrap();
    let here = x0.map(|x| x as f32);
    ctl.set_mode(mode(m.alpha_rad.map(|a| a as f32), here))
        .unwrap();
    let (mut excursion_m, mut speed_m_s) = (0.0f64, 0.0f64);
    for _ in 0..periods {
        ctl.heartbeat();
        let out = ctl.step(&Sensors {
            alpha_rad: m.alpha_rad.map(|a| a as f32),
            force_sensor_n: m.force_sensor_n.map(|f| f as f32),
        });
        assert_eq!(out.state, State::Armed, "{:?}", out.faults);
        m = twin.step(0.001, out.current_ma.map(f64::from), &handle);
        let s = twin.state();
        let (dx, v) = (s.handle_user_m, s.handle_velocity_user_m_s);
        excursion_m = excursion_m.max((dx[0] - x0[0]).hypot(dx[1] - x0[1]));
        speed_m_s = speed_m_s.max(v[0].hypot(v[1]));
    }
    Arming {
        excursion_m,
        speed_m_s,
    }
}

/// Hold where the arm is, at `pamctl set joint`'s default stiffness.
fn hold_here(alpha_rad: [f32; 2], _: [f32; 2]) -> Mode {
    Mode::Joint {
        alpha_rad,
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [95.0, 40.0],
    }
}

/// No force at the handle, open loop, at `pamctl set force`'s default stiffness.
fn no_force(_: [f32; 2], _: [f32; 2]) -> Mode {
    Mode::Force {
        force_n: [0.0; 2],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: false,
    }
}

/// No force at the handle, the load cell in the loop, as `pamctl set force --closed-loop`
/// defaults to.
fn no_force_closed_loop(_: [f32; 2], _: [f32; 2]) -> Mode {
    Mode::ForceClosedLoop {
        force_n: [0.0; 2],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: false,
        gain_scale: 1.0,
    }
}

/// Transparent impedance, as `pamctl set impedance` defaults to (no spring, 5 N·s/m).
fn transparent(_: [f32; 2], _: [f32; 2]) -> Mode {
    Mode::Impedance {
        target_user_m: [0.0; 2],
        stiffness_n_per_m: [0.0; 2],
        damping_n_s_per_m: [5.0; 2],
        mass_kg: [0.0; 2],
    }
}

/// The modes that hold the arm still, by name.
const MODES: [(&str, HoldMode); 4] = [
    ("joint", hold_here),
    ("force", no_force),
    ("closed loop", no_force_closed_loop),
    ("impedance", transparent),
];

/// The poses: §5.2's nine and each joint 1 mrad inside its soft limits (the other at 0).
fn poses() -> Vec<[f64; 2]> {
    let joints = pam_model::RobotParams::<f64>::thesis().joints;
    let soft = f64::from(SOFT_LIMIT_RAD) + 1e-3;
    let mut p: Vec<[f64; 2]> = STEP_POSES_DEG
        .iter()
        .map(|d| [d[0].to_radians(), d[1].to_radians()])
        .collect();
    for j in 0..2 {
        for a in [
            joints[j].alpha_min_rad + soft,
            joints[j].alpha_max_rad - soft,
        ] {
            let mut alpha = [0.0; 2];
            alpha[j] = a;
            p.push(alpha);
        }
    }
    p
}

/// Periods simulated after arming: the ramp and 1.5 s (the arm's slowest swing, ≈ 2 Hz,
/// three times over).
const ARMING_RUN_PERIODS: usize = (ARM_RAMP_S as f64 * 1000.0) as usize + 1500;
/// Periods of the ramp alone. After it the impedance mode renders no spring and keeps a
/// force, not a position: a free handle, which takes no force, drifts with whatever the model
/// misses (up to 18 mm within 1.5 s), the mode's transparency and not the arming.
const RAMP_PERIODS: usize = (ARM_RAMP_S as f64 * 1000.0) as usize;
/// Periods after the ramp that belong to the closed force loop's arming: its entry, from the
/// force measured when the ramp ends, and one swing of the arm (≈ 2 Hz). After it the loop
/// keeps 0 N, not a position, and a free handle drifts like the impedance mode's (up to
/// 6.4 mm within 1.5 s at 16 mm/s on the default twin).
const ENTRY_PERIODS: usize = 500;
/// Largest handle excursion while arming, m: 6 mm, the travel of a hand resting on the
/// handle that the patient feels as a nudge, not a pull. What is left is the converters'
/// lag, longer into the larger volume of the more contracted muscle, which the model does
/// not know: the joint's equilibrium shifts while the pressures rise (5.4 mm at worst on
/// the twins). One slew-limited jump to the pretension moves the handle 18–46 mm.
const ARMING_EXCURSION_MAX_M: f64 = 0.006;
/// Largest handle speed while arming, m/s: 60 mm/s, a tenth of the closed loops' speed
/// guard (0.5 m/s); the one-jump pressurisation reaches 0.3–1 m/s.
const ARMING_SPEED_MAX_M_S: f64 = 0.06;

/// Runs every pose, both twins and every mode with the handle held by `holder`; returns the
/// worst excursion and speed and the runs beyond the bounds.
fn arm_everywhere(holder: Holder) -> ((f64, f64), Vec<String>) {
    let mut worst = (0.0f64, 0.0f64);
    let mut failures = Vec::new();
    for rig in [false, true] {
        for (name, mode) in MODES {
            for alpha in poses() {
                let a = match (holder, name) {
                    (Holder::Free, "impedance") => arm_for(rig, alpha, mode, holder, RAMP_PERIODS),
                    (Holder::Free, "closed loop") => {
                        arm_for(rig, alpha, mode, holder, RAMP_PERIODS + ENTRY_PERIODS)
                    }
                    _ => arm_at(rig, alpha, mode, holder),
                };
                println!(
                    "{holder:?} rig {rig} {name:12} α [{:6.2}°, {:6.2}°]: excursion {:5.2} mm, \
                     speed {:6.1} mm/s",
                    alpha[0].to_degrees(),
                    alpha[1].to_degrees(),
                    a.excursion_m * 1e3,
                    a.speed_m_s * 1e3
                );
                worst = (worst.0.max(a.excursion_m), worst.1.max(a.speed_m_s));
                if a.excursion_m > ARMING_EXCURSION_MAX_M || a.speed_m_s > ARMING_SPEED_MAX_M_S {
                    failures.push(format!("{holder:?} rig {rig} {name} α {alpha:?}: {a:?}"));
                }
            }
        }
    }
    println!(
        "{holder:?} worst: excursion {:.2} mm, speed {:.1} mm/s",
        worst.0 * 1e3,
        worst.1 * 1e3
    );
    (worst, failures)
}

/// At every pose, on both twins and in the four modes that hold the arm still, arming
/// moves a free handle less than 6 mm and slower than 60 mm/s.
#[test]
fn arming_with_a_free_handle_does_not_move_it() {
    let (_, failures) = arm_everywhere(Holder::Free);
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The same with a relaxed hand on the handle (1000 N/m, 50 N·s/m: the softest grip the
/// closed loops are designed for).
#[test]
fn arming_into_a_hand_does_not_move_it() {
    let (_, failures) = arm_everywhere(Holder::Hand(1000.0, 50.0));
    assert!(failures.is_empty(), "{failures:#?}");
}
