//! Checks of the motion limits of every mode: the shaped joint target, the soft limits,
//! the joint speed supervision and the pressures mode's ceilings. Run by `cargo test` on
//! the host and on the Cortex-M4F under QEMU (`qemu-tests/`).

use crate::motion::{
    JointShaper, ARM_RAMP_S, JOINT_TARGET_ACCEL_MAX_RAD_S2, JOINT_TARGET_RATE_MAX_RAD_S,
    SOFT_LIMIT_RAD,
};
use crate::supervisor::{Controller, Faults, Mode, Reject, SafetyConfig, Sensors, State};
use crate::VENT_CURRENT_MA;
use pam_model::checks::{holds_that as holds, CheckResult, Failure};
use pam_model::{Limited, RobotModel};

pub use pam_model::checks::Check;

fn at(alpha_rad: [f32; 2], k: u32) -> Sensors {
    let d = if k.is_multiple_of(2) { 0.01 } else { -0.01 };
    Sensors {
        alpha_rad,
        force_sensor_n: [0.5 + d, -0.3],
    }
}

/// A handle held still at `alpha_rad`: the load cell reads the force that balances what the
/// muscles make there for the commanded `pressure_bar` (the torque a hand or a block takes).
pub(crate) fn held(c: &Controller, alpha_rad: [f32; 2], pressure_bar: [f32; 4], k: u32) -> Sensors {
    let m = c.model();
    let torque = m.direct(alpha_rad, m.joint_pressures_bar(pressure_bar));
    let jt_inv = m.kinematics.jacobian(alpha_rad).transpose().inverse();
    let user = jt_inv.map_or([0.0; 2], |j| j.mul_vec([torque[0].0, torque[1].0]));
    let mut s = at(alpha_rad, k);
    let sensor = m.kinematics.user_to_sensor(alpha_rad, user);
    s.force_sensor_n = [
        s.force_sensor_n[0] + sensor[0],
        s.force_sensor_n[1] + sensor[1],
    ];
    s
}

/// Armed in `mode`, the tensioning ramp run through at rest.
fn armed(mode: Mode) -> Result<Controller, Failure> {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    holds("mode accepted", c.set_mode(mode).is_ok())?;
    for k in 0..RAMP_PERIODS {
        c.heartbeat();
        c.step(&at([0.0; 2], k));
    }
    Ok(c)
}

/// The tensioning ramp's periods at 1 kHz.
const RAMP_PERIODS: u32 = (ARM_RAMP_S * 1000.0) as u32 + 1;

const MOVE: Mode = Mode::Joint {
    alpha_rad: [0.1745, 0.1134],
    torque_nm: [0.0; 2],
    stiffness_nm_per_rad: [95.0, 40.0],
};

/// A joint target 10° away is not a step: 100 ms after it (the muscles tensioned) the
/// muscles pull the still arm with almost no torque, 2.5 s after it with the whole spring
/// K·Δα.
pub fn a_joint_target_is_approached_from_where_the_arm_is() -> CheckResult {
    let mut c = armed(MOVE)?;
    let torque_at = |c: &mut Controller, from: u32, to: u32| {
        let mut out = c.step(&held(c, [0.0; 2], c.pressure_bar, from));
        for k in from + 1..to {
            c.heartbeat();
            out = c.step(&held(c, [0.0; 2], out.pressure_bar, k));
        }
        let m = c.model();
        m.direct([0.0; 2], m.joint_pressures_bar(out.pressure_bar))[0].0
    };
    let early = torque_at(&mut c, 0, 100);
    holds(
        "100 ms: less than 2 N·m (a step: 16 N·m)",
        early.abs() < 2.0,
    )?;
    let late = torque_at(&mut c, 100, 2500);
    holds("2.5 s: the spring's torque", late.abs() > 10.0)
}

/// The shaped reference: never faster than its rate, never accelerating beyond its
/// limit, ending on the target without passing it.
pub fn the_joint_reference_is_rate_and_acceleration_limited() -> CheckResult {
    let mut s = JointShaper::new();
    let range = [(-0.5, 0.5); 2];
    let dt = 0.001;
    let target = [0.3, -0.2];
    let (mut last, _, _) = s.step(target, [0.0; 2], [0.0; 2], range, dt);
    // the first step started from rest at 0
    let mut last_rate = [last[0] / dt, last[1] / dt];
    for k in 0..5000u32 {
        let (a, _, _) = s.step(target, [0.0; 2], [0.0; 2], range, dt);
        for j in 0..2 {
            let rate = (a[j] - last[j]) / dt;
            let fail = |what| Failure {
                what,
                got: (rate - last_rate[j]) as f64,
                expected: 0.0,
                tolerance: 0.0,
                index: k,
            };
            if rate.abs() > JOINT_TARGET_RATE_MAX_RAD_S * 1.001 {
                return Err(fail("rate within its limit"));
            }
            // the landing step drops what little rate is left (< 0.01 rad/s) at once
            let landing = if a[j] == target[j] { 0.01 } else { 0.0 };
            let dv = JOINT_TARGET_ACCEL_MAX_RAD_S2 * dt * 1.01 + 1e-4 + landing;
            if (rate - last_rate[j]).abs() > dv {
                return Err(fail("acceleration within its limit"));
            }
            if (a[j] - target[j]) * target[j].signum() > 1e-6 {
                return Err(fail("never past the target"));
            }
            last_rate[j] = rate;
        }
        last = a;
    }
    holds("on the target", last == target)
}

/// A joint target at the hard stop is kept the soft margin inside it, and flagged.
pub fn a_joint_target_stays_inside_the_soft_limits() -> CheckResult {
    let p = RobotModel::<f32>::thesis().params;
    let max = p.joints[0].alpha_max_rad;
    let mut c = armed(Mode::Joint {
        alpha_rad: [max, 0.0],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [60.0, 27.0],
    })?;
    let out = c.step(&at([0.0; 2], 0));
    holds("flagged", out.limited.contains(Limited::TARGET))?;
    let mut s = JointShaper::new();
    let range = [(-max + SOFT_LIMIT_RAD, max - SOFT_LIMIT_RAD); 2];
    let mut a = [0.0; 2];
    for _ in 0..20_000 {
        a = s.step([max, -max], [0.0; 2], [0.0; 2], range, 0.001).0;
    }
    holds(
        "the reference ends inside the soft limits",
        a == [max - SOFT_LIMIT_RAD, -max + SOFT_LIMIT_RAD],
    )
}

/// In every mode the arm moving at 6 rad/s (below the encoder-jump speed) faults and
/// vents within 50 ms; in pressures mode 2 rad/s does not.
pub fn the_joint_speed_is_supervised_in_every_mode() -> CheckResult {
    let modes = [
        Mode::Pressures {
            pressure_bar: [2.0; 4],
        },
        Mode::Joint {
            alpha_rad: [0.0; 2],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [60.0, 27.0],
        },
        Mode::Force {
            force_n: [0.0; 2],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
        },
        Mode::ForceClosedLoop {
            force_n: [0.0; 2],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
            gain_scale: 1.0,
        },
        Mode::Impedance {
            target_user_m: [0.0; 2],
            stiffness_n_per_m: [100.0; 2],
            damping_n_s_per_m: [10.0; 2],
            mass_kg: [0.0; 2],
        },
    ];
    for (i, mode) in modes.into_iter().enumerate() {
        let mut c = armed(mode)?;
        let mut out = c.step(&at([0.0; 2], 0));
        let mut k = 0;
        while out.state == State::Armed && k < 50 {
            k += 1;
            out = c.step(&at([0.006 * k as f32, 0.0], k));
        }
        let caught = out.faults.contains(Faults::CONTROL_UNSTABLE)
            && out.current_ma.iter().all(|&i| i == VENT_CURRENT_MA);
        if !caught {
            return Err(Failure {
                what: "6 rad/s faults and vents within 50 ms",
                got: out.faults.0 as f64,
                expected: Faults::CONTROL_UNSTABLE.0 as f64,
                tolerance: 0.0,
                index: i as u32,
            });
        }
    }
    let mut c = armed(modes[0])?;
    let mut out = c.step(&at([0.0; 2], 0));
    for k in 1..200u32 {
        c.heartbeat();
        out = c.step(&at([0.002 * k as f32, 0.0], k));
    }
    holds("2 rad/s is motion, not a fault", out.state == State::Armed)
}

/// The pressures mode refuses a joint's pair beyond the imbalance or co-contraction
/// ceiling; within them it is accepted.
pub fn pressures_mode_bounds_co_contraction_and_imbalance() -> CheckResult {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    // channels 0 and 1 drive joint 1, 2 and 3 joint 2
    for bad in [[4.0; 4], [3.0, 0.5, 1.0, 1.0], [1.0, 1.0, 0.5, 3.0]] {
        holds(
            "refused",
            c.set_mode(Mode::Pressures { pressure_bar: bad }) == Err(Reject::OutOfRange),
        )?;
    }
    holds("nothing changed", c.mode() == Mode::Idle)?;
    holds(
        "within the ceilings",
        c.set_mode(Mode::Pressures {
            pressure_bar: [3.0, 1.0, 3.5, 3.5],
        })
        .is_ok(),
    )
}

/// In impedance mode a stuck encoder blinds the speed guard and the released-handle
/// detector: the handle force changing by 20 N while an angle stays bit-identical faults
/// and vents; the same force change with the angle following does not.
pub fn a_stuck_encoder_faults_in_impedance_mode() -> CheckResult {
    let mode = Mode::Impedance {
        target_user_m: [0.0; 2],
        stiffness_n_per_m: [0.0; 2],
        damping_n_s_per_m: [0.0; 2],
        mass_kg: [0.0; 2],
    };
    let push = |k: u32| [0.5 + 20.0 * (k as f32 / 500.0).min(1.0), -0.3];
    // followed: the handle gives way as the force grows
    let mut c = armed(mode)?;
    for k in 0..600u32 {
        c.heartbeat();
        let a = 1e-4 * (k as f32 / 5.0).min(100.0);
        c.step(&Sensors {
            alpha_rad: [a, -a],
            force_sensor_n: push(k),
        });
    }
    holds(
        "a moving handle is no stuck encoder",
        !c.faults().contains(Faults::STATIC_IMBALANCE),
    )?;
    let mut c = armed(mode)?;
    let mut out = c.step(&at([0.0; 2], 0));
    for k in 1..600u32 {
        c.heartbeat();
        out = c.step(&Sensors {
            alpha_rad: [0.0; 2],
            force_sensor_n: push(k),
        });
        if out.state != State::Armed {
            break;
        }
    }
    holds(
        "stuck: faulted",
        out.faults.contains(Faults::STATIC_IMBALANCE),
    )?;
    holds(
        "vented",
        out.current_ma.iter().all(|&i| i == VENT_CURRENT_MA),
    )
}

/// In joint mode a stuck encoder hides the arm's motion from the speed guard. A move of
/// 0.12 rad at 120 N·m/rad changes the muscles' torque at the stuck angle by ≈ 14 N·m with
/// nothing holding the handle: faulted within 6 s (at 0.2 rad the balance check's
/// tolerance, 16 + 116 · 0.2 N·m, is above that change, so it alone never judges). The same
/// move with the angle following is no fault.
pub fn a_stuck_encoder_faults_in_joint_mode() -> CheckResult {
    let from = [0.2, 0.0];
    let mode = Mode::Joint {
        alpha_rad: [0.32, 0.0],
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [120.0, 40.0],
    };
    let (faults, _) = stuck_or_following(mode, from, true)?;
    holds("an arm that follows is no stuck encoder", faults.is_none())?;
    let (faults, current_ma) = stuck_or_following(mode, from, false)?;
    holds("stuck: faulted", faults.contains(Faults::STATIC_IMBALANCE))?;
    holds("vented", current_ma.iter().all(|&i| i == VENT_CURRENT_MA))
}

/// The stuck encoder's run in `mode`: armed at `from`, the angle following a free arm's
/// path (`follow`) or bit-identical (stuck), nothing holding the handle, 6 s.
fn stuck_or_following(
    mode: Mode,
    from: [f32; 2],
    follow: bool,
) -> Result<(Faults, [f32; 4]), Failure> {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    c.step(&at(from, 0));
    holds("armed", c.arm().is_ok())?;
    holds("mode accepted", c.set_mode(mode).is_ok())?;
    let mut out = c.step(&at(from, 0));
    for k in 1..6000u32 {
        c.heartbeat();
        // a free arm goes where the muscles pull it: 0.12 rad in ≈ 1.2 s
        let a = if follow {
            from[0] + 0.12 * (k as f32 / 1200.0).min(1.0)
        } else {
            from[0]
        };
        out = c.step(&at([a, from[1]], k));
        if out.state != State::Armed {
            break;
        }
    }
    Ok((out.faults, out.current_ma))
}

/// Pressures mode: joint 1's muscles at 2.9 and 2.1 bar turn a free arm by ≈ 0.15 rad; an
/// encoder that does not see it faults, one that does is no fault.
pub fn a_stuck_encoder_faults_in_pressures_mode() -> CheckResult {
    let mode = Mode::Pressures {
        pressure_bar: [2.1, 2.9, 2.5, 2.5],
    };
    let (faults, _) = stuck_or_following(mode, [0.0; 2], true)?;
    holds("an arm that follows is no stuck encoder", faults.is_none())?;
    let (faults, current_ma) = stuck_or_following(mode, [0.0; 2], false)?;
    holds("stuck: faulted", faults.contains(Faults::STATIC_IMBALANCE))?;
    holds("vented", current_ma.iter().all(|&i| i == VENT_CURRENT_MA))
}

/// Open-loop force mode at joint 1's 0.2 rad: 20 N along x asked of a free handle turns the
/// arm; an encoder that does not see it faults (the pressures follow the stuck angle, the
/// load cell reads nothing), one that does is no fault. At 0.2 rad the balance check's
/// bound (16 + 116 · 0.2 N·m) is above the ≈ 14 N·m asked: it alone never judges.
pub fn a_stuck_encoder_faults_in_open_loop_force_mode() -> CheckResult {
    let mode = Mode::Force {
        force_n: [20.0, 0.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: false,
    };
    let (faults, _) = stuck_or_following(mode, [0.2, 0.0], true)?;
    holds("an arm that follows is no stuck encoder", faults.is_none())?;
    let (faults, current_ma) = stuck_or_following(mode, [0.2, 0.0], false)?;
    holds("stuck: faulted", faults.contains(Faults::STATIC_IMBALANCE))?;
    holds("vented", current_ma.iter().all(|&i| i == VENT_CURRENT_MA))
}

/// Arming (and any mode after idle) tensions the muscles at the angle the arm is at and
/// ends on the mode's own command: a mode that holds the arm there asks for no torque at
/// any instant of the ramp (once the cables are taut the model's torque is the arm's;
/// before, slack cables pull nothing), which takes [`ARM_RAMP_S`] instead of the slew
/// limit's 50 ms; a pressures target is reached exactly as the ramp ends.
pub fn the_muscles_are_tensioned_without_moving_the_arm() -> CheckResult {
    let alpha = [0.2, -0.1];
    let hold = Mode::Joint {
        alpha_rad: alpha,
        torque_nm: [0.0; 2],
        stiffness_nm_per_rad: [95.0, 40.0],
    };
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    holds("mode", c.set_mode(hold).is_ok())?;
    let mut peak_nm: f32 = 0.0;
    let mut at_50ms = [0.0; 4];
    let mut out = c.step(&at(alpha, 0));
    for k in 1..RAMP_PERIODS {
        c.heartbeat();
        out = c.step(&at(alpha, k));
        if k > RAMP_PERIODS / 2 {
            let m = c.model();
            let t = m.direct(alpha, m.joint_pressures_bar(out.pressure_bar));
            peak_nm = peak_nm.max(t[0].0.abs()).max(t[1].0.abs());
        }
        if k == 50 {
            at_50ms = out.pressure_bar;
        }
    }
    holds("no torque at the arm's angle (< 0.1 N·m)", peak_nm < 0.1)?;
    let end = out.pressure_bar;
    holds(
        "gradual: at 50 ms less than a tenth of the way",
        (0..4).all(|ch| at_50ms[ch] < 0.1 + (end[ch] - 0.1) / 10.0),
    )?;
    holds("tensioned", end.iter().all(|&p| p > 1.0))?;
    c.heartbeat();
    let next = c.step(&at(alpha, RAMP_PERIODS));
    holds(
        "the ramp ends on the mode's command",
        (0..4).all(|ch| (next.pressure_bar[ch] - end[ch]).abs() < 1e-3),
    )?;
    let target = [2.5, 1.5, 2.0, 2.0];
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    let pressures = Mode::Pressures {
        pressure_bar: target,
    };
    holds("pressures", c.set_mode(pressures).is_ok())?;
    for k in 0..RAMP_PERIODS {
        c.heartbeat();
        out = c.step(&at(alpha, k));
    }
    holds(
        "a pressures target reached as the ramp ends",
        (0..4).all(|ch| (out.pressure_bar[ch] - target[ch]).abs() < 1e-4),
    )
}

pam_model::register_checks!(
    a_joint_target_is_approached_from_where_the_arm_is,
    the_joint_reference_is_rate_and_acceleration_limited,
    a_joint_target_stays_inside_the_soft_limits,
    the_joint_speed_is_supervised_in_every_mode,
    pressures_mode_bounds_co_contraction_and_imbalance,
    a_stuck_encoder_faults_in_impedance_mode,
    a_stuck_encoder_faults_in_joint_mode,
    a_stuck_encoder_faults_in_pressures_mode,
    a_stuck_encoder_faults_in_open_loop_force_mode,
    the_muscles_are_tensioned_without_moving_the_arm,
);
