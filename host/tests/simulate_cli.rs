//! `pamctl simulate` end to end: a twin trial with a hidden effect written as a log, the same
//! log for the same seed, and clear errors for bad values.
mod cli;

use cli::{pamctl, tmpdir};
use pam_twin::simulate::{run_trial, Experiment, TrialSpec};
use std::path::Path;

const EFFECT: &str = "carrier_ball_friction:coulomb_n=3";

fn simulate(out: &Path, seed: &str) -> String {
    let (code, stdout, err) = pamctl(&[
        "simulate",
        "--experiment",
        "dynamic",
        "--point",
        "4",
        "--stiffness",
        "high",
        "--duration",
        "2",
        "--period",
        "0.01",
        "--noise",
        "0.3",
        "--with",
        EFFECT,
        "--seed",
        seed,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    stdout
}

#[test]
fn a_seeded_trial_with_a_hidden_effect_is_a_log_and_is_reproducible() {
    let dir = tmpdir("simulate");
    let d = dir.path();
    let (a, b, c) = (d.join("a.csv"), d.join("b.csv"), d.join("c.csv"));
    let said = simulate(&a, "5");
    simulate(&b, "5");
    simulate(&c, "6");
    assert_eq!(said.trim(), format!("wrote 200 rows to {}", a.display()));

    let log = pam_log::read_path(&a).expect("a log-format-v1 file");
    assert_eq!(log.len(), 200);
    assert_eq!(log.meta("experiment"), Some("dynamic"));
    assert_eq!(log.meta("seed"), Some("5"));
    let effects = log.meta("effects").unwrap();
    assert!(
        effects.starts_with("carrier_ball_friction:coulomb_n=3,"),
        "{effects}"
    );
    assert!((log.sample_period_s().unwrap() - 0.01).abs() < 1e-9);
    for col in [
        "t_s",
        "alpha1_rad",
        "alpha2_rad",
        "fx_n",
        "fy_n",
        "i1_ma",
        "i4_ma",
    ] {
        let v = log.column(col).unwrap_or_else(|| panic!("no column {col}"));
        assert!(v.iter().all(|x| x.is_finite()), "{col}");
    }

    let text = |p: &Path| std::fs::read_to_string(p).unwrap();
    assert_eq!(text(&a), text(&b), "same seed, same log");
    assert_ne!(text(&a), text(&c), "another seed, another log");

    // the command is the library's trial with the flags' values
    let mut spec = TrialSpec::new(Experiment::Dynamic);
    spec.point = 4;
    spec.stiffness = pam_twin::experiments::StiffnessLevel::High;
    spec.duration_s = 2.0;
    spec.period_s = 0.01;
    spec.loadcell_noise_n = Some(0.3);
    spec.effects = vec![EFFECT.into()];
    spec.seed = 5;
    assert_eq!(text(&a), run_trial(&spec).unwrap().to_csv_string());
}

#[test]
fn bad_values_are_clear_errors() {
    let dir = tmpdir("simulate-bad");
    let out = dir.path().join("x.csv");
    let out = out.to_str().unwrap();
    // refused by the parser (exit 2), naming the flag and the value
    let (code, _, err) = pamctl(&["simulate", "--experiment", "sideways", "--out", out]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--experiment"), "{err}");
    assert!(
        err.contains(
            "unknown experiment `sideways` (expected dynamic, static, force_step, impedance)"
        ),
        "{err}"
    );
    let (code, _, err) = pamctl(&[
        "simulate",
        "--experiment",
        "dynamic",
        "--period",
        "fast",
        "--out",
        out,
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--period") && err.contains("`fast` is not a number"),
        "{err}"
    );
    let (code, _, err) = pamctl(&["simulate", "--experiment", "dynamic"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--out"), "{err}");
    // refused by the trial (exit 1)
    for (args, message) in [
        (
            &["--experiment", "force_step", "--pose", "9"][..],
            "pose 9: expected 0..8",
        ),
        (
            &["--experiment", "static", "--point", "6"][..],
            "point 6 is not one of the five Table 4.1 points",
        ),
        (
            &["--experiment", "dynamic", "--noise=-1"][..],
            "load-cell noise -1 N",
        ),
        (
            &["--experiment", "dynamic", "--with", "no_such_effect"][..],
            "no_such_effect",
        ),
    ] {
        let mut all = vec!["simulate"];
        all.extend_from_slice(args);
        all.extend(["--out", out]);
        let (code, _, err) = pamctl(&all);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: {err}");
    }
    assert!(!Path::new(out).exists(), "no log written on an error");
}

#[test]
fn help_and_effect_list() {
    let (code, out, _) = pamctl(&["simulate", "--help"]);
    assert_eq!(code, 0);
    for flag in [
        "--experiment",
        "--point",
        "--pose",
        "--stiffness",
        "--duration",
        "--period",
        "--seed",
        "--noise",
        "--with",
        "--feed-forward",
        "--closed-loop",
        "--gain-scale",
        "--identified-rig",
        "--out",
        "--list-effects",
    ] {
        assert!(out.contains(flag), "{flag} missing from:\n{out}");
    }
    let (code, out, _) = pamctl(&["simulate", "--list-effects"]);
    assert_eq!(code, 0);
    assert!(out.contains("carrier_ball_friction"), "{out}");
    assert!(out.contains("mains_hum"), "{out}");
}

#[test]
fn closed_loop_force_step_is_a_log_that_meets_the_step_goals() {
    let dir = tmpdir("simulate_cl");
    let d = dir.path();
    let out = d.join("step_cl.csv");
    let (code, _, err) = pamctl(&[
        "simulate",
        "--experiment",
        "force_step",
        "--pose",
        "4",
        "--closed-loop",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let log = pam_log::read_path(&out).expect("a log");
    assert_eq!(log.meta("closed_loop"), Some("true"));
    assert_eq!(log.meta("gain_scale"), Some("1"));
    let s = pam_twin::step_metrics::summarize(
        &pam_twin::step_metrics::force_steps(&log).expect("step figures"),
    );
    assert_eq!(s.steps, 24);
    assert!(
        s.overshoot_worst_pct <= 10.0 && s.gain_error_mean <= 0.02,
        "{s:?}"
    );
}

#[test]
fn impedance_trial_then_ident_dynamic_finds_the_commanded_k() {
    let dir = tmpdir("simulate_imp");
    let d = dir.path();
    let out = d.join("imp.csv");
    let path = out.to_str().unwrap();
    let (code, _, err) = pamctl(&[
        "simulate",
        "--experiment",
        "impedance",
        "--virtual-k-n-per-m",
        "300,300",
        "--duration",
        "10",
        "--out",
        path,
    ]);
    assert_eq!(code, 0, "{err}");
    let log = pam_log::read_path(&out).expect("a log");
    assert_eq!(log.meta("experiment"), Some("impedance"));
    assert_eq!(log.meta("virtual_k_n_per_m"), Some("300 300"));
    let (code, text, err) = pamctl(&["ident", "dynamic", path]);
    assert_eq!(code, 0, "{err}");
    // "  K = [[  302.728,     1.034], [    1.034,   307.745]]  ellipse: …"
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("K = [["))
        .unwrap_or_else(|| panic!("no K in {text}"));
    let nums: Vec<f64> = line
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .filter_map(|s| s.parse().ok())
        .collect();
    let (kxx, kyy) = (nums[0], nums[3]);
    assert!(
        (kxx - 300.0).abs() < 30.0 && (kyy - 300.0).abs() < 30.0,
        "{line}"
    );
}
