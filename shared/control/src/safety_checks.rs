//! Checks of the limits a host cannot move: the fixed safe state, the link-loss ramp, the
//! ceilings of the safety limits, tightening only while armed, the closed loop's gain
//! bound, its slow-oscillation detector and its load-cell plausibility. Run by `cargo test`
//! on the host and on the Cortex-M4F under QEMU (`qemu-tests/`).

use crate::force_loop::{ForceLoop, ForceLoopConfig, MAX_GAIN_SCALE};
use crate::safety::ceiling;
use crate::supervisor::{Controller, Faults, Mode, Reject, SafetyConfig, Sensors, State};
use crate::VENT_CURRENT_MA;
use pam_model::checks::holds_that as holds;
use pam_model::{RobotModel, RobotParams};

pub use pam_model::checks::{Check, CheckResult};

fn sensors(k: u32) -> Sensors {
    let d = if k.is_multiple_of(2) { 0.01 } else { -0.01 };
    Sensors {
        alpha_rad: [0.0, 0.0],
        force_sensor_n: [0.5 + d, -0.3],
    }
}

fn vented(c: &[f32; 4]) -> bool {
    c.iter().all(|&i| i == VENT_CURRENT_MA)
}

/// A pressure law that starts at 12 mA (and a least pressure of 1 bar) changes neither
/// boot, disarm, nor a fault: every output is the fixed vent current.
pub fn the_safe_state_is_a_constant_whatever_the_parameters() -> CheckResult {
    let mut p = RobotParams::<f32>::thesis();
    p.ip.current_min_ma = 12.0;
    p.pressure.min_bar = 1.0;
    let mut c = Controller::new(RobotModel::new(p), SafetyConfig::default_1khz());
    holds("boot", vented(&c.step(&sensors(0)).current_ma))?;
    holds("armed", c.arm().is_ok())?;
    let pressures = Mode::Pressures {
        pressure_bar: [2.0; 4],
    };
    holds("mode", c.set_mode(pressures).is_ok())?;
    for k in 1..100 {
        c.heartbeat();
        c.step(&sensors(k));
    }
    c.disarm();
    holds("disarm", vented(&c.step(&sensors(100)).current_ma))?;
    c.raise(Faults::OUTPUT_OPEN_LOOP);
    let out = c.step(&sensors(101));
    holds("fault", vented(&out.current_ma) && c.outputs_vented())
}

/// The link-loss ramp ends at the vent (not at the modes' least pressure) within its
/// ceiling, even under a configuration that asks for a slower ramp.
pub fn link_loss_ramps_to_the_vent_within_its_ceiling() -> CheckResult {
    let mut p = RobotParams::<f32>::thesis();
    p.pressure.min_bar = 1.0;
    let mut slow = SafetyConfig::default_1khz();
    slow.timeout_ramp_bar_per_s = 1e-6;
    holds(
        "a slow ramp is refused",
        slow.validate() == Err(Reject::OutOfRange),
    )?;
    // a controller built around it (the device never does) still ramps at the floor rate
    let mut c = Controller::new(RobotModel::new(p), slow);
    holds("armed", c.arm().is_ok())?;
    let mode = Mode::Pressures {
        pressure_bar: [3.5; 4],
    };
    holds("mode", c.set_mode(mode).is_ok())?;
    for k in 0..300 {
        c.heartbeat();
        c.step(&sensors(k));
    }
    // silence: 100 ms to the timeout, then at most 1 s of ramp
    let mut out = c.step(&sensors(300));
    let mut k = 0;
    while !vented(&out.current_ma) && k < 2000 {
        k += 1;
        out = c.step(&sensors(301 + k));
    }
    holds("timed out", c.faults() == Faults::COMMAND_TIMEOUT)?;
    holds(
        "at the vent within the timeout and the ramp's ceiling",
        vented(&out.current_ma) && (k as f32) * 0.001 <= 0.1 + ceiling::TIMEOUT_RAMP_MAX_S,
    )?;
    holds(
        "at the converters' floor, below the modes' least pressure",
        out.pressure_bar
            .iter()
            .all(|&b| b == c.model().params.ip.output_min_bar),
    )
}

/// Every limit has a ceiling: beyond it, or off (zero, infinite, NaN), it is refused.
pub fn every_safety_limit_has_a_ceiling() -> CheckResult {
    let d = SafetyConfig::default_1khz();
    holds("the defaults pass", d.validate().is_ok())?;
    let beyond: [fn(&mut SafetyConfig); 14] = [
        |s| s.angle_margin_rad = f32::INFINITY,
        |s| s.angle_margin_rad = 2.0 * ceiling::ANGLE_MARGIN_MAX_RAD,
        |s| s.command_timeout_s = 2.0 * ceiling::COMMAND_TIMEOUT_MAX_S,
        |s| s.slew_bar_per_s = 2.0 * ceiling::SLEW_MAX_BAR_PER_S,
        |s| s.timeout_ramp_bar_per_s = 0.5 * ceiling::TIMEOUT_RAMP_MIN_BAR_PER_S,
        |s| s.timeout_ramp_bar_per_s = f32::INFINITY,
        |s| s.max_joint_speed_rad_s = 2.0 * ceiling::JOINT_SPEED_MAX_RAD_S,
        |s| s.loadcell_limit_n = 2.0 * ceiling::LOADCELL_LIMIT_MAX_N,
        |s| s.loadcell_stuck_samples = 2 * ceiling::LOADCELL_STUCK_SAMPLES_MAX,
        |s| s.max_request_torque_nm = 2.0 * ceiling::REQUEST_TORQUE_MAX_NM,
        |s| s.max_request_stiffness_nm_per_rad = 2.0 * ceiling::REQUEST_STIFFNESS_MAX_NM_PER_RAD,
        |s| s.max_request_force_n = 2.0 * ceiling::REQUEST_FORCE_MAX_N,
        |s| s.max_request_force_n = f32::NAN,
        |s| s.period_s = 2.0 * ceiling::PERIOD_MAX_S,
    ];
    for (i, set) in beyond.iter().enumerate() {
        let mut s = d;
        set(&mut s);
        if s.validate() != Err(Reject::OutOfRange) {
            return Err(pam_model::checks::Failure {
                what: "a limit beyond its ceiling is refused",
                got: 0.0,
                expected: 1.0,
                tolerance: 0.0,
                index: i as u32,
            });
        }
    }
    Ok(())
}

/// Armed, a limit may be tightened but never loosened, not even back to where it was.
pub fn while_armed_the_limits_only_tighten() -> CheckResult {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    let d = SafetyConfig::default_1khz();
    let mut tighter = d;
    tighter.angle_margin_rad = 0.03;
    tighter.max_request_force_n = 50.0;
    holds("tightened", c.set_safety(tighter).is_ok())?;
    holds(
        "loosened back refused",
        c.set_safety(d) == Err(Reject::WrongState),
    )?;
    let mut faster_vent = tighter;
    faster_vent.timeout_ramp_bar_per_s = 2.0 * d.timeout_ramp_bar_per_s;
    holds("a faster ramp tightens", c.set_safety(faster_vent).is_ok())?;
    holds(
        "and a slower one again loosens",
        c.set_safety(tighter) == Err(Reject::WrongState),
    )?;
    let mut longer = faster_vent;
    longer.command_timeout_s = 0.5;
    holds(
        "a longer timeout refused",
        c.set_safety(longer) == Err(Reject::WrongState),
    )?;
    holds("unchanged", c.safety().angle_margin_rad == 0.03)?;
    c.disarm();
    holds("disarmed, any valid limits", c.set_safety(d).is_ok())
}

/// The closed loop's gain scale is bounded by the design's margin.
pub fn the_gain_scale_is_bounded_by_the_margin() -> CheckResult {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    let closed = |gain_scale: f32| Mode::ForceClosedLoop {
        force_n: [5.0, 0.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: false,
        gain_scale,
    };
    holds("the ceiling is the margin", MAX_GAIN_SCALE <= 3.0)?;
    holds("at the ceiling", c.set_mode(closed(MAX_GAIN_SCALE)).is_ok())?;
    holds(
        "twenty times refused",
        c.set_mode(closed(20.0)) == Err(Reject::OutOfRange),
    )
}

/// A ±20 N limit cycle at 1 Hz (and at 0.5 Hz) trips the guard; a steady error of the
/// same size does not trip it as an oscillation.
pub fn a_slow_limit_cycle_trips_the_guard() -> CheckResult {
    let cfg = ForceLoopConfig::designed();
    let ip = RobotParams::<f32>::thesis().ip;
    for (i, hz) in [1.0f32, 2.0, 0.5].into_iter().enumerate() {
        let mut fl = ForceLoop::new();
        let mut tripped = None;
        let period_ms = (1000.0 / hz) as u32;
        for k in 0..12_000u32 {
            // a triangle wave (no libm needed)
            let phase = (k % period_ms) as f32 / period_ms as f32;
            let tri = 4.0 * (phase - 0.5).abs() - 1.0;
            let measured = [10.0 + 20.0 * tri, 0.0];
            let out = fl.step(&cfg, &ip, [10.0, 0.0], measured, 1.0, false, 0.001);
            if out.trip.is_some() {
                tripped = Some(k);
                break;
            }
        }
        if tripped.is_none_or(|k| k >= 8_000) {
            return Err(pam_model::checks::Failure {
                what: "a ±20 N limit cycle trips the guard within 8 s",
                got: tripped.map_or(-1.0, |k| k as f64),
                expected: 8000.0,
                tolerance: 0.0,
                index: i as u32,
            });
        }
    }
    Ok(())
}

/// A dead load cell that still dithers, in closed-loop force mode: the loop winds up a
/// force the cell never reads; the plausibility check faults it and vents.
pub fn a_dead_dithering_load_cell_faults_in_closed_loop() -> CheckResult {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    let mode = Mode::ForceClosedLoop {
        force_n: [5.0, 0.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: false,
        gain_scale: 1.0,
    };
    holds("mode", c.set_mode(mode).is_ok())?;
    let mut faulted = None;
    for k in 0..5000u32 {
        c.heartbeat();
        let d = if k.is_multiple_of(2) { 0.05 } else { -0.05 };
        let out = c.step(&Sensors {
            alpha_rad: [0.0; 2],
            force_sensor_n: [d, -d],
        });
        if out.state == State::Faulted {
            faulted = Some(out);
            break;
        }
    }
    holds("faulted", faulted.is_some())?;
    let out = faulted.unwrap_or_else(|| c.step(&sensors(0)));
    holds(
        "as a load-cell fault",
        out.faults.contains(Faults::LOADCELL_STUCK),
    )?;
    holds("vented", vented(&out.current_ma))
}

/// A configuration change is not a command: a host that keeps sending (tighter) limits while
/// armed does not keep the arm alive. The timeout fires as if nothing had been sent.
pub fn a_limits_change_does_not_feed_the_command_timeout() -> CheckResult {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    let timeout_periods = (c.safety().command_timeout_s / c.safety().period_s) as u32;
    let mut tighter = SafetyConfig::default_1khz();
    let mut timed_out_at = None;
    for k in 0..3 * timeout_periods {
        if k % 10 == 0 {
            tighter.max_request_force_n *= 0.99;
            holds("the tighter limits accepted", c.set_safety(tighter).is_ok())?;
        }
        let out = c.step(&sensors(k));
        if out.faults.contains(Faults::COMMAND_TIMEOUT) {
            timed_out_at = Some(k);
            break;
        }
    }
    holds(
        "timed out one timeout after arming",
        timed_out_at.is_some_and(|k| k <= timeout_periods + 2),
    )
}

/// Equal pressures in a joint's two muscles hold the arm at the neutral pose. A home taken
/// with joint 2 17° from it (the zero 0.3 rad off) puts the arm, once it rests there with
/// the muscles at 2.5 bar and a free handle, 0.3 rad from the model's equilibrium: the home
/// is refused (`STATIC_IMBALANCE`, vented). The right home rests on the equilibrium and is
/// confirmed. Neither the balance check (at 0.3 rad its bound is 8 + 24 · 0.3 N·m) nor the
/// unseen motion (under 10 N·m of change) judges this rest.
pub fn a_home_far_from_the_pressures_equilibrium_is_refused() -> CheckResult {
    let run = |offset_rad: f32| {
        let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
        let ok = c.judge_home().is_ok()
            && c.arm().is_ok()
            && c.set_mode(Mode::Pressures {
                pressure_bar: [2.5; 4],
            })
            .is_ok();
        let at = |k: u32| {
            let mut s = sensors(k);
            s.alpha_rad[1] = offset_rad;
            s
        };
        let mut out = c.step(&at(0));
        for k in 1..5000 {
            c.heartbeat();
            out = c.step(&at(k));
            if out.state != State::Armed {
                break;
            }
        }
        (ok, out, c.home_check().refused(), c.home_check().pending())
    };
    let (ok, out, refused, pending) = run(0.0);
    holds("home, arm, pressures accepted", ok)?;
    holds("a right home: no fault", out.faults.is_none())?;
    holds("a right home: confirmed", !refused && !pending)?;
    let (_, out, refused, _) = run(0.3);
    holds("a wrong home: refused", refused)?;
    holds(
        "a wrong home: STATIC_IMBALANCE",
        out.faults == Faults::STATIC_IMBALANCE,
    )?;
    holds("a wrong home: vented", vented(&out.current_ma))?;
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("armed", c.arm().is_ok())?;
    holds(
        "a home is refused while armed",
        c.judge_home() == Err(Reject::WrongState),
    )
}

/// With the muscles vented (idle) or a handle held, a rest says nothing of the home: it
/// waits, and no fault comes of it.
pub fn a_rest_that_cannot_judge_the_home_waits() -> CheckResult {
    let mut c = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    holds("home", c.judge_home().is_ok())?;
    holds("armed", c.arm().is_ok())?;
    // vented, the arm anywhere: 20° on joint 1
    let at = |k: u32| {
        let mut s = sensors(k);
        s.alpha_rad[0] = 0.35;
        s
    };
    let mut out = c.step(&at(0));
    for k in 1..4000 {
        c.heartbeat();
        out = c.step(&at(k));
    }
    holds("idle: no fault", out.faults.is_none())?;
    holds("idle: still waiting", c.home_check().pending())
}

pam_model::register_checks!(
    the_safe_state_is_a_constant_whatever_the_parameters,
    a_limits_change_does_not_feed_the_command_timeout,
    link_loss_ramps_to_the_vent_within_its_ceiling,
    every_safety_limit_has_a_ceiling,
    while_armed_the_limits_only_tighten,
    the_gain_scale_is_bounded_by_the_margin,
    a_slow_limit_cycle_trips_the_guard,
    a_dead_dithering_load_cell_faults_in_closed_loop,
    a_home_far_from_the_pressures_equilibrium_is_refused,
    a_rest_that_cannot_judge_the_home_waits,
);
