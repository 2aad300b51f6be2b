//! The steps with the handle blocked at the neutral pose (§5.2 set-up): the load cell in
//! open-loop force steps, the converters (`converters`), a first closed-loop force step at
//! low gain.

use super::analysis::{tare, Finding};
use super::loadcell::{diagnose, force_map};
use super::{
    collect, conclude, phase_mean, print_bounds, CommissionState, Sample, StepError, StepRecord,
};
use crate::LinkArgs;
use pam_control::Mode;
use pam_link::Client;
use pam_model::protocols::step_test_stiffness;
use pam_model::RobotModel;
use pam_protocol::{RequestBody, Telemetry};
use std::io::Write;
use std::time::Instant;

/// The open-loop force step along each axis, N: a fifth of the thesis's step tests.
pub const LOADCELL_STEP_N: f64 = 10.0;
/// The closed-loop step, N, and the loop's gain scale (1 = the design).
pub const CLOSED_STEP_N: f64 = 5.0;
pub const CLOSED_GAIN_SCALE: f32 = 0.3;
/// The closed loop's final force must lie within this fraction of the step.
pub const CLOSED_TOLERANCE: f64 = 0.2;
/// Bounds of the blocked steps: handle force, N; joint speed, rad/s (the block lets the arm
/// creep only through its own compliance).
pub const BLOCKED_FORCE_N: f64 = 25.0;
pub const BLOCKED_SPEED_RAD_S: f64 = 0.5;
const HOLD_S: f64 = 1.5;

/// The blocked steps in order, each skipped when it passed earlier.
pub fn run_all(
    link: &LinkArgs,
    state: &mut CommissionState,
    out: &mut dyn Write,
) -> Result<(), StepError> {
    let client = super::super::connect(link)?;
    let done = |state: &CommissionState, s: &str| state.passed.iter().any(|p| p == s);
    if !done(state, "loadcell") {
        loadcell_step(&client, state, out)?;
    }
    if !done(state, "converters") {
        super::converters::converters_step(&client, state, out)?;
    }
    if !done(state, "closed_loop") {
        closed_loop_step(&client, state, out)?;
    }
    Ok(())
}

fn model() -> RobotModel<f64> {
    RobotModel::thesis()
}

/// Runs `phases` (mode, seconds) in force mode at the pose, then disarms whatever happened.
fn run_phases(
    client: &Client,
    phases: &[(Mode, f64)],
    record: &mut StepRecord,
) -> anyhow::Result<Vec<Sample>> {
    client.command(RequestBody::SetTelemetry { divider: 1 })?;
    client.command(RequestBody::Arm)?;
    client.start_telemetry();
    let t0 = Instant::now();
    let mut samples = Vec::new();
    let mut result = Ok(());
    for (i, (mode, seconds)) in phases.iter().enumerate() {
        result = client
            .command(RequestBody::SetMode((*mode).into()))
            .map_err(anyhow::Error::from)
            .and_then(|()| collect(client, *seconds, i, &mut samples, record));
        if result.is_err() {
            break;
        }
    }
    let vented = client.command(RequestBody::Disarm);
    record.seconds = t0.elapsed().as_secs_f64();
    result?;
    vented?;
    Ok(samples)
}

pub(super) fn record(name: &str) -> StepRecord {
    StepRecord {
        name: name.into(),
        speed_bound_rad_s: BLOCKED_SPEED_RAD_S,
        force_bound_n: BLOCKED_FORCE_N,
        ..StepRecord::default()
    }
}

pub(super) fn force(t: &Telemetry) -> [f64; 2] {
    t.force_user_n.map(f64::from)
}

fn loadcell_step(
    client: &Client,
    state: &mut CommissionState,
    out: &mut dyn Write,
) -> Result<(), StepError> {
    writeln!(
        out,
        "step 2: the load cell. With the handle blocked, open-loop force steps of {LOADCELL_STEP_N} N along X, then Y; \
         expected: the load cell reads the commanded force (axes, signs, gains of eq. 2.1, its angle of eq. 2.6–2.7), \
         0 N at zero command. Bounds: {BLOCKED_SPEED_RAD_S} rad/s, {BLOCKED_FORCE_N} N."
    )?;
    let m = model();
    let alpha = [0.0, 0.0];
    let k = step_test_stiffness(&m, alpha);
    let stiffness = [k[0] as f32, k[1] as f32];
    let at = |f: [f64; 2]| Mode::Force {
        force_n: [f[0] as f32, f[1] as f32],
        stiffness_nm_per_rad: stiffness,
        feed_forward: false,
    };
    let s = LOADCELL_STEP_N;
    let phases = [
        (at([0.0, 0.0]), HOLD_S),
        (at([s, 0.0]), HOLD_S),
        (at([0.0, 0.0]), HOLD_S),
        (at([0.0, s]), HOLD_S),
        (at([0.0, 0.0]), 0.5),
    ];
    let mut rec = record("loadcell");
    let result = run_phases(client, &phases, &mut rec);
    print_bounds(out, &rec)?;
    state.steps.push(rec);
    let samples = result?;
    let base_x = phase_mean(&samples, 0, &force);
    let fx = phase_mean(&samples, 1, &force);
    let base_y = phase_mean(&samples, 2, &force);
    let fy = phase_mean(&samples, 3, &force);
    let pose = phase_mean(&samples, 0, &|t| t.alpha_rad.map(f64::from));
    let dx = [fx[0] - base_x[0], fx[1] - base_x[1]];
    let dy = [fy[0] - base_y[0], fy[1] - base_y[1]];
    let map = force_map(s, dx, dy);
    writeln!(
        out,
        "  at zero command ({:+.2}, {:+.2}) N; X step read ({:+.2}, {:+.2}) N, Y step ({:+.2}, {:+.2}) N (commanded {s} N)",
        base_x[0], base_x[1], dx[0], dx[1], dy[0], dy[1]
    )?;
    let [[a, b], [c, d]] = map.0;
    if let Some(r) = state.steps.last_mut() {
        r.checks = vec![
            check(
                "force at zero command, N",
                base_x[0].hypot(base_x[1]),
                0.0,
                tare_tol(),
            ),
            check(
                "X step: Fx / command",
                a,
                1.0,
                super::loadcell::MATRIX_TOLERANCE,
            ),
            check(
                "X step: Fy / command",
                c,
                0.0,
                super::loadcell::MATRIX_TOLERANCE,
            ),
            check(
                "Y step: Fx / command",
                b,
                0.0,
                super::loadcell::MATRIX_TOLERANCE,
            ),
            check(
                "Y step: Fy / command",
                d,
                1.0,
                super::loadcell::MATRIX_TOLERANCE,
            ),
            check(
                "load-cell angle, deg",
                c.atan2(a).to_degrees(),
                0.0,
                super::loadcell::ANGLE_TOLERANCE_DEG,
            ),
        ];
    }
    let mut findings = diagnose(&m, pose, &map, state.reversed_joint);
    // the tare, against the model's 0 N at zero command; with a joint read backwards the
    // force mode models another pose and its zero-force pressures push (step 1 checked the
    // tare with the handle free)
    if state.reversed_joint.is_none() {
        findings.extend(tare(base_x));
    }
    if state.reversed_joint.is_some() && findings.is_empty() {
        // a reversal step 1 saw must be explained here
        findings.push(Finding {
            fix: None,
            fault: "joint_reversed_unexplained",
            detail: "a joint turned backwards with the handle free, and the blocked handle could not say why".into(),
            advice: "check the joint's encoder sign and its muscle tubes one at a time".into(),
        });
    }
    conclude(state, "loadcell", findings, out)
}

fn tare_tol() -> f64 {
    super::analysis::TARE_TOLERANCE_N
}

/// One row of a step's checks: what, measured, expected, tolerance and margin.
pub fn check(what: &str, measured: f64, expected: f64, tolerance: f64) -> [String; 4] {
    let margin = tolerance - (measured - expected).abs();
    [
        what.to_string(),
        format!("{measured:+.3}"),
        format!("{expected:+.3}"),
        format!("±{} (margin {margin:+.3})", short(tolerance)),
    ]
}

/// A tolerance as it reads: at most three decimals, without trailing zeros (`0.15`, `3`,
/// `6.482`).
fn short(x: f64) -> String {
    let text = format!("{x:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    text.to_string()
}

fn closed_loop_step(
    client: &Client,
    state: &mut CommissionState,
    out: &mut dyn Write,
) -> Result<(), StepError> {
    writeln!(
        out,
        "step 4: a first closed-loop force step. With the handle blocked, the load cell in the loop at \
         {CLOSED_GAIN_SCALE}× the designed gains, a {CLOSED_STEP_N} N step along X; expected: the force settles \
         within {}% of the step. Bounds: {BLOCKED_SPEED_RAD_S} rad/s, {BLOCKED_FORCE_N} N.",
        CLOSED_TOLERANCE * 100.0
    )?;
    let m = model();
    let k = step_test_stiffness(&m, [0.0, 0.0]);
    let at = |f: f64| Mode::ForceClosedLoop {
        force_n: [f as f32, 0.0],
        stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
        feed_forward: false,
        gain_scale: CLOSED_GAIN_SCALE,
    };
    let phases = [(at(0.0), 1.0), (at(CLOSED_STEP_N), 2.5), (at(0.0), 0.5)];
    let mut rec = record("closed_loop");
    let result = run_phases(client, &phases, &mut rec);
    print_bounds(out, &rec)?;
    state.steps.push(rec);
    let samples = result?;
    let base = phase_mean(&samples, 0, &force);
    let end = phase_mean(&samples, 1, &force);
    let peak = samples
        .iter()
        .filter(|s| s.phase == 1)
        .map(|s| f64::from(s.t.force_user_n[0]) - base[0])
        .fold(0.0, f64::max);
    let rise = end[0] - base[0];
    let overshoot = (peak / CLOSED_STEP_N - 1.0).max(0.0);
    writeln!(
        out,
        "  the force rose {rise:+.2} N (commanded {CLOSED_STEP_N} N), peak {peak:+.2} N, cross axis {:+.2} N",
        end[1] - base[1]
    )?;
    let tol = CLOSED_TOLERANCE * CLOSED_STEP_N;
    if let Some(r) = state.steps.last_mut() {
        r.checks = vec![
            check("final force, N", rise, CLOSED_STEP_N, tol),
            check("cross-axis force, N", end[1] - base[1], 0.0, tol),
            check("overshoot, fraction", overshoot, 0.0, 0.5),
        ];
    }
    let mut findings = Vec::new();
    if (rise - CLOSED_STEP_N).abs() > tol || (end[1] - base[1]).abs() > tol || overshoot > 0.5 {
        findings.push(Finding {
            fix: None,
            fault: "closed_loop_step",
            detail: format!(
                "the closed loop reached {rise:+.2} N for {CLOSED_STEP_N} N (overshoot {:.0}%)",
                overshoot * 100.0
            ),
            advice: "measure the plant gain (`pamctl tune`) before raising the gain; check the load cell step's findings".into(),
        });
    }
    conclude(state, "closed_loop", findings, out)
}

#[cfg(test)]
mod tests {
    use super::check;

    #[test]
    fn a_tolerance_reads_with_at_most_three_decimals() {
        assert_eq!(
            check("gain", 1.0, 1.0, 6.482342409500256)[3],
            "±6.482 (margin +6.482)"
        );
        assert_eq!(check("tare", 0.0, 0.0, 3.0)[3], "±3 (margin +3.000)");
        assert_eq!(check("ζ", 0.0, 0.0, 0.15)[3], "±0.15 (margin +0.150)");
    }
}
