//! `pamctl commission`: the guided first bring-up of a rig, one step at a time, with the
//! patient away and the handle free.
//!
//! Each step says what it will do and what it expects, drives small pressures slowly, stops
//! and vents at any fault, at a bound crossed or at Ctrl-C, and says what it measured.
//! The state file makes the procedure resumable and refuses to go on after a failure.

mod analysis;
mod apply;
mod blocked;
mod converters;
mod loadcell;
mod report;

use crate::LinkArgs;
use analysis::{channel_map, encoder_zero, tare, ChannelResponse, Finding};
use anyhow::{bail, Context};
use clap::Args;
use pam_control::Mode;
use pam_link::Client;
use pam_protocol::{wire, RequestBody, Telemetry};
use pam_twin::{HandleCondition, Twin, TwinConfig};
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Pressure of every muscle during the steps, bar: just above the 2.3 bar that tensions the
/// cables at the neutral pose (§2.3), far below the
/// rig's working range.
const BASE_BAR: f32 = 2.5;
/// The single-channel step, bar.
const STEP_BAR: f32 = 0.3;
/// How long the baseline settles before and the step lasts, s.
const SETTLE_S: f64 = 1.0;
const STEP_S: f64 = 1.5;
/// Averaging window at the end of each phase, s.
const WINDOW_S: f64 = 0.2;
/// Bounds every sample of step 1 must stay within: joint speed, rad/s; handle force, N
/// (free handle).
const MAX_SPEED_RAD_S: f64 = 2.0;
const MAX_FORCE_N: f64 = 15.0;

/// What the handle is doing now, as the person at the rig says.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum HandleNow {
    /// Nothing touches the handle: step 1 (encoders, channel map).
    Free,
    /// The handle is blocked at the neutral pose (§5.2 set-up): the load cell, the converters,
    /// the closed force loop.
    Blocked,
}

#[derive(Args, Debug)]
pub struct CommissionArgs {
    /// The state file (resumable procedure; created when missing).
    #[arg(long, default_value = "commission-state.json", value_name = "FILE")]
    pub state: PathBuf,
    /// Write the commissioning report (Markdown) to FILE.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Also write the report as an HTML page with the steps' plots.
    #[arg(long, value_name = "FILE")]
    pub html: Option<PathBuf>,
    /// Write the fixes the configuration record can take (encoder sign, counts and zero, the
    /// I/P channel map, load-cell gain) to the device and persist them; the next run checks
    /// them.
    #[arg(long)]
    pub apply: bool,
    /// Start again from the first step even after a failure.
    #[arg(long)]
    pub restart: bool,
    /// What holds the handle now: step 1 runs with it free, the later steps with it blocked.
    #[arg(long, value_enum, default_value = "free")]
    pub handle: HandleNow,
}

/// The bounds of one step and the largest values the telemetry showed during it.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct StepRecord {
    pub name: String,
    pub speed_bound_rad_s: f64,
    pub force_bound_n: f64,
    pub max_speed_rad_s: f64,
    pub max_force_n: f64,
    pub seconds: f64,
    /// Telemetry at 50 Hz for the report's plots: t s, α1, α2 rad, Fx, Fy N, Fx ref, Fy ref N.
    pub trace: Vec<[f64; 7]>,
    /// Measured values and checks: (what, measured, expected, tolerance / margin).
    pub checks: Vec<[String; 4]>,
}

/// What the state file keeps between runs.
#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
struct CommissionState {
    /// The step that passed last (`channels`), if any.
    passed: Vec<String>,
    /// A failed step: the procedure refuses to go on until `--restart`.
    failed: Option<String>,
    responses: Vec<ChannelResponse>,
    tare_n: Option<[f64; 2]>,
    /// The joints' angles at equal pressures, rad: measured and the model's equilibrium.
    #[serde(default)]
    zero_rad: Option<[[f64; 2]; 2]>,
    /// The joint step 1 saw turn backwards for both its channels: its encoder or its
    /// muscles, which the blocked handle tells apart.
    reversed_joint: Option<usize>,
    steps: Vec<StepRecord>,
    /// Findings of the step that failed, for the report.
    findings: Vec<[String; 3]>,
    seconds: f64,
}

/// One recorded sample and the phase it belongs to.
struct Sample {
    t: Telemetry,
    phase: usize,
}

pub fn run(args: CommissionArgs, link: &LinkArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    let started = Instant::now();
    let mut state: CommissionState = match std::fs::read_to_string(&args.state) {
        Ok(text) if !args.restart => serde_json::from_str(&text)
            .with_context(|| format!("{}: not a commissioning state file", args.state.display()))?,
        _ => CommissionState::default(),
    };
    if let Some(step) = &state.failed {
        bail!(
            "the step `{step}` failed earlier ({}): fix what it named, then run `pamctl commission --restart`",
            args.state.display()
        );
    }
    let passed = |state: &CommissionState, s: &str| state.passed.iter().any(|p| p == s);
    let step1_done = passed(&state, "channels") || state.reversed_joint.is_some();
    let result = if !step1_done {
        if args.handle != HandleNow::Free {
            bail!("step 1 moves the arm: unblock the handle and run `pamctl commission --handle free`");
        }
        step_channels(&args, link, &mut state, out)
    } else if args.handle != HandleNow::Blocked {
        writeln!(out, "step 1 (encoders and channel map): done earlier")?;
        Ok(())
    } else {
        blocked::run_all(link, &mut state, out)
    };
    state.seconds += started.elapsed().as_secs_f64();
    let findings: Vec<Finding> = match &result {
        Err(StepError::Findings(f)) => f.clone(),
        _ => Vec::new(),
    };
    save(&args.state, &state)?;
    if let Some(path) = &args.report {
        report::markdown(path, &state)?;
    }
    if let Some(path) = &args.html {
        report::html(path, &state)?;
    }
    match result {
        Ok(()) => {}
        Err(StepError::Findings(_)) => {
            for f in &findings {
                writeln!(out, "FAULT {}: {}\n  fix: {}", f.fault, f.detail, f.advice)?;
            }
            if args.apply {
                let client = super::connect(link)?;
                let done = apply::apply(&client, &findings)?;
                writeln!(
                    out,
                    "wrote to the configuration record and persisted: {}; run `pamctl commission` again to check",
                    done.join(", ")
                )?;
                // the fixed step runs again; an encoder's fix re-runs step 1 too
                let step1 = findings.iter().any(|f| {
                    matches!(
                        f.fix,
                        Some(
                            analysis::ConfigFix::EncoderSign(_)
                                | analysis::ConfigFix::EncoderScale(..)
                                | analysis::ConfigFix::EncoderZero(..)
                                | analysis::ConfigFix::ChannelMap(_)
                        )
                    )
                });
                state.failed = None;
                state.findings.clear();
                if step1 {
                    state.passed.clear();
                    state.reversed_joint = None;
                }
                save(&args.state, &state)?;
            }
            bail!(
                "commissioning stopped at the step `{}` with {} finding(s); vented",
                state.failed.as_deref().unwrap_or("?"),
                findings.len()
            );
        }
        Err(StepError::Other(e)) => return Err(e),
    }
    let all = ["channels", "loadcell", "converters", "closed_loop"];
    if all.iter().all(|s| passed(&state, s)) {
        writeln!(
            out,
            "commissioning done: every step passed, {:.1} s on the rig in all",
            state.seconds
        )?;
    } else if args.handle == HandleNow::Free {
        writeln!(
            out,
            "next: block the handle at the neutral pose (§5.2 set-up), then run `pamctl commission --handle blocked`"
        )?;
    }
    Ok(())
}

/// Why a step stopped: what it found wrong, or anything else (link, fault, bound, Ctrl-C).
pub enum StepError {
    Findings(Vec<Finding>),
    Other(anyhow::Error),
}

macro_rules! step_error_from {
    ($($t:ty),*) => {$(
        impl From<$t> for StepError {
            fn from(e: $t) -> Self {
                StepError::Other(e.into())
            }
        }
    )*};
}
step_error_from!(
    anyhow::Error,
    std::io::Error,
    pam_link::LinkError,
    std::array::TryFromSliceError
);

/// Records the findings of step `name` in `state`: passed when there is none.
fn conclude(
    state: &mut CommissionState,
    name: &str,
    findings: Vec<Finding>,
    out: &mut dyn Write,
) -> Result<(), StepError> {
    if findings.is_empty() {
        state.passed.push(name.into());
        writeln!(out, "step `{name}` passed: vented")?;
        return Ok(());
    }
    state.failed = Some(name.into());
    state.findings = findings
        .iter()
        .map(|f| [f.fault.to_string(), f.detail.clone(), f.advice.clone()])
        .collect();
    Err(StepError::Findings(findings))
}

/// Prints the largest speed and force of the step that just ran against its bounds.
fn print_bounds(out: &mut dyn Write, r: &StepRecord) -> std::io::Result<()> {
    writeln!(
        out,
        "  {}: largest joint speed {:.3} rad/s (bound {}), largest handle force {:.2} N (bound {}), {:.1} s",
        r.name, r.max_speed_rad_s, r.speed_bound_rad_s, r.max_force_n, r.force_bound_n, r.seconds
    )
}

fn step_channels(
    _args: &CommissionArgs,
    link: &LinkArgs,
    state: &mut CommissionState,
    out: &mut dyn Write,
) -> Result<(), StepError> {
    let client = super::connect(link)?;
    writeln!(
        out,
        "step 1: encoders and I/P channel map. With the arm resting at its homing mark by the neutral pose (the \
         encoders' zero, homed once per power-up), the handle free and nobody near the arm, every muscle goes to {BASE_BAR} bar, then each channel in turn to {} bar for {STEP_S} s; expected: \
         the joint the model names turns the way it says, and at equal pressures each joint reads the model's equilibrium. Bounds: {MAX_SPEED_RAD_S} rad/s, {MAX_FORCE_N} N.",
        BASE_BAR + STEP_BAR
    )?;
    let mut record = StepRecord {
        name: "channels".into(),
        speed_bound_rad_s: MAX_SPEED_RAD_S,
        force_bound_n: MAX_FORCE_N,
        ..StepRecord::default()
    };
    let t0 = Instant::now();
    let result = channel_steps(&client, state, &mut record);
    // vented whatever happened
    let vented = client.command(RequestBody::Disarm);
    record.seconds = t0.elapsed().as_secs_f64();
    state.steps.push(record.clone());
    print_bounds(out, &record)?;
    result?;
    vented?;
    let mut findings = channel_map(state.responses.as_slice().try_into()?);
    if let Some([measured, model]) = state.zero_rad {
        writeln!(
            out,
            "  at equal pressures the joints read ({:+.2}, {:+.2})°, the model's equilibrium ({:+.2}, {:+.2})°",
            measured[0].to_degrees(),
            measured[1].to_degrees(),
            model[0].to_degrees(),
            model[1].to_degrees()
        )?;
        if let Some(r) = state.steps.last_mut() {
            r.checks = (0..2)
                .map(|j| {
                    blocked::check(
                        &format!("joint {} at equal pressures − model, rad", j + 1),
                        measured[j] - model[j],
                        0.0,
                        analysis::ZERO_TOLERANCE_RAD,
                    )
                })
                .collect();
        }
        findings.extend(encoder_zero(measured, model));
    }
    findings.extend(state.tare_n.and_then(tare));
    for r in &state.responses {
        writeln!(
            out,
            "  channel {}: joints moved ({:+.4}, {:+.4}) rad, model ({:+.4}, {:+.4}) rad",
            r.channel + 1,
            r.measured_rad[0],
            r.measured_rad[1],
            r.model_rad[0],
            r.model_rad[1]
        )?;
    }
    if let Some(f) = state.tare_n {
        writeln!(
            out,
            "  at rest the load cell reads ({:+.2}, {:+.2}) N",
            f[0], f[1]
        )?;
    }
    // a joint turned backwards, and nothing else: the blocked handle tells which
    let reversed: Vec<usize> = findings
        .iter()
        .filter_map(|f| match f.fault {
            "joint1_reversed" => Some(0),
            "joint2_reversed" => Some(1),
            _ => None,
        })
        .collect();
    if reversed.len() == 1 && findings.len() == 1 {
        let f = &findings[0];
        writeln!(out, "  {}: {}\n  {}", f.fault, f.detail, f.advice)?;
        state.reversed_joint = Some(reversed[0]);
        writeln!(
            out,
            "step 1 ends open: the load-cell step with the handle blocked names the fault"
        )?;
        return Ok(());
    }
    conclude(state, "channels", findings, out)
}

fn save(path: &std::path::Path, state: &CommissionState) -> anyhow::Result<()> {
    std::fs::write(path, serde_json::to_string_pretty(state)?)
        .with_context(|| format!("cannot write the state file {}", path.display()))
}

/// Arms in pressure mode (the one entry into it) at the base pressures, steps each channel,
/// and fills `state` with the responses, the tare and the largest speed and force.
fn channel_steps(
    client: &Client,
    state: &mut CommissionState,
    record: &mut StepRecord,
) -> anyhow::Result<()> {
    client.command(RequestBody::SetTelemetry { divider: 1 })?;
    // the encoders' zero: the arm rests at its homing mark, vented and disarmed; homed once
    // per power-up (the encoders count on from there, and a re-home would move the zero
    // the configuration's zero_rad corrects)
    let homed = matches!(
        client.request(RequestBody::GetStatus)?,
        pam_protocol::ReplyData::Status(s) if s.homed
    );
    if !homed {
        client.command(RequestBody::Home)?;
    }
    client.command(RequestBody::Arm)?;
    let mut samples = Vec::new();
    // from the vent up to the base pressure slowly, in 20 steps over 1 s
    enter_pressure_service(client, [0.0; 4])?;
    // samples from before the arm are not the step's
    client.start_telemetry();
    for k in 1..=20 {
        set_pressures(client, [BASE_BAR * k as f32 / 20.0; 4])?;
        collect(client, 0.05, 0, &mut samples, record)?;
    }
    collect(client, SETTLE_S, 0, &mut samples, record)?;
    for c in 0..4 {
        let mut p = [BASE_BAR; 4];
        p[c] += STEP_BAR;
        set_pressures(client, p)?;
        collect(client, STEP_S, 2 * c + 1, &mut samples, record)?;
        set_pressures(client, [BASE_BAR; 4])?;
        collect(client, SETTLE_S, 2 * c + 2, &mut samples, record)?;
    }
    let model = model_alpha(&samples);
    let mean = |phase: usize, of: &dyn Fn(usize) -> [f64; 2]| -> [f64; 2] {
        let idx: Vec<usize> = (0..samples.len())
            .filter(|&i| samples[i].phase == phase)
            .collect();
        let tail = &idx[idx.len().saturating_sub((WINDOW_S * 1000.0) as usize)..];
        let n = tail.len().max(1) as f64;
        let s = tail.iter().fold([0.0; 2], |a, &i| {
            let v = of(i);
            [a[0] + v[0], a[1] + v[1]]
        });
        [s[0] / n, s[1] / n]
    };
    let measured = |i: usize| samples[i].t.alpha_rad.map(f64::from);
    let modelled = |i: usize| model[i];
    state.tare_n = Some(mean(0, &|i| samples[i].t.force_user_n.map(f64::from)));

    state.responses = (0..4)
        .map(|c| {
            let d = |f: &dyn Fn(usize) -> [f64; 2]| {
                let (a, b) = (mean(2 * c, f), mean(2 * c + 1, f));
                [b[0] - a[0], b[1] - a[1]]
            };
            ChannelResponse {
                channel: c,
                measured_rad: d(&measured),
                model_rad: d(&modelled),
            }
        })
        .collect();
    // the equal pressures' pose, per joint, approached once from each side: the mean of
    // the returns after the channels that turned it most either way cancels what the
    // friction holds back
    let at_rest =
        |of: &dyn Fn(usize) -> [f64; 2], moved: &dyn Fn(&ChannelResponse) -> f64, j: usize| {
            let by = |a: &&ChannelResponse, b: &&ChannelResponse| moved(a).total_cmp(&moved(b));
            let up = state.responses.iter().max_by(by).map_or(0, |r| r.channel);
            let down = state.responses.iter().min_by(by).map_or(0, |r| r.channel);
            (mean(2 * up + 2, of)[j] + mean(2 * down + 2, of)[j]) / 2.0
        };
    let zero = |of: &dyn Fn(usize) -> [f64; 2], pick: fn(&ChannelResponse) -> [f64; 2]| {
        [0, 1].map(|j| at_rest(of, &|r| pick(r)[j], j))
    };
    state.zero_rad = Some([
        zero(&measured, |r| r.measured_rad),
        zero(&modelled, |r| r.model_rad),
    ]);
    Ok(())
}

/// The one entry into pressure mode. Pressure mode bypasses the joint and force loops, so
/// the device keeps it behind its service interlock, which this turns on first (the device
/// takes it armed in idle, and clears it again at the disarm that ends every step).
fn enter_pressure_service(client: &Client, pressure_bar: [f32; 4]) -> anyhow::Result<()> {
    client
        .set_service_mode(true)
        .context("turning on the service interlock for the pressures mode")?;
    set_pressures(client, pressure_bar)
}

fn set_pressures(client: &Client, pressure_bar: [f32; 4]) -> anyhow::Result<()> {
    Ok(client.command(RequestBody::SetMode(
        Mode::Pressures { pressure_bar }.into(),
    ))?)
}

/// Collects `seconds` of telemetry into `samples` (keeping the link alive), and stops at a
/// fault, a disarm, a bound crossed or Ctrl-C.
fn collect(
    client: &Client,
    seconds: f64,
    phase: usize,
    samples: &mut Vec<Sample>,
    state: &mut StepRecord,
) -> anyhow::Result<()> {
    let stop = super::interrupted();
    let start = Instant::now();
    let mut last_beat = Instant::now();
    while start.elapsed().as_secs_f64() < seconds {
        if stop.load(Ordering::SeqCst) {
            bail!("interrupted (Ctrl-C): vented");
        }
        if last_beat.elapsed() > Duration::from_millis(20) {
            client.heartbeat()?;
            last_beat = Instant::now();
        }
        let Some(t) = client.next_telemetry(Duration::from_millis(50))? else {
            continue;
        };
        if t.faults != 0 || t.state != wire::State::Armed {
            bail!(
                "the device stopped the step (state {:?}, faults {:#06x}): vented",
                t.state,
                t.faults
            );
        }
        // over 50 ms: one encoder count in one period alone reads as 1.6 rad/s
        if let Some(prev) = samples.len().checked_sub(50).map(|i| samples[i].t) {
            let dt = (t.time_us.wrapping_sub(prev.time_us) as f64 * 1e-6).max(1e-4);
            for j in 0..2 {
                let v = f64::from(t.alpha_rad[j] - prev.alpha_rad[j]).abs() / dt;
                state.max_speed_rad_s = state.max_speed_rad_s.max(v);
            }
        }
        let f = f64::from(t.force_user_n[0]).hypot(f64::from(t.force_user_n[1]));
        state.max_force_n = state.max_force_n.max(f);
        if state.max_speed_rad_s > state.speed_bound_rad_s
            || state.max_force_n > state.force_bound_n
        {
            bail!(
                "a bound was crossed (speed {:.2} rad/s, force {:.1} N): vented",
                state.max_speed_rad_s,
                state.max_force_n
            );
        }
        if t.seq % 20 == 0 {
            // 0 N outside the force modes (a JSON number: the state file keeps the trace)
            let f = t.force_ref_n.unwrap_or([0.0; 2]);
            state.trace.push([
                start_s(samples, &t),
                f64::from(t.alpha_rad[0]),
                f64::from(t.alpha_rad[1]),
                f64::from(t.force_user_n[0]),
                f64::from(t.force_user_n[1]),
                f64::from(f[0]),
                f64::from(f[1]),
            ]);
        }
        samples.push(Sample { t, phase });
    }
    Ok(())
}

/// The model's joint angles for the same loop currents: the twin of the thesis's rig,
/// free handle, driven with the currents the device reported.
fn model_alpha(samples: &[Sample]) -> Vec<[f64; 2]> {
    let mut twin = Twin::new(TwinConfig::thesis());
    let mut prev = samples.first().map(|s| s.t.time_us).unwrap_or(0);
    samples
        .iter()
        .map(|s| {
            let dt = (s.t.time_us.wrapping_sub(prev) as f64 * 1e-6).max(1e-6);
            prev = s.t.time_us;
            twin.step(dt, s.t.current_ma.map(f64::from), &HandleCondition::Free);
            twin.state().alpha_rad
        })
        .collect()
}

/// Seconds since the step's first sample.
fn start_s(samples: &[Sample], t: &Telemetry) -> f64 {
    let t0 = samples.first().map_or(t.time_us, |s| s.t.time_us);
    t.time_us.wrapping_sub(t0) as f64 * 1e-6
}

/// The mean of `of` over the last `WINDOW_S` of phase `phase`.
fn phase_mean(samples: &[Sample], phase: usize, of: &dyn Fn(&Telemetry) -> [f64; 2]) -> [f64; 2] {
    let idx: Vec<&Sample> = samples.iter().filter(|s| s.phase == phase).collect();
    let tail = &idx[idx.len().saturating_sub((WINDOW_S * 1000.0) as usize)..];
    let n = tail.len().max(1) as f64;
    let s = tail.iter().fold([0.0; 2], |a, s| {
        let v = of(&s.t);
        [a[0] + v[0], a[1] + v[1]]
    });
    [s[0] / n, s[1] / n]
}
