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
use pam_control::{Controller, Mode, SafetyConfig, Sensors};
use pam_model::checks::{precision, workload, Check, CHECKS_F32, CHECKS_F64};
use pam_model::kinematics::Kinematics;
use pam_model::RobotModel;

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
    for c in pam_control::checks::CHECKS {
        match (c.run)() {
            Ok(()) => {
                passed += 1;
                hprintln!("ok   control {}", c.name);
            }
            Err(e) => {
                failed += 1;
                hprintln!(
                    "FAIL control {}: {} got {} expected {}",
                    c.name,
                    e.what,
                    e.got,
                    e.expected
                );
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

    // One full control step, sensors in -> outputs out: supervisor, load-cell rotation,
    // mode (force with feed-forward: the longest path), slew limits, currents.
    let mut ctl = Controller::new(RobotModel::thesis(), SafetyConfig::default_1khz());
    let _ = ctl.arm();
    let _ = ctl.set_mode(Mode::Force {
        force_n: [9.1, -4.0],
        stiffness_nm_per_rad: [60.0, 27.0],
        feed_forward: true,
    });
    let mut k = 0u32;
    let step_ticks = ticks(|| {
        for _ in 0..REPS {
            for w in inputs.iter() {
                ctl.heartbeat();
                k += 1;
                let a = [
                    w.alpha_rad[0] * 0.001 * (k & 7) as f32,
                    w.alpha_rad[1] * 0.001 * (k & 7) as f32,
                ];
                let s = Sensors {
                    alpha_rad: a,
                    force_sensor_n: [w.torque_nm[0] * 0.1, w.torque_nm[1] * 0.1],
                };
                black_box(ctl.step(black_box(&s)));
            }
        }
    });
    let per_step = (step_ticks.saturating_sub(empty_ticks)) as f32 * insn_per_tick / n;
    hprintln!("bench control step (sensors in -> outputs out, force mode + feed-forward + supervisor), f32/{}: {:.0} instructions per step; state {:?}", math, per_step, ctl.state());

    hprintln!("qemu: {} passed, {} failed", passed, failed);
    if failed == 0 {
        debug::exit(debug::EXIT_SUCCESS);
    } else {
        debug::exit(debug::EXIT_FAILURE);
    }
    loop {}
}
