//! Step 3: the converters' step response (Table 5.2: a second order and a dead time), one
//! channel at a time, with the handle blocked.
//!
//! The board reads no muscle pressure. The thesis identified Table 5.2 from the force at a
//! blocked handle (§5.2–5.3), and so does this step: from the pressures the force mode holds
//! at zero force, each channel in turn takes a small pressure step and back; the load
//! cell's force along the direction the model says the step pushes is fitted with
//! `G·ωn² / (s² + 2ζωn s + ωn²) · e^(−Td s)` from the commanded pressure, and so is the
//! model's force for the same loop currents (the twin of the thesis's rig, blocked). The
//! fit is checked against Table 5.2 (ωn, ζ), the gain against the model's, the dead time
//! against Table 5.1's tube delay.

use super::analysis::Finding;
use super::blocked::{check, force, record, BLOCKED_FORCE_N, BLOCKED_SPEED_RAD_S};
use super::{collect, conclude, phase_mean, print_bounds, CommissionState, Sample, StepError};
use pam_control::Mode;
use pam_ident::step::{simulate, StepParams};
use pam_link::Client;
use pam_model::protocols::step_test_stiffness;
use pam_model::RobotModel;
use pam_numerics::lm;
use pam_protocol::RequestBody;
use pam_twin::{HandleCondition, Twin, TwinConfig};
use std::io::Write;
use std::time::Instant;

/// The pressure step on one channel, bar.
pub const STEP_BAR: f32 = 0.3;
/// Force mode at zero force before the steps (its tensioning ramp is 1 s), the step, the
/// return, s: Table 5.2's settling is 0.28–0.42 s.
const ENTRY_S: f64 = 1.2;
const UP_S: f64 = 0.5;
const DOWN_S: f64 = 0.4;
/// Table 5.2: the I/P converter and muscles from reference to force.
pub const TABLE_OMEGA_N_RAD_S: f64 = 23.04;
pub const TABLE_ZETA: f64 = 0.42;
/// Tolerances: ωn relative, ζ absolute, the gain relative to the model's.
pub const OMEGA_TOLERANCE: f64 = 0.3;
pub const ZETA_TOLERANCE: f64 = 0.15;
pub const GAIN_TOLERANCE: f64 = 0.3;
/// Longest dead time, s: Table 5.1 finds the tube's delay under 0.05 s.
pub const DEAD_TIME_MAX_S: f64 = 0.05;
/// A gain under this fraction of the model's: the converter does not respond.
const DEAD_GAIN: f64 = 0.2;

/// A second order with dead time fitted to one channel's step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepFit {
    /// N per bar, along the model's direction of the step's force.
    pub gain: f64,
    pub zeta: f64,
    pub omega_n_rad_s: f64,
    pub dead_time_s: f64,
}

/// `u` delayed by `delay_s` on the uniform grid `t_s`; 0 before the grid (the step's input
/// is taken from its base, so it was 0 before the step).
fn delayed(t_s: &[f64], u: &[f64], delay_s: f64, out: &mut [f64]) {
    let n = t_s.len();
    let dt = (t_s[n - 1] - t_s[0]) / (n - 1) as f64;
    for (i, o) in out.iter_mut().enumerate() {
        let x = i as f64 - delay_s / dt;
        if x <= -1.0 {
            *o = 0.0;
            continue;
        }
        // between the 0 before the grid (index −1) and the samples
        let k = x.floor();
        let f = x - k;
        let at = |j: f64| {
            if j < 0.0 {
                0.0
            } else {
                u[(j as usize).min(n - 1)]
            }
        };
        *o = at(k) + (at(k + 1.0) - at(k)) * f;
    }
}

/// Fits `y` (from 0) to the second order with dead time driven by `u`; `None` without a
/// response to fit (fewer than 50 samples, a flat input) or when the fit does not converge
/// to finite numbers.
pub fn fit_step(t_s: &[f64], u: &[f64], y: &[f64]) -> Option<StepFit> {
    let n = t_s.len().min(u.len()).min(y.len());
    let u_peak = u.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if n < 50 || u_peak < 1e-6 {
        return None;
    }
    let (t, u, y) = (&t_s[..n], &u[..n], &y[..n]);
    let stride = (n / 200).max(1);
    let sel: Vec<usize> = (0..n).step_by(stride).collect();
    let peak_at = (0..n).max_by(|&a, &b| u[a].abs().total_cmp(&u[b].abs()))?;
    let g0 = y[peak_at] / u[peak_at];
    let residuals = |v: &[f64], r: &mut [f64]| {
        let mut ud = vec![0.0; n];
        delayed(t, u, v[3], &mut ud);
        let mut sim = vec![0.0; n];
        simulate(&StepParams::base(v[0], v[1], v[2]), t, &ud, 0.0, &mut sim);
        for (j, &i) in sel.iter().enumerate() {
            r[j] = sim[i] - y[i];
        }
    };
    // the dead time trades against ωn in a long valley: a grid over it first, every 5 ms
    // to 0.1 s, the second order fitted at each, then all four together from the best
    let mut start = [g0, 0.5, 20.0, 0.0];
    let mut best_cost = f64::INFINITY;
    let mut best_td = 0.0;
    for k in 0..=20 {
        let td = k as f64 * 0.005;
        let report = lm::minimize(
            &start[..3],
            &[(1, 0.05), (2, 1.0)],
            sel.len(),
            15,
            |v, r| residuals(&[v[0], v[1], v[2], td], r),
        );
        if report.is_finite() && report.cost < best_cost {
            best_cost = report.cost;
            best_td = td;
            start[..3].copy_from_slice(&report.theta);
        }
    }
    start[3] = best_td;
    let best = Some(lm::minimize(
        &start,
        &[(1, 0.05), (2, 1.0), (3, 0.0)],
        sel.len(),
        40,
        residuals,
    ))
    .filter(|r| r.is_finite());
    let th = best?.theta;
    Some(StepFit {
        gain: th[0],
        zeta: th[1],
        omega_n_rad_s: th[2],
        dead_time_s: th[3],
    })
}

/// The checks of one channel (rows for the report) and its finding, if any.
pub fn judge(
    channel: usize,
    rig: Option<StepFit>,
    model: Option<StepFit>,
) -> (Vec<[String; 4]>, Option<Finding>) {
    let n = channel + 1;
    let model_gain = model.map_or(f64::NAN, |m| m.gain);
    let Some(rig) = rig.filter(|r| r.gain / model_gain >= DEAD_GAIN) else {
        let gain = rig.map_or(0.0, |r| r.gain);
        let rows = vec![check(
            &format!("channel {n}: gain, N/bar"),
            gain,
            model_gain,
            GAIN_TOLERANCE * model_gain.abs(),
        )];
        return (
            rows,
            Some(Finding {
                fix: None,
                fault: "converter_dead",
                detail: format!(
                    "channel {n}'s pressure step moved the blocked handle's force {gain:+.2} N/bar, the model {model_gain:+.2} N/bar"
                ),
                advice: format!(
                    "check converter {n}: its supply, its 4–20 mA loop (a meter in series), its tube to the muscle; replace it if it stays silent"
                ),
            }),
        );
    };
    let rows = vec![
        check(
            &format!("channel {n}: ωn, rad/s (Table 5.2)"),
            rig.omega_n_rad_s,
            TABLE_OMEGA_N_RAD_S,
            OMEGA_TOLERANCE * TABLE_OMEGA_N_RAD_S,
        ),
        check(
            &format!("channel {n}: ζ (Table 5.2)"),
            rig.zeta,
            TABLE_ZETA,
            ZETA_TOLERANCE,
        ),
        check(
            &format!("channel {n}: gain, N/bar (model)"),
            rig.gain,
            model_gain,
            GAIN_TOLERANCE * model_gain.abs(),
        ),
        check(
            &format!("channel {n}: dead time, s"),
            rig.dead_time_s,
            0.0,
            DEAD_TIME_MAX_S,
        ),
    ];
    // a lag in front of the second order shows as a lower ωn, a dead time or a larger ζ
    let slow = rig.omega_n_rad_s < (1.0 - OMEGA_TOLERANCE) * TABLE_OMEGA_N_RAD_S
        || rig.dead_time_s > DEAD_TIME_MAX_S
        || rig.zeta > TABLE_ZETA + ZETA_TOLERANCE;
    let off = (rig.omega_n_rad_s / TABLE_OMEGA_N_RAD_S - 1.0).abs() > OMEGA_TOLERANCE
        || (rig.zeta - TABLE_ZETA).abs() > ZETA_TOLERANCE
        || (rig.gain / model_gain - 1.0).abs() > GAIN_TOLERANCE;
    let detail = format!(
        "channel {n}: ωn {:.1} rad/s, ζ {:.2}, dead time {:.3} s, gain {:.2} N/bar (Table 5.2: ωn {TABLE_OMEGA_N_RAD_S}, ζ {TABLE_ZETA}; model gain {model_gain:.2})",
        rig.omega_n_rad_s, rig.zeta, rig.dead_time_s, rig.gain
    );
    let finding = if slow {
        Some(Finding {
            fix: None,
            fault: "converter_slow",
            detail,
            advice: format!(
                "converter {n} responds slowly: check its supply pressure and filter, its pilot, and the tube to its muscle for a kink or a long run; replace it if it stays slow"
            ),
        })
    } else if off {
        Some(Finding {
            fix: None,
            fault: "converter_response",
            detail,
            advice: format!(
                "converter {n} or its muscle responds unlike Table 5.2: check its supply pressure, its I/P law (eq. 2.2) with a gauge, and the muscle's fittings for a leak"
            ),
        })
    } else {
        None
    };
    (rows, finding)
}

/// Runs the step: force mode at zero force, then the pressures it holds, each channel
/// stepped in turn; vented at the end whatever happened.
pub fn converters_step(
    client: &Client,
    state: &mut CommissionState,
    out: &mut dyn Write,
) -> Result<(), StepError> {
    writeln!(
        out,
        "step 3: the converters' step response. With the handle blocked, from the pressures of zero force, each \
         channel in turn {STEP_BAR} bar up for {UP_S} s and back; expected per channel: the force follows Table 5.2's \
         second order (ωn {TABLE_OMEGA_N_RAD_S} rad/s ±{:.0}%, ζ {TABLE_ZETA} ±{ZETA_TOLERANCE}), a dead time under \
         {DEAD_TIME_MAX_S} s, the model's gain ±{:.0}%. Bounds: {BLOCKED_SPEED_RAD_S} rad/s, {BLOCKED_FORCE_N} N.",
        OMEGA_TOLERANCE * 100.0,
        GAIN_TOLERANCE * 100.0
    )?;
    let mut rec = record("converters");
    let t0 = Instant::now();
    let result = run_steps(client, &mut rec);
    let vented = client.command(RequestBody::Disarm);
    rec.seconds = t0.elapsed().as_secs_f64();
    print_bounds(out, &rec)?;
    state.steps.push(rec);
    let samples = result?;
    vented?;
    let model_force = model_force(&samples);
    let mut findings = Vec::new();
    let mut rows = Vec::new();
    for c in 0..4 {
        let before = if c == 0 { 1 } else { 2 * c + 1 };
        let idx: Vec<usize> = (0..samples.len())
            .filter(|&i| samples[i].phase == 2 * c + 2 || samples[i].phase == 2 * c + 3)
            .collect();
        // along the model's force change over the step
        let m0 = phase_mean_of(&samples, &model_force, before);
        let m1 = phase_mean_of(&samples, &model_force, 2 * c + 2);
        let d = [m1[0] - m0[0], m1[1] - m0[1]];
        let norm = d[0].hypot(d[1]).max(1e-9);
        let along = |f: [f64; 2]| (f[0] * d[0] + f[1] * d[1]) / norm;
        let y0 = along(phase_mean(&samples, before, &force));
        let u0 = phase_mean(&samples, before, &|t| {
            [f64::from(t.pressure_cmd_bar[c]), 0.0]
        })[0];
        let t: Vec<f64> = idx
            .iter()
            .map(|&i| samples[i].t.time_us.wrapping_sub(samples[idx[0]].t.time_us) as f64 * 1e-6)
            .collect();
        let u: Vec<f64> = idx
            .iter()
            .map(|&i| f64::from(samples[i].t.pressure_cmd_bar[c]) - u0)
            .collect();
        let y: Vec<f64> = idx
            .iter()
            .map(|&i| along(force(&samples[i].t)) - y0)
            .collect();
        let ym0 = along(m0);
        let ym: Vec<f64> = idx.iter().map(|&i| along(model_force[i]) - ym0).collect();
        let (rig, model) = (fit_step(&t, &u, &y), fit_step(&t, &u, &ym));
        writeln!(
            out,
            "  converter {}: {}; model {}",
            c + 1,
            describe(rig),
            describe(model)
        )?;
        let (r, f) = judge(c, rig, model);
        rows.extend(r);
        findings.extend(f);
    }
    if let Some(r) = state.steps.last_mut() {
        r.checks = rows;
    }
    conclude(state, "converters", findings, out)
}

fn describe(fit: Option<StepFit>) -> String {
    fit.map_or("no response to fit".into(), |f| {
        format!(
            "ωn {:.1} rad/s, ζ {:.2}, dead time {:.3} s, gain {:+.2} N/bar",
            f.omega_n_rad_s, f.zeta, f.dead_time_s, f.gain
        )
    })
}

/// Phases: 0 force mode at zero force, 1 its pressures held, then per channel c the step
/// (2c + 2) and the return (2c + 3).
fn run_steps(client: &Client, rec: &mut super::StepRecord) -> anyhow::Result<Vec<Sample>> {
    let m = RobotModel::<f64>::thesis();
    let k = step_test_stiffness(&m, [0.0, 0.0]);
    client.command(RequestBody::SetTelemetry { divider: 1 })?;
    // the pressures mode follows the force mode within one arming
    client.set_service_mode(true)?;
    client.command(RequestBody::Arm)?;
    client.start_telemetry();
    let mut samples = Vec::new();
    let zero_force = Mode::Force {
        force_n: [0.0; 2],
        stiffness_nm_per_rad: [k[0] as f32, k[1] as f32],
        feed_forward: false,
    };
    client.command(RequestBody::SetMode(zero_force.into()))?;
    collect(client, ENTRY_S, 0, &mut samples, rec)?;
    let base = samples
        .last()
        .map(|s| s.t.pressure_cmd_bar)
        .ok_or_else(|| anyhow::anyhow!("no telemetry in the force mode"))?;
    let set = |pressure_bar: [f32; 4]| {
        client.command(RequestBody::SetMode(
            Mode::Pressures { pressure_bar }.into(),
        ))
    };
    set(base)?;
    collect(client, 0.2, 1, &mut samples, rec)?;
    for c in 0..4 {
        let mut p = base;
        p[c] = (p[c] + STEP_BAR).min(4.5);
        set(p)?;
        collect(client, UP_S, 2 * c + 2, &mut samples, rec)?;
        set(base)?;
        collect(client, DOWN_S, 2 * c + 3, &mut samples, rec)?;
    }
    Ok(samples)
}

/// The model's force at the blocked handle for the loop currents the device reported.
fn model_force(samples: &[Sample]) -> Vec<[f64; 2]> {
    let mut twin = Twin::new(TwinConfig::thesis());
    let mut prev = samples.first().map_or(0, |s| s.t.time_us);
    samples
        .iter()
        .map(|s| {
            let dt = (s.t.time_us.wrapping_sub(prev) as f64 * 1e-6).max(1e-6);
            prev = s.t.time_us;
            twin.step(dt, s.t.current_ma.map(f64::from), &HandleCondition::Blocked)
                .force_user_n
        })
        .collect()
}

/// The mean of `values` over the last 0.2 s of phase `phase`.
fn phase_mean_of(samples: &[Sample], values: &[[f64; 2]], phase: usize) -> [f64; 2] {
    let idx: Vec<usize> = (0..samples.len())
        .filter(|&i| samples[i].phase == phase)
        .collect();
    let tail = &idx[idx.len().saturating_sub(200)..];
    let n = tail.len().max(1) as f64;
    let s = tail
        .iter()
        .fold([0.0; 2], |a, &i| [a[0] + values[i][0], a[1] + values[i][1]]);
    [s[0] / n, s[1] / n]
}

#[cfg(test)]
mod tests {
    use super::{fit_step, judge, StepFit, TABLE_OMEGA_N_RAD_S, TABLE_ZETA};
    use pam_ident::step::{simulate, StepParams};

    /// A 0.5 bar step for 0.5 s and back over 0.4 s at 1 kHz, through Table 5.2's second
    /// order with gain `g`, `omega` and a dead time of `td` s, with a little noise.
    fn response(g: f64, omega: f64, td: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..900).map(|i| i as f64 * 1e-3).collect();
        let u: Vec<f64> = t.iter().map(|&t| if t < 0.5 { 0.5 } else { 0.0 }).collect();
        let ud: Vec<f64> = t
            .iter()
            .map(|&t| if t >= td && t < 0.5 + td { 0.5 } else { 0.0 })
            .collect();
        let mut y = vec![0.0; t.len()];
        simulate(
            &StepParams::base(g, TABLE_ZETA, omega),
            &t,
            &ud,
            0.0,
            &mut y,
        );
        for (i, v) in y.iter_mut().enumerate() {
            *v += 0.02 * ((i * 7919) % 13) as f64 / 13.0 - 0.01;
        }
        (t, u, y)
    }

    #[test]
    fn the_fit_recovers_table_5_2_and_a_dead_time() {
        let (t, u, y) = response(5.0, TABLE_OMEGA_N_RAD_S, 0.02);
        let f = fit_step(&t, &u, &y).unwrap();
        assert!(
            (f.omega_n_rad_s / TABLE_OMEGA_N_RAD_S - 1.0).abs() < 0.05,
            "{f:?}"
        );
        assert!((f.zeta - TABLE_ZETA).abs() < 0.04, "{f:?}");
        assert!((f.gain - 5.0).abs() < 0.1, "{f:?}");
        assert!((f.dead_time_s - 0.02).abs() < 0.005, "{f:?}");
        let (_, finding) = judge(0, Some(f), Some(f));
        assert!(finding.is_none(), "{finding:?}");
    }

    #[test]
    fn a_slow_or_a_dead_converter_is_named_with_its_channel() {
        let model = StepFit {
            gain: 5.0,
            zeta: TABLE_ZETA,
            omega_n_rad_s: TABLE_OMEGA_N_RAD_S,
            dead_time_s: 0.0,
        };
        let (t, u, y) = response(5.0, 12.0, 0.0);
        let (_, slow) = judge(1, fit_step(&t, &u, &y), Some(model));
        let slow = slow.unwrap();
        assert_eq!(slow.fault, "converter_slow");
        assert!(slow.advice.contains("converter 2"), "{}", slow.advice);
        let (_, late) = judge(
            2,
            fit_step(
                &response(5.0, 23.04, 0.12).0,
                &u,
                &response(5.0, 23.04, 0.12).2,
            ),
            Some(model),
        );
        assert_eq!(late.unwrap().fault, "converter_slow");
        // a converter behind a 0.08 s lag: overdamped
        let mut lagged = 0.0;
        let ul: Vec<f64> = u
            .iter()
            .map(|&x| {
                lagged += (1.0 - (-1e-3f64 / 0.08).exp()) * (x - lagged);
                lagged
            })
            .collect();
        let mut y = vec![0.0; t.len()];
        simulate(
            &StepParams::base(5.0, TABLE_ZETA, TABLE_OMEGA_N_RAD_S),
            &t,
            &ul,
            0.0,
            &mut y,
        );
        let (_, lag) = judge(0, fit_step(&t, &u, &y), Some(model));
        assert_eq!(lag.unwrap().fault, "converter_slow");
        let (t, u, y) = response(0.2, TABLE_OMEGA_N_RAD_S, 0.0);
        let (_, dead) = judge(3, fit_step(&t, &u, &y), Some(model));
        assert_eq!(dead.unwrap().fault, "converter_dead");
    }
}
