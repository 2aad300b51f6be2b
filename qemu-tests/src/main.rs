//! The robot model's self-checks on an emulated Cortex-M4F with FPU.
//!
//! Prints one line per check, the f32-vs-f64 precision report, the instruction count of
//! one full model evaluation (both joints), and a closing `qemu: N passed, M failed`.
//! Exits non-zero (semihosting) if any check failed.
#![no_std]
#![no_main]

use core::arch::asm;
use core::hint::black_box;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use pam_control::{Mode, SafetyConfig, State};
use pam_device::checks::OPTIONS;
use pam_device::{Device, RawSensors, StepTiming};
use pam_model::checks::{precision, workload, Check, CHECKS_F32, CHECKS_F64};
use pam_model::kinematics::Kinematics;
use pam_model::{RobotModel, RobotParams};
use pam_protocol::{Request, RequestBody};

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("PANIC: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}

fn run(label: &str, checks: &[Check], passed: &mut u32, failed: &mut u32) {
    for c in checks {
        match (c.run)() {
            Ok(()) => {
                *passed += 1;
                hprintln!("ok   {} {}", label, c.name);
            }
            Err(e) => {
                *failed += 1;
                hprintln!(
                    "FAIL {} {}: {} [#{}] got {} expected {} +- {}",
                    label,
                    c.name,
                    e.what,
                    e.index,
                    e.got,
                    e.expected,
                    e.tolerance
                );
            }
        }
    }
}

/// SysTick ticks for a block; the counter counts down and is 24 bits wide.
fn ticks<F: FnMut()>(mut f: F) -> u32 {
    let before = cortex_m::peripheral::SYST::get_current();
    f();
    let after = cortex_m::peripheral::SYST::get_current();
    before.wrapping_sub(after) & 0x00FF_FFFF
}

/// A loop of exactly two instructions per iteration (`subs`, `bne`), used to learn how
/// many instructions one SysTick tick is under `-icount`.
fn known_instructions(iterations: u32) {
    unsafe {
        asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) iterations => _, options(nomem, nostack));
    }
}

/// The timing of the `k`-th benchmarked period: 1 ms apart, a short and steady loop.
fn bench_timing(k: u32) -> StepTiming {
    StepTiming {
        time_us: k * 1000,
        loop_exec_us: 20,
        loop_jitter_us: 1,
    }
}

/// A request of the session the handshake issued.
fn request(body: RequestBody) -> Request {
    Request {
        id: 1,
        body,
        session: 1,
    }
}

/// A device at the thesis's parameters, handshaken, homed at the zero pose, armed and in
/// `mode`: its tensioning ramp has just begun.
fn armed_device(mode: Mode) -> Device {
    let mut dev = Device::new(RobotParams::thesis(), SafetyConfig::default_1khz(), OPTIONS);
    let home = RawSensors {
        encoder_counts: [0, 0],
        loadcell_volts: [0.0, 0.0],
    };
    dev.step(home, StepTiming::default());
    // the handshake issues session 1, which arming and the mode need
    dev.handle(&request(RequestBody::Hello {
        protocol_version: pam_protocol::PROTOCOL_VERSION,
        schema_fingerprint: pam_protocol::SCHEMA_FINGERPRINT,
    }));
    dev.handle(&request(RequestBody::Home));
    dev.handle(&request(RequestBody::Arm));
    dev.handle(&request(RequestBody::SetMode(mode.into())));
    dev
}

/// Instructions per control step of the closed force loop while it arms: the tensioning
/// ramp's first 0.8 s, where the loop also watches the handle to choose its gains (the
/// bench in `main` measures the loop after its ramp). Returns the figure and whether the
/// device stayed armed.
fn closed_loop_ramp_step(insn_per_tick: f32) -> (f32, bool) {
    const STEPS: u32 = 800;
    let mut dev = armed_device(Mode::ForceClosedLoop {
        force_n: [2.0, -1.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: true,
        gain_scale: 1.0,
    });
    let mut k = 0u32;
    let step_ticks = ticks(|| {
        for _ in 0..STEPS {
            dev.handle(&request(RequestBody::Heartbeat));
            k += 1;
            // a handle still within the encoders' dead band and a slowly rising force, as
            // at a blocked handle
            let raw = RawSensors {
                encoder_counts: [0, 0],
                loadcell_volts: [(k as f32) * 1.0e-5, -(k as f32) * 0.5e-5],
            };
            black_box(dev.step(black_box(raw), bench_timing(k)));
        }
    });
    let heartbeat_ticks = ticks(|| {
        for _ in 0..STEPS {
            black_box(dev.handle(&request(RequestBody::Heartbeat)));
        }
    });
    let per_step = step_ticks.saturating_sub(heartbeat_ticks) as f32 * insn_per_tick / STEPS as f32;
    (per_step, dev.controller().state() == State::Armed)
}

#[entry]
fn main() -> ! {
    let core = cortex_m::Peripherals::take().unwrap();
    let (mut passed, mut failed) = (0u32, 0u32);
    let math = if cfg!(feature = "micromath") {
        "micromath"
    } else {
        "libm"
    };
    hprintln!(
        "pam-model self-checks on Cortex-M4F (QEMU mps2-an386), f32 transcendental functions: {}",
        math
    );
    run("f32", CHECKS_F32, &mut passed, &mut failed);
    run("f64", CHECKS_F64, &mut passed, &mut failed);
    for (label, checks) in [
        ("control", pam_control::checks::CHECKS),
        ("control force loop", pam_control::force_loop_checks::CHECKS),
        ("control motion", pam_control::motion_checks::CHECKS),
        ("control safety", pam_control::safety_checks::CHECKS),
        ("device", pam_device::checks::CHECKS),
        ("config store", pam_config_store::checks::CHECKS),
    ] {
        for c in checks {
            match (c.run)() {
                Ok(()) => {
                    passed += 1;
                    hprintln!("ok   {} {}", label, c.name);
                }
                Err(e) => {
                    failed += 1;
                    hprintln!(
                        "FAIL {} {}: {} got {} expected {}",
                        label,
                        c.name,
                        e.what,
                        e.got,
                        e.expected
                    );
                }
            }
        }
    }

    // Precision of the f32 model against the f64 reference, both computed here.
    let report = precision::compare();
    for q in report.iter() {
        hprintln!(
            "precision {:<28} max |f32-f64| = {:.3e} {:<8} (max rel {:.2e}) over {} samples",
            q.name,
            q.max_abs,
            q.unit,
            q.max_rel,
            q.samples
        );
    }

    // Instruction count of one full evaluation of both joints.
    let mut syst = core.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
    const CAL_ITER: u32 = 200_000;
    let cal_ticks = ticks(|| known_instructions(CAL_ITER));
    let insn_per_tick = (2 * CAL_ITER) as f32 / cal_ticks.max(1) as f32;
    let model = RobotModel::<f32>::thesis();
    let inputs = workload::inputs::<f32>();
    const REPS: u32 = 20;
    let loop_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                black_box(model.evaluate(
                    black_box(w.alpha_rad),
                    black_box(w.torque_nm),
                    black_box(w.stiffness_nm_per_rad),
                ));
            }
        }
    });
    let empty_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                black_box(black_box(w.alpha_rad));
            }
        }
    });
    let n = (REPS as usize * inputs.len()) as f32;
    let per_eval = (loop_ticks.saturating_sub(empty_ticks)) as f32 * insn_per_tick / n;
    hprintln!("bench model.evaluate (both joints: direct + inverse + limits), f32/{}: {:.0} instructions per evaluation ({} evaluations, {:.1} instructions per SysTick tick)", math, per_eval, n as u32, insn_per_tick);

    // The Cartesian force path: load-cell rotation, gain plane, τ = Jᵀ F, inverse model.
    let force_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                let alpha = black_box(w.alpha_rad);
                let trig = model.kinematics.trig(alpha);
                let f = Kinematics::sensor_to_user_at(
                    &trig,
                    black_box([w.torque_nm[0], w.torque_nm[1]]),
                );
                black_box(model.force_command_at(
                    alpha,
                    &trig,
                    f,
                    black_box(w.stiffness_nm_per_rad),
                    true,
                ));
            }
        }
    });
    let per_force = (force_ticks.saturating_sub(empty_ticks)) as f32 * insn_per_tick / n;
    hprintln!("bench force path (load-cell rotation + gain plane + J^T F + inverse, both joints), f32/{}: {:.0} instructions per evaluation", math, per_force);

    // One full control step through the device service, raw sensors in -> output
    // currents out: encoder count accumulation, load-cell volts -> N, supervisor,
    // load-cell rotation, mode (force with feed-forward: the longest path), slew limits,
    // currents, output calibration and the telemetry sample.
    let mut dev = armed_device(Mode::Force {
        force_n: [9.1, -4.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: true,
    });
    let mut k = 0u32;
    let step_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                // the command timeout's counter reset, as a host request does
                dev.handle(&request(RequestBody::Heartbeat));
                k += 1;
                // small wandering pose (a few counts, no encoder jump), dithering load cell
                let raw = RawSensors {
                    encoder_counts: [(k & 7).wrapping_sub(4) & 0xFFFF, (k & 3) * 2],
                    loadcell_volts: [w.torque_nm[0] * 0.001, w.torque_nm[1] * 0.001],
                };
                black_box(dev.step(black_box(raw), bench_timing(k)));
            }
        }
    });
    let heartbeat_ticks = ticks(|| {
        for _ in 0..REPS {
            for _ in inputs.iter() {
                black_box(dev.handle(&request(RequestBody::Heartbeat)));
            }
        }
    });
    let per_step = (step_ticks.saturating_sub(heartbeat_ticks)) as f32 * insn_per_tick / n;
    let armed_through_bench = dev.controller().state() == State::Armed;
    hprintln!("bench control step (pam-device: raw counts/volts in -> output currents out, force mode + feed-forward + supervisor + telemetry), f32/{}: {:.0} instructions per step; state {:?}, faults {:#x}", math, per_step, dev.controller().state(), dev.controller().faults().0);
    // The same step in closed-loop force mode: reference model, converter-inverse
    // feed-forward, PID with anti-windup, guard, then the gain plane and the same force path.
    // The target is near the dithering load cell's reading so the guard stays quiet (a
    // faulted device would take the short path).
    dev.handle(&request(RequestBody::SetMode(
        Mode::ForceClosedLoop {
            force_n: [2.0, -1.0],
            stiffness_nm_per_rad: [60.0, 27.0],
            feed_forward: true,
            gain_scale: 1.0,
        }
        .into(),
    )));
    let cl_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                dev.handle(&request(RequestBody::Heartbeat));
                k += 1;
                let raw = RawSensors {
                    encoder_counts: [(k & 7).wrapping_sub(4) & 0xFFFF, (k & 3) * 2],
                    loadcell_volts: [w.torque_nm[0] * 0.001, w.torque_nm[1] * 0.001],
                };
                black_box(dev.step(black_box(raw), bench_timing(k)));
            }
        }
    });
    let per_step_cl = (cl_ticks.saturating_sub(heartbeat_ticks)) as f32 * insn_per_tick / n;
    let armed_through_cl = dev.controller().state() == State::Armed;
    hprintln!("bench control step closed loop (pam-device, force mode closed loop + gain plane + supervisor + telemetry), f32/{}: {:.0} instructions per step; state {:?}, faults {:#x}", math, per_step_cl, dev.controller().state(), dev.controller().faults().0);
    if !armed_through_cl {
        failed += 1;
        hprintln!("FAIL bench: the device left the armed state during the closed-loop benchmark");
    }
    // impedance mode: handle position, velocity filter, spring-damper, the force loop
    dev.handle(&request(RequestBody::SetMode(
        Mode::Impedance {
            target_user_m: [0.0, 0.0],
            stiffness_n_per_m: [300.0, 300.0],
            damping_n_s_per_m: [5.0, 5.0],
            mass_kg: [0.0, 0.0],
        }
        .into(),
    )));
    let imp_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                dev.handle(&request(RequestBody::Heartbeat));
                k += 1;
                // a handle moving one count every 64 ms: the velocity filter sees a motion,
                // not the ±4-count jitter per period above (its damping force would make
                // the guard see an oscillation, as it should)
                let raw = RawSensors {
                    encoder_counts: [(k >> 6) & 7, (k >> 6) & 3],
                    loadcell_volts: [w.torque_nm[0] * 0.001, w.torque_nm[1] * 0.001],
                };
                black_box(dev.step(black_box(raw), bench_timing(k)));
            }
        }
    });
    let per_step_imp = (imp_ticks.saturating_sub(heartbeat_ticks)) as f32 * insn_per_tick / n;
    let armed_through_imp = dev.controller().state() == State::Armed;
    hprintln!("bench control step impedance (pam-device, impedance mode through the closed force loop + supervisor + telemetry), f32/{}: {:.0} instructions per step; state {:?}, faults {:#x}", math, per_step_imp, dev.controller().state(), dev.controller().faults().0);
    if !armed_through_imp {
        failed += 1;
        hprintln!("FAIL bench: the device left the armed state during the impedance benchmark");
    }
    // joint mode: the shaped reference, the inverse model, and the encoders' plausibility
    // (static balance and unseen motion) on the muscles' torque at the measured pose
    dev.handle(&request(RequestBody::SetMode(
        Mode::Joint {
            alpha_rad: [0.0, 0.0],
            torque_nm: [0.0, 0.0],
            stiffness_nm_per_rad: [95.0, 40.0],
        }
        .into(),
    )));
    let wandering = |k: u32, w: &workload::Input<f32>| RawSensors {
        encoder_counts: [(k & 7).wrapping_sub(4) & 0xFFFF, (k & 3) * 2],
        loadcell_volts: [w.torque_nm[0] * 0.001, w.torque_nm[1] * 0.001],
    };
    // the tensioning ramp (1 s) first: the bench measures the mode's own step
    for _ in 0..1100 {
        dev.handle(&request(RequestBody::Heartbeat));
        k += 1;
        dev.step(
            wandering(k, &inputs[k as usize % inputs.len()]),
            StepTiming::default(),
        );
    }
    let joint_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                dev.handle(&request(RequestBody::Heartbeat));
                k += 1;
                black_box(dev.step(black_box(wandering(k, w)), bench_timing(k)));
            }
        }
    });
    let per_step_joint = (joint_ticks.saturating_sub(heartbeat_ticks)) as f32 * insn_per_tick / n;
    let armed_through_joint = dev.controller().state() == State::Armed;
    hprintln!("bench control step joint (pam-device, joint mode: shaped reference + inverse + supervisor + telemetry), f32/{}: {:.0} instructions per step; state {:?}, faults {:#x}", math, per_step_joint, dev.controller().state(), dev.controller().faults().0);
    if !armed_through_joint {
        failed += 1;
        hprintln!("FAIL bench: the device left the armed state during the joint-mode benchmark");
    }
    let (per_step_ramp, armed_through_ramp) = closed_loop_ramp_step(insn_per_tick);
    hprintln!("bench control step closed loop while arming (pam-device, the tensioning ramp's first 0.8 s: force loop + handle watch + ramp + supervisor + telemetry), f32/{}: {:.0} instructions per step; armed {}", math, per_step_ramp, armed_through_ramp);
    if !armed_through_ramp {
        failed += 1;
        hprintln!("FAIL bench: the device left the armed state while the closed loop armed");
    }
    // the budget of one control step
    const STEP_BUDGET_INSTRUCTIONS: f32 = 5000.0;
    if per_step_cl > STEP_BUDGET_INSTRUCTIONS
        || per_step_ramp > STEP_BUDGET_INSTRUCTIONS
        || per_step > STEP_BUDGET_INSTRUCTIONS
        || per_step_imp > STEP_BUDGET_INSTRUCTIONS
        || per_step_joint > STEP_BUDGET_INSTRUCTIONS
    {
        failed += 1;
        hprintln!(
            "FAIL bench: a control step takes more than {} instructions",
            STEP_BUDGET_INSTRUCTIONS
        );
    }
    // The slowest requests, so the firmware knows what handling one costs wherever it
    // calls it: the handshake (hashes the parameters) and a new parameter set (rebuilds the
    // model's derived constants). Measured disarmed, where SetConfig is allowed.
    dev.handle(&request(RequestBody::Disarm));
    let hello = RequestBody::Hello {
        protocol_version: pam_protocol::PROTOCOL_VERSION,
        schema_fingerprint: pam_protocol::SCHEMA_FINGERPRINT,
    };
    let robot: pam_protocol::wire::RobotParams = RobotParams::thesis().into();
    let mut hello_ok = true;
    let mut config_ok = true;
    const REQ_REPS: u32 = 20;
    let hello_ticks = ticks(|| {
        for _ in 0..REQ_REPS {
            hello_ok &= black_box(dev.handle(black_box(&request(hello))))
                .result
                .is_ok();
        }
    });
    let config_ticks = ticks(|| {
        for _ in 0..REQ_REPS {
            config_ok &= black_box(dev.handle(black_box(&request(RequestBody::SetConfig(
                pam_protocol::Config::Robot(robot),
            )))))
            .result
            .is_ok();
        }
    });
    hprintln!("bench device.handle(Hello), f32/{}: {:.0} instructions; device.handle(SetConfig(Robot)): {:.0} instructions", math, hello_ticks as f32 * insn_per_tick / REQ_REPS as f32, config_ticks as f32 * insn_per_tick / REQ_REPS as f32);
    if !(hello_ok && config_ok) {
        failed += 1;
        hprintln!("FAIL bench: a benchmarked request was refused");
    }
    if !armed_through_bench {
        // a faulted device takes the short path: the figure would be meaningless
        failed += 1;
        hprintln!("FAIL bench: the device left the armed state during the benchmark");
    }

    hprintln!("qemu: {} passed, {} failed", passed, failed);
    if failed == 0 {
        debug::exit(debug::EXIT_SUCCESS);
    } else {
        debug::exit(debug::EXIT_FAILURE);
    }
    loop {}
}
