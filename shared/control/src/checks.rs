//! Checks of the state machine and every fault path, run by `cargo test` on the host and
//! on the Cortex-M4F under QEMU (`qemu-tests/`).

use crate::supervisor::*;
use pam_model::{Limited, RobotModel};

pub use pam_model::checks::{Check, CheckResult, Failure};

use pam_model::checks::{holds_that as holds, near_f32 as near};

fn controller() -> Controller {
    Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz())
}

/// Neutral pose with a little load-cell dither, as a live sensor has.
fn sensors(k: u32) -> Sensors {
    let d = if k.is_multiple_of(2) { 0.01 } else { -0.01 };
    Sensors {
        alpha_rad: [0.0, 0.0],
        force_sensor_n: [0.5 + d, -0.3],
    }
}

fn run_steps(c: &mut Controller, n: u32, start: u32) -> StepOutput {
    let mut out = c.step(&sensors(start));
    for k in 1..n {
        c.heartbeat();
        out = c.step(&sensors(start + k));
    }
    out
}

/// The tensioning ramp's periods at 1 kHz, and one.
const RAMP_PERIODS: u32 = (crate::motion::ARM_RAMP_S * 1000.0) as u32 + 1;

fn is_vent(out: &StepOutput) -> bool {
    out.current_ma.iter().all(|&i| i == 4.0) && out.pressure_bar.iter().all(|&p| p == 0.1)
}

pub fn boots_disarmed_and_vented() -> CheckResult {
    let mut c = controller();
    holds("boots disarmed", c.state() == State::Disarmed)?;
    let out = c.step(&sensors(0));
    holds("vented at boot", is_vent(&out))
}

pub fn pressures_mode_slews_to_target() -> CheckResult {
    let mut c = controller();
    holds("arm", c.arm().is_ok())?;
    let target = [2.3, 2.3, 3.0, 1.0];
    holds(
        "mode accepted",
        c.set_mode(Mode::Pressures {
            pressure_bar: target,
        })
        .is_ok(),
    )?;
    // the tensioning ramp ends on the target: a new target after it is slew-limited
    let ramp = RAMP_PERIODS;
    let tensioned = run_steps(&mut c, ramp, 0);
    near(
        "tensioned to the target",
        tensioned.pressure_bar[2],
        3.0,
        1e-4,
    )?;
    let target = [2.3, 2.3, 2.0, 2.0];
    holds(
        "new target accepted",
        c.set_mode(Mode::Pressures {
            pressure_bar: target,
        })
        .is_ok(),
    )?;
    let first = c.step(&sensors(ramp));
    // 50 bar/s at 1 ms: at most 0.05 bar per step toward the target
    near("first step slew-limited", first.pressure_bar[2], 2.95, 1e-5)?;
    holds("slew flagged", first.output_limited)?;
    let out = run_steps(&mut c, 300, ramp + 1);
    for ch in 0..4 {
        near("target reached", out.pressure_bar[ch], target[ch], 1e-4)?;
    }
    near(
        "current for 2.3 bar",
        out.current_ma[0],
        (2.3 + 1.63) / 0.32667,
        1e-3,
    )?;
    holds(
        "still armed",
        out.state == State::Armed && out.faults.is_none(),
    )
}

pub fn out_of_range_command_refused_and_nothing_changes() -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    c.set_mode(Mode::Pressures {
        pressure_bar: [1.0; 4],
    })
    .ok();
    let before = c.mode();
    let bad = [
        Mode::Pressures {
            pressure_bar: [1.0, 1.0, 6.0, 1.0],
        },
        Mode::Pressures {
            pressure_bar: [1.0, f32::NAN, 1.0, 1.0],
        },
        Mode::Joint {
            alpha_rad: [0.0, 1.0],
            torque_nm: [0.0; 2],
            stiffness_nm_per_rad: [60.0, 27.0],
        },
        Mode::Joint {
            alpha_rad: [0.0; 2],
            torque_nm: [1e6, 0.0],
            stiffness_nm_per_rad: [60.0, 27.0],
        },
        Mode::Force {
            force_n: [0.0, f32::INFINITY],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: false,
        },
        Mode::Force {
            force_n: [0.0, 0.0],
            stiffness_nm_per_rad: [-1.0, 27.0],
            feed_forward: false,
        },
    ];
    for m in bad {
        holds("refused", c.set_mode(m) == Err(Reject::OutOfRange))?;
        holds("mode unchanged", c.mode() == before)?;
    }
    let mut s = *c.safety();
    s.command_timeout_s = f32::NAN;
    holds("safety config with NaN refused", c.set_safety(s).is_err())?;
    s.command_timeout_s = 0.1;
    s.period_s = 0.02;
    holds("period beyond 10 ms refused", c.set_safety(s).is_err())?;
    holds("safety unchanged", c.safety().period_s == 0.001)
}

pub fn non_finite_sensor_faults_vents_and_latches() -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    c.set_mode(Mode::Pressures {
        pressure_bar: [3.0; 4],
    })
    .ok();
    run_steps(&mut c, 100, 0);
    let bad = Sensors {
        alpha_rad: [f32::NAN, 0.0],
        force_sensor_n: [0.0, 0.0],
    };
    let out = c.step(&bad);
    holds(
        "NaN faults",
        out.faults.contains(Faults::NON_FINITE) && out.state == State::Faulted,
    )?;
    holds("vented at once", is_vent(&out))?;
    holds(
        "clear refused while NaN persists",
        c.clear_faults(&bad) == Err(Reject::FaultStillPresent),
    )?;
    let out = run_steps(&mut c, 10, 200);
    holds(
        "fault latched after sensors recover",
        out.state == State::Faulted && is_vent(&out),
    )?;
    holds(
        "arm refused while faulted",
        c.arm() == Err(Reject::WrongState),
    )?;
    holds("clear accepted", c.clear_faults(&sensors(0)).is_ok())?;
    holds(
        "disarmed after clear",
        c.state() == State::Disarmed && c.faults().is_none(),
    )?;
    holds("re-arm", c.arm().is_ok())
}

fn faults_once(sensor_seq: &[Sensors], expect: Faults) -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    c.set_mode(Mode::Pressures {
        pressure_bar: [2.0; 4],
    })
    .ok();
    run_steps(&mut c, 50, 0);
    let mut out = None;
    for s in sensor_seq {
        c.heartbeat();
        out = Some(c.step(s));
    }
    let out = out.unwrap_or_else(|| c.step(&sensors(0)));
    holds("expected fault bit", out.faults.contains(expect))?;
    holds(
        "faulted and vented",
        out.state == State::Faulted && is_vent(&out),
    )
}

pub fn angle_out_of_range_faults() -> CheckResult {
    faults_once(
        &[
            Sensors {
                alpha_rad: [0.0, 0.0],
                force_sensor_n: [0.1, 0.2],
            },
            Sensors {
                alpha_rad: [0.0, 0.9],
                force_sensor_n: [0.2, 0.1],
            },
        ],
        Faults::ANGLE_OUT_OF_RANGE,
    )
}

pub fn encoder_jump_faults() -> CheckResult {
    // 0.1 rad in 1 ms is 100 rad/s: not a human arm
    faults_once(
        &[Sensors {
            alpha_rad: [0.1, 0.0],
            force_sensor_n: [0.1, 0.2],
        }],
        Faults::ENCODER_JUMP,
    )
}

pub fn loadcell_saturation_faults() -> CheckResult {
    faults_once(
        &[Sensors {
            alpha_rad: [0.0, 0.0],
            force_sensor_n: [250.0, 0.0],
        }],
        Faults::LOADCELL_SATURATED,
    )
}

/// Each channel faults at its amplifier's full scale (X ±111 N, Z ±167 N with the thesis's
/// gains), well inside the 190 N force limit for X; 1 % below it is no fault. With a tare
/// offset the same volts are a different force: the limit follows the calibration.
pub fn loadcell_amplifier_full_scale_faults() -> CheckResult {
    let full_scale_n = [111.2, 166.7]; // 10 V × 11.11 N/V, 10 V × 16.67 N/V, rounded up
    for ch in 0..2 {
        for sign in [1.0f32, -1.0] {
            let mut below = [0.1, 0.2];
            below[ch] = sign * 0.99 * full_scale_n[ch];
            let mut c = controller();
            c.arm().ok();
            for k in 0..5 {
                c.heartbeat();
                below[1 - ch] += if k % 2 == 0 { 0.01 } else { -0.01 };
                let out = c.step(&Sensors {
                    alpha_rad: [0.0, 0.0],
                    force_sensor_n: below,
                });
                holds("1 % below full scale is no fault", out.faults.is_none())?;
            }
            let mut at = [0.1, 0.2];
            at[ch] = sign * full_scale_n[ch];
            faults_once(
                &[Sensors {
                    alpha_rad: [0.0, 0.0],
                    force_sensor_n: at,
                }],
                Faults::LOADCELL_SATURATED,
            )?;
        }
    }
    // tared at +5 V on X: +5 V more (55.6 N) is full scale, −100 N (−4 V) is not
    let mut c = controller();
    let mut cell = c.model().params.load_cell;
    cell.tare([5.0, 0.0]);
    c.set_load_cell(cell);
    c.arm().ok();
    c.heartbeat();
    let out = c.step(&Sensors {
        alpha_rad: [0.0, 0.0],
        force_sensor_n: [-100.0, 0.2],
    });
    holds(
        "tared: -100 N is inside the amplifier range",
        out.faults.is_none(),
    )?;
    c.heartbeat();
    let out = c.step(&Sensors {
        alpha_rad: [0.0, 0.0],
        force_sensor_n: [55.6, 0.2],
    });
    holds(
        "tared: +5 V more is full scale",
        out.faults.contains(Faults::LOADCELL_SATURATED) && is_vent(&out),
    )?;
    holds(
        "clear refused while the channel is at full scale",
        c.clear_faults(&Sensors {
            alpha_rad: [0.0, 0.0],
            force_sensor_n: [55.6, 0.2],
        }) == Err(Reject::FaultStillPresent),
    )
}

pub fn loadcell_stuck_faults() -> CheckResult {
    let stuck = [Sensors {
        alpha_rad: [0.0, 0.0],
        force_sensor_n: [1.25, -0.5],
    }; 501];
    faults_once(&stuck, Faults::LOADCELL_STUCK)?;
    // one sample short of the limit is not a fault
    let mut c = controller();
    c.arm().ok();
    for s in stuck.iter().take(499) {
        c.heartbeat();
        let out = c.step(s);
        holds("not stuck yet", out.faults.is_none())?;
    }
    Ok(())
}

pub fn command_timeout_ramps_to_safe_state() -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    c.set_mode(Mode::Pressures {
        pressure_bar: [3.5; 4],
    })
    .ok();
    // the tensioning ramp, then the pressures
    run_steps(&mut c, RAMP_PERIODS + 300, 0);
    // host goes quiet: no heartbeat from here on
    let mut k = 0;
    let mut out = c.step(&sensors(1000));
    while out.faults.is_none() && k < 1000 {
        k += 1;
        out = c.step(&sensors(1000 + k));
    }
    holds("timeout detected", out.faults == Faults::COMMAND_TIMEOUT)?;
    // the last step of run_steps followed the last command; k + 2 periods have passed
    near(
        "detected in the first period past 100 ms [periods]",
        k as f32 + 2.0,
        101.0,
        0.0,
    )?;
    let after_first = out.pressure_bar[0];
    holds(
        "ramps, does not cut",
        after_first > 3.4 && after_first < 3.5,
    )?;
    // 5 bar/s from 3.5 bar (the co-contraction ceiling) to 0.1 bar: 0.68 s
    let mut steps = 0;
    while out.pressure_bar[0] > 0.1 + 1e-6 && steps < 2000 {
        steps += 1;
        out = c.step(&sensors(3000 + steps));
    }
    near(
        "reaches the safe state in (3.5-0.1)/5 s [ms]",
        steps as f32,
        679.0,
        2.0,
    )?;
    // the ramp's end is the safe state itself: every loop at 4 mA, not the 5.3 mA that
    // the I/P law gives for its 0.1 bar floor
    holds(
        "ends at the safe current (4 mA on every channel)",
        out.current_ma.iter().all(|&i| i == 4.0),
    )?;
    holds("latched", c.state() == State::Faulted)
}

pub fn disarm_vents_at_once() -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    c.set_mode(Mode::Pressures {
        pressure_bar: [3.0; 4],
    })
    .ok();
    run_steps(&mut c, 100, 0);
    c.disarm();
    let out = c.step(&sensors(500));
    holds(
        "disarmed vents",
        is_vent(&out) && out.state == State::Disarmed,
    )?;
    holds("mode reset", c.mode() == Mode::Idle)
}

pub fn unattainable_joint_request_is_clamped_and_flagged() -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    holds(
        "accepted (inside absolute limits)",
        c.set_mode(Mode::Joint {
            alpha_rad: [0.0; 2],
            torque_nm: [150.0, 0.0],
            stiffness_nm_per_rad: [60.0, 27.0],
        })
        .is_ok(),
    )?;
    // after the tensioning ramp the torque request rises at its rate limit (20 N·m/s) and
    // passes what the muscles can give after ≈ 3.8 s; a hand holds the arm still against
    // it (a still arm that reads no force is an encoder that does not see it move)
    let mut out = run_steps(&mut c, RAMP_PERIODS, 0);
    for k in 1..4500 {
        c.heartbeat();
        out = c.step(&crate::motion_checks::held(
            &c,
            [0.0; 2],
            out.pressure_bar,
            RAMP_PERIODS + k,
        ));
    }
    holds(
        "torque clamp flagged",
        out.limited.contains(Limited::TORQUE),
    )?;
    holds(
        "pressures within limits",
        out.pressure_bar.iter().all(|&p| (0.0..=5.0).contains(&p)),
    )?;
    holds("still armed", out.state == State::Armed)
}

pub fn force_mode_commands_pressures() -> CheckResult {
    let mut c = controller();
    c.arm().ok();
    c.set_mode(Mode::Force {
        force_n: [9.1, 0.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: false,
    })
    .ok();
    let plain = run_steps(&mut c, 300, 0);
    c.set_mode(Mode::Force {
        force_n: [9.1, 0.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: true,
    })
    .ok();
    let ff = run_steps(&mut c, 300, 300);
    holds(
        "armed, no fault",
        plain.faults.is_none() && ff.faults.is_none(),
    )?;
    // joint 2 pressures differ more with the 1/0.57 correction
    let d_plain = (plain.pressure_bar[2] - plain.pressure_bar[3]).abs();
    let d_ff = (ff.pressure_bar[2] - ff.pressure_bar[3]).abs();
    holds("feed-forward enlarges the command", d_ff > d_plain * 1.3)
}

pub fn hardware_faults_latch() -> CheckResult {
    // every fault the firmware raises: armed → faulted, vented, latched, clearable
    for fault in [
        Faults::WATCHDOG_RESET,
        Faults::OUTPUT_OPEN_LOOP,
        Faults::CPU_FAULT,
        Faults::LOOP_OVERRUN,
        Faults::STACK_LOW,
        Faults::ESTOP,
    ] {
        let mut c = controller();
        c.arm().ok();
        c.set_mode(Mode::Pressures {
            pressure_bar: [2.0; 4],
        })
        .ok();
        run_steps(&mut c, 20, 0);
        c.raise(fault);
        let out = c.step(&sensors(0));
        holds(
            "hardware fault latched and vented",
            out.faults.contains(fault) && out.state == State::Faulted && is_vent(&out),
        )?;
        let out = run_steps(&mut c, 5, 1);
        holds("still latched", out.faults.contains(fault) && is_vent(&out))?;
        holds("arm refused", c.arm() == Err(Reject::WrongState))?;
        holds(
            "clearable when sensors are fine",
            c.clear_faults(&sensors(1)).is_ok(),
        )?;
    }
    // the numbered bits are distinct
    let all = [
        Faults::COMMAND_TIMEOUT,
        Faults::NON_FINITE,
        Faults::ANGLE_OUT_OF_RANGE,
        Faults::ENCODER_JUMP,
        Faults::LOADCELL_SATURATED,
        Faults::LOADCELL_STUCK,
        Faults::OUTPUT_NON_FINITE,
        Faults::WATCHDOG_RESET,
        Faults::OUTPUT_OPEN_LOOP,
        Faults::CPU_FAULT,
        Faults::LOOP_OVERRUN,
        Faults::STACK_LOW,
        Faults::ESTOP,
        Faults::STATIC_IMBALANCE,
        Faults::CONTROL_UNSTABLE,
    ];
    let union = all.iter().fold(0u32, |a, f| a | u32::from(f.0));
    holds(
        "one bit per fault",
        union.count_ones() as usize == all.len(),
    )
}

/// The count of consecutive missed periods that latches `LOOP_OVERRUN`: 3 by
/// default, a limit like any other, refused outside 1–100 with nothing changed.
pub fn overrun_count_is_a_validated_limit() -> CheckResult {
    let mut c = controller();
    holds(
        "default 3",
        c.safety().overrun_fault_periods == DEFAULT_OVERRUN_FAULT_PERIODS
            && DEFAULT_OVERRUN_FAULT_PERIODS == 3,
    )?;
    for bad in [0, 101, u32::MAX] {
        let s = SafetyConfig {
            overrun_fault_periods: bad,
            ..SafetyConfig::default_1khz()
        };
        holds(
            "out of range refused",
            s.validate() == Err(Reject::OutOfRange),
        )?;
        holds("set refused", c.set_safety(s) == Err(Reject::OutOfRange))?;
        holds(
            "nothing changed",
            *c.safety() == SafetyConfig::default_1khz(),
        )?;
    }
    for good in [1, 7, 100] {
        let s = SafetyConfig {
            overrun_fault_periods: good,
            ..SafetyConfig::default_1khz()
        };
        holds("in range accepted", c.set_safety(s).is_ok())?;
        holds("in force", c.safety().overrun_fault_periods == good)?;
    }
    holds(
        "the range is 1–100",
        OVERRUN_FAULT_PERIODS_RANGE == (1..=100),
    )
}

pam_model::register_checks!(
    boots_disarmed_and_vented,
    pressures_mode_slews_to_target,
    out_of_range_command_refused_and_nothing_changes,
    non_finite_sensor_faults_vents_and_latches,
    angle_out_of_range_faults,
    encoder_jump_faults,
    loadcell_saturation_faults,
    loadcell_amplifier_full_scale_faults,
    loadcell_stuck_faults,
    command_timeout_ramps_to_safe_state,
    disarm_vents_at_once,
    unattainable_joint_request_is_clamped_and_flagged,
    force_mode_commands_pressures,
    hardware_faults_latch,
    overrun_count_is_a_validated_limit,
);
