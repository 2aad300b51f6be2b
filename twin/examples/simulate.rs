//! Runs one thesis experiment on the twin and writes the log (format v1).
//!
//! ```text
//! cargo run -p pam-twin --release --example simulate -- --experiment dynamic --point 1 \
//!     --stiffness low --with nonlinear_stiffness:cubic_n=20 --seed 7 --period 0.05 --out x.csv
//! cargo run -p pam-twin --example simulate -- --list-effects
//! ```
//! Experiments: `dynamic` (`--point 1..5 --stiffness low|high --duration 90`), `static`
//! (`--point`, `--stiffness`), `force_step` (`--pose 0..8` index into the nine §5.2 poses).

use std::process::ExitCode;

use pam_twin::effects::{self, EffectSet};
use pam_twin::experiments::{
    dynamic_trial, force_step_test, static_trial, ExperimentConfig, StiffnessLevel, STEP_POSES_DEG,
};
use pam_twin::TwinConfig;

fn usage() -> &'static str {
    "usage: simulate --experiment dynamic|static|force_step [--point N] [--pose N] [--stiffness low|high] \
     [--duration S] [--period S] [--seed N] [--noise N] [--with EFFECT_SPEC]... [--feed-forward] [--identified-rig] --out FILE\n       simulate --list-effects"
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut experiment = None;
    let (mut point, mut pose, mut level) = (1usize, 0usize, StiffnessLevel::Low);
    let (mut duration, mut period, mut seed) = (90.0f64, 0.001f64, 0u64);
    let mut specs: Vec<String> = Vec::new();
    let mut out = None;
    let mut feed_forward = false;
    let mut identified_rig = false;
    let mut noise_n: Option<f64> = None;
    let mut i = 0;
    let value = |i: &mut usize| -> Result<String, String> {
        *i += 1;
        args.get(*i)
            .cloned()
            .ok_or_else(|| format!("{} needs a value\n{}", args[*i - 1], usage()))
    };
    let num = |s: String, what: &str| -> Result<f64, String> {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{what}: `{s}` is not a number"))
    };
    while i < args.len() {
        match args[i].as_str() {
            "--list-effects" => {
                for e in effects::catalog() {
                    println!("{}", effects::describe(e.as_ref()));
                }
                return Ok(());
            }
            "--experiment" => experiment = Some(value(&mut i)?),
            "--point" => point = num(value(&mut i)?, "--point")? as usize,
            "--pose" => pose = num(value(&mut i)?, "--pose")? as usize,
            "--stiffness" => {
                level = match value(&mut i)?.as_str() {
                    "low" => StiffnessLevel::Low,
                    "high" => StiffnessLevel::High,
                    s => return Err(format!("--stiffness `{s}`: expected low or high")),
                }
            }
            "--duration" => duration = num(value(&mut i)?, "--duration")?,
            "--period" => period = num(value(&mut i)?, "--period")?,
            "--seed" => seed = num(value(&mut i)?, "--seed")? as u64,
            "--noise" => noise_n = Some(num(value(&mut i)?, "--noise")?),
            "--with" => specs.push(value(&mut i)?),
            "--feed-forward" => feed_forward = true,
            "--identified-rig" => identified_rig = true,
            "--out" => out = Some(value(&mut i)?),
            "-h" | "--help" => {
                println!("{}", usage());
                return Ok(());
            }
            a => return Err(format!("unknown argument `{a}`\n{}", usage())),
        }
        i += 1;
    }
    let experiment = experiment.ok_or_else(|| format!("--experiment is required\n{}", usage()))?;
    let out = out.ok_or_else(|| format!("--out is required\n{}", usage()))?;
    let mut twin = if identified_rig {
        TwinConfig::identified_rig()
    } else {
        TwinConfig::thesis()
    };
    twin.seed = seed;
    if let Some(n) = noise_n {
        twin.sensors.loadcell_noise_n = [n; 2];
    }
    twin.effects = EffectSet::parse_list(&specs).map_err(|e| e.to_string())?;
    let mut cfg = ExperimentConfig::new(twin);
    cfg.period_s = period;
    cfg.feed_forward = feed_forward;
    let log = match experiment.as_str() {
        "dynamic" => dynamic_trial(&cfg, point, level, duration),
        "static" => static_trial(&cfg, point, level),
        "force_step" => {
            let p = *STEP_POSES_DEG
                .get(pose)
                .ok_or_else(|| format!("--pose {pose}: expected 0..8"))?;
            force_step_test(&cfg, p)
        }
        e => {
            return Err(format!(
                "unknown experiment `{e}` (dynamic, static, force_step)"
            ))
        }
    }
    .map_err(|e| e.to_string())?;
    log.write_path(&out).map_err(|e| format!("{out}: {e}"))?;
    eprintln!("wrote {} rows to {out}", log.len());
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("simulate: {e}");
            ExitCode::FAILURE
        }
    }
}
