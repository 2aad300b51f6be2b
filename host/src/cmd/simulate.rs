//! `pamctl simulate`: one thesis experiment on the digital twin, written as a log (format v1),
//! with hidden effects if asked — the logs the model loop (`pamctl model diagnose`) is tried
//! on. The trial itself is `pam_twin::simulate::run_trial`.

use anyhow::Context;
use clap::Args;
use pam_twin::experiments::StiffnessLevel;
use pam_twin::impedance_trial::VirtualImpedance;
use pam_twin::simulate::{run_trial, Experiment, TrialSpec};
use std::io::Write;
use std::path::PathBuf;

#[derive(Args, Debug)]
#[command(after_help = "Examples:
  pamctl simulate --experiment dynamic --point 1 --with carrier_ball_friction:coulomb_n=3 --out trial.csv
  pamctl simulate --experiment force_step --pose 4 --period 0.05 --seed 7 --out step.csv
  pamctl simulate --experiment force_step --pose 4 --closed-loop --out step_cl.csv
  pamctl simulate --list-effects")]
pub struct SimulateArgs {
    /// The experiment: dynamic (§4.2, operator path), static (§4.2, nine holds),
    /// force_step (§5.2, blocked handle) or impedance (impedance mode, operator path).
    #[arg(long, value_name = "EXPERIMENT", value_parser = parse_experiment,
          required_unless_present = "list_effects")]
    pub experiment: Option<Experiment>,
    /// Table 4.1 point, 1–5 (dynamic, static).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub point: usize,
    /// Index of the §5.2 pose, 0–8 (force_step).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub pose: usize,
    /// Joint stiffness of the trial: low (K_min) or high (dynamic, static).
    #[arg(long, default_value = "low", value_name = "low|high", value_parser = parse_stiffness)]
    pub stiffness: StiffnessLevel,
    /// Length of a dynamic trial, s.
    #[arg(long, default_value_t = 90.0, value_name = "SECONDS", value_parser = finite)]
    pub duration: f64,
    /// Loop and logging period, s (0.001–0.1; the thesis sampled at 0.05).
    #[arg(long, default_value_t = 0.001, value_name = "SECONDS", value_parser = finite)]
    pub period: f64,
    /// Seed of the twin's noise, effects and operator path: the same seed, the same log.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Load-cell noise, N (standard deviation per axis; default: the twin's 0.15).
    #[arg(long, value_name = "N", value_parser = finite)]
    pub noise: Option<f64>,
    /// A hidden effect, `id` or `id:param=value,...` (repeatable; `--list-effects`).
    #[arg(long = "with", value_name = "EFFECT")]
    pub with: Vec<String>,
    /// Gain-plane feed-forward in force mode (off: as the thesis measured its steps).
    #[arg(long)]
    pub feed_forward: bool,
    /// Force mode with the load cell in the loop (force_step; docs/closed-loop.md).
    #[arg(long)]
    pub closed_loop: bool,
    /// Multiplier of the closed loop's designed feedback gains (1 = the design; up to 20,
    /// to see the guard catch an unstable loop).
    #[arg(long, default_value_t = 1.0, value_name = "S", value_parser = finite)]
    pub gain_scale: f64,
    /// Impedance trial: virtual stiffness KX,KY, N/m (0: transparent).
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], value_name = "KX,KY")]
    pub virtual_k_n_per_m: Vec<f64>,
    /// Impedance trial: virtual damping BX,BY, N·s/m.
    #[arg(long, value_delimiter = ',', default_values_t = [5.0, 5.0], value_name = "BX,BY")]
    pub virtual_b_n_s_per_m: Vec<f64>,
    /// Impedance trial: virtual mass MX,MY, kg, 0–1 (the twin only: not rendered faithfully
    /// enough to be on the wire, docs/impedance.md).
    #[arg(long, value_delimiter = ',', default_values_t = [0.0, 0.0], value_name = "MX,MY")]
    pub virtual_m_kg: Vec<f64>,
    /// Simulate the rig as the thesis measured it (0.57 of the model's muscle force, Table 5.2,
    /// and a parallel joint stiffness, Fig. 4.3: docs/closed-loop.md) instead of its model.
    #[arg(long)]
    pub identified_rig: bool,
    /// The log to write (CSV, log format v1, docs/log-format.md).
    #[arg(long, value_name = "FILE", required_unless_present = "list_effects")]
    pub out: Option<PathBuf>,
    /// List the twin's effects and their parameters, then exit.
    #[arg(long)]
    pub list_effects: bool,
}

fn parse_experiment(s: &str) -> Result<Experiment, pam_twin::simulate::SimulateError> {
    s.parse()
}

fn parse_stiffness(s: &str) -> Result<StiffnessLevel, pam_twin::simulate::SimulateError> {
    pam_twin::simulate::parse_stiffness(s)
}

fn pair(name: &str, v: &[f64]) -> anyhow::Result<[f64; 2]> {
    match v {
        [a, b] if a.is_finite() && b.is_finite() => Ok([*a, *b]),
        _ => Err(anyhow::anyhow!("{name} takes two comma-separated numbers")),
    }
}

fn finite(s: &str) -> anyhow::Result<f64> {
    s.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| anyhow::anyhow!("`{s}` is not a number"))
}

pub fn run(args: SimulateArgs, out: &mut dyn Write) -> anyhow::Result<()> {
    if args.list_effects {
        for e in pam_twin::effects::catalog() {
            writeln!(out, "{}", pam_twin::effects::describe(e.as_ref()))?;
        }
        return Ok(());
    }
    let (Some(experiment), Some(path)) = (args.experiment, args.out) else {
        return Err(anyhow::anyhow!("--experiment and --out are required"));
    };
    let spec = TrialSpec {
        experiment,
        point: args.point,
        pose: args.pose,
        stiffness: args.stiffness,
        duration_s: args.duration,
        period_s: args.period,
        seed: args.seed,
        loadcell_noise_n: args.noise,
        effects: args.with,
        feed_forward: args.feed_forward,
        closed_loop: args.closed_loop,
        gain_scale: args.gain_scale,
        impedance: VirtualImpedance {
            stiffness_n_per_m: pair("--virtual-k-n-per-m", &args.virtual_k_n_per_m)?,
            damping_n_s_per_m: pair("--virtual-b-n-s-per-m", &args.virtual_b_n_s_per_m)?,
            mass_kg: pair("--virtual-m-kg", &args.virtual_m_kg)?,
        },
        identified_rig: args.identified_rig,
    };
    let log = run_trial(&spec)?;
    log.write_path(&path)
        .with_context(|| format!("{}", path.display()))?;
    Ok(writeln!(
        out,
        "wrote {} rows to {}",
        log.len(),
        path.display()
    )?)
}
