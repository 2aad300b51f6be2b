//! The force-step table: the §5.2 force steps at the nine poses on the twin, measured
//! from the logs (`pam_twin::step_metrics`).
//!
//! ```sh
//! cargo run --release -p pam-twin --example force_step_table -- [--closed-loop] \
//!     [--feed-forward] [--identified-rig] [--gain-scale S] [--with EFFECT]... [--per-pose]
//!     [--per-step] [--period SECONDS] [--within N] [--seed N]
//! ```
//! Prints one markdown row: worst / mean 5 % settling, worst overshoot, mean |gain − 1|,
//! gain range, the worst steady error on the axis that did not step, the steps the controller
//! declared out of reach (its worst overshoot there in newtons; those steps are left out of
//! the overshoot column, `pam_twin::step_metrics`), and how many poses faulted. `--within N` keeps only the steps between levels
//! of at most N newtons (e.g. 19: leave out the ±27.3 N levels the identified rig's weaker
//! muscles cannot reach at every pose). `--seed N` changes the twin's noise realisation
//! (default 0): check a result on a few.

use pam_twin::simulate::{run_trial, Experiment, TrialSpec};
use pam_twin::step_metrics::{force_steps, summarize, StepFigures};

fn main() {
    let mut spec = TrialSpec::new(Experiment::ForceStep);
    let mut per_pose = false;
    let mut per_step = false;
    let mut within_n = f64::INFINITY;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--closed-loop" => spec.closed_loop = true,
            "--feed-forward" => spec.feed_forward = true,
            "--identified-rig" => spec.identified_rig = true,
            "--per-pose" => per_pose = true,
            "--per-step" => per_step = true,
            "--gain-scale" => {
                spec.gain_scale = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--gain-scale S")
            }
            "--with" => spec.effects.push(args.next().expect("--with EFFECT")),
            "--period" => {
                spec.period_s = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--period SECONDS")
            }
            "--seed" => spec.seed = args.next().and_then(|v| v.parse().ok()).expect("--seed N"),
            "--within" => {
                within_n = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--within NEWTONS")
            }
            other => panic!("unknown argument {other}"),
        }
    }
    let mut all: Vec<StepFigures> = Vec::new();
    let mut faulted = Vec::new();
    for pose in 0..9 {
        spec.pose = pose;
        match run_trial(&spec) {
            Ok(log) => {
                let steps: Vec<StepFigures> = force_steps(&log)
                    .expect("force-step log")
                    .into_iter()
                    .filter(|s| s.from_n.abs() <= within_n && s.to_n.abs() <= within_n)
                    .collect();
                if per_step {
                    for s in &steps {
                        println!(
                            "pose {pose} axis {} {:6.1} → {:6.1} N: settle {:.3} s, overshoot {:.1} % ({:.2} N), gain {:.3}, cross {:.2} N{}",
                            s.axis, s.from_n, s.to_n, s.settling_s, s.overshoot_pct, s.overshoot_n,
                            s.gain, s.cross_error_n, if s.out_of_reach { ", out of reach" } else { "" }
                        );
                    }
                }
                if per_pose {
                    let s = summarize(&steps);
                    println!(
                        "pose {pose}: settle worst {:.3} s mean {:.3} s, overshoot {:.1} %, |g−1| {:.3}, gain {:.3}–{:.3}",
                        s.settling_worst_s, s.settling_mean_s, s.overshoot_worst_pct,
                        s.gain_error_mean, s.gain_min, s.gain_max
                    );
                }
                all.extend(steps);
            }
            Err(e) => faulted.push(format!("pose {pose}: {e}")),
        }
    }
    let s = summarize(&all);
    let label = format!(
        "{}{}{}{}{}",
        if spec.closed_loop {
            "closed loop"
        } else {
            "open loop"
        },
        if spec.feed_forward {
            " + gain plane"
        } else {
            ""
        },
        if spec.identified_rig {
            ", identified rig"
        } else {
            ""
        },
        if spec.effects.is_empty() {
            String::new()
        } else {
            format!(", {}", spec.effects.join(" "))
        },
        if within_n.is_finite() {
            format!(", steps within ±{within_n} N")
        } else {
            String::new()
        },
    );
    println!(
        "| {label} | {:.3} | {:.3} | {:.1} | {:.3} | {:.3}–{:.3} | {:.2} | {} ({:.2} N) | {} |",
        s.settling_worst_s,
        s.settling_mean_s,
        s.overshoot_worst_pct,
        s.gain_error_mean,
        s.gain_min,
        s.gain_max,
        s.cross_error_worst_n,
        s.out_of_reach_steps,
        s.out_of_reach_overshoot_worst_n,
        faulted.len()
    );
    for f in faulted {
        eprintln!("{f}");
    }
}
